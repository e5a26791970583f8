"""Rigid transforms as 4x4 homogeneous matrices (thesis eqs. 7.1-7.3).

A transform is named for what it maps: ``camera_to_robot`` (the thesis' A_c^r) takes
coordinates in the camera frame to coordinates in the robot base frame, and is also the
camera's pose in the robot frame. Composition is matrix product, ``a_to_c = b_to_c @ a_to_b``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def check_pose(pose, name: str) -> np.ndarray:
    """Validate a 4x4 homogeneous rigid transform (orthonormal rotation to 1e-6, det +1).

    Raises
    ------
    ValueError
        Naming ``name`` for a wrong shape, a non-finite entry or a non-rigid matrix.
    """
    arr = np.asarray(pose, dtype=float)
    if arr.shape != (4, 4) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected a finite 4x4 homogeneous matrix, got shape {arr.shape}")
    rot = arr[:3, :3]
    if (not np.allclose(arr[3], [0.0, 0.0, 0.0, 1.0])
            or not np.allclose(rot.T @ rot, np.eye(3), atol=1e-6) or np.linalg.det(rot) < 0):
        raise ValueError(f"{name}: the matrix is not a rigid transform (rotation + translation)")
    return arr


def pose_matrix(rotation, translation) -> np.ndarray:
    """A 4x4 transform from a rotation (scipy Rotation or 3x3 matrix) and a translation [m]."""
    rot = rotation.as_matrix() if isinstance(rotation, Rotation) else np.asarray(rotation, float)
    out = np.eye(4)
    out[:3, :3] = rot
    out[:3, 3] = np.asarray(translation, dtype=float).reshape(3)
    return out


def invert_pose(pose) -> np.ndarray:
    """The inverse rigid transform (R^T, -R^T t), (4, 4)."""
    arr = check_pose(pose, "pose")
    out = np.eye(4)
    out[:3, :3] = arr[:3, :3].T
    out[:3, 3] = -arr[:3, :3].T @ arr[:3, 3]
    return out


def transform_points(a_to_b, points) -> np.ndarray:
    """Points in frame a -> the same points in frame b: p^b = A_a^b p^a (eq. 7.3).

    Parameters
    ----------
    a_to_b : array_like
        (4, 4) transform.
    points : array_like
        (..., 3) points [m] in frame a.

    Returns
    -------
    numpy.ndarray
        (..., 3) points [m] in frame b.
    """
    transform = check_pose(a_to_b, "a_to_b")
    pts = np.asarray(points, dtype=float)
    if pts.shape[-1:] != (3,):
        raise ValueError(f"points: expected shape (..., 3), got {pts.shape}")
    return pts @ transform[:3, :3].T + transform[:3, 3]


def transform_poses(a_to_b, poses) -> np.ndarray:
    """Object poses in frame a -> in frame b: A_o^b = A_a^b A_o^a (eq. 7.1), (..., 4, 4)."""
    transform = check_pose(a_to_b, "a_to_b")
    arr = np.asarray(poses, dtype=float)
    if arr.shape[-2:] != (4, 4):
        raise ValueError(f"poses: expected shape (..., 4, 4), got {arr.shape}")
    return transform @ arr
