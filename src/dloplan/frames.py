"""Small, vectorized frame constructions shared by the clips, the grippers and the plots.

All rotations are :class:`scipy.spatial.transform.Rotation`; a frame's x, y, z axes are the
clip's u, v, w axes (thesis Fig. 4.23).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

UP = np.array([0.0, 0.0, 1.0])


def frame_from_axis(u, up=UP) -> Rotation:
    """Rotations whose x-axis is ``u`` and whose z-axis leans toward ``up``.

    Parameters
    ----------
    u : array_like
        Axes, (..., 3) (normalized here).
    up : array_like
        Preferred direction of the z-axis; where u is (nearly) parallel to it, world x (then y)
        is used instead, so the frame is always defined.

    Returns
    -------
    scipy.spatial.transform.Rotation
        One ``frame_to_world`` rotation per axis.
    """
    u = np.atleast_2d(np.asarray(u, dtype=float))
    u = u / np.linalg.norm(u, axis=-1, keepdims=True)
    aux = np.broadcast_to(np.asarray(up, dtype=float), u.shape).copy()
    for fallback in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
        parallel = np.linalg.norm(np.cross(u, aux), axis=-1) < 1e-6
        aux[parallel] = fallback
    v = np.cross(aux, u)
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    w = np.cross(u, v)
    return Rotation.from_matrix(np.stack([u, v, w], axis=-1))


def minimal_rotation(a, b) -> Rotation:
    """The rotations of least angle taking unit vectors ``a`` to unit vectors ``b``.

    Closed form of the thesis' optimization (eqs. 4.25-4.29): the rotation about a x b by the
    angle between a and b. For antiparallel vectors (angle pi) the axis is any perpendicular to
    a; the one of :func:`frame_from_axis` (its y-axis) is used, so the result is deterministic.

    Parameters
    ----------
    a, b : array_like
        Unit vectors, (..., 3), broadcast together.
    """
    a, b = np.broadcast_arrays(np.atleast_2d(a).astype(float), np.atleast_2d(b).astype(float))
    axis = np.cross(a, b)
    s = np.linalg.norm(axis, axis=-1)
    c = np.einsum("...k,...k", a, b)
    angle = np.arctan2(s, c)
    safe = s > 1e-12
    unit = np.where(safe[..., None], axis / np.where(safe, s, 1.0)[..., None], 0.0)
    flipped = ~safe & (c < 0)
    if np.any(flipped):
        unit[flipped] = frame_from_axis(a[flipped]).apply([0.0, 1.0, 0.0])
    return Rotation.from_rotvec(unit * np.where(safe | flipped, angle, 0.0)[..., None])
