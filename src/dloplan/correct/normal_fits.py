"""The model-error fit of the linearized closed loop by its normal equations, many at once.

:func:`~.step.update_modulus` fits ln E, the discretization bias alpha (with its prior) and
the clamp length beta to a measured residual by SVD least squares per residual
(:func:`.model_error.fit_model_error`, :func:`.model_error.parameter_covariance`). The study's
linearized closed loop (:mod:`.linearized`) fits thousands of residuals of the same size
against a handful of columns, so here the fit is solved from its p x p normal equations:

* :func:`fit_amplitudes`: many residuals against shared columns, with the covariance (a
  chunk's first fits);
* :func:`fit_estimates`: many residuals each against its own columns, the estimates alone
  (a round of the model update's Gauss-Newton steps or last amplitudes across a chunk); what it
  cannot fit on the normal equations (a singular system, an estimate not finite) it hands back
  for :func:`fit_estimate`, the same fit of one residual, which falls back to the library's
  fit.

Estimates beyond the amplitudes' bounds are held there and the others refitted, all of a batch
at once.

Equal to the library's fit to round-off (tested).
"""

from __future__ import annotations

import math

import numpy as np

from .model_error import BOUNDS
from .step import fit_with_covariance


def fit_amplitudes(jacobian, directions, residuals, prior) -> list[tuple]:
    """The model-error fit as :func:`~.step.update_modulus` takes it, of many residuals at once,
    by its normal equations: per residual ``(delta ln E, amplitudes, sds, correlation of ln E
    and alpha)``.

    The estimate of :func:`.model_error.fit_model_error` (alpha's prior weighted by the scatter
    of the fit without it) and the sds and correlation of :func:`.model_error.
    parameter_covariance` at what it leaves, from the p x p normal equations of [J, d, g]
    shared by the residuals, instead of SVD least squares per residual (equal to round-off,
    tested). An estimate outside the amplitudes' bounds, or a singular system, is left to those
    functions (the bounds' hold-and-refit).

    Parameters
    ----------
    jacobian : numpy.ndarray or None
        (n + 1, 3) d x / d ln E [m]; None: E held (a zero column: its step and sd 0).
    directions : sequence of numpy.ndarray
        d, or d and g, (n + 1, 3) [m].
    residuals : numpy.ndarray
        (B, n + 1, 3) measured minus the model [m].
    prior : tuple of float
        (alpha_0, sd) of alpha.
    """
    try:
        a, r, i, gram, values = _estimates(jacobian, directions, residuals, prior)
        left = r - values @ a.T
        s2 = np.einsum("bn,bn->b", left, left) / (max(a.shape[0] - len(directions) - 1, 1)
                                                  + (jacobian is None))
        system = np.repeat(gram[None], len(r), axis=0)
        system[:, i, i] += s2 / prior[1] ** 2
        covariance = s2[:, None, None] * np.linalg.inv(system)
    except np.linalg.LinAlgError:
        return [_library_fit(jacobian, directions, x, prior) for x in residuals]
    variance = np.diagonal(covariance, axis1=1, axis2=2)
    ok = np.isfinite(variance) & (variance >= 0)
    sds = np.where(ok, np.sqrt(np.where(ok, variance, 0.0)), math.inf)
    out = []
    for b in range(len(r)):
        amplitudes = values[b, i:]
        if jacobian is None:
            out.append((0.0, amplitudes, np.r_[0.0, sds[b]], 0.0))
        else:
            correlation = 0.0
            if 0.0 < sds[b, 0] < math.inf and 0.0 < sds[b, 1] < math.inf:
                correlation = float(np.clip(covariance[b, 0, 1] / (sds[b, 0] * sds[b, 1]),
                                            -1.0, 1.0))
            out.append((float(values[b, 0]), amplitudes, sds[b], correlation))
    return out


def fit_estimate(jacobian, directions, residual, prior) -> np.ndarray:
    """The estimates of :func:`fit_amplitudes` for one ``residual`` (n + 1, 3) [m], without
    the covariance: ``(delta ln E, amplitudes...)``, or the amplitudes alone without
    ``jacobian`` (a Gauss-Newton step of the model update, or its last amplitudes)."""
    try:
        return _estimates(jacobian, directions, residual[None], prior)[4][0]
    except np.linalg.LinAlgError:
        step, amplitudes = _library_fit(jacobian, directions, residual, prior)[:2]
        return np.asarray(amplitudes) if jacobian is None else np.r_[step, amplitudes]


def columns_of(jacobian, directions) -> np.ndarray:
    """The fit's columns (3 (n + 1), p): [J, d, g], raveled, without J when it is None."""
    columns = [] if jacobian is None else [jacobian.ravel()]
    return np.stack(columns + [d.ravel() for d in directions], axis=1)


