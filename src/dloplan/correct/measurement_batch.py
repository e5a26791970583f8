"""Many measurements checked and resampled at once (a study's closed loop, a chunk at a time).

:func:`.measurement.resample_measured` takes one measured shape through its checks, a
least-squares cubic spline (:func:`scipy.interpolate.make_lsq_spline`) over the points'
positions along the prediction and an arc-length resampling: 0.5-0.8 ms of CPU per sample,
most of it Python and array set-up around arrays of 200 points. A study's chunk measures its B
sampled plants against the same prediction, so here every step runs over the whole chunk:

* :func:`measured_points`: the plants' shapes resampled onto the measured points plus each
  sample's noise draws, bit for bit :meth:`~.plant.Plant.measure`'s (the same arithmetic as
  :func:`numpy.interp`, :func:`resample_polylines`);
* :func:`resample_measured_batch`: :func:`.measurement.resample_measured`'s checks and its
  spline (compiled, measurement by measurement: :mod:`.smoothing`, equal to the library's QR
  to round-off, tested). A sample that any check would refuse, or that the batch cannot vouch
  for (a repeated point, too few points, a singular fit), is handed back: the caller runs
  :func:`.measurement.resample_measured` on it, which refuses it with its reason;
* :func:`noise_sds`: :func:`.measurement.noise_sd` of every sample;
* :func:`told_offsets`: the measured offsets :func:`~.step.offset_verdict` applies, each
  decided here unless its score is within round-off of the threshold.
"""

from __future__ import annotations

import numpy as np

from ..geometry import arc_length
from ..jit import njit
from ..sim.clips import HELD_INDICES
from .measurement import (
    DENSE,
    MAX_EXTENT,
    MAX_LENGTH_ERROR,
    MIN_ORDER,
    MIN_POINTS,
    POINTS_PER_SPAN,
    UNIT_BAND,
    UNIT_FACTOR,
    nearest_points,
)
from .smoothing import smooth_measurements
from .step import OFFSET_SIGNIFICANCE

MARGIN = 1e-9
"""A score decides here when it is further than this share of :data:`~.step.
OFFSET_SIGNIFICANCE` from it (round-off of the score is about 1e-16 of it)."""


def resample_polylines(points: np.ndarray, n_points: int) -> np.ndarray:
    """:func:`dloplan.geometry.resample_by_arc_length` of B polylines (B, k, 3) at once, bit
    for bit where no link has zero length (its points are dropped there; the caller checks).

    Each coordinate is :func:`numpy.interp`'s ``slope (t - s_j) + x_j`` with ``slope = (x_{j+1}
    - x_j) / (s_{j+1} - s_j)``, the target's own point where it is one, at the targets
    ``linspace(0, s_end, n_points)``. The arc lengths and the targets are numpy's
    (:func:`dloplan.geometry.arc_length`, :func:`numpy.linspace`); the search and the
    interpolation are compiled (:func:`_interpolated`): numpy's expressions of the same numbers
    made a dozen passes over (B, n_points, k) arrays, 0.06 ms a sample of the closed-loop
    study's measurements.

    Returns
    -------
    numpy.ndarray
        (B, n_points, 3) [m].
    """
    points = np.ascontiguousarray(points, dtype=float)
    s = arc_length(points)  # (B, k)
    out = np.empty((points.shape[0], n_points, 3))
    # C-ordered for any B: numpy's linspace along the last axis is F-ordered for B > 1 and both
    # for B = 1 (numba types that 'C'), which compiled a second overload for a batch of one
    target = np.ascontiguousarray(np.linspace(0.0, s[:, -1], n_points, axis=-1))
    _interpolated(points, s, target, out)
    return out


@njit(cache=True, error_model="numpy")
def _interpolated(points, s, target, out):
    """``out`` (B, n_points, 3) <- :func:`resample_polylines`' values of ``points`` (B, k, 3)
    with arc lengths ``s`` (B, k) at ``target`` (B, n_points): j the number of s_0 .. s_(k-2)
    at or below the target less one, within 0 .. k - 2; a division by zero (a link of no
    length) gives numpy's inf or NaN, not an exception."""
    k = points.shape[1]
    for b in range(points.shape[0]):
        for q in range(target.shape[1]):
            t = target[b, q]
            j = -1
            for i in range(k - 1):
                if s[b, i] <= t:
                    j += 1
            j = min(max(j, 0), k - 2)
            s_j, s_next = s[b, j], s[b, j + 1]
            for a in range(3):
                x_j, x_next = points[b, j, a], points[b, j + 1, a]
                value = (x_next - x_j) / (s_next - s_j) * (t - s_j) + x_j
                if t == s_j:
                    value = x_j
                if t == s_next:
                    value = x_next
                out[b, q, a] = value


def measured_points(shapes: np.ndarray, seeds, noise: float, n_measured: int) -> np.ndarray:
    """What :meth:`~.plant.Plant.measure` returns for each plant's ``shapes`` (B, n + 1, 3)
    [m]: the shape resampled onto ``n_measured`` points plus normal noise of sd ``noise`` [m]
    drawn from ``numpy.random.default_rng(seed)``, (B, n_measured, 3), bit for bit."""
    points = resample_polylines(shapes, n_measured)
    for b, seed in enumerate(seeds):
        points[b] += np.random.default_rng(seed).normal(scale=noise, size=points.shape[1:])
    return points


