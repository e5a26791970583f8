"""The plan document: one versioned JSON file that every command and every output reads.

:class:`PlanDocument` is the plan as data, with a typed section per concern: the cable, the
planned shapes, the gripper frames, the timed trajectory, and what the pipeline computed on them
(planner stages and forces, stabilized shapes and clip wrenches, target check, obstacle
re-planning, twist, verification, identification, harness summary). :func:`document_to_dict` and
:func:`document_from_dict` are its only writer and reader (format ``"dloplan-plan"``,
:data:`PLAN_VERSION`); version 1 files (whose computed sections sat in a free-form ``extra``
mapping) still load. Poses are ``geometry_msgs/PoseStamped`` shaped; floats are written with
Python's shortest round-tripping repr and quaternions canonical (w >= 0), so a document read back
is the document written. Every other output (CSV, ROS, RAPID, figures, report) is made from this
document by a writer of :mod:`dloplan.app.writers`. The file itself (:func:`dloplan.app.write_plan`,
:func:`dloplan.app.read_plan`) is the application's: this module turns the document into plain
JSON-ready data and back (:func:`document_to_dict`, :func:`document_from_dict`).
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass, field, fields

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import Cable
from ..geometry import as_path
from ..grippers.axes import CLIP_NAMES
from ..grippers.path import GripperPath
from ..io.poses import (
    DEFAULT_FRAME_ID,
    canonical_quaternions,
    check_frame_id,
    duration_dict,
    pose_stamped_dict,
    pose_stamped_from_dict,
)
from ..obstacles.shapes import Box, Cylinder, Table
from ..planning.result import ForceStatistics
from ..trajectory import ARMS, MotionLimits, Profile, TimeLaw, Trajectory

PLAN_FORMAT = "dloplan-plan"
PLAN_VERSION = 2
"""Version written by :func:`write_plan`; the reader accepts 1 and 2."""


def cable_to_dict(cable: Cable) -> dict:
    """Every field of a :class:`Cable` as JSON-ready values (rest_shape as nested lists or None)."""
    out = {}
    for f in fields(cable):
        value = getattr(cable, f.name)
        out[f.name] = np.asarray(value).tolist() if isinstance(value, np.ndarray) else value
    return out


def _stamped_poses(positions: np.ndarray, rotations: Rotation, frame_id: str) -> list[dict]:
    quats = canonical_quaternions(rotations)
    return [pose_stamped_dict(p, q, frame_id) for p, q in zip(positions, quats, strict=True)]


def _grippers_section(grippers: GripperPath, frame_id: str) -> dict:
    return {
        "method": grippers.method,
        "success": grippers.success,
        "message": grippers.message,
        "max_twist": grippers.max_twist,
        "twist": grippers.twist.tolist(),
        "warnings": list(grippers.warnings),
        "clips": {
            name: _stamped_poses(grippers.positions[:, c], grippers.rotations[c], frame_id)
            for c, name in enumerate(CLIP_NAMES)
        },
    }


def _trajectory_section(trajectory: Trajectory, frame_id: str) -> dict:
    poses = [
        _stamped_poses(trajectory.positions[:, a], trajectory.rotations[a], frame_id)
        for a in (0, 1)
    ]
    return {
        "joint_names": [f"{arm}_tcp" for arm in ARMS],
        "arm_clips": [CLIP_NAMES[c] for c in trajectory.arm_clips],
        "max_speed": trajectory.max_speed,
        "max_angular_speed": trajectory.max_angular_speed,
        "duration": trajectory.duration,
        "law": None if trajectory.law is None else law_to_dict(trajectory.law),
        "points": [
            {"time": float(t), "time_from_start": duration_dict(t), "poses": [left, right]}
            for t, left, right in zip(trajectory.times, *poses, strict=True)
        ],
    }


def _get(mapping, key: str, where: str, kind=None):
    if not isinstance(mapping, dict) or key not in mapping:
        raise ValueError(f"{where}: missing {key!r}")
    value = mapping[key]
    if kind is not None and not isinstance(value, kind):
        raise ValueError(f"{where}.{key}: got {type(value).__name__}, expected {kind}")
    return value


def _read_poses(items, where: str, frame_id: str) -> tuple[np.ndarray, Rotation]:
    if not isinstance(items, list) or not items:
        raise ValueError(f"{where}: expected a non-empty list of poses")
    positions, quats = [], []
    for i, item in enumerate(items):
        pos, quat, frame = pose_stamped_from_dict(item, f"{where}[{i}]")
        if frame != frame_id:
            raise ValueError(f"{where}[{i}].header.frame_id: got {frame!r}, expected {frame_id!r}")
        positions.append(pos)
        quats.append(quat)
    return np.array(positions), Rotation.from_quat(np.array(quats))


def _read_grippers(section: dict, frame_id: str) -> GripperPath:
    where = "grippers"
    clips = _get(section, "clips", where, dict)
    read = [
        _read_poses(_get(clips, name, f"{where}.clips"), f"{where}.clips.{name}", frame_id)
        for name in CLIP_NAMES
    ]
    return GripperPath(
        positions=np.stack([read[0][0], read[1][0]], axis=1),
        rotations=(read[0][1], read[1][1]),
        method=_get(section, "method", where, str),
        twist=np.asarray(_get(section, "twist", where, list), dtype=float),
        warnings=tuple(_get(section, "warnings", where, list)),
        success=bool(_get(section, "success", where, bool)),
        message=_get(section, "message", where, str),
        max_twist=float(_get(section, "max_twist", where, int | float)),
    )


def _read_trajectory(section: dict, frame_id: str) -> Trajectory:
    where = "trajectory"
    points = _get(section, "points", where, list)
    if not points:
        raise ValueError(f"{where}.points: empty")
    times = [
        float(_get(p, "time", f"{where}.points[{i}]", int | float)) for i, p in enumerate(points)
    ]
    arms = []
    for a, arm in enumerate(ARMS):
        poses = []
        for i, p in enumerate(points):
            pair = _get(p, "poses", f"{where}.points[{i}]", list)
            if len(pair) != 2:
                raise ValueError(f"{where}.points[{i}].poses: expected 2 poses (left, right)")
            poses.append(pair[a])
        arms.append(_read_poses(poses, f"{where}.points[*].poses[{a}] ({arm})", frame_id))
    clip_names = _get(section, "arm_clips", where, list)
    if sorted(clip_names) != sorted(CLIP_NAMES):
        raise ValueError(
            f"{where}.arm_clips: got {clip_names!r}, expected a permutation of {CLIP_NAMES}"
        )
    speeds = {name: _get(section, name, where, int | float)
              for name in ("max_speed", "max_angular_speed")}
    law = None if section.get("law") is None else law_from_dict(section["law"], where)
    try:
        return Trajectory(times=np.array(times),
                          positions=np.stack([arms[0][0], arms[1][0]], axis=1),
                          rotations=(arms[0][1], arms[1][1]), **speeds,
                          arm_clips=tuple(CLIP_NAMES.index(c) for c in clip_names), law=law)
    except ValueError as exc:  # the trajectory's own checks name its fields: say where it is
        raise ValueError(f"{where}.{exc}") from None


def law_to_dict(law: TimeLaw) -> dict:
    """A trajectory's time law as JSON-ready data: every segment's jerk-limited profile, the
    knot instants, zones and limits, so a plan read back moves exactly as it was planned."""
    return {"kind": law.kind, "starts": law.starts.tolist(),
            "knot_times": law.knot_times.tolist(), "zones": law.zones.tolist(),
            "limits": None if law.limits is None else section_to_dict(law.limits),
            "speed_scale": None if law.speed_scale is None else law.speed_scale.tolist(),
            "profiles": [section_to_dict(p) for p in law.profiles]}


def law_from_dict(data: dict, where: str) -> TimeLaw:
    """The :class:`~dloplan.trajectory.TimeLaw` of :func:`law_to_dict`'s data."""
    where = f"{where}.law"
    try:
        return TimeLaw(
            starts=np.asarray(data["starts"], float),
            profiles=tuple(section_from_dict(Profile, p, f"{where}.profiles[{k}]")
                           for k, p in enumerate(data["profiles"])),
            knot_times=np.asarray(data["knot_times"], float),
            zones=np.asarray(data["zones"], float), kind=data["kind"],
            limits=None if data["limits"] is None else MotionLimits(**data["limits"]),
            speed_scale=None if data["speed_scale"] is None else
            np.asarray(data["speed_scale"], float))
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{where}: {exc}") from None

