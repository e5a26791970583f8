"""A measured cable shape as a smooth curve: its length, its curvature, a guess on n + 1 points.

A measurement is an ordered polyline of k points [m]: one marker per model point, or a few
hundred points of a registered image (:mod:`dloplan.vision.shapes_io`), each with noise of
standard deviation sigma per coordinate. Its raw polyline length is biased by the noise (each
segment of spacing h gains about 2 sigma^2 / h^2 of its length: 15 % at h = 2.5 mm and
sigma = 1 mm), so neither the length check nor a resampling by arc length may use it directly.

:func:`measured_curve` fits a parametric cubic smoothing spline (``scipy.interpolate.splprep``)
whose residual sum of squares is the noise's expected k * 3 sigma^2 (or keeps the polyline
itself when the spline comes out longer: it then overshoots sharp corners of clean data), and
reads off it:

* the **length** (for the check against the cable's),
* its **turning** over a given arc length w, the largest angle between its tangents at two
  points w apart (for the discretization check: a model link of length l turns by about that
  angle at its joints, see :mod:`dloplan.identify.fit`); w / turning is the smallest bend
  radius seen at the scale w. (A pointwise curvature would see the corners of a polyline
  measurement, or the noise, instead of the bends a link has to follow.)
* the **guess** of an equilibrium on the cable's n + 1 points (the smooth curve resampled by arc
  length), the start of the branch-aware simulations.

The fit itself never compares the model with the smoothed curve, only with the raw points (by
their distance to the model's curve, :mod:`dloplan.identify.distance`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import splev, splprep

from ..geometry import arc_length, as_shape, resample_by_arc_length

SAMPLES = 2001
"""Points at which the smoothing spline is evaluated (the smooth curve's polyline)."""

END_MARGIN = 0.02
"""Fraction of the curve at each end left out of the curvature (a spline's ends are loose)."""


@dataclass(frozen=True, eq=False)
class MeasuredCurve:
    """A measured shape and its smoothing spline (see :func:`measured_curve`).

    Attributes
    ----------
    points : numpy.ndarray
        (k, 3) the measured points as given [m].
    smooth : numpy.ndarray
        (SAMPLES, 3) the smoothing spline, densely sampled [m].
    length : float
        Length of the smooth curve [m].
    tangents : numpy.ndarray
        (SAMPLES, 3) unit tangents of the smooth curve.
    noise : float
        The noise standard deviation per coordinate it was smoothed for [m].
    """

    points: np.ndarray
    smooth: np.ndarray
    length: float
    tangents: np.ndarray
    noise: float

    def turning(self, window: float) -> float:
        """Largest angle between the tangents at two points ``window`` apart [rad].

        The ends (``END_MARGIN`` of the samples each) are left out: a spline's end tangents
        are loose.
        """
        step = self.length / (SAMPLES - 1)
        m = max(1, round(window / step))
        margin = int(END_MARGIN * SAMPLES)
        t = self.tangents[margin:SAMPLES - margin]
        if m >= len(t):
            m = len(t) - 1
        cosines = np.clip(np.einsum("ij,ij->i", t[:-m], t[m:]), -1.0, 1.0)
        return float(np.arccos(cosines.min()))

    def bend_radius(self, window: float) -> float:
        """Smallest bend radius seen at the scale ``window`` [m]: window / turning (inf if 0)."""
        turn = self.turning(window)
        return window / turn if turn > 0 else math.inf

    def resampled(self, n_points: int) -> np.ndarray:
        """The smooth curve at ``n_points`` points equally spaced in arc length [m]."""
        return resample_by_arc_length(self.smooth, n_points)

    def reversed(self) -> MeasuredCurve:
        """The same curve from its other end."""
        return MeasuredCurve(self.points[::-1].copy(), self.smooth[::-1].copy(), self.length,
                             -self.tangents[::-1].copy(), self.noise)


def measured_curve(points, noise: float, name: str = "measured_shape") -> MeasuredCurve:
    """Smooth a measured polyline by a cubic spline fitted to its noise (module docstring).

    Parameters
    ----------
    points : array_like
        (k, 3) or (k, 2) ordered points along the cable [m], k >= 2.
    noise : float
        Standard deviation of a measured coordinate [m], > 0.
    name : str
        The argument's name in error messages.

    Raises
    ------
    ValueError
        Naming ``name``: malformed points, or a polyline whose consecutive points all coincide.
    """
    x = as_shape(points, name=name)
    steps = np.linalg.norm(np.diff(x, axis=0), axis=1)
    keep = np.concatenate([[True], steps > 0.0])
    x_unique = x[keep]
    if len(x_unique) < 2:
        raise ValueError(f"{name}: the polyline has zero length")
    u = arc_length(x_unique)
    u_length = u[-1]
    u = u / u_length
    degree = min(3, len(x_unique) - 1)
    smoothing = len(x_unique) * 3.0 * noise**2
    tck, _ = splprep(x_unique.T, u=u, k=degree, s=smoothing)
    t = np.linspace(0.0, 1.0, SAMPLES)
    # sample the spline evenly in its own arc length, so windows are lengths
    dense = np.array(splev(t, tck)).T
    s_dense = arc_length(dense)
    if s_dense[-1] >= u_length:
        # a spline longer than the raw polyline overshoots its corners (a clean polyline with
        # sharp turns, e.g. a coarse model's shape): the polyline itself is the better curve
        # (its tangent turns linearly between the middles of its segments: a corner of angle
        # beta between segments of length h reads as a bend of radius h / beta)
        smooth = resample_by_arc_length(x_unique, SAMPLES)
        directions = np.diff(x_unique, axis=0)
        directions /= np.linalg.norm(directions, axis=1)[:, None]
        middles = 0.5 * (u[:-1] + u[1:]) * u_length
        where = np.linspace(0.0, u_length, SAMPLES)
        tangents = np.stack([np.interp(where, middles, directions[:, k]) for k in range(3)],
                            axis=1)
        tangents /= np.linalg.norm(tangents, axis=1)[:, None]
        return MeasuredCurve(x, smooth, float(u_length), tangents, float(noise))
    t = np.interp(np.linspace(0.0, s_dense[-1], SAMPLES), s_dense, t)
    smooth = np.array(splev(t, tck)).T
    d1 = np.array(splev(t, tck, der=1)).T
    tangents = d1 / np.linalg.norm(d1, axis=1)[:, None]
    return MeasuredCurve(x, smooth, float(arc_length(smooth)[-1]), tangents, float(noise))


CHI3_MEDIAN = math.sqrt(2.365973884375338)
"""Median length of a 3-vector of independent unit normals (sqrt of chi-squared(3)'s median)."""


@dataclass(frozen=True)
class Scatter:
    """How measured points scatter, read off their second differences (no curve fitted).

    The second difference x[i-1] - 2 x[i] + x[i+1] of points with independent noise sigma per
    coordinate is a 3-vector of normals of sd sqrt(6) sigma, plus h^2 times the curvature,
    which is small where the points are dense. Its median length over the polyline therefore
    estimates sigma robustly (one outlier does not move it), and the largest one finds an
    outlier: a point moved by e off the line of its neighbours has a second difference of 2 e.

    Attributes
    ----------
    noise : float
        sigma estimated from the median second difference [m] (0 for fewer than 3 points).
    worst : int
        Index of the point whose second difference is largest (-1 for fewer than 3 points).
    offset : float
        That point's distance from the middle of its two neighbours [m].
    """

    noise: float
    worst: int
    offset: float


def point_scatter(points) -> Scatter:
    """The scatter of an ordered polyline's points (:class:`Scatter`).

    Parameters
    ----------
    points : array_like
        (k, 3) ordered points along the cable [m].
    """
    x = np.asarray(points, dtype=float)
    if len(x) < 3:
        return Scatter(0.0, -1, 0.0)
    second = np.linalg.norm(x[:-2] - 2.0 * x[1:-1] + x[2:], axis=1)
    worst = int(np.argmax(second))
    return Scatter(float(np.median(second)) / (math.sqrt(6.0) * CHI3_MEDIAN), worst + 1,
                   0.5 * float(second[worst]))

