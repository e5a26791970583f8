"""Least-squares cubic splines of many measurements at once, compiled.

:func:`.measurement.smooth_polyline` fits each coordinate of a measurement's points by a cubic
spline over their positions along the prediction (:func:`scipy.interpolate.make_lsq_spline`,
QR of the banded design matrix) and evaluates it on a dense grid. For a study's chunk the same
fit runs here measurement by measurement in one compiled loop: the knots ``u_0`` (x4), the
interior ``linspace(u_0, u_end, spans + 1)``, ``u_end`` (x4); each point's four non-zero
B-splines by de Boor's recursion (Piegl & Tiller, The NURBS Book, algorithm A2.2); the normal
equations of the spans + 3 coefficients solved by Cholesky (equal to the library's QR to
round-off, tested); the curve at ``linspace(u_0, u_end, n_dense)``.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit

DEGREE = 3
"""The spline's degree (cubic)."""


@njit(cache=True)
def _linspace_into(first, last, out):
    """numpy.linspace(first, last, len(out)) into ``out``, numpy's arithmetic."""
    count = out.shape[0]
    step = (last - first) / (count - 1)
    for i in range(count):
        out[i] = i * step + first
    out[count - 1] = last


@njit(cache=True)
def _basis(knots, spans, u, values, left, right):
    """The four cubic B-splines not zero at ``u`` into ``values`` (4,); returns the index of
    the first of them (its knot span less 3)."""
    span = DEGREE
    while span < spans + DEGREE - 1 and knots[span + 1] <= u:
        span += 1  # knots[span] <= u < knots[span + 1], the last span closed
    values[0] = 1.0
    for j in range(1, DEGREE + 1):
        left[j] = u - knots[span + 1 - j]
        right[j] = knots[span + j] - u
        saved = 0.0
        for r in range(j):
            temp = values[r] / (right[r + 1] + left[j - r])
            values[r] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        values[j] = saved
    return span - DEGREE


@njit(cache=True)
def smooth_measurements(points, along, spans, out, done):
    """Each measurement's least-squares cubic spline over its parameter, in place.

    Parameters
    ----------
    points : numpy.ndarray
        (B, k, 3) the measured points [m], ordered by ``along``.
    along : numpy.ndarray
        (B, k) their positions along the prediction [m], non-decreasing.
    spans : int
        Uniform knot spans.
    out : numpy.ndarray
        (B, n_dense, 3) out: the splines on ``linspace(along[b, 0], along[b, -1], n_dense)``.
    done : numpy.ndarray
        (B,) bool out: False where the normal equations are not positive definite (too few
        points in a span: the measurement is left to :func:`.measurement.smooth_polyline`).
    """
    count = spans + DEGREE
    knots = np.empty(spans + 2 * DEGREE + 1)
    values, left, right = np.empty(DEGREE + 1), np.empty(DEGREE + 1), np.empty(DEGREE + 1)
    normal = np.empty((count, count))
    rhs = np.empty((count, 3))
    grid = np.empty(out.shape[1])
    for b in range(points.shape[0]):
        first, last = along[b, 0], along[b, along.shape[1] - 1]
        knots[:DEGREE] = first
        _linspace_into(first, last, knots[DEGREE : spans + DEGREE + 1])
        knots[spans + DEGREE + 1 :] = last
        normal[:] = 0.0
        rhs[:] = 0.0
        for i in range(points.shape[1]):
            start = _basis(knots, spans, along[b, i], values, left, right)
            for r in range(DEGREE + 1):
                for c in range(DEGREE + 1):
                    normal[start + r, start + c] += values[r] * values[c]
                for a in range(3):
                    rhs[start + r, a] += values[r] * points[b, i, a]
        done[b] = _cholesky_solve(normal, rhs)
        if not done[b]:
            continue
        _linspace_into(first, last, grid)
        for j in range(grid.shape[0]):
            start = _basis(knots, spans, grid[j], values, left, right)
            for a in range(3):
                total = 0.0
                for r in range(DEGREE + 1):
                    total += values[r] * rhs[start + r, a]
                out[b, j, a] = total


@njit(cache=True)
def _cholesky_solve(matrix, rhs):
    """Solve ``matrix`` x = ``rhs`` (p x p symmetric positive definite, p x 3) in place (x in
    ``rhs``, the factor in ``matrix``'s lower triangle); False if not positive definite."""
    p = matrix.shape[0]
    for j in range(p):
        total = matrix[j, j]
        for m in range(j):
            total -= matrix[j, m] ** 2
        if not total > 0.0:
            return False
        matrix[j, j] = math.sqrt(total)
        for i in range(j + 1, p):
            total = matrix[i, j]
            for m in range(j):
                total -= matrix[i, m] * matrix[j, m]
            matrix[i, j] = total / matrix[j, j]
    for a in range(rhs.shape[1]):
        for i in range(p):
            total = rhs[i, a]
            for m in range(i):
                total -= matrix[i, m] * rhs[m, a]
            rhs[i, a] = total / matrix[i, i]
        for i in range(p - 1, -1, -1):
            total = rhs[i, a]
            for m in range(i + 1, p):
                total -= matrix[m, i] * rhs[m, a]
            rhs[i, a] = total / matrix[i, i]
    return True
