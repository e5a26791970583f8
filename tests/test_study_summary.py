"""Summary statistics: binomial intervals against closed forms, criteria applied afterwards."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dloplan.study import CriteriaSpec, success_interval, summarize


def test_clopper_pearson_closed_forms():
    # k = 0: upper bound 1 - (alpha/2)^(1/n); k = n: lower bound (alpha/2)^(1/n)
    lo, hi = success_interval(0, 10, 0.95, "clopper-pearson")
    assert lo == 0.0 and hi == pytest.approx(1 - 0.025 ** (1 / 10), rel=1e-9)
    lo, hi = success_interval(20, 20, 0.95, "clopper-pearson")
    assert hi == 1.0 and lo == pytest.approx(0.025 ** (1 / 20), rel=1e-9)


@pytest.mark.parametrize(("k", "n"), [(0, 10), (7, 20), (95, 100)])
def test_wilson_score_interval(k, n):
    z = 1.959963984540054
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    lo, hi = success_interval(k, n)
    assert lo == pytest.approx(max(centre - half, 0.0), abs=1e-12)
    assert hi == pytest.approx(min(centre + half, 1.0), abs=1e-12)


def test_interval_arguments_are_checked():
    with pytest.raises(ValueError, match="method: got 'bayes'"):
        success_interval(1, 2, method="bayes")
    with pytest.raises(ValueError, match="successes, trials: got 3, 2"):
        success_interval(3, 2)


def _table():
    # 4 samples x 2 shapes; sample 1 deviates 30 mm on shape 0, sample 2 collides, sample 3's
    # target moved 12 mm from the planned one
    n, s = 4, 2
    t = {"sample": np.repeat(np.arange(n), s), "shape": np.tile(np.arange(s), n)}
    t["converged"] = np.ones(n * s, bool)
    t["stable"] = np.ones(n * s, bool)
    t["deviation"] = np.array([1, 2, 30, 1, 1, 1, 2, 2], float) * 1e-3
    t["collision"] = np.array([0, 0, 0, 0, 1, 0, 0, 0], bool)
    t["displacement"] = np.array([1, 1, 1, 1, 1, 1, 1, 12], float) * 1e-3
    t["sag"] = np.array([50, 40, 60, 45, 50, 40, 50, 40], float) * 1e-3
    t["max_tension"] = np.ones(n * s)
    t["clip_force"] = np.ones(n * s)
    e = np.repeat([1.0, 2.0, 3.0, 4.0], s)
    for name in ("youngs_modulus", "mass_per_length", "length", "clip_position_error",
                 "clip_orientation_error", "obstacle_position_error"):
        t[name] = e if name == "youngs_modulus" else np.zeros(n * s)
    return t


def test_criteria_are_applied_per_sample_and_can_change_afterwards():
    t = _table()
    summary = summarize(t, CriteriaSpec())
    assert summary.n_success == 1
    assert summary.failures == {"stable": 0, "deviation": 1, "collision": 1, "target": 1}
    assert summary.deviation["max"] == pytest.approx(0.030)
    relaxed = summarize(t, CriteriaSpec(max_deviation=40, collision_free=False,
                                        target_threshold=15, max_sag=55))
    assert relaxed.failures == {"stable": 0, "deviation": 0, "target": 0, "sag": 1}
    assert relaxed.n_success == 3
    assert [s.parameter for s in relaxed.sensitivities] == ["youngs_modulus"]
    assert relaxed.ranked_by == "failure"
    assert "success 3/4 = 75.0 %" in relaxed.lines()[0]


def test_rank_p_values_of_a_few_samples_count_their_pairings():
    """3 samples in order: rho = 1 in 2 of the 6 pairings, p = 1/3 (``spearmanr``'s t
    approximation said p = 0, and a 3-sample study's --json read as a certain driver); 4 in
    order 2/24. With ties (failure as 0/1) the count agrees with scipy's own exact
    permutation test; above EXACT_PAIRINGS samples the approximation is kept."""
    from scipy.stats import permutation_test, spearmanr

    from dloplan.study.summary import EXACT_PAIRINGS, exact_rank_p_value

    def table(e, deviation, failed):
        t = _table()
        n, s = len(e), 2
        for name in list(t):
            t[name] = np.resize(t[name], n * s)
        t["sample"], t["shape"] = np.repeat(np.arange(n), s), np.tile(np.arange(s), n)
        t["youngs_modulus"] = np.repeat(np.asarray(e, float), s)
        t["deviation"] = np.repeat(np.asarray(deviation, float), s)
        t["collision"] = np.repeat(np.asarray(failed, bool), s)
        t["displacement"] = np.zeros(n * s)
        return t

    e = [1.0, 2.0, 3.0]
    sens = summarize(table(e, [1e-3, 2e-3, 3e-3], [0, 0, 0])).sensitivities[0]
    assert sens.rho_deviation == pytest.approx(1.0) and sens.p_deviation == pytest.approx(1 / 3)
    sens = summarize(table(e + [4.0], [4e-3, 3e-3, 2e-3, 1e-3], [0, 0, 1, 1])).sensitivities[0]
    assert sens.rho_deviation == pytest.approx(-1.0)
    assert sens.p_deviation == pytest.approx(2 / 24)

    x = np.array([0.3, 1.2, 0.7, 2.5, 1.9, 0.1, 3.0])
    failed = np.array([0, 1, 0, 1, 1, 0, 0], float)
    exact = permutation_test((x,), lambda v: spearmanr(v, failed).statistic,
                             permutation_type="pairings", n_resamples=math.inf)
    assert exact_rank_p_value(x, failed) == pytest.approx(exact.pvalue, abs=1e-12)

    n = EXACT_PAIRINGS + 2
    x = np.arange(n, dtype=float)
    y = np.array([2.0, 1.0, 4.0, 3.0, 6.0, 5.0, 8.0, 7.0, 10.0, 9.0])[:n]
    sens = summarize(table(x, 1e-3 * y, np.zeros(n))).sensitivities[0]
    assert sens.p_deviation == pytest.approx(spearmanr(x, y).pvalue, rel=1e-12)


def test_the_deviation_line_says_over_how_many_samples():
    """A study whose samples' shapes did not all converge (a 200 mm clip spread: 2 of 3) printed
    "largest deviation per sample: median 375.13 mm, ... max 375.13 mm", the one converged
    sample's, as if it were every sample's: the line now says over how many."""
    t = _table()
    t["converged"][2:4] = False  # sample 1
    t["deviation"][2:4] = np.nan
    summary = summarize(t)
    assert summary.deviation["samples"] == 3
    assert summary.deviation["max"] == pytest.approx(2e-3)
    line = next(x for x in summary.lines() if x.startswith("largest deviation per sample"))
    assert line.endswith("(over 3 of 4 samples: 1 with a shape not converged, no deviation)")
    assert summary.to_dict()["deviation_m"]["samples"] == 3
    whole = next(x for x in summarize(_table()).lines() if x.startswith("largest deviation"))
    assert "over" not in whole


def test_the_deviation_line_tells_refused_samples_from_unconverged_ones():
    """A study with a uniform 99 % spread on the length (round 11 of the unseen-case sweep):
    9 of 20 sampled cables were shorter than their clips are apart, refused before any solve
    ("clips: ... out of reach", 0 iterations), and the line called them "with a shape not
    converged". It now counts them apart, in the line and in ``deviation_m.refused``."""
    t = _table()
    t["iterations"] = np.full(8, 7)
    t["message"] = np.array([""] * 8, dtype=object)
    t["converged"][2:6] = False  # sample 1 not converged, sample 2 refused
    t["deviation"][2:6] = np.nan
    t["iterations"][4:6] = 0
    t["message"][4:6] = "clips: the inner held points are 0.4471 m apart ...: out of reach"
    summary = summarize(t)
    line = next(x for x in summary.lines() if x.startswith("largest deviation per sample"))
    assert line.endswith("(over 2 of 4 samples: 1 with a shape not converged, 1 refused "
                         "before solving (its rows' message says why), no deviation)")
    assert summary.to_dict()["deviation_m"]["refused"] == 1
    assert summarize(_table()).deviation["refused"] == 0  # a table without the columns
