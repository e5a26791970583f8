"""A measured cable shape, checked and resampled onto the model's points.

A measurement is any number of points ordered along the cable from the first clip's end to the
last clip's (a registered shape, :mod:`dloplan.vision.shapes_io`), in the plan's frame, with
noise. The model compares shapes point by point, so the measurement is resampled to the model's
n + 1 points equally spaced in arc length -- but not on the raw polyline: noise of standard
deviation sigma on points a spacing h apart lengthens each segment by about sigma^2 / h, so a
dense noisy polyline is much longer than the cable (1 mm noise on points 2 mm apart: +25 %).
Each coordinate is therefore first fitted by a least-squares cubic spline
(:func:`scipy.interpolate.make_lsq_spline`) over the points' positions along the predicted shape
(their projections: the chord length of noisy points is no good parameter either), with as many
uniform knot spans as the model has links but at most one per :data:`POINTS_PER_SPAN` points
(the fit averages the noise over them), and the smooth curve is resampled. A measurement of
fewer than 4 points is used as a polyline.

A measurement that disagrees wildly with the model is refused (:class:`CorrectionRefused`), with
the reason, rather than used:

* it is in the wrong units: its points span more than :data:`MAX_EXTENT` cable lengths (a
  millimetre file read as metres), said so before its order is judged;
* its points run the wrong way or are not ordered along the cable: their positions projected
  onto the predicted shape must grow with their index (correlation >= :data:`MIN_ORDER`);
* another cable: the smoothed length differs from the cable's by more than
  :data:`MAX_LENGTH_ERROR`;
* another shape altogether: the mean distance to the predicted shape exceeds
  ``max_disagreement`` (default :data:`MAX_DISAGREEMENT` cable lengths);
* too few points to tell a shape (fewer than :data:`MIN_POINTS`: two points are the clips);
* points in another unit: a polyline :data:`UNIT_FACTOR` times longer (or shorter) than the
  cable is named as millimetres (or kilometres) written as metres.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import make_lsq_spline

from ..geometry import arc_length, as_shape, resample_by_arc_length
from .projection import project_points

MAX_LENGTH_ERROR = 0.10
"""Largest relative difference between the measured (smoothed) and the cable's length."""

MAX_EXTENT = 10.0
"""A measurement spanning more than this many cable lengths is in the wrong units."""

MIN_ORDER = 0.9
"""Smallest correlation between the points' index and their position along the prediction."""

MAX_DISAGREEMENT = 0.25
"""Largest mean distance between measured and predicted shape, in cable lengths."""

DENSE = 20
"""The smooth curve is evaluated at DENSE points per model link before resampling."""

POINTS_PER_SPAN = 4
"""Fewest measured points per knot span of the smoothing spline."""

MIN_POINTS = 5
"""Fewest measured points of a shape: fewer say next to nothing about the cable between the clips
(two points are the clips themselves), so no correction is made from them."""

UNIT_FACTOR = 1000.0
"""A measured polyline about this many times longer than the cable is in millimetres."""

UNIT_BAND = (0.5, 3.0)
"""A measured polyline between these multiples of :data:`UNIT_FACTOR` (or of its inverse) times
the cable's length is read as millimetres (kilometres) written as metres."""


class CorrectionRefused(ValueError):
    """A measurement or a correction outside the documented limits; the message says why."""