def resample_measured_batch(points: np.ndarray, predicted: np.ndarray, cable_length: float,
                            max_disagreement: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`.measurement.resample_measured` of B measurements (B, k, 3) [m] against one
    prediction (n + 1, 3) [m].

    Returns
    -------
    tuple
        ``(shapes (B, n + 1, 3) [m], done (B,) bool)``: the resampled measurements, equal to
        the function's to round-off where ``done``; elsewhere a check refuses the measurement
        or the batch does not vouch for it (the caller asks the function itself).
    """
    count, k = points.shape[:2]
    n_points = len(predicted)
    steps = np.linalg.norm(np.diff(points, axis=1), axis=-1)  # (B, k - 1)
    ratio = steps.sum(axis=1) / cable_length
    done = np.all(steps > 0.0, axis=1) & np.all(np.isfinite(points), axis=(1, 2))
    done &= (k >= MIN_POINTS) & (k // POINTS_PER_SPAN >= 1) & (k >= 4)
    low, high = UNIT_BAND  # check_scale's
    for factor in (UNIT_FACTOR, 1.0 / UNIT_FACTOR):
        done &= ~((low * factor <= ratio) & (ratio <= high * factor))
    done &= np.linalg.norm(np.ptp(points, axis=1), axis=-1) <= MAX_EXTENT * cable_length
    along = nearest_points(points, predicted)[0]  # (B, k)
    if k >= 3:
        index = np.arange(k) - 0.5 * (k - 1)
        centred = along - along.mean(axis=1, keepdims=True)
        with np.errstate(invalid="ignore", divide="ignore"):
            order = (centred @ index) / np.sqrt((centred**2).sum(axis=1) * (index @ index))
        done &= (np.ptp(along, axis=1) > 0) & (order >= MIN_ORDER)
    shapes = np.full((count, n_points, 3), np.nan)
    live = np.flatnonzero(done)
    if len(live) == 0:
        return shapes, done
    smooth, fitted = _smoothed(points[live], along[live],
                               min(n_points - 1, k // POINTS_PER_SPAN), DENSE * n_points)
    done[live[~fitted]] = False
    live, smooth = live[fitted], smooth[fitted]
    length = arc_length(smooth)[:, -1]
    done[live] &= np.abs(length / cable_length - 1.0) <= MAX_LENGTH_ERROR
    shapes[live] = resample_polylines(smooth, n_points)
    mean = np.mean(np.linalg.norm(shapes[live] - predicted, axis=-1), axis=1)
    done[live] &= np.isfinite(mean) & (mean <= max_disagreement * cable_length)
    return shapes, done


def noise_sds(points: np.ndarray, curves: np.ndarray) -> np.ndarray:
    """:func:`.measurement.noise_sd` of B measurements (B, k, 3) resampled onto ``curves``
    (B, n + 1, 3) [m]: sqrt(sum d_i^2 / (2 max(k - n - 3, 1))) per sample, (B,) [m]."""
    distance = nearest_points(points, curves)[1]
    dof = max(points.shape[1] - (curves.shape[1] + 2), 1)
    return np.sqrt(np.einsum("bk,bk->b", distance, distance) / (2.0 * dof))


def told_offsets(residuals: np.ndarray, u_axes: np.ndarray,
                 noise: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The offsets :func:`~.step.offset_verdict` takes out of B measurements: each residual's
    (B, n + 1, 3) [m] offset and its scatter at the held points (:func:`.model_error.
    measured_offset`), their covariance with the noise ``noise`` (B,) [m] along the clips'
    ``u_axes`` (2, 3) (:func:`.model_error.offset_covariance`), applied where its score
    sqrt(o^T C^-1 o) is at least :data:`~.step.OFFSET_SIGNIFICANCE`.

    Returns
    -------
    tuple
        ``(offsets (B, 3) [m], decided (B,) bool)``: the offset applied (zeros where not told);
        not decided where the score is within :data:`MARGIN` of the threshold, not finite, or
        every one when a covariance is singular (the caller asks the functions themselves).
    """
    held = residuals[:, list(HELD_INDICES)]  # (B, 4, 3)
    offsets = held.mean(axis=1)
    scatter = np.sqrt(np.sum((held - offsets[:, None]) ** 2, axis=(1, 2))
                      / (held[0].size - 3)) / np.sqrt(held.shape[1])
    u = np.asarray(u_axes, dtype=float)
    covariance = (scatter[:, None, None] ** 2 * np.eye(3)
                  + 0.25 * np.asarray(noise)[:, None, None] ** 2 * (u.T @ u))
    try:
        solved = np.linalg.solve(covariance, offsets[:, :, None])[:, :, 0]
    except np.linalg.LinAlgError:
        return np.zeros_like(offsets), np.zeros(len(offsets), dtype=bool)
    score = np.sqrt(np.einsum("bi,bi->b", offsets, solved))
    decided = np.isfinite(score) & (np.abs(score - OFFSET_SIGNIFICANCE)
                                    > MARGIN * OFFSET_SIGNIFICANCE)
    return np.where((score >= OFFSET_SIGNIFICANCE)[:, None], offsets, 0.0), decided


def _smoothed(points: np.ndarray, along: np.ndarray, spans: int,
              n_dense: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`.measurement.smooth_polyline` of B measurements (B, k, 3) over ``along`` (B, k)
    [m] with ``spans`` uniform knot spans (:func:`.smoothing.smooth_measurements`): ``(curves
    (B, n_dense, 3) [m], done (B,) bool)``, not done where its normal equations are singular."""
    order = np.argsort(along, axis=1, kind="stable")
    u = np.ascontiguousarray(np.take_along_axis(along, order, axis=1))
    x = np.ascontiguousarray(np.take_along_axis(points, order[:, :, None], axis=1))
    curves = np.empty((len(points), n_dense, 3))
    done = np.zeros(len(points), dtype=np.bool_)
    smooth_measurements(x, u, spans, curves, done)
    return curves, done
