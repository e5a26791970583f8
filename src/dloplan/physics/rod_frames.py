"""Material frames of a discretized cable: parallel transport, twist and material curvature.

Each link j (from point j to point j + 1) carries an orthonormal frame (t_j, m1_j, m2_j): t_j the
unit link direction and m1_j, m2_j = t_j x m1_j the material directors, which turn with the cable
when it is twisted (the discrete elastic rod of Bergou et al. 2008). A frame is stored as its
first director m1 alone, (..., n, 3), since t comes from the points.

* **Parallel transport** P(t_a -> t_b) is the rotation of least angle taking t_a to t_b (about
  t_a x t_b): in closed form P v = v + k x v + k x (k x v) / (1 + c), k = t_a x t_b,
  c = t_a . t_b (rational in the tangents, defined for t_b != -t_a).
* **Discrete twist** at the interior point i between links a = i-1 and b = i: the angle psi_i by
  which m1_b is turned about t_b from P(t_a -> t_b) m1_a. From the rotation taking frame a to
  frame b (trace and axial vector), with the common positive factor 1 + c cancelled:
  psi = atan2(1/2 (m1_a x m1_b + m2_a x m2_b) . (t_a + t_b), m1_a . m1_b + m2_a . m2_b),
  exact, smooth, and needing no reference frame.
* **Curvature binormal** kappa b_i = beta_i n_i (beta the turning angle, n the unit normal of
  the two links), computed as f(c) t_a x t_b with f(c) = beta / sin(beta) smooth at c = 1.
* **Material curvatures** of point i seen from link j in {i-1, i} (Bergou et al. 2008, eq. 3):
  omega_i^j = (kappa b_i . m2_j, -kappa b_i . m1_j) [rad]. |omega_i^j| = beta_i exactly, so
  1/2 |omega|^2 is the bending measure of the torsion-free model (:mod:`.bending`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import polynomial as P

from ..geometry import tangents
from ..jit import njit
from .jet import cross_last

_SERIES_BELOW = 1e-2  # 1 - c below which f(c) = beta / sin(beta) uses its series
_SERIES = np.array([1.0, 1 / 3, 2 / 15, 2 / 35, 8 / 315, 8 / 693, 16 / 3003, 16 / 6435])
"""Coefficients a_k of beta / sin(beta) = sum a_k (1 - cos beta)^k, a_k = 2^k k!^2 / (2k+1)!."""


def _cross(a, b):
    a, b = np.broadcast_arrays(a, b)
    return cross_last(a, b)


def _dot(a, b):
    return np.einsum("...k,...k->...", a, b)


def parallel_transport(v, t_from, t_to) -> np.ndarray:
    """Transport vectors v from unit tangents ``t_from`` to ``t_to``, (..., 3) each."""
    k = _cross(t_from, t_to)
    c = _dot(t_from, t_to)
    return v + _cross(k, v) + _cross(k, _cross(k, v)) / (1.0 + c)[..., None]


def rotate_about(v, axis, angle) -> np.ndarray:
    """Vectors v perpendicular to unit ``axis`` turned by ``angle`` [rad] about it."""
    angle = np.asarray(angle, dtype=float)[..., None]
    return np.cos(angle) * v + np.sin(angle) * _cross(axis, v)


def signed_angle(a, b, axis) -> np.ndarray:
    """Angle [rad] in (-pi, pi] turning a to b about ``axis`` (a, b perpendicular to it)."""
    return np.arctan2(_dot(_cross(a, b), axis), _dot(a, b))


def transported_directors(shape, first_director) -> np.ndarray:
    """Space-parallel transport of a director of link 0 along the links, (n, 3).

    Parameters
    ----------
    shape : numpy.ndarray
        (n + 1, 3) points [m].
    first_director : array_like
        (3,) unit vector perpendicular to link 0.
    """
    t = np.ascontiguousarray(tangents(shape))
    d = np.empty_like(t)
    _transport_along(t, np.asarray(first_director, dtype=float), d)
    return d


@njit(cache=True)
def _transport_along(t, first, d):
    """d[j] = P(t[j-1] -> t[j]) d[j-1], normalized, from d[0] = first (compiled loop)."""
    d[0] = first
    for j in range(1, t.shape[0]):
        c = 0.0
        a = 0.0
        for k in range(3):
            c += t[j - 1, k] * t[j, k]
            a += d[j - 1, k] * t[j, k]
        norm = 0.0
        for k in range(3):  # P v = v - (v . t_b)(t_a + t_b) / (1 + c) for v perpendicular to t_a
            d[j, k] = d[j - 1, k] - a * (t[j - 1, k] + t[j, k]) / (1.0 + c)
            norm += d[j, k] * d[j, k]
        norm = math.sqrt(norm)
        for k in range(3):
            d[j, k] /= norm


def discrete_twist(t, d1) -> np.ndarray:
    """Discrete twist psi_i [rad] at the interior points, (..., n - 1) (module docstring).

    Parameters
    ----------
    t, d1 : numpy.ndarray
        (..., n, 3) unit link directions and first material directors.
    """
    d2 = _cross(t, d1)
    ta, tb = t[..., :-1, :], t[..., 1:, :]
    m1a, m1b, m2a, m2b = d1[..., :-1, :], d1[..., 1:, :], d2[..., :-1, :], d2[..., 1:, :]
    cos_part = _dot(m1a, m1b) + _dot(m2a, m2b)
    sin_part = 0.5 * _dot(_cross(m1a, m1b) + _cross(m2a, m2b), ta + tb)
    return np.arctan2(sin_part, cos_part)


def angle_ratio(c):
    """f(c) = beta / sin(beta) with c = cos(beta), and its derivatives f'(c), f''(c)."""
    c = np.asarray(c, dtype=float)
    u = 1.0 - c
    series = (
        P.polyval(u, _SERIES),
        -P.polyval(u, P.polyder(_SERIES)),
        P.polyval(u, P.polyder(_SERIES, 2)),
    )
    s2 = np.maximum(1.0 - c * c, 1e-12)  # c = -1 (links folded back) is singular
    f = np.arccos(np.clip(c, -1.0, 1.0)) / np.sqrt(s2)
    f1 = (c * f - 1.0) / s2
    f2 = (f + 3.0 * c * f1) / s2
    small = u < _SERIES_BELOW
    return tuple(np.where(small, s, e) for s, e in zip(series, (f, f1, f2), strict=True))


