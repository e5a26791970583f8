"""A quasi-static continuation with contacts in one compiled call (a harness section's moves).

:func:`dloplan.sim.statics.continuation` solves each sub-step with
:func:`~dloplan.sim.statics.equilibrium`; with the board's contacts its Python set-up (the
reach check, the conformed guess, the tolerance, the start's energy with the contacts) and its
result (forces, clip reactions, penetration) cost about as much as the compiled Newton loop of
a harness section (:func:`dloplan.sim.contact_newton.newton_contacts`), and the held model of a
harness job solves some 450 of them. :func:`contact_substeps` solves the sub-steps of a move in
one compiled loop that does, sub-step by sub-step, what ``equilibrium`` does with contacts and
the default tolerance: the held points from the clip poses, the reach test, the guess conformed
(:func:`~dloplan.physics.compiled.conform_free_part`), the residual tolerance with its round-off
floor, the start's energy (the chain's, plus the penalty's summed per obstacle as numpy sums
it: :func:`pairwise_sum`), the trust-region Newton loop from the same trust radius. The same
kernels in the same order: every shape bit for bit ``equilibrium``'s (tested), and its message.

A sub-step whose Newton loop stops at a saddle (the escape along the lowest mode uses LAPACK's
banded solver) or whose clips are at the edge of the cable's reach is handed back to
``equilibrium`` itself, and the compiled loop goes on from its shape.
"""

from __future__ import annotations

import math

import numpy as np

from ..cable import Cable
from ..frames import slerp_quaternions
from ..jit import njit
from ..physics.chain import HALF_BANDWIDTH, SpringChain
from ..physics.compiled import chain_energy, conform_free_part
from ..physics.contact import contact_rows
from ..physics.contact_compiled import signed_distances
from .clips import MAX_STRAIN, ClipPoses, held_points_of
from .compiled import CONVERGED, MAX_ITERATIONS, SADDLE, STALLED
from .contact_newton import newton_contacts
from .newton import newton_message
from .result import DEFAULT_RTOL, EPS, ROUNDOFF, force_scale, stiffest
from .statics import equilibrium, interpolate_clips

PAIRWISE_BLOCK = 128
"""Longest array :func:`pairwise_sum` sums as numpy does (numpy's pairwise summation splits
longer ones): a chain with more points is solved by ``equilibrium`` itself."""

_EDGE = 1e-9  # relative margin of the compiled reach test: closer calls go to equilibrium()

MAX_NEWTON = 500
"""Newton iterations per sub-step: :func:`~dloplan.sim.statics.equilibrium`'s default."""

_OUTCOMES = {CONVERGED: "converged", MAX_ITERATIONS: "max_iterations", STALLED: "stalled"}


@njit(cache=True)
def pairwise_sum(a, n):
    """The sum of a[:n] (n <= :data:`PAIRWISE_BLOCK`) in numpy's order (``np.add.reduce`` of a
    contiguous array: eight partial sums for n >= 8, then the rest one by one)."""
    if n < 8:
        total = -0.0
        for i in range(n):
            total += a[i]
        return total
    r = a[:8].copy()
    i = 8
    while i < n - n % 8:
        for j in range(8):
            r[j] += a[i + j]
        i += 8
    total = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < n:
        total += a[i]
        i += 1
    return total


@njit(cache=True)
def continue_contacts(shapes, positions, quaternions, constants, rows, radius, stiffness, link,
                      length, tolerance, roundoff, stiff, stiff_axial, max_step, max_iterations,
                      start, status, iterations, residuals, limits):
    """The equilibria of sub-steps ``start`` .. m with contacts, each from the one before, in
    place (module docstring).

    Parameters
    ----------
    shapes : numpy.ndarray
        (m + 1, n + 1, 3): ``shapes[start - 1]`` the shape to start from [m]; out: the
        equilibria.
    positions, quaternions : numpy.ndarray
        (m + 1, 2, 3) clip points [m] and (m + 1, 2, 4) unit quaternions (x, y, z, w).
    constants, rows, radius, stiffness
        The chain's constants, the obstacles' contact rows (K, 8), the cable's radius [m] and
        the penalty stiffness [N/m], as :func:`~dloplan.sim.contact_newton.newton_contacts`
        takes them.
    link, length : float
        l and L [m].
    tolerance, roundoff, stiff : float
        The residual tolerance [N], the round-off factor (16 eps) and the largest stiffness
        [N/m] of its floor (:func:`dloplan.sim.result.residual_tolerance`).
    stiff_axial : bool
        :attr:`dloplan.physics.chain.SpringChain.stiff_axial`.
    max_step : float
        The Newton loop's length scale [m] (:func:`~dloplan.sim.statics.equilibrium`'s).
    max_iterations : int
        Newton iterations per sub-step.
    start : int
        The first sub-step to solve (>= 1).
    status, iterations, residuals, limits : numpy.ndarray
        (m + 1,) out: the loop's status (:data:`~dloplan.sim.compiled.CONVERGED` ...), its
        iterations, the residual [N] and the tolerance [N] of each sub-step solved.

    Returns
    -------
    int
        The last sub-step solved (m, or one less than a sub-step to hand back: a saddle, or
        clips at the edge of the reach).
    """
    n_points = shapes.shape[1]
    gravity = constants[5]
    need = (n_points - 3) * link
    history = np.empty(max_iterations + 1)
    band = np.empty((HALF_BANDWIDTH + 1, 3 * n_points))
    grad = np.empty((n_points, 3))
    phi = np.empty((rows.shape[0], n_points))
    normals = np.empty((rows.shape[0], n_points, 3))
    squares = np.empty(n_points)
    for j in range(start, shapes.shape[0]):
        held = held_points_of(positions[j], quaternions[j], link)
        distance = math.sqrt(np.sum((positions[j, 0] - positions[j, 1]) ** 2))
        gap = math.sqrt(np.sum((held[2] - held[1]) ** 2))
        if gap > need * (1.0 + MAX_STRAIN) * (1.0 - _EDGE) or \
                distance < 1e-6 * length * (1.0 + _EDGE):
            return j - 1
        x = shapes[j]
        for i in range(n_points):
            for a in range(3):
                x[i, a] = shapes[j - 1, i, a]
        conform_free_part(x, held, need, length, gravity)
        limit = max(tolerance, roundoff * (length + np.max(np.abs(x))) * stiff)
        signed_distances(x, rows, phi, normals)
        contact = 0.0
        for k in range(rows.shape[0]):
            for i in range(n_points):
                depth = max(radius - phi[k, i], 0.0)
                squares[i] = depth * depth
            contact = contact + 0.5 * stiffness * pairwise_sum(squares, n_points)
        history[0] = chain_energy(x, *constants) + contact
        outcome, done, residual, _, _ = newton_contacts(
            x, np.int64(2), n_points - 2, constants, rows, radius, stiffness, max_step, limit,
            max_iterations, np.int64(0), 0.25 * max_step, history, np.int64(1), grad, band,
            np.bool_(True), stiff_axial)
        if outcome == SADDLE:
            return j - 1
        status[j], iterations[j], residuals[j], limits[j] = outcome, done, residual, limit
    return shapes.shape[0] - 1


