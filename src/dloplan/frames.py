"""Small, vectorized frame constructions shared by the clips, the grippers and the plots.

All rotations are :class:`scipy.spatial.transform.Rotation`; a frame's x, y, z axes are the
clip's u, v, w axes (thesis Fig. 4.23).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from .jit import njit

UP = np.array([0.0, 0.0, 1.0])


def compose(p: Rotation, q: Rotation) -> Rotation:
    """``p * q`` (q, then p) of two stacks of rotations, bit for bit as scipy composes them.

    scipy 1.17 composes stacks in compiled code that makes an array object per rotation
    (about 1.3 us each: 11 ms for the 8 200 samples of a replay's clip motion). This is the
    same arithmetic on whole arrays: scipy's quaternion product term by term in its order,
    then ``Rotation.from_quat``'s normalization, as ``p * q`` normalizes (tests/test_frames.py
    compares them bit for bit). A single rotation or an N-dimensional stack is composed by
    scipy.

    Parameters
    ----------
    p, q : Rotation
        (N,) or (1,) rotations each (N of both, or one of them 1: broadcast).

    Returns
    -------
    Rotation
        (N,) the compositions.
    """
    a, b = p.as_quat(), q.as_quat()  # (N, 4) [x, y, z, w]
    if a.ndim != 2 or b.ndim != 2:
        return p * q
    a0, a1, a2, a3 = a.T
    b0, b1, b2, b3 = b.T
    cross = (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0)
    return Rotation.from_quat(np.stack([a3 * b0 + b3 * a0 + cross[0],
                                        a3 * b1 + b3 * a1 + cross[1],
                                        a3 * b2 + b3 * a2 + cross[2],
                                        a3 * b3 - a0 * b0 - a1 * b1 - a2 * b2], axis=-1))


def table_frame(directions) -> Rotation:
    """The job's frame on the table (``job_to_world``): z up, y along the first of
    ``directions`` that is not (nearly) vertical, projected onto the table, x = y x z.

    A job turned on the table (about the vertical) turns this frame with it, so what is drawn
    in it (a study's clip and obstacle offsets) turns with the job. A job whose first direction
    is world +y (the thesis' jobs: the cable across the front of the robot, clip 0 to clip 1
    along +y) has the world frame.

    Parameters
    ----------
    directions : array_like
        (D, 3) candidate directions, first choice first (a study: the start's chord from
        clip 0 to clip 1, then the first clip's axes).

    Returns
    -------
    Rotation
        The rotation about z taking the frame's axes to the world; the identity when every
        direction is vertical.
    """
    for d in np.asarray(directions, dtype=float).reshape(-1, 3):
        length = float(np.linalg.norm(d))
        if length > 0.0 and math.hypot(d[0], d[1]) > 1e-6 * length:
            yaw = math.remainder(math.atan2(d[1], d[0]) - math.pi / 2.0, 2.0 * math.pi)
            # a turn below 1e-12 rad is the round-off of a direction given in degrees (cos 90
            # deg = 6e-17): none, so a job along +y draws exactly what the world frame draws
            return Rotation.from_rotvec([0.0, 0.0, 0.0 if abs(yaw) < 1e-12 else yaw])
    return Rotation.identity()


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
    aux = np.broadcast_to(np.asarray(up, dtype=float), u.shape).reshape(-1, 3)
    quaternions = np.empty((len(aux), 4))
    # copied: one axis broadcast is a read-only view, a second overload of the kernel to load
    _frame_quaternions(np.ascontiguousarray(u.reshape(-1, 3)), np.array(aux, order="C"),
                       quaternions)
    return Rotation.from_quat(quaternions.reshape(u.shape[:-1] + (4,)))


@njit(cache=True)
def _frame_quaternions(u, up, out):
    """Quaternions (k, 4) (x, y, z, w) of :func:`frame_from_axis`'s frames [u v w] for axes u and
    up directions (k, 3); the matrix to quaternion step as scipy's ``Rotation.from_matrix``.
    Compiled: built per shape by the solvers, the frames cost 1 ms in numpy and scipy."""
    m = np.empty((3, 3))
    for r in range(u.shape[0]):
        norm = math.sqrt(u[r, 0] ** 2 + u[r, 1] ** 2 + u[r, 2] ** 2)
        for a in range(3):
            m[a, 0] = u[r, a] / norm
        aux = up[r].copy()
        for fallback in (0, 1):  # world x, then y, where u is (nearly) parallel to aux
            cross = 0.0
            for a in range(3):
                b, c = (a + 1) % 3, (a + 2) % 3
                cross += (m[b, 0] * aux[c] - m[c, 0] * aux[b]) ** 2
            if math.sqrt(cross) < 1e-6:
                aux[:] = 0.0
                aux[fallback] = 1.0
        norm = 0.0
        for a in range(3):  # v = aux x u, normalized; w = u x v
            b, c = (a + 1) % 3, (a + 2) % 3
            m[a, 1] = aux[b] * m[c, 0] - aux[c] * m[b, 0]
            norm += m[a, 1] ** 2
        norm = math.sqrt(norm)
        for a in range(3):
            m[a, 1] /= norm
        for a in range(3):
            b, c = (a + 1) % 3, (a + 2) % 3
            m[a, 2] = m[b, 0] * m[c, 1] - m[c, 0] * m[b, 1]
        trace = m[0, 0] + m[1, 1] + m[2, 2]
        choice = 3
        largest = trace
        for i in (2, 1, 0):  # the first largest of (m00, m11, m22, trace), as numpy's argmax
            if m[i, i] >= largest:
                choice, largest = i, m[i, i]
        if choice == 3:
            out[r, 0] = m[2, 1] - m[1, 2]
            out[r, 1] = m[0, 2] - m[2, 0]
            out[r, 2] = m[1, 0] - m[0, 1]
            out[r, 3] = 1.0 + trace
        else:
            i = choice
            j, k = (i + 1) % 3, (i + 2) % 3
            out[r, i] = 1.0 - trace + 2.0 * m[i, i]
            out[r, j] = m[j, i] + m[i, j]
            out[r, k] = m[k, i] + m[i, k]
            out[r, 3] = m[k, j] - m[j, k]
        norm = math.sqrt(out[r, 0] ** 2 + out[r, 1] ** 2 + out[r, 2] ** 2 + out[r, 3] ** 2)
        for a in range(4):
            out[r, a] /= norm


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


def slerp_quaternions(times, quaternions, t) -> np.ndarray:
    """Spherical linear interpolation of unit quaternions between key times.

    The rotation of least angle between neighbouring keys, at a constant rate: the same
    rotations as ``scipy.spatial.transform.Slerp(times, Rotation.from_quat(quaternions))(t)``
    to round-off, in plain array arithmetic (scipy's composes ``Rotation`` objects: 4 ms for
    4096 times against 1 ms here, the replay's largest cost per step chunk).

    Parameters
    ----------
    times : numpy.ndarray
        (K,) strictly increasing key times [s], K >= 2.
    quaternions : numpy.ndarray
        (K, ..., 4) unit quaternions (x, y, z, w) at the keys (e.g. (K, 2, 4): both clips).
    t : numpy.ndarray
        (M,) times [s] within ``[times[0], times[-1]]``.

    Returns
    -------
    numpy.ndarray
        (M, ..., 4) unit quaternions (x, y, z, w); at a key time, that key's rotation.
    """
    k = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    f = ((t - times[k]) / (times[k + 1] - times[k])).reshape((-1,) + (1,) * (quaternions.ndim - 1))
    q0, q1 = quaternions[k], quaternions[k + 1]
    cos = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(cos < 0.0, -q1, q1)  # q and -q are one rotation: the shorter arc
    angle = np.arccos(np.minimum(np.abs(cos), 1.0))
    sin = np.sin(angle)
    tiny = sin < 1e-12  # (nearly) equal keys: linear weights, exact to O(angle^2)
    safe = np.where(tiny, 1.0, sin)
    w0 = np.where(tiny, 1.0 - f, np.sin((1.0 - f) * angle) / safe)
    w1 = np.where(tiny, f, np.sin(f * angle) / safe)
    q = w0 * q0 + w1 * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quaternion_x_axes(quaternions) -> np.ndarray:
    """The x-axes (first columns of the rotation matrices) of unit quaternions (x, y, z, w),
    (..., 4) -> (..., 3): what the held points need of the clips' frames, without building
    ``Rotation`` objects per step chunk of the replay."""
    x, y, z, w = np.moveaxis(np.asarray(quaternions, dtype=float), -1, 0)
    return np.stack([1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + z * w), 2.0 * (x * z - y * w)],
                    axis=-1)
