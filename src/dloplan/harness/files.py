"""Harness scenario files: a scenario with a ``harness:`` section instead of a target.

The file reuses the scenario format (:mod:`dloplan.io.scenario`): ``cable``, ``start``,
``obstacles``, ``table``, ``planner`` (``physical_mode``), ``grippers`` (``method``),
``trajectory`` (speeds, accelerations, jerks, ``zone``, gripper action times), ``check``
(``z_safety``, ``max_rounds``) and ``units``; the target is computed from the board, so
there is none. The ``harness:`` section (:class:`~dloplan.harness.board.HarnessSpec`) holds
the fixtures, the pegs and the job's settings. Lengths are in ``units``; forces in N; speeds
as in the scenario format.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field

from ..cable import Cable
from ..io.scenario import (
    JobSpec,
    OutputName,
    ScenarioError,
    TableSpec,
    build_cable,
    build_obstacles,
    build_shape,
    parse_model,
    read_mapping,
)
from ..obstacles.shapes import Table
from .board import Board, HarnessSpec, check_board
from .job import HarnessResult, HarnessSettings, run_harness


class HarnessScenario(JobSpec):
    """A harness job file (schema version 1): the job's common sections and a board."""

    harness: HarnessSpec
    table: TableSpec = Field(default_factory=TableSpec)
    outputs: list[OutputName] = Field(default_factory=lambda: ["json", "rapid"])


@dataclass(frozen=True, eq=False)
class HarnessJob:
    """A harness file resolved into library objects (SI units)."""

    scenario: HarnessScenario
    cable: Cable
    start: np.ndarray
    board: Board
    settings: HarnessSettings
    source: str = ""


def is_harness(data: Any) -> bool:
    """True when a scenario mapping has a ``harness:`` section (dispatch for ``dloplan plan``)."""
    return isinstance(data, dict) and "harness" in data


def parse_harness(data: Any, source: str = "harness scenario") -> HarnessScenario:
    """Validate a mapping as a :class:`HarnessScenario`; :class:`ScenarioError` (one line)."""
    return parse_model(HarnessScenario, data, source)


def resolve_harness(scenario: HarnessScenario, source: str = "harness scenario") -> HarnessJob:
    """Build the cable, start shape, board and settings; check the board against the cable.

    Raises
    ------
    ScenarioError
        One line naming the section: an identification request (not supported here: give a
        modulus), planner weights (not supported by harness jobs), an invalid fixture or peg,
        or a board the cable cannot be used on (:func:`check_board`).
    """
    scale = scenario.scale
    if scenario.cable.youngs_modulus == "identify":
        raise ScenarioError(f"{source}: cable.youngs_modulus: 'identify' is not supported in a "
                            "harness job, give the modulus [Pa]")
    if scenario.planner.weights:
        raise ScenarioError(f"{source}: planner.weights: not supported in a harness job "
                            "(the planner's defaults for the cable's stiffness family are used)")
    try:
        cable = build_cable(scenario.cable, scale, None)
    except ValueError as exc:
        raise ScenarioError(f"{source}: cable.{exc}") from None
    start = build_shape(scenario.start, cable, scale, "start")
    obstacles = build_obstacles(scenario.obstacles, None, scale)
    h = scenario.harness
    try:
        board = h.build_board(scale, obstacles, Table(scenario.table.height * scale))
        check_board(board, cable)
    except ValueError as exc:
        raise ScenarioError(f"{source}: harness: {exc}") from None
    t = h.tension
    settings = HarnessSettings(
        n_shapes=tuple(h.n_shapes), approach_height=h.approach_height * scale,
        clearance=h.clearance * scale, contact_force=t.contact_force,
        max_axial_force=t.max_axial_force, max_offset=t.max_offset * scale,
        section_links=t.n_links, substeps=t.substeps,
        max_speed=scenario.trajectory.limits(scale).speed,
        max_angular_speed=scenario.trajectory.angular_speed,
        limits=scenario.trajectory.limits(scale), zone=scenario.trajectory.zone * scale,
        grasp_time=scenario.trajectory.grasp_time, release_time=scenario.trajectory.release_time,
        min_tension=t.min_tension, rated_load=t.rated_load,
        gripper_method=scenario.grippers.method,
        physical_mode=scenario.planner.physical_mode or "equilibrium",
        z_safety=scenario.check.lengths(scale)[1], max_rounds=scenario.check.max_rounds,
    )
    return HarnessJob(scenario, cable, start, board, settings, source)


def load_harness(path: str | Path) -> HarnessJob:
    """Read, validate and resolve a harness file (YAML or JSON)."""
    return resolve_harness(parse_harness(read_mapping(path), str(path)), str(path))


def run_harness_job(job: HarnessJob) -> HarnessResult:
    """Run a resolved harness file (:func:`dloplan.harness.job.run_harness`)."""
    if not isinstance(job, HarnessJob):
        raise ValueError(f"job: got {type(job).__name__}, expected a HarnessJob")
    return run_harness(job.cable, job.start, job.board, job.settings)
