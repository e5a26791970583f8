"""Peak joint speeds and accelerations of a robot program along its time law.

A controller moves each arm's TCP along the move's straight line (and, on the YuMi, its arm
angle linearly) with one path parameter s in [0, 1] timed by the move's law u(t)
(:class:`dloplan.trajectory.timelaw.Profile`). The joints along the time law are the
program's :class:`~dloplan.robot.motion.JointMotion` (the one every writer samples: q(s) the
spline through the verified sub-steps),

    dq/dt = q'(s) u',        d2q/dt2 = q''(s) u'^2 + q'(s) u''

summed over the moves that run (two moves overlap at a fly-by target: their joint velocities
add there). Each move is sampled on a time grid of :data:`GRID` instants that holds its law's
phase boundaries; the peak of |dq_j/dt| / v_j over the move is what a controller must deliver:
the jerk-limited law cruises at up to twice the move's average rate, so averages (joint change
over duration) miss it by up to 2x. The grids of all moves are sampled in one evaluation of the
motion (each spline once over all of them, not once per move).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .motion import JointMotion

GRID = 200
"""Time samples per move (besides the law's phase boundaries)."""

SLOW_MARGIN = 0.98
"""A segment over a joint-speed limit is slowed to this fraction of the limit."""


@dataclass(frozen=True)
class JointPeaks:
    """Per move the peak joint speed and acceleration of one arm.

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


def motion_peaks(motion: JointMotion, max_velocity, max_acceleration) -> list[JointPeaks]:
    """The peaks of every move of every arm of a program's motion (module docstring).

    Parameters
    ----------
    motion : JointMotion
        The program's joints along its time law (``program.joint_motion(trajectory)``).
    max_velocity, max_acceleration : sequence of array_like
        Per arm the (J,) limits [rad/s], [rad/s^2]; inf where none is published.

    Returns
    -------
    list of JointPeaks
        One per arm.
    """
    windows = []
    for m, law in enumerate(motion.profiles):
        t = np.union1d(np.linspace(0.0, law.duration, GRID), law.bounds)
        windows.append(motion.starts[m] + t[(t >= 0.0) & (t <= law.duration)])
    # every move's window in one evaluation of the splines (the same values as one by one)
    ends = np.cumsum([len(t) for t in windows])
    sampled = motion.sample(np.concatenate(windows), 2) if windows else []
    rows = [[] for _ in motion.paths]
    for a, values in enumerate(sampled):
        for window in np.split(values, ends[:-1], axis=1):
            velocity = np.abs(window[1]).max(axis=0)
            acceleration = np.abs(window[2]).max(axis=0)
            speed = velocity / np.asarray(max_velocity[a], dtype=float)
            limits = np.asarray(max_acceleration[a], dtype=float)
            published = np.isfinite(limits)
            ratio = np.where(published, acceleration / np.where(published, limits, 1.0), 0.0)
            rows[a].append((float(speed.max()), int(speed.argmax()), float(ratio.max()),
                            int(ratio.argmax()), float(acceleration.max())))
    out = []
    for arm in rows:
        columns = list(zip(*arm, strict=True)) if arm else [[]] * 5
        out.append(JointPeaks(np.array(columns[0], float), np.array(columns[1], int),
                              np.array(columns[2], float), np.array(columns[3], int),
                              np.array(columns[4], float)))
    return out


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
