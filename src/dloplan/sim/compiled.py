"""The static solver's Newton loop for positions, compiled: no Python per iteration.

:func:`dloplan.sim.newton.trust_region_newton` is the readable, generic loop (any state, any
energy: positions with contacts, twist angles). For the plain chain (positions only, no contact
obstacles) every iteration is the same few kernels, so the whole loop runs here in one numba
function: the compiled energy, gradient and Hessian band of :mod:`dloplan.physics.compiled` and
the compiled banded Cholesky of :mod:`dloplan.sim.newton`. It takes the same decisions in the same
order as the generic loop (tests compare both, iterate by iterate), and hands back to Python at
a saddle, where :func:`dloplan.sim.newton.escape_saddle` (an eigenvector of the band) takes over.

Status codes of :func:`newton_positions`: :data:`CONVERGED`, :data:`MAX_ITERATIONS`,
:data:`STALLED`, :data:`SADDLE`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..physics.compiled import chain_derivatives, chain_energy
from .newton import NEUTRAL, cholesky_band, cholesky_solve

CONVERGED, MAX_ITERATIONS, STALLED, SADDLE = 0, 1, 2, 3


@njit(cache=True)
def _longest(p):
    """Largest point displacement of a step p over free points (3 coordinates each) [m]."""
    longest = 0.0
    for i in range(p.shape[0] // 3):
        d = math.sqrt(p[3 * i] ** 2 + p[3 * i + 1] ** 2 + p[3 * i + 2] ** 2)
        longest = max(longest, d)
    return longest


@njit(cache=True)
def newton_positions(x, first, stop, k_s, rest_lengths, k_b, rest_angles, masses, gravity,
                     length_scale, tolerance, max_iterations, iterations, radius, history,
                     n_history, grad, band, stop_at_saddle):
    """Run the trust-region Newton loop on the free points ``first .. stop - 1`` of x, in place.

    Parameters
    ----------
    x : numpy.ndarray
        (n + 1, 3) state [m], updated in place.
    first, stop : int
        The free point range.
    k_s, rest_lengths, k_b, rest_angles, masses, gravity
        The chain's constants (:attr:`dloplan.physics.chain.SpringChain.constants`).
    length_scale, tolerance, max_iterations
        As in :func:`dloplan.sim.newton.trust_region_newton`.
    iterations : int
        Iterations already done (after a saddle escape).
    radius : float
        Trust radius [m] to start with.
    history : numpy.ndarray
        (max_iterations + 1,) energies [J]; ``history[:n_history]`` are filled already, the
        first being the start's energy.
    n_history : int
        Entries of ``history`` in use.
    grad, band : numpy.ndarray
        (n + 1, 3) and (9, 3(n + 1)) work arrays: on return the last gradient [N] and band.
    stop_at_saddle : bool
        Return :data:`SADDLE` at a converged but unstable point (else step on from it).

    Returns
    -------
    tuple
        ``(status, iterations, residual, radius, n_history)``.
    """
    free = slice(3 * first, 3 * stop)
    n_free = 3 * (stop - first)
    factor = np.empty((band.shape[0], n_free))
    p = np.empty(n_free)
    trial = np.empty_like(x)
    shift = 0.0
    f = history[n_history - 1]
    while True:
        chain_derivatives(x, k_s, rest_lengths, k_b, rest_angles, masses, gravity, grad, band)
        residual = 0.0
        for i in range(first, stop):
            residual = max(residual, math.sqrt(grad[i, 0] ** 2 + grad[i, 1] ** 2
                                               + grad[i, 2] ** 2))
        g = grad.ravel()[free]
        h = band[:, free]
        scale = np.mean(h[0])
        if residual <= tolerance and cholesky_band(h, NEUTRAL * scale, factor):
            return CONVERGED, iterations, residual, radius, n_history
        if iterations >= max_iterations:
            return MAX_ITERATIONS, iterations, residual, radius, n_history
        if residual <= tolerance and stop_at_saddle:
            return SADDLE, iterations, residual, radius, n_history
        accepted = False
        for _ in range(60):  # adapt the shift until a step is accepted
            if not cholesky_band(h, shift, factor):
                shift = max(4.0 * shift, 1e-8 * scale)
                continue
            for j in range(n_free):
                p[j] = g[j]
            cholesky_solve(factor, p)
            g_p = 0.0
            p_p = 0.0
            for j in range(n_free):
                p[j] = -p[j]
                g_p += g[j] * p[j]
                p_p += p[j] * p[j]
            longest = _longest(p)
            alpha = min(1.0, radius / longest) if longest > 0 else 1.0
            predicted = alpha * g_p + 0.5 * alpha**2 * (-g_p - shift * p_p)
            trial[:] = x
            for j in range(n_free):
                trial[first + j // 3, j % 3] += alpha * p[j]
            f_trial = chain_energy(trial, k_s, rest_lengths, k_b, rest_angles, masses, gravity)
            actual = f_trial - f
            noise = 1e-13 * (abs(f) + abs(predicted)) + 1e-300
            if predicted < 0 and (actual < 0 or abs(actual) < noise):
                ratio = actual / predicted if abs(predicted) > noise else 1.0
                x[:] = trial
                f = f_trial
                accepted = True
                if ratio > 0.75:
                    shift = 0.0 if shift < 1e-6 * scale else shift / 8.0
                    radius = min(2.0 * radius, length_scale)
                elif ratio < 0.25:
                    shift = max(4.0 * shift, 1e-8 * scale)
                break
            shift = max(4.0 * shift, 1e-8 * scale)
            radius = max(0.5 * min(radius, longest), 1e-9 * length_scale)
        iterations += 1
        if not accepted:
            return STALLED, iterations, residual, radius, n_history
        history[n_history] = f
        n_history += 1
