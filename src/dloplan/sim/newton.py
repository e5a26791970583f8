"""Banded linear algebra and the trust-region Newton loop shared by every static solver.

The Hessians of a cable's energy are symmetric bands (a point couples with its neighbours only),
so each Newton iteration costs O(n): a banded Cholesky factorization (LAPACK ``dpbtrf``) and two
triangular solves (``dpbtrs``). Bands use the lower layout of
``scipy.linalg.cholesky_banded(lower=True)``: ``band[k, j] = H[j + k, j]``.

:func:`trust_region_newton` is the minimizer (see :mod:`dloplan.sim.statics` for the method): it
knows nothing of cables, only an energy, its gradient and Hessian band, how a step moves the
state and how long a step is. Positions only (:func:`dloplan.sim.statics.minimize_energy`) and
positions with twist angles (:mod:`dloplan.sim.torsion`) share it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ..jit import njit, njit_leaf

NEUTRAL = 1e-9
"""Relative shift under which a Hessian still counts as positive (semi-)definite: a mode of zero
stiffness is neutral, not unstable."""

MAX_ESCAPES = 20
"""Saddle escapes per solve before a saddle counts as a point to step on from."""


def free_band(band: np.ndarray, free: slice) -> np.ndarray:
    """The band of the coordinates of a contiguous range of points, 3 per point.

    Parameters
    ----------
    band : numpy.ndarray
        (w + 1, 3(n + 1)) lower band over all points' coordinates.
    free : slice
        Contiguous point range (step 1, explicit start and stop, or a negative stop).
    """
    start, stop, _ = free.indices(band.shape[1] // 3)
    return band[:, 3 * start : 3 * stop]


def factor_band(band: np.ndarray, shift: float = 0.0) -> np.ndarray | None:
    """Banded Cholesky factor of ``band + shift I``, or None if not positive definite.

    The factor L is in the same lower layout (``factor[k, j] = L[j + k, j]``, as LAPACK dpbtrf
    and ``scipy.linalg.cholesky_banded(lower=True)`` return it).

    Parameters
    ----------
    band : numpy.ndarray
        (w + 1, N) lower band of a symmetric matrix; not modified.
    shift : float
        Added to the diagonal (negative to test definiteness above a bound).
    """
    factor = np.empty_like(band, dtype=float)
    return factor if cholesky_band(band, shift, factor) else None


def solve_band(factor: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve ``A y = rhs`` (rhs (N,)) with a factor of :func:`factor_band`."""
    out = np.array(rhs, dtype=float)
    cholesky_solve(factor, out)
    return out


@njit(cache=True, inline="always")
def _eliminate(factor, j, m):
    """Column j of the right-looking banded Cholesky: its pivot, its m entries below the
    diagonal, and their rank-1 update of the trailing m x m triangle; False for a pivot that is
    not positive (also NaN). With a constant m (the bulk of a band of known width) numba unrolls
    the loops, and the updates carry no dependency chain."""
    pivot = factor[0, j]
    if not pivot > 0.0:
        return False
    pivot = math.sqrt(pivot)
    factor[0, j] = pivot
    inverse = 1.0 / pivot
    for i in range(1, m + 1):
        factor[i, j] *= inverse
    for i in range(1, m + 1):
        l_ij = factor[i, j]
        for k in range(i, m + 1):  # L[j + k, j + i] -= L[j + k, j] L[j + i, j]
            factor[k - i, j + i] -= factor[k, j] * l_ij
    return True


@njit(cache=True, inline="always")
def _substitute(factor, rhs, j, m):
    """Forward step j of L z = rhs (column oriented: z_j, then its m updates below)."""
    value = rhs[j] / factor[0, j]
    rhs[j] = value
    for k in range(1, m + 1):
        rhs[j + k] -= factor[k, j] * value


@njit(cache=True, inline="always")
def _back_substitute(factor, rhs, j, m):
    """Backward step j of L^T y = z (a dot product of m entries)."""
    value = rhs[j]
    for k in range(1, m + 1):
        value -= factor[k, j] * rhs[j + k]
    rhs[j] = value / factor[0, j]


FACTOR, FORWARD, BACKWARD = 0, 1, 2
"""The three passes of a banded Cholesky solve (:func:`_bulk_pass`)."""