# -- the typed sections --------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Stages:
    """The planner's stages (thesis chapter 4).

    Attributes
    ----------
    basic, advanced : numpy.ndarray
        (S + 2, n + 1, 3) paths of the geometric stages [m].
    lengths : numpy.ndarray
        (3, S + 2) cable length of every shape after the basic, advanced, physical stage [m].
    family : str
        The stiffness family of the cable (the weights' row of Table 6.2).
    weights_used : bool
        Whether the family's physical weights shaped the plan ("thesis" physical mode); in the
        "equilibrium" mode the family only labels the cable.
    physical_mode : str
        "equilibrium" or "thesis".
    timings : dict
        Wall time per stage [s].
    """

    basic: np.ndarray
    advanced: np.ndarray
    lengths: np.ndarray
    family: str
    weights_used: bool
    physical_mode: str
    timings: dict = field(default_factory=dict)


@dataclass(frozen=True)
class TargetCheckSection:
    """The target's stability check (thesis 5.3): largest point displacement vs T_cf [m]."""

    stable: bool
    max_displacement: float
    threshold: float
    message: str


@dataclass(frozen=True, eq=False)
class TwistSection:
    """Twist the gripper frames put into the cable, per shape (:func:`dloplan.twist_along_path`).

    Attributes
    ----------
    twist, relative_twist : numpy.ndarray
        (S + 2,) total twist between the clips, and its change from the start [rad].
    twist_energy : numpy.ndarray
        (S + 2,) twist energy [J].
    gripper_relative_twist : numpy.ndarray
        (S + 2,) relative rotation of the clips about the cable (from the frames alone) [rad].
    message : str
    """

    twist: np.ndarray
    relative_twist: np.ndarray
    twist_energy: np.ndarray
    gripper_relative_twist: np.ndarray
    message: str


