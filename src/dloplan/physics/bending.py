"""Bending springs at the interior mass points (thesis 3.4.2, 3.9.3).

U^b = sum_i 1/2 k_b (beta_i - beta0_i)^2 (eq. 3.28; eq. 3.11 when beta0 = 0), with beta_i the
angle between links i and i+1 and beta0_i the angle of the rest shape. Its negative gradient is
the bending force of eq. 3.18: the thesis writes it term by term with 1/sin(beta) factors; here it
is the exact gradient, computed through c = cos(beta) so that the straight shape is not special.

Writing G(c) = 1/2 k_b (arccos(c) - beta0)^2 with c = u . v (u, v the unit directions of the two
links), dG/dc = -k_b (beta - beta0)/sin(beta) and d^2G/dc^2 = k_b (sin(beta) - (beta - beta0)
cos(beta)) / sin(beta)^3. For beta0 = 0 both have finite limits at beta = 0 (-k_b and k_b/3),
evaluated by their series; so a straight rest shape is smooth everywhere.

Limitation of an angle-only model (until torsion adds material frames): a curved rest shape is
known by the *unsigned* angles beta0 only, not by the direction in which the cable is curved.
The energy is then a cone in the joint's bending direction: at beta = 0 with beta0 > 0 every
bending direction is equally good and the gradient is not defined. The kernels return a zero
gradient there (a sub-gradient) and a finite Hessian (sin(beta) is clamped), never NaN.
"""

from __future__ import annotations

import numpy as np

from ..geometry import norms

_SERIES_BELOW = 1e-3  # [rad] below this angle the beta0 = 0 ratios use their Taylor series
_SIN_FLOOR = 1e-12  # clamp of sin(beta) in the cone terms (beta0 != 0) and at beta = pi

def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    # np.cross carries ~15 us of overhead on small arrays; this is the same product.
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _joint_geometry(x: np.ndarray):
    e = x[..., 1:, :] - x[..., :-1, :]
    length = norms(e)
    t = e / length[..., None]
    u, v = t[..., :-1, :], t[..., 1:, :]
    la, lb = length[..., :-1], length[..., 1:]
    s = norms(_cross(u, v))
    c = np.einsum("...k,...k->...", u, v)
    beta = np.arctan2(s, c)
    return u, v, la, lb, c, s, beta


def _cos_derivatives(k_b: float, beta0: np.ndarray, c, s, beta):
    """dG/dc and d^2G/dc^2 for G = 1/2 k_b (arccos c - beta0)^2, finite everywhere."""
    small = beta < _SERIES_BELOW
    s_safe = np.maximum(s, _SIN_FLOOR)
    b2 = beta * beta
    beta_over_s = np.where(small, 1.0 + b2 / 6.0, beta / s_safe)
    curvature = np.where(small, 1.0 / 3.0 + 2.0 * b2 / 15.0, (s - beta * c) / s_safe**3)
    d1 = -k_b * (beta_over_s - beta0 / s_safe)
    d2 = k_b * (curvature + beta0 * c / s_safe**3)
    return d1, d2


def bending_energy(x: np.ndarray, k_b: float, rest_angles: np.ndarray) -> np.ndarray:
    """Bending energy [J], shape (...) (eq. 3.28 summed over the interior points)."""
    *_, beta = _joint_geometry(x)
    return 0.5 * k_b * np.sum((beta - rest_angles) ** 2, axis=-1)


def _link_gradients(x, k_b, rest_angles):
    u, v, la, lb, c, s, beta = _joint_geometry(x)
    d1, d2 = _cos_derivatives(k_b, rest_angles, c, s, beta)
    w = v - c[..., None] * u  # |a| dc/da
    z = u - c[..., None] * v  # |b| dc/db
    grad_a = (d1 / la)[..., None] * w
    grad_b = (d1 / lb)[..., None] * z
    return grad_a, grad_b, (u, v, la, lb, c, w, z, d1, d2)


