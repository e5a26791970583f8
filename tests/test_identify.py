"""Young's modulus identification (thesis 6.1, Table 7.1; issue 19): the parts and the whole.

Synthetic experiments are made with the model itself, at a discretization fine enough for the
shape (the n the identification's own curvature check asks for, so the data are a cable's
shape, not a coarse polyline's), with 1 mm Gaussian noise per coordinate on 300 points along
the shape (a registered image, not markers on the model's points). Seeds are fixed; every
tolerance is stated against the predicted standard deviation it allows.
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import cache

import numpy as np
import pytest

from dloplan.app.identification import (
    dump_identification,
    experiment_to_dict,
    load_identification,
    parse_identification,
)
from dloplan.cable import catalogue_cable
from dloplan.geometry import arc_length, resample_by_arc_length
from dloplan.identify import (
    DynamicSettings,
    Experiment,
    Manipulation,
    assess_manipulation,
    bending_manipulation,
    cantilever_manipulation,
    identify_youngs_modulus,
    modulus_sensitivity,
    prepare_shapes,
    run_manipulation,
    synthetic_experiment,
)
from dloplan.identify.distance import curve_residuals
from dloplan.identify.experiment import initial_on
from dloplan.identify.fit import links_for_curvature
from dloplan.identify.measured import measured_curve, point_scatter
from dloplan.identify.report import FAILURE, OK, WARNINGS, exit_code, plan_warnings
from dloplan.identify.search import Sample, Search
from dloplan.identify.tuning_loop import thesis_equivalent_modulus, tune_for_identified
from dloplan.io.scenario import ScenarioError
from dloplan.planning.tuning import stiffness_family
from dloplan.shapes import discretize

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_identify")

DESIGNS = {
    "two-clip": bending_manipulation,  # thesis Fig. 6.3: clips to 0.15 m, tilted up 90 deg
    "cantilever": cantilever_manipulation,
}


def run_of(cable, manipulation):
    return run_manipulation(cable, manipulation, initial_on(cable, manipulation))


@cache
def data_links(name: str, design: str, model: str) -> int:
    """The n the shape needs (its own curvature check), so the data resolve the cable's bends."""
    cable = _cable(name, 64, model)
    run = run_of(cable, DESIGNS[design](cable))
    return max(16, links_for_curvature(cable, measured_curve(run.final, 1e-5)) + 2)


def _cable(name: str, n: int, model: str):
    cable = catalogue_cable(name, n_links=n)
    return cable.thesis_model() if model == "thesis" else cable


@cache
def case(name: str, design: str, model: str, seed: int = 7, points: int = 300):
    cable = _cable(name, data_links(name, design, model), model)
    manipulation = DESIGNS[design](cable)
    return cable, synthetic_experiment(cable, manipulation, noise=1e-3, n_measured=points,
                                       seed=seed)


# -- the sensitivity (the fit's Jacobian) ------------------------------------------------------
@pytest.mark.parametrize("name,design,axial", [("usb", "two-clip", None),
                                               ("pa12", "cantilever", None),
                                               ("usb", "two-clip", 2e9)])
def test_sensitivity_matches_finite_differences(name, design, axial):
    # d xi / d ln E from one sparse solve vs a central difference of two full simulations; the
    # difference step h = 1e-4 in ln E gives an O(h^2) truncation far below the 1e-4 asked.
    # With an axial modulus of its own only the bending springs scale with E.
    cable = catalogue_cable(name, n_links=20, axial_modulus=axial)
    manipulation = DESIGNS[design](cable)
    run = run_of(cable, manipulation)
    assert run.success
    h = 1e-4
    up, down = (run_manipulation(cable.with_modulus(cable.youngs_modulus * math.exp(d)),
                                 manipulation, initial_on(cable, manipulation),
                                 warm_start=run.shapes).final
                for d in (h, -h))
    fd = (up - down) / (2 * h)
    assert np.linalg.norm(fd) > 1e-3  # the comparison is not between two zeros
    assert np.linalg.norm(run.sensitivity - fd) <= 1e-4 * np.linalg.norm(fd)
    assert np.all(run.sensitivity[[0, 1]] == 0.0)  # held points do not move


