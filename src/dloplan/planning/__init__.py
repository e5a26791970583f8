"""The three-stage planner (thesis chapter 4): basic geometric, advanced geometric, physical.

``plan(cable, start, target, n_shapes)`` returns a :class:`Plan` holding the path of every
stage; ``tuning`` holds the stiffness families and the weights of thesis Tables 6.1/6.2.
"""

from .geometric import StageStatus, advanced_path, basic_path
from .physical import PHYSICAL_MODES, ShapeResult, minimize_shape, physical_stage, preprocess_target
from .pipeline import plan
from .result import STAGES, ForceStatistics, Plan
from .tuning import (
    FAMILIES,
    PHYSICAL_WEIGHTS,
    AdvancedWeights,
    BasicWeights,
    FamilyBoundaries,
    PhysicalWeights,
    PlannerWeights,
    planner_weights,
    stiffness_family,
)

__all__ = [
    "FAMILIES",
    "PHYSICAL_MODES",
    "PHYSICAL_WEIGHTS",
    "STAGES",
    "AdvancedWeights",
    "BasicWeights",
    "FamilyBoundaries",
    "ForceStatistics",
    "PhysicalWeights",
    "Plan",
    "PlannerWeights",
    "ShapeResult",
    "StageStatus",
    "advanced_path",
    "basic_path",
    "minimize_shape",
    "physical_stage",
    "plan",
    "planner_weights",
    "preprocess_target",
    "stiffness_family",
]
