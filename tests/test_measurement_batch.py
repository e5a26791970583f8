"""A chunk's measurements at once (:mod:`dloplan.correct.measurement_batch`) against the
per-sample functions the exact correction uses (:mod:`dloplan.correct.measurement`).

The plants' shapes are hanging chains of 10 links between clips 0.3-0.5 m apart (the study
example's size), measured at 200 points."""

from __future__ import annotations

import numpy as np
import pytest

from dloplan.correct.measurement import (
    CorrectionRefused,
    nearest_points,
    noise_sd,
    positions_along,
    resample_measured,
)
from dloplan.correct.measurement_batch import (
    measured_points,
    noise_sds,
    resample_measured_batch,
    resample_polylines,
)
from dloplan.geometry import arc_length, resample_by_arc_length

LENGTH = 0.6


def _hanging(count: int, rng) -> np.ndarray:
    """(count, 11, 3) sagging polylines of length about LENGTH [m], each a little different."""
    t = np.linspace(-1.0, 1.0, 11)
    out = []
    for _ in range(count):
        span = rng.uniform(0.3, 0.5)
        x = np.stack([0.5 * span * t, rng.normal(scale=0.01) * t,
                      rng.uniform(0.1, 0.2) * (t**2 - 1.0)], axis=1)
        out.append(x * LENGTH / arc_length(x)[-1])
    return np.array(out)


def test_resampled_polylines_are_resample_by_arc_length_bit_for_bit():
    """The batch's arithmetic is numpy.interp's: the same points, bit for bit, onto fewer and
    onto more points than the polylines have."""
    rng = np.random.default_rng(3)
    polylines = np.cumsum(rng.normal(size=(6, 11, 3)), axis=1)
    for n in (5, 11, 200):
        batch = resample_polylines(polylines, n)
        for b, polyline in enumerate(polylines):
            assert np.array_equal(batch[b], resample_by_arc_length(polyline, n)), (n, b)


def test_a_batch_of_one_polyline_uses_the_many_polylines_overload():
    """A chunk where one sample is left (a study's closed loop) resamples a batch of one: the
    kernel is called with the arrays' layouts of a larger batch, so the warm-up's one compiled
    overload serves both (a batch of one compiled a second one after the warm-up)."""
    from dloplan.correct.measurement_batch import _interpolated

    rng = np.random.default_rng(5)
    for count in (1, 3):
        polylines = np.cumsum(rng.normal(size=(count, 11, 3)), axis=1)
        assert np.array_equal(resample_polylines(polylines, 7)[0],
                              resample_by_arc_length(polylines[0], 7))
    assert len(_interpolated.signatures) == 1, _interpolated.signatures


def test_measured_points_are_the_plants_measurement_bit_for_bit():
    """Plant.measure: the shape resampled onto the measured points plus the seed's noise."""
    from dloplan.cable import Cable
    from dloplan.correct.plant import Plant

    shapes = _hanging(3, np.random.default_rng(4))
    seeds = [11, 12, 13]
    points = measured_points(shapes, seeds, 1e-3, 200)
    cable = Cable(length=LENGTH, diameter=0.006, mass=0.03, youngs_modulus=1e8, n_links=10)
    for b, seed in enumerate(seeds):
        plant = Plant(cable, noise=1e-3, n_measured=200, seed=seed)
        want = plant.measure(shapes[b], np.random.default_rng(seed))  # as run_closed_loop
        assert np.array_equal(points[b], want)


def test_nearest_points_broadcasts_over_measurements():
    """One polyline for many point sets, or one each: each row what the single call gives,
    bit for bit."""
    rng = np.random.default_rng(5)
    polylines, points = _hanging(4, rng), rng.normal(scale=0.2, size=(4, 50, 3))
    shared = nearest_points(points, polylines[0][None])
    each = nearest_points(points, polylines)
    for b in range(4):
        for got, want in zip((shared, each), (nearest_points(points[b], polylines[0]),
                                              nearest_points(points[b], polylines[b])),
                             strict=True):
            assert np.array_equal(got[0][b], want[0]) and np.array_equal(got[1][b], want[1])
    assert np.array_equal(shared[0][0], positions_along(points[0], polylines[0]))


