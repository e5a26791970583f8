"""What a study table says: how likely the plan is to work, and what makes it fail.

* **Success**: a sample succeeds when every shape passes every criterion of
  :class:`~dloplan.study.spec.CriteriaSpec` (equilibrium converged and stable, deviation from
  the nominal stabilized shape, no collision, the stabilized target within T_cf of the planned
  one, and the optional sag, tension and clip-force limits). The criteria are applied to the
  stored measurements here, not during the run, so they can be changed without re-running.
* **Success probability** p = k / N with a confidence interval for a binomial proportion:
  Wilson's score interval (default; good coverage even near p = 0 or 1 and at small N) or the
  exact Clopper-Pearson interval (conservative: coverage at least the nominal level), both from
  ``scipy.stats.binomtest(k, N).proportion_ci``. With LHS the samples are not independent draws,
  which makes the binomial interval slightly conservative for smooth failure regions.
* **Sensitivities**: Spearman's rank correlation (``scipy.stats.spearmanr``) of each varied
  parameter with the sample's largest deviation and with its failure (0/1), and its two-sided
  p-value: exact, over every pairing of the ranks, for at most :data:`EXACT_PAIRINGS` samples
  (``spearmanr``'s t approximation gives p = 0 for |rho| = 1 at any N: 3 samples in order
  would read as certain, where 2 of their 6 pairings are as extreme), else
  ``spearmanr``'s. Rank correlation
  measures a monotone association without assuming linearity or a distribution; its sign says
  in which direction the parameter pushes. The parameters are ranked by |rho| with failure
  when the study has both successes and failures, otherwise with deviation. Clip and obstacle
  errors enter by their magnitude (the largest offset norm of a sample), because an error
  hurts in either direction.

Sobol indices (SALib) are not computed: they need a Saltelli design of N (2d + 2) model runs
instead of N, separate from the LHS design, and they answer a question (how much of the
variance each parameter explains, with interactions) that a go/no-go decision rarely needs
once rank correlations have named the driver.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from itertools import permutations

import numpy as np

from .sampling import RELATIVE, UNITS
from .spec import CriteriaSpec

SENSITIVITY_PARAMETERS = (*RELATIVE, "clip_position_error", "clip_orientation_error",
                          "obstacle_position_error")
"""Per-sample parameters whose rank correlations are reported."""

INTERVAL_METHODS = {"wilson": "wilson", "clopper-pearson": "exact"}

EXACT_PAIRINGS = 8
"""Up to this many samples a rank correlation's p-value counts every pairing (8! = 40320)."""


@dataclass(frozen=True)
class Sensitivity:
    """Rank correlation of one parameter with the outcome of the samples.

    Attributes
    ----------
    parameter : str
        Column name (e.g. ``youngs_modulus``).
    unit : str
        Its unit.
    rho_deviation, p_deviation : float
        Spearman's rho with the sample's largest deviation [-], and its p-value.
    rho_failure, p_failure : float
        Spearman's rho with failure (1 failed, 0 succeeded), and its p-value; NaN when every
        sample failed or every sample succeeded.
    """

    parameter: str
    unit: str
    rho_deviation: float
    p_deviation: float
    rho_failure: float
    p_failure: float


