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

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..frames import frame_from_axis, minimal_rotation
from ..geometry import as_shape
from ..jit import njit
from ..physics.compiled import conform_free_part

HELD_INDICES = (0, 1, -2, -1)
"""Indices of the four points fixed by the two clips, in the order first-end, first-inner,
last-inner, last-end."""

MAX_STRAIN = 0.02
"""Largest mean strain of the free part accepted before clips are declared out of reach."""


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
        # its own copy (held points are cached), C-ordered whatever the caller's (a transposed
        # array): the compiled kernels taking the positions then have one overload each
        pos = np.array(self.positions, dtype=float, order="C")
        if pos.shape != (2, 3):
            raise ValueError(f"clips.positions: expected shape (2, 3), got {pos.shape}")
        if not np.all(np.isfinite(pos)):
            raise ValueError("clips.positions: non-finite coordinate (NaN or inf)")
        if not isinstance(self.rotations, Rotation) or self.rotations.single or len(
            self.rotations
        ) != 2:
            raise ValueError("clips.rotations: expected a scipy Rotation holding 2 rotations")
        quaternions = self.rotations.as_quat()
        if not np.all(np.isfinite(quaternions)):
            raise ValueError("clips.rotations: non-finite quaternion (NaN or inf)")
        object.__setattr__(self, "positions", pos)
        # the u-axes from the quaternions (Rotation.apply costs more than every use of them)
        object.__setattr__(self, "_u_axes", _x_axes(quaternions))
        object.__setattr__(self, "_held", {})  # held points per link length

    @property
    def u_axes(self) -> np.ndarray:
        """The two u-axes (held link directions, inward), (2, 3)."""
        return self._u_axes.copy()

    @property
    def distance(self) -> float:
        """Distance between the two clip points Delta_clip [m] (thesis Fig. 4.5)."""
        return math.dist(self.positions[0], self.positions[1])

    def held_points(self, link_length: float) -> np.ndarray:
        """Positions of the four held points (see :data:`HELD_INDICES`), (4, 3) [m]."""
        if link_length not in self._held:  # solvers ask for them several times per solve
            self._held[link_length] = _held_points(self.positions, self._u_axes,
                                                   float(link_length))
        return self._held[link_length].copy()

    def moved(self, translation=(0.0, 0.0, 0.0), rotation: Rotation | None = None) -> ClipPoses:
        """Both clips moved by the rigid motion x -> rotation x + translation."""
        rot = rotation if rotation is not None else Rotation.identity()
        return ClipPoses(
            rot.apply(self.positions) + np.asarray(translation, dtype=float), rot * self.rotations
        )


@njit(cache=True)
def _x_axes(quaternions):
    """First columns of the rotation matrices of unit quaternions (k, 4) (x, y, z, w), (k, 3);
    the formula of scipy's ``Rotation.as_matrix``."""
    out = np.empty((quaternions.shape[0], 3))
    for k in range(quaternions.shape[0]):
        x, y, z, w = quaternions[k]
        out[k, 0] = x * x - y * y - z * z + w * w
        out[k, 1] = 2.0 * (x * y + z * w)
        out[k, 2] = 2.0 * (x * z - y * w)
    return out


@njit(cache=True)
def _held_points(positions, u_axes, link_length):
    """The held points (4, 3) [m] of clips at ``positions`` with ``u_axes`` (2, 3)."""
    out = np.empty((4, 3))
    for a in range(3):
        half_0 = 0.5 * link_length * u_axes[0, a]
        half_1 = 0.5 * link_length * u_axes[1, a]
        out[0, a] = positions[0, a] - half_0
        out[1, a] = positions[0, a] + half_0
        out[2, a] = positions[1, a] + half_1
        out[3, a] = positions[1, a] - half_1
    return out


