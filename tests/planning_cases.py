"""Shapes shared by the planner tests: planar arcs and the thesis' folding case (Table 4.2)."""

from __future__ import annotations

import numpy as np

import dloplan


def arc(length: float, angle: float, n_links: int, origin=(0.0, 0.0, 0.0),
        heading: float = 0.0) -> np.ndarray:
    """A planar circular arc in the x-z plane turning by ``angle`` [rad], (n + 1, 3) [m]."""
    s = np.linspace(0.0, length, n_links + 1)
    k = angle / length
    theta = heading + k * s
    if abs(k) < 1e-12:
        x, z = s * np.cos(heading), s * np.sin(heading)
    else:
        x = (np.sin(theta) - np.sin(heading)) / k
        z = -(np.cos(theta) - np.cos(heading)) / k
    return np.stack([x, np.zeros_like(s), z], axis=1) + np.asarray(origin, dtype=float)


def folding_case(n_links: int = 10, scale: float = 1.0):
    """Ethernet cable (0.5 m), straight start, target folded into a half circle beside it.

    ``scale`` = 1000 gives the same problem in millimetres (kg, mm, s: E in kg/(mm s^2)).
    """
    cable = dloplan.catalogue_cable("ethernet", n_links=n_links)
    if scale != 1.0:
        cable = dloplan.Cable(length=cable.length * scale, diameter=cable.diameter * scale,
                              mass=cable.mass, youngs_modulus=cable.youngs_modulus / scale,
                              poisson_ratio=cable.poisson_ratio, n_links=n_links,
                              axial_modulus=cable.axial_modulus / scale)
    length = cable.length
    start = arc(length, 0.0, n_links)
    target = arc(length, np.pi, n_links, origin=(0.2 * length, 0.0, 0.1 * length))
    return cable, start, target
