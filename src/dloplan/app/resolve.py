"""Resolving a job file: validated sections turned into a frozen job in SI units.

Every conversion of a job file happens here, once, at load: lengths in the file's ``units`` to
metres (:func:`build_cable`, :func:`build_shape`, :func:`build_obstacles`, :func:`build_board`,
the motion limits, T_cf and the lift safety, the robot cell's base, tools and approach, the
URScript writer's settings), degrees to radians (rotations, yaws, arcs), the defaults of every
stage applied, and the planner's weights and stiffness family chosen, so the planner, the study
and the report all see the same ones. :func:`resolve_scenario` makes a
:class:`~dloplan.pipeline.job.Job`, :func:`resolve_harness` a
:class:`~dloplan.pipeline.job.HarnessJob`. No pydantic model and no file unit passes this point
(:mod:`dloplan.app.load` reads the file; :mod:`dloplan.io.scenario` describes its sections).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..bounds import WORKSPACE
from ..cable import Cable, catalogue_cable
from ..geometry import resample_by_arc_length
from ..io.job_file import svg_copies
from ..io.scenario import (
    PROGRAM_NAMES,
    ArcShape,
    BoxSpec,
    CableSpec,
    CheckSpec,
    PointsShape,
    RotationSpec,
    ScenarioError,
    StraightShape,
    TableSpec,
    TrajectorySpec,
    UrscriptSpec,
)
from ..obstacles.shapes import Box, Cylinder, Table
from ..pipeline.job import (
    GripperSettings,
    HarnessJob,
    Job,
    MotionSettings,
    PlannerSettings,
    RepairSettings,
)
from ..planning.tuning import planner_weights, stiffness_family
from ..robot.cell import RobotCell
from ..robot.plugins import cell_name, program_formats
from ..robot.urdf_cell import DescribedCell, cell_from_mapping
from ..robot.yumi import BASE_ABOVE_FOOT
from ..shapes import arc_shape, discretize, place, sine_shape, straight_shape
from ..trajectory import MotionLimits

if TYPE_CHECKING:  # the harness package is imported by a harness job's resolution only
    from ..harness.board import Board
    from ..harness.job import HarnessSettings


DEFAULT_THRESHOLD = 0.01
"""Default T_cf [m] of the target stability check (thesis 5.3)."""
DEFAULT_Z_SAFETY = 0.02
"""Default safety offset [m] of the obstacle lift (thesis 5.4.3)."""


SMALLEST = {"length": 0.02, "diameter": 1e-4}
"""Least cable length and diameter [m]: two grippers hold a cable's ends (about a centimetre
each), and no cable or hose is thinner than a tenth of a millimetre; less is a length in the
wrong units (metres written into a mm file)."""


# -- the sections' conversions ------------------------------------------------------------------
def rotation(spec: RotationSpec) -> Rotation:
    """A rotation section (Euler angles in its ``seq`` and ``degrees``, or a quaternion
    x-y-z-w) as a scipy :class:`~scipy.spatial.transform.Rotation`."""
    if spec.euler is not None:
        return Rotation.from_euler(spec.seq, spec.euler, degrees=spec.degrees)
    return Rotation.from_quat(spec.quaternion)


def motion_limits(spec: TrajectorySpec, scale: float) -> MotionLimits:
    """The :class:`dloplan.trajectory.MotionLimits` of a ``trajectory:`` section in SI
    (lengths times ``scale`` [m/unit]; the YuMi defaults of :mod:`dloplan.trajectory.limits`
    where the file gives none)."""
    defaults = MotionLimits()
    given = {"speed": spec.tcp_speed, "acceleration": spec.acceleration, "jerk": spec.jerk}
    lengths = {k: getattr(defaults, k) if v is None else v * scale for k, v in given.items()}
    return MotionLimits(**lengths, angular_speed=spec.angular_speed,
                        angular_acceleration=spec.angular_acceleration,
                        angular_jerk=spec.angular_jerk)


def check_lengths(spec: CheckSpec, scale: float) -> tuple[float, float]:
    """(T_cf, z_safety) [m] of a ``check:`` section: the file's values times ``scale``, or
    the thesis' defaults (:data:`DEFAULT_THRESHOLD`, :data:`DEFAULT_Z_SAFETY`)."""
    threshold = DEFAULT_THRESHOLD if spec.threshold is None else spec.threshold * scale
    z_safety = DEFAULT_Z_SAFETY if spec.z_safety is None else spec.z_safety * scale
    return threshold, z_safety