@njit(cache=True, inline="always")
def _bulk_pass(step, factor, rhs, stop, w):
    """One pass over the bulk columns ``0 .. stop - 1`` of a band of half width w (those whose
    w entries below the diagonal all exist): the factorization (False at a pivot that is not
    positive), the forward or the backward substitution of ``rhs``."""
    if step == FACTOR:
        for j in range(stop):
            if not _eliminate(factor, j, w):
                return False
    elif step == FORWARD:
        for j in range(stop):
            _substitute(factor, rhs, j, w)
    else:
        for j in range(stop - 1, -1, -1):
            _back_substitute(factor, rhs, j, w)
    return True


# The bulk at the half widths of the chain's band (3 coordinates per point, 3 points per joint),
# of positions with twist angles interleaved (dloplan.sim.torsion), and of the twist angles alone
# (dloplan.sim.stepping), w a literal: numba inlines _bulk_pass and LLVM unrolls its loops. Three
# functions with names of their own, not closures made by one factory: closures share one
# qualified name, numba tells compilations apart by a per-process counter in the symbol name, and
# cached code written by two processes (two test workers compiling at once) then holds two
# different kernels under one symbol: the loader linked the width-8 pass into width-10 solves.
@njit_leaf(cache=True)
def _bulk_8(step, factor, rhs, stop):
    return _bulk_pass(step, factor, rhs, stop, 8)


@njit_leaf(cache=True)
def _bulk_10(step, factor, rhs, stop):
    return _bulk_pass(step, factor, rhs, stop, 10)


@njit_leaf(cache=True)
def _bulk_1(step, factor, rhs, stop):
    return _bulk_pass(step, factor, rhs, stop, 1)


@njit_leaf(cache=True)
def _bulk(step, factor, rhs, stop):
    """:func:`_bulk_pass` at the factor's half width, with a constant width where one is
    compiled."""
    w = factor.shape[0] - 1
    if w == 8:
        return _bulk_8(step, factor, rhs, stop)
    if w == 10:
        return _bulk_10(step, factor, rhs, stop)
    if w == 1:
        return _bulk_1(step, factor, rhs, stop)
    return _bulk_pass(step, factor, rhs, stop, w)


@njit_leaf(cache=True)
def cholesky_band(band, shift, factor):
    """Compiled banded Cholesky: ``factor`` <- L of ``band + shift I``; returns False (``factor``
    then undefined) if a pivot is not positive. O(N w^2) for N unknowns and half bandwidth w.

    Right-looking (column j scaled, then the trailing triangle updated, as LAPACK's dpbtf2 does
    with dsyr); for w = 8, 10 and 1 the bulk of the columns runs with w a compile-time constant,
    3 to 4 times faster than loops with variable bounds.
    """
    w = band.shape[0] - 1
    n = band.shape[1]
    for i in range(w + 1):  # row by row: the band's rows are contiguous, its columns strided
        for j in range(n):
            factor[i, j] = band[i, j]
    for j in range(n):
        factor[0, j] += shift
    bulk = max(n - w, 0)
    if not _bulk(np.int64(FACTOR), factor, factor[0], bulk):  # int64: one overload per width
        return False
    for j in range(bulk, n):  # the last columns, with fewer entries below the diagonal
        if not _eliminate(factor, j, n - 1 - j):
            return False
    return True


@njit_leaf(cache=True)
def cholesky_solve(factor, rhs):
    """Solve L L^T y = rhs in place with a factor of :func:`cholesky_band`."""
    n = factor.shape[1]
    bulk = max(n - factor.shape[0] + 1, 0)
    _bulk(np.int64(FORWARD), factor, rhs, bulk)
    for j in range(bulk, n):  # L z = rhs
        _substitute(factor, rhs, j, n - 1 - j)
    for j in range(n - 1, bulk - 1, -1):  # L^T y = z
        _back_substitute(factor, rhs, j, n - 1 - j)
    _bulk(np.int64(BACKWARD), factor, rhs, bulk)


def lowest_eigenpair(band: np.ndarray) -> tuple[float, np.ndarray]:
    """The smallest eigenvalue [N/m] and its unit eigenvector (N,) of a symmetric matrix given
    by its lower band (w + 1, N) [N/m] (LAPACK's banded solver)."""
    values, vectors = sla.eig_banded(band, lower=True, select="i", select_range=(0, 0),
                                     check_finite=False)
    return float(values[0]), vectors[:, 0]