def test_sensitivity_sign_of_a_cantilever():
    # a stiffer cantilever sags less: d z_tip / d ln E > 0, and equals the sag to first order
    # for a small, linear deflection (z_tip ~ z_clip - c / E)
    cable = catalogue_cable("pa12", n_links=12)
    final = run_of(cable, cantilever_manipulation(cable)).final
    dz = modulus_sensitivity(cable, final, "first")[-1, 2]
    sag = 0.3 - final[-1, 2]
    assert dz > 0
    assert dz == pytest.approx(sag, rel=0.05)  # geometric nonlinearity of a 5 % sag


def test_warm_start_gives_the_same_equilibria_with_fewer_iterations():
    cable = catalogue_cable("usb", n_links=24)
    manipulation = bending_manipulation(cable, clip_distance=0.3, angle=30.0)
    initial = initial_on(cable, manipulation)
    near = run_manipulation(cable.with_modulus(2.2e6), manipulation, initial)
    cold = run_manipulation(cable, manipulation, initial)
    warm = run_manipulation(cable, manipulation, initial, warm_start=near.shapes)
    assert np.abs(warm.final - cold.final).max() < 1e-9
    assert warm.solver_iterations < cold.solver_iterations


# -- the cost: distances to the model's curve ---------------------------------------------------
def test_curve_residuals_and_their_derivative():
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 21)
    model = np.stack([t, 0.1 * np.sin(3 * t), 0.05 * t**2], axis=1)
    jac = rng.normal(0.0, 0.01, model.shape)
    points = resample_by_arc_length(model, 57) + rng.normal(0.0, 0.002, (57, 3))
    fit = curve_residuals(points, model, jac)
    # each residual is the shortest vector to the polyline (checked on a fine resampling)
    fine = resample_by_arc_length(model, 20001)
    nearest = np.min(np.linalg.norm(points[:, None] - fine[None], axis=2), axis=1)
    assert np.allclose(np.linalg.norm(fit.residuals, axis=1), nearest, atol=1e-4)
    # the exact slope against a central difference of the cost under x + h J
    h = 1e-6
    costs = [curve_residuals(points, model + d * jac).cost for d in (h, -h)]
    assert fit.slope == pytest.approx((costs[0] - costs[1]) / (2 * h), rel=1e-5)


def test_noise_along_the_curve_does_not_bias_the_distance():
    # 300 noisy points along an arc of radius 0.2 m: the mean signed radial residual is within
    # sigma^2 / R (0.005 mm) + 3 standard errors (0.17 mm) of zero; the raw polyline is 30 %
    # longer, the smoothed curve within 0.5 % of the true length
    rng = np.random.default_rng(5)
    angle = np.linspace(0.0, 2.5, 300)
    arc = 0.2 * np.stack([np.cos(angle), np.zeros_like(angle), np.sin(angle)], axis=1)
    noisy = arc + rng.normal(0.0, 1e-3, arc.shape)
    model = resample_by_arc_length(arc, 400)
    fit = curve_residuals(noisy, model)
    outward = noisy / np.linalg.norm(noisy, axis=1)[:, None]  # the arc's centre is the origin
    radial = np.einsum("ij,ij->i", fit.residuals, outward)
    assert abs(radial.mean()) < 0.2e-3
    assert arc_length(noisy)[-1] > 1.2 * 0.5
    assert measured_curve(noisy, 1e-3).length == pytest.approx(0.5, rel=5e-3)


