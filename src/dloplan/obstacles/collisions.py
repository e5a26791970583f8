"""Collision checks of cable shapes against obstacles (thesis 5.4.2, Figs. 5.13-5.14).

The cable is checked as capsules: each link is a segment inflated by the cable's radius, so a
link crossing a thin obstacle between two mass points is caught (a point-only check, the
thesis' own, misses it). Shapes are checked as given; :func:`stabilized_path` first lets every
shape settle under gravity with its clips held, the thesis' worst case for collisions.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..cable import GRAVITY, Cable
from ..geometry import as_shape
from ..sim.statics import Equilibrium, stabilize


@dataclass(frozen=True, eq=False)
class CollisionReport:
    """Collisions of one shape.

    Attributes
    ----------
    shape_index : int
        Index of the shape in its path (0 = start).
    colliding : bool
        True when any link enters any obstacle.
    obstacles : tuple of str
        Names of the obstacles entered.
    links : numpy.ndarray
        Indices of the colliding links (link i joins points i and i+1).
    points : numpy.ndarray
        Indices of the points of those links.
    z_depth : float
        Upward translation that clears the shape (thesis Fig. 5.14) [m].
    penetration : float
        Largest depth a link enters an obstacle [m] (<= 0 when clear: the clearance).
    """

    shape_index: int
    colliding: bool
    obstacles: tuple[str, ...]
    links: np.ndarray
    points: np.ndarray
    z_depth: float
    penetration: float

    def describe(self) -> str:
        """One line for logs and warnings."""
        if not self.colliding:
            return f"shape {self.shape_index}: clear"
        return (
            f"shape {self.shape_index}: links {self.links.tolist()} enter "
            f"{', '.join(self.obstacles)} by up to {1e3 * self.penetration:.1f} mm "
            f"(z_depth {1e3 * self.z_depth:.1f} mm)"
        )


def check_shape(shape, obstacles: Sequence, radius: float, index: int = 0) -> CollisionReport:
    """Check one shape (n + 1, 3) [m] whose links are capsules of ``radius`` [m]."""
    x = as_shape(shape, name="shape")
    a, b = x[:-1], x[1:]
    hit = np.zeros(len(a), dtype=bool)
    names: list[str] = []
    deepest = -np.inf
    lift = 0.0
    for obstacle in obstacles:
        depth = obstacle.penetration(a, b, radius)
        inside = depth > 0
        deepest = max(deepest, float(depth.max()))
        if np.any(inside):
            hit |= inside
            names.append(obstacle.name)
            lift = max(lift, float(obstacle.lift_depth(a, b, radius).max()))
    links = np.flatnonzero(hit)
    points = np.unique(np.concatenate([links, links + 1]))
    return CollisionReport(index, bool(hit.any()), tuple(names), links, points, lift, deepest)


def check_path(path, obstacles: Sequence, radius: float) -> list[CollisionReport]:
    """Check every shape of a path (S + 2, n + 1, 3) [m]."""
    return [check_shape(shape, obstacles, radius, k) for k, shape in enumerate(path)]


def stabilized_path(
    cable: Cable, path, *, gravity=GRAVITY
) -> tuple[np.ndarray, list[Equilibrium]]:
    """Every shape of a path settled under gravity with its own clips held (thesis 5.2).

    Returns the stabilized shapes (S + 2, n + 1, 3) [m] and the equilibria (with convergence
    flags: a shape that did not converge is reported by its ``Equilibrium``, never hidden).
    """
    shapes = np.asarray(path, dtype=float)
    results = [stabilize(shape, cable, gravity=gravity) for shape in shapes]
    return np.stack([r.shape for r in results]), results
