"""The static Newton loop with one-sided contacts, compiled: a held cable on a board.

:func:`dloplan.sim.statics.equilibrium` with ``contacts`` (pegs, plates, the table) minimizes
U(x) + U^c(x), the chain's energy plus the contact penalty of :mod:`dloplan.physics.contact`:

    U^c = sum_i sum_k 1/2 k_c max(0, r - phi_k(x_i))^2,

phi_k the signed distance of point i to obstacle k and r the cable's radius; its gradient is
-k_c d n per pressing point (d = r - phi > 0, n the outward normal) and its Hessian the block
k_c n n^T (the statics' Hessian: the curvature term of a round face is left out, see
:mod:`dloplan.physics.contact`). The obstacles are the compiled rows of
:mod:`dloplan.physics.contact_compiled` (``contact_row()``: the table, cylinders, boxes).

:func:`newton_contacts` is the trust-region Newton loop of :func:`dloplan.sim.newton.
trust_region_newton` (and of the contact-free :func:`dloplan.sim.compiled.newton_positions`),
taking the same decisions in the same order with this energy, in one numba function: no Python
per iteration. A harness job solves thousands of such equilibria (the continuations of its
checks); the generic loop spent about 0.3 ms of Python per iteration on them. At a saddle it
returns :data:`~dloplan.sim.compiled.SADDLE` and :func:`dloplan.sim.newton.escape_saddle`
takes over, as for the plain chain.
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from ..physics.compiled import chain_derivatives, chain_energy
from ..physics.contact import ENTRY_DEPTH
from ..physics.contact_compiled import point_distance
from .compiled import (
    RUNNING,
    STALLED,
    largest_force,
    model_change,
    model_step,
    moved_by,
    restore_link_lengths,
    stop_status,
)
from .newton import step_verdict, wants_correction

__all__ = ["add_penalty", "entry_fraction_rows", "newton_contacts", "penalty_energy",
           "penalty_terms"]


@njit(cache=True)
def penalty_terms(x, rows, radius, stiffness, grad, band):
    """Add the penalty's gradient [N] to ``grad`` (n + 1, 3) and its blocks k_c n n^T [N/m] to
    the lower ``band`` (9, 3(n + 1)); return its energy [J] (module docstring)."""
    total = 0.0
    for k in range(rows.shape[0]):
        for i in range(x.shape[0]):
            phi, n0, n1, n2 = point_distance(x[i, 0], x[i, 1], x[i, 2], rows[k])
            depth = radius - phi
            if depth <= 0.0:
                continue
            total += 0.5 * stiffness * depth * depth
            add_penalty(i, depth, n0, n1, n2, stiffness, grad, band)
    return total


@njit(cache=True, inline="always")
def add_penalty(i, depth, n0, n1, n2, stiffness, grad, band):
    """Add one pressing point's penalty: the gradient -k_c d n [N] to row i of ``grad`` and the
    block k_c n n^T [N/m] to the lower ``band`` (module docstring)."""
    push = stiffness * depth
    grad[i, 0] -= push * n0
    grad[i, 1] -= push * n1
    grad[i, 2] -= push * n2
    j = 3 * i
    band[0, j] += stiffness * n0 * n0
    band[0, j + 1] += stiffness * n1 * n1
    band[0, j + 2] += stiffness * n2 * n2
    band[1, j] += stiffness * n1 * n0
    band[1, j + 1] += stiffness * n2 * n1
    band[2, j] += stiffness * n2 * n0


@njit(cache=True)
def penalty_energy(x, rows, radius, stiffness):
    """The penalty's energy U^c [J] of a shape (n + 1, 3) (module docstring)."""
    total = 0.0
    for k in range(rows.shape[0]):
        for i in range(x.shape[0]):
            depth = radius - point_distance(x[i, 0], x[i, 1], x[i, 2], rows[k])[0]
            if depth > 0.0:
                total += 0.5 * stiffness * depth * depth
    return total


@njit(cache=True)
def entry_fraction_rows(x, trial, first, stop, rows, radius):
    """:func:`dloplan.physics.contact.entry_fraction` over the compiled rows: the fraction in
    (0, 1] of the move from ``x`` to ``trial`` (free points ``first .. stop - 1``) that lands
    every point out of contact at ``x`` at most ``ENTRY_DEPTH * radius`` deep in an obstacle
    (its depth interpolated linearly along the move)."""
    landing = ENTRY_DEPTH * radius
    fraction = 1.0
    for k in range(rows.shape[0]):
        for i in range(first, stop):
            before = radius - point_distance(x[i, 0], x[i, 1], x[i, 2], rows[k])[0]
            if before > 0.0:
                continue
            after = radius - point_distance(trial[i, 0], trial[i, 1], trial[i, 2], rows[k])[0]
            if after > landing:
                fraction = min(fraction, (landing - before) / (after - before))
    return fraction