def file_length(spec, name: str, scale: float):
    """Length field ``name`` of a file's section ``spec`` (a pydantic model) in metres: the
    value the file gives times ``scale`` [m per unit], or, left out, the field's default,
    which is in metres whatever the file's ``units`` (as the check's and the TCP speed's
    defaults, docs/scenario.md). A file in mm that leaves a peg's ``plate_thickness`` out gets
    3 mm, not 3 um.

    Returns
    -------
    float or tuple of float
        A tuple for a list field (``plate_size``).
    """
    value = getattr(spec, name)
    factor = scale if name in spec.model_fields_set else 1.0
    if isinstance(value, list | tuple):
        return tuple(float(v) * factor for v in value)
    return value * factor


def urscript_settings(spec: UrscriptSpec, scale: float) -> dict:
    """The URScript writer's keyword settings (:func:`dloplan.io.urscript.write_urscript`) in
    SI (:func:`file_length`: the file's lengths times ``scale``, a default in SI)."""
    return {**spec.model_dump(), "blend": file_length(spec, "blend", scale),
            "acceleration": file_length(spec, "acceleration", scale)}


def build_cable(spec: CableSpec, scale: float, youngs_modulus: float | None) -> Cable:
    """The :class:`Cable` of a cable specification (lengths in file units times ``scale``).

    Raises
    ------
    ValueError
        Naming the field: a length or diameter below :data:`SMALLEST`, or a bad cable.
    """
    params: dict[str, Any] = {"n_links": spec.n_links, "bending": spec.bending,
                              "masses": spec.masses}
    for key in ("length", "diameter"):
        value = getattr(spec, key)
        if value is not None:
            params[key] = value * scale
            if params[key] < SMALLEST[key]:
                raise ValueError(f"{key}: got {value:g} file units ({params[key]:.3g} m), "
                                 f"expected at least {SMALLEST[key]:g} m (a length in metres "
                                 "in a mm file?)")
    for key in ("mass", "poisson_ratio", "axial_modulus"):
        if getattr(spec, key) is not None:
            params[key] = getattr(spec, key)
    if spec.axial_modulus == "thesis":  # the thesis: one modulus for bending and stretching
        params["axial_modulus"] = None
    if youngs_modulus is not None:
        params["youngs_modulus"] = youngs_modulus
    elif spec.youngs_modulus not in (None, "identify"):
        params["youngs_modulus"] = spec.youngs_modulus
    if spec.name is not None:
        return catalogue_cable(spec.name, **params)
    return Cable(**params)


def build_shape(spec, cable: Cable, scale: float, name: str) -> np.ndarray:
    """The points [m] of a shape specification for ``cable``."""
    if isinstance(spec, PointsShape):
        pts = np.asarray(spec.points, dtype=float) * scale
        if pts.shape[1] == 2:
            pts = np.stack([pts[:, 0], np.zeros(len(pts)), pts[:, 1]], axis=1)
        return pts
    n, length = cable.n_links, cable.length
    try:
        if isinstance(spec, StraightShape):
            local = straight_shape(length, n)
        elif isinstance(spec, ArcShape):
            local = arc_shape(length, n, math.radians(spec.angle))
        else:
            local = sine_shape(length, n, spec.amplitude * scale, spec.periods)
    except ValueError as exc:
        raise ScenarioError(f"{name}: {exc}") from None
    turn = rotation(spec.placement.rotation) if spec.placement.rotation else None
    return place(local, np.asarray(spec.placement.position) * scale, turn)


def build_obstacles(specs, table: TableSpec | None, scale: float) -> list:
    """Obstacle objects [m] from their specifications."""
    out: list = []
    for k, spec in enumerate(specs):
        try:
            if isinstance(spec, BoxSpec):
                if spec.center is not None:
                    out.append(Box(tuple(np.multiply(spec.center, scale)),
                                   tuple(np.multiply(spec.size, scale)),
                                   math.radians(spec.yaw), spec.name))
                else:
                    out.append(Box.from_corners(np.multiply(spec.min, scale),
                                                np.multiply(spec.max, scale),
                                                math.radians(spec.yaw), spec.name))
            else:
                out.append(Cylinder(tuple(np.multiply(spec.base, scale)), spec.radius * scale,
                                    spec.height * scale, spec.name))
        except ValueError as exc:
            raise ScenarioError(f"obstacles.{k}: {exc}") from None
    if table is not None:
        out.append(Table(table.height * scale))
    return out


def build_board(spec, scale: float, obstacles=(), table: Table | None = None) -> Board:
    """The :class:`~dloplan.harness.board.Board` of a ``harness:`` section in metres (its
    fixtures and pegs, a length left out its default in metres, :func:`file_length`;
    obstacles and table from the file's own sections; ``table`` None: no table)."""
    from ..harness.board import Board, Fixture, Peg

    fixtures = tuple(Fixture(tuple(np.multiply(f.position, scale)), tuple(f.axis),
                             tuple(f.opening), *(file_length(f, key, scale) for key in
                                                 ("slot_width", "depth", "length", "wall")),
                             name)
                     for f, name in zip(spec.fixtures, spec.fixture_names(), strict=True))
    pegs = tuple(Peg(tuple(np.multiply(p.base, scale)), p.radius * scale, p.height * scale,
                     None if p.plate_height is None else p.plate_height * scale,
                     file_length(p, "plate_size", scale), file_length(p, "plate_thickness", scale),
                     tuple(p.side), name)
                 for p, name in zip(spec.pegs, spec.peg_names(), strict=True))
    return Board(fixtures, pegs, tuple(obstacles), table)


