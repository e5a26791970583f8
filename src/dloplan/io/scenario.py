"""The sections of a job file (schema version 1): pydantic models in the file's units.

A job file names the cable (a catalogue name or explicit properties), the discretization, the
start (and target) shapes (point lists or parametric: straight, arc, sine, each with a
placement), obstacles, gripper, trajectory, planner, check and robot settings. Lengths in the
file are in ``units`` (``m`` by default, or ``mm``). Every error names the field, the value and
what was expected, on one line (:class:`ScenarioError`). :func:`read_mapping` reads a file
(:mod:`dloplan.io.job_file`, re-exported here), :func:`parse_model` validates it.

This module only describes: the root models of the job files (a scenario, a harness job) are
:mod:`dloplan.app.schema`'s, and every conversion to SI units and library objects
(cables, shapes, obstacles, limits, the robot cell) is :mod:`dloplan.app.resolve`'s.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, get_args

import numpy as np
from pydantic import BaseModel, Field, ValidationError, field_validator, model_validator

from ..bounds import MAX_LINKS, MAX_RATE, MAX_SHAPES, MIN_LINKS
from ..cable import CATALOGUE_NAMES
from ..job_model import JobModel
from .job_file import ScenarioError, read_mapping  # noqa: F401 - read_mapping re-exported

SCHEMA_VERSION = 1


def _finite(values, name="value"):
    arr = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite numbers, got {values!r}")
    return values


Vector3 = Annotated[list[float], Field(min_length=3, max_length=3)]
PositiveLength = Annotated[float, Field(gt=0, allow_inf_nan=False)]


class RotationSpec(JobModel):
    """A rotation: Euler angles (``seq``, ``angles``, ``degrees``) or a quaternion x-y-z-w."""

    euler: list[float] | None = Field(None, description="Euler angles, see seq and degrees")
    seq: str = Field("xyz", description="scipy Euler sequence, e.g. 'xyz' (extrinsic)")
    degrees: bool = True
    quaternion: Annotated[list[float], Field(min_length=4, max_length=4)] | None = Field(
        None, description="quaternion in scipy order x, y, z, w"
    )

    @model_validator(mode="after")
    def _one_form(self):
        if (self.euler is None) == (self.quaternion is None):
            raise ValueError("give exactly one of euler or quaternion")
        if self.euler is not None:
            _finite(self.euler, "euler")
            if len(self.euler) != len(self.seq):
                raise ValueError(f"euler has {len(self.euler)} angles for seq {self.seq!r}")
        if self.quaternion is not None:
            _finite(self.quaternion, "quaternion")
            if np.linalg.norm(self.quaternion) < 1e-9:
                raise ValueError("quaternion has zero norm")
        return self


class Placement(JobModel):
    """Where a parametric shape goes: its first point at ``position``, then ``rotation``."""

    position: Vector3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    rotation: RotationSpec | None = None

    @field_validator("position")
    @classmethod
    def _pos(cls, v):
        return _finite(v, "position")


class PointsShape(JobModel):
    """An explicit polyline, (k, 3) or (k, 2) = (x, z) points; resampled to n + 1 points."""

    kind: Literal["points"] = "points"
    points: list[list[float]]

    @field_validator("points")
    @classmethod
    def _points(cls, v):
        if len(v) < 3:
            raise ValueError(f"{len(v)} points given, need at least 3")
        widths = {len(p) for p in v}
        if widths - {2, 3} or len(widths) != 1:
            raise ValueError(f"every point needs 3 (x, y, z) or 2 (x, z) coordinates, got {widths}")
        return _finite(v, "points")


class StraightShape(JobModel):
    """A straight cable along the placement's x-axis."""

    kind: Literal["straight"] = "straight"
    placement: Placement = Field(default_factory=Placement)


