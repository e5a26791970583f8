"""Arm-arm clearance: every link of an arm as a capsule, closest distances between segments.

A capsule is the set of points within a radius of a segment, so the clearance of two capsules
is the distance of their segments minus both radii (negative: they overlap).
"""

from __future__ import annotations

import numpy as np

from .chain import capsules

_EPS = 1e-12


def segment_distance(p0, p1, q0, q1) -> np.ndarray:
    """Closest distance between segments [p0, p1] and [q0, q1], vectorized.

    Closed form of Ericson, *Real-Time Collision Detection* (2005), sec. 5.1.9: minimize
    |p0 + s d1 - q0 - t d2| over s, t in [0, 1], clamping s and then t, with the degenerate
    cases (a segment of zero length, parallel segments) handled explicitly.

    Parameters
    ----------
    p0, p1, q0, q1 : array_like
        (..., 3) end points [m], broadcast together.

    Returns
    -------
    numpy.ndarray
        (...,) distances [m].
    """
    p0, p1, q0, q1 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (p0, p1, q0, q1)))
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = np.einsum("...k,...k", d1, d1)
    e = np.einsum("...k,...k", d2, d2)
    f = np.einsum("...k,...k", d2, r)
    c = np.einsum("...k,...k", d1, r)
    b = np.einsum("...k,...k", d1, d2)
    denom = a * e - b * b
    # s on the infinite lines (0 when parallel: any s is closest, pick the start), clamped.
    s = np.where(denom > _EPS * np.maximum(a * e, _EPS),
                 (b * f - c * e) / np.where(denom > 0, denom, 1.0), 0.0)
    s = np.clip(s, 0.0, 1.0)
    t = (b * s + f) / np.where(e > _EPS, e, 1.0)
    # t outside [0, 1]: clamp it and recompute s for the clamped t.
    t_clamped = np.clip(t, 0.0, 1.0)
    s = np.where(t != t_clamped,
                 np.clip((b * t_clamped - c) / np.where(a > _EPS, a, 1.0), 0.0, 1.0), s)
    t = t_clamped
    # Degenerate segments (points).
    point_p = a <= _EPS
    point_q = e <= _EPS
    s = np.where(point_p, 0.0, s)
    t = np.where(point_p & ~point_q, np.clip(f / np.where(e > _EPS, e, 1.0), 0.0, 1.0), t)
    t = np.where(point_q, 0.0, t)
    s = np.where(point_q & ~point_p, np.clip(-c / np.where(a > _EPS, a, 1.0), 0.0, 1.0), s)
    closest = (p0 + s[..., None] * d1) - (q0 + t[..., None] * d2)
    return np.linalg.norm(closest, axis=-1)


def arm_clearance(left, q_left, right, q_right, *,
                  shared_base: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Smallest capsule-capsule clearance between two arms (:func:`~dloplan.robot.chain.
    capsules`: the description's, then the tool's).

    Parameters
    ----------
    left, right : CellArm
    q_left, q_right : array_like
        (..., n) joint values [rad] of each arm, same batch shape.
    shared_base : bool
        Both arms hang on one body (one description with two chains): their base links'
        capsules are not checked against each other.

    Returns
    -------
    clearance : numpy.ndarray
        (...,) smallest surface distance [m] over all capsule pairs; negative when they
        overlap.
    pair : numpy.ndarray
        (..., 2) int: the capsule index of the left and the right arm that come closest (for
        the YuMi 0-6 links 1-7, 7 the gripper).
    """
    seg_l, rad_l, link_l = capsules(left, q_left)
    seg_r, rad_r, link_r = capsules(right, q_right)
    dist = segment_distance(seg_l[..., :, None, 0, :], seg_l[..., :, None, 1, :],
                            seg_r[..., None, :, 0, :], seg_r[..., None, :, 1, :])
    gap = dist - rad_l[:, None] - rad_r[None, :]
    if shared_base:
        gap = np.where((link_l[:, None] < 0) & (link_r[None, :] < 0), np.inf, gap)
    flat = gap.reshape(gap.shape[:-2] + (-1,))
    idx = np.argmin(flat, axis=-1)
    clearance = np.take_along_axis(flat, idx[..., None], axis=-1)[..., 0]
    return clearance, np.stack(np.unravel_index(idx, gap.shape[-2:]), axis=-1)
