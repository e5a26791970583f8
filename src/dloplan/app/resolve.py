"""Resolving a job file: a validated scenario turned into a :class:`~dloplan.pipeline.job.Job`.

Every unit conversion of a scenario happens here (lengths in the file's ``units`` to metres,
degrees to radians, the trajectory's limits, the robot cell), and the planner's weights and
stiffness family are chosen, so the planner, the study and the report all see the same ones. No
pydantic model and no file unit passes this point (:mod:`dloplan.app.load` reads the file).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import Cable
from ..geometry import resample_by_arc_length
from ..io.scenario import (
    PROGRAM_NAMES,
    WORKSPACE,
    Scenario,
    ScenarioError,
    build_cable,
    build_obstacles,
    build_shape,
)
from ..pipeline.job import GripperSettings, Job, MotionSettings, PlannerSettings
from ..planning.tuning import planner_weights, stiffness_family
from ..robot.cell import RobotCell
from ..robot.cell_program import cell_name, program_formats
from ..robot.urdf_cell import DescribedCell, cell_from_mapping
from ..robot.yumi import BASE_ABOVE_FOOT
from ..shapes import discretize


def _initial_frames(spec) -> Rotation | None:
    frames = spec.grippers.initial_frames
    if frames.first is None and frames.last is None:
        return None
    if frames.first is None or frames.last is None:
        raise ScenarioError("grippers.initial_frames: give both first and last, or neither")
    return Rotation.concatenate([frames.first.to_rotation(), frames.last.to_rotation()])


def resolve_cable(scenario, source: str, youngs_modulus: float | None = None) -> Cable:
    """The scenario's :class:`Cable` in SI units, with its rest shape resampled to n + 1 points.

    ``youngs_modulus`` [Pa] replaces the file's (after an identification).
    """
    scale = scenario.scale
    if scenario.cable.youngs_modulus == "identify" and youngs_modulus is None:
        raise ScenarioError(
            f"{source}: cable.youngs_modulus is 'identify': identify it first "
            "(dloplan plan and dloplan check do, from the identify section) or give E [Pa]"
        )
    try:
        cable = build_cable(scenario.cable, scale, youngs_modulus)
        if scenario.cable.rest_shape is not None:
            rest = build_shape(scenario.cable.rest_shape, cable, scale, "cable.rest_shape")
            if len(rest) != cable.n_points:
                rest = resample_by_arc_length(rest, cable.n_points)
            cable = replace(cable, rest_shape=rest)
    except ValueError as exc:
        raise ScenarioError(f"{source}: cable.{exc}") from None
    return cable


def planner_settings(scenario, cable: Cable, scale: float) -> PlannerSettings:
    """The planner's settings of a scenario (or harness file) for ``cable``: weights chosen."""
    spec = scenario.planner
    forced = spec.family != "auto"
    family = spec.family if forced else stiffness_family(cable.youngs_modulus)
    try:
        weights = planner_weights(family=family, overrides=spec.weights or None)
    except ValueError as exc:
        raise ScenarioError(f"planner.weights: {exc}") from None
    z_safety = scenario.check.lengths(scale)[1]
    return PlannerSettings(spec.n_shapes, weights, family, forced,
                           spec.physical_mode or "equilibrium", z_safety,
                           scenario.check.max_rounds, spec.keep_target)


def motion_settings(scenario, scale: float) -> MotionSettings:
    """Motion limits and zone in SI (the file's length units per second...), actions, rate."""
    spec = scenario.trajectory
    try:
        limits = spec.limits(scale)
    except ValueError as exc:
        raise ScenarioError(f"trajectory: {exc}") from None
    return MotionSettings(limits, spec.zone * scale, spec.grasp_time, spec.release_time,
                          spec.rate)


def gripper_settings(scenario) -> GripperSettings:
    """The gripper orientation method and its vectors."""
    spec = scenario.grippers
    return GripperSettings(spec.method, np.asarray(spec.auxiliary_vector, dtype=float),
                           _initial_frames(scenario))


def check_workspace(points, name: str, source: str) -> None:
    """Raise a one-line ScenarioError when a point lies beyond :data:`WORKSPACE` [m]."""
    reach = float(np.max(np.linalg.norm(np.reshape(points, (-1, 3)), axis=1)))
    if reach > WORKSPACE:
        raise ScenarioError(f"{source}: {name}: a point {reach:.4g} m from the origin, expected "
                            f"within {WORKSPACE:g} m of the robot (a length in wrong units?)")


YUMI_ONLY = ("base_position", "base_rotation", "wobj", "tools", "approach", "grip_time",
             "hold_force", "arm_angle_reference")
"""Settings of the ``robot:`` section that describe the YuMi's cell (not a described one)."""


