"""One-sided contact of the mass points with rigid obstacles: a stiff quadratic penalty.

A point of a cable of radius r penetrates an obstacle by d = r - phi, with phi the signed
distance from the point to the obstacle's surface (negative inside). The penalty energy
U^c = sum_i 1/2 k_c max(0, d_i)^2 pushes it out along the surface normal n_i with the force
k_c d_i n_i. Its Hessian is taken as k_c n n^T for the penetrating points (exact for flat faces;
the curvature term of round faces, of order k_c d / R, is left out: Newton's method then
converges linearly rather than quadratically at a contact on a peg, which the trust region
absorbs). With k_c a hundred times E A / l (the axial springs of the bending modulus), a contact
penetrates F / k_c: a hundredth of the stretch the same force gives one link.

The penalty's Hessian jumps where a point touches a surface: a Newton step computed while a point
hangs free above an obstacle does not see the penalty it will meet. :func:`entry_fraction` tells
a static solver how much of such a step to take so that the point lands just inside, where the
next Hessian holds its contact (:func:`dloplan.sim.statics.minimize_energy`).

Obstacles provide ``signed_distance(points) -> (phi, normal)`` (:mod:`dloplan.obstacles`);
those that also give their ``contact_row()`` (boxes, cylinders, the table) are measured by the
compiled :func:`dloplan.physics.contact_compiled.signed_distances` in one call for all of them
(the same numbers to round-off: a static solve with a board's contacts evaluates them three
times per Newton iteration).

The stability check needs the exact Hessian (:func:`contact_hessian_blocks`): with the curvature
term, k_c (n n^T - d grad^2 phi), a cable pressed on a peg with a force lambda per point is softer
by lambda / rho along the peg's surface than the static solver's Hessian says; for a cable
wrapped tight around a peg this is of the order of the tension's own transverse stiffness
(lambda / rho = T l / rho^2 against T / l), so leaving it out would call a sliding wrap stiffer
than it is. Obstacles give the curvature as ``distance_hessian(points)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import numpy as np

from .contact_compiled import signed_distances


@lru_cache(maxsize=64)
def _rows(obstacles: tuple) -> np.ndarray | None:
    """The obstacles' contact rows (K, 8), or None when one has none."""
    if not all(hasattr(o, "contact_row") for o in obstacles):
        return None
    return np.stack([np.asarray(o.contact_row(), dtype=float) for o in obstacles])


def _compiled_rows(obstacles: Sequence) -> np.ndarray | None:
    try:
        return _rows(tuple(obstacles))
    except TypeError:  # an obstacle that cannot be hashed: measured by its own method
        return None


def contact_rows(obstacles: Sequence) -> np.ndarray | None:
    """The obstacles' compiled contact rows (K, 8) (:mod:`dloplan.physics.contact_compiled`),
    or None when one of them has none (it is measured by its own ``signed_distance``)."""
    return _compiled_rows(obstacles) if len(obstacles) else np.zeros((0, 8))


def penetrations(x: np.ndarray, obstacles: Sequence, radius: float):
    """Per obstacle, penetration depths (..., n + 1) [m] (> 0 in contact) and normals."""
    rows = _compiled_rows(obstacles) if len(obstacles) else None
    if rows is None:
        out = []
        for obstacle in obstacles:
            phi, normal = obstacle.signed_distance(x)
            out.append((radius - phi, normal))
        return out
    x = np.asarray(x, dtype=float)
    points = np.ascontiguousarray(x.reshape(-1, 3))
    phi = np.empty((len(rows), len(points)))
    normals = np.empty((len(rows), len(points), 3))
    signed_distances(points, rows, phi, normals)
    return [(radius - phi[k].reshape(x.shape[:-1]), normals[k].reshape(x.shape))
            for k in range(len(rows))]


def contact_energy(x: np.ndarray, obstacles: Sequence, radius: float, stiffness: float):
    """Penalty energy [J], shape (...)."""
    total = 0.0
    for depth, _ in penetrations(x, obstacles, radius):
        total = total + 0.5 * stiffness * np.sum(np.maximum(depth, 0.0) ** 2, axis=-1)
    return total


def contact_gradient(x: np.ndarray, obstacles: Sequence, radius: float, stiffness: float):
    """Gradient of the penalty [N], (..., n + 1, 3); the contact force is its negative."""
    grad = np.zeros(x.shape)
    for depth, normal in penetrations(x, obstacles, radius):
        grad -= stiffness * np.maximum(depth, 0.0)[..., None] * normal
    return grad


def contact_hessian_diagonal(x: np.ndarray, obstacles: Sequence, radius: float,
                             stiffness: float) -> np.ndarray:
    """Per-point 3x3 Hessian blocks k_c n n^T of the penetrating points, (n + 1, 3, 3)."""
    blocks = np.zeros(x.shape + (3,))
    for depth, normal in penetrations(x, obstacles, radius):
        active = (depth > 0)[..., None, None]
        blocks += np.where(active, stiffness * normal[..., :, None] * normal[..., None, :], 0.0)
    return blocks


ENTRY_DEPTH = 1e-6
"""Depth a step lands a point at when it enters an obstacle, relative to the cable's radius
(:func:`entry_fraction`): just inside, so the next Hessian holds the contact."""


def entry_fraction(x: np.ndarray, trial: np.ndarray, obstacles: Sequence, radius: float) -> float:
    """How much of the straight move from ``x`` to ``trial`` to take so that no point that is out
    of contact at ``x`` ends deeper than ``ENTRY_DEPTH * radius`` in an obstacle, in (0, 1].

    Each entering point's depth is interpolated linearly along the move (exact for flat faces).

    Parameters
    ----------
    x, trial : numpy.ndarray
        (n + 1, 3) the state and the trial state [m].
    obstacles : sequence
        Obstacles with ``signed_distance``.
    radius : float
        The cable's radius [m].
    """
    landing = ENTRY_DEPTH * radius
    fraction = 1.0
    for (before, _), (after, _) in zip(penetrations(x, obstacles, radius),
                                       penetrations(trial, obstacles, radius), strict=True):
        entering = (before <= 0.0) & (after > landing)
        if np.any(entering):
            fraction = min(fraction, float(np.min(
                (landing - before[entering]) / (after[entering] - before[entering]))))
    return fraction


def contact_hessian_blocks(x: np.ndarray, obstacles: Sequence, radius: float,
                           stiffness: float) -> np.ndarray:
    """Exact per-point 3x3 Hessian blocks of the penalty, (n + 1, 3, 3) [N/m].

    k_c (n n^T - d grad^2 phi) for the penetrating points (d > 0): the derivative of
    :func:`contact_gradient`, the surface's curvature included (module docstring); obstacles
    provide ``distance_hessian(points)``.
    """
    blocks = np.zeros(x.shape + (3,))
    for obstacle in obstacles:
        phi, normal = obstacle.signed_distance(x)
        depth = radius - phi
        active = (depth > 0)[..., None, None]
        curvature = obstacle.distance_hessian(x)
        block = stiffness * (normal[..., :, None] * normal[..., None, :]
                             - depth[..., None, None] * curvature)
        blocks += np.where(active, block, 0.0)
    return blocks
