"""Poses and durations shaped like ROS messages, with canonical quaternion signs.

A pose is a ``geometry_msgs/Pose``-shaped dict ``{"position": {x, y, z}, "orientation":
{x, y, z, w}}`` (metres; quaternion scalar last, like ROS and scipy), optionally wrapped as a
``geometry_msgs/PoseStamped`` ``{"header": {"frame_id": ...}, "pose": ...}``. Quaternions are
written with **w >= 0** (scipy's canonical form), so the same rotation is always written the
same way.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

DEFAULT_FRAME_ID = "world"
"""The frame of every pose unless a plan says otherwise."""

PLANNER_FRAME_NAMES = frozenset({DEFAULT_FRAME_ID, "robot_base"})
"""The two names of the planner's frame: ``world`` in plans and their ROS exports,
``robot_base`` in the vision files (calibrations, registered shapes; docs/vision.md, "Frames")."""


def same_frame(a: str, b: str) -> bool:
    """True when frame names ``a`` and ``b`` name one frame: equal, or both the planner's
    (:data:`PLANNER_FRAME_NAMES`)."""
    return a == b or {a, b} <= PLANNER_FRAME_NAMES


def check_frame_id(frame_id) -> str:
    """``frame_id`` when it is a non-empty string; ValueError otherwise."""
    if not isinstance(frame_id, str) or not frame_id.strip():
        raise ValueError(f"frame_id: got {frame_id!r}, expected a non-empty string")
    return frame_id


def canonical_quaternions(rotations: Rotation, scalar_first: bool = False) -> np.ndarray:
    """(N, 4) unit quaternions with w >= 0, x-y-z-w order (or w-x-y-z with ``scalar_first``).

    Negative zeros are written as 0 so text output is stable.
    """
    quat = np.atleast_2d(rotations.as_quat(canonical=True, scalar_first=scalar_first))
    return quat + 0.0


def pose_dict(position, quat_xyzw) -> dict:
    """A ``geometry_msgs/Pose``-shaped dict from a position [m] and an x-y-z-w quaternion."""
    x, y, z = (float(v) for v in position)
    qx, qy, qz, qw = (float(v) for v in quat_xyzw)
    return {
        "position": {"x": x, "y": y, "z": z},
        "orientation": {"x": qx, "y": qy, "z": qz, "w": qw},
    }


def pose_stamped_dict(position, quat_xyzw, frame_id: str) -> dict:
    """A ``geometry_msgs/PoseStamped``-shaped dict (header without stamp: a plan is timeless)."""
    return {"header": {"frame_id": frame_id}, "pose": pose_dict(position, quat_xyzw)}


def transform_dict(position, quat_xyzw) -> dict:
    """A ``geometry_msgs/Transform``-shaped dict (translation [m], rotation x-y-z-w)."""
    pose = pose_dict(position, quat_xyzw)
    return {"translation": pose["position"], "rotation": pose["orientation"]}


def _number(mapping: dict, key: str, where: str) -> float:
    if not isinstance(mapping, dict) or key not in mapping:
        raise ValueError(f"{where}: missing {key!r}")
    value = mapping[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{where}.{key}: got {value!r}, expected a finite number")
    return float(value)


def pose_from_dict(pose: dict, where: str) -> tuple[np.ndarray, np.ndarray]:
    """Position (3,) [m] and x-y-z-w quaternion (4,) of a ``geometry_msgs/Pose`` dict.

    Raises
    ------
    ValueError
        Naming ``where`` and the missing or malformed field, or a zero quaternion.
    """
    if not isinstance(pose, dict):
        raise ValueError(f"{where}: expected a pose mapping, got {type(pose).__name__}")
    pos = np.array([_number(pose.get("position"), k, f"{where}.position") for k in "xyz"])
    quat = np.array([_number(pose.get("orientation"), k, f"{where}.orientation") for k in "xyzw"])
    if np.linalg.norm(quat) < 0.5:
        raise ValueError(
            f"{where}.orientation: quaternion {quat.tolist()} is not a unit quaternion"
        )
    return pos, quat


def pose_stamped_from_dict(stamped: dict, where: str) -> tuple[np.ndarray, np.ndarray, str]:
    """Position, x-y-z-w quaternion and frame_id of a ``geometry_msgs/PoseStamped`` dict."""
    if not isinstance(stamped, dict) or "pose" not in stamped:
        raise ValueError(f"{where}: missing 'pose'")
    header = stamped.get("header", {})
    frame_id = header.get("frame_id") if isinstance(header, dict) else None
    if not isinstance(frame_id, str):
        raise ValueError(f"{where}.header.frame_id: missing or not a string")
    pos, quat = pose_from_dict(stamped["pose"], f"{where}.pose")
    return pos, quat, frame_id


def duration_dict(seconds: float) -> dict:
    """A ``builtin_interfaces/Duration``-shaped dict {sec, nanosec} (nanosec in [0, 1e9))."""
    total = int(round(float(seconds) * 1e9))
    sec, nanosec = divmod(total, 1_000_000_000)
    return {"sec": int(sec), "nanosec": int(nanosec)}
