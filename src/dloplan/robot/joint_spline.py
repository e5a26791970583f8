"""The not-a-knot cubic spline a robot program runs its joints along, in numpy alone.

A program's joint motion between the verified sub-steps of a move is the not-a-knot cubic
spline through them (:mod:`dloplan.robot.motion`): twice continuously differentiable, exact at
every knot, and its third derivative continuous at the second and the last-but-one knot (so
the first two and the last two pieces are one cubic each). :class:`NotAKnotSpline` is that
spline as ``scipy.interpolate.CubicSpline(x, y, axis=0)`` builds it (``bc_type="not-a-knot"``,
extrapolated by the end pieces), without importing ``scipy.interpolate``: that import pulls in
``scipy.optimize``, ``scipy.fft`` and ``scipy.special``'s array-API layer, about 150 modules a
plan otherwise never runs (docs/decisions.md, "The joint spline is dloplan's own").

**Construction** (the same equations and operations as scipy's, n knots x, values y):
the spline's first derivatives s_i at the knots solve the tridiagonal system

    dx_i s_{i-1} + 2 (dx_{i-1} + dx_i) s_i + dx_{i-1} s_{i+1}
        = 3 (dx_i m_{i-1} + dx_{i-1} m_i),      i = 1 .. n-2,

(dx_i = x_{i+1} - x_i, m_i = (y_{i+1} - y_i) / dx_i) closed by the not-a-knot rows
``dx_1 s_0 + (x_2 - x_0) s_1 = ((dx_0 + 2 d) dx_1 m_0 + dx_0^2 m_1) / d`` (d = x_2 - x_0) and
its mirror at the end. Two knots give the line (s = m_0); three the parabola through them
(the not-a-knot rows coincide there: ``s_0 + s_1 = 2 m_0``, ``s_1 + s_2 = 2 m_1``). The system
is solved by Gaussian elimination with partial pivoting on its three bands (LAPACK's
``gtsv``; scipy's banded ``gbsv`` pivots alike), all columns of y at once. Each piece is then
the cubic Hermite polynomial ``c_3 + c_2 h + c_1 h^2 + c_0 h^3`` in h = x - x_i, evaluated as
scipy's ``PPoly`` sums it. The results agree with scipy's to round-off (a few ulp: the solve's
operations are not LAPACK's to the bit; tests/test_joint_spline.py).
"""

from __future__ import annotations

import numpy as np

ORDERS = (0, 1, 2)
"""The derivatives :meth:`NotAKnotSpline.__call__` evaluates (value, first, second)."""


def _solve_tridiagonal(lower, diag, upper, rhs) -> np.ndarray:
    """The solution of a tridiagonal system by elimination with partial pivoting (LAPACK
    ``gtsv``).

    Parameters
    ----------
    lower, upper : numpy.ndarray
        (n - 1,) the sub- and super-diagonal (row i + 1, column i; row i, column i + 1).
    diag : numpy.ndarray
        (n,) the diagonal.
    rhs : numpy.ndarray
        (n, ...) right-hand sides, solved together.

    Returns
    -------
    numpy.ndarray
        (n, ...) the solution.
    """
    n = len(diag)
    d, du, dl = diag.astype(float), upper.astype(float), lower.astype(float)
    fill = np.zeros(max(n - 2, 0))  # the second super-diagonal a row interchange creates
    b = rhs.astype(float)
    for i in range(n - 1):
        if abs(d[i]) >= abs(dl[i]):  # no interchange
            factor = dl[i] / d[i]
            d[i + 1] -= factor * du[i]
            b[i + 1] -= factor * b[i]
        else:  # rows i and i + 1 swap
            factor = d[i] / dl[i]
            d[i] = dl[i]
            below = d[i + 1]
            d[i + 1] = du[i] - factor * below
            if i < n - 2:
                fill[i] = du[i + 1]
                du[i + 1] = -factor * fill[i]
            du[i] = below
            row = b[i].copy()
            b[i] = b[i + 1]
            b[i + 1] = row - factor * b[i + 1]
    b[n - 1] /= d[n - 1]
    if n > 1:
        b[n - 2] = (b[n - 2] - du[n - 2] * b[n - 1]) / d[n - 2]
    for i in range(n - 3, -1, -1):
        b[i] = (b[i] - du[i] * b[i + 1] - fill[i] * b[i + 2]) / d[i]
    return b


