"""How far a described cell's joint motion leaves the straight TCP line between its sub-steps.

A program's arm moves from pose k-1 to pose k with its TCP on the straight line (and slerped
orientation) of :mod:`dloplan.robot.path`; the path check solves the IK at the move's sub-steps
only (every ``step_length`` / ``step_angle``), and the time-based programs run the joints along
the not-a-knot cubic spline through those sub-steps (:func:`~dloplan.robot.motion.move_spline`,
linear in the joints for one sub-step). Between sub-steps that joint motion is not the line:
its TCP departs from it by the interpolation error of the spacing, about a millimetre on an
18 mm move of a UR5e with one sub-step. :func:`line_deviation` measures it by forward
kinematics at :data:`SAMPLES` points inside every sub-step interval, against the line's point
at the same move parameter s (the TCP moves linearly in s, so this is also the distance at the
same instant of the time law).
"""

from __future__ import annotations

import numpy as np

from .kinematics import forward
from .motion import move_spline

SAMPLES = (0.25, 0.5, 0.75)
"""Where inside each sub-step interval the spline's TCP is measured (fractions of it)."""

LINE_TOLERANCE = 5e-4
"""[m] How far a described cell's program may leave the straight TCP line between sub-steps
(docs/cells.md); the path check refines the sub-steps of a move that leaves it by more
(:attr:`~dloplan.robot.path.ReachOptions.line_tolerance`)."""


def _joints_at(path, s) -> np.ndarray:
    """q_m(s) of one move's sub-steps (n + 1, J) [rad] at ``s`` (k,): the spline of
    :func:`~dloplan.robot.motion.move_spline`, in closed form for one and two sub-steps (the
    not-a-knot spline through two and three points is the line and the parabola through them;
    building the spline costs ten to forty times evaluating these)."""
    if len(path) == 2:
        return path[0] + s[:, None] * (path[1] - path[0])
    if len(path) == 3:
        return ((2.0 * (s - 0.5) * (s - 1.0))[:, None] * path[0]
                - (4.0 * s * (s - 1.0))[:, None] * path[1]
                + (2.0 * s * (s - 0.5))[:, None] * path[2])
    return move_spline(path)(s)


def line_deviation(arm, motion, positions, counts) -> np.ndarray:
    """The largest distance of an arm's joint motion from its straight TCP line, per move.

    Parameters
    ----------
    arm : CellArm
    motion : numpy.ndarray
        (1 + sum(counts), n) joints [rad] of every sub-step (pose 0, then each move's).
    positions : numpy.ndarray
        (K, 3) TCP positions [m] of the planned poses.
    counts : numpy.ndarray
        (K-1,) int, the sub-steps of each move (:func:`~dloplan.robot.path.substeps`).

    Returns
    -------
    numpy.ndarray
        (K,) [m] at pose k the largest distance over the move into it (0 at pose 0).
    """
    counts = np.asarray(counts, dtype=int)
    out = np.zeros(len(positions))
    if len(counts) == 0:
        return out
    ends = np.concatenate([[0], np.cumsum(counts)])
    params = [((np.arange(n)[:, None] + np.asarray(SAMPLES)) / n).ravel() for n in counts]
    joints = np.concatenate([_joints_at(motion[ends[m]:ends[m + 1] + 1], s)
                             for m, s in enumerate(params)])
    s = np.concatenate(params)
    move = np.repeat(np.arange(len(counts)), [len(p) for p in params])
    line = (1.0 - s)[:, None] * positions[move] + s[:, None] * positions[move + 1]
    tcp, _ = forward(arm, joints)  # every move's samples at once
    distance = np.linalg.norm(tcp - line, axis=1)
    out[1:] = np.maximum.reduceat(distance, np.concatenate([[0], np.cumsum(
        [len(p) for p in params])[:-1]]))
    return out


__all__ = ["LINE_TOLERANCE", "SAMPLES", "line_deviation"]
