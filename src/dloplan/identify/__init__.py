"""Young's modulus identification from a measured manipulation (thesis chapter 6.1, 6.2)."""

from .design import (
    DesignCheck,
    assess_manipulation,
    bending_manipulation,
    cantilever_manipulation,
    synthetic_experiment,
)
from .experiment import Experiment, Manipulation, PreparedShapes, prepare_shapes
from .fit import DEFAULT_BOUNDS, Identification, LocalMinimum, identify_youngs_modulus
from .simulate import (
    DynamicSettings,
    ManipulationRun,
    final_equilibrium,
    modulus_sensitivity,
    run_manipulation,
)

__all__ = [
    "DEFAULT_BOUNDS",
    "DesignCheck",
    "DynamicSettings",
    "Experiment",
    "Identification",
    "LocalMinimum",
    "Manipulation",
    "ManipulationRun",
    "PreparedShapes",
    "assess_manipulation",
    "bending_manipulation",
    "cantilever_manipulation",
    "final_equilibrium",
    "identify_youngs_modulus",
    "modulus_sensitivity",
    "prepare_shapes",
    "run_manipulation",
    "synthetic_experiment",
]