# -- a scenario -----------------------------------------------------------------------------------
def _initial_frames(spec) -> Rotation | None:
    frames = spec.grippers.initial_frames
    if frames.first is None and frames.last is None:
        return None
    if frames.first is None or frames.last is None:
        raise ScenarioError("grippers.initial_frames: give both first and last, or neither")
    return Rotation.concatenate([rotation(frames.first), rotation(frames.last)])


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
    z_safety = check_lengths(scenario.check, scale)[1]
    return PlannerSettings(spec.n_shapes, weights, family, forced,
                           spec.physical_mode or "equilibrium", z_safety,
                           scenario.check.max_rounds, spec.keep_target)


def motion_settings(scenario, scale: float) -> MotionSettings:
    """Motion limits and zone in SI (the file's length units per second...), actions, rate."""
    spec = scenario.trajectory
    try:
        limits = motion_limits(spec, scale)
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


YUMI_ONLY = ("base_position", "base_rotation", "wobj", "tools", "approach", "hold_force",
             "arm_angle_reference")
"""Settings of the ``robot:`` section that describe the YuMi's cell (not a described one)."""


def robot_cell(scenario, scale: float, folder=".", *,
               placement: bool = False) -> RobotCell | DescribedCell:
    """The robot cell of a job file's ``robot:`` section (lengths in file units times
    ``scale``): the YuMi's :class:`RobotCell`, or with ``robot.cell`` a
    :class:`~dloplan.robot.urdf_cell.DescribedCell` (URDF paths relative to ``folder``; table
    height by default the file's table). The YuMi stands on the file's table unless
    ``robot.base_position`` says otherwise: its base frame
    :data:`~dloplan.robot.yumi.BASE_ABOVE_FOOT` above the table top, above the plan's origin;
    without a table, the plan's frame is the base frame (the table, under the robot's foot, at
    -0.1 m). A described cell searches where on the table it runs the job (``robot.place``)
    only when the job may be moved (``placement``: the consent of docs/repair.md); otherwise it
    verifies the job where the file puts it."""
    spec = scenario.robot
    table = scenario.table.height * scale if scenario.table is not None else None
    if spec.cell is not None:
        mixed = sorted(set(YUMI_ONLY) & spec.model_fields_set)
        if mixed:
            raise ScenarioError(f"robot.{mixed[0]}: set for the YuMi's cell, expected nothing "
                                "with robot.cell (its arms are placed in robot.cell)")
        data = dict(spec.cell)
        data.setdefault("table_height", scenario.table.height if scenario.table else 0.0)
        gripper = spec.gripper.model_dump()
        writers = {"urscript": {**urscript_settings(spec.urscript, scale), "gripper": gripper},
                   "ur_rtde": {**spec.ur_rtde.model_dump(), "hosts": tuple(spec.ur_rtde.hosts),
                               "gripper": gripper},
                   "ros_joints": {k: v for k, v in spec.ros_joints.model_dump().items()
                                  if v is not None}}
        if not gripper["tool"] and gripper["output"] == spec.urscript.ready_output:
            raise ScenarioError(f"robot.gripper.output: got {gripper['output']}, the standard "
                                "digital output robot.urscript.ready_output; expected another")
        try:
            cell = cell_from_mapping(data, folder, scale)
        except ValueError as exc:
            message = str(exc)
            raise ScenarioError(message if message.startswith("robot.") else
                                f"robot.cell: {message}") from None
        return replace(cell, place=spec.place and placement, writers=writers,
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
            base_rotation=rotation(spec.base_rotation) if spec.base_rotation else
            Rotation.identity(),
            tools=tuple(tools), wobj=spec.wobj, table_height=table,
            approach=defaults.approach if spec.approach is None else spec.approach * scale,
            hold_force=spec.hold_force,
            arm_angle_reference=defaults.arm_angle_reference
            if spec.arm_angle_reference is None else tuple(spec.arm_angle_reference),
            reach=replace(defaults.reach, min_margin=float(np.radians(spec.min_joint_margin))))
    except ValueError as exc:
        raise ScenarioError(f"robot: {exc}") from None


