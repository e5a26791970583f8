"""Where the job lies on the table: the placement search of ``dloplan verify --place`` as a repair.

A placement is a horizontal translation d of the whole job (start, target, obstacles: the operator
puts the cable and its fixtures there) that brings every planned gripper pose within the robot's
reach (:func:`dloplan.robot.search_placement`). The cable model is invariant under translation
(uniform gravity, the table a horizontal plane, obstacles moved with the job), so the plan of the
translated job is the plan translated: :func:`translated_document` moves the document instead of
planning again. The arm assignment follows the geometry (the clip further to the robot's left
is held by the left arm, the rule the reachability check applies), and the trajectory is timed with
it, so the program holds the clips the way the check assumed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from ..grippers.path import GripperPath
from ..obstacles.shapes import Box, Cylinder
from .rebuild import left_clip, timed

SEARCH_EXTENT = (0.2, 0.2, 0.0)
"""Half-widths [m] of the searched placements: +-20 cm on the table, at the job's height."""

SEARCH_STEP = 0.05
"""Grid spacing [m] of the placement search."""


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


def translated_document(doc, offset):
    """The plan document moved by ``offset`` (3,) [m]: shapes, frames, trajectory, obstacles."""
    d = np.asarray(offset, dtype=float)
    moved = replace(
        doc, shapes=doc.shapes + d,
        stabilized=None if doc.stabilized is None else doc.stabilized + d,
        grippers=None if doc.grippers is None else translated_grippers(doc.grippers, d),
        obstacles=tuple(translated_obstacle(o, d) for o in doc.obstacles))
    return moved if doc.trajectory is None else timed(moved)


@dataclass(frozen=True, eq=False)
class PlacementRepair:
    """Outcome of :func:`place`.

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


def place(grippers: GripperPath, *, extent=SEARCH_EXTENT, step: float = SEARCH_STEP,
          robot=None) -> PlacementRepair:
    """Search a placement of the job where the robot reaches every planned pose.

    The nearest working offset to the job's own placement wins (grid of ``step`` within
    ``+-extent``); the arm assignment is the geometric one (:func:`left_clip`).
    """
    from ..robot import search_placement

    found = search_placement(grippers.positions, Rotation.from_matrix(grippers.matrices), robot,
                             extent=extent, step=step, assignment="auto")
    offset = found.offset if found.success else np.zeros(3)
    return PlacementRepair(offset, left_clip(grippers), found.success, found.message)
