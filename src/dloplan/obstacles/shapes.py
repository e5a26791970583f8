"""Obstacle volumes: boxes on the table (thesis 5.4.1, Fig. 5.11), vertical cylinders (pegs), the
table plane.

Every obstacle answers two questions about the links of a cable seen as capsules (segments
inflated by the cable's radius), vectorized over all links of a shape or a batch of shapes:

* ``penetration(a, b, radius)``: how deep each capsule enters the volume [m] (> 0 colliding);
* ``lift_depth(a, b, radius)``: how far the capsule must be raised along +z to clear the volume
  [m] (the thesis' z_depth, Fig. 5.14, measured on segments rather than on mass points).

A new convex shape is a new class with these two methods (and ``name``), and ``edges()``, its
outline as polylines for the figures; nothing else changes. For the contact of mass points
(:mod:`dloplan.physics.contact`) a volume also gives ``signed_distance(points)`` (the distance
phi and its gradient, the outward normal n) and ``distance_hessian(points)``, the Hessian of phi
(the derivative of n): zero on a flat face, (I - n n^T - a a^T) / rho beside a round face of
curvature radius rho about the axis a, and the curvature of the distance to an edge or corner.
The explicit simulator reads a volume as ``contact_row()``
(:mod:`dloplan.physics.contact_compiled`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..physics.contact_compiled import BOX, CYLINDER, PLANE
from .compiled import box_segment_distances

_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
_SEARCH_STEPS = 60  # golden-section steps: the bracket shrinks by 0.618^60 ~ 3e-13


def _check_vector(name: str, value, size: int = 3) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (size,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: got {value!r}, expected {size} finite numbers [m]")
    return arr


def _min_along_segment(a: np.ndarray, b: np.ndarray, distance) -> np.ndarray:
    """Minimum over t in [0, 1] of ``distance(a + t (b - a))`` for a convex distance, (...,)."""
    lo = np.zeros(a.shape[:-1])
    hi = np.ones(a.shape[:-1])
    d = b - a
    for _ in range(_SEARCH_STEPS):
        t1 = hi - _GOLDEN * (hi - lo)
        t2 = lo + _GOLDEN * (hi - lo)
        left = distance(a + t1[..., None] * d) < distance(a + t2[..., None] * d)
        hi = np.where(left, t2, hi)
        lo = np.where(left, lo, t1)
    t = 0.5 * (lo + hi)
    return np.minimum(distance(a + t[..., None] * d), np.minimum(distance(a), distance(b)))


def _footprint_interval(a2: np.ndarray, b2: np.ndarray, half: np.ndarray):
    """Parameter interval [t0, t1] of segments (2D, local frame) inside |p| <= half (slabs)."""
    d = b2 - a2
    t0 = np.zeros(a2.shape[:-1])
    t1 = np.ones(a2.shape[:-1])
    for k in range(2):
        with np.errstate(divide="ignore", invalid="ignore"):
            lo = (-half[k] - a2[..., k]) / d[..., k]
            hi = (half[k] - a2[..., k]) / d[..., k]
        parallel = d[..., k] == 0.0
        inside = np.abs(a2[..., k]) <= half[k]
        enter = np.where(parallel, np.where(inside, -np.inf, np.inf), np.minimum(lo, hi))
        leave = np.where(parallel, np.where(inside, np.inf, -np.inf), np.maximum(lo, hi))
        t0 = np.maximum(t0, enter)
        t1 = np.minimum(t1, leave)
    return t0, t1


def _box_normal(q: np.ndarray, excess: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Normal (in the frame of ``q``, signs from q) and signed distance of a box-like set.

    ``excess`` (..., k) is |q| - half-size per axis: outside, the distance is the norm of its
    positive part; inside, the largest (least negative) component, through that face.
    """
    outside = np.maximum(excess, 0.0)
    dist = np.linalg.norm(outside, axis=-1)
    inside = dist == 0.0
    face = np.argmax(excess, axis=-1)
    face_normal = (np.arange(excess.shape[-1]) == face[..., None]).astype(float)
    safe = np.where(inside, 1.0, dist)[..., None]
    direction = np.where(inside[..., None], face_normal, outside / safe)
    phi = np.where(inside, np.max(excess, axis=-1), dist)
    return np.sign(np.where(q == 0, 1.0, q)) * direction, phi