@dataclass(frozen=True)
class AvoidanceSection:
    """Obstacle re-planning (thesis 5.4): status, rounds, collisions before and after."""

    status: str
    rounds: int
    message: str
    before: tuple = ()
    after: tuple = ()

    @property
    def colliding_after(self) -> list[int]:
        """Indices of the shapes that still collide after re-planning."""
        return [row["shape"] for row in self.after if row["colliding"]]


@dataclass(frozen=True)
class VerificationSection:
    """The plan verification (:func:`~dloplan.verify.verify_path`): verdict, messages, table;
    for a wire-harness plan one row per phase (``phases``,
    :class:`~dloplan.harness.verification.PhaseRow` fields) instead of one per shape."""

    ok: bool
    messages: tuple[str, ...]
    rows: tuple = ()
    timings: dict = field(default_factory=dict)
    phases: tuple = ()

    def table(self) -> str:
        """The table as fixed-width text (:meth:`dloplan.verify.Verification.table`, or the
        harness plan's :func:`~dloplan.harness.verification.phase_table`)."""
        if self.phases:
            from ..harness.verification import PhaseRow, phase_table

            return phase_table([PhaseRow(**{**row, "notes": tuple(row.get("notes", ()))})
                                for row in self.phases], self.ok, self.messages)
        from ..verify.report import ShapeRow, Verification

        rows = tuple(ShapeRow(**row) for row in self.rows)
        return Verification(rows, self.ok, self.messages, self.timings).table()