def contact_substeps(cable: Cable, chain: SpringChain, start: np.ndarray, before: ClipPoses,
                     after: ClipPoses, count: int) -> tuple[np.ndarray, tuple[str, ...]]:
    """The equilibria at the ``count`` sub-steps from clip poses ``before`` to ``after`` and the
    solver's message of each: :func:`dloplan.sim.statics.continuation`'s ``every_substep``
    solves of that move from ``start`` (the shapes bit for bit, module docstring).

    Parameters
    ----------
    cable : Cable
    chain : SpringChain
        The cable's chain with the contacts (:meth:`SpringChain.from_cable` with ``contacts``).
    start : numpy.ndarray
        (n + 1, 3) the equilibrium at ``before`` [m].
    before, after : ClipPoses
        The move's clip poses.
    count : int
        Sub-steps (the clips interpolated at the fractions j / count, j = 1 .. count).

    Returns
    -------
    shapes : numpy.ndarray
        (count, n + 1, 3) [m].
    messages : tuple of str
    """
    fractions = np.arange(1, count + 1) / count
    # continuation()'s clip poses (interpolate_clips), row 0 unused: the same arrays, since
    # numpy's vectorized sines may differ in the last bit with an element's place in the array
    positions = (1.0 - fractions)[:, None, None] * before.positions \
        + fractions[:, None, None] * after.positions
    keys = np.stack([before.rotations.as_quat(), after.rotations.as_quat()])
    quaternions = slerp_quaternions(np.array([0.0, 1.0]), keys, fractions)
    positions = np.concatenate([before.positions[None], positions])
    quaternions = np.concatenate([keys[:1], quaternions])
    stops = None  # the ClipPoses, made when a sub-step is handed back
    shapes = np.empty((count + 1, cable.n_points, 3))
    shapes[0] = start
    messages = [""] * (count + 1)
    rows = contact_rows(chain.contacts)
    compiled = rows is not None and len(rows) > 0 and cable.n_points <= PAIRWISE_BLOCK
    status, iterations = np.zeros(count + 1, dtype=np.int64), np.zeros(count + 1, dtype=np.int64)
    residuals, limits = np.zeros(count + 1), np.zeros(count + 1)
    tolerance = DEFAULT_RTOL * force_scale(cable, chain.gravity)
    stiff = stiffest(cable, chain.contact_stiffness)
    max_step = max(cable.diameter, 1e-3)  # equilibrium()'s with contacts
    j = 1
    while j <= count:
        done = continue_contacts(
            shapes, positions, quaternions, chain.constants, rows, chain.contact_radius,
            chain.contact_stiffness, cable.rest_link_length, cable.length, tolerance,
            ROUNDOFF * EPS, stiff, chain.stiff_axial, max_step, MAX_NEWTON, j, status,
            iterations, residuals, limits) if compiled else j - 1
        for k in range(j, done + 1):
            messages[k] = _message(int(status[k]), int(iterations[k]), float(residuals[k]),
                                   float(limits[k]))
        j = done + 1
        if j <= count:  # handed back: equilibrium() solves it (or raises as it does)
            stops = stops or interpolate_clips(before, after, fractions)
            eq = equilibrium(cable, shapes[j - 1], stops[j - 1], gravity=chain.gravity,
                             chain=chain)
            shapes[j], messages[j] = eq.shape, eq.message
            j += 1
    return shapes[1:], tuple(messages[1:])


def _message(status: int, iterations: int, residual: float, limit: float) -> str:
    """:func:`~dloplan.sim.statics.equilibrium`'s message of a compiled sub-step."""
    message = newton_message(_OUTCOMES[status], iterations, residual)
    if status != CONVERGED and residual <= limit:
        message += "; the equilibrium is not stable (Hessian not positive definite)"
    return message


__all__ = ["MAX_NEWTON", "PAIRWISE_BLOCK", "contact_substeps", "continue_contacts",
           "pairwise_sum"]