@dataclass(frozen=True, eq=False)
class NewtonRun:
    """Outcome of :func:`trust_region_newton`.

    Attributes
    ----------
    state : object
        The final state (whatever the caller's ``moved`` builds).
    extra : object
        The fourth item of the last ``derivatives(state)`` call (e.g. the full gradient).
    iterations : int
        Newton iterations.
    residual : float
        The residual of the last evaluation (the caller's unit, e.g. [N]).
    stable : bool
        Residual below the tolerance and the free Hessian positive definite.
    history : numpy.ndarray
        Energy after each accepted iteration [J].
    message : str
        What happened.
    """

    state: object
    extra: object
    iterations: int
    residual: float
    stable: bool
    history: np.ndarray
    message: str


def trust_region_newton(
    state, energy_of, derivatives, moved, displacement, length_scale: float, tolerance: float,
    max_iterations: int = 500, unit: str = "N", corrected=None, limit=None,
) -> NewtonRun:
    """The trust-region (Levenberg-Marquardt) Newton loop of the static solvers.

    Each iteration solves (H + lambda I) p = -g by :func:`factor_band`; lambda = 0 whenever H is
    positive definite and the quadratic model is trusted, otherwise it grows until the
    factorization succeeds and shrinks again as steps succeed. A step is accepted only if the
    energy decreases and no coordinate moves farther than the trust radius; the ratio of actual to
    predicted decrease adapts lambda and the radius. At a saddle (residual converged, Hessian
    indefinite) the loop steps downhill along :func:`lowest_eigenpair`'s vector and carries on.

    Parameters
    ----------
    state : object
        The start.
    energy_of : callable
        ``energy_of(state) -> float`` [J].
    derivatives : callable
        ``derivatives(state) -> (g, band, residual, extra)``: the gradient over the free
        coordinates (1-D), the lower band of their Hessian, the residual compared with
        ``tolerance``, and anything to hand back.
    moved : callable
        ``moved(state, p) -> state``: the state after the step ``p`` of the free coordinates.
    displacement : callable
        ``displacement(p) -> float``: the size of a step [m], compared with the trust radius.
    length_scale : float
        Largest step [m] at the start (a quarter of it) and ever (all of it).
    tolerance : float
        Residual for convergence.
    max_iterations : int
        Iteration limit.
    unit : str
        Unit of the residual, for the messages.
    corrected : callable, optional
        ``corrected(state, p) -> state or None``: the state after the step ``p`` with a
        second-order correction (a chain's :func:`dloplan.sim.compiled.restore_link_lengths`),
        or None where none applies. Tried when the plain step is not a very successful one
        (:func:`wants_correction`); the trial with the lower energy goes to the ratio test.
    limit : callable, optional
        ``limit(state, p) -> float`` in (0, 1]: the fraction of the (radius-truncated) step
        ``p`` to take (contacts: where the first free point enters an obstacle,
        :func:`dloplan.physics.contact.entry_fraction`).
    """
    radius = 0.25 * length_scale  # trust radius: the largest point displacement of one step
    shift = 0.0
    f = energy_of(state)
    history = [f]
    iterations = 0
    message = ""
    stable = False
    escapes = 0
    while True:
        gf, band, residual, extra = derivatives(state)
        scale = float(np.mean(band[0]))
        # stable: positive definite up to a relative 1e-9 (a zero-stiffness mode is neutral)
        stable = residual <= tolerance and factor_band(band, NEUTRAL * scale) is not None
        if stable or iterations >= max_iterations:
            message = newton_message("converged" if stable else "max_iterations", iterations,
                                     residual, unit)
            break
        if residual <= tolerance and escapes < MAX_ESCAPES:
            # a saddle (an unstable equilibrium): leave it downhill along the direction of
            # most negative curvature, then carry on with Newton toward a stable one
            escaped = escape_saddle(state, f, band, energy_of, moved, displacement, radius)
            iterations += 1
            escapes += 1
            if escaped is None:
                message = newton_message("stuck", iterations, residual, unit)
                break
            state, f = escaped
            history.append(f)
            shift = 0.0
            continue
        accepted = False
        for _ in range(60):  # adapt the shift until a step is accepted
            factor = factor_band(band, shift)
            if factor is None:
                shift = max(4.0 * shift, 1e-8 * scale)
                continue
            p = -solve_band(factor, gf)
            longest = displacement(p)
            alpha = min(1.0, radius / longest) if longest > 0 else 1.0  # truncate to the radius
            if limit is not None:
                alpha *= limit(state, alpha * p)
            # model decrease g.p + p.H.p/2 with (H + shift I) p_full = -g, p = alpha p_full
            g_p = float(gf @ p)
            predicted = alpha * g_p + 0.5 * alpha**2 * (-g_p - shift * float(p @ p))
            p *= alpha
            trial = moved(state, p)
            f_trial = energy_of(trial)
            if corrected is not None and wants_correction(f, f_trial, predicted):
                better = corrected(state, p)
                f_better = energy_of(better) if better is not None else math.inf
                if f_better < f_trial:
                    trial, f_trial = better, f_better
            accepted, shift, radius = step_verdict(f, f_trial, predicted, shift, scale, radius,
                                                   longest, length_scale)
            if accepted:
                state, f = trial, f_trial
                break
        iterations += 1
        if not accepted:
            message = newton_message("stalled", iterations, residual, unit)
            break
        history.append(f)
    return NewtonRun(state, extra, iterations, residual, stable, np.asarray(history), message)