def job_outputs(scenario, cell) -> tuple[str, ...]:
    """What ``dloplan plan`` writes: the scenario's ``outputs`` with the robot programs the
    cell takes (``robot.programs``; by default all of them, replacing ``rapid``); ``svg`` kept
    (the figures' SVG copies, :func:`dloplan.io.job_file.svg_copies`).

    Raises
    ------
    ScenarioError
        A program (in ``robot.programs`` or a given ``outputs``) the cell cannot run; ``svg``
        without ``figures`` or ``report``.
    """
    svg_copies(scenario.outputs)
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


def resolve_scenario(scenario, source: str = "scenario", youngs_modulus: float | None = None,
                     identification=None, *, allow_placement: bool = False) -> Job:
    """Turn a validated scenario into a :class:`Job` (SI units, library objects, defaults).

    Parameters
    ----------
    scenario : dloplan.app.schema.Scenario
        The validated file.
    source : str
        Its name, for messages.
    youngs_modulus : float, optional
        Replaces the file's E [Pa] (after an identification).
    identification : Identification, optional
        Kept in the job, for the plan document.
    allow_placement : bool
        Let the repair move the job on the table even when the file does not
        (``--allow-placement``; the file's ``repair: {placement: true}`` does too).

    Raises
    ------
    ScenarioError
        One line starting with ``source`` and naming the field: a shape the cable cannot take,
        bad weights, ...
    """
    try:
        return _resolved(scenario, source, youngs_modulus, identification,
                         scenario.repair.placement or allow_placement)
    except ScenarioError as exc:
        if str(exc).startswith(f"{source}: "):
            raise
        raise ScenarioError(f"{source}: {exc}") from None


def _resolved(scenario, source: str, youngs_modulus: float | None, identification,
              placement: bool) -> Job:
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
    threshold = check_lengths(scenario.check, scale)[0]
    obstacles = tuple(build_obstacles(scenario.obstacles, scenario.table, scale))
    for name, shape in shapes.items():
        check_workspace(shape, name, source)
    cell = robot_cell(scenario, scale, Path(source).parent, placement=placement)
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
        repair=RepairSettings(placement=placement),
    )


# -- a wire-harness job ---------------------------------------------------------------------------
def harness_settings(scenario, scale: float) -> HarnessSettings:
    """The harness job's settings in SI: the ``harness:`` section's phases, insertion and
    tensioning (a length left out its default in metres, :func:`file_length`), the
    trajectory's limits, the planner's mode and the check's lift safety."""
    from ..harness.job import HarnessSettings

    h, t = scenario.harness, scenario.harness.tension
    limits = motion_limits(scenario.trajectory, scale)
    return HarnessSettings(
        n_shapes=tuple(h.n_shapes), approach_height=file_length(h, "approach_height", scale),
        clearance=file_length(h, "clearance", scale), contact_force=t.contact_force,
        max_axial_force=t.max_axial_force, max_offset=file_length(t, "max_offset", scale),
        section_links=t.n_links, substeps=t.substeps, max_speed=limits.speed,
        max_angular_speed=scenario.trajectory.angular_speed, limits=limits,
        zone=scenario.trajectory.zone * scale, grasp_time=scenario.trajectory.grasp_time,
        release_time=scenario.trajectory.release_time, min_tension=t.min_tension,
        rated_load=t.rated_load, gripper_method=scenario.grippers.method,
        physical_mode=scenario.planner.physical_mode or "equilibrium",
        z_safety=check_lengths(scenario.check, scale)[1], max_rounds=scenario.check.max_rounds)


def resolve_harness(scenario, source: str = "harness scenario") -> HarnessJob:
    """Turn a validated harness file (:class:`dloplan.app.schema.HarnessScenario`) into a
    :class:`~dloplan.pipeline.job.HarnessJob`: the cable, the start, the board checked against
    the cable (:func:`~dloplan.harness.board.check_board`), the settings, the robot cell (which
    does not move the job: a board is fixed) and the outputs.

    Raises
    ------
    ScenarioError
        One line naming the file and the section: an identification request (not supported
        here: give a modulus), planner weights (not supported by harness jobs), an invalid
        fixture or peg, a board the cable cannot be used on, a program the cell cannot run.
    """
    from ..harness.board import check_board

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
    try:
        start = build_shape(scenario.start, cable, scale, "start")
        obstacles = build_obstacles(scenario.obstacles, None, scale)
        cell = robot_cell(scenario, scale, Path(source).parent)
        outputs = job_outputs(scenario, cell)
        settings = harness_settings(scenario, scale)
    except ScenarioError as exc:
        raise ScenarioError(f"{source}: {exc}") from None
    except ValueError as exc:  # the limits
        raise ScenarioError(f"{source}: trajectory: {exc}") from None
    try:
        board = build_board(scenario.harness, scale, obstacles,
                            Table(scenario.table.height * scale))
        check_board(board, cable)
    except ValueError as exc:
        raise ScenarioError(f"{source}: harness: {exc}") from None
    return HarnessJob(source, cable, start, board, settings, cell, outputs)
