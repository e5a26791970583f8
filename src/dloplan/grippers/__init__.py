"""Gripper (TCP) frames from planned shapes (thesis 4.6, Table 4.3).

``gripper_path(path, method="auto", cable=cable)`` gives a :class:`GripperPath`: clip positions
and ``clip_to_world`` rotations at every shape, the method used, the relative twist between the
clips along the path, and warnings.
"""

from ..geometry import as_path
from .axes import CLIP_NAMES, clip_axes
from .methods import (
    as_initial_frames,
    auxiliary_vector_frames,
    body_frames,
    minimal_rotation_frames,
    rigid_rotation_frames,
)
from .path import METHODS, GripperPath, gripper_path, relative_twist, resolve_method

__all__ = [
    "CLIP_NAMES",
    "METHODS",
    "GripperPath",
    "as_initial_frames",
    "as_path",
    "auxiliary_vector_frames",
    "body_frames",
    "clip_axes",
    "gripper_path",
    "minimal_rotation_frames",
    "relative_twist",
    "resolve_method",
    "rigid_rotation_frames",
]
