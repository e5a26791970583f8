"""Peak joint speeds and accelerations of a robot program along its time law.

A controller moves each arm's TCP along the segment's straight line (and, on the YuMi, its arm
angle linearly) with one path parameter s in [0, 1] timed by the segment's law u(t)
(:class:`dloplan.trajectory.timelaw.Profile`). The joints follow q(s), known at the sub-steps
of the program's replay (uniform in s). Along the law,

    dq/dt = q'(s) u',        d2q/dt2 = q''(s) u'^2 + q'(s) u''

with q', q'' by central differences over the sub-steps (second order; one-sided at the ends)
and u', u'' from the law, sampled on a time grid that holds the law's phase boundaries. The
peak of |dq_j/dt| / v_j over the segment is what a controller must deliver: the jerk-limited
law cruises at up to twice the average rate of the segment, so averages (joint change over
duration) miss it by up to 2x.

Two segments overlapping at a fly-by knot are checked each with its own law (their joint
velocities add during the overlap; the overlap is short and taken at half the acceleration
limits, docs/grippers-and-exports.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GRID = 200
"""Time samples per segment (besides the law's phase boundaries)."""

SLOW_MARGIN = 0.98
"""A segment over a joint-speed limit is slowed to this fraction of the limit."""


@dataclass(frozen=True)
class JointPeaks:
    """Per segment the peak joint speed and acceleration of one arm.

    Attributes
    ----------
    speed : numpy.ndarray
        (M - 1,) largest |dq_j/dt| / v_j over the joints (1 = at the limit).
    speed_joint : numpy.ndarray
        (M - 1,) int, the joint it is reached by.
    acceleration : numpy.ndarray
        (M - 1,) largest |d2q_j/dt2| / a_j over the joints with a published limit (0 when
        no joint has one).
    acceleration_joint : numpy.ndarray
        (M - 1,) int.
    largest_acceleration : numpy.ndarray
        (M - 1,) largest |d2q_j/dt2| [rad/s^2] over all joints.
    """

    speed: np.ndarray
    speed_joint: np.ndarray
    acceleration: np.ndarray
    acceleration_joint: np.ndarray
    largest_acceleration: np.ndarray


def segment_peaks(path, profile, max_velocity, max_acceleration):
    """Peak joint speed and acceleration of one segment (module docstring).

    Parameters
    ----------
    path : array_like
        (n + 1, J) joints [rad] at s = 0, 1/n, ..., 1 (n >= 1).
    profile : Profile
        The segment's law u(t).
    max_velocity, max_acceleration : array_like
        (J,) limits [rad/s], [rad/s^2]; inf where none is published.

    Returns
    -------
    tuple
        (speed ratio, its joint, acceleration ratio, its joint, largest acceleration [rad/s^2]).
    """
    q = np.asarray(path, dtype=float)
    if profile.duration <= 0.0 or len(q) < 2:
        return 0.0, 0, 0.0, 0, 0.0
    s = np.linspace(0.0, 1.0, len(q))
    d1 = np.gradient(q, s, axis=0, edge_order=2 if len(q) > 2 else 1)
    d2 = np.gradient(d1, s, axis=0, edge_order=2 if len(q) > 2 else 1)
    t = np.union1d(np.linspace(0.0, profile.duration, GRID), profile.bounds)
    t = t[t < profile.duration]
    u, rate, accel = profile.evaluate(t, 2)
    u = np.clip(u, 0.0, 1.0)
    q1 = np.stack([np.interp(u, s, d1[:, j]) for j in range(q.shape[1])], axis=1)
    q2 = np.stack([np.interp(u, s, d2[:, j]) for j in range(q.shape[1])], axis=1)
    velocity = np.abs(q1 * rate[:, None])
    acceleration = np.abs(q2 * rate[:, None] ** 2 + q1 * accel[:, None])
    speed = (velocity / np.asarray(max_velocity, dtype=float)).max(axis=0)
    limits = np.asarray(max_acceleration, dtype=float)
    published = np.isfinite(limits)
    ratio = np.where(published, acceleration.max(axis=0) / np.where(published, limits, 1.0),
                     0.0)
    return (float(speed.max()), int(speed.argmax()), float(ratio.max()), int(ratio.argmax()),
            float(acceleration.max()))


def joint_peaks(paths, profiles, max_velocity, max_acceleration) -> JointPeaks:
    """:func:`segment_peaks` of every segment of one arm: ``paths`` and ``profiles`` one per
    segment."""
    rows = [segment_peaks(p, law, max_velocity, max_acceleration)
            for p, law in zip(paths, profiles, strict=True)]
    columns = list(zip(*rows, strict=True)) if rows else [[]] * 5
    return JointPeaks(np.array(columns[0], float), np.array(columns[1], int),
                      np.array(columns[2], float), np.array(columns[3], int),
                      np.array(columns[4], float))


def slowed_scale(trajectory, ratios) -> np.ndarray:
    """Per-segment speed scales (K - 1,) of ``trajectory``'s law that bring segments whose
    peak joint speed ratio ``ratios`` (K - 1,) exceeds 1 to :data:`SLOW_MARGIN` of the limit:
    the segment's rate capped at the fraction of its limit it reaches
    (:meth:`~dloplan.trajectory.Trajectory.segment_speed_use`; an acceleration-limited
    segment never cruises) times SLOW_MARGIN / ratio (the joints' speeds scale with the
    rate)."""
    law = trajectory.law
    scale = law.speed_scale if law.speed_scale is not None else np.ones(len(ratios))
    ratios = np.asarray(ratios, dtype=float)
    use = trajectory.segment_speed_use()
    slower = scale * np.maximum(use, 1e-6) * SLOW_MARGIN / np.maximum(ratios, 1e-12)
    return np.where(ratios > 1.0, np.minimum(slower, scale), scale)
