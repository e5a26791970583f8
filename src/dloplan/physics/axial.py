"""Axial (linear) springs between consecutive mass points (thesis 3.4.1).

U^s = sum_i 1/2 k_s (l_i - l_i^0)^2 (eq. 3.8); its negative gradient is the axial force F^s of
eq. 3.17. Kernels take shapes (..., n + 1, 3) and return energies, gradients and the 6x6
Hessian blocks of each link (points i-1, i).
"""

from __future__ import annotations

import numpy as np

from ..geometry import link_vectors, norms


def axial_energy(x: np.ndarray, k_s: float, rest_lengths: np.ndarray) -> np.ndarray:
    """Axial energy [J], shape (...) (eq. 3.8 summed over links)."""
    stretch = norms(link_vectors(x)) - rest_lengths
    return 0.5 * k_s * np.sum(stretch**2, axis=-1)


def axial_link_forces(x: np.ndarray, k_s: float, rest_lengths: np.ndarray) -> np.ndarray:
    """Tension of each link k_s (l_i - l_i^0) [N], shape (..., n); positive when stretched."""
    return k_s * (norms(link_vectors(x)) - rest_lengths)


def axial_gradient(x: np.ndarray, k_s: float, rest_lengths: np.ndarray) -> np.ndarray:
    """Gradient dU^s/dx [N], shape (..., n + 1, 3); the axial force of eq. 3.17 is its negative."""
    e = link_vectors(x)
    length = norms(e)[..., None]
    g_link = k_s * (length - rest_lengths[..., None]) * e / length
    grad = np.zeros(x.shape)
    grad[..., 1:, :] += g_link
    grad[..., :-1, :] -= g_link
    return grad


def axial_hessian_blocks(x: np.ndarray, k_s: float, rest_lengths: np.ndarray) -> np.ndarray:
    """Hessian blocks of each link, shape (..., n, 6, 6), over the points (i-1, i).

    d^2 U / de^2 = k_s t t^T + k_s (l - l^0)/l (I - t t^T) with t = e/l, mapped to the two
    end points with the signs (-1, +1).
    """
    e = link_vectors(x)
    length = norms(e)
    t = e / length[..., None]
    tt = t[..., :, None] * t[..., None, :]
    ratio = (length - rest_lengths) / length
    h = k_s * (tt + ratio[..., None, None] * (np.eye(3) - tt))
    top = np.concatenate([h, -h], axis=-1)
    return np.concatenate([top, -top], axis=-2)
