"""The smallest eigenpair of a banded symmetric matrix from a nearby matrix's, certified.

Along a quasi-static continuation the stiffness changes little from one sub-step to the next, and
so does its lowest mode. :func:`follow_lowest` finds the smallest eigenvalue lambda_1 of a
Hessian band H and its eigenvector from the previous sub-step's mode v_0 by inverse iteration,
on the compiled banded Cholesky factorization of the solvers (:mod:`dloplan.sim.newton`), in
O(N w^2) for N unknowns and half bandwidth w; LAPACK's banded eigen-solver
(:func:`~dloplan.verify.stability.band_eigenpairs`) reduces the band to tridiagonal form in
O(N^2 w) and its eigenvector costs O(N^2) more: about 1.1 ms against 0.1 ms for the 93 free
coordinates of a wire-harness section.

Method
------
1. rho_0 = v_0^T H v_0 (unit v_0) is an upper bound of lambda_1 (Rayleigh's principle). The
   start s = min(rho_0, lambda_prev), lambda_prev the previous sub-step's eigenvalue: where a
   contact's stiff penalty is in the Hessian, the previous mode's small components along it
   put rho_0 far above lambda_1 (0.54 against 0.14 N/m on the USB job), while the eigenvalue
   itself moves by a few per cent from one sub-step to the next.
2. A shift sigma = s - delta, delta = 10^-2, 10^-1 and 1 times max(|s|, ``scale``) in turn,
   until H - sigma I has a Cholesky factor: then every eigenvalue exceeds sigma (Sylvester's
   law of inertia), and inverse iteration converges to lambda_1, the eigenvalue nearest sigma,
   by the factor (lambda_1 - sigma) / (lambda_2 - sigma) per iteration.
3. Iterate v <- (H - sigma I)^-1 v / |...| until the residual r = |H v - rho v|, rho = v^T H v,
   is at most ``tolerance``: an eigenvalue then lies within r of rho, and rho is within
   r^2 / (lambda_2 - rho) of it.
4. **Certificate**: H - (rho - ``tolerance``) I has a Cholesky factor. Then lambda_1 lies in
   (rho - tolerance, rho], whatever the starting vector was: a mode that changed its order
   with another (two eigenvalues crossing between sub-steps) cannot pass for the lowest.

Where a step fails (no factor at any of the three shifts: lambda_1 is below s - max(|s|,
scale), e.g. negative where s was positive; no convergence in :data:`MAX_ITERATIONS`, which
a jump of the eigenvalue at a contact's opening or closing makes slow; the certificate
refused, which includes a Cholesky factorization failing by round-off) the result says so and
the caller solves the eigenproblem by LAPACK.

Tolerance
---------
The certificate holds up to the round-off of the factorization itself: a factor of H - mu I
computed in floating point is the exact factor of H - mu I + E with |E| of order eps |H| times
a small multiple of w (the backward error of Cholesky's method), so the certified interval is
(rho - tolerance - c eps |H|, rho]. :func:`eigenvalue_tolerance` keeps ``tolerance`` at the
round-off floor of an eigenvalue of H (:data:`~dloplan.verify.stability.ROUNDOFF_FACTOR` eps
|H|_inf, the stability test's) or at :data:`RTOL` of the eigenvalue's size, whichever is
larger: LAPACK's eigenvalue carries an error of the same order (its backward error, eps |H|
times a low power of N), so the two agree to the accuracy either has. A caller that judges the
eigenvalue against a threshold takes it only when it clears the threshold by twice the
tolerance, so that the verdict is certain
(``method="follow"`` of :func:`dloplan.verify.stability.elastic_stabilities`).
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from ..sim.newton import cholesky_band, cholesky_solve

RTOL = 1e-9
"""Relative accuracy asked of the eigenvalue (against max(|lambda_1|, scale)) where it exceeds the
round-off floor."""

MAX_ITERATIONS = 12
"""Inverse iterations before giving up (the sub-steps of the shipped examples take 1 to 3)."""


def eigenvalue_tolerance(previous: float, scale: float, norm: float,
                         roundoff_factor: float) -> float:
    """The certified accuracy [N/m] of an eigenvalue near ``previous`` (module docstring):
    max(:data:`RTOL` max(|previous|, scale), roundoff_factor eps norm), ``norm`` = |H|_inf."""
    return max(RTOL * max(abs(previous), scale),
               roundoff_factor * np.finfo(float).eps * norm)


def follow_lowest(band: np.ndarray, previous: np.ndarray, value: float, scale: float,
                  tolerance: float) -> tuple[float, np.ndarray] | None:
    """The smallest eigenvalue of a symmetric band and its unit eigenvector, from a nearby mode.

    Parameters
    ----------
    band : numpy.ndarray
        (w + 1, N) lower band of H, ``band[k, j] = H[j + k, j]`` [N/m].
    previous : numpy.ndarray
        (N,) the starting vector (the previous sub-step's lowest mode); not modified.
    value : float
        The previous sub-step's smallest eigenvalue [N/m].
    scale : float
        A magnitude of eigenvalues of interest [N/m] (> 0): sets the shifts tried where the
        starting Rayleigh quotient is near zero.
    tolerance : float
        The residual asked, and the certified accuracy [N/m] (module docstring,
        :func:`eigenvalue_tolerance`).

    Returns
    -------
    (float, numpy.ndarray) or None
        lambda_1 [N/m], certified in (lambda - tolerance, lambda] up to the factorization's
        round-off, and its unit eigenvector (N,); None where the method does not apply (module
        docstring).
    """
    band = np.ascontiguousarray(band)  # one compiled overload (a band slice is 'A' layout)
    vector = np.array(previous, dtype=float)
    factor = np.empty_like(band)
    work = np.empty(band.shape[1])
    found = _follow_lowest(band, vector, float(value), float(scale), float(tolerance),
                           MAX_ITERATIONS, factor, work)
    return None if math.isnan(found) else (found, vector)


@njit(cache=True)
def _band_product(band, x, out):
    """out <- H x for the lower band of a symmetric H."""
    n = band.shape[1]
    for j in range(n):
        out[j] = band[0, j] * x[j]
    for d in range(1, band.shape[0]):
        for j in range(n - d):
            h = band[d, j]
            out[j + d] += h * x[j]
            out[j] += h * x[j + d]


@njit(cache=True)
def _rayleigh(band, vector, work):
    """Normalize ``vector`` in place; its Rayleigh quotient, H v left in ``work``."""
    length = math.sqrt(np.dot(vector, vector))
    vector /= length
    _band_product(band, vector, work)
    return np.dot(vector, work)


@njit(cache=True)
def _follow_lowest(band, vector, value, scale, tolerance, max_iterations, factor, work):
    """:func:`follow_lowest`'s steps 1-4 (module docstring) in place on ``vector``; NaN where
    one fails."""
    if not np.all(np.isfinite(vector)) or not np.any(vector != 0.0) or not math.isfinite(value):
        return math.nan
    start = min(_rayleigh(band, vector, work), value)
    size = max(abs(start), scale)
    shift = math.nan
    for k in range(3):
        sigma = start - size * 10.0 ** (k - 2)
        if cholesky_band(band, -sigma, factor):
            shift = sigma
            break
    if math.isnan(shift):
        return math.nan
    for _ in range(max_iterations):
        cholesky_solve(factor, vector)
        rho = _rayleigh(band, vector, work)
        residual = 0.0
        for j in range(vector.shape[0]):
            residual += (work[j] - rho * vector[j]) ** 2
        if math.sqrt(residual) <= tolerance:
            return rho if cholesky_band(band, tolerance - rho, factor) else math.nan
    return math.nan


__all__ = ["MAX_ITERATIONS", "RTOL", "eigenvalue_tolerance", "follow_lowest"]