class ArcShape(JobModel):
    """A circular arc turning by ``angle`` [deg] in the placement's x-y plane."""

    kind: Literal["arc"] = "arc"
    angle: float = Field(..., ge=-360, le=360, allow_inf_nan=False,
                         description="total turning angle [deg], at most a full turn")
    placement: Placement = Field(default_factory=Placement)


class SineShape(JobModel):
    """A sine wave of ``amplitude`` (file units) and ``periods`` in the placement's x-y plane."""

    kind: Literal["sine"] = "sine"
    amplitude: float = Field(..., allow_inf_nan=False)
    periods: float = Field(1.0, gt=0, allow_inf_nan=False)
    placement: Placement = Field(default_factory=Placement)


ShapeSpec = Annotated[
    PointsShape | StraightShape | ArcShape | SineShape, Field(discriminator="kind")
]


class CableSpec(JobModel):
    """The cable: a catalogue ``name`` and/or explicit properties (explicit ones win)."""

    name: str | None = Field(None, description=f"one of {', '.join(CATALOGUE_NAMES)}")
    length: PositiveLength | None = None
    diameter: PositiveLength | None = None
    mass: PositiveLength | None = Field(None, description="[kg]")
    youngs_modulus: PositiveLength | Literal["identify"] | None = Field(
        None, description="[Pa], or 'identify' with an identify section"
    )
    poisson_ratio: float | None = Field(None, gt=-1, le=0.5)
    axial_modulus: PositiveLength | Literal["thesis"] | None = Field(
        None, description="[Pa] modulus of the axial springs (default: the catalogue's for usb "
        "and ethernet, their copper's 2e9; else youngs_modulus), or 'thesis': the thesis' one "
        "modulus for bending and stretching (E_a = youngs_modulus)")
    n_links: int = Field(10, ge=MIN_LINKS, le=MAX_LINKS, description=(
        "n >= 4: each clip holds two points, so n = 4 is the least that leaves the cable a "
        f"free point; n <= {MAX_LINKS}: plans in minutes at most"))
    bending: Literal["rod", "thesis"] = "rod"
    masses: Literal["consistent", "equal"] = "consistent"
    rest_shape: ShapeSpec | None = None

    @model_validator(mode="after")
    def _known(self):
        if self.name is None:
            missing = [f for f in ("length", "diameter", "mass", "youngs_modulus")
                       if getattr(self, f) is None]
            if missing:
                raise ValueError(f"without a catalogue name, give {', '.join(missing)}")
        elif self.name.lower() not in CATALOGUE_NAMES:
            raise ValueError(
                f"unknown cable name {self.name!r}, expected one of {', '.join(CATALOGUE_NAMES)}"
            )
        return self


class BoxSpec(JobModel):
    """A box on the table: ``center`` + ``size`` or ``min`` + ``max``, optional ``yaw`` [deg]."""

    type: Literal["box"] = "box"
    name: str = "box"
    center: Vector3 | None = None
    size: Vector3 | None = None
    min: Vector3 | None = None
    max: Vector3 | None = None
    yaw: float = Field(0.0, allow_inf_nan=False, description="[deg] about z")

    @model_validator(mode="after")
    def _form(self):
        by_center = self.center is not None and self.size is not None
        by_corners = self.min is not None and self.max is not None
        if by_center == by_corners:
            raise ValueError("give either center and size, or min and max")
        for key in ("center", "size", "min", "max"):
            if getattr(self, key) is not None:
                _finite(getattr(self, key), key)
        return self


class CylinderSpec(JobModel):
    """A vertical cylinder (peg) standing at ``base``."""

    type: Literal["cylinder"] = "cylinder"
    name: str = "cylinder"
    base: Vector3
    radius: PositiveLength
    height: PositiveLength


ObstacleSpec = Annotated[BoxSpec | CylinderSpec, Field(discriminator="type")]