@njit(cache=True)
def held_points_of(positions, quaternions, link_length):
    """:meth:`ClipPoses.held_points` (4, 3) [m] of clips at ``positions`` (2, 3) [m] with
    ``clip_to_world`` unit quaternions (2, 4) (x, y, z, w), for compiled callers."""
    return _held_points(positions, _x_axes(quaternions), link_length)


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
    points, u = end_links(shape)
    if rotations is None:
        rot = frame_from_axis(u)
    else:
        current = rotations.apply([1.0, 0.0, 0.0])
        rot = minimal_rotation(current, u) * rotations
    return ClipPoses(points, rot)


def end_links(shape) -> tuple[np.ndarray, np.ndarray]:
    """The clip points (the middles of the end links) and the inward unit u-axes of a shape
    (n + 1, 3) [m]: two (2, 3) arrays."""
    x = as_shape(shape, name="shape")
    ends = x[[0, -1]]
    inner = x[[1, -2]]
    u = inner - ends
    norms = np.linalg.norm(u, axis=1)
    if np.any(norms <= 0.0):
        raise ValueError("shape: an end link has zero length, its clip axis is undefined")
    return 0.5 * (ends + inner), u / norms[:, None]


def place_held_points(shape: np.ndarray, clips: ClipPoses, link_length: float) -> np.ndarray:
    """A copy of ``shape`` with its four held points placed by the clips."""
    x = np.array(shape, dtype=float)
    x[list(HELD_INDICES)] = clips.held_points(link_length)
    return x


def held_links_conformed(shape, link_length: float) -> np.ndarray:
    """A copy of ``shape`` with each held link set to ``link_length`` [m] about its clip point:
    ``place_held_points(shape, clip_poses_from_shape(shape), link_length)`` without building
    the clips' frames (a clip's roll does not move its held points; the frames cost about 1 ms)."""
    points, u = end_links(shape)
    x = np.array(shape, dtype=float)
    x[list(HELD_INDICES)] = _held_points(points, u, float(link_length))
    return x


def check_clip_reach(cable: Cable, clips: ClipPoses) -> None:
    """Raise ValueError when the clips are coincident or farther apart than the cable reaches."""
    distance = clips.distance
    if distance < 1e-6 * cable.length:
        raise ValueError(f"clips: the two clip points coincide (distance {distance:.3g} m)")
    held = clips.held_points(cable.rest_link_length)
    gap = float(np.linalg.norm(held[2] - held[1]))
    reach = (cable.n_links - 2) * cable.rest_link_length
    if gap > reach * (1.0 + MAX_STRAIN):
        raise ValueError(
            f"clips: the inner held points are {gap:.4g} m apart but the free part of the cable "
            f"is {reach:.4g} m long (clip distance {distance:.4g} m for a {cable.length:.4g} m "
            f"cable): out of reach"
        )


def conform_guess(cable: Cable, guess: np.ndarray, clips: ClipPoses, gravity=GRAVITY) -> np.ndarray:
    """A starting shape with the held points placed and the free part at its rest length.

    A guess whose free part is shorter or longer than the cable (a geometric path's shape,
    or a warm start whose clips moved) starts Newton's method with large axial forces: the
    Hessian is then strongly indefinite and steps crawl. This keeps the guess's shape and
    branch but scales its deviation from the chord between the inner held points until the
    length is right, and spaces the points evenly along it. A straight guess that is too long
    for the clips is bowed along gravity (or any perpendicular) first.

    Parameters
    ----------
    cable : Cable
        The cable.
    guess : numpy.ndarray
        (n + 1, 3) shape [m].
    clips : ClipPoses
        The clips holding points 0, 1 and n-1, n.
    gravity : array_like
        Gravity [m/s^2], the direction a straight compressed guess is bowed toward.
    """
    x = np.array(guess, dtype=float)
    conform_free_part(x, clips.held_points(cable.rest_link_length),
                      (cable.n_links - 2) * cable.rest_link_length, cable.length,
                      np.asarray(gravity, dtype=float))
    return x
