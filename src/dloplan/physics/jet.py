"""Second-order forward differentiation of small vectorized stencil functions.

The twist and directional-bending energies of :mod:`dloplan.physics.twist` are compositions of
normalizations, cross products, a parallel transport and an ``atan2`` over a stencil of eight
local variables. Writing their exact Hessians by hand is long and fragile; instead each quantity
is carried as a :class:`Jet`: its value, its gradient and its Hessian with respect to the
stencil variables, propagated by the chain rule through every operation. The result is the exact
gradient and Hessian (to rounding), evaluated for all stencils at once with numpy.

A jet's value has any shape ``S`` (e.g. ``(N,)`` for one scalar per stencil or ``(N, 3)`` for a
vector); its gradient has shape ``S + (K,)`` and its Hessian ``S + (K, K)``, K the number of
stencil variables. Plain arrays mix with jets as constants.
"""

from __future__ import annotations

import numpy as np


class Jet:
    """A value with its gradient and Hessian over K variables (see the module docstring)."""

    __slots__ = ("grad", "hess", "val")
    __array_ufunc__ = None  # numpy defers to the reflected operators: array * jet is a jet

    def __init__(self, val, grad, hess):
        self.val = val
        self.grad = grad
        self.hess = hess

    @classmethod
    def variables(cls, values: np.ndarray, first: int, n_vars: int) -> Jet:
        """Independent variables: ``values`` (N,) or (N, d) are variables first .. first+d-1."""
        values = np.asarray(values, dtype=float)
        vector = values.ndim == 2
        d = values.shape[-1] if vector else 1
        grad = np.zeros(values.shape + (n_vars,))
        if vector:
            grad[..., np.arange(d), first + np.arange(d)] = 1.0
        else:
            grad[..., first] = 1.0
        return cls(values, grad, np.zeros(values.shape + (n_vars, n_vars)))

    # -- shape ------------------------------------------------------------------------------
    def __getitem__(self, k: int) -> Jet:
        """Component ``k`` of the value's last axis."""
        return Jet(self.val[..., k], self.grad[..., k, :], self.hess[..., k, :, :])

    def expand(self) -> Jet:
        """A trailing axis of length 1 on the value (to scale a vector by a scalar jet)."""
        return Jet(self.val[..., None], self.grad[..., None, :], self.hess[..., None, :, :])

    def sum(self) -> Jet:
        """Sum over the value's last axis."""
        return Jet(self.val.sum(-1), self.grad.sum(-2), self.hess.sum(-3))

    # -- arithmetic -------------------------------------------------------------------------
    def __add__(self, other) -> Jet:
        if isinstance(other, Jet):
            return Jet(self.val + other.val, self.grad + other.grad, self.hess + other.hess)
        return Jet(self.val + other, self.grad, self.hess)

    __radd__ = __add__

    def __neg__(self) -> Jet:
        return Jet(-self.val, -self.grad, -self.hess)

    def __sub__(self, other) -> Jet:
        return self + (-other)

    def __rsub__(self, other) -> Jet:
        return (-self) + other

    def __mul__(self, other) -> Jet:
        if not isinstance(other, Jet):
            c = np.asarray(other, dtype=float)
            return Jet(self.val * c, self.grad * c[..., None], self.hess * c[..., None, None])
        a, b = self, other
        g_a, g_b = a.grad, b.grad
        cross = g_a[..., :, None] * g_b[..., None, :]
        return Jet(
            a.val * b.val,
            g_a * b.val[..., None] + a.val[..., None] * g_b,
            a.hess * b.val[..., None, None] + a.val[..., None, None] * b.hess
            + cross + np.swapaxes(cross, -1, -2),
        )

    __rmul__ = __mul__

    def __truediv__(self, other) -> Jet:
        if isinstance(other, Jet):
            return self * other.apply(1.0 / other.val, -1.0 / other.val**2, 2.0 / other.val**3)
        return self * (1.0 / np.asarray(other, dtype=float))

    def apply(self, f0, f1, f2) -> Jet:
        """A scalar function f applied elementwise, given f, f' and f'' at the value."""
        g = self.grad
        return Jet(
            f0,
            f1[..., None] * g,
            f1[..., None, None] * self.hess
            + f2[..., None, None] * g[..., :, None] * g[..., None, :],
        )


def dot(a, b) -> Jet:
    """Dot product over the last axis (jets or arrays)."""
    return (a * b).sum()


def cross_last(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (broadcast), without np.cross's overhead."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def cross(a, b):
    """Cross product over the last value axis of length 3 (jets or arrays).

    d(a x b) = da x b + a x db and d2(a x b) = d2a x b + a x d2b + da_p x db_q + da_q x db_p,
    evaluated with the vector components moved to the last axis.
    """
    if not isinstance(a, Jet):
        return -cross(b, a)
    a_g = np.moveaxis(a.grad, -2, -1)  # (..., K, 3)
    a_h = np.moveaxis(a.hess, -3, -1)  # (..., K, K, 3)
    if not isinstance(b, Jet):
        b = np.asarray(b, dtype=float)
        b_g_vec = b[..., None, :]
        grad = cross_last(a_g, b_g_vec)
        hess = cross_last(a_h, b[..., None, None, :])
    else:
        b_g = np.moveaxis(b.grad, -2, -1)
        b_h = np.moveaxis(b.hess, -3, -1)
        grad = cross_last(a_g, b.val[..., None, :]) + cross_last(a.val[..., None, :], b_g)
        mixed = cross_last(a_g[..., :, None, :], b_g[..., None, :, :])
        hess = (cross_last(a_h, b.val[..., None, None, :])
                + cross_last(a.val[..., None, None, :], b_h)
                + mixed + np.swapaxes(mixed, -2, -3))
        b = b.val
    return Jet(cross_last(a.val, b), np.moveaxis(grad, -1, -2), np.moveaxis(hess, -1, -3))


def stack(parts: list[Jet]) -> Jet:
    """Jets of equal shape stacked along a new last value axis."""
    return Jet(
        np.stack([p.val for p in parts], -1),
        np.stack([p.grad for p in parts], -2),
        np.stack([p.hess for p in parts], -3),
    )


def sqrt(a: Jet) -> Jet:
    """Square root (of a positive jet)."""
    r = np.sqrt(a.val)
    return a.apply(r, 0.5 / r, -0.25 / (r * a.val))


def cos(a: Jet) -> Jet:
    """Cosine."""
    c, s = np.cos(a.val), np.sin(a.val)
    return a.apply(c, -s, -c)


def sin(a: Jet) -> Jet:
    """Sine."""
    c, s = np.cos(a.val), np.sin(a.val)
    return a.apply(s, c, -s)


def atan2(y: Jet, x: Jet) -> Jet:
    """The angle atan2(y, x) [rad], with its exact first and second derivatives."""
    r2 = x.val**2 + y.val**2
    fy, fx = x.val / r2, -y.val / r2
    fyy = -2.0 * x.val * y.val / r2**2
    fxy = (y.val**2 - x.val**2) / r2**2
    gy, gx = y.grad, x.grad

    def outer(p, q):
        return p[..., :, None] * q[..., None, :]

    mixed = outer(gx, gy)
    hess = (
        fy[..., None, None] * y.hess + fx[..., None, None] * x.hess
        + fyy[..., None, None] * (outer(gy, gy) - outer(gx, gx))
        + fxy[..., None, None] * (mixed + np.swapaxes(mixed, -1, -2))
    )
    return Jet(np.arctan2(y.val, x.val), fy[..., None] * gy + fx[..., None] * gx, hess)