@pytest.mark.parametrize("noise", [1e-4, 1e-3, 5e-3])
def test_the_batch_resamples_as_resample_measured(noise):
    """The spline's normal equations against the library's QR: the resampled shapes equal to
    1e-12 m (round-off of a 13-coefficient fit; measured ~1e-15 m) and the noise estimate to
    1e-10 relative."""
    rng = np.random.default_rng(6)
    shapes = _hanging(8, rng)
    predicted = shapes[0]
    points = measured_points(shapes, range(8), noise, 200)
    got, done = resample_measured_batch(points, predicted, LENGTH, 0.25)
    assert done.all()
    sds = noise_sds(points, got)
    for b in range(8):
        want = resample_measured(points[b], predicted, LENGTH)
        assert np.abs(got[b] - want).max() <= 1e-12
        assert sds[b] == pytest.approx(noise_sd(points[b], want), rel=1e-10)


def test_what_the_batch_does_not_vouch_for_is_refused_by_resample_measured():
    """Measurements the function refuses -- reversed, in millimetres, far from the prediction,
    much longer than the cable (60 mm noise) -- are handed back, and the others are done."""
    rng = np.random.default_rng(7)
    shapes = _hanging(6, rng)
    predicted = shapes[0]
    points = measured_points(shapes, range(6), 1e-3, 200)
    points[1] = points[1][::-1]  # reversed
    points[2] *= 1000.0  # millimetres written as metres
    points[3] += np.array([0.0, 0.0, 0.3])  # far from the prediction
    points[4] = measured_points(shapes[4:5], [4], 0.06, 200)[0]  # too long
    _, done = resample_measured_batch(points, predicted, LENGTH, 0.25)
    assert list(done) == [True, False, False, False, False, True]
    for b in (1, 2, 3, 4):
        with pytest.raises(CorrectionRefused):
            resample_measured(points[b], predicted, LENGTH)


def test_a_fit_with_empty_knot_spans_is_not_done():
    """Points only near the ends leave the middle coefficients undetermined: the normal
    equations are singular and the measurement is handed back, not smoothed."""
    from dloplan.correct.smoothing import smooth_measurements

    along = np.r_[np.linspace(0.0, 0.05, 20), np.linspace(0.55, 0.6, 20)][None]
    points = np.stack([along[0], np.zeros(40), np.zeros(40)], axis=1)[None]
    curves, done = np.empty((1, 50, 3)), np.ones(1, dtype=bool)
    smooth_measurements(points, along, 10, curves, done)
    assert not done[0]
    smooth_measurements(points, along, 1, curves, done)  # one span: four coefficients told
    assert done[0] and np.allclose(curves[0, :, 0], np.linspace(0.0, 0.6, 50), atol=1e-12)


def test_told_offsets_are_offset_verdicts_and_leave_the_threshold_to_it():
    """told_offsets against measured_offset, offset_covariance and offset_verdict one by one
    on residuals with offsets from none to 3 mm: the same offsets applied (to 1e-15 m) where
    it decides, and a residual whose score is the threshold itself left undecided."""
    from dloplan.correct.measurement_batch import told_offsets
    from dloplan.correct.model_error import measured_offset, offset_covariance
    from dloplan.correct.step import OFFSET_SIGNIFICANCE, offset_verdict
    from dloplan.sim.clips import HELD_INDICES

    rng = np.random.default_rng(11)
    count, size = 30, 11
    u_axes = np.array([[1.0, 0.0, 0.0], [0.0, 0.6, 0.8]])
    residuals = rng.normal(size=(count, size, 3)) * 3e-4
    residuals += rng.uniform(0.0, 3e-3, size=(count, 1, 1)) * rng.normal(size=(count, 1, 3))
    noise = np.full(count, 1e-3)
    # the last: its score scaled onto the threshold
    offset, scatter = measured_offset(residuals[-1])
    covariance = offset_covariance(scatter, u_axes, noise[-1])
    score = np.sqrt(offset @ np.linalg.solve(covariance, offset))
    held = list(HELD_INDICES)
    residuals[-1, held] += offset * (OFFSET_SIGNIFICANCE / score - 1.0)
    applied, decided = told_offsets(residuals, u_axes, noise)
    assert not decided[-1]
    told = 0
    for b in range(count - 1):
        offset, scatter = measured_offset(residuals[b])
        want = offset_verdict(offset, offset_covariance(scatter, u_axes, noise[b]))[0]
        assert decided[b]
        np.testing.assert_allclose(applied[b], want, rtol=0, atol=1e-15)
        told += bool(np.any(want != 0.0))
    assert 0 < told < count - 1
