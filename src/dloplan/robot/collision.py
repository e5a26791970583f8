"""Arm-arm clearance: every link of an arm as a capsule, closest distances between segments.

A capsule is the set of points within a radius of a segment, so the clearance of two capsules
is the distance of their segments minus both radii (negative: they overlap).
"""

from __future__ import annotations

import numpy as np

from ..geometry import segment_distance
from .chain import capsules


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
