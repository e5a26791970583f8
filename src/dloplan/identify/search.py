"""The search over s = ln E: a global scan, then safeguarded Gauss-Newton in every basin.

Each evaluation simulates the experiment at one E and returns the cost f(s), its exact slope
f'(s) and the Gauss-Newton curvature f'' ~ 2 |dr/ds|^2 (:mod:`dloplan.identify.distance`).

1. **Scan**: one simulation per decade of the bounds (at least 3), both bounds included. The
   slopes find the basins a sampled cost alone would miss: every pair of neighbouring samples
   with f' < 0 on the left and f' > 0 on the right brackets a local minimum; a bound whose
   slope points outward is a minimum at the bound. (A basin and a hump both narrower than a
   decade, between two samples whose slopes agree, escape the scan.)
2. **Refine** every bracket, the most promising first (its minimum estimated by the cubic
   Hermite interpolant of the two samples' costs and slopes, no simulation): Gauss-Newton
   steps s <- s - f'/f'' from the bracket's best sample, replaced by the Hermite minimizer when
   they leave the bracket, and by a bisection after two steps in a row that did not halve it
   (a kink or a jump of the cost); each new sample replaces the bracket end of the same slope
   sign.
   It stops when the step is below ``tol`` (a fraction of the statistical precision: further
   digits would be noise). Other brackets are refined only while their estimated minimum could
   compete with the best one (see :class:`Search`); the rest are reported with their estimate.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .distance import CurveResiduals
from .simulate import ManipulationRun


@dataclass(eq=False)
class Sample:
    """One simulation at s = ln E and its fit to the measurement.

    Attributes
    ----------
    s : float
        ln E [ln Pa].
    run : ManipulationRun
        The simulation.
    fit : CurveResiduals or None
        The residuals (None when the simulation failed).
    """

    s: float
    run: ManipulationRun
    fit: CurveResiduals | None

    @property
    def ok(self) -> bool:
        """The simulation succeeded."""
        return self.fit is not None

    @property
    def cost(self) -> float:
        """f [m^2] (NaN when failed)."""
        return self.fit.cost if self.fit is not None else math.nan

    @property
    def slope(self) -> float:
        """df/ds [m^2] (NaN when failed)."""
        return self.fit.slope if self.fit is not None else math.nan

    @property
    def curvature(self) -> float:
        """Gauss-Newton d^2f/ds^2 [m^2] (NaN when failed)."""
        return self.fit.curvature if self.fit is not None else math.nan


@dataclass(frozen=True)
class Minimum:
    """A local minimum of the cost over ln E.

    Attributes
    ----------
    sample : Sample
        The best sample of its basin.
    estimated_cost : float
        Its cost [m^2]: the sample's when ``refined``, else the Hermite estimate.
    refined : bool
        Gauss-Newton converged on it.
    at_bound : str
        ``""``, ``"E_min"`` or ``"E_max"``: the minimum is a bound with the cost still
        decreasing outward.
    """

    sample: Sample
    estimated_cost: float
    refined: bool
    at_bound: str = ""

    @property
    def youngs_modulus(self) -> float:
        """E of the best sample [Pa]."""
        return math.exp(self.sample.s)


def hermite_minimizer(a: Sample, b: Sample) -> tuple[float, float]:
    """(s, f) at the minimum of the cubic matching f, f' at a < b with f'(a) < 0 < f'(b).

    Nocedal and Wright, Numerical Optimization (2006), eq. 3.59; kept inside (a, b).
    """
    h = b.s - a.s
    d1 = a.slope + b.slope - 3.0 * (a.cost - b.cost) / (a.s - b.s)
    d2 = math.sqrt(max(d1 * d1 - a.slope * b.slope, 0.0))
    s = b.s - h * (b.slope + d2 - d1) / (b.slope - a.slope + 2.0 * d2)
    s = min(max(s, a.s + 0.05 * h), b.s - 0.05 * h)
    # the cubic's value at s (Hermite basis on t in [0, 1])
    t = (s - a.s) / h
    h00, h10 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t
    h01, h11 = -2 * t**3 + 3 * t**2, t**3 - t**2
    f = h00 * a.cost + h10 * h * a.slope + h01 * b.cost + h11 * h * b.slope
    return s, max(f, 0.0)


@dataclass(eq=False)
class Search:
    """Samples of the cost over ln E and the search on them (module docstring).

    Parameters
    ----------
    simulate : callable
        ``simulate(s, near)`` -> (ManipulationRun, CurveResiduals or None): the experiment at
        E = exp(s), warm-started from the sample ``near`` (or None).
    s_bounds : (float, float)
        ln of the bounds.
    budget : int
        Largest number of simulations.
    warm_radius : float
        Largest |s - s_near| of a warm start [-].
    """

    simulate: Callable
    s_bounds: tuple[float, float]
    budget: int
    warm_radius: float = 0.7
    samples: list[Sample] = field(default_factory=list)

    @property
    def exhausted(self) -> bool:
        """The simulation budget is spent."""
        return len(self.samples) >= self.budget

    def evaluate(self, s: float, warm: bool = True) -> Sample:
        """Simulate at s, warm-started from the nearest good sample within ``warm_radius``."""
        near = None
        if warm:
            close = [p for p in self.samples if p.ok and abs(p.s - s) <= self.warm_radius]
            near = min(close, key=lambda p: abs(p.s - s)) if close else None
        run, fit = self.simulate(s, near)
        sample = Sample(float(s), run, fit)
        self.samples.append(sample)
        return sample

    @property
    def good(self) -> list[Sample]:
        """Successful samples sorted by s."""
        return sorted((p for p in self.samples if p.ok), key=lambda p: p.s)

    def scan(self, n_grid: int) -> None:
        """One cold-started simulation at each of ``n_grid`` points evenly spaced in ln E."""
        for s in np.linspace(*self.s_bounds, n_grid):
            self.evaluate(float(s), warm=False)

    def brackets(self) -> list[tuple[Sample | None, Sample | None]]:
        """Basins of the scanned cost: (left, right) samples with f' < 0 < f', or a bound.

        A bound minimum is (None, sample) at E_min (f' > 0 there) or (sample, None) at E_max.
        """
        good = self.good
        out: list[tuple[Sample | None, Sample | None]] = []
        if not good:
            return out
        lo, hi = self.s_bounds
        if good[0].s <= lo + 1e-12 and good[0].slope > 0:
            out.append((None, good[0]))
        for a, b in zip(good, good[1:], strict=False):
            if a.slope < 0 < b.slope:
                out.append((a, b))
        if good[-1].s >= hi - 1e-12 and good[-1].slope < 0:
            out.append((good[-1], None))
        if not out:  # flat or monotone without a sign change: the best sample's neighbourhood
            k = min(range(len(good)), key=lambda i: good[i].cost)
            out.append((good[k - 1] if k > 0 else None, good[k + 1] if k + 1 < len(good)
                        else None))
        return out

    def refine(self, left: Sample | None, right: Sample | None, tol: float) -> Sample:
        """Safeguarded Gauss-Newton inside (left, right); returns the best sample found."""
        inside = [p for p in (left, right) if p is not None]
        best = min(inside, key=lambda p: p.cost)
        lo = left.s if left is not None else self.s_bounds[0]
        hi = right.s if right is not None else self.s_bounds[1]
        slow = 0  # steps in a row that did not halve the bracket (a kink or a jump of the cost)
        while not self.exhausted and hi - lo > tol:
            step = -best.slope / best.curvature if best.curvature > 0 else math.nan
            if math.isfinite(step) and abs(step) < tol:
                break  # converged
            trial = best.s + step
            if slow >= 2:
                trial, slow = 0.5 * (lo + hi), 0
            elif not (math.isfinite(trial) and lo < trial < hi):
                if left is not None and right is not None:
                    trial = hermite_minimizer(left, right)[0]
                else:
                    trial = 0.5 * (best.s + (hi if best.slope < 0 else lo))
            width = hi - lo
            new = self.evaluate(trial)
            if not new.ok:  # shrink toward the best sample
                if trial > best.s:
                    hi, right = trial, None
                else:
                    lo, left = trial, None
                continue
            if new.slope > 0:
                hi, right = new.s, new
            else:
                lo, left = new.s, new
            slow = slow + 1 if hi - lo > 0.5 * width else 0
            moved = abs(new.s - best.s)
            if new.cost < best.cost:
                best = new
            if moved < tol:
                break
        return best

    def minima(self, tol: float, compete: Callable[[float, float], bool]) -> list[Minimum]:
        """Every basin of the scan, refined while it may compete with the best (sorted by cost).

        ``compete(estimate, best_cost)`` says whether a basin whose estimated minimum cost is
        ``estimate`` must be refined given the best refined cost so far.
        """
        lo, hi = self.s_bounds
        candidates = []
        for left, right in self.brackets():
            if left is not None and right is not None:
                estimate = hermite_minimizer(left, right)[1] if left.slope < 0 < right.slope \
                    else min(left.cost, right.cost)
            else:
                estimate = (left or right).cost
            candidates.append((estimate, left, right))
        candidates.sort(key=lambda c: c[0])
        found: list[Minimum] = []
        best_cost = math.inf
        for estimate, left, right in candidates:
            bound = ""
            if left is None and right is not None and right.s <= lo + 1e-12 and right.slope > 0:
                bound = "E_min"
            elif right is None and left is not None and left.s >= hi - 1e-12 and left.slope < 0:
                bound = "E_max"
            if bound:
                sample = left or right
                found.append(Minimum(sample, sample.cost, True, bound))
                best_cost = min(best_cost, sample.cost)
                continue
            if best_cost == math.inf or (compete(estimate, best_cost) and not self.exhausted):
                sample = self.refine(left, right, tol)
                found.append(Minimum(sample, sample.cost, True))
                best_cost = min(best_cost, sample.cost)
            else:
                sample = min((p for p in (left, right) if p is not None), key=lambda p: p.cost)
                found.append(Minimum(sample, estimate, False))
        return sorted(found, key=lambda m: m.estimated_cost)
