"""Plan documents and trajectory exports: versioned plan JSON, ROS 2 trajectory, CSV.

* :func:`write_plan_json` / :func:`read_plan_json`: the whole plan (cable, shapes, clip poses,
  timed trajectory, warnings, extra sections) as a versioned JSON document (format
  ``"dloplan-plan"``, :data:`PLAN_VERSION`) whose poses are ``geometry_msgs/PoseStamped``
  shaped; reading it back gives the same plan (floats are written with Python's shortest
  round-tripping repr, quaternions canonical with w >= 0).
* :func:`write_ros_trajectory`: the trajectory as a ``trajectory_msgs/MultiDOFJointTrajectory``
  message (YAML or JSON) with two "joints" ``left_tcp`` and ``right_tcp``.
* :func:`write_trajectory_csv`: the trajectory sampled at a rate, one row per sample.

All files are written atomically (:mod:`dloplan.io.files`); the RAPID program is in
:mod:`dloplan.io.rapid`. See ``docs/grippers-and-exports.md`` for the formats with examples.
"""

from __future__ import annotations

import io
import json
import os
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from ..cable import Cable
from ..grippers.axes import CLIP_NAMES
from ..grippers.path import GripperPath
from ..physics.geometry import as_path
from ..trajectory import ARMS, Trajectory
from .files import atomic_write_text
from .poses import (
    canonical_quaternions,
    duration_dict,
    pose_stamped_dict,
    pose_stamped_from_dict,
    transform_dict,
)

PLAN_FORMAT = "dloplan-plan"
PLAN_VERSION = 1
"""Version of the plan document written by :func:`plan_document`; the reader accepts <= it."""

DEFAULT_FRAME_ID = "world"
DEFAULT_CSV_RATE = 100.0
"""Default sampling rate [Hz] of the CSV export."""


@dataclass(frozen=True, eq=False)
class PlanDocument:
    """The pieces of a plan read back from a plan document.

    Parameters
    ----------
    cable : Cable
    shapes : numpy.ndarray
        (S + 2, n + 1, 3) planned shapes [m].
    grippers : GripperPath or None
    trajectory : Trajectory or None
    warnings : tuple of str
        The plan's warnings.
    extra : dict
        Further sections, as written.
    frame_id : str
        The frame all positions and orientations are expressed in.
    version : int
        The document's format version.
    """

    cable: Cable
    shapes: np.ndarray
    grippers: GripperPath | None = None
    trajectory: Trajectory | None = None
    warnings: tuple[str, ...] = ()
    extra: dict = field(default_factory=dict)
    frame_id: str = DEFAULT_FRAME_ID
    version: int = PLAN_VERSION


# -- writing -----------------------------------------------------------------------------------
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
        "points": [
            {"time": float(t), "time_from_start": duration_dict(t), "poses": [left, right]}
            for t, left, right in zip(trajectory.times, *poses, strict=True)
        ],
    }


def _json_default(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serializable: {type(value).__name__}")


def _check_frame_id(frame_id) -> str:
    if not isinstance(frame_id, str) or not frame_id.strip():
        raise ValueError(f"frame_id: got {frame_id!r}, expected a non-empty string")
    return frame_id


def plan_document(
    cable: Cable,
    shapes,
    grippers: GripperPath | None = None,
    trajectory: Trajectory | None = None,
    warnings=(),
    extra: dict | None = None,
    *,
    frame_id: str = DEFAULT_FRAME_ID,
) -> dict:
    """The plan as a JSON-ready dict (see ``docs/grippers-and-exports.md``).

    Parameters
    ----------
    cable : Cable
    shapes : array_like
        (S + 2, n + 1, 3) planned shapes [m], n + 1 = ``cable.n_points``.
    grippers : GripperPath, optional
        Clip poses, one per shape.
    trajectory : Trajectory, optional
        The timed dual-arm trajectory, one knot per shape.
    warnings : sequence of str
        The plan's warnings.
    extra : dict, optional
        More top-level sections (JSON-serializable; numpy arrays become lists), under "extra".
    frame_id : str
        The frame of all poses (the robot's world / work-object frame).

    Raises
    ------
    ValueError
        When the pieces do not fit together (point or shape counts) or ``extra`` is not
        JSON-serializable.
    """
    if not isinstance(cable, Cable):
        raise ValueError(f"cable: expected a Cable, got {type(cable).__name__}")
    frame_id = _check_frame_id(frame_id)
    x = as_path(shapes, name="shapes")
    if x.shape[1] != cable.n_points:
        raise ValueError(
            f"shapes: {x.shape[1]} points per shape, expected cable.n_points = {cable.n_points}"
        )
    if grippers is not None and grippers.n_shapes != len(x):
        raise ValueError(f"grippers: {grippers.n_shapes} shapes, expected {len(x)} (one per shape)")
    if trajectory is not None and trajectory.n_knots != len(x):
        raise ValueError(
            f"trajectory: {trajectory.n_knots} knots, expected {len(x)} (one per shape)"
        )
    if isinstance(warnings, str):
        raise ValueError("warnings: expected a sequence of strings, got one string")
    warnings = list(warnings or ())
    if not all(isinstance(w, str) for w in warnings):
        raise ValueError("warnings: expected a sequence of strings")
    extra = {} if extra is None else extra
    if not isinstance(extra, dict):
        raise ValueError(f"extra: expected a dict, got {type(extra).__name__}")
    try:
        extra = json.loads(json.dumps(extra, default=_json_default, allow_nan=False))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"extra: not JSON-serializable ({exc})") from exc
    return {
        "format": PLAN_FORMAT,
        "version": PLAN_VERSION,
        "units": {"length": "m", "time": "s", "angle": "rad", "mass": "kg", "pressure": "Pa"},
        "quaternion_order": "xyzw",
        "frame_id": frame_id,
        "cable": cable_to_dict(cable),
        "shapes": x.tolist(),
        "grippers": None if grippers is None else _grippers_section(grippers, frame_id),
        "trajectory": None if trajectory is None else _trajectory_section(trajectory, frame_id),
        "warnings": list(warnings),
        "extra": extra,
    }