@dataclass(frozen=True)
class IdentificationSection:
    """How the cable's E was identified (thesis 6.1) before planning, with the n it used."""

    youngs_modulus: float
    confidence_interval: tuple[float, float]
    simulations: int
    rms_error: float
    informative: bool
    message: str
    n_links: int = 0


@dataclass(frozen=True)
class RobotSection:
    """The robot program of the plan and its checks (:func:`dloplan.robot.robot_program`).

    Attributes
    ----------
    ok : bool
        Every check of the program passed (reach, joint limits, clearance, continuity, ...).
    message : str
        One line: passed with its key numbers, or the first failure of each failing check.
    cell : dict
        The robot cell the program was made for (:func:`cell_to_dict`).
    program : dict
        The program as written (:meth:`dloplan.robot.RobotProgram.to_dict`): on the YuMi
        the arm assignment, targets with their verified joints, confdata and arm angles; on a
        described cell the placement offset, the assignment, the targets' TCP poses and
        verified joints; the checks' summary and rows.
    """

    ok: bool
    message: str
    cell: dict
    program: dict


@dataclass(frozen=True, eq=False)
class PlacementSection:
    """Where the job must lie on the table: the job file's start and target turned by ``yaw``
    about the vertical through ``pivot``, then shifted by ``offset``,
    x -> R_z(yaw) (x - pivot) + pivot + offset (the repair's
    :class:`~dloplan.pipeline.repair.placement.TableMove`; docs/repair.md, "Consent").

    Attributes
    ----------
    applied : bool
        True: the plan is made for the moved job (allowed by ``repair: {placement: true}`` or
        ``--allow-placement``), and the cable must be placed so for its robot program. False:
        proposed only; the plan is the job where the file puts it, and it fails its robot check.
    yaw : float
        Turn about the vertical [rad].
    pivot : numpy.ndarray
        (3,) a point of the vertical axis of the turn [m].
    offset : numpy.ndarray
        (3,) shift after the turn [m].
    message : str
        Where the job goes, in words ("the job file's start and target turned ...").
    """

    applied: bool
    yaw: float
    pivot: np.ndarray
    offset: np.ndarray
    message: str


def cell_to_dict(cell) -> dict:
    """A cell as JSON-ready data: :meth:`~dloplan.robot.RobotCell.to_dict` (quaternions
    x-y-z-w), a :class:`~dloplan.robot.urdf_cell.DescribedCell` as its record (``kind:
    described``)."""
    return cell.to_dict()


def document_cell(doc: PlanDocument):
    """The robot cell a plan document was made for: its recorded cell, else the default YuMi
    (a plan made without robot checks)."""
    from ..robot.cell import RobotCell

    return RobotCell() if doc.robot is None else cell_from_dict(doc.robot.cell)


def program_offset(doc: PlanDocument) -> np.ndarray:
    """(3,) [m] how far a described cell's placement runs the job from the plan's shapes (the
    recorded program's ``offset``); zeros on the YuMi (its placement moves the plan itself) and
    without a program."""
    record = None if doc.robot is None else doc.robot.program
    return np.asarray((record or {}).get("offset", np.zeros(3)), dtype=float)


def cell_from_dict(data: dict, where: str = "plan.robot.cell"):
    """The cell of :func:`cell_to_dict`'s data: a described cell for ``kind: described`` (its
    URDF files must still be where the plan was made), else the YuMi's RobotCell."""
    from ..robot import cell, urdf_cell

    described = isinstance(data, dict) and data.get("kind") == "described"
    try:
        return (urdf_cell if described else cell).cell_from_record(data)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