class PlannerSpec(JobModel):
    """Planner settings (thesis chapter 4, Tables 6.1/6.2)."""

    n_shapes: int = Field(5, ge=1, le=MAX_SHAPES, description="S, intermediate shapes")
    physical_mode: Literal["thesis", "equilibrium"] | None = None
    keep_target: bool = Field(
        False, description="plan to the target as given, not to its minimal-energy shape "
                           "(thesis 4.5.1 pre-processing; default: minimized, with the distance "
                           "reported when it moves more than 2 % of L)")
    family: Literal["auto", "soft", "medium", "stiff"] = Field(
        "auto", description="stiffness family of the physical weights (auto: from E)"
    )
    weights: dict[Literal["basic", "advanced", "physical"], dict[str, float]] = Field(
        default_factory=dict,
        description="weight overrides per stage, e.g. {advanced: {clip: 0.02}, physical: "
                    "{bending: 1000}} (docs/planner.md)",
    )

    @field_validator("weights")
    @classmethod
    def _weights(cls, v):
        for stage, values in v.items():
            for key, value in values.items():
                if not (math.isfinite(value) and value >= 0):
                    raise ValueError(
                        f"weight {stage}.{key} = {value!r}, expected a finite number >= 0"
                    )
        return v


class FrameSpec(JobModel):
    """Initial clip frames for the minimal-rotation and rigid-rotation methods."""

    first: RotationSpec | None = None
    last: RotationSpec | None = None


class GripperSpec(JobModel):
    """Gripper orientation method (thesis 4.6, Table 4.3)."""

    method: Literal["auto", "auxiliary", "minimal", "rigid"] = "auto"
    auxiliary_vector: Vector3 = Field(default_factory=lambda: [0.0, 0.0, 1.0])
    initial_frames: FrameSpec = Field(default_factory=FrameSpec)

    @field_validator("auxiliary_vector")
    @classmethod
    def _direction(cls, v):
        arr = np.asarray(_finite(v, "auxiliary_vector"), dtype=float)
        if not np.linalg.norm(arr) > 0:
            raise ValueError(f"expected a non-zero direction, got {v}")
        return v


class TrajectorySpec(JobModel):
    """Timed dual-arm motion (thesis 7.3: 100 mm/s; limits: dloplan.trajectory.limits)."""

    tcp_speed: PositiveLength | None = Field(
        None, description="[file units/s]; default 100 mm/s (thesis 7.3)")
    angular_speed: PositiveLength = Field(1.0, description="[rad/s]")
    rate: PositiveLength = Field(50.0, le=MAX_RATE, description="sampling rate [Hz]")
    acceleration: PositiveLength | None = Field(
        None, description="TCP acceleration limit [units/s^2]; default 1 m/s^2 (YuMi)")
    jerk: PositiveLength | None = Field(
        None, description="TCP jerk limit [units/s^3]; default 10 m/s^3")
    angular_acceleration: PositiveLength = Field(10.0, description="[rad/s^2]")
    angular_jerk: PositiveLength = Field(100.0, description="[rad/s^3]")
    zone: float = Field(0.0, ge=0, allow_inf_nan=False,
                        description="fly-by zone radius [units]; 0: stop at every shape")
    grasp_time: PositiveLength = Field(0.5, description="gripper grasp duration [s]")
    release_time: PositiveLength = Field(0.4, description="gripper release duration [s]")


class CheckSpec(JobModel):
    """Target stability check (thesis 5.3) and obstacle avoidance (5.4) settings."""

    threshold: PositiveLength | None = Field(None, description="T_cf [file units]; 1 cm")
    z_safety: float | None = Field(None, ge=0, allow_inf_nan=False,
                                   description="lift safety [file units]; 2 cm")
    max_rounds: int = Field(5, ge=0, le=50)


class TableSpec(JobModel):
    """The table plane the obstacles rest on."""

    height: float = Field(0.0, allow_inf_nan=False)


OutputName = Literal["json", "csv", "rapid", "ros", "ros_joints", "urscript", "ur_rtde",
                     "figures", "report", "svg"]
ProgramName = Literal["rapid", "urscript", "ur_rtde", "ros_joints"]
PROGRAM_NAMES = get_args(ProgramName)
"""The robot program formats a cell may take (``robot.programs``)."""


