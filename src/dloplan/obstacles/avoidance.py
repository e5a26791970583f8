"""Obstacle avoidance by lifting and re-planning (thesis 5.4.3, Figs. 5.15-5.17).

Loop: stabilize every shape of the path under gravity, check the stabilized shapes against the
obstacles, lift each colliding shape by its z_depth plus a safety offset, re-plan the path from
the start to the first lifted shape and from the last lifted shape to the target with the full
planner (sub-path sizes chosen so the total number of shapes is unchanged), and check again,
for a bounded number of rounds. A start or target that collides cannot be avoided by
re-planning and is reported as such.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..cable import GRAVITY, Cable
from .collisions import CollisionReport, check_path, stabilized_path

Replanner = Callable[[np.ndarray, np.ndarray, int], np.ndarray]
"""``replan(start, target, n_intermediate) -> path (n_intermediate + 2, n + 1, 3)``."""


@dataclass(frozen=True, eq=False)
class Avoidance:
    """Result of :func:`avoid_obstacles`.

    Attributes
    ----------
    path : numpy.ndarray
        (S + 2, n + 1, 3) planned shapes after re-planning [m].
    stabilized : numpy.ndarray
        The same shapes settled under gravity [m].
    reports_before : list of CollisionReport
        Collisions of the stabilized input path.
    reports_after : list of CollisionReport
        Collisions of the final stabilized path.
    rounds : int
        Re-planning rounds done.
    statics_solves : int
        Static equilibria solved.
    success : bool
        True when the final stabilized path is collision-free and every stabilization converged.
    status : str
        ``"clear"`` (nothing to do), ``"replanned"``, ``"start_collides"``,
        ``"target_collides"``, ``"not_converged"`` or ``"failed"``.
    message : str
        What happened, naming the offending shapes.
    """

    path: np.ndarray
    stabilized: np.ndarray
    reports_before: list[CollisionReport]
    reports_after: list[CollisionReport]
    rounds: int
    statics_solves: int
    success: bool
    status: str
    message: str


def lift_shapes(path: np.ndarray, reports: Sequence[CollisionReport], z_safety: float):
    """Lift the colliding shapes by z_depth + z_safety, and the shapes between them smoothly.

    Returns the lifted path and the indices (first, last) of the lifted block.
    """
    lifts = np.array([r.z_depth + z_safety if r.colliding else 0.0 for r in reports])
    hits = np.flatnonzero(lifts > 0)
    first, last = int(hits[0]), int(hits[-1])
    block = np.arange(first, last + 1)
    lifts[block] = np.interp(block, hits, lifts[hits])  # no dip between lifted shapes
    lifted = np.array(path, dtype=float)
    lifted[:, :, 2] += lifts[:, None]
    return lifted, first, last


def avoid_obstacles(
    cable: Cable,
    path,
    obstacles: Sequence,
    replan: Replanner,
    *,
    z_safety: float = 0.02,
    max_rounds: int = 5,
    gravity=GRAVITY,
) -> Avoidance:
    """Make a planned path collision-free after stabilization (thesis 5.4).

    Parameters
    ----------
    cable : Cable
        The cable; its radius inflates the links.
    path : array_like
        (S + 2, n + 1, 3) planned shapes [m].
    obstacles : sequence
        Obstacle volumes (:mod:`dloplan.obstacles.shapes`).
    replan : callable
        The planner for sub-paths: ``replan(start, target, n_intermediate)`` returns the path
        including both ends.
    z_safety : float
        Safety offset added to every lift [m] (thesis: 2 cm).
    max_rounds : int
        Re-planning rounds at most.
    gravity : array_like
        Gravity [m/s^2].
    """
    if not (np.isfinite(z_safety) and z_safety >= 0):
        raise ValueError(f"z_safety: got {z_safety!r}, expected a distance >= 0 [m]")
    if int(max_rounds) != max_rounds or max_rounds < 0:
        raise ValueError(f"max_rounds: got {max_rounds!r}, expected an integer >= 0")
    radius = cable.diameter / 2
    current = np.array(path, dtype=float)
    n_shapes = len(current)
    stabilized, equilibria = stabilized_path(cable, current, gravity=gravity)
    solves = n_shapes
    reports = check_path(stabilized, obstacles, radius)
    before = reports
    rounds = 0
    for end, status in ((0, "start_collides"), (n_shapes - 1, "target_collides")):
        if reports[end].colliding:
            return Avoidance(current, stabilized, before, reports, 0, solves, False, status,
                             f"cannot be avoided by re-planning: {reports[end].describe()}")
    while any(r.colliding for r in reports) and rounds < max_rounds:
        rounds += 1
        lifted, first, last = lift_shapes(current, reports, z_safety)
        head = replan(lifted[0], lifted[first], first - 1) if first > 1 else lifted[: first + 1]
        tail_count = n_shapes - 1 - last - 1
        tail = replan(lifted[last], lifted[-1], tail_count) if tail_count > 0 else lifted[last:]
        # head ends with the first lifted shape and tail starts with the last: one shape when
        # a single shape was lifted, which must not appear twice
        current = np.concatenate([head, lifted[first + 1 : last], tail[1:] if first == last
                                  else tail])
        current[0], current[-1] = path[0], path[-1]
        stabilized, equilibria = stabilized_path(cable, current, gravity=gravity)
        solves += n_shapes
        reports = check_path(stabilized, obstacles, radius)
    colliding = [r for r in reports if r.colliding]
    unconverged = [k for k, eq in enumerate(equilibria) if not eq.converged]
    if colliding:
        status = "failed"
        message = (f"still colliding after {rounds} re-planning rounds: "
                   + "; ".join(r.describe() for r in colliding))
    elif unconverged:
        status = "not_converged"
        message = f"stabilization did not converge for shapes {unconverged}"
    else:
        status = "replanned" if rounds else "clear"
        message = (f"collision-free after {rounds} re-planning round(s)" if rounds
                   else "no collision")
    return Avoidance(current, stabilized, before, reports, rounds, solves,
                     not colliding and not unconverged, status, message)