def write_plan_json(
    path: str | os.PathLike,
    cable: Cable,
    shapes,
    grippers: GripperPath | None = None,
    trajectory: Trajectory | None = None,
    warnings=(),
    extra: dict | None = None,
    *,
    frame_id: str = DEFAULT_FRAME_ID,
) -> Path:
    """Write the plan document (:func:`plan_document`) atomically to ``path``; returns it."""
    doc = plan_document(cable, shapes, grippers, trajectory, warnings, extra, frame_id=frame_id)
    return atomic_write_text(path, json.dumps(doc, indent=1, allow_nan=False) + "\n")


# -- reading -----------------------------------------------------------------------------------
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
    return Trajectory(
        times=np.array(times),
        positions=np.stack([arms[0][0], arms[1][0]], axis=1),
        rotations=(arms[0][1], arms[1][1]),
        max_speed=_get(section, "max_speed", where, int | float),
        max_angular_speed=_get(section, "max_angular_speed", where, int | float),
        arm_clips=tuple(CLIP_NAMES.index(c) for c in clip_names),
    )


def plan_from_document(doc: dict) -> PlanDocument:
    """Rebuild the plan pieces from a plan document dict (inverse of :func:`plan_document`).

    Raises
    ------
    ValueError
        For another format, a newer version, or a missing or malformed field (named by its
        path in the document).
    """
    if not isinstance(doc, dict) or doc.get("format") != PLAN_FORMAT:
        raise ValueError(
            f"plan: not a {PLAN_FORMAT!r} document (its 'format' field is missing or different)"
        )
    version = _get(doc, "version", "plan", int)
    if not 1 <= version <= PLAN_VERSION:
        raise ValueError(
            f"plan.version: got {version}, this dloplan reads versions 1..{PLAN_VERSION}"
        )
    frame_id = _check_frame_id(_get(doc, "frame_id", "plan"))
    cable_fields = dict(_get(doc, "cable", "plan", dict))
    if cable_fields.get("rest_shape") is not None:
        cable_fields["rest_shape"] = np.asarray(cable_fields["rest_shape"], dtype=float)
    try:
        cable = Cable(**cable_fields)
    except TypeError as exc:
        raise ValueError(f"plan.cable: {exc}") from exc
    shapes = as_path(_get(doc, "shapes", "plan", list), name="plan.shapes")
    grippers = doc.get("grippers")
    trajectory = doc.get("trajectory")
    warnings = _get(doc, "warnings", "plan", list)
    extra = doc.get("extra") or {}
    return PlanDocument(
        cable=cable,
        shapes=shapes,
        grippers=None if grippers is None else _read_grippers(grippers, frame_id),
        trajectory=None if trajectory is None else _read_trajectory(trajectory, frame_id),
        warnings=tuple(str(w) for w in warnings),
        extra=extra,
        frame_id=frame_id,
        version=version,
    )


def read_plan_json(path: str | os.PathLike) -> PlanDocument:
    """Read a plan document written by :func:`write_plan_json`.

    Raises
    ------
    ValueError
        When the file is not valid JSON or not a readable plan document (naming the field).
    """
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not valid JSON ({exc})") from exc
    return plan_from_document(doc)


