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

import math

import numpy as np

from ..jit import njit
from ..physics.compiled import chain_derivatives, chain_energy
from ..physics.contact_compiled import point_distance
from .compiled import RUNNING, STALLED, model_step, stop_status
from .newton import step_verdict

__all__ = ["add_penalty", "newton_contacts", "penalty_energy", "penalty_terms"]


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
def newton_contacts(x, first, stop, constants, rows, radius, stiffness, length_scale, tolerance,
                    max_iterations, iterations, trust, history, n_history, grad, band,
                    stop_at_saddle):
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
    shift = 0.0
    f = history[n_history - 1]
    while True:
        chain_derivatives(x, *constants, grad, band)
        penalty_terms(x, rows, radius, stiffness, grad, band)
        residual = 0.0
        for i in range(first, stop):
            residual = max(residual, math.sqrt(grad[i, 0] ** 2 + grad[i, 1] ** 2
                                               + grad[i, 2] ** 2))
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
                                                                  factor, p, False)
            if not solved:
                continue
            trial[:] = x
            for j in range(n_free):
                trial[first + j // 3, j % 3] += alpha * p[j]
            f_trial = chain_energy(trial, *constants) + penalty_energy(trial, rows, radius,
                                                                       stiffness)
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