@dataclass(frozen=True, eq=False)
class StudySummary:
    """The summary of a study table.

    Attributes
    ----------
    n_samples, n_success : int
        Samples evaluated and samples that passed every criterion.
    probability : float
        Estimated success probability k / N.
    interval : tuple of float
        Confidence interval (low, high) of the success probability.
    confidence : float
        Its level (e.g. 0.95).
    method : str
        ``"wilson"`` or ``"clopper-pearson"``.
    failures : dict
        Criterion -> number of samples failing it (a sample may fail several).
    sensitivities : tuple of Sensitivity
        Varied parameters, most influential first.
    ranked_by : str
        ``"failure"`` or ``"deviation"``: which correlation ranks the sensitivities.
    deviation : dict
        Median, 95th percentile and largest of the samples' largest deviations [m], and
        ``samples``, how many samples have one (a sample with a shape not converged has none),
        and ``refused``, how many of those without were refused before any solve (a cable its
        clips cannot hold: 0 iterations, the rows' message says why).
    closed_loop : ClosedLoopSuccess or None
        With a ``correction:`` section: the open- and closed-loop success probabilities of
        :func:`dloplan.correct.closed_loop_study` (its ``message`` and ``to_dict()``).
    """

    n_samples: int
    n_success: int
    probability: float
    interval: tuple[float, float]
    confidence: float
    method: str
    failures: dict
    sensitivities: tuple
    ranked_by: str
    deviation: dict
    closed_loop: object = None

    def lines(self) -> list[str]:
        """A few lines for the console."""
        lo, hi = self.interval
        out = [f"success {self.n_success}/{self.n_samples} = {100 * self.probability:.1f} % "
               f"({100 * self.confidence:.0f} % {self.method} interval {100 * lo:.1f}-"
               f"{100 * hi:.1f} %)"]
        failed = ", ".join(f"{k} {v}" for k, v in self.failures.items() if v)
        out.append(f"failures by criterion: {failed or 'none'}")
        d = self.deviation
        if math.isfinite(d["max"]):
            unevaluated = self.n_samples - d["samples"]
            refused = d.get("refused", 0)
            why = ", ".join(filter(None, [
                f"{unevaluated - refused} with a shape not converged" if unevaluated > refused
                else "", f"{refused} refused before solving (its rows' message says why)"
                if refused else ""]))
            over = "" if not unevaluated else \
                f" (over {d['samples']} of {self.n_samples} samples: {why}, no deviation)"
            out.append(f"largest deviation per sample: median {1e3 * d['median']:.2f} mm, 95 % "
                       f"{1e3 * d['p95']:.2f} mm, max {1e3 * d['max']:.2f} mm{over}")
        else:
            out.append("largest deviation per sample: none (no sample converged)")
        for s in self.sensitivities:
            out.append(f"  {s.parameter:<24} rho(deviation) {_rho(s.rho_deviation)}   "
                       f"rho(failure) {_rho(s.rho_failure)}")
        if self.closed_loop is not None:
            out.append(f"one correction: {self.closed_loop.message}")
        return out

    def to_dict(self) -> dict:
        """JSON-able form (NaN as null)."""
        def clean(v):
            return None if isinstance(v, float) and not math.isfinite(v) else v

        return {
            "n_samples": self.n_samples, "n_success": self.n_success,
            "probability": self.probability, "interval": list(self.interval),
            "confidence": self.confidence, "method": self.method, "failures": self.failures,
            "ranked_by": self.ranked_by, "deviation_m": self.deviation,
            "sensitivities": [{k: clean(v) for k, v in s.__dict__.items()}
                              for s in self.sensitivities],
            "closed_loop": None if self.closed_loop is None else self.closed_loop.to_dict(),
        }


def success_interval(successes: int, trials: int, confidence: float = 0.95,
                     method: str = "wilson") -> tuple[float, float]:
    """Confidence interval of a binomial proportion (Wilson score or Clopper-Pearson exact)."""
    if method not in INTERVAL_METHODS:
        raise ValueError(f"method: got {method!r}, expected 'wilson' or 'clopper-pearson'")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence: got {confidence!r}, expected a level in (0, 1)")
    if trials < 1 or not 0 <= successes <= trials:
        raise ValueError(f"successes, trials: got {successes}, {trials}, expected "
                         "0 <= successes <= trials, trials >= 1")
    from scipy.stats import binomtest  # ~1 s to import: only when summarizing

    ci = binomtest(int(successes), int(trials)).proportion_ci(confidence,
                                                               INTERVAL_METHODS[method])
    return float(ci.low), float(ci.high)


def sample_outcomes(table: dict, criteria: CriteriaSpec) -> dict:
    """Per-sample verdicts of a study table.

    Returns
    -------
    dict
        ``sample`` (N,) indices in ascending order; ``success`` (N,) bool; ``passed``: a dict
        of one (N,) bool array per active criterion (True = passed); ``deviation`` (N,)
        largest deviation [m] (inf for a sample that could not be evaluated); and each
        per-sample parameter column (N,).
    """
    samples, first = np.unique(table["sample"], return_index=True)
    position = np.searchsorted(samples, table["sample"])
    target = table["shape"] == table["shape"].max()
    checks = {}
    if criteria.require_stable:
        checks["stable"] = table["converged"] & table["stable"]
    if criteria.max_deviation is not None:
        checks["deviation"] = table["deviation"] <= criteria.max_deviation * 1e-3
    if criteria.collision_free:
        checks["collision"] = ~table["collision"]
    if criteria.target_threshold is not None:
        checks["target"] = ~target | (table["displacement"] <= criteria.target_threshold * 1e-3)
    if criteria.max_sag is not None:
        checks["sag"] = table["sag"] <= criteria.max_sag * 1e-3
    if criteria.max_tension is not None:
        checks["tension"] = table["max_tension"] <= criteria.max_tension
    if criteria.max_clip_force is not None:
        checks["clip_force"] = table["clip_force"] <= criteria.max_clip_force
    out = {"sample": samples, "passed": {}}
    success = np.ones(len(samples), dtype=bool)
    for name, passed in checks.items():
        per_sample = np.ones(len(samples), dtype=bool)
        np.logical_and.at(per_sample, position, passed)
        out["passed"][name] = per_sample
        success &= per_sample
    out["success"] = success
    deviation = np.full(len(samples), -np.inf)
    np.maximum.at(deviation, position, np.where(np.isnan(table["deviation"]), np.inf,
                                                table["deviation"]))
    out["deviation"] = deviation
    for name in SENSITIVITY_PARAMETERS:
        out[name] = table[name][first]
    return out