def robot_cell(scenario, scale: float, folder=".") -> RobotCell | DescribedCell:
    """The robot cell of a scenario's ``robot:`` section (lengths in file units times
    ``scale``): the YuMi's :class:`RobotCell`, or with ``robot.cell`` a
    :class:`~dloplan.robot.urdf_cell.DescribedCell` (URDF paths relative to ``folder``; table
    height by default the scenario's table). The YuMi stands on the scenario's table unless
    ``robot.base_position`` says otherwise: its base frame
    :data:`~dloplan.robot.yumi.BASE_ABOVE_FOOT` above the table top, above the plan's origin;
    without a table, the plan's frame is the base frame (the table, under the robot's foot, at
    -0.1 m)."""
    spec = scenario.robot
    table = scenario.table.height * scale if scenario.table is not None else None
    if spec.cell is not None:
        mixed = sorted(set(YUMI_ONLY) & spec.model_fields_set)
        if mixed:
            raise ScenarioError(f"robot.{mixed[0]}: set for the YuMi's cell, expected nothing "
                                "with robot.cell (its arms are placed in robot.cell)")
        data = dict(spec.cell)
        data.setdefault("table_height", scenario.table.height if scenario.table else 0.0)
        writers = {"urscript": spec.urscript.settings(scale),
                   "ros_joints": {k: v for k, v in spec.ros_joints.model_dump().items()
                                  if v is not None}}
        try:
            cell = cell_from_mapping(data, folder, scale)
        except ValueError as exc:
            message = str(exc)
            raise ScenarioError(message if message.startswith("robot.") else
                                f"robot.cell: {message}") from None
        return replace(cell, place=spec.place, writers=writers,
                       min_margin=float(np.radians(spec.min_joint_margin)))
    defaults = RobotCell()
    tools = []
    for k, (tool_spec, tool) in enumerate(zip(spec.tools, defaults.tools, strict=True)):
        changes = {key: value for key, value in (
            ("name", tool_spec.name), ("mass", tool_spec.mass),
            ("tcp_offset", None if tool_spec.tcp_offset is None
             else np.multiply(tool_spec.tcp_offset, scale))) if value is not None}
        try:
            tools.append(replace(tool, **changes))
        except ValueError as exc:
            raise ScenarioError(f"robot.tools.{k}: {exc}") from None
    base = np.multiply(spec.base_position, scale)
    if "base_position" not in spec.model_fields_set and table is not None:
        base = np.array([0.0, 0.0, table + BASE_ABOVE_FOOT])  # the robot's foot on the table
    try:
        return RobotCell(
            base_position=base,
            base_rotation=spec.base_rotation.to_rotation() if spec.base_rotation else
            Rotation.identity(),
            tools=tuple(tools), wobj=spec.wobj, table_height=table,
            approach=defaults.approach if spec.approach is None else spec.approach * scale,
            grip_time=spec.grip_time, hold_force=spec.hold_force,
            arm_angle_reference=defaults.arm_angle_reference
            if spec.arm_angle_reference is None else tuple(spec.arm_angle_reference),
            reach=replace(defaults.reach, min_margin=float(np.radians(spec.min_joint_margin))))
    except ValueError as exc:
        raise ScenarioError(f"robot: {exc}") from None


def job_outputs(scenario, cell) -> tuple[str, ...]:
    """What ``dloplan plan`` writes: the scenario's ``outputs`` with the robot programs the
    cell takes (``robot.programs``; by default all of them, replacing ``rapid``).

    Raises
    ------
    ScenarioError
        A program (in ``robot.programs`` or a given ``outputs``) the cell cannot run.
    """
    formats = program_formats(cell)
    wanted = scenario.robot.programs
    if wanted is None:
        if "outputs" in scenario.model_fields_set or isinstance(cell, RobotCell):
            wanted = [f for f in PROGRAM_NAMES if f in scenario.outputs]
        else:
            wanted = list(formats)
    where = "robot.programs" if scenario.robot.programs is not None else "outputs"
    for name in wanted:
        if name not in formats:
            raise ScenarioError(f"{where}: got {name!r}, the cell {cell_name(cell)!r} takes "
                                f"{', '.join(formats)} (docs/cells.md)")
    others = [f for f in scenario.outputs if f not in PROGRAM_NAMES]
    return tuple(others + [f for f in PROGRAM_NAMES if f in wanted])


def resolve_scenario(scenario: Scenario, source: str = "scenario",
                     youngs_modulus: float | None = None, identification=None) -> Job:
    """Turn a validated scenario into a :class:`Job` (SI units, library objects, defaults).

    Parameters
    ----------
    scenario : Scenario
        The validated file.
    source : str
        Its name, for messages.
    youngs_modulus : float, optional
        Replaces the file's E [Pa] (after an identification).
    identification : Identification, optional
        Kept in the job, for the plan document.

    Raises
    ------
    ScenarioError
        One line starting with ``source`` and naming the field: a shape the cable cannot take,
        bad weights, ...
    """
    try:
        return _resolved(scenario, source, youngs_modulus, identification)
    except ScenarioError as exc:
        if str(exc).startswith(f"{source}: "):
            raise
        raise ScenarioError(f"{source}: {exc}") from None


def _resolved(scenario: Scenario, source: str, youngs_modulus: float | None,
              identification) -> Job:
    """:func:`resolve_scenario`'s work (its messages name the field, not always the file)."""
    scale = scenario.scale
    cable = resolve_cable(scenario, source, youngs_modulus)
    shapes = {}
    for name in ("start", "target"):
        points = build_shape(getattr(scenario, name), cable, scale, name)
        try:
            shapes[name] = discretize(points, cable, name)
        except ValueError as exc:
            raise ScenarioError(f"{source}: {exc}") from None
    threshold = scenario.check.lengths(scale)[0]
    obstacles = tuple(build_obstacles(scenario.obstacles, scenario.table, scale))
    for name, shape in shapes.items():
        check_workspace(shape, name, source)
    cell = robot_cell(scenario, scale, Path(source).parent)
    for k, obstacle in enumerate(obstacles):
        corner = np.array(getattr(obstacle, "center", getattr(obstacle, "base", (0, 0, 0))))
        check_workspace(corner, f"obstacles.{k}", source)
    return Job(
        source=source, cable=cable, start=shapes["start"], target=shapes["target"],
        obstacles=obstacles,
        planner=planner_settings(scenario, cable, scale), grippers=gripper_settings(scenario),
        motion=motion_settings(scenario, scale), target_threshold=threshold,
        outputs=job_outputs(scenario, cell), robot=cell,
        identification=identification, study=scenario.study,
    )
