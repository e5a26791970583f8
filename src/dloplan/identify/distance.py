"""Residuals of measured points from a model's curve, and their derivative in ln E.

The cost of the fit is the sum of squared distances of the k measured points p_j to the
model's polyline x_0 .. x_n (the simulated cable), not to model points picked by arc length:

    f(s) = sum_j | p_j - c_j(s) |^2 ,   c_j = the point of the polyline closest to p_j   [m^2]

Noise along the cable then only slides c_j along the curve and noise across it is unbiased to
first order (a bias of sigma^2 / R, R the bend radius: 0.03 mm for sigma = 1 mm and R = 37
mm), whereas resampling a noisy polyline by arc length stretches it (see
:mod:`dloplan.identify.measured`). Markers on the model's points and hundreds of registered
points give the same E.

Derivative (Gauss-Newton Jacobian) with J_i = d x_i / d ln E: when c_j lies inside segment
i at the fraction t, the residual r_j = p_j - c_j is normal to the segment and

    d r_j / ds = -(I - tau tau^T) ((1 - t) J_i + t J_{i+1}),   tau the unit segment direction

(sliding along the segment does not change the distance); when c_j is a vertex x_i,
d r_j / ds = -J_i. Then df/ds = 2 sum r_j . dr_j/ds exactly (the closest point is stationary).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class CurveResiduals:
    """Residuals of measured points from a model polyline (see :func:`curve_residuals`).

    Attributes
    ----------
    residuals : numpy.ndarray
        (k, 3) p_j - c_j [m].
    jacobian : numpy.ndarray
        (k, 3) d r_j / d ln E [m].
    inside : numpy.ndarray
        (k,) bool: c_j strictly inside a segment (the residual is normal to it: two free
        components) rather than at a vertex (three).
    """

    residuals: np.ndarray
    jacobian: np.ndarray
    inside: np.ndarray

    @property
    def cost(self) -> float:
        """f = sum |r_j|^2 [m^2]."""
        return float(np.sum(self.residuals**2))

    @property
    def slope(self) -> float:
        """df / d ln E [m^2]."""
        return float(2.0 * np.sum(self.residuals * self.jacobian))

    @property
    def curvature(self) -> float:
        """Gauss-Newton d^2 f / d(ln E)^2 ~ 2 |dr/ds|^2 [m^2]."""
        return float(2.0 * np.sum(self.jacobian**2))

    @property
    def degrees_of_freedom(self) -> int:
        """Independent residual components: 2 per point inside a segment, 3 at a vertex."""
        return int(2 * np.count_nonzero(self.inside) + 3 * np.count_nonzero(~self.inside))


def curve_residuals(points: np.ndarray, model: np.ndarray,
                    sensitivity: np.ndarray | None = None) -> CurveResiduals:
    """Distances of measured points to a model polyline and their ln E derivatives.

    Parameters
    ----------
    points : numpy.ndarray
        (k, 3) measured points [m].
    model : numpy.ndarray
        (n + 1, 3) model polyline [m].
    sensitivity : numpy.ndarray, optional
        (n + 1, 3) d x / d ln E of the model points [m]; zeros when not given.

    Returns
    -------
    CurveResiduals
    """
    p = np.asarray(points, dtype=float)
    a = model[:-1]
    d = np.diff(model, axis=0)  # (n, 3)
    dd = np.einsum("ij,ij->i", d, d)
    # fraction along every segment of the foot of every point, clamped to the segment
    t = np.einsum("kij,ij->ki", p[:, None, :] - a[None], d) / dd[None]
    t = np.clip(t, 0.0, 1.0)
    foot = a[None] + t[..., None] * d[None]  # (k, n, 3)
    dist2 = np.sum((p[:, None, :] - foot) ** 2, axis=2)
    seg = np.argmin(dist2, axis=1)
    rows = np.arange(len(p))
    t_best = t[rows, seg]
    residuals = p - foot[rows, seg]
    inside = (t_best > 0.0) & (t_best < 1.0)
    jac = np.zeros_like(p)
    if sensitivity is not None:
        js = sensitivity
        moved = (1.0 - t_best)[:, None] * js[seg] + t_best[:, None] * js[seg + 1]
        tau = d[seg] / np.sqrt(dd[seg])[:, None]
        normal_part = moved - np.einsum("ij,ij->i", moved, tau)[:, None] * tau
        jac = -np.where(inside[:, None], normal_part, moved)
    return CurveResiduals(residuals, jac, inside)