def fit_estimates(columns: np.ndarray, residuals: np.ndarray, alpha: int,
                  prior) -> tuple[np.ndarray, np.ndarray]:
    """:func:`fit_estimate` of B residuals, each against its own columns, on their stacked
    normal equations: the estimates ``(B, p)`` and which of them are final ``(B,)`` bool.

    Parameters
    ----------
    columns : numpy.ndarray
        (B, m, p) per residual [J, d, g] (or [d, g], [J, d], [d]), each raveled [m].
    residuals : numpy.ndarray
        (B, m) measured minus the model [m].
    alpha : int
        alpha's column (1 with J, 0 without).
    prior : tuple of float
        (alpha_0, sd) of alpha.

    Returns
    -------
    tuple
        ``(values, final)``: the estimates, those beyond the amplitudes' bounds held there as
        :func:`fit_estimate` holds them; one that is not final (not finite, or every estimate
        when a system is singular) is left to :func:`fit_estimate`.
    """
    count, size, p = columns.shape
    dof = max(size - (p - alpha) - 1, 1)
    transposed = np.swapaxes(columns, 1, 2)
    gram = np.matmul(transposed, columns)
    rhs = np.matmul(transposed, residuals[:, :, None])[:, :, 0]
    try:
        plain = np.linalg.solve(gram, rhs[:, :, None])
        left = residuals - np.matmul(columns, plain)[:, :, 0]
        weight = np.einsum("bn,bn->b", left, left) / dof / prior[1] ** 2
        gram[:, alpha, alpha] += weight
        rhs[:, alpha] += weight * prior[0]
        values = _within_bounds(gram, rhs, np.linalg.solve(gram, rhs[:, :, None])[:, :, 0],
                                alpha)
    except np.linalg.LinAlgError:
        return np.zeros((count, p)), np.zeros(count, dtype=bool)
    return values, np.all(np.isfinite(values), axis=1)


def _estimates(jacobian, directions, residuals, prior) -> tuple:
    """:func:`fit_amplitudes`' estimates: ``(a, r, i, gram, values)``, the columns [J, d, g]
    (3 (n + 1), p), the residuals (B, 3 (n + 1)), alpha's column, a^T a and the estimates
    (B, p): alpha's prior weighted by the scatter of the fit without it (:func:`.model_error.
    fit_model_error`), an estimate outside the amplitudes' bounds held there
    (:func:`_held_at_bounds`). Raises LinAlgError on a singular system."""
    a = columns_of(jacobian, directions)
    r = residuals.reshape(len(residuals), -1)
    i = int(jacobian is not None)  # alpha's column
    dof = max(a.shape[0] - len(directions) - 1, 1)
    gram, rhs = a.T @ a, r @ a
    left = r - np.linalg.solve(gram, rhs.T).T @ a.T
    weight = np.einsum("bn,bn->b", left, left) / dof / prior[1] ** 2
    system = np.repeat(gram[None], len(r), axis=0)
    system[:, i, i] += weight
    rhs_prior = rhs.copy()
    rhs_prior[:, i] += weight * prior[0]
    values = np.linalg.solve(system, rhs_prior[:, :, None])[:, :, 0]
    values = _within_bounds(system, rhs_prior, values, i)
    return a, r, i, gram, values


def _within_bounds(system, target, values, alpha) -> np.ndarray:
    """The estimates ``values`` (B, p), those beyond the amplitudes' bounds
    (:data:`.model_error.BOUNDS`, from column ``alpha`` on) held there (:func:`_held_at_bounds`
    on their normal equations ``system`` (B, p, p) and ``target`` (B, p))."""
    p = values.shape[1]
    bounds = np.array([(-math.inf, math.inf)] * alpha + list(BOUNDS[: p - alpha]))
    out = ~np.all((values >= bounds[:, 0]) & (values <= bounds[:, 1]), axis=1)
    if np.any(out):
        values = values.copy()
        values[out] = _held_at_bounds(system[out], target[out], values[out], bounds)
    return values


def _held_at_bounds(system, target, values, bounds) -> np.ndarray:
    """:func:`.model_error.fit_model_error`'s bounds on the normal equations of B residuals
    (``system`` (B, p, p) with the prior's weight, ``target`` (B, p)) from their estimates
    ``values`` (B, p): in each, the amplitude furthest out held at its bound and the others
    refitted (the held ones' rows of the system made unit rows at their values), until all
    are within or held; ``bounds`` (p, 2)."""
    low, high = bounds[:, 0], bounds[:, 1]
    values = values.copy()
    rows = np.arange(len(values))
    held = np.zeros(values.shape, dtype=bool)
    for _ in range(values.shape[1]):
        excess = np.where(held, -np.inf, np.maximum(low - values, values - high))
        worst = np.argmax(excess, axis=1)
        out = excess[rows, worst] > 0.0
        if not np.any(out):
            break
        take = rows[out]
        values[take, worst[out]] = np.clip(values[take, worst[out]], low[worst[out]],
                                           high[worst[out]])
        held[take, worst[out]] = True
        fixed = held[take]
        a = np.where(fixed[:, :, None], np.eye(values.shape[1]), system[take])
        b = np.where(fixed, values[take], target[take])
        values[take] = np.linalg.solve(a, b[:, :, None])[:, :, 0]
    return values


def _library_fit(jacobian, directions, residual, prior) -> tuple:
    """:func:`fit_amplitudes` by :func:`~.step.fit_with_covariance` (the model-error fit and its
    covariance, as :func:`~.step.update_modulus` takes them); without ``jacobian`` a zero
    column for ln E."""
    column = np.zeros_like(residual) if jacobian is None else jacobian
    return fit_with_covariance(column, directions, residual, prior)