def test_turning_of_a_measured_arc_reads_its_radius():
    angle = np.linspace(0.0, 2.0, 500)
    arc = 0.1 * np.stack([np.cos(angle), np.zeros_like(angle), np.sin(angle)], axis=1)
    curve = measured_curve(arc, 1e-5)
    # w / R, within the +-4 % curvature ripple of a cubic smoothing spline (enough to choose n)
    assert curve.turning(0.02) == pytest.approx(0.2, rel=0.05)
    assert curve.bend_radius(0.02) == pytest.approx(0.1, rel=0.05)


# -- the search: every basin ------------------------------------------------------------------
def test_search_finds_and_refines_both_basins_of_a_two_well_cost():
    # a made-up residual r(s) = (s - 1)(s - 4) / 4 in one coordinate: minima at s = 1 and 4
    class Fit:
        def __init__(self, s):
            r, dr = (s - 1) * (s - 4) / 4, (2 * s - 5) / 4
            self.cost, self.slope, self.curvature = r * r, 2 * r * dr, 2 * dr * dr

    search = Search(lambda s, near: (None, Fit(s)), (-2.0, 7.0), 40)
    search.scan(8)  # samples off the minima: the slopes bracket them
    found = search.minima(1e-6, lambda estimate, best: True)
    assert sorted(round(m.sample.s, 4) for m in found) == [1.0, 4.0]
    assert all(m.refined and m.sample.cost < 1e-12 for m in found)
    assert all(isinstance(p, Sample) for p in search.samples)


# -- recovering the catalogue moduli from model-made data ---------------------------------------
RECOVERABLE = [(name, design, model) for name in ("usb", "ethernet", "pu", "pa12")
               for design in DESIGNS for model in ("rod", "thesis")
               if not (design == "two-clip" and name in ("pu", "pa12"))]


@pytest.mark.parametrize("name,design,model", RECOVERABLE)
def test_recovers_the_modulus_of_model_made_data(name, design, model):
    cable, experiment = case(name, design, model)
    truth = cable.youngs_modulus
    result = identify_youngs_modulus(cable.with_modulus(1e7), experiment)
    assert result.success, result.message
    lo, hi = result.confidence_interval
    assert lo <= truth <= hi
    # within 3 %, or within the interval's half-width where the design cannot do better (the
    # thesis-model Ethernet on the thesis' bend: sd(ln E) ~ 0.09, a 35 % discretization error)
    half = 0.5 * math.log(hi / lo)
    assert abs(math.log(result.youngs_modulus / truth)) <= max(0.03, half)
    assert result.n_links >= cable.n_links and result.bending == cable.bending
    assert result.noise_ratio < 1.5  # the residual is the noise
    assert result.cable.youngs_modulus == result.youngs_modulus
    assert np.all(np.diff(result.curve[:, 0]) > 0)
    assert result.simulations <= 14  # the thesis needed 42-46; the benchmark prints them


@pytest.mark.parametrize("name", ["pu", "pa12"])
def test_a_stiff_hose_between_two_clips_is_refused_as_uninformative(name):
    # clamped at both ends a hose barely sags (thesis design): the cost is flat in E
    cable = catalogue_cable(name, n_links=32)
    manipulation = bending_manipulation(cable)
    assert not assess_manipulation(cable, manipulation).informative
    result = identify_youngs_modulus(cable, synthetic_experiment(cable, manipulation, seed=2,
                                                                 n_measured=300))
    assert not result.success and not result.informative
    assert "not informative" in result.message  # the reason may be the bound it drifts to
    assert math.isnan(result.youngs_modulus) and exit_code(result) == FAILURE


def test_dense_points_give_the_marker_fit_modulus():
    # 300 noisy points vs one noisy marker per model point along the same shape: the dense
    # fit's E lies inside the marker fit's interval (and vice versa the truth in both)
    cable, _ = case("ethernet", "cantilever", "rod")
    manipulation = cantilever_manipulation(cable)
    markers = synthetic_experiment(cable, manipulation, noise=1e-3, n_measured=cable.n_points,
                                   seed=4)
    dense = synthetic_experiment(cable, manipulation, noise=1e-3, n_measured=300, seed=4)
    by_markers = identify_youngs_modulus(cable, markers)
    by_points = identify_youngs_modulus(cable, dense)
    lo, hi = by_markers.confidence_interval
    assert by_markers.success and by_points.success
    assert lo <= by_points.youngs_modulus <= hi
    assert by_points.log_sd < by_markers.log_sd  # more points, smaller statistical error


