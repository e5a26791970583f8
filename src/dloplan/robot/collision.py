"""Arm-arm clearance: every link of an arm as a capsule, closest distances between segments.

A capsule is the set of points within a radius of a segment, so the clearance of two capsules
is the distance of their segments minus both radii (negative: they overlap).
"""

from __future__ import annotations

import numpy as np

from .kinematics import link_frames
from .yumi import Arm

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


def arm_capsules(arm: Arm, q) -> tuple[np.ndarray, np.ndarray]:
    """World end points and radii of an arm's capsules.

    Parameters
    ----------
    arm : Arm
    q : array_like
        (..., 7) joint values [rad].

    Returns
    -------
    segments : numpy.ndarray
        (..., 8, 2, 3) capsule end points [m] (links 1..7, then the gripper).
    radii : numpy.ndarray
        (8,) radii [m].
    """
    frames = link_frames(arm, np.asarray(q, dtype=float))
    rot = np.concatenate([frames.rotations[..., :7, :, :], frames.rotations[..., 6:7, :, :]], -3)
    pos = np.concatenate([frames.positions[..., :7, :], frames.positions[..., 6:7, :]], -2)
    ends = np.einsum("...lij,lej->...lei", rot, arm.capsules) + pos[..., None, :]
    return ends, arm.radii


def arm_clearance(left: Arm, q_left, right: Arm, q_right) -> tuple[np.ndarray, np.ndarray]:
    """Smallest capsule-capsule clearance between the two arms.

    Parameters
    ----------
    left, right : Arm
    q_left, q_right : array_like
        (..., 7) joint values [rad] of each arm, same batch shape.

    Returns
    -------
    clearance : numpy.ndarray
        (...,) smallest surface distance [m] over all link pairs; negative when they overlap.
    pair : numpy.ndarray
        (..., 2) int: the link index (0-6 links 1-7, 7 gripper) of the left and right arm that
        come closest.
    """
    seg_l, rad_l = arm_capsules(left, q_left)
    seg_r, rad_r = arm_capsules(right, q_right)
    dist = segment_distance(seg_l[..., :, None, 0, :], seg_l[..., :, None, 1, :],
                            seg_r[..., None, :, 0, :], seg_r[..., None, :, 1, :])
    gap = dist - rad_l[:, None] - rad_r[None, :]
    flat = gap.reshape(gap.shape[:-2] + (-1,))
    idx = np.argmin(flat, axis=-1)
    clearance = np.take_along_axis(flat, idx[..., None], axis=-1)[..., 0]
    return clearance, np.stack(np.unravel_index(idx, gap.shape[-2:]), axis=-1)