@dataclass(frozen=True, eq=False)
class PlanDocument:
    """A plan as data (see the module docstring). Only ``cable`` and ``shapes`` are required.

    Attributes
    ----------
    cable : Cable
    shapes : numpy.ndarray
        (S + 2, n + 1, 3) planned shapes [m].
    grippers : GripperPath or None
        Both clip frames for every shape.
    trajectory : Trajectory or None
        The timed dual-arm motion, one knot per shape.
    warnings : tuple of str
        Everything the user should look at.
    source : str
        The job file the plan was made from.
    obstacles : tuple
        The obstacles the plan avoids (Box, Cylinder, Table) [m].
    stabilized : numpy.ndarray or None
        (S + 2, n + 1, 3) every shape settled under gravity with its clips held [m].
    clip_wrenches : numpy.ndarray or None
        (S + 2, 2, 6) force [N] and moment [N m] on each clip of each stabilized shape.
    stages : Stages or None
    forces : dict
        Phase name -> :class:`~dloplan.planning.result.ForceStatistics` per mass point
        ("physical" for a plan; one per phase for a harness job).
    target_check, twist, avoidance, verification, identification : sections or None
    harness : dict or None
        The wire-harness job's numbers (:func:`dloplan.harness.harness_summary`).
    robot : RobotSection or None
        The verified robot program (None when the plan was made without robot checks).
    repairs : tuple of dict
        The repairs the plan went through after a failed check (:mod:`dloplan.pipeline.repair`):
        what failed, what was changed, the check before and after.
    placement : PlacementSection or None
        Where the job must lie on the table when a repair moved it (or proposes to move it).
    cycle : dict or None
        The timeline with gripper actions (:class:`dloplan.trajectory.Cycle`): ``phases``
        (name, kind, start, duration, knots), ``motion_time``, ``action_time``,
        ``cycle_time`` [s].
    correction : dict or None
        A closed-loop correction's report (:meth:`dloplan.correct.Correction.report`) when the
        document is a corrected plan (``dloplan correct``).
    program : RobotProgram or None
        The program object itself, kept in memory after planning so the writers do not solve
        it again (not written; a document read from a file rebuilds it from ``robot.cell``,
        the gripper path and the trajectory, and checks it against ``robot.program``).
    timings : dict
        Wall time per pipeline step [s].
    frame_id : str
        The frame of every pose.
    version : int
        The format version the document was read from.
    """

    cable: Cable
    shapes: np.ndarray
    grippers: GripperPath | None = None
    trajectory: Trajectory | None = None
    warnings: tuple[str, ...] = ()
    source: str = ""
    obstacles: tuple = ()
    stabilized: np.ndarray | None = None
    clip_wrenches: np.ndarray | None = None
    stages: Stages | None = None
    forces: dict = field(default_factory=dict)
    target_check: TargetCheckSection | None = None
    twist: TwistSection | None = None
    avoidance: AvoidanceSection | None = None
    verification: VerificationSection | None = None
    identification: IdentificationSection | None = None
    harness: dict | None = None
    robot: RobotSection | None = None
    repairs: tuple = ()
    placement: PlacementSection | None = None
    cycle: dict | None = None
    correction: dict | None = None
    timings: dict = field(default_factory=dict)
    frame_id: str = DEFAULT_FRAME_ID
    version: int = PLAN_VERSION
    program: object = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.cable, Cable):
            raise ValueError(f"cable: expected a Cable, got {type(self.cable).__name__}")
        check_frame_id(self.frame_id)
        shapes = as_path(self.shapes, name="shapes")
        if shapes.shape[1] != self.cable.n_points:
            raise ValueError(f"shapes: {shapes.shape[1]} points per shape, expected "
                             f"cable.n_points = {self.cable.n_points}")
        object.__setattr__(self, "shapes", shapes)
        k = len(shapes)
        if self.grippers is not None and self.grippers.n_shapes != k:
            raise ValueError(f"grippers: {self.grippers.n_shapes} shapes, expected {k} "
                             "(one per shape)")
        if self.trajectory is not None and self.trajectory.n_knots != k:
            raise ValueError(f"trajectory: {self.trajectory.n_knots} knots, expected {k} "
                             "(one per shape)")
        if self.stabilized is not None:
            object.__setattr__(self, "stabilized", as_path(self.stabilized, self.cable.n_points,
                                                           "stabilized"))
            if len(self.stabilized) != k:
                raise ValueError(f"stabilized: {len(self.stabilized)} shapes, expected {k}")
        if isinstance(self.warnings, str) or not all(isinstance(w, str) for w in self.warnings):
            raise ValueError("warnings: expected a sequence of strings")
        object.__setattr__(self, "warnings", tuple(self.warnings))

    @property
    def n_shapes(self) -> int:
        """S, the number of intermediate shapes."""
        return len(self.shapes) - 2

    @property
    def ok(self) -> bool:
        """No failure recorded: obstacles cleared, verification passed (warnings allowed)."""
        return not self.failed_checks

    @property
    def failed_checks(self) -> list[str]:
        """The checks recorded as failed: harness, obstacles, robot program, verification."""
        failed = {"harness": self.harness is not None and not self.harness.get("success", True),
                  "obstacles": self.avoidance is not None
                  and self.avoidance.status not in ("clear", "replanned"),
                  "robot program": self.robot is not None and not self.robot.ok,
                  "verification": self.verification is not None and not self.verification.ok}
        return [name for name, failing in failed.items() if failing]

    def clip_poses(self) -> list:
        """Clip poses of every shape: the gripper frames, or read off the shapes."""
        from ..sim.clips import clip_poses_from_shape

        if self.grippers is not None:
            return [self.grippers.clip_poses(k) for k in range(len(self.shapes))]
        return [clip_poses_from_shape(shape) for shape in self.shapes]