def _box_hessian(excess: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
    """Hessian (..., 3, 3) of the signed distance of a box-like set, its own curvature left out.

    ``excess`` (..., k) as in :func:`_box_normal`; ``jacobian`` (..., k, 3) the gradients of its
    components. Outside, phi = |o| with o the positive part of the excess, whose Hessian is
    J^T (I_A - o o^T / phi^2) J / phi (I_A: the identity on the positive components); inside,
    phi is one component, linear here: zero. (A component that is curved itself, as the radial
    excess of a cylinder, adds its own Hessian: the caller's.)
    """
    outside = np.maximum(excess, 0.0)
    phi = np.linalg.norm(outside, axis=-1)
    active = (excess > 0).astype(float)
    safe = np.where(phi > 0, phi, 1.0)
    unit = outside / safe[..., None]
    projector = (active[..., :, None] * np.eye(excess.shape[-1])
                 - unit[..., :, None] * unit[..., None, :]) / safe[..., None, None]
    hessian = np.einsum("...ai,...ab,...bj->...ij", jacobian, projector, jacobian)
    return np.where((phi > 0)[..., None, None], hessian, 0.0)


@dataclass(frozen=True)
class Box:
    """A box resting on the table: a prohibitive volume (thesis Fig. 5.11).

    Parameters
    ----------
    center : array_like
        Centre of the box [m], (3,).
    size : array_like
        Edge lengths along its own x, y, z axes [m], (3,), all > 0.
    yaw : float
        Rotation about the world z-axis [rad].
    name : str
        Label used in reports.
    """

    center: tuple[float, float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0
    name: str = "box"

    def __post_init__(self) -> None:
        center = _check_vector(f"{self.name}.center", self.center)
        size = _check_vector(f"{self.name}.size", self.size)
        if np.any(size <= 0):
            raise ValueError(f"{self.name}.size: got {tuple(size)}, expected 3 lengths > 0 [m]")
        if not math.isfinite(self.yaw):
            raise ValueError(f"{self.name}.yaw: got {self.yaw!r}, expected a finite angle [rad]")
        object.__setattr__(self, "center", tuple(float(v) for v in center))
        object.__setattr__(self, "size", tuple(float(v) for v in size))

    @classmethod
    def from_corners(cls, lower, upper, yaw: float = 0.0, name: str = "box") -> Box:
        """A box from its lower and upper corners [m] (in its own frame when ``yaw`` != 0)."""
        lo = _check_vector(f"{name}.min", lower)
        hi = _check_vector(f"{name}.max", upper)
        if np.any(hi <= lo):
            raise ValueError(f"{name}: max corner {tuple(hi)} must exceed min corner {tuple(lo)}")
        return cls(tuple((lo + hi) / 2), tuple(hi - lo), yaw, name)

    @property
    def top(self) -> float:
        """Height of the top face [m]."""
        return self.center[2] + self.size[2] / 2

    def edges(self) -> list[np.ndarray]:
        """The box's outline for drawing: its top and bottom rings (5, 3) and four vertical
        edges (2, 3) [m]."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        h = np.asarray(self.size) / 2
        corners = {}
        for i in (-1, 1):
            for j in (-1, 1):
                for k in (-1, 1):
                    lx, ly = i * h[0], j * h[1]
                    corners[i, j, k] = np.asarray(self.center) + [c * lx - s * ly,
                                                                  s * lx + c * ly, k * h[2]]
        edges = []
        for k in (-1, 1):
            ring = [corners[-1, -1, k], corners[1, -1, k], corners[1, 1, k], corners[-1, 1, k],
                    corners[-1, -1, k]]
            edges.append(np.array(ring))
        for i, j in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            edges.append(np.array([corners[i, j, -1], corners[i, j, 1]]))
        return edges

    def _local(self, p: np.ndarray) -> np.ndarray:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        q = p - np.asarray(self.center)
        return np.stack([c * q[..., 0] + s * q[..., 1], -s * q[..., 0] + c * q[..., 1],
                         q[..., 2]], axis=-1)

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Distance from points to the box [m], 0 inside, (...,)."""
        excess = np.abs(self._local(points)) - np.asarray(self.size) / 2
        return np.linalg.norm(np.maximum(excess, 0.0), axis=-1)

    def signed_distance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance [m] (negative inside) and outward unit normal of the nearest surface.

        Shapes (...,) and (..., 3), for contact forces (:mod:`dloplan.physics.contact`).
        """
        q = self._local(points)
        excess = np.abs(q) - np.asarray(self.size) / 2
        local_normal, phi = _box_normal(q, excess)
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        normal = np.stack([c * local_normal[..., 0] - s * local_normal[..., 1],
                           s * local_normal[..., 0] + c * local_normal[..., 1],
                           local_normal[..., 2]], axis=-1)
        return phi, normal

    def contact_row(self) -> np.ndarray:
        """The box for the simulator's contacts (:mod:`dloplan.physics.contact_compiled`),
        (8,)."""
        return np.array([BOX, *self.center, *(np.asarray(self.size) / 2), self.yaw])

    def distance_hessian(self, points: np.ndarray) -> np.ndarray:
        """Hessian of :meth:`signed_distance` [1/m], (..., 3, 3): zero beside a face and inside,
        the curvature of the distance to an edge or a corner beyond them."""
        q = self._local(points)
        excess = np.abs(q) - np.asarray(self.size) / 2
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        world = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # local -> world
        signs = np.sign(np.where(q == 0, 1.0, q))
        jacobian = signs[..., :, None] * world.T  # d excess_k / d p = sign(q_k) (row k of R^T)
        return _box_hessian(excess, jacobian)

    def penetration(self, a: np.ndarray, b: np.ndarray, radius: float) -> np.ndarray:
        """How deep capsules (a, b, radius) enter the box [m]; <= 0 means clear, (...,).

        The golden-section search of ``_min_along_segment`` over ``distance``, compiled
        (:func:`dloplan.obstacles.compiled.box_segment_distances`)."""
        a, b = np.broadcast_arrays(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
        out = np.empty(a.shape[:-1])
        box_segment_distances(np.ascontiguousarray(a.reshape(-1, 3)),
                              np.ascontiguousarray(b.reshape(-1, 3)), np.asarray(self.center),
                              np.asarray(self.size) / 2, self.yaw, out.reshape(-1))
        return radius - out

    def lift_depth(self, a: np.ndarray, b: np.ndarray, radius: float) -> np.ndarray:
        """Upward translation clearing the capsules over the box (thesis z_depth) [m], (...,)."""
        la, lb = self._local(a), self._local(b)
        half = np.asarray(self.size[:2]) / 2 + radius
        t0, t1 = _footprint_interval(la[..., :2], lb[..., :2], half)
        over = t0 <= t1
        z_low = np.minimum(la[..., 2] + np.clip(t0, 0, 1) * (lb[..., 2] - la[..., 2]),
                           la[..., 2] + np.clip(t1, 0, 1) * (lb[..., 2] - la[..., 2]))
        depth = self.size[2] / 2 + radius - z_low
        colliding = self.penetration(a, b, radius) > 0
        return np.where(over & colliding, np.maximum(depth, 0.0), 0.0)


@dataclass(frozen=True)
class Cylinder:
    """A vertical cylinder standing on the table (a peg).

    Parameters
    ----------
    base : array_like
        Centre of the bottom face [m], (3,).
    radius : float
        Radius [m] > 0.
    height : float
        Height [m] > 0.
    name : str
        Label used in reports.
    """

    base: tuple[float, float, float]
    radius: float
    height: float
    name: str = "cylinder"

    def __post_init__(self) -> None:
        base = _check_vector(f"{self.name}.base", self.base)
        for field in ("radius", "height"):
            value = float(getattr(self, field))
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{self.name}.{field}: got {value!r}, expected a length > 0 [m]")
        object.__setattr__(self, "base", tuple(float(v) for v in base))

    @property
    def top(self) -> float:
        """Height of the top face [m]."""
        return self.base[2] + self.height

    def edges(self) -> list[np.ndarray]:
        """The cylinder's outline for drawing: bottom and top circles (33, 3) and four
        vertical lines (2, 3) [m]."""
        a = np.linspace(0, 2 * np.pi, 33)
        base = np.asarray(self.base)
        ring = np.stack([base[0] + self.radius * np.cos(a), base[1] + self.radius * np.sin(a),
                         np.full_like(a, base[2])], 1)
        top = ring + [0, 0, self.height]
        return [ring, top] + [np.array([ring[k], top[k]]) for k in (0, 8, 16, 24)]

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Distance from points to the solid cylinder [m], 0 inside, (...,)."""
        q = points - np.asarray(self.base)
        radial = np.maximum(np.hypot(q[..., 0], q[..., 1]) - self.radius, 0.0)
        vertical = np.maximum(np.maximum(-q[..., 2], q[..., 2] - self.height), 0.0)
        return np.hypot(radial, vertical)

    def _faces(self, points: np.ndarray):
        """The points' distance rho from the axis [m] (...,; 1 on the axis, where it divides),
        the radial and the vertical unit vectors (..., 3) (up above half height, else down) and
        the excess over the round face and the nearer flat face [m] (..., 2)."""
        q = points - np.asarray(self.base)
        rho = np.hypot(q[..., 0], q[..., 1])
        safe = np.where(rho > 0, rho, 1.0)
        radial = np.stack([np.where(rho > 0, q[..., 0] / safe, 1.0),
                           np.where(rho > 0, q[..., 1] / safe, 0.0), np.zeros_like(rho)], -1)
        above = q[..., 2] > 0.5 * self.height
        vertical = np.zeros_like(radial)
        vertical[..., 2] = np.where(above, 1.0, -1.0)
        excess = np.stack([rho - self.radius,
                           np.where(above, q[..., 2] - self.height, -q[..., 2])], axis=-1)
        return safe, radial, vertical, excess

    def signed_distance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance [m] (negative inside) and outward unit normal, (...,), (..., 3)."""
        _, radial, vertical, excess = self._faces(points)
        weights, phi = _box_normal(np.ones_like(excess), excess)
        return phi, weights[..., :1] * radial + weights[..., 1:] * vertical

    def contact_row(self) -> np.ndarray:
        """The cylinder for the simulator's contacts (:mod:`dloplan.physics.contact_compiled`),
        (8,)."""
        return np.array([CYLINDER, *self.base, self.radius, self.height, 0.0, 0.0])

    def distance_hessian(self, points: np.ndarray) -> np.ndarray:
        """Hessian of :meth:`signed_distance` [1/m], (..., 3, 3).

        The radial excess rho - R is curved, (I - r r^T - z z^T) / rho (r the radial and z the
        vertical unit vector); where it is the distance (beside the round face, inside or out)
        or a part of it (beyond the rims) that curvature enters weighted by its share of the
        distance, and the rim adds the curvature of the distance to a circle's edge
        (:func:`_box_hessian`).
        """
        rho, radial, vertical, excess = self._faces(points)
        weights, _ = _box_normal(np.ones_like(excess), excess)  # d phi / d excess_k
        tangential = np.eye(3) - radial[..., :, None] * radial[..., None, :]
        tangential[..., 2, 2] = 0.0  # drop z z^T (r has no z component)
        curved = tangential / rho[..., None, None]  # Hessian of rho
        jacobian = np.stack([radial, vertical], axis=-2)
        return weights[..., 0, None, None] * curved + _box_hessian(excess, jacobian)

    def penetration(self, a: np.ndarray, b: np.ndarray, radius: float) -> np.ndarray:
        """How deep capsules (a, b, radius) enter the cylinder [m]; <= 0 means clear."""
        return radius - _min_along_segment(a, b, self.distance)

    def lift_depth(self, a: np.ndarray, b: np.ndarray, radius: float) -> np.ndarray:
        """Upward translation clearing the capsules over the cylinder's top [m]."""
        colliding = self.penetration(a, b, radius) > 0
        z_low = np.minimum(a[..., 2], b[..., 2])
        return np.where(colliding, np.maximum(self.top + radius - z_low, 0.0), 0.0)


@dataclass(frozen=True)
class Table:
    """The table plane z = height: the cable must stay above it."""

    height: float = 0.0
    name: str = "table"

    def __post_init__(self) -> None:
        if not math.isfinite(self.height):
            raise ValueError(f"{self.name}.height: got {self.height!r}, expected a finite z [m]")

    def edges(self) -> list[np.ndarray]:
        """None to draw: an unbounded plane (the figures draw its height as a line)."""
        return []

    def signed_distance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Height above the plane [m] and its normal (+z), (...,), (..., 3)."""
        normal = np.zeros(points.shape)
        normal[..., 2] = 1.0
        return points[..., 2] - self.height, normal

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Distance from points to the solid below the plane [m], 0 in it, (...,)."""
        return np.maximum(np.asarray(points)[..., 2] - self.height, 0.0)

    def contact_row(self) -> np.ndarray:
        """The plane for the simulator's contacts (:mod:`dloplan.physics.contact_compiled`),
        (8,)."""
        return np.array([PLANE, self.height, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])

    def distance_hessian(self, points: np.ndarray) -> np.ndarray:
        """Hessian of :meth:`signed_distance`: zero (a plane), (..., 3, 3)."""
        return np.zeros(points.shape + (3,))

    def penetration(self, a: np.ndarray, b: np.ndarray, radius: float) -> np.ndarray:
        """Depth of the capsules below the plane [m]; <= 0 means clear."""
        return self.height + radius - np.minimum(a[..., 2], b[..., 2])

    def lift_depth(self, a: np.ndarray, b: np.ndarray, radius: float) -> np.ndarray:
        """Upward translation that puts the capsules back above the plane [m]."""
        return np.maximum(self.penetration(a, b, radius), 0.0)