class ToolSpec(JobModel):
    """One arm's tool as RAPID ``tooldata`` (default: ABB's SmartGripper data, docs/robot.md)."""

    name: str | None = Field(None, description="tooldata name (default dlo_tool_l / _r)")
    tcp_offset: Vector3 | None = Field(None, description="TCP in the flange frame [units]")
    mass: PositiveLength | None = Field(None, description="[kg]")


class UrscriptSpec(JobModel):
    """How the URScript programs are written (:func:`dloplan.io.urscript.write_urscript`)."""

    mode: Literal["movej", "movel"] = "movej"
    blend: float = Field(0.0, ge=0, allow_inf_nan=False, description="blend radius [units]")
    acceleration: PositiveLength = Field(1.2, description="movel acceleration [units/s^2]; "
                                         "left out: 1.2 m/s^2 whatever the units")
    start_speed: PositiveLength = Field(0.5, description="joint speed to the start [rad/s]")
    start_input: int = Field(0, ge=0, le=7, description="standard digital input to wait for")
    ready_output: int = Field(0, ge=0, le=7, description="standard digital output raised")


class UrRtdeSpec(JobModel):
    """How the UR pair's RTDE streamer is written (:mod:`dloplan.io.ur_rtde`)."""

    hosts: list[str] = Field(default_factory=lambda: ["", ""], min_length=2, max_length=2,
                             description="left, right controller address (or on the "
                             "command line)")
    rate: PositiveLength = Field(500.0, description="control rate [Hz]: 500 e-Series, 125 CB3")
    lookahead: float = Field(0.1, ge=0.03, le=0.2, description="servoJ lookahead [s]")
    gain: float = Field(300.0, ge=100, le=2000, description="servoJ gain")
    start_speed: PositiveLength = Field(0.5, description="joint speed to the start [rad/s]")
    start_tolerance: PositiveLength = Field(0.01, description="[rad] from the start joints")
    tracking_tolerance: PositiveLength = Field(0.05, description="[rad] from the commanded "
                                               "joints one lookahead earlier")


class GripperIoSpec(JobModel):
    """The gripper of each UR arm, driven by one digital output (URScript and ur_rtde)."""

    output: int = Field(1, ge=0, le=7, description="digital output (tool: 0..1)")
    tool: bool = Field(False, description="the tool flange's output instead of a standard one")
    closed: bool = Field(True, description="the level that closes the fingers")

    @model_validator(mode="after")
    def _tool_output(self):
        if self.tool and self.output > 1:
            raise ValueError(f"output: got {self.output}, a tool digital output is 0 or 1")
        return self


class RosJointsSpec(JobModel):
    """How the ROS 2 joint trajectories are written (:mod:`dloplan.io.ros_joints`)."""

    joint_prefix: list[str] | None = Field(None, min_length=2, max_length=2,
                                           description="per arm before every joint name")
    velocities: bool = Field(True, description="write velocities and accelerations")
    rate: PositiveLength = Field(100.0, description="points per second [Hz]")