# -- plain values <-> JSON ------------------------------------------------------------------------
def _plain(value):
    """A section value as JSON-ready data (arrays as nested lists, tuples as lists)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def section_to_dict(section) -> dict | None:
    """A section dataclass as a JSON-ready dict (None stays None)."""
    if section is None:
        return None
    return {f.name: _plain(getattr(section, f.name)) for f in fields(section)}


def section_from_dict(kind, data, where: str):
    """The section ``kind`` from its dict; arrays and tuples restored by their annotation."""
    if data is None:
        return None
    if not isinstance(data, dict):
        raise ValueError(f"{where}: expected a mapping, got {type(data).__name__}")
    values = {}
    for f in fields(kind):
        if f.name not in data:
            if f.default is not MISSING or f.default_factory is not MISSING:  # optional
                continue
            raise ValueError(f"{where}: missing {f.name!r}")
        value = data[f.name]
        if "np.ndarray" in str(f.type):
            value = np.asarray(value, dtype=float)
        elif str(f.type).startswith("tuple"):
            value = tuple(value)
        values[f.name] = value
    try:
        return kind(**values)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}: {exc}") from None


def _obstacle_to_dict(obstacle) -> dict:
    return {"type": type(obstacle).__name__.lower(), **section_to_dict(obstacle)}


def _obstacle_from_dict(data: dict, where: str):
    kinds = {"box": Box, "cylinder": Cylinder, "table": Table}
    kind = kinds.get(data.get("type")) if isinstance(data, dict) else None
    if kind is None:
        raise ValueError(f"{where}.type: expected one of {', '.join(kinds)}")
    values = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items() if k != "type"}
    try:
        return kind(**values)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}: {exc}") from None


def document_to_dict(doc: PlanDocument) -> dict:
    """The plan document as JSON-ready data (the file's layout, see ``docs/plan-format.md``)."""
    frame_id = doc.frame_id
    return {
        "format": PLAN_FORMAT,
        "version": PLAN_VERSION,
        "units": {"length": "m", "time": "s", "angle": "rad", "mass": "kg", "pressure": "Pa",
                  "force": "N"},
        "quaternion_order": "xyzw",
        "frame_id": frame_id,
        "source": doc.source,
        "cable": cable_to_dict(doc.cable),
        "shapes": doc.shapes.tolist(),
        "grippers": None if doc.grippers is None else _grippers_section(doc.grippers, frame_id),
        "trajectory": None if doc.trajectory is None else
        _trajectory_section(doc.trajectory, frame_id),
        "warnings": list(doc.warnings),
        "obstacles": [_obstacle_to_dict(o) for o in doc.obstacles],
        "stabilized": None if doc.stabilized is None else doc.stabilized.tolist(),
        "clip_wrenches": None if doc.clip_wrenches is None else _plain(doc.clip_wrenches),
        "stages": section_to_dict(doc.stages),
        "forces": {name: section_to_dict(stats) for name, stats in doc.forces.items()},
        "target_check": section_to_dict(doc.target_check),
        "twist": section_to_dict(doc.twist),
        "avoidance": section_to_dict(doc.avoidance),
        "verification": section_to_dict(doc.verification),
        "identification": section_to_dict(doc.identification),
        "harness": _plain(doc.harness),
        "robot": section_to_dict(doc.robot),
        "repairs": _plain(doc.repairs),
        "placement": section_to_dict(doc.placement),
        "cycle": _plain(doc.cycle),
        "correction": _plain(doc.correction),
        "timings": _plain(doc.timings),
    }


def _version_1_sections(extra: dict) -> dict:
    """The typed sections of a version 1 document's ``extra`` mapping."""
    sections: dict = {}
    if "stabilized" in extra:
        sections["stabilized"] = extra["stabilized"]
    if "clip_wrenches" in extra:
        sections["clip_wrenches"] = extra["clip_wrenches"]
    if "stages" in extra and "lengths" in extra:
        lengths = extra["lengths"]
        sections["stages"] = {
            "basic": extra["stages"]["basic"], "advanced": extra["stages"]["advanced"],
            "lengths": [lengths["basic"], lengths["advanced"], lengths["physical"]],
            "family": extra.get("family", ""), "weights_used":
                extra.get("physical_mode") == "thesis",
            "physical_mode": extra.get("physical_mode", "equilibrium")}
    if "forces" in extra:
        sections["forces"] = {"physical": extra["forces"]}
    if "harness" in extra:
        sections["harness"] = extra["harness"]
        sections["forces"] = extra["harness"].get("forces", {})
    for key in ("target_check", "identification", "verification", "timings"):
        if key in extra:
            sections[key] = extra[key]
    if "twist" in extra:
        sections["twist"] = {**extra["twist"], "gripper_relative_twist":
                             extra.get("gripper_relative_twist", extra["twist"]["twist"])}
    if "obstacles" in extra:
        sections["avoidance"] = extra["obstacles"]
    if "scenario" in extra:
        sections["source"] = extra["scenario"]
    return sections


def document_from_dict(data: dict) -> PlanDocument:
    """The :class:`PlanDocument` of a plan file's data (inverse of :func:`document_to_dict`).

    Raises
    ------
    ValueError
        For another format, an unknown version, or a missing or malformed field (named by its
        path in the document).
    """
    if not isinstance(data, dict) or data.get("format") != PLAN_FORMAT:
        raise ValueError(
            f"plan: not a {PLAN_FORMAT!r} document (its 'format' field is missing or different)"
        )
    version = _get(data, "version", "plan", int)
    if not 1 <= version <= PLAN_VERSION:
        raise ValueError(
            f"plan.version: got {version}, this dloplan reads versions 1..{PLAN_VERSION}"
        )
    frame_id = check_frame_id(_get(data, "frame_id", "plan"))
    cable_fields = dict(_get(data, "cable", "plan", dict))
    if cable_fields.get("rest_shape") is not None:
        cable_fields["rest_shape"] = np.asarray(cable_fields["rest_shape"], dtype=float)
    try:
        cable = Cable(**cable_fields)
    except TypeError as exc:
        raise ValueError(f"plan.cable: {exc}") from exc
    sections = _version_1_sections(data.get("extra") or {}) if version == 1 else data
    grippers, trajectory = data.get("grippers"), data.get("trajectory")
    forces = sections.get("forces") or {}
    if not isinstance(forces, dict):
        raise ValueError("plan.forces: expected a mapping of phase -> statistics")
    wrenches = sections.get("clip_wrenches")
    return PlanDocument(
        cable=cable,
        shapes=as_path(_get(data, "shapes", "plan", list), name="plan.shapes"),
        grippers=None if grippers is None else _read_grippers(grippers, frame_id),
        trajectory=None if trajectory is None else _read_trajectory(trajectory, frame_id),
        warnings=tuple(str(w) for w in _get(data, "warnings", "plan", list)),
        source=str(sections.get("source") or ""),
        obstacles=tuple(_obstacle_from_dict(o, f"plan.obstacles[{k}]")
                        for k, o in enumerate(sections.get("obstacles") or [])),
        stabilized=sections.get("stabilized"),
        clip_wrenches=None if wrenches is None else np.asarray(wrenches, dtype=float),
        stages=section_from_dict(Stages, sections.get("stages"), "plan.stages"),
        forces={name: section_from_dict(ForceStatistics, stats, f"plan.forces.{name}")
                for name, stats in forces.items()},
        target_check=section_from_dict(TargetCheckSection, sections.get("target_check"),
                                       "plan.target_check"),
        twist=section_from_dict(TwistSection, sections.get("twist"), "plan.twist"),
        avoidance=section_from_dict(AvoidanceSection, sections.get("avoidance"),
                                    "plan.avoidance"),
        verification=section_from_dict(VerificationSection, sections.get("verification"),
                                       "plan.verification"),
        identification=section_from_dict(IdentificationSection,
                                         sections.get("identification"), "plan.identification"),
        harness=sections.get("harness"),
        robot=section_from_dict(RobotSection, sections.get("robot"), "plan.robot"),
        repairs=tuple(sections.get("repairs") or ()),
        placement=section_from_dict(PlacementSection, sections.get("placement"),
                                    "plan.placement"),
        cycle=sections.get("cycle"),
        correction=sections.get("correction"),
        timings=dict(sections.get("timings") or {}),
        frame_id=frame_id,
        version=version,
    )


def cycle_to_dict(cycle) -> dict:
    """A :class:`~dloplan.trajectory.Cycle` as the document's ``cycle`` section: its phases,
    times and gripper ``actions`` (name, knot, duration, opening [s])."""
    return {"phases": [section_to_dict(p) for p in cycle.phases],
            "actions": [section_to_dict(a) for a in cycle.actions],
            "motion_time": cycle.motion_time, "action_time": cycle.action_time,
            "cycle_time": cycle.cycle_time, "breakdown": cycle.breakdown()}


def cycle_actions(section: dict | None) -> tuple:
    """The gripper actions (:class:`~dloplan.trajectory.GripperAction`) of a document's
    ``cycle`` section, in the order they run; a document written before the section listed
    them gives its grasp and release phases.

    Raises
    ------
    ValueError
        A malformed section, or a regrasp of an older document (its opening part was not
        recorded: plan again).
    """
    from ..trajectory import GripperAction

    if section is None:
        return ()
    try:
        if "actions" in section:
            return tuple(GripperAction(a["name"], a["knot"], a["duration"], a["opening"])
                         for a in section["actions"])
        return tuple(GripperAction(p["name"], p["knots"][0], p["duration"])
                     for p in section["phases"] if p["kind"] == "action")
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"plan.cycle.actions: malformed ({exc}); plan again") from None
