"""Young's modulus identification: a global, branch-aware least-squares fit with honest verdicts.

The decision variable is E in [E_min, E_max] (thesis eq. 6.3), searched as s = ln E. The cost
replaces thesis eq. 6.4's point-to-point distance by the distance of every measured point to
the simulated cable's curve (:mod:`dloplan.identify.distance`; unbiased by noise, any number of
points):

    f(s) = sum_j | p_j - c_j(s) |^2        [m^2]

Steps of :func:`identify_youngs_modulus`:

1. **Discretization check.** The measured shape is smoothed (:mod:`dloplan.identify.measured`)
   and its bend radius R read at the scale of a link
   (:meth:`~dloplan.identify.measured.MeasuredCurve.turning`); a model link longer than
   ``LINK_FRACTION`` R cannot follow the bend (a USB cable with a 37 mm bend near the clip came
   out 92 % low with 31 mm links). By default the fit then uses the fewest links that satisfy
   it (at most ``MAX_LINKS``), says so, and the result carries that n: plan with it
   (:func:`dloplan.identify.report.plan_warnings`).
2. **Global scan and refinement** (:mod:`dloplan.identify.search`), each simulation the final
   equilibrium started from the measured shape (the ``"branch"`` simulator,
   :mod:`dloplan.identify.simulate`), so every simulated shape stays on the measured branch
   (when Newton's method does not converge from that start, a noisy measurement of a very
   soft cable's tight bends, the simulated manipulation stands in). Every local minimum found
   is reported with its cost.
3. **Discretization error.** The best E is fitted again with 2n links (Gauss-Newton from the
   first E). With an error of E(n) of first order in 1/n (the clip holds half a link of cable
   outside its point), E(n) - E(inf) ~ 2 (E(n) - E(2n)): the first-order extrapolate lies that
   far from E(n), so the 95 % interval of ln E is widened by half as much again,
   ``DISCRETIZATION_COVER`` |ln E(n) - ln E(2n)| = 3 |...|, added to the statistical half-width
   (a bias, not a random error; with 2 |...| the extrapolate sat on the interval's edge and the
   truth fell outside at n = 16, issue 35).
4. **Path check** (``"branch"`` only). The manipulation simulated quasi-statically at the
   identified E must end on the measured branch; if not, a warning (the model cannot reproduce
   the measured manipulation, although the measured shape is one of its equilibria).

Statistics (Gauss-Newton linearization; residual components independent, Gaussian, of equal
variance): sigma_hat = sqrt(f / dof) per coordinate (dof: 2 per point whose closest point lies
inside a segment, 3 at a vertex, minus 1); var(ln E) = sigma^2 / |dr/ds|^2 with sigma =
max(sigma_hat, the stated noise). The 95 % half-width in ln E is 1.96 sd, widened to every
simulated E whose cost is within 1.96^2 sigma^2 of the best (a cost flatter on one side than
its curvature says, e.g. near a fold of the branch), plus the discretization error.

Verdicts: ``success`` is False, with ``reason`` one line, when

* the fit leaves residuals above ``MAX_NOISE_RATIO`` (3) times the stated noise (sigma_hat / noise:
  the model, the clip poses or the data are inconsistent),
* two basins fit almost equally well: a second local minimum, at least 3 sd and 10 % in E away,
  whose cost exceeds the best by less than ``AMBIGUITY`` sigma^2 (9, a 3-sigma difference),
* E is at a bound with the cost still decreasing outward,
* the experiment is uninformative: sd(ln E) > ``max_log_sd`` (0.1),
* every simulation failed.

Warnings (``success`` True, ``warnings`` non-empty): residuals above ``WARN_NOISE_RATIO``
(1.5) times the noise, n raised for the curvature, a discretization error above
``MAX_DISCRETIZATION`` (10 %), a manipulation that does not reach the
measured branch, failed simulations skipped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..cable import Cable
from .distance import curve_residuals
from .experiment import Experiment, PreparedShapes, prepare_shapes
from .measured import MeasuredCurve, measured_curve
from .search import Minimum, Search
from .simulate import SIMULATORS, DynamicSettings, final_equilibrium, run_manipulation

DEFAULT_BOUNDS = (1e5, 1e10)
"""Default search range of E [Pa] (thesis 6.1)."""

MAX_LOG_SD = 0.1
"""Largest standard deviation of ln E of an informative experiment."""

DISCRETIZATION_COVER = 3.0
"""The interval's discretization term in units of |ln E(n) - ln E(2n)|: 2 to the first-order
extrapolate E(inf), and 1 more for the noise on it and the higher orders of a coarse n."""

MAX_NOISE_RATIO = 3.0
"""Largest residual sigma_hat / stated noise of a successful fit."""

WARN_NOISE_RATIO = 1.5
"""A residual sigma_hat / stated noise above this is warned about (a model or clip misfit)."""

AMBIGUITY = 9.0
"""Two basins are ambiguous when their costs differ by less than this many sigma^2."""

LINK_FRACTION = 0.25
"""Longest model link l as a fraction of the measured bend radius R: the largest angle [rad] the
measured shape may turn over one link's length (l / R)."""