@njit(cache=True)
def wants_correction(f, f_trial, predicted):
    """Whether to try a second-order correction of a trial step: unless the step already
    gives more than 3/4 of the decrease the quadratic model predicted (``step_verdict``'s very
    successful step, where the correction would only cost an energy evaluation)."""
    return not (predicted < 0.0 and f_trial - f <= 0.75 * predicted)


@njit(cache=True)
def step_verdict(f, f_trial, predicted, shift, scale, radius, longest, length_scale):
    """Accept a trust-region step or not, and the next shift and radius (all the Newton loops).

    A step is accepted if the model predicts a decrease and the energy does not rise beyond
    round-off; the ratio of actual to predicted decrease then relaxes (> 0.75) or tightens
    (< 0.25) the shift, and a rejection tightens the shift and halves the radius.

    Parameters
    ----------
    f, f_trial : float
        Energies before and after the step [J].
    predicted : float
        The quadratic model's change [J].
    shift, scale : float
        Levenberg-Marquardt shift and the Hessian's mean diagonal (its scale).
    radius, longest, length_scale : float
        Trust radius, the step's size and the largest radius [m].

    Returns
    -------
    tuple
        ``(accepted, shift, radius)``.
    """
    actual = f_trial - f
    noise = 1e-13 * (abs(f) + abs(predicted)) + 1e-300
    if predicted < 0 and (actual < 0 or abs(actual) < noise):
        ratio = actual / predicted if abs(predicted) > noise else 1.0
        if ratio > 0.75:
            shift = 0.0 if shift < 1e-6 * scale else shift / 8.0
            radius = min(2.0 * radius, length_scale)
        elif ratio < 0.25:
            shift = max(4.0 * shift, 1e-8 * scale)
        return True, shift, radius
    shift = max(4.0 * shift, 1e-8 * scale)
    radius = max(0.5 * min(radius, longest), 1e-9 * length_scale)
    return False, shift, radius


def newton_message(outcome: str, iterations: int, residual: float, unit: str = "N") -> str:
    """What a Newton run ended with, in words.

    ``outcome``: "converged", "max_iterations", "stuck" (at a saddle no step leaves) or
    "stalled" (no step lowers the energy).
    """
    if outcome == "converged":
        return f"converged in {iterations} iterations"
    if outcome == "max_iterations":
        return f"no convergence in {iterations} iterations (residual {residual:.3g} {unit})"
    if outcome == "stuck":
        return f"stuck at an unstable equilibrium after {iterations} iterations"
    return f"stalled after {iterations} iterations (residual {residual:.3g} {unit})"


def escape_saddle(state, f, band, energy_of, moved, displacement, radius):
    """A step from a saddle along the eigenvector of the most negative Hessian eigenvalue.

    Tries both signs with a backtracking length, starting at the trust radius; returns
    ``(state, energy)`` of the first step that lowers the energy, or None.
    """
    _, mode = lowest_eigenpair(band)
    direction = mode / displacement(mode)
    length = radius
    for _ in range(40):
        for sign in (1.0, -1.0):
            trial = moved(state, sign * length * direction)
            f_trial = energy_of(trial)
            if f_trial < f:
                return trial, f_trial
        length *= 0.5
    return None
