"""Wire-harness jobs (thesis 7.3): boards, two-phase planning, insertion and tensioning.

``run_harness(cable, start, board)`` runs a whole job; a job file with a ``harness:`` section is
read by :func:`dloplan.app.load_job` into a :class:`dloplan.pipeline.job.HarnessJob`; see
``docs/harness.md``.
"""

from .board import Board, Fixture, Peg, check_board, route_length
from .insertion import (
    Insertion,
    TensionState,
    insert_and_tension,
    tension_state,
)
from .job import (
    PHASES,
    HarnessResult,
    HarnessSettings,
    force_statistics,
    harness_summary,
    held_before_planning,
    run_harness,
)
from .phases import Phases, approach_shape, fixture_clips, insertion_pose, plan_phases
from .section import section_cable, section_shape, whole_shape

__all__ = [
    "PHASES",
    "Board",
    "Fixture",
    "HarnessResult",
    "HarnessSettings",
    "Insertion",
    "Peg",
    "Phases",
    "TensionState",
    "approach_shape",
    "check_board",
    "fixture_clips",
    "force_statistics",
    "harness_summary",
    "held_before_planning",
    "insert_and_tension",
    "insertion_pose",
    "plan_phases",
    "route_length",
    "run_harness",
    "section_cable",
    "section_shape",
    "tension_state",
    "whole_shape",
]