@njit(cache=True)
def newton_contacts(x, first, stop, constants, rows, radius, stiffness, length_scale, tolerance,
                    max_iterations, iterations, trust, history, n_history, grad, band,
                    stop_at_saddle, stiff):
    """Run the trust-region Newton loop on U + U^c over the free points ``first .. stop - 1``.

    Parameters
    ----------
    x : numpy.ndarray
        (n + 1, 3) state [m], updated in place.
    first, stop : int
        The free point range.
    constants : tuple
        The chain's constants (:attr:`dloplan.physics.chain.SpringChain.constants`).
    rows : numpy.ndarray
        (K, 8) the obstacles' contact rows.
    radius, stiffness : float
        The cable's radius [m] and the penalty stiffness k_c [N/m].
    length_scale, tolerance, max_iterations
        As in :func:`dloplan.sim.newton.trust_region_newton`.
    iterations : int
        Iterations already done (after a saddle escape).
    trust : float
        Trust radius [m] to start with.
    history : numpy.ndarray
        (max_iterations + 1,) energies [J]; ``history[:n_history]`` are filled already.
    n_history : int
        Entries of ``history`` in use.
    grad, band : numpy.ndarray
        (n + 1, 3) and (9, 3(n + 1)) work arrays: on return the last gradient [N] and band.
    stop_at_saddle : bool
        Return :data:`SADDLE` at a converged but unstable point (else step on from it).
    stiff : bool
        Stiff axial springs (:attr:`dloplan.physics.chain.SpringChain.stiff_axial`): take of
        each step the fraction :func:`entry_fraction_rows` that lands a point entering an
        obstacle just inside it, and try the second-order correction
        :func:`dloplan.sim.compiled.restore_link_lengths` on a step that is not very successful,
        as the generic loop does (:func:`dloplan.sim.statics.minimize_energy`). Without the
        landing, a step that carries a free point deep into an obstacle the Hessian did not
        see is rejected by the penalty's energy, halving the trust radius, again and again:
        a sub-step of the Ethernet harness' phase 2 crawled 500 iterations (585 to converge),
        against 24 with it.

    Returns
    -------
    tuple
        ``(status, iterations, residual, trust, n_history)``, the status codes of
        :func:`dloplan.sim.compiled.newton_positions`.
    """
    free = slice(3 * first, 3 * stop)
    n_free = 3 * (stop - first)
    factor = np.empty((band.shape[0], n_free))
    p = np.empty(n_free)
    trial = np.empty_like(x)
    corrected = np.empty_like(x)
    shift = 0.0
    f = history[n_history - 1]
    while True:
        chain_derivatives(x, *constants, grad, band)
        penalty_terms(x, rows, radius, stiffness, grad, band)
        residual = largest_force(grad, first, stop)
        g = grad.ravel()[free]
        h = band[:, free]
        scale = np.mean(h[0])
        status = stop_status(residual, tolerance, h, scale, factor, iterations, max_iterations,
                             stop_at_saddle)
        if status != RUNNING:
            return status, iterations, residual, trust, n_history
        accepted = False
        for _ in range(60):  # adapt the shift until a step is accepted
            solved, shift, longest, alpha, predicted = model_step(h, g, shift, scale, trust,
                                                                  factor, p, np.bool_(False))
            if not solved:
                continue
            moved_by(x, alpha, p, first, trial)
            if stiff:  # land a point entering an obstacle just inside it
                landed = entry_fraction_rows(x, trial, first, stop, rows, radius)
                if landed < 1.0:
                    alpha *= landed
                    predicted = model_change(alpha, np.dot(g, p), np.dot(p, p), shift)
                    moved_by(x, alpha, p, first, trial)
            f_trial = chain_energy(trial, *constants) + penalty_energy(trial, rows, radius,
                                                                       stiffness)
            if stiff and wants_correction(f, f_trial, predicted):
                corrected[:] = trial
                if restore_link_lengths(x, corrected, first, stop):
                    f_corrected = chain_energy(corrected, *constants) \
                        + penalty_energy(corrected, rows, radius, stiffness)
                    if f_corrected < f_trial:
                        trial[:] = corrected
                        f_trial = f_corrected
            accepted, shift, trust = step_verdict(f, f_trial, predicted, shift, scale, trust,
                                                  longest, length_scale)
            if accepted:
                x[:] = trial
                f = f_trial
                break
        iterations += 1
        if not accepted:
            return STALLED, iterations, residual, trust, n_history
        history[n_history] = f
        n_history += 1
