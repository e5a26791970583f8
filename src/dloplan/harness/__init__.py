"""Wire-harness jobs (thesis 7.3): boards, two-phase planning, insertion and tensioning.

``run_harness(cable, start, board)`` runs a whole job; ``load_harness(path)`` reads a scenario
file with a ``harness:`` section; see ``docs/harness.md``.
"""

from .board import Board, Fixture, HarnessSpec, Peg, check_board, route_length
from .files import HarnessJob, HarnessScenario, is_harness, load_harness, run_harness_job
from .insertion import (
    Insertion,
    TensionState,
    insert_and_tension,
    section_cable,
    section_shape,
    tension_state,
)
from .job import (
    PHASES,
    HarnessResult,
    HarnessSettings,
    force_statistics,
    harness_summary,
    run_harness,
    write_harness_rapid,
)
from .phases import Phases, approach_shape, fixture_clips, insertion_pose, plan_phases

__all__ = [
    "PHASES",
    "Board",
    "Fixture",
    "HarnessJob",
    "HarnessResult",
    "HarnessScenario",
    "HarnessSettings",
    "HarnessSpec",
    "Insertion",
    "Peg",
    "Phases",
    "TensionState",
    "approach_shape",
    "check_board",
    "fixture_clips",
    "force_statistics",
    "harness_summary",
    "insert_and_tension",
    "insertion_pose",
    "is_harness",
    "load_harness",
    "plan_phases",
    "route_length",
    "run_harness",
    "run_harness_job",
    "section_cable",
    "section_shape",
    "tension_state",
    "write_harness_rapid",
]