def bending_gradient(x: np.ndarray, k_b: float, rest_angles: np.ndarray) -> np.ndarray:
    """Gradient dU^b/dx [N], (..., n + 1, 3); the bending force of eq. 3.18 is its negative."""
    grad_a, grad_b, _ = _link_gradients(x, k_b, rest_angles)
    return _point_gradient(x.shape, grad_a, grad_b)


def _point_gradient(shape, grad_a, grad_b):
    grad = np.zeros(shape)
    grad[..., :-2, :] -= grad_a
    grad[..., 1:-1, :] += grad_a - grad_b
    grad[..., 2:, :] += grad_b
    return grad


def bending_hessian_blocks(x: np.ndarray, k_b: float, rest_angles: np.ndarray) -> np.ndarray:
    """Hessian blocks of each joint, shape (..., n - 1, 9, 9); see :func:`bending_derivatives`."""
    return bending_derivatives(x, k_b, rest_angles)[1]


def bending_derivatives(x: np.ndarray, k_b: float, rest_angles: np.ndarray):
    """Gradient (..., n + 1, 3) [N] and Hessian blocks (..., n - 1, 9, 9) [N/m] together.

    Hessian blocks of each joint, shape (..., n - 1, 9, 9), over the points (i-1, i, i+1).

    The link vectors a = x_i - x_{i-1}, b = x_{i+1} - x_i map to the points with the signs
    (-1, 0), (1, -1), (0, 1), which gives the 3x3 point blocks written below.

    With a, b the two link vectors: H_ab = G'(c) d^2c + G''(c) dc dc^T, where
    d^2c/da^2 = -(u w^T + w u^T + c P_u)/|a|^2, d^2c/da db = (P_v - u z^T)/(|a||b|),
    d^2c/db^2 = -(v z^T + z v^T + c P_v)/|b|^2, P_u = I - u u^T, w = v - c u, z = u - c v.
    """
    grad_a, grad_b, (u, v, la, lb, c, w, z, d1, d2) = _link_gradients(x, k_b, rest_angles)
    eye = np.eye(3)

    def outer(p, q):
        return p[..., :, None] * q[..., None, :]

    cc = c[..., None, None]
    p_u = eye - outer(u, u)
    p_v = eye - outer(v, v)
    caa = -(outer(u, w) + outer(w, u) + cc * p_u) / (la**2)[..., None, None]
    cab = (p_v - outer(u, z)) / (la * lb)[..., None, None]
    cbb = -(outer(v, z) + outer(z, v) + cc * p_v) / (lb**2)[..., None, None]
    dca = w / la[..., None]
    dcb = z / lb[..., None]
    g1 = d1[..., None, None]
    g2 = d2[..., None, None]
    haa = g1 * caa + g2 * outer(dca, dca)
    hab = g1 * cab + g2 * outer(dca, dcb)
    hbb = g1 * cbb + g2 * outer(dcb, dcb)
    hba = np.swapaxes(hab, -1, -2)
    blocks = np.empty(haa.shape[:-2] + (3, 3, 3, 3))  # (..., point p, point q, i, j)
    blocks[..., 0, 0, :, :] = haa
    blocks[..., 0, 1, :, :] = hab - haa
    blocks[..., 0, 2, :, :] = -hab
    blocks[..., 1, 1, :, :] = haa - hab - hba + hbb
    blocks[..., 1, 2, :, :] = hab - hbb
    blocks[..., 2, 2, :, :] = hbb
    for p, q in ((1, 0), (2, 0), (2, 1)):
        blocks[..., p, q, :, :] = np.swapaxes(blocks[..., q, p, :, :], -1, -2)
    h_points = np.swapaxes(blocks, -3, -2)  # (..., p, i, q, j)
    grad = _point_gradient(x.shape, grad_a, grad_b)
    return grad, h_points.reshape(h_points.shape[:-4] + (9, 9))
