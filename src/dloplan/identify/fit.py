"""Young's modulus identification: a bounded, simulation-based least-squares fit (thesis 6.1).

The decision variable is E in [E_min, E_max] (eq. 6.3), searched as s = ln E; the cost is eq. 6.4

    f(s) = | xi_data,f - xi_sim,f(s) |^2        [m^2]

over the n + 1 points of the measured and the simulated final shape. Each simulation also
returns the sensitivity J = d xi_sim,f / d s (one sparse solve, see
:mod:`dloplan.identify.simulate`), hence the exact gradient f' = -2 r.J (r = xi_data - xi_sim)
and the Gauss-Newton curvature f'' ~ 2 J.J. The search:

1. **Grid**: one simulation per decade of the bounds (at least 3), both bounds included: the
   cost samples of thesis Fig. 6.8 and the basin of the global minimum (the cost of a
   path-dependent manipulation need not be convex, or even continuous, across decades).
2. **Bracketed Gauss-Newton**: from the best sample, Gauss-Newton steps s <- s + r.J / J.J kept
   inside the bracket given by the neighbouring samples; the bracket shrinks with the sign of
   each new gradient (a step outside it, or a failed one, bisects). Each new simulation is
   warm-started from the run at the nearest modulus already simulated.
3. **At a bound**: when the best sample is a bound and the gradient there points outward, no E
   in the bounds explains the data: ``success`` is False, ``at_bound`` True, and no modulus is
   reported.

Uncertainty (a Gauss-Newton linearization): the residuals are assumed independent, Gaussian,
of equal variance sigma^2 on every coordinate and the model otherwise exact; then
var(ln E) = sigma^2 / J.J. sigma is the residual RMS per coordinate, sqrt(f / (3(n + 1) - 1)),
but never less than the stated measurement noise (so a perfect synthetic fit does not claim
a perfect modulus). The 95 % interval is E exp(+-1.96 sd). An experiment is ``informative``
when sd(ln E) <= ``max_log_sd`` (default 0.1: E known to about +-10 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..cable import Cable
from .experiment import Experiment, prepare_shapes
from .simulate import SIMULATORS, DynamicSettings, ManipulationRun, run_manipulation

DEFAULT_BOUNDS = (1e5, 1e10)
"""Default search range of E [Pa] (thesis 6.1)."""

MAX_LOG_SD = 0.1
"""Largest standard deviation of ln E of an informative experiment."""

WARM_RADIUS = 0.7
"""Largest |ln E - ln E_previous| from which a run is warm-started (a factor 2 in E)."""

Z95 = 1.959963984540054
"""Two-sided 95 % quantile of the standard normal distribution."""


@dataclass(frozen=True, eq=False)
class Identification:
    """Result of :func:`identify_youngs_modulus` (the columns of thesis Table 7.1 and more).

    Attributes
    ----------
    success : bool
        An interior minimum was found with converged simulations.
    message : str
        What happened, with any warning (poor fit, uninformative experiment, reversed data).
    youngs_modulus : float
        Identified E [Pa]; NaN when ``success`` is False.
    best_in_bounds : float
        E of the smallest cost simulated [Pa] (a bound when ``at_bound``).
    confidence_interval : tuple of float
        95 % interval of E [Pa] from the cost's curvature (see the module docstring).
    log_sd : float
        Standard deviation of ln E [-] (about the relative standard deviation of E).
    cost : float
        f(x) of eq. 6.4 at the solution [m^2].
    rms_error : float
        RMS distance between measured and simulated points [m].
    max_error : float
        Largest such distance [m].
    optimality : float
        First-order optimality |df / d ln E| at the solution [m^2].
    iterations : int
        Gauss-Newton steps after the grid.
    simulations : int
        Simulated manipulations (grid and steps).
    solver_iterations : int
        Newton iterations (static) or time steps (dynamic) of all the simulations.
    at_bound : bool
        The best E is a bound with the cost still decreasing outward.
    informative : bool
        sd(ln E) <= the ``max_log_sd`` asked for.
    curve : numpy.ndarray
        (K, 2) samples (E [Pa], cost [m^2]) sorted by E (thesis Fig. 6.8); failed
        simulations are left out.
    bounds : tuple of float
        (E_min, E_max) [Pa].
    measured_shape : numpy.ndarray
        (n + 1, 3) measured final shape resampled by arc length [m].
    simulated_shape : numpy.ndarray
        (n + 1, 3) simulated final shape at the best E [m].
    cable : Cable
        The input cable with the identified modulus (unchanged when ``success`` is False).
    failed_simulations : int
        Simulations whose equilibria did not converge (left out of the search).
    """

    success: bool
    message: str
    youngs_modulus: float
    best_in_bounds: float
    confidence_interval: tuple[float, float]
    log_sd: float
    cost: float
    rms_error: float
    max_error: float
    optimality: float
    iterations: int
    simulations: int
    solver_iterations: int
    at_bound: bool
    informative: bool
    curve: np.ndarray
    bounds: tuple[float, float]
    measured_shape: np.ndarray
    simulated_shape: np.ndarray
    cable: Cable
    failed_simulations: int = 0

    def table(self) -> dict[str, float]:
        """The row of thesis Table 7.1, keyed by column name (units in brackets)."""
        return {
            "iterations": self.iterations,
            "simulations": self.simulations,
            "f(x) [m^2]": self.cost,
            "first-order optimality [m^2]": self.optimality,
            "E identified [Pa]": self.youngs_modulus,
        }


@dataclass(eq=False)
class _Sample:
    s: float
    run: ManipulationRun
    cost: float = math.nan
    slope: float = math.nan  # df/ds
    curvature: float = math.nan  # Gauss-Newton 2 J.J


@dataclass(eq=False)
class _Search:
    cable: Cable
    experiment: Experiment
    initial: np.ndarray
    measured: np.ndarray
    simulator: str
    dynamic: DynamicSettings | None
    warm_start: bool
    samples: list[_Sample] = field(default_factory=list)

    def evaluate(self, s: float) -> _Sample:
        warm = None
        if self.warm_start and self.simulator == "static":
            near = [p for p in self.samples if p.run.success and abs(p.s - s) <= WARM_RADIUS]
            if near:
                warm = min(near, key=lambda p: abs(p.s - s)).run.shapes
        run = run_manipulation(self.cable.with_modulus(math.exp(s)),
                               self.experiment.manipulation, self.initial,
                               simulator=self.simulator, warm_start=warm, dynamic=self.dynamic)
        sample = _Sample(s, run)
        if run.success:
            r = (self.measured - run.final).ravel()
            j = run.sensitivity.ravel()
            sample.cost = float(r @ r)
            sample.slope = float(-2.0 * r @ j)
            sample.curvature = float(2.0 * j @ j)
        self.samples.append(sample)
        return sample

    @property
    def good(self) -> list[_Sample]:
        return sorted((p for p in self.samples if p.run.success), key=lambda p: p.s)


def _check_bounds(bounds) -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in bounds)
    except (TypeError, ValueError):
        raise ValueError(f"bounds: got {bounds!r}, expected (E_min, E_max) [Pa]") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise ValueError(f"bounds: got {bounds!r}, expected finite 0 < E_min < E_max [Pa]")
    return lo, hi


def identify_youngs_modulus(
    cable: Cable,
    experiment: Experiment,
    *,
    bounds=DEFAULT_BOUNDS,
    simulator: str = "static",
    dynamic: DynamicSettings | None = None,
    xtol: float = 1e-3,
    max_simulations: int = 30,
    max_log_sd: float = MAX_LOG_SD,
    warm_start: bool = True,
) -> Identification:
    """Identify the Young's modulus that makes the model reproduce a measured shape (thesis 6.1).

    Minimizes eq. 6.4 over E in ``bounds`` (eq. 6.3), in ln E, with a grid then bracketed
    Gauss-Newton steps using the exact sensitivity of the final equilibrium (module docstring).

    Parameters
    ----------
    cable : Cable
        The cable (length, diameter, mass, discretization, bending model); its own modulus is
        ignored. The identified E belongs to this ``bending`` model: ``"thesis"`` gives about a
        third of ``"rod"`` for the same data (see ``docs/identification.md``).
    experiment : Experiment
        The manipulation and its measured final shape.
    bounds : (float, float)
        (E_min, E_max) [Pa], 0 < E_min < E_max; default 1e5 to 1e10 (thesis 6.1).
    simulator : {"static", "dynamic"}
        Quasi-static continuation (default) or the thesis' time stepping (much slower).
    dynamic : DynamicSettings, optional
        Settings of the dynamic simulator (pace, settling, the capped modulus of Fig. 6.5).
    xtol : float
        Convergence: a Gauss-Newton step or the bracket below ``xtol`` in ln E [-].
    max_simulations : int
        Simulation budget (the grid included).
    max_log_sd : float
        The experiment is informative when sd(ln E) is at most this [-].
    warm_start : bool
        Start each static simulation from the run at the nearest modulus (within a factor 2).

    Returns
    -------
    Identification
        E, its 95 % interval, Table 7.1's numbers, the cost curve and the flags.

    Raises
    ------
    ValueError
        Bad bounds or settings, a measured shape whose length is not the cable's (with a hint
        when it looks like millimetres), or whose ends are far from the final clips.
    """
    lo, hi = _check_bounds(bounds)
    if simulator not in SIMULATORS:
        raise ValueError(f"simulator: got {simulator!r}, expected 'static' or 'dynamic'")
    if simulator == "dynamic" and experiment.manipulation.held != "both":
        raise ValueError("simulator: 'dynamic' needs held='both' (the thesis' two-clip setup); "
                         "use 'static' for a cantilever experiment")
    for name, value in (("xtol", xtol), ("max_log_sd", max_log_sd)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}: got {value!r}, expected a number > 0")
    s_lo, s_hi = math.log(lo), math.log(hi)
    n_grid = max(3, math.ceil((s_hi - s_lo) / math.log(10.0) - 1e-9) + 1)
    if int(max_simulations) != max_simulations or max_simulations < n_grid + 1:
        raise ValueError(
            f"max_simulations: got {max_simulations!r}, expected an integer >= {n_grid + 1} "
            f"(the {n_grid}-point grid over the bounds and one step)"
        )
    prepared = prepare_shapes(cable, experiment)
    search = _Search(cable, experiment, prepared.initial, prepared.measured, simulator,
                     dynamic, warm_start)
    for s in np.linspace(s_lo, s_hi, n_grid):
        search.evaluate(float(s))
    iterations = _refine(search, s_lo, s_hi, xtol, max_simulations)
    return _result(search, prepared, lo, hi, xtol, max_log_sd, iterations)


def _refine(search: _Search, s_lo: float, s_hi: float, xtol: float, budget: int) -> int:
    """Bracketed Gauss-Newton from the best grid sample; returns the number of steps."""
    good = search.good
    if not good:
        return 0
    k = min(range(len(good)), key=lambda i: good[i].cost)
    best = good[k]
    if (best.s <= s_lo and best.slope >= 0) or (best.s >= s_hi and best.slope <= 0):
        return 0  # the constrained minimum is a bound
    a = good[k - 1].s if k > 0 else s_lo
    b = good[k + 1].s if k + 1 < len(good) else s_hi
    steps = 0
    while len(search.samples) < budget and b - a > xtol:
        step = -best.slope / best.curvature if best.curvature > 0 else math.nan
        if abs(step) < xtol:
            break  # converged: the next Gauss-Newton step is below xtol
        trial = best.s + step
        if not (math.isfinite(trial) and a < trial < b):
            trial = 0.5 * (best.s + (b if best.slope < 0 else a))  # bisect toward the descent
        new = search.evaluate(trial)
        steps += 1
        if new.run.success and new.cost < best.cost:
            # the minimum lies between two points of opposite slopes, else downhill of the new
            if new.slope * best.slope < 0:
                a, b = sorted((new.s, best.s))
            elif new.slope > 0:
                b = new.s
            else:
                a = new.s
            moved = abs(new.s - best.s)
            best = new
            if moved < xtol:
                break
        elif new.s > best.s:  # worse (or failed): the minimum is on the best point's side
            b = new.s
        else:
            a = new.s
    return steps


def _result(search: _Search, prepared, lo, hi, xtol, max_log_sd, iterations) -> Identification:
    good = search.good
    failed = len(search.samples) - len(good)
    curve = np.array([[math.exp(p.s), p.cost] for p in good]).reshape(-1, 2)
    measured = prepared.measured
    common = dict(bounds=(lo, hi), measured_shape=measured, simulations=len(search.samples),
                  iterations=iterations, failed_simulations=failed, curve=curve,
                  solver_iterations=sum(p.run.solver_iterations for p in search.samples))
    if not good:
        first = search.samples[0].run.message
        return Identification(
            success=False, message=f"every simulation failed (first: {first})",
            youngs_modulus=math.nan, best_in_bounds=math.nan,
            confidence_interval=(math.nan, math.nan), log_sd=math.nan, cost=math.nan,
            rms_error=math.nan, max_error=math.nan, optimality=math.nan, at_bound=False,
            informative=False, simulated_shape=np.full_like(measured, np.nan),
            cable=search.cable, **common)
    best = min(good, key=lambda p: p.cost)
    e_best = math.exp(best.s)
    simulated = best.run.final
    distances = np.linalg.norm(measured - simulated, axis=1)
    n_coords = measured.size
    sigma = max(math.sqrt(best.cost / (n_coords - 1)), search.experiment.measurement_noise)
    j_norm = math.sqrt(0.5 * best.curvature)
    log_sd = sigma / j_norm if j_norm > 0 else math.inf
    informative = log_sd <= max_log_sd
    at_bound = ((best.s <= math.log(lo) + xtol and best.slope >= 0)
                or (best.s >= math.log(hi) - xtol and best.slope <= 0))
    notes = []
    if prepared.reversed:
        notes.append("the measured points ran from the last clip to the first and were reversed")
    if failed:
        notes.append(f"{failed} of {len(search.samples)} simulations failed and were skipped")
    rms = float(np.sqrt(np.mean(distances**2)))
    if rms > 5.0 * math.sqrt(3.0) * search.experiment.measurement_noise:
        notes.append(
            f"the best fit leaves an RMS point error of {1e3 * rms:.1f} mm, more than 5 times "
            "the measurement noise: the model, the clip poses or the data may be inconsistent")
    if not informative:
        notes.append(
            f"the experiment is not informative: sd(ln E) = {log_sd:.3g} > {max_log_sd:g} "
            "(a flat cost: bend the cable more under gravity, e.g. a cantilever for stiff ones)")
    if at_bound:
        side = "E_min" if best.s <= math.log(lo) + xtol else "E_max"
        head = (f"no modulus in [{lo:.3g}, {hi:.3g}] Pa explains the data: the cost still "
                f"decreases beyond {side} = {e_best:.3g} Pa; widen the bounds or check the "
                "experiment")
        success, e_out, interval = False, math.nan, (math.nan, math.nan)
        cable = search.cable
    else:
        success, e_out = True, e_best
        interval = (e_best * math.exp(-Z95 * log_sd), e_best * math.exp(Z95 * log_sd))
        head = (f"identified E = {e_best:.4g} Pa (95 % interval {interval[0]:.4g} to "
                f"{interval[1]:.4g} Pa) in {len(search.samples)} simulations")
        cable = search.cable.with_modulus(e_best)
    return Identification(
        success=success, message="; ".join([head, *notes]), youngs_modulus=e_out,
        best_in_bounds=e_best, confidence_interval=interval, log_sd=float(log_sd),
        cost=best.cost, rms_error=rms, max_error=float(distances.max()),
        optimality=abs(best.slope), at_bound=bool(at_bound), informative=bool(informative),
        simulated_shape=simulated, cable=cable, **common)