def _spearman(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    keep = np.isfinite(x) & np.isfinite(y)
    x, y = x[keep], y[keep]
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return math.nan, math.nan
    from scipy.stats import spearmanr

    result = spearmanr(x, y)
    rho = float(result.statistic)
    if len(x) > EXACT_PAIRINGS:
        return rho, float(result.pvalue)
    return rho, exact_rank_p_value(x, y)


@cache
def _pairings(n: int) -> np.ndarray:
    """(n!, n) every permutation of range(n), made once per n."""
    return np.array(list(permutations(range(n))))


def exact_rank_p_value(x: np.ndarray, y: np.ndarray) -> float:
    """Two-sided p-value of Spearman's rho of ``x`` and ``y`` by every pairing of their ranks.

    Parameters
    ----------
    x, y : numpy.ndarray
        (N,) paired values, N small (N! pairings are enumerated), neither constant.

    Returns
    -------
    float
        The fraction of the N! pairings whose |rho| is at least the observed one (ties get
        average ranks, as in ``scipy.stats.spearmanr``).
    """
    from scipy.stats import rankdata

    rx = rankdata(x) - (len(x) + 1) / 2.0
    ry = rankdata(y) - (len(y) + 1) / 2.0
    scale = math.sqrt(float(rx @ rx) * float(ry @ ry))
    pairings = ry[_pairings(len(y))]
    rhos = np.abs(pairings @ rx) / scale
    observed = abs(float(ry @ rx)) / scale
    return float(np.mean(rhos >= observed - 1e-12))


def summarize(table: dict, criteria: CriteriaSpec | None = None, *, confidence: float = 0.95,
              method: str = "wilson") -> StudySummary:
    """Success probability with its interval, failures per criterion and sensitivities.

    Parameters
    ----------
    table : dict
        A study table (one row per sample and shape).
    criteria : CriteriaSpec, optional
        Default: :class:`CriteriaSpec` defaults.
    confidence : float
        Level of the interval.
    method : {"wilson", "clopper-pearson"}
        Interval method.
    """
    criteria = criteria or CriteriaSpec()
    if not table or len(table["sample"]) == 0:
        raise ValueError("table: empty, expected the rows of at least one sample")
    per = sample_outcomes(table, criteria)
    n = len(per["sample"])
    k = int(per["success"].sum())
    failed = (~per["success"]).astype(float)
    sens = []
    for name in SENSITIVITY_PARAMETERS:
        x = per[name]
        if np.ptp(x) == 0:
            continue  # not varied
        sens.append(Sensitivity(name, UNITS[name], *_spearman(x, per["deviation"]),
                                *_spearman(x, failed)))
    ranked_by = "failure" if 0 < k < n else "deviation"

    def key(s: Sensitivity) -> float:
        rho = s.rho_failure if ranked_by == "failure" else s.rho_deviation
        return -abs(rho) if math.isfinite(rho) else 0.0

    sens.sort(key=key)
    finite = per["deviation"][np.isfinite(per["deviation"])]
    stats = {"median": float(np.median(finite)) if len(finite) else math.nan,
             "p95": float(np.percentile(finite, 95)) if len(finite) else math.nan,
             "max": float(finite.max()) if len(finite) else math.nan,
             "samples": len(finite), "refused": _refused(table)}
    failures = {name: int((~passed).sum()) for name, passed in per["passed"].items()}
    return StudySummary(n, k, k / n, success_interval(k, n, confidence, method), confidence,
                        method, failures, tuple(sens), ranked_by, stats)


def _refused(table: dict) -> int:
    """Samples with a shape refused before any solve (0 iterations, not converged: a cable
    the clips cannot hold, ``evaluate._failed``); 0 for a table without ``iterations``."""
    if "iterations" not in table:
        return 0
    refused = (np.asarray(table["iterations"]) == 0) & ~np.asarray(table["converged"], bool)
    return len(np.unique(np.asarray(table["sample"])[refused]))


def _rho(value: float) -> str:
    """A rank correlation for the console; "n/a" where it is undefined (a constant column)."""
    return f"{value:+.2f}" if math.isfinite(value) else "  n/a"