@njit(cache=True)
def angle_ratio_scalar(c):
    """:func:`angle_ratio` of one cosine c, compiled: (f, f', f'') at c."""
    u = 1.0 - c
    if u < _SERIES_BELOW:
        f0 = 0.0
        f1 = 0.0
        f2 = 0.0
        for k in range(len(_SERIES) - 1, -1, -1):  # Horner, with the two derivatives in u
            f2 = f2 * u + 2.0 * f1
            f1 = f1 * u + f0
            f0 = f0 * u + _SERIES[k]
        return f0, -f1, f2
    s2 = max(1.0 - c * c, 1e-12)
    f0 = math.acos(min(max(c, -1.0), 1.0)) / math.sqrt(s2)
    f1 = (c * f0 - 1.0) / s2
    return f0, f1, (f0 + 3.0 * c * f1) / s2


def curvature_binormals(t) -> np.ndarray:
    """beta_i n_i at the interior points [rad], (..., n - 1, 3), from unit link directions."""
    ta, tb = t[..., :-1, :], t[..., 1:, :]
    return angle_ratio(_dot(ta, tb))[0][..., None] * _cross(ta, tb)


def material_curvatures(t, d1) -> np.ndarray:
    """omega_i^j [rad], (..., n - 1, 2, 2): point i, link j in (i-1, i), components (1, 2)."""
    kb = curvature_binormals(t)[..., None, :]
    m1 = np.stack([d1[..., :-1, :], d1[..., 1:, :]], axis=-2)
    m2 = _cross(np.stack([t[..., :-1, :], t[..., 1:, :]], axis=-2), m1)
    return np.stack([_dot(kb, m2), -_dot(kb, m1)], axis=-1)
