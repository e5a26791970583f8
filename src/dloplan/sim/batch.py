"""Many static equilibria of held cables in one compiled call (a study's samples x shapes).

:func:`dloplan.sim.statics.equilibrium` is one solve: its Python set-up (checks, the chain, the
clips' held points, the conformed guess) and result (forces, clip reactions, messages) cost
about ten times the compiled Newton loop of a small cable. A robustness study solves the same
small problem thousands of times with other cable constants and clip poses, so here the set-up
of a whole batch is a few arrays and one compiled loop does, item by item, what
:func:`~dloplan.sim.statics.equilibrium` does for a cable held by both clips without contacts:
the held points from the clip poses, the reach check, the guess conformed
(:func:`~dloplan.physics.compiled.conform_free_part`), the trust-region Newton loop
(:func:`~dloplan.sim.compiled.newton_positions`) from the same start, tolerance and trust
radius. The same kernels run in the same order, so an item's shape is bit for bit the one
``equilibrium`` returns (tested).

Two kinds of item are handed back to ``equilibrium`` itself, which finishes them the readable
way: an item whose Newton loop stops at a saddle (the escape along the lowest mode uses LAPACK's
banded eigen-solver) and one whose clips are at or beyond the cable's reach (``equilibrium``
raises the ValueError that names the distances; its message is kept per item).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..jit import njit
from ..physics.chain import HALF_BANDWIDTH, SpringChain
from ..physics.compiled import chain_derivatives, chain_energy, conform_free_part
from .clips import MAX_STRAIN, ClipPoses, held_points_of
from .compiled import (
    CONVERGED,
    MAX_ITERATIONS,
    SADDLE,
    STALLED,
    largest_force,
    newton_positions,
)
from .newton import newton_message
from .result import DEFAULT_RTOL, ROUNDOFF, force_scale, stiffest
from .statics import equilibrium

HANDED_BACK = -1
"""Kernel status of an item left to :func:`~dloplan.sim.statics.equilibrium` (a saddle, or
clips at the edge of the cable's reach)."""

REFUSED = -2
"""Status of an item :func:`~dloplan.sim.statics.equilibrium` refused (clips out of reach)."""

_EDGE = 1e-9  # relative margin of the compiled reach test: closer calls go to equilibrium()


@njit(cache=True)
def solve_held(guesses, cable_of, k_s, rest_lengths, k_b, rest_angles, masses, gravity,
               positions, quaternions, link, length, tolerance, roundoff, stiff, stiff_axial,
               max_iterations, shapes, gradients, iterations, residuals, status, tolerances):
    """The equilibria of B held cables, in place (the loop of :func:`held_equilibria`).

    Parameters
    ----------
    guesses : numpy.ndarray
        (B, n + 1, 3) starting shapes [m].
    cable_of : numpy.ndarray
        (B,) int: the cable of each item, an index into the per-cable arrays.
    k_s, rest_lengths, k_b, rest_angles, masses : numpy.ndarray
        Per cable (C,), (C, n), (C,), (C, n - 1), (C, n + 1): the chain's constants
        (:attr:`dloplan.physics.chain.SpringChain.constants`).
    gravity : numpy.ndarray
        (3,) [m/s^2].
    positions, quaternions : numpy.ndarray
        (B, 2, 3) clip points [m] and (B, 2, 4) ``clip_to_world`` quaternions (x, y, z, w).
    link, length, tolerance : numpy.ndarray
        Per cable (C,): rest link length l [m], length L [m], residual tolerance [N].
    roundoff : float
        The round-off factor of the tolerance's floor (16 eps; 0: no floor, an explicit rtol).
    stiff : numpy.ndarray
        Per cable (C,): the largest stiffness of the floor [N/m]
        (:func:`dloplan.sim.result.residual_tolerance`).
    stiff_axial : numpy.ndarray
        Per cable (C,) bool: :attr:`dloplan.physics.chain.SpringChain.stiff_axial` (the Newton
        steps' link lengths corrected).
    max_iterations : int
        Newton iterations per item.
    shapes, gradients : numpy.ndarray
        (B, n + 1, 3) out: the equilibria [m] and their energy gradients [N].
    iterations, residuals, status, tolerances : numpy.ndarray
        (B,) out: Newton iterations, the residual [N], the loop's status
        (:data:`~dloplan.sim.compiled.CONVERGED` ...), or :data:`HANDED_BACK`, and the
        tolerance [N].
    """
    history = np.empty(max_iterations + 1)
    band = np.empty((HALF_BANDWIDTH + 1, 3 * guesses.shape[1]))
    for b in range(guesses.shape[0]):
        c = cable_of[b]
        status[b], iterations[b], residuals[b], tolerances[b] = _held_item(
            shapes[b], guesses[b], k_s[c], rest_lengths[c], k_b[c], rest_angles[c], masses[c],
            gravity, positions[b], quaternions[b], link[c], length[c], tolerance[c], roundoff,
            stiff[c], stiff_axial[c], max_iterations, gradients[b], band, history)


@njit(cache=True)
def _held_item(x, guess, k_s, rest_lengths, k_b, rest_angles, masses, gravity, position,
               quaternion, link, length, tolerance, roundoff, stiff, stiff_axial, max_iterations,
               grad, band, history):
    """One equilibrium of :func:`solve_held` into x (n + 1, 3) from ``guess``: returns
    ``(status, iterations, residual, tolerance)``. The tolerance [N] is ``max(tolerance,
    roundoff (L + max |x|) stiff)`` at the conformed guess (``roundoff`` > 0: the round-off
    floor of :func:`dloplan.sim.result.residual_tolerance`, ``stiff`` its largest stiffness
    [N/m], in the same order of operations; ``stiff_axial``: the chain's, for the Newton loop)."""
    n_points = guess.shape[0]
    held = held_points_of(position, quaternion, link)
    distance = math.sqrt(np.sum((position[0] - position[1]) ** 2))
    gap = math.sqrt(np.sum((held[2] - held[1]) ** 2))
    need = (n_points - 3) * link
    if gap > need * (1.0 + MAX_STRAIN) * (1.0 - _EDGE) or \
            distance < 1e-6 * length * (1.0 + _EDGE):
        return HANDED_BACK, 0, math.nan, tolerance
    for i in range(n_points):  # a loop: a slice assignment compiles numba's shape check
        for a in range(3):
            x[i, a] = guess[i, a]
    conform_free_part(x, held, need, length, gravity)
    if roundoff > 0.0:
        tolerance = max(tolerance, roundoff * (length + np.max(np.abs(x))) * stiff)
    history[0] = chain_energy(x, k_s, rest_lengths, k_b, rest_angles, masses, gravity)
    # typed, not literal, constants: the overload `equilibrium` compiles (dloplan.jit)
    outcome, iterations, residual, _, _ = newton_positions(
        x, np.int64(2), n_points - 2, k_s, rest_lengths, k_b, rest_angles, masses, gravity,
        length, tolerance, max_iterations, np.int64(0), 0.25 * length, history, np.int64(1),
        grad, band, np.bool_(True), stiff_axial, np.bool_(False))
    return (HANDED_BACK if outcome == SADDLE else outcome), iterations, residual, tolerance


@njit(cache=True)
def continue_held(shapes, positions, quaternions, k_s, rest_lengths, k_b, rest_angles, masses,
                  gravity, link, length, tolerance, roundoff, stiff, stiff_axial, max_iterations,
                  converged, residuals, eigenvalues, norms):
    """A quasi-static continuation in one call: the equilibria at sub-steps 1 .. m, each from
    the one before, with the smallest eigenvalue of each (the loop of the snap-through check,
    :mod:`dloplan.verify.snap`).

    Sub-step j is :func:`~dloplan.sim.statics.equilibrium` of the cable from ``shapes[j - 1]``
    at clips j with the default tolerance (``tolerance``, ``roundoff``, ``stiff``:
    :func:`_held_item`),
    bit for bit, then the free Hessian at it, dense, and its eigenvalues by LAPACK's symmetric
    solver (those of :func:`dloplan.verify.stability.elastic_stability` to round-off).

    Parameters
    ----------
    shapes : numpy.ndarray
        (m + 1, n + 1, 3): ``shapes[0]`` the start [m]; out: the equilibria.
    positions, quaternions : numpy.ndarray
        (m + 1, 2, 3) clip points [m] and (m + 1, 2, 4) unit quaternions (x, y, z, w).
    k_s, rest_lengths, k_b, rest_angles, masses, gravity
        The chain's constants.
    link, length, tolerance, roundoff, stiff : float
        l [m], L [m], the residual tolerance [N], the round-off factor (16 eps) and the
        largest stiffness [N/m] of its floor (:func:`dloplan.sim.result.residual_tolerance`).
    stiff_axial : bool
        :attr:`dloplan.physics.chain.SpringChain.stiff_axial` of the chain.
    max_iterations : int
        Newton iterations per sub-step.
    converged : numpy.ndarray
        (m + 1,) bool out: the Newton loop met its tolerance.
    residuals, eigenvalues, norms : numpy.ndarray
        (m + 1,) out: the largest free-point force at the equilibrium [N], the smallest
        eigenvalue of its free Hessian [N/m] and that Hessian's infinity norm [N/m].

    Returns
    -------
    int
        The sub-steps done (m, or fewer: sub-step ``done + 1`` is a saddle or at the edge of
        the cable's reach, for :func:`~dloplan.sim.statics.equilibrium` to do).
    """
    n_points = shapes.shape[1]
    n_free = 3 * (n_points - 4)
    history = np.empty(max_iterations + 1)
    band = np.empty((HALF_BANDWIDTH + 1, 3 * n_points))
    grad = np.empty((n_points, 3))
    dense = np.zeros((n_free, n_free))
    for j in range(1, shapes.shape[0]):
        outcome, _, residual, limit = _held_item(
            shapes[j], shapes[j - 1], k_s, rest_lengths, k_b, rest_angles, masses, gravity,
            positions[j], quaternions[j], link, length, tolerance, roundoff, stiff,
            stiff_axial, max_iterations, grad, band, history)
        if outcome == HANDED_BACK:
            return j - 1
        converged[j] = residual <= limit
        chain_derivatives(shapes[j], k_s, rest_lengths, k_b, rest_angles, masses, gravity,
                          grad, band)
        residuals[j] = largest_force(grad, 2, n_points - 2)
        norm = 0.0
        for r in range(n_free):
            row = 0.0
            for c in range(max(0, r - HALF_BANDWIDTH), min(n_free, r + HALF_BANDWIDTH + 1)):
                value = band[r - c, 6 + c] if r >= c else band[c - r, 6 + r]
                dense[r, c] = value
                row += abs(value)
            norm = max(norm, row)
        norms[j] = norm
        eigenvalues[j] = np.linalg.eigvalsh(dense)[0]
    return shapes.shape[0] - 1


@dataclass(frozen=True, eq=False)
class HeldEquilibria:
    """The equilibria of :func:`held_equilibria`, one per item.

    Attributes
    ----------
    shapes : numpy.ndarray
        (B, n + 1, 3) equilibrium shapes [m] (NaN for a refused item).
    clip_wrenches : numpy.ndarray
        (B, 2, 6) force [N] and moment [N m] on each clip, as
        :attr:`~dloplan.sim.result.Equilibrium.clip_wrenches`.
    iterations : numpy.ndarray
        (B,) Newton iterations.
    residuals, tolerances : numpy.ndarray
        (B,) largest free-point force [N] and its tolerance [N].
    converged, stable : numpy.ndarray
        (B,) bool, as in :class:`~dloplan.sim.result.Equilibrium`.
    messages : tuple of str
        What happened to each item, ``equilibrium``'s message, or its ValueError's for a
        refused item (clips out of reach).
    refused : numpy.ndarray
        (B,) bool: ``equilibrium`` refused the item.
    """

    shapes: np.ndarray
    clip_wrenches: np.ndarray
    iterations: np.ndarray
    residuals: np.ndarray
    tolerances: np.ndarray
    converged: np.ndarray
    stable: np.ndarray
    messages: tuple
    refused: np.ndarray

    @property
    def success(self) -> np.ndarray:
        """(B,) converged to a stable equilibrium."""
        return self.converged & self.stable


def held_equilibria(
    cables: Sequence[Cable],
    cable_of,
    guesses,
    clip_positions,
    clip_rotations: Rotation,
    *,
    gravity=GRAVITY,
    rtol: float | None = None,
    max_iterations: int = 500,
) -> HeldEquilibria:
    """The nearest stable equilibria of many cables held by both clips, in one compiled loop.

    Item b is ``equilibrium(cables[cable_of[b]], guesses[b], ClipPoses(clip_positions[b],
    clip_rotations[2 b : 2 b + 2]), gravity=gravity, rtol=rtol, max_iterations=max_iterations)``
    (see the module docstring), bit for bit.

    Parameters
    ----------
    cables : sequence of Cable
        The cables, all with the same number of links n.
    cable_of : array_like
        (B,) int: each item's cable.
    guesses : array_like
        (B, n + 1, 3) starting shapes [m] (they choose the branch).
    clip_positions : array_like
        (B, 2, 3) clip points [m].
    clip_rotations : scipy.spatial.transform.Rotation
        2 B ``clip_to_world`` rotations, the two clips of item 0 first.
    gravity : array_like
        (3,) [m/s^2].
    rtol, max_iterations
        As for :func:`~dloplan.sim.statics.equilibrium`.

    Raises
    ------
    ValueError
        Naming the argument whose shape or values do not fit.
    """
    cables = list(cables)
    if not cables or len({c.n_links for c in cables}) != 1:
        raise ValueError(f"cables: got {len(cables)} cables with n_links "
                         f"{sorted({c.n_links for c in cables})}, expected at least one, all "
                         "with the same number of links")
    n_points = cables[0].n_points
    x0 = np.ascontiguousarray(guesses, dtype=float)
    if x0.ndim != 3 or x0.shape[1:] != (n_points, 3) or not np.all(np.isfinite(x0)):
        raise ValueError(f"guesses: got an array of shape {x0.shape}, expected finite "
                         f"(B, {n_points}, 3)")
    n_items = len(x0)
    index = np.asarray(cable_of)
    if index.shape != (n_items,) or not np.issubdtype(index.dtype, np.integer) or (
            n_items and not 0 <= index.min() <= index.max() < len(cables)):
        raise ValueError(f"cable_of: expected {n_items} integers in 0 .. {len(cables) - 1}")
    positions = np.ascontiguousarray(clip_positions, dtype=float)
    if positions.shape != (n_items, 2, 3) or not np.all(np.isfinite(positions)):
        raise ValueError(f"clip_positions: got an array of shape {positions.shape}, expected "
                         f"finite ({n_items}, 2, 3)")
    if not isinstance(clip_rotations, Rotation) or clip_rotations.single or \
            len(clip_rotations) != 2 * n_items:
        raise ValueError(f"clip_rotations: expected a scipy Rotation of {2 * n_items} "
                         "rotations (two per item)")
    gravity = np.asarray(gravity, dtype=float)
    chains = [SpringChain.from_cable(cable, gravity) for cable in cables]
    constants = [np.array([ch.constants[k] for ch in chains]) for k in range(5)]
    link = np.array([cable.rest_link_length for cable in cables])
    length = np.array([cable.length for cable in cables])
    tolerance = np.array([(DEFAULT_RTOL if rtol is None else rtol) * force_scale(cable, gravity)
                          for cable in cables])
    roundoff = ROUNDOFF * np.finfo(float).eps if rtol is None else 0.0  # the floor, as asked
    stiff = np.array([stiffest(cable) for cable in cables])
    stiff_axial = np.array([chain.stiff_axial for chain in chains])
    quaternions = clip_rotations.as_quat().reshape(n_items, 2, 4)

    cable_of = index.astype(np.int64)
    shapes, gradients, iterations, residuals, status, tolerances = held_loop(
        x0, cable_of, constants, chains[0].constants[5], positions, quaternions, link, length,
        tolerance, roundoff, stiff, stiff_axial, max_iterations)

    wrenches = _clip_wrenches(shapes, gradients, positions)
    converged = residuals <= tolerances
    stable = status == CONVERGED
    refused = np.zeros(n_items, dtype=bool)
    outcomes = {CONVERGED: "converged", MAX_ITERATIONS: "max_iterations", STALLED: "stalled"}
    messages = []
    for b in range(n_items):
        if status[b] != HANDED_BACK:
            message = newton_message(outcomes[status[b]], iterations[b], residuals[b])
            if converged[b] and not stable[b]:
                message += "; the equilibrium is not stable (Hessian not positive definite)"
            messages.append(message)
            continue
        cable = cables[cable_of[b]]
        clips = ClipPoses(positions[b], clip_rotations[2 * b: 2 * b + 2])
        try:
            eq = equilibrium(cable, x0[b], clips, gravity=gravity, rtol=rtol,
                             max_iterations=max_iterations, chain=chains[cable_of[b]])
        except ValueError as exc:
            refused[b], status[b] = True, REFUSED
            messages.append(str(exc))
            continue
        shapes[b], wrenches[b] = eq.shape, eq.clip_wrenches
        iterations[b], residuals[b] = eq.iterations, eq.residual
        converged[b], stable[b] = eq.converged, eq.stable
        messages.append(eq.message)
    return HeldEquilibria(shapes, wrenches, iterations, residuals, tolerances, converged, stable,
                          tuple(messages), refused)


def held_loop(guesses, cable_of, constants, gravity, positions, quaternions, link, length,
              tolerance, roundoff, stiff, stiff_axial, max_iterations) -> tuple:
    """:func:`solve_held` with its outputs made: the arguments as its (``constants`` the five
    per-cable arrays of :attr:`dloplan.physics.chain.SpringChain.constants`, stacked), the
    arrays C-ordered float64 (``cable_of`` int64) as it takes them.

    Returns
    -------
    tuple
        ``(shapes, gradients, iterations, residuals, status, tolerances)``, as
        :func:`solve_held` fills them (an item's ``status`` :data:`HANDED_BACK` for
        :func:`~dloplan.sim.statics.equilibrium` to finish).
    """
    n_items = len(guesses)
    shapes = np.full_like(guesses, np.nan)
    gradients = np.zeros_like(guesses)
    iterations = np.zeros(n_items, dtype=np.int64)
    residuals = np.full(n_items, np.nan)
    status = np.empty(n_items, dtype=np.int64)
    tolerances = np.empty(n_items)
    solve_held(guesses, cable_of, *constants, gravity, positions, quaternions, link, length,
               tolerance, roundoff, stiff, stiff_axial, max_iterations, shapes, gradients,
               iterations, residuals, status, tolerances)
    return shapes, gradients, iterations, residuals, status, tolerances


def _clip_wrenches(x: np.ndarray, grad: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """:func:`~dloplan.sim.result.clip_reactions` of a batch: (B, 2, 6) from shapes and
    gradients (B, n + 1, 3) and clip points (B, 2, 3)."""
    out = np.empty(positions.shape[:-1] + (6,))
    for k, points in enumerate(((0, 1), (-2, -1))):
        force = -grad[:, points[0]] - grad[:, points[1]]
        moment = sum(np.cross(x[:, p] - positions[:, k], -grad[:, p])
                     for p in points)
        out[:, k, :3] = force
        out[:, k, 3:] = moment
    return out
