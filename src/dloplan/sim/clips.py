"""Clip poses: how the two grippers hold the cable (thesis Fig. 4.5, 4.24).

Each clip grips the middle of an end link. Its pose is a position [m] (the middle of the held
link) and a rotation ``clip_to_world`` (a :class:`scipy.spatial.transform.Rotation`) whose
x-axis is the clip's u-axis, the direction of the held link.

Convention (kept for both clips, so that mirroring a problem mirrors the answer): **u points
inward**, from the cable's end into the cable. The first clip holds points 0 and 1 with
u along x_1 - x_0; the last clip holds points n and n-1 with u along x_{n-1} - x_n. A held link
keeps its rest length l: the end point is at ``position - l/2 u`` and the inner point at
``position + l/2 u``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..frames import frame_from_axis, minimal_rotation
from ..physics.geometry import as_shape

HELD_INDICES = (0, 1, -2, -1)
"""Indices of the four points fixed by the two clips, in the order first-end, first-inner,
last-inner, last-end."""


@dataclass(frozen=True, eq=False)
class ClipPoses:
    """Poses of the two clips holding a cable.

    Parameters
    ----------
    positions : numpy.ndarray
        (2, 3) clip points [m]: the middle of the first and of the last link.
    rotations : scipy.spatial.transform.Rotation
        Two ``clip_to_world`` rotations; their x-axes are the clips' u-axes (pointing inward).
    """

    positions: np.ndarray
    rotations: Rotation

    def __post_init__(self) -> None:
        pos = np.asarray(self.positions, dtype=float)
        if pos.shape != (2, 3):
            raise ValueError(f"clips.positions: expected shape (2, 3), got {pos.shape}")
        if not np.all(np.isfinite(pos)):
            raise ValueError("clips.positions: non-finite coordinate (NaN or inf)")
        if not isinstance(self.rotations, Rotation) or self.rotations.single or len(
            self.rotations
        ) != 2:
            raise ValueError("clips.rotations: expected a scipy Rotation holding 2 rotations")
        if not np.all(np.isfinite(self.rotations.as_quat())):
            raise ValueError("clips.rotations: non-finite quaternion (NaN or inf)")
        object.__setattr__(self, "positions", pos)

    @property
    def u_axes(self) -> np.ndarray:
        """The two u-axes (held link directions, inward), (2, 3)."""
        return self.rotations.apply([1.0, 0.0, 0.0])

    @property
    def distance(self) -> float:
        """Distance between the two clip points Delta_clip [m] (thesis Fig. 4.5)."""
        return float(np.linalg.norm(self.positions[1] - self.positions[0]))

    def held_points(self, link_length: float) -> np.ndarray:
        """Positions of the four held points (see :data:`HELD_INDICES`), (4, 3) [m]."""
        half = 0.5 * link_length * self.u_axes
        p = self.positions
        return np.stack([p[0] - half[0], p[0] + half[0], p[1] + half[1], p[1] - half[1]])

    def moved(self, translation=(0.0, 0.0, 0.0), rotation: Rotation | None = None) -> ClipPoses:
        """Both clips moved by the rigid motion x -> rotation x + translation."""
        rot = rotation if rotation is not None else Rotation.identity()
        return ClipPoses(
            rot.apply(self.positions) + np.asarray(translation, dtype=float), rot * self.rotations
        )


def clip_poses_from_shape(shape, rotations: Rotation | None = None) -> ClipPoses:
    """Read the clip poses off a shape: the middle of the end links and their inward u-axes.

    Parameters
    ----------
    shape : array_like
        (n + 1, 3) points [m].
    rotations : scipy.spatial.transform.Rotation, optional
        Two rotations giving the roll of each clip about its u-axis; they are turned by the
        minimal rotation that aligns their x-axis with the shape's u-axis. Without them the
        clip's z-axis leans toward world up (:func:`frame_from_axis`): the roll does not
        matter to a model without torsion.
    """
    x = as_shape(shape, name="shape")
    ends = x[[0, -1]]
    inner = x[[1, -2]]
    u = inner - ends
    norms = np.linalg.norm(u, axis=1)
    if np.any(norms <= 0.0):
        raise ValueError("shape: an end link has zero length, its clip axis is undefined")
    u /= norms[:, None]
    if rotations is None:
        rot = frame_from_axis(u)
    else:
        current = rotations.apply([1.0, 0.0, 0.0])
        rot = minimal_rotation(current, u) * rotations
    return ClipPoses(0.5 * (ends + inner), rot)


def place_held_points(shape: np.ndarray, clips: ClipPoses, link_length: float) -> np.ndarray:
    """A copy of ``shape`` with its four held points placed by the clips."""
    x = np.array(shape, dtype=float)
    x[list(HELD_INDICES)] = clips.held_points(link_length)
    return x