def positions_along(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """Arc length [m] of the point of ``polyline`` nearest to each of ``points``, (k,)."""
    return nearest_points(points, polyline)[0]


def nearest_points(points: np.ndarray, polyline: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(arc length [m], distance [m]) of the point of ``polyline`` nearest to each of
    ``points`` (k, 3), each (k,); or of B measurements (B, k, 3) at once, each (B, k), against
    one polyline (m, 3) or one each (B, m, 3) (:func:`.projection.project_points`)."""
    x = np.asarray(points, dtype=float)
    batch = x if x.ndim == 3 else x[None]
    lines = np.asarray(polyline, dtype=float)
    lines = lines if lines.ndim == 3 else lines[None]
    along, distance = np.empty(batch.shape[:2]), np.empty(batch.shape[:2])
    project_points(np.ascontiguousarray(batch), np.ascontiguousarray(lines), along, distance)
    return (along, distance) if x.ndim == 3 else (along[0], distance[0])


def noise_sd(points, curve: np.ndarray) -> float:
    """The measurement's noise, its standard deviation per coordinate [m], from the measured
    points' distances d_i to the smoothed curve they were resampled onto.

    Noise of sd sigma per coordinate has two components across the curve (the one along it
    does not show in the distance), so sum d_i^2 = 2 sigma^2 (k - m): k points, m = n + 3 the
    spline's coefficients per coordinate (:func:`smooth_polyline`, n knot spans), at least 1.

    Parameters
    ----------
    points : array_like
        (k, 3) the measured points [m].
    curve : numpy.ndarray
        (n + 1, 3) the measurement resampled (:func:`resample_measured`) [m].
    """
    x = np.asarray(points, dtype=float)
    distance = nearest_points(x, curve)[1]
    dof = max(len(x) - (len(curve) + 2), 1)
    return math.sqrt(float(distance @ distance) / (2.0 * dof))


def smooth_polyline(points: np.ndarray, along: np.ndarray, n_spans: int,
                    n_dense: int) -> np.ndarray:
    """The points' least-squares cubic spline over the parameter ``along``, (n_dense, 3) [m].

    ``along`` (k,) is the points' position along a nearby curve [m] (their chord length would
    be inflated by noise, non-uniformly). At most ``n_spans`` uniform knot spans, and at least
    :data:`POINTS_PER_SPAN` points per span; with too few points for one cubic span, the
    polyline itself.
    """
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    keep = np.r_[True, steps > 0.0]
    spans = min(n_spans, int(keep.sum()) // POINTS_PER_SPAN)
    if spans < 1 or keep.sum() < 4:
        x = points[keep]
        u = np.r_[0.0, np.cumsum(steps[steps > 0.0])]
        grid = np.linspace(0.0, u[-1], n_dense)
        return np.stack([np.interp(grid, u, x[:, k]) for k in range(3)], axis=1)
    order = np.argsort(along, kind="stable")
    u, x = along[order], points[order]
    knots = np.r_[[u[0]] * 3, np.linspace(u[0], u[-1], spans + 1), [u[-1]] * 3]
    return make_lsq_spline(u, x, knots, k=3)(np.linspace(u[0], u[-1], n_dense))


def check_scale(points: np.ndarray, cable_length: float) -> None:
    """Refuse a measurement of too few points, or one in millimetres written as metres.

    Raises
    ------
    CorrectionRefused
        Naming the count, or the length and the likely unit.
    """
    if len(points) < MIN_POINTS:
        raise CorrectionRefused(
            f"measured: {len(points)} points, expected at least {MIN_POINTS} along the cable: "
            "too few to tell its shape between the clips (a camera centreline gives hundreds)")
    raw = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
    ratio = raw / cable_length
    low, high = UNIT_BAND
    for factor, unit in ((UNIT_FACTOR, "millimetres"), (1.0 / UNIT_FACTOR, "kilometres")):
        if low * factor <= ratio <= high * factor:
            raise CorrectionRefused(
                f"measured: the points span {raw:.4g} m along the cable, {ratio:.3g} times its "
                f"{cable_length:.4g} m: the coordinates look like {unit} written as metres "
                "(a CSV is in metres; convert it, or write JSON with \"units\": \"mm\")")


def resample_measured(points, predicted: np.ndarray, cable_length: float, *,
                      max_disagreement: float = MAX_DISAGREEMENT) -> np.ndarray:
    """Check a measured shape against the model's prediction and resample it onto its points.

    Parameters
    ----------
    points : array_like
        (k, 3) measured points [m], k >= 2, ordered from the first clip's end to the last's.
    predicted : numpy.ndarray
        (n + 1, 3) the model's shape at the same clip poses [m].
    cable_length : float
        L [m].
    max_disagreement : float
        Largest mean point distance to the prediction, in cable lengths.

    Returns
    -------
    numpy.ndarray
        (n + 1, 3) the measured shape at the model's points, equally spaced in arc length.

    Raises
    ------
    CorrectionRefused
        For a measurement in the wrong order, of another length or far from the prediction.
    ValueError
        For malformed points (fewer than 2, not 3D, non-finite).
    """
    x = as_shape(points, name="measured")
    check_scale(x, cable_length)
    n_points = len(predicted)
    extent = float(np.linalg.norm(np.ptp(x, axis=0)))
    if extent > MAX_EXTENT * cable_length:
        raise CorrectionRefused(
            f"measured: the points span {extent:.4g} m for a {1e3 * cable_length:.0f} mm cable: "
            "millimetres read as metres? (a registered-shape CSV is in metres; a JSON one may "
            "say \"units\": \"mm\")")
    s = positions_along(x, predicted)
    if len(x) >= 3:
        order = float(np.corrcoef(np.arange(len(x)), s)[0, 1]) if np.ptp(s) > 0 else 0.0
        if not order >= MIN_ORDER:
            # points far from the whole prediction have no order along it to judge: a mirrored
            # or misplaced shape projects onto a piece of the prediction (correlation ~0)
            refuse_far(float(np.mean(nearest_points(x, predicted)[1])), cable_length,
                       max_disagreement,
                       "the points are", ", each from its nearest point")
            how = ("run from the last clip to the first (reverse them)" if order <= -MIN_ORDER
                   else "are not ordered along the cable")
            raise CorrectionRefused(
                f"measured: the {len(x)} points {how}: the correlation of their index with their "
                f"position along the predicted shape is {order:.2f}, expected >= {MIN_ORDER}"
            )
    smooth = smooth_polyline(x, s, n_points - 1, DENSE * n_points)
    length = float(arc_length(smooth)[-1])
    if not abs(length / cable_length - 1.0) <= MAX_LENGTH_ERROR:
        raise CorrectionRefused(
            f"measured: the shape is {1e3 * length:.0f} mm long (smoothed) but the cable is "
            f"{1e3 * cable_length:.0f} mm: another cable, or a partial measurement (limit "
            f"{100 * MAX_LENGTH_ERROR:.0f} %)"
        )
    shape = resample_by_arc_length(smooth, n_points)
    refuse_far(float(np.mean(np.linalg.norm(shape - predicted, axis=1))), cable_length,
               max_disagreement)
    return shape


def refuse_far(mean: float, cable_length: float, max_disagreement: float,
               subject: str = "the shape is", how: str = "") -> None:
    """Refuse a measurement on average ``mean`` [m] from the prediction beyond
    ``max_disagreement`` cable lengths (:class:`CorrectionRefused`; NaN is refused).

    Parameters
    ----------
    mean, cable_length : float
        The mean distance and L [m].
    max_disagreement : float
        The limit in cable lengths.
    subject, how : str
        What is that far ("the shape is": the resampled shape point by point) and how it
        was measured (appended to the distance).
    """
    if not (math.isfinite(mean) and mean <= max_disagreement * cable_length):
        raise CorrectionRefused(
            f"measured: {subject} on average {1e3 * mean:.0f} mm from the model's prediction"
            f"{how} (limit {1e3 * max_disagreement * cable_length:.0f} mm = "
            f"{max_disagreement:g} cable lengths): the cable is not where the plan has it"
        )