class RobotSpec(JobModel):
    """The robot cell: where the YuMi stands in the plan's frame, its tools and work object;
    or, with ``cell``, any two arms from robot descriptions (docs/cells.md), where the YuMi's
    settings do not apply."""

    cell: dict[str, Any] | None = Field(
        None, description="a cell from descriptions: {preset: ur5e_pair | panda_pair | yumi, "
        "...} or {arms: {left: {urdf, tip_link, ...}, right: ...}} (docs/cells.md)")
    place: bool = Field(True, description="search the job's placement on the table (cell)")
    min_joint_margin: float = Field(
        5.0, ge=0, lt=90, allow_inf_nan=False,
        description="smallest distance of every joint from its limits at every target [deg]: "
        "a program closer fails (any cell)")
    programs: list[ProgramName] | None = Field(
        None, description="robot programs `dloplan plan` writes (default all the cell takes)")
    urscript: UrscriptSpec = Field(default_factory=UrscriptSpec)
    ur_rtde: UrRtdeSpec = Field(default_factory=UrRtdeSpec)
    gripper: GripperIoSpec = Field(default_factory=GripperIoSpec)
    ros_joints: RosJointsSpec = Field(default_factory=RosJointsSpec)

    base_position: Vector3 = Field(
        default_factory=lambda: [0.0, 0.0, 0.0],
        description="robot base origin in the plan's frame [units]; default: the YuMi standing "
        "on the table, 0.1 m above it over the plan's origin (no table: the origin)")
    base_rotation: RotationSpec | None = None
    wobj: str = Field("dlo_wobj", description="wobjdata name of the plan's frame")
    tools: list[ToolSpec] = Field(default_factory=lambda: [ToolSpec(), ToolSpec()],
                                  min_length=2, max_length=2, description="left, right")
    approach: float | None = Field(None, ge=0, allow_inf_nan=False,
                                   description="approach/retreat distance [units]; 5 cm")
    hold_force: float | None = Field(None, gt=0, le=20, description="SmartGripper [N]")
    arm_angle_reference: list[Vector3] | None = Field(
        None, min_length=2, max_length=2,
        description="YuMi: the controller's Arm-Angle Reference Direction of the left and the "
        "right arm, in the robot's base frame (default [0, -1, 0], [0, 1, 0]; docs/robot.md)")

    @field_validator("base_position")
    @classmethod
    def _pos(cls, v):
        return _finite(v, "base_position")


class RepairSpec(JobModel):
    """What a repair may change without asking (docs/repair.md, "Consent")."""

    placement: bool = Field(
        False, description="move or turn the job on the table where the robot reaches it (the "
        "robot program then says where to place it); false: such a move is only proposed")


class JobSpec(JobModel):
    """What every job file has: units, the cable, its start, planner, obstacles, robot motion."""

    version: Literal[1] = 1
    units: Literal["m", "mm"] = "m"
    cable: CableSpec
    start: ShapeSpec
    planner: PlannerSpec = Field(default_factory=PlannerSpec)
    obstacles: list[ObstacleSpec] = Field(default_factory=list)
    table: TableSpec | None = None
    grippers: GripperSpec = Field(default_factory=GripperSpec)
    trajectory: TrajectorySpec = Field(default_factory=TrajectorySpec)
    check: CheckSpec = Field(default_factory=CheckSpec)
    robot: RobotSpec = Field(default_factory=RobotSpec)

    @property
    def scale(self) -> float:
        """Metres per file unit."""
        return 1e-3 if self.units == "mm" else 1.0


_TAGS = {"points", "straight", "arc", "sine", "box", "cylinder"}


def format_validation_error(error: ValidationError) -> str:
    """The first error of a pydantic validation as one line: field path, message, value."""
    first = error.errors()[0]
    parts = [str(p) for p in first["loc"] if not str(p).startswith("function-")]
    # drop the union tags pydantic inserts (start.arc.angle -> start.angle)
    parts = [p for k, p in enumerate(parts) if not (p in _TAGS and k + 1 < len(parts))]
    loc = ".".join(parts)
    message = first["msg"].removeprefix("Value error, ")
    value = first.get("input")
    long = isinstance(value, dict | list) and len(str(value)) > 60
    shown = "" if long or "got " in message else f" (got {value!r})"  # the value once
    extra = "" if len(error.errors()) == 1 else f" [and {len(error.errors()) - 1} more]"
    return f"{loc or 'scenario'}: {message}{shown}{extra}"


def parse_model(model: type[BaseModel], data: Any, source: str):
    """Validate a mapping as ``model``; raises :class:`ScenarioError` (one line)."""
    if not isinstance(data, dict):
        raise ScenarioError(f"{source}: expected a mapping at the top level, got "
                            f"{type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(f"{source}: {format_validation_error(exc)}") from None