def _knot_slopes(x, dx, y, slope) -> np.ndarray:
    """(n, ...) the spline's first derivatives at the knots (module docstring)."""
    n = len(x)
    if n == 2:
        return np.stack([slope[0], slope[0]])
    dxr = dx.reshape((-1,) + (1,) * (y.ndim - 1))
    rhs = np.empty(y.shape)
    rhs[1:-1] = 3 * (dxr[1:] * slope[:-1] + dxr[:-1] * slope[1:])
    if n == 3:  # the parabola (the two not-a-knot conditions are one), solved densely as scipy
        rhs[0], rhs[2] = 2 * slope[0], 2 * slope[1]
        matrix = np.array([[1.0, 1.0, 0.0], [dx[1], 2 * (dx[0] + dx[1]), dx[0]],
                           [0.0, 1.0, 1.0]])
        return np.linalg.solve(matrix, rhs.reshape(3, -1)).reshape(y.shape)
    diag = np.empty(n)
    diag[1:-1] = 2 * (dx[:-1] + dx[1:])
    lower = np.empty(n - 1)  # row i + 1, column i
    upper = np.empty(n - 1)  # row i, column i + 1
    lower[:-1], upper[1:] = dx[1:], dx[:-1]
    d = x[2] - x[0]
    diag[0], upper[0] = dx[1], d
    rhs[0] = ((dxr[0] + 2 * d) * dxr[1] * slope[0] + dxr[0] ** 2 * slope[1]) / d
    d = x[-1] - x[-3]
    diag[-1], lower[-1] = dx[-2], d
    rhs[-1] = (dxr[-1] ** 2 * slope[-2] + (2 * d + dxr[-1]) * dxr[-2] * slope[-1]) / d
    return _solve_tridiagonal(lower, diag, upper, rhs)


class NotAKnotSpline:
    """The not-a-knot cubic spline through ``(x[i], y[i])`` (module docstring).

    Parameters
    ----------
    x : array_like
        (n,) the knots, finite and strictly increasing, n >= 2 (the callers': the move
        parameter s = 0, 1/(n-1), ..., 1).
    y : array_like
        (n, ...) finite values at the knots (the callers': joints (n, J) [rad]).

    Raises
    ------
    ValueError
        Naming the argument, what it got and what it expects.
    """

    def __init__(self, x, y) -> None:
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        if x.ndim != 1 or len(x) < 2:
            raise ValueError(f"x: got shape {x.shape}, expected (n,) knots with n >= 2")
        if y.ndim < 1 or len(y) != len(x):
            raise ValueError(f"y: got shape {y.shape}, expected ({len(x)}, ...) values, one "
                             f"per knot")
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            raise ValueError("x, y: expected finite values, got NaN or infinite ones")
        dx = np.diff(x)
        if np.any(dx <= 0):
            raise ValueError(f"x: got {x}, expected strictly increasing knots")
        dxr = dx.reshape((-1,) + (1,) * (y.ndim - 1))
        slope = np.diff(y, axis=0) / dxr
        s = _knot_slopes(x, dx, y, slope)
        t = (s[:-1] + s[1:] - 2 * slope) / dxr  # the Hermite coefficients, as scipy's
        self.x = x
        self.coefficients = np.stack([t / dxr, (slope - s[:-1]) / dxr - t, s[:-1], y[:-1]])
        """(4, n - 1, ...) per piece i the coefficients of h^3, h^2, h, 1 (h = x - x[i])."""

    def __call__(self, at, nu: int = 0) -> np.ndarray:
        """The spline or its derivative of order ``nu`` at ``at``.

        Parameters
        ----------
        at : float or array_like
            (k,) where [unit of x]; outside the knots the end pieces extrapolate.
        nu : int
            0, 1 or 2: the value [unit of y], the first [y / x] or second [y / x^2] derivative.

        Returns
        -------
        numpy.ndarray
            at.shape + y.shape[1:].
        """
        if nu not in ORDERS:
            raise ValueError(f"nu: got {nu!r}, expected 0, 1 or 2")
        at = np.asarray(at, dtype=float)
        piece = np.clip(np.searchsorted(self.x, at, side="right") - 1, 0, len(self.x) - 2)
        c = self.coefficients[:4 - nu, piece]  # those the derivative keeps
        h = (at - self.x[piece]).reshape(at.shape + (1,) * (c.ndim - 1 - at.ndim))
        # summed as scipy's PPoly evaluates (term by term in rising powers of h)
        if nu == 0:
            return c[3] + c[2] * h + c[1] * (h * h) + c[0] * (h * h * h)
        if nu == 1:
            return c[2] + c[1] * h * 2.0 + c[0] * (h * h) * 3.0
        return c[1] * 2.0 + c[0] * h * 6.0


__all__ = ["NotAKnotSpline"]