MAX_LINKS = 200
"""Largest n the discretization check raises n to."""

MAX_DISCRETIZATION = 0.1
"""A discretization error of ln E above this is warned about."""

WARM_RADIUS = 0.7
"""Largest |ln E - ln E_previous| from which a run is warm-started (a factor 2 in E)."""

Z95 = 1.959963984540054
"""Two-sided 95 % quantile of the standard normal distribution."""


@dataclass(frozen=True)
class LocalMinimum:
    """One basin of the cost over E.

    Attributes
    ----------
    youngs_modulus : float
        E of its best sample [Pa].
    cost : float
        Its cost [m^2] (estimated from the scan when not ``refined``).
    refined : bool
        Gauss-Newton converged on it.
    at_bound : str
        ``""``, ``"E_min"`` or ``"E_max"``.
    """

    youngs_modulus: float
    cost: float
    refined: bool
    at_bound: str = ""


@dataclass(frozen=True, eq=False)
class Identification:
    """Result of :func:`identify_youngs_modulus` (the columns of thesis Table 7.1 and more).

    Attributes
    ----------
    success : bool
        A trustworthy modulus was found (module docstring: the verdicts).
    message : str
        What happened: the result, then every warning and note.
    youngs_modulus : float
        Identified E [Pa] for the ``bending`` model and ``n_links``; NaN unless ``success``.
    best_in_bounds : float
        E of the smallest cost simulated [Pa].
    confidence_interval : tuple of float
        95 % interval of E [Pa], statistical and discretization errors (NaN unless success).
    log_sd : float
        Statistical standard deviation of ln E [-].
    cost : float
        f at the solution [m^2].
    rms_error : float
        RMS distance of the measured points to the model's curve [m].
    max_error : float
        Largest such distance [m].
    optimality : float
        |df / d ln E| at the solution [m^2].
    iterations : int
        Simulations after the scan but the path check: the Gauss-Newton steps of every basin
        and the 2n fit.
    simulations : int
        Simulations (the scan, the steps, the 2n fit and the path check).
    solver_iterations : int
        Newton iterations (static) or time steps (dynamic) of all the simulations.
    at_bound : bool
        The best E is a bound with the cost still decreasing outward.
    informative : bool
        sd(ln E) <= the ``max_log_sd`` asked for.
    curve : numpy.ndarray
        (K, 2) samples (E [Pa], cost [m^2]) at n links, sorted by E (thesis Fig. 6.8).
    bounds : tuple of float
        (E_min, E_max) [Pa].
    measured_shape : numpy.ndarray
        (k, 3) the measured points, from the first clip's end [m].
    simulated_shape : numpy.ndarray
        (n + 1, 3) simulated final shape at the best E [m].
    cable : Cable
        The input cable with ``n_links`` and the identified modulus (input modulus when not
        ``success``).
    failed_simulations : int
        Simulations whose equilibria did not converge (left out of the search).
    reason : str
        One line saying why ``success`` is False ("" when it is True).
    warnings : tuple of str
        Warnings of a successful identification (each one line).
    n_links : int
        The discretization the modulus belongs to.
    minima : tuple of LocalMinimum
        Every basin found, best first.
    noise_ratio : float
        sigma_hat / stated noise [-].
    discretization_error : float
        2 |ln E(n) - ln E(2n)| [-] (NaN when not computed).
    min_bend_radius : float
        Smallest bend radius of the measurement at the scale of one link [m]
        (:meth:`~dloplan.identify.measured.MeasuredCurve.bend_radius`).
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
    reason: str = ""
    warnings: tuple[str, ...] = ()
    n_links: int = 0
    minima: tuple[LocalMinimum, ...] = ()
    noise_ratio: float = math.nan
    discretization_error: float = math.nan
    min_bend_radius: float = math.nan

    @property
    def bending(self) -> str:
        """The bending model the modulus belongs to."""
        return self.cable.bending

    def table(self) -> dict[str, float]:
        """The row of thesis Table 7.1, keyed by column name (units in brackets)."""
        return {
            "iterations": self.iterations,
            "simulations": self.simulations,
            "f(x) [m^2]": self.cost,
            "first-order optimality [m^2]": self.optimality,
            "E identified [Pa]": self.youngs_modulus,
        }


def _check_bounds(bounds) -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in bounds)
    except (TypeError, ValueError):
        raise ValueError(f"bounds: got {bounds!r}, expected (E_min, E_max) [Pa]") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise ValueError(f"bounds: got {bounds!r}, expected finite 0 < E_min < E_max [Pa]")
    return lo, hi


def links_for_curvature(cable: Cable, curve: MeasuredCurve) -> int:
    """Fewest links n (up to MAX_LINKS + 1) whose length the measured shape turns by at most
    ``LINK_FRACTION`` rad over (a link shorter than LINK_FRACTION times the bend radius)."""
    for n in range(3, MAX_LINKS + 1):
        if curve.turning(cable.length / n) <= LINK_FRACTION:
            return n
    return MAX_LINKS + 1


def _simulator(cable: Cable, experiment: Experiment, prepared: PreparedShapes, simulator: str,
               dynamic: DynamicSettings | None):
    """simulate(s, near) for :class:`~dloplan.identify.search.Search`."""
    manipulation = experiment.manipulation

    def simulate(s: float, near):
        trial = cable.with_modulus(math.exp(s))
        if simulator == "branch":
            guess = near.run.final if near is not None else prepared.guess
            run = final_equilibrium(trial, manipulation, guess)
            if not run.success:  # a guess too rough for a flat landscape: the manipulation
                path = run_manipulation(trial, manipulation, prepared.initial)
                run = replace(path, solver_iterations=path.solver_iterations
                              + run.solver_iterations)
        else:
            warm = near.run.shapes if near is not None and simulator == "static" else None
            run = run_manipulation(trial, manipulation, prepared.initial, simulator=simulator,
                                   warm_start=warm, dynamic=dynamic)
        fit = curve_residuals(prepared.measured, run.final, run.sensitivity) \
            if run.success else None
        return run, fit

    return simulate


@dataclass(frozen=True)
class _Settings:
    simulator: str
    dynamic: DynamicSettings | None
    xtol: float
    warm_radius: float
    noise: float


def _tolerance(settings: _Settings, sample) -> float:
    """Gauss-Newton stops below xtol or a tenth of the statistical sd of ln E."""
    j = math.sqrt(0.5 * sample.curvature) if sample.ok and sample.curvature > 0 else 0.0
    sd = settings.noise / j if j > 0 else math.inf
    return max(settings.xtol, 0.1 * min(sd, 1.0))


def _sigma(sample, noise: float) -> tuple[float, float]:
    """(sigma_hat per coordinate [m], sigma used [m]) at a sample."""
    dof = max(sample.fit.degrees_of_freedom - 1, 1)
    sigma_hat = math.sqrt(sample.cost / dof)
    return sigma_hat, max(sigma_hat, noise)


def identify_youngs_modulus(
    cable: Cable,
    experiment: Experiment,
    *,
    bounds=DEFAULT_BOUNDS,
    simulator: str = "branch",
    dynamic: DynamicSettings | None = None,
    xtol: float = 1e-3,
    max_simulations: int = 30,
    max_log_sd: float = MAX_LOG_SD,
    warm_start: bool = True,
    refine_links: bool = True,
    check_discretization: bool = True,
    check_path: bool = True,
) -> Identification:
    """Identify the Young's modulus that makes the model reproduce a measured shape (thesis 6.1).

    Parameters
    ----------
    cable : Cable
        The cable (length, diameter, mass, discretization, bending model, axial modulus); its
        own modulus is ignored. The identified E belongs to this ``bending`` model (``"thesis"``
        gives about a third of ``"rod"`` for the same data) and to the result's ``n_links``.
        With an ``axial_modulus`` the axial springs are held fixed and only bending is fitted.
    experiment : Experiment
        The manipulation and its measured final shape (any number of points).
    bounds : (float, float)
        (E_min, E_max) [Pa], 0 < E_min < E_max; default 1e5 to 1e10 (thesis 6.1).
    simulator : {"branch", "static", "dynamic"}
        The final equilibrium on the measured branch (default), the quasi-static manipulation,
        or the thesis' time stepping (module :mod:`dloplan.identify.simulate`).
    dynamic : DynamicSettings, optional
        Settings of the dynamic simulator.
    xtol : float
        Gauss-Newton stops when a step is below ``xtol`` in ln E (or below a tenth of sd(ln E)).
    max_simulations : int
        Simulation budget of the search at n (the scan included).
    max_log_sd : float
        The experiment is informative when sd(ln E) is at most this [-].
    warm_start : bool
        Start each refinement simulation from the sample at the nearest modulus.
    refine_links : bool
        Raise n when the links are too long for the measured curvature (step 1).
    check_discretization : bool
        Fit again at 2n and include the difference in the interval (step 3).
    check_path : bool
        Check that the manipulation reaches the measured branch (step 4, ``"branch"`` only).

    Returns
    -------
    Identification

    Raises
    ------
    ValueError
        Bad bounds or settings, a measured shape whose length is not the cable's (with a hint
        when it looks like millimetres), or whose ends are far from the final clips.
    """
    lo, hi = _check_bounds(bounds)
    if simulator not in SIMULATORS:
        raise ValueError(f"simulator: got {simulator!r}, expected one of {', '.join(SIMULATORS)}")
    if simulator == "dynamic" and experiment.manipulation.held != "both":
        raise ValueError("simulator: 'dynamic' needs held='both' (the thesis' two-clip setup); "
                         "use 'branch' or 'static' for a cantilever experiment")
    for name, value in (("xtol", xtol), ("max_log_sd", max_log_sd)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}: got {value!r}, expected a number > 0")
    s_lo, s_hi = math.log(lo), math.log(hi)
    n_grid = max(3, math.ceil((s_hi - s_lo) / math.log(10.0) - 1e-9) + 1)
    if int(max_simulations) != max_simulations or max_simulations < n_grid + 1:
        raise ValueError(
            f"max_simulations: got {max_simulations!r}, expected an integer >= {n_grid + 1} "
            f"(the {n_grid}-point scan over the bounds and one step)")
    noise = experiment.measurement_noise
    curve = measured_curve(experiment.measured_shape, noise)
    notes: list[str] = []
    n_fit = cable.n_links
    needed = links_for_curvature(cable, curve)
    if needed > n_fit:
        link = 1e3 * cable.rest_link_length
        radius = 1e3 * curve.bend_radius(cable.rest_link_length)
        if refine_links:
            n_fit = min(needed, MAX_LINKS)
            notes.append(f"n = {cable.n_links} is too coarse for the measured curvature ({link:.0f}"
                         f" mm links, smallest bend radius {radius:.0f} mm): identified with "
                         f"n = {n_fit}; plan with n = {n_fit}")
        else:
            notes.append(f"n = {cable.n_links} is too coarse for the measured curvature ({link:.0f}"
                         f" mm links > {LINK_FRACTION:g} x the smallest bend radius {radius:.0f} "
                         f"mm): the modulus is biased; use n >= {needed}")
    fit_cable = cable.with_links(n_fit)
    settings = _Settings(simulator, dynamic, xtol, WARM_RADIUS if warm_start else -1.0, noise)
    prepared = prepare_shapes(fit_cable, experiment, curve)
    search = Search(_simulator(fit_cable, experiment, prepared, simulator, dynamic),
                    (s_lo, s_hi), int(max_simulations), settings.warm_radius)
    search.scan(n_grid)

    def compete(estimate: float, best_cost: float) -> bool:
        return estimate - best_cost < AMBIGUITY * max(noise**2, best_cost / prepared.measured.size)

    good = search.good
    minima = []
    if good:
        minima = search.minima(_tolerance(settings, min(good, key=lambda p: p.cost)), compete)
    return _conclude(fit_cable, experiment, prepared, search, minima, settings, (lo, hi),
                     max_log_sd, notes, check_discretization, check_path and simulator == "branch",
                     n_grid)


def _second_fit(cable: Cable, experiment: Experiment, best, settings: _Settings,
                s_bounds) -> tuple[float, Search]:
    """ln E fitted with 2n links by Gauss-Newton from the best s (NaN if it fails)."""
    fine = cable.with_links(2 * cable.n_links)
    prepared = prepare_shapes(fine, experiment)
    s0 = best.sample.s
    window = (max(s_bounds[0], s0 - 1.5), min(s_bounds[1], s0 + 1.5))
    search = Search(_simulator(fine, experiment, prepared, settings.simulator, settings.dynamic),
                    window, 6, settings.warm_radius)
    start = search.evaluate(s0, warm=False)
    if not start.ok:
        return math.nan, search
    tol = _tolerance(settings, start)
    found = search.refine(None, start, tol) if start.slope > 0 else search.refine(start, None, tol)
    return found.s, search


def _conclude(cable, experiment, prepared, search, minima: list[Minimum], settings, bounds,
              max_log_sd, notes, check_discretization, check_path, n_grid) -> Identification:
    lo, hi = bounds
    good = search.good
    failed = len(search.samples) - len(good)
    curve = np.array([[math.exp(p.s), p.cost] for p in good]).reshape(-1, 2)
    noise = settings.noise
    all_searches = [search]
    common = dict(bounds=(lo, hi), measured_shape=prepared.measured, curve=curve,
                  n_links=cable.n_links,
                  min_bend_radius=prepared.curve.bend_radius(cable.rest_link_length),
                  minima=tuple(LocalMinimum(m.youngs_modulus, m.estimated_cost, m.refined,
                                            m.at_bound) for m in minima))
    if not good:
        first = search.samples[0].run.message
        return Identification(
            success=False, message=f"every simulation failed (first: {first})",
            reason=f"every simulation failed (first: {first})",
            youngs_modulus=math.nan, best_in_bounds=math.nan,
            confidence_interval=(math.nan, math.nan), log_sd=math.nan, cost=math.nan,
            rms_error=math.nan, max_error=math.nan, optimality=math.nan, at_bound=False,
            informative=False, simulated_shape=np.full((cable.n_points, 3), np.nan),
            cable=cable, simulations=len(search.samples), iterations=0,
            failed_simulations=failed,
            solver_iterations=sum(p.run.solver_iterations for p in search.samples), **common)
    best = minima[0]
    sample = best.sample
    e_best = math.exp(sample.s)
    sigma_hat, sigma = _sigma(sample, noise)
    j_norm = math.sqrt(0.5 * sample.curvature)
    log_sd = sigma / j_norm if j_norm > 0 else math.inf
    informative = log_sd <= max_log_sd
    distances = np.linalg.norm(sample.fit.residuals, axis=1)
    reasons: list[str] = []
    warnings: list[str] = list(notes)
    if not informative:  # a flat cost: the root cause of any other verdict
        reasons.append(
            f"the experiment is not informative: sd(ln E) = {log_sd:.3g} > {max_log_sd:g} "
            "(a flat cost: bend the cable more under gravity, see dloplan identify --design)")
    if best.at_bound:
        reasons.append(
            f"no modulus in [{lo:.3g}, {hi:.3g}] Pa explains the data: the cost still "
            f"decreases beyond {best.at_bound} = {e_best:.3g} Pa; widen the bounds or check the "
            "experiment")
    ratio = sigma_hat / noise
    if ratio > MAX_NOISE_RATIO:
        reasons.append(
            f"poor fit: the residuals are {ratio:.1f} times the stated noise of "
            f"{1e3 * noise:g} mm (RMS distance {1e3 * float(np.sqrt(np.mean(distances**2))):.1f}"
            " mm): the model, the clip poses or the data are inconsistent")
    elif ratio > WARN_NOISE_RATIO:
        warnings.append(f"the residuals are {ratio:.1f} times the stated noise: the model (its "
                        "discretization, bending model), the clip poses or the noise figure "
                        "do not quite match the data")
    for other in minima[1:]:
        apart = abs(math.log(other.youngs_modulus) - sample.s)
        if (other.estimated_cost - sample.cost < AMBIGUITY * sigma**2
                and apart > max(3 * log_sd, 0.1)):
            reasons.append(
                f"ambiguous: two basins fit almost equally well, E = {e_best:.3g} Pa "
                f"(cost {sample.cost:.3g} m^2) and E = {other.youngs_modulus:.3g} Pa (cost "
                f"{other.estimated_cost:.3g} m^2); use a more informative experiment")
            break
    disc = math.nan
    if check_discretization and not reasons:
        s_fine, fine_search = _second_fit(cable, experiment, best, settings, (math.log(lo),
                                                                              math.log(hi)))
        all_searches.append(fine_search)
        if math.isfinite(s_fine):
            disc = DISCRETIZATION_COVER * abs(s_fine - sample.s)
            if disc > MAX_DISCRETIZATION:
                warnings.append(
                    f"discretization error: E with {2 * cable.n_links} links is "
                    f"{math.exp(s_fine) / e_best:.3g} times E with {cable.n_links}; the interval "
                    "includes it (identify with more links to narrow it)")
        else:
            warnings.append(f"the check with {2 * cable.n_links} links failed; the interval "
                            "leaves out the discretization error")
    path_runs = []
    if check_path and not reasons:
        run = run_manipulation(cable.with_modulus(e_best), experiment.manipulation,
                               prepared.initial)
        path_runs.append(run)
        gap = float(np.max(np.linalg.norm(run.final - sample.run.final, axis=1))) \
            if run.success else math.inf
        if gap > max(5 * noise, 0.01 * cable.length):
            warnings.append(
                f"the simulated manipulation does not reach the measured shape at E = "
                f"{e_best:.3g} Pa (its final shape is {1e3 * gap:.0f} mm away): the measured "
                "shape is an equilibrium of the model, on a branch this manipulation misses")
    if failed:
        warnings.append(f"{failed} of {len(search.samples)} simulations failed and were skipped")
    if prepared.reversed:
        warnings.append("the measured points ran from the last clip to the first and were "
                        "reversed")
    runs = [p.run for s in all_searches for p in s.samples] + path_runs
    counts = dict(simulations=len(runs), iterations=len(runs) - len(path_runs) - n_grid,
                  failed_simulations=failed,
                  solver_iterations=sum(r.solver_iterations for r in runs))
    success = not reasons
    if success:
        # the linearized half-width, widened to every sampled E the data cannot reject
        # (a cost rising more slowly than its curvature predicts), plus the discretization
        indistinct = [abs(p.s - sample.s) for p in good
                      if p.cost - sample.cost < Z95**2 * sigma**2]
        half = max([Z95 * log_sd, *indistinct]) + (disc if math.isfinite(disc) else 0.0)
        interval = (e_best * math.exp(-half), e_best * math.exp(half))
        extra = ", including the discretization error" if math.isfinite(disc) else ""
        head = (f"identified E = {e_best:.4g} Pa (95 % interval {interval[0]:.4g} to "
                f"{interval[1]:.4g} Pa{extra}; {cable.bending} bending model, n = "
                f"{cable.n_links}) in {counts['simulations']} simulations")
        e_out, out_cable = e_best, cable.with_modulus(e_best)
    else:
        head = reasons[0]
        interval, e_out, out_cable = (math.nan, math.nan), math.nan, cable
    found = []
    if len(minima) > 1:  # information (result.minima), not a warning: the verdicts judged them
        found.append("local minima: " + ", ".join(
            f"E = {m.youngs_modulus:.3g} Pa (cost {m.estimated_cost:.3g} m^2"
            f"{'' if m.refined else ', estimated'})" for m in minima))
    return Identification(
        success=success, message="; ".join([head, *reasons[1:], *warnings, *found]),
        reason=reasons[0] if reasons else "", warnings=tuple(warnings) if success else (),
        youngs_modulus=e_out, best_in_bounds=e_best, confidence_interval=interval,
        log_sd=float(log_sd), cost=sample.cost,
        rms_error=float(np.sqrt(np.mean(distances**2))), max_error=float(distances.max()),
        optimality=abs(sample.slope), at_bound=bool(best.at_bound),
        informative=bool(informative), simulated_shape=sample.run.final, cable=out_cable,
        noise_ratio=float(ratio), discretization_error=float(disc), **counts, **common)