# -- ROS 2 trajectory_msgs/MultiDOFJointTrajectory ---------------------------------------------
def _trajectory_points(trajectory: Trajectory, rate: float | None):
    if rate is None:
        return trajectory.times, trajectory.positions, trajectory.rotations
    samples = trajectory.sample(rate)
    return samples.times, samples.positions, samples.rotations


def multi_dof_trajectory_msg(
    trajectory: Trajectory, *, rate: float | None = None, frame_id: str = DEFAULT_FRAME_ID
) -> dict:
    """The trajectory as a ``trajectory_msgs/MultiDOFJointTrajectory``-shaped dict.

    Parameters
    ----------
    trajectory : Trajectory
    rate : float, optional
        Sampling rate [Hz]; None writes the knots only (one point per planned shape), which a
        controller interpolating linearly between points reproduces exactly in position.
    frame_id : str
        ``header.frame_id``.

    Notes
    -----
    Joint names are ``left_tcp`` and ``right_tcp``; each point has one
    ``geometry_msgs/Transform`` per joint (translation [m], rotation x-y-z-w, w >= 0), empty
    velocities and accelerations (the segment velocities are piecewise constant and jump at
    the knots), and ``time_from_start`` as ``builtin_interfaces/Duration``.
    """
    frame_id = _check_frame_id(frame_id)
    times, positions, rotations = _trajectory_points(trajectory, rate)
    quats = [canonical_quaternions(r) for r in rotations]
    points = [
        {
            "transforms": [transform_dict(positions[i, a], quats[a][i]) for a in (0, 1)],
            "velocities": [],
            "accelerations": [],
            "time_from_start": duration_dict(t),
        }
        for i, t in enumerate(times)
    ]
    return {
        "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": frame_id},
        "joint_names": [f"{arm}_tcp" for arm in ARMS],
        "points": points,
    }


def write_ros_trajectory(
    path: str | os.PathLike,
    trajectory: Trajectory,
    *,
    rate: float | None = None,
    frame_id: str = DEFAULT_FRAME_ID,
    fmt: str | None = None,
) -> Path:
    """Write :func:`multi_dof_trajectory_msg` as YAML or JSON, atomically.

    Parameters
    ----------
    fmt : {"yaml", "json"}, optional
        Default: from the suffix (``.json`` -> JSON, otherwise YAML).
    """
    fmt = fmt or ("json" if Path(path).suffix.lower() == ".json" else "yaml")
    if fmt not in ("yaml", "json"):
        raise ValueError(f"fmt: got {fmt!r}, expected 'yaml' or 'json'")
    msg = multi_dof_trajectory_msg(trajectory, rate=rate, frame_id=frame_id)
    if fmt == "json":
        text = json.dumps(msg, indent=1) + "\n"
    else:
        text = yaml.safe_dump(msg, sort_keys=False, default_flow_style=None, width=100)
    return atomic_write_text(path, text)


# -- CSV -----------------------------------------------------------------------------------------
CSV_COLUMNS = ["time [s]"] + [
    f"{arm} {c}" for arm in ARMS for c in ("x [m]", "y [m]", "z [m]", "qx", "qy", "qz", "qw")
]


def trajectory_csv(
    trajectory: Trajectory, *, rate: float = DEFAULT_CSV_RATE, frame_id: str = DEFAULT_FRAME_ID
) -> str:
    """The sampled trajectory as CSV text (one comment line, one header line, one row per sample).

    Columns: time [s]; per arm (left, right) x, y, z [m] and the unit quaternion qx, qy, qz,
    qw (x-y-z-w order, scalar last, sign canonical w >= 0) of ``tcp_to_world``.
    """
    frame_id = _check_frame_id(frame_id)
    samples = trajectory.sample(rate)
    quats = [canonical_quaternions(r) for r in samples.rotations]
    table = np.column_stack(
        [samples.times] + [np.column_stack([samples.positions[:, a], quats[a]]) for a in (0, 1)]
    )
    out = io.StringIO()
    out.write(
        f"# dloplan dual-arm TCP trajectory; frame {frame_id}; positions in m; quaternions "
        f"x-y-z-w (scalar last, w >= 0); sampled at {rate:g} Hz; "
        f"duration {trajectory.duration:.6g} s\n"
    )
    out.write(",".join(CSV_COLUMNS) + "\n")
    np.savetxt(out, table, delimiter=",", fmt="%.12g")
    return out.getvalue()


def write_trajectory_csv(
    path: str | os.PathLike,
    trajectory: Trajectory,
    *,
    rate: float = DEFAULT_CSV_RATE,
    frame_id: str = DEFAULT_FRAME_ID,
) -> Path:
    """Write :func:`trajectory_csv` atomically to ``path``."""
    return atomic_write_text(path, trajectory_csv(trajectory, rate=rate, frame_id=frame_id))
