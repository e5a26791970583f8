"""Where the job lies on the table: the placement search of ``dloplan verify --place`` as a repair.

A placement is a horizontal translation d of the whole job (start, target, obstacles: the operator
puts the cable and its fixtures there) that brings every planned gripper pose within the robot's
reach (:func:`dloplan.robot.search_placement`). The cable model is invariant under translation
(uniform gravity, the table a horizontal plane, obstacles moved with the job), so the plan of the
translated job is the plan translated: :func:`translated_document` moves the document instead of
planning again, and its robot program is made again in the job's robot cell (the arm
assignment, IK, limits, clearance and continuity of the moved targets,
:func:`dloplan.robot.robot_program`). The search itself uses the reachability check of the YuMi
at the work frame's origin with the side rule's assignment; the program confirms it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from ..grippers.path import GripperPath
from ..obstacles.shapes import Box, Cylinder
from .rebuild import left_clip, timed_with_robot

SEARCHES = ((0.2, 0.05, "nearest"), (0.3, 0.05, "nearest"))
"""The placement searches tried in turn: half-width [m] of the square searched on the table
(at the job's height), grid spacing [m], and which working offset wins (the nearest to the job's
own placement, or the one with the largest joint margin)."""


def translated_obstacle(obstacle, offset: np.ndarray):
    """An obstacle moved by ``offset`` [m] (the table plane is horizontal: it moves by dz)."""
    if isinstance(obstacle, Box):
        return replace(obstacle, center=tuple(np.add(obstacle.center, offset)))
    if isinstance(obstacle, Cylinder):
        return replace(obstacle, base=tuple(np.add(obstacle.base, offset)))
    if offset[2] != 0.0:
        return replace(obstacle, height=obstacle.height + float(offset[2]))
    return obstacle


def translated_job(job, offset):
    """The job moved by ``offset`` (3,) [m]: start, target and obstacles."""
    d = np.asarray(offset, dtype=float)
    return replace(job, start=job.start + d, target=job.target + d,
                   obstacles=tuple(translated_obstacle(o, d) for o in job.obstacles))


def translated_grippers(grippers: GripperPath, offset: np.ndarray) -> GripperPath:
    """Gripper frames moved by ``offset`` [m] (rotations unchanged)."""
    return replace(grippers, positions=grippers.positions + offset)


def translated_document(job, doc, offset):
    """The plan document moved by ``offset`` (3,) [m]: shapes, frames, trajectory, obstacles,
    and its robot program made again in the cell of ``job`` (the job already moved)."""
    d = np.asarray(offset, dtype=float)
    moved = replace(
        doc, shapes=doc.shapes + d,
        stabilized=None if doc.stabilized is None else doc.stabilized + d,
        grippers=None if doc.grippers is None else translated_grippers(doc.grippers, d),
        obstacles=tuple(translated_obstacle(o, d) for o in doc.obstacles))
    return moved if doc.trajectory is None else timed_with_robot(job, moved)


@dataclass(frozen=True, eq=False)
class PlacementRepair:
    """One placement search of :func:`placements`.

    Attributes
    ----------
    offset : numpy.ndarray
        (3,) translation of the job [m] (zero when none works).
    left_clip : int
        The clip the left arm holds.
    success : bool
        Every pose reachable, continuous and collision-free at ``offset``.
    message : str
        The search's one line (the best offset's problems when none works).
    """

    offset: np.ndarray
    left_clip: int
    success: bool
    message: str


def placements(grippers: GripperPath, *, searches=SEARCHES, robot=None):
    """Placements of the job where the robot reaches every planned pose, best first.

    For each (half-width, step, objective) of ``searches`` and each arm assignment (the side
    rule's, then the swapped one, which the robot program also falls back to), the working
    offset the objective picks (:func:`dloplan.robot.search_placement`). Yields a
    :class:`PlacementRepair` per search, successful or not (``success`` says which).
    """
    from ..robot import search_placement

    side = left_clip(grippers)
    for half, step, objective in searches:
        for clip in (side, 1 - side):
            found = search_placement(grippers.positions, Rotation.from_matrix(grippers.matrices),
                                     robot, extent=(half, half, 0.0), step=step,
                                     objective=objective,
                                     assignment=("first-left", "first-right")[clip])
            yield PlacementRepair(found.offset if found.success else np.zeros(3), clip,
                                  found.success, found.message)
