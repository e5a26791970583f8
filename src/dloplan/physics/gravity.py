"""Gravity on the mass points (thesis 3.6, eq. 3.20): G_i = m_i g."""

from __future__ import annotations

import numpy as np


def gravity_energy(x: np.ndarray, point_masses: np.ndarray, gravity: np.ndarray) -> np.ndarray:
    """Gravitational potential energy -sum_i m_i g . x_i [J], shape (...)."""
    return -np.einsum("...ik,i,k->...", x, point_masses, gravity)


def gravity_force(point_masses: np.ndarray, gravity: np.ndarray) -> np.ndarray:
    """Weight of each point m_i g [N], shape (n + 1, 3) (eq. 3.20)."""
    return point_masses[:, None] * np.asarray(gravity, dtype=float)[None, :]
