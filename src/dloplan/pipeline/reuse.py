"""The physics checks of a plan moved rigidly on the table: reused, not run again.

A placement repair (:class:`~dloplan.pipeline.repair.placement.TableMove`) turns the whole job
about the vertical and shifts it horizontally. The checks of the plan's physics -- elastic
stability, the snap-through continuation and the dynamic replay
(:func:`dloplan.pipeline.stages.verify_plan`) -- see the cable, its stabilized shapes, the clip
poses and the time law, under gravity along -z and without obstacles (the obstacles enter the
plan's collision check, which the placement search runs on the moved shapes). A rotation about
the vertical and a translation leave gravity and every energy of the chain unchanged, so the
moved plan's eigenvalues, snap events, straying and replay deviations are those of the plan
before, to round-off (tests/test_verify_reuse.py runs both). Only the robot checks change.

:func:`moved_rigidly` decides from the documents alone whether that holds: the same cable, the
same time law (to round-off: a re-timed motion is not the same), and one horizontal rigid
motion that carries every stabilized shape, clip point and clip frame of the first onto the
second. A repair that changed anything else (other gripper frames, a rolled grasp, a slower
motion, new shapes) is verified from scratch.
"""

from __future__ import annotations

import dataclasses

import numpy as np

LENGTH_TOLERANCE = 1e-9
"""Largest distance [m] between a moved point of one plan and the other's (round-off of the
moved coordinates, about 1e-16 m per operation on coordinates below 1 m)."""

ANGLE_TOLERANCE = 1e-9
"""Largest angle [rad] between a moved clip frame and the other's, and largest tilt of the
motion's axis from the vertical."""

RELATIVE_TOLERANCE = 1e-9
"""Relative tolerance on the numbers of the time law (a law re-timed from moved geometry
differs from the first by round-off)."""


def moved_rigidly(before, after) -> bool:
    """Whether plan document ``after`` is ``before`` turned about the vertical and shifted.

    Parameters
    ----------
    before, after : PlanDocument
        Two plans of one job (not wire-harness plans).

    Returns
    -------
    bool
        The same cable and time law, and one rotation about z and translation carrying every
        stabilized shape, clip point and clip frame of ``before`` onto ``after`` within
        :data:`LENGTH_TOLERANCE` and :data:`ANGLE_TOLERANCE`.
    """
    if before.harness is not None or after.harness is not None or not (
            before.cable is after.cable or _close(before.cable, after.cable)):
        return False
    if (before.trajectory is None) != (after.trajectory is None) or (
            before.stabilized is None or after.stabilized is None
            or before.stabilized.shape != after.stabilized.shape):
        return False
    if before.trajectory is not None and not (
            _close(before.trajectory.times, after.trajectory.times)
            and _close(before.trajectory.law, after.trajectory.law)):
        return False
    poses_a, poses_b = before.clip_poses(), after.clip_poses()
    turn = poses_b[0].rotations[0] * poses_a[0].rotations[0].inv()
    if np.linalg.norm(turn.as_rotvec()[:2]) > ANGLE_TOLERANCE:
        return False  # not about the vertical: gravity would turn with the job
    shift = poses_b[0].positions[0] - turn.apply(poses_a[0].positions[0])
    for a, b in zip(poses_a, poses_b, strict=True):
        if np.max(np.linalg.norm(turn.apply(a.positions) + shift - b.positions, axis=1)) > \
                LENGTH_TOLERANCE:
            return False
        if np.max(((turn * a.rotations).inv() * b.rotations).magnitude()) > ANGLE_TOLERANCE:
            return False
    moved = turn.apply(before.stabilized.reshape(-1, 3)) + shift
    return bool(np.max(np.linalg.norm(moved - after.stabilized.reshape(-1, 3), axis=1))
                <= LENGTH_TOLERANCE)


def _close(a, b) -> bool:
    """Equal values, numbers to :data:`RELATIVE_TOLERANCE` (arrays, tuples, dataclasses)."""
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        return type(a) is type(b) and all(
            _close(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a))
    if isinstance(a, (tuple, list)):
        return isinstance(b, (tuple, list)) and len(a) == len(b) and all(
            _close(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, (np.ndarray, float)) or isinstance(b, (np.ndarray, float)):
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        return a.shape == b.shape and bool(np.allclose(a, b, rtol=RELATIVE_TOLERANCE,
                                                       atol=1e-12, equal_nan=True))
    return a == b


__all__ = ["moved_rigidly"]