# -- deliberately wrong models: never a silent wrong value -------------------------------------
def test_the_other_bending_model_gives_its_equivalent_modulus_and_a_plan_warning():
    # rod data fitted with k_b = 3EI/l: the same bending stiffness needs a third of E, which is
    # the right modulus *of that model* (a shape cannot tell k_b = 3 E I / l from E I / l);
    # planning with the rod model and that E is the mistake, and it is warned about
    cable, experiment = case("ethernet", "cantilever", "rod")
    thesis = identify_youngs_modulus(replace(cable, bending="thesis"), experiment)
    assert thesis.success
    assert thesis.youngs_modulus == pytest.approx(cable.youngs_modulus / 3, rel=0.03)
    assert thesis_equivalent_modulus(thesis.cable) == pytest.approx(thesis.youngs_modulus)
    warnings = plan_warnings(thesis, cable.with_modulus(thesis.youngs_modulus))
    assert any("bending model" in w for w in warnings)
    assert plan_warnings(thesis, thesis.cable) == []


def test_a_five_times_coarser_model_is_flagged_or_corrected():
    cable, experiment = case("ethernet", "cantilever", "rod")
    coarse = cable.with_links(max(3, cable.n_links // 5))
    truth = cable.youngs_modulus
    kept = identify_youngs_modulus(coarse, experiment, refine_links=False)
    # n kept coarse on request: a warning names it, or the fit is refused
    assert (not kept.success) or any("too coarse" in w for w in kept.warnings)
    assert exit_code(kept) in (WARNINGS, FAILURE)
    refined = identify_youngs_modulus(coarse, experiment)  # the default raises n
    assert refined.n_links > coarse.n_links
    assert any("too coarse" in w for w in refined.warnings)
    lo, hi = refined.confidence_interval
    assert lo <= truth <= hi
    assert any("plan with it" in w or "n = " in w
               for w in plan_warnings(refined, coarse.with_modulus(refined.youngs_modulus)))


def test_clips_that_do_not_match_the_data_give_a_poor_fit_verdict():
    cable, experiment = case("ethernet", "cantilever", "rod")
    manipulation = experiment.manipulation
    tilted = cantilever_manipulation(cable, angle=20.0)  # data made level
    wrong = Experiment(Manipulation(manipulation.initial_shape, tilted.clips, held="first"),
                       experiment.measured_shape, measurement_noise=1e-3)
    result = identify_youngs_modulus(cable, wrong)
    assert exit_code(result) != OK
    if result.success:
        assert any("times the stated noise" in w for w in result.warnings)
    else:
        assert "\n" not in result.reason


def test_two_basins_that_fit_equally_well_are_refused(small_case, monkeypatch):
    # a made-up model whose shape moves sideways by a(s) = (s - s1)(s - s2) mm: it matches
    # the data at two moduli 2.4 decades apart (the scan samples both basins' slopes),
    # equally well; the identification must say so
    from dloplan.identify import ManipulationRun
    from dloplan.identify import fit as fit_module

    cable, manipulation, experiment = small_case
    base = run_of(cable, manipulation).final
    side = np.array([0.0, 1.0, 0.0])
    s1, s2 = math.log(2e6), math.log(5e8)

    def fake_simulator(cable, experiment, prepared, simulator, dynamic):
        def simulate(s, near):
            shape = base + 1e-3 * (s - s1) * (s - s2) * side
            sensitivity = np.tile(1e-3 * (2 * s - s1 - s2) * side, (len(base), 1))
            run = ManipulationRun(math.exp(s), shape[None], sensitivity, True, "ok", 1)
            return run, curve_residuals(prepared.measured, shape, sensitivity)
        return simulate

    monkeypatch.setattr(fit_module, "_simulator", fake_simulator)
    result = identify_youngs_modulus(cable, experiment, refine_links=False)
    found = sorted(m.youngs_modulus for m in result.minima if m.refined)
    assert found == pytest.approx([2e6, 5e8], rel=0.02)
    assert not result.success and result.reason.startswith("ambiguous")
    assert exit_code(result) == FAILURE


# -- the regression cases --------------------------------------------------------------
def test_thesis_design_usb_data_is_not_silently_misidentified():
    # issue 19: the thesis-model USB on the thesis' dual-arm bend, n = 16, noise-free, used
    # to give E = 9.5e5 Pa with success=True (a branch jump between grid points)
    cable = catalogue_cable("usb", n_links=16).thesis_model()
    experiment = synthetic_experiment(cable, bending_manipulation(cable), noise=0.0)
    default = identify_youngs_modulus(cable.with_modulus(1e7), experiment)
    if default.success:
        lo, hi = default.confidence_interval
        assert lo <= 2.5e6 <= hi
    # kept at n = 16 the branch-aware fit finds the right basin, and warns about n
    kept = identify_youngs_modulus(cable.with_modulus(1e7), experiment, refine_links=False)
    assert kept.success, kept.message
    assert kept.youngs_modulus == pytest.approx(2.5e6, rel=0.03)
    assert any("too coarse" in w for w in kept.warnings)
    assert exit_code(kept) == WARNINGS


def test_thesis_design_pa12_is_refused_not_misidentified():
    # issue 19: 2.9e7 Pa instead of 1e9, reported as a success
    cable = catalogue_cable("pa12", n_links=16).thesis_model()
    experiment = synthetic_experiment(cable, bending_manipulation(cable), noise=0.0)
    result = identify_youngs_modulus(cable, experiment)
    assert not result.success
    assert not (result.youngs_modulus < 5e8)  # NaN: no modulus reported


# -- flags: bounds -----------------------------------------------------------------------------
def test_a_modulus_beyond_the_upper_bound_is_flagged_not_reported():
    cable = catalogue_cable("pa12", n_links=12, youngs_modulus=3e10)
    experiment = synthetic_experiment(cable, cantilever_manipulation(cable), seed=1,
                                      n_measured=300)
    result = identify_youngs_modulus(cable, experiment, bounds=(1e8, 1e10))
    assert result.at_bound and not result.success
    assert math.isnan(result.youngs_modulus)
    assert result.best_in_bounds == pytest.approx(1e10)
    assert "E_max" in result.message and "widen the bounds" in result.message
    with pytest.raises(ValueError, match="not successful"):
        tune_for_identified(result)


def test_a_modulus_below_the_lower_bound_is_flagged():
    cable, experiment = case("ethernet", "cantilever", "rod")
    result = identify_youngs_modulus(cable, experiment, bounds=(3e7, 1e10))
    assert result.at_bound and not result.success and "E_min" in result.reason
    assert result.best_in_bounds == pytest.approx(3e7)


# -- bad input ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def small_case():
    cable = catalogue_cable("pu", n_links=16)
    manipulation = cantilever_manipulation(cable)
    return cable, manipulation, synthetic_experiment(cable, manipulation, seed=3)


def test_a_shape_in_millimetres_is_detected(small_case):
    cable, manipulation, experiment = small_case
    in_mm = Experiment(manipulation, experiment.measured_shape * 1000.0)
    with pytest.raises(ValueError, match=r"measured_shape: .*millimetres"):
        identify_youngs_modulus(cable, in_mm)


def test_a_shape_of_the_wrong_length_is_refused(small_case):
    cable, manipulation, experiment = small_case
    longer = Experiment(manipulation, experiment.measured_shape * 1.3)
    with pytest.raises(ValueError, match=r"measured_shape: the shape is .* long but the cable"):
        identify_youngs_modulus(cable, longer)


def test_a_shape_far_from_the_clips_is_refused(small_case):
    cable, manipulation, experiment = small_case
    moved = Experiment(manipulation, experiment.measured_shape + [0.0, 0.2, 0.0])
    with pytest.raises(ValueError, match="world frame"):
        identify_youngs_modulus(cable, moved)


def test_reversed_measured_points_are_reoriented(small_case):
    cable, manipulation, experiment = small_case
    flipped = Experiment(manipulation, experiment.measured_shape[::-1])
    assert prepare_shapes(cable, flipped).reversed
    straight = identify_youngs_modulus(cable, experiment)
    result = identify_youngs_modulus(cable, flipped)
    assert any("reversed" in w for w in result.warnings)
    assert result.youngs_modulus == pytest.approx(straight.youngs_modulus, rel=1e-6)


@pytest.mark.parametrize("bounds", [(0.0, 1e9), (1e9, 1e8), (-1e6, 1e7), (math.nan, 1e8),
                                    (1e6,), "wide"])
def test_bad_bounds_are_refused(small_case, bounds):
    cable, _, experiment = small_case
    with pytest.raises(ValueError, match="bounds"):
        identify_youngs_modulus(cable, experiment, bounds=bounds)


def test_bad_settings_are_refused(small_case):
    cable, manipulation, experiment = small_case
    with pytest.raises(ValueError, match="simulator"):
        identify_youngs_modulus(cable, experiment, simulator="euler")
    with pytest.raises(ValueError, match="max_simulations"):
        identify_youngs_modulus(cable, experiment, max_simulations=3)
    with pytest.raises(ValueError, match="held"):
        Manipulation(manipulation.initial_shape, manipulation.clips, held="none")
    with pytest.raises(ValueError, match="clips"):
        Manipulation(manipulation.initial_shape, [])
    with pytest.raises(ValueError, match="measurement_noise"):
        Experiment(manipulation, experiment.measured_shape, measurement_noise=-1.0)
    with pytest.raises(ValueError, match="measured_shape"):
        Experiment(manipulation, [[0.0, 0.0, 0.0], [np.nan, 0.0, 0.0]])
    with pytest.raises(ValueError, match="youngs_modulus_cap"):
        DynamicSettings(youngs_modulus_cap=-1.0)


# -- the other simulators ----------------------------------------------------------------------
def test_the_quasi_static_path_simulator_identifies_the_same_modulus(small_case):
    cable, _, experiment = small_case
    branch = identify_youngs_modulus(cable, experiment)
    path = identify_youngs_modulus(cable, experiment, simulator="static")
    assert path.success and branch.success
    assert path.youngs_modulus == pytest.approx(branch.youngs_modulus, rel=1e-3)


def test_dynamic_simulator_identifies_the_same_modulus():
    # the thesis' time stepping, with its time step from a capped modulus; it settles to the
    # static equilibrium (rest speed 1 mm/s: a few hundredths of a mm away) and so gives the
    # same E within 1 %
    cable = catalogue_cable("usb", n_links=8)
    manipulation = bending_manipulation(cable, clip_distance=0.15, angle=60.0, steps=2)
    experiment = synthetic_experiment(cable, manipulation, noise=0.0)
    settings = DynamicSettings(max_settle=30.0, rest_speed=1e-3, youngs_modulus_cap=1e6)
    result = identify_youngs_modulus(cable, experiment, bounds=(1.5e6, 4e6),
                                     simulator="dynamic", dynamic=settings,
                                     refine_links=False, check_discretization=False)
    assert result.best_in_bounds == pytest.approx(2.5e6, rel=0.01)


def test_dynamic_divergence_is_reported_not_hidden():
    # a cap 1e4 times below E: a time step 100 times too long for the explicit scheme
    cable = catalogue_cable("pu", n_links=8)
    manipulation = bending_manipulation(cable, clip_distance=0.3, angle=30.0, steps=1)
    run = run_manipulation(cable, manipulation, initial_on(cable, manipulation),
                           simulator="dynamic",
                           dynamic=DynamicSettings(youngs_modulus_cap=1e4, max_settle=1.0))
    assert not run.success and "diverged" in run.message


# -- files, example, tuning loop ----------------------------------------------------------------
def test_file_round_trip_in_millimetres(small_case, tmp_path):
    cable, _, experiment = small_case
    data = experiment_to_dict(experiment, {"name": "pu", "n_links": 16,
                                           "youngs_modulus": "identify"},
                              bounds=(1e6, 1e10), units="mm")
    path = tmp_path / "pu.yaml"
    path.write_text(dump_identification(data))
    job = load_identification(path)
    assert job.bounds == (1e6, 1e10) and job.cable.n_links == 16
    assert job.simulator == "branch"
    assert job.experiment.measurement_noise == pytest.approx(1e-3)
    assert np.allclose(job.experiment.measured_shape, experiment.measured_shape, atol=1e-9)
    direct = identify_youngs_modulus(cable, experiment, bounds=(1e6, 1e10))
    loaded = identify_youngs_modulus(job.cable, job.experiment, bounds=job.bounds)
    assert loaded.youngs_modulus == pytest.approx(direct.youngs_modulus, rel=1e-6)


def test_the_example_file_identifies_the_ethernet_cable():
    from pathlib import Path

    job = load_identification(Path(__file__).parents[1] / "examples" / "identify_ethernet.yaml")
    result = identify_youngs_modulus(job.cable, job.experiment, bounds=job.bounds)
    assert result.success and result.youngs_modulus == pytest.approx(7.5e6, rel=0.05)
    lo, hi = result.confidence_interval
    assert lo <= 7.5e6 <= hi
    assert exit_code(result) in (OK, WARNINGS)


@pytest.mark.parametrize("change,match", [
    (lambda d: d["identify"].update(bounds=[1e9, 1e6]), "identify: bounds must be"),
    (lambda d: d["identify"]["trajectory"][0]["first"].update(u=[1, 0, 0]), "exactly one"),
    (lambda d: d["identify"].pop("measured_shape"), "exactly one of measured_shape"),
    (lambda d: d["identify"].update(measured_file={"path": "x.csv"}),
     "exactly one of measured_shape"),
    (lambda d: d.pop("identify"), "no identify section"),
    (lambda d: d["identify"].update(held="second"), "identify.held"),
    (lambda d: d["identify"].update(simulator="euler"), "identify.simulator"),
    # the unseen-case sweep's identification in metres with the example's noise of 1.0 (mm)
    # kept: it was refused later as a shape 5 % short of the cable, the smoothing's doing
    (lambda d: d["identify"].update(measurement_noise=1.0),
     r"identify.measurement_noise: 1 m, expected less than 0.1 of the cable's 0.5 m"),
])
def test_bad_files_give_one_line_errors(small_case, change, match):
    _, _, experiment = small_case
    data = experiment_to_dict(experiment, {"name": "pu", "youngs_modulus": "identify"})
    change(data)
    with pytest.raises(ScenarioError, match=match) as info:
        parse_identification(data, "bad.yaml")
    assert "\n" not in str(info.value)


def test_tuning_loop_returns_the_identified_cable():
    cable, experiment = case("usb", "two-clip", "thesis")
    result = identify_youngs_modulus(cable, experiment)
    setup = tune_for_identified(result)
    assert setup.cable.youngs_modulus == result.youngs_modulus
    assert setup.thesis_modulus == pytest.approx(result.youngs_modulus)  # thesis model
    # the USB modulus (~2.5e6 Pa) is a soft cable's (thesis 6.2), as the planner classes it
    assert setup.family == "soft" == stiffness_family(result.youngs_modulus)
    assert setup.weights.physical.bending == 1000.0


def test_a_shape_of_a_few_markers_is_refused_naming_the_points_it_needs():
    """Four markers along the USB cable's cantilever (the unseen-case sweep's identification
    with fewer markers): the polyline through them is 5 % short of the cable. The refusal named
    the lengths only, as if the wrong cable were measured; it now says that too few points
    were measured, and how many the cable's n asks for."""
    cable = catalogue_cable("usb", n_links=16)
    manipulation = cantilever_manipulation(cable)
    experiment = synthetic_experiment(cable, manipulation, seed=3)
    sparse = Experiment(manipulation, experiment.measured_shape[::16])
    assert len(sparse.measured_shape) == 4
    with pytest.raises(ValueError, match=r"measured_shape: the shape is .* long but the cable "
                       r"is 0.5 m \(only 4 points measured: .*at least n \+ 1 = 17 points"):
        prepare_shapes(cable, sparse)
    prepare_shapes(cable, Experiment(manipulation, experiment.measured_shape))  # dense: fine


def test_a_shape_longer_than_its_cable_names_an_outlier_or_the_noise_it_has():
    """One marker 60 mm off, or 5 mm of noise stated as 1 mm (the unseen-case sweep, round 5,
    on the Ethernet example): the smoothing spline follows them and the shape reads 18-26 %
    longer than the cable. The refusal named the lengths only, as if another cable were
    measured; it now names the outlier, or the scatter the points have."""
    cable = catalogue_cable("usb", n_links=16)
    manipulation = cantilever_manipulation(cable)
    experiment = synthetic_experiment(cable, manipulation, seed=3)
    moved = experiment.measured_shape.copy()
    moved[30] += [0.0, 0.0, 0.06]
    with pytest.raises(ValueError, match=r"long but the cable is 0.5 m \(point 30 lies "
                       r"6[0-3]\.\d mm off the line of its neighbours, .*an outlier\? "
                       r"remove it\)"):
        prepare_shapes(cable, Experiment(manipulation, moved, measurement_noise=1e-3))
    noisy = synthetic_experiment(cable, manipulation, noise=5e-3, seed=3).measured_shape
    with pytest.raises(ValueError, match=r"long but the cable is 0.5 m \(the points scatter "
                       r"about [3-6](\.\d)? mm, .* more than the stated measurement_noise of 1 mm"):
        prepare_shapes(cable, Experiment(manipulation, noisy, measurement_noise=1e-3))
    scatter = point_scatter(experiment.measured_shape)  # 1 mm of noise, as stated
    assert 0.5e-3 < scatter.noise < 2e-3
    prepare_shapes(cable, experiment)  # accepted as before


def test_a_shape_a_thousand_times_short_is_named_as_metres_in_a_millimetre_file():
    """The example's measured points written in metres into its file in millimetres (round 11
    of the unseen-case sweep): the shape reads 0.47 mm long, its curvature raises n to 200, and
    the refusal said that 49 points were too few to follow the bends (measure 201). It now says
    what a thousandfold is, as the shapes of a plan's job say the opposite slip; the initial
    shape likewise."""
    cable = catalogue_cable("usb", n_links=16)
    manipulation = cantilever_manipulation(cable)
    experiment = synthetic_experiment(cable, manipulation, seed=3)
    short = Experiment(manipulation, experiment.measured_shape * 1e-3)
    with pytest.raises(ValueError, match=r"measured_shape: the shape is 0.000\d+ m long but the "
                       r"cable is 0.5 m \(given in metres in a file in millimetres\?\); expected"):
        prepare_shapes(cable, short)
    with pytest.raises(ValueError, match=r"initial: the shape is 0.0005 m long .*\(given in "
                       r"metres in a file in millimetres\?\)"):
        discretize(manipulation.initial_shape * 1e-3, cable, name="initial")
