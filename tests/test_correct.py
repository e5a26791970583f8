"""Closed-loop shape correction (dloplan.correct): measurements, the correction, the closed loop.

The plans are made by ``dloplan plan`` itself from the demo and the 3D Ethernet example with a
model of n = 20 links; the plant is the same cable with n = 100 links and another E, measured with
1 mm noise (per coordinate) at 200 points, as a camera centreline would give.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from dloplan.app import read_plan
from dloplan.app.correct import CorrectionService, correct_document
from dloplan.cable import catalogue_cable
from dloplan.cli import main
from dloplan.correct import (
    CorrectionLimits,
    CorrectionRefused,
    Plant,
    closed_loop_sample,
    closed_loop_success,
    correct_plan,
    reachable_error,
    resample_measured,
    run_closed_loop,
    shared_floor,
)
from dloplan.correct import step as correct_step
from dloplan.geometry import resample_by_arc_length, shape_length
from dloplan.grippers import GripperPath
from dloplan.sim import equilibrium
from dloplan.sim.sensitivity import equilibrium_sensitivity
from dloplan.vision.shapes_io import RegisteredShape, write_shapes

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_correct")

SCENARIOS = {
    "demo": Path(__file__).resolve().parent / "data" / "sagging_demo.yaml",
    "ethernet-3d": Path(__file__).resolve().parents[1] / "examples/qualitative2_ethernet_3d.yaml",
}
MODEL_LINKS = 20
NOISE = 1e-3


@pytest.fixture(scope="module")
def plans(tmp_path_factory):
    """name -> (plan document, path of plan.json), planned by the CLI with n = 20."""
    out = {}
    for name, path in SCENARIOS.items():
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
        data["cable"]["n_links"] = MODEL_LINKS
        data["outputs"] = ["json"]
        folder = tmp_path_factory.mktemp(name)
        scenario = folder / "scenario.yaml"
        scenario.write_text(yaml.safe_dump(data), encoding="utf-8")
        planned = folder / "plan"
        # the closed loop needs the planned shapes and clips, not a robot program: no repair
        # search (exit 3 when the robot program fails is fine here)
        assert main(["plan", str(scenario), "-o", str(planned), "-q", "--no-repair"]) in (0, 1, 3)
        out[name] = (read_plan(planned / "plan.json"), planned / "plan.json")
    return out


def _stabilized(doc):
    return doc.stabilized


def _chord(shape):
    """The unit vector from a shape's first point to its last."""
    chord = shape[-1] - shape[0]
    return chord / np.linalg.norm(chord)


def _measure(shape, n_points=200, noise=NOISE, seed=0):
    rng = np.random.default_rng(seed)
    points = resample_by_arc_length(shape, n_points)
    return points + rng.normal(scale=noise, size=points.shape)


# -- the closed loop -----------------------------------------------------------------------------
# Final mean error [mm] against the plan's stabilized target (curves at equal arc length), seed 1,
# open loop -> corrected once at mid-path (floor: the best any target clip pose gives the plant,
# reachable_error); benchmarks/bench_correct.py prints them:
#   demo x0.5: 6.06 -> 3.31 (floor 3.26); demo x2: 18.20 -> 2.95 (2.98)
#   3D x0.5:   1.73 -> 0.87 (0.86);        3D x2:   4.84 -> 0.89 (0.85)
# The one fifth is reached at 2E. At E / 2 the floor itself is above one fifth (a softer
# cable sags more and two clips cannot give it the stiffer cable's shape): the test asserts that
# the correction reaches the floor instead, and that the floor is physical (> 0.4 x open loop).
@pytest.mark.parametrize("name", list(SCENARIOS))
@pytest.mark.parametrize("factor", [0.5, 2.0])
def test_one_correction_at_mid_path_reaches_one_fifth_or_the_physical_floor(plans, name, factor):
    doc, _ = plans[name]
    cable = doc.cable
    last = len(doc.shapes) - 1
    plant = Plant(cable.with_links(100).with_modulus(factor * cable.youngs_modulus),
                  noise=NOISE, n_measured=200, seed=1, clamp=cable.rest_link_length)
    run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, [last // 2],
                          stabilized=_stabilized(doc), trajectory=doc.trajectory)
    assert not run.refusals
    (correction,) = run.corrections
    # E and the discretization bias together identify the plant's E within 25 % (E alone
    # absorbed the discretization: 1.4 times the plant's), and explain the measurement to the
    # noise (1 mm per coordinate, smoothed over 200 points: 0.6-0.75 mm mean)
    assert abs(np.log(correction.model.youngs_modulus / (factor * cable.youngs_modulus))) < 0.25
    assert 0.5 < correction.model.discretization < 3.0
    assert correction.model.residual_after < 0.8e-3
    # the prediction of the corrected final shape is honest: within 1 mm of what the plant does
    assert abs(correction.corrected_error[-1] - run.closed_loop_error) < 1e-3
    floor = reachable_error(plant, doc.grippers.clip_poses(last), run.reference,
                            run.open_loop[-1])
    if factor > 1:
        assert run.closed_loop_error <= 0.2 * run.open_loop_error
    else:
        assert floor > 0.4 * run.open_loop_error
    assert run.closed_loop_error <= 1.15 * floor


@pytest.fixture(scope="module")
def u_demo(tmp_path_factory):
    """The embedded U demo planned by the CLI at its own n (12) and at n = 20."""
    source = Path(__file__).resolve().parents[1] / "src" / "dloplan" / "data" / "demo.yaml"
    out = {}
    for n_links in (None, MODEL_LINKS):
        data = yaml.safe_load(source.read_text(encoding="utf-8"))
        if n_links is not None:
            data["cable"]["n_links"] = n_links
        data["outputs"] = ["json"]
        folder = tmp_path_factory.mktemp(f"u{n_links}")
        scenario = folder / "scenario.yaml"
        scenario.write_text(yaml.safe_dump(data), encoding="utf-8")
        assert main(["plan", str(scenario), "-o", str(folder / "plan"), "-q", "--no-repair"]) \
            in (0, 1, 3)
        doc = read_plan(folder / "plan" / "plan.json")
        out[doc.cable.n_links] = doc
    return out


@pytest.mark.parametrize("grip", ["estimate", "known"])
@pytest.mark.parametrize(("n_links", "factor"), [(12, 2.0), (20, 0.5), (20, 2.0)])
def test_the_closed_loop_never_ends_worse_than_the_open_loop_on_the_u_demo(u_demo, n_links,
                                                                          factor, grip):
    """The U demo (issue 35), its plant clamping the model's L / n (96 links at n = 12): its
    shapes hardly depend on E, and with alpha clipped at 0 the correction made the final error
    worse (0.19 -> 0.43 mm at E x0.5 on dismech's rod). With alpha's prior at its first-order
    value (alpha_prior) and the gain check the closed loop ends no worse than the open loop:
    the correction is made, or refused because its predicted gain is within 2 sd of zero (the
    plan kept, the reason given: with the clamp length not known, a quarter link of it moves
    the U's target by millimetres), and the interval holds. Measured (seed 1, chain plant):
    grip known, n = 20: E x2 0.47 -> 0.18 mm, E x0.5 0.27 -> 0.06 mm (floor 0.06)."""
    doc = u_demo[n_links]
    cable = doc.cable
    last = len(doc.shapes) - 1
    plant = Plant(cable.with_links(n_links * round(100 / n_links))
                  .with_modulus(factor * cable.youngs_modulus),
                  noise=NOISE, n_measured=200, seed=1, clamp=cable.rest_link_length)
    run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, [last // 2],
                          stabilized=doc.stabilized, trajectory=doc.trajectory, grip=grip)
    # 0.05 mm: a tenth of the noise smoothed over the cable (the plant's own result is exact)
    assert run.closed_loop_error <= run.open_loop_error + 0.05e-3
    if run.refusals:
        (reason,) = run.refusals
        assert "gain" in reason and "the plan is kept" in reason
        assert run.closed_loop_error == pytest.approx(run.open_loop_error, abs=1e-9)
    else:
        (correction,) = run.corrections
        low, high = correction.prediction_interval
        assert low <= run.closed_loop_error <= high
        assert correction.model.discretization > 0.5  # near its prior (1.6-1.76), not clipped
    if grip == "known" and n_links == 20:
        assert run.corrections and run.closed_loop_error < 0.7 * run.open_loop_error


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_an_unknown_grip_on_the_u_demo_never_makes_the_closed_loop_worse(u_demo, seed):
    """The U demo at its own n = 12 on a 100-link plant: the plant clamps 8 of its links, 40 mm,
    for the model's 41.7 (no whole number of plant links is L / n), E x2, 1 mm noise, the clamp
    length estimated (the default). Its target moves 28 mm per half link of clamp, so the
    estimate's error (37.9 mm for 40, seed 1) carries millimetres to the target: the correction
    made it 1.09 -> 3.88 mm while the gain check, linearized in the mean distance, let it pass
    (the corrected prediction sits on the reference, where a shift of millimetres is far from
    linear). With the gain also evaluated with the clamp length 2 sd off
    (step._gain_at_clamp_bounds) the correction is refused naming the cause, or made and no
    worse than the open loop."""
    doc = u_demo[12]
    cable = doc.cable
    last = len(doc.shapes) - 1
    plant = Plant(cable.with_links(100).with_modulus(2.0 * cable.youngs_modulus),
                  noise=NOISE, n_measured=200, seed=seed, clamp=cable.rest_link_length)
    assert plant.clamp_links == 8  # 40 mm: the grip is not the model's
    run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, [last // 2],
                          stabilized=doc.stabilized, trajectory=doc.trajectory)
    # 0.05 mm: a tenth of the noise smoothed over the cable (the plant's own result is exact)
    assert run.closed_loop_error <= run.open_loop_error + 0.05e-3
    if run.refusals:  # measured, seeds 1-3: lost with the clamp length +2 sd (-1.9 to -2.7 mm)
        (reason,) = run.refusals
        assert "gain" in reason and "clamp length" in reason and "the plan is kept" in reason
    else:
        (correction,) = run.corrections
        low, high = correction.prediction_interval
        assert low <= run.closed_loop_error <= high


def test_estimating_e_alone_leaves_the_discretization_error(plans):
    """The old correction (E only) on the 3D example at 2E stays above one fifth."""
    doc, _ = plans["ethernet-3d"]
    cable = doc.cable
    last = len(doc.shapes) - 1
    plant = Plant(cable.with_links(100).with_modulus(2 * cable.youngs_modulus), noise=NOISE,
                  n_measured=200, seed=1)
    runs = {kind: run_closed_loop(plant, cable, doc.shapes, doc.grippers, [last // 2],
                                  stabilized=_stabilized(doc), model_error=kind)
            for kind in ("modulus", "discretization")}
    only_e = runs["modulus"].corrections[0].model
    assert only_e.discretization == 0.0
    assert only_e.youngs_modulus > 2.4 * cable.youngs_modulus  # absorbs the coarse chain
    assert runs["modulus"].closed_loop_error > 0.2 * runs["modulus"].open_loop_error
    assert runs["discretization"].closed_loop_error < 0.85 * runs["modulus"].closed_loop_error


@pytest.mark.parametrize("factor", [0.5, 2.0])
def test_the_thesis_bending_model_reaches_the_floor_too(plans, factor):
    """Not the case the method was built on: k_b = 3EI/l and equal masses, another noise seed.

    3D example (seed 3): open 1.98 -> 0.73 mm (floor 0.72) at E / 2, 2.91 -> 0.52 mm (0.50) at 2E.
    """
    doc, _ = plans["ethernet-3d"]
    cable = doc.cable.thesis_model()
    last = len(doc.shapes) - 1
    plant = Plant(cable.with_links(100).with_modulus(factor * cable.youngs_modulus),
                  noise=NOISE, n_measured=200, seed=3, clamp=cable.rest_link_length)
    run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, [last // 2])
    (correction,) = run.corrections
    assert abs(np.log(correction.model.youngs_modulus / (factor * cable.youngs_modulus))) < 0.2
    assert abs(correction.corrected_error[-1] - run.closed_loop_error) < 0.3e-3
    floor = reachable_error(plant, doc.grippers.clip_poses(last), run.reference,
                            run.open_loop[-1])
    assert run.closed_loop_error <= 1.1 * floor
    if factor > 1:
        assert run.closed_loop_error <= 0.2 * run.open_loop_error


def test_the_discretization_direction_is_the_richardson_one():
    """d = R_n[x_2n] - x_n of a sagging cable: first order, so x_n + 2 d is nearer the rod."""
    from dloplan.correct.model_error import clamped_equilibrium, discretization_error
    from dloplan.sim import ClipPoses

    base = catalogue_cable("ethernet", 10)
    span = 0.7 * base.length
    clips = ClipPoses(np.array([[0.0, 0.0, 0.3], [span, 0.0, 0.3]]),
                      Rotation.from_euler("z", [[0.0], [180.0]], degrees=True))
    t = np.linspace(0.0, 1.0, 400)
    sag = np.stack([span * t, 0 * t, 0.3 - 0.3 * base.length * np.sin(np.pi * t)], axis=1)

    def settled(n, clamp_links=1):
        cable = base.with_links(n)
        x, stable, _ = clamped_equilibrium(cable, resample_by_arc_length(sag, n + 1), clips,
                                           clamp_links)
        assert stable
        return cable, x

    errors = {}
    for n in (20, 40):
        cable, x = settled(n)
        d = discretization_error(cable, x, clips)
        _, rod = settled(320, clamp_links=320 // n)  # the same clamp length L / n
        on = resample_by_arc_length(rod, n + 1)
        errors[n] = (np.mean(np.linalg.norm(x - on, axis=1)),
                     np.mean(np.linalg.norm(x + 2 * d - on, axis=1)),
                     np.mean(np.linalg.norm(d, axis=1)))
    assert errors[20][0] > 1e-3  # a real discretization error to remove (mm)
    assert 1.6 < errors[20][2] / errors[40][2] < 2.4  # d halves with n: first order
    for n in (20, 40):
        assert errors[n][1] < errors[n][0] / 3  # extrapolation removes most of it


def test_a_measurement_of_the_model_itself_changes_nothing(plans):
    doc, _ = plans["demo"]
    stable = _stabilized(doc)
    at = 3
    result = correct_plan(doc.cable, doc.shapes, doc.grippers, at,
                          resample_by_arc_length(stable[at], 300), stabilized=stable,
                          trajectory=doc.trajectory)
    assert abs(np.log(result.model.youngs_modulus / doc.cable.youngs_modulus)) < 0.02
    assert np.max(np.abs(result.clip_corrections[:, [0, 1, 2, 6, 7, 8]])) < 1e-3  # < 1 mm
    assert np.max(result.corrected_error) < 1e-3
    # shapes 0 .. K and their timing are untouched; the rest is re-timed from K
    assert np.allclose(result.grippers.positions[: at + 1], doc.grippers.positions[: at + 1])
    assert np.allclose(result.trajectory.times[: at + 1], doc.trajectory.times[: at + 1])
    assert result.remaining.n_knots == len(doc.shapes) - at
    assert result.remaining.times[0] == 0.0
    assert np.allclose(result.remaining.positions[0], doc.trajectory.positions[at])
    assert result.remaining.max_speed == doc.trajectory.max_speed


def test_the_all_mode_fits_every_remaining_shape(plans):
    doc, _ = plans["ethernet-3d"]
    stable = _stabilized(doc)
    plant_like = doc.cable.with_modulus(2.0 * doc.cable.youngs_modulus)
    at = 2
    truth = equilibrium(plant_like, stable[at], doc.grippers.clip_poses(at)).shape
    both = {mode: correct_plan(doc.cable, doc.shapes, doc.grippers, at, _measure(truth),
                               stabilized=stable, mode=mode) for mode in ("target", "all")}
    for result in both.values():
        assert result.corrected_error[-1] < 0.5 * result.open_loop_error[-1]
    # fitting every shape beats ramping the target's correction in on the way
    assert np.mean(both["all"].corrected_error[:-1]) < np.mean(both["target"].corrected_error[:-1])


# -- measurements ------------------------------------------------------------------------------
def test_noisy_dense_measurements_are_resampled_by_smoothed_arc_length(plans):
    doc, _ = plans["ethernet-3d"]
    shape = _stabilized(doc)[3]
    points = _measure(shape, n_points=1000, noise=NOISE)
    assert shape_length(points) > 1.5 * doc.cable.length  # noise inflates the raw polyline
    resampled = resample_measured(points, shape, doc.cable.length)
    assert np.mean(np.linalg.norm(resampled - shape, axis=1)) < 0.6e-3
    assert abs(shape_length(resampled) / doc.cable.length - 1) < 0.01
    # five points, one spline span; fewer are refused
    few = resample_measured(shape[::5], shape, doc.cable.length)
    assert np.mean(np.linalg.norm(few - shape, axis=1)) < 5e-3
    with pytest.raises(CorrectionRefused, match="3 points, expected at least 5"):
        resample_measured(shape[::10], shape, doc.cable.length)


@pytest.mark.parametrize(
    ("make", "reason"),
    [
        (lambda s: s[::-1], "reverse them"),
        (lambda s: np.random.default_rng(3).permutation(s), "not ordered along the cable"),
        (lambda s: s[0] + 0.6 * (s - s[0]), "another cable"),
        (lambda s: s + [0.3, 0.0, 0.0], "not where the plan has it"),
        # reflected across the plane through its first point normal to its chord: the points
        # project onto the prediction's first end (correlation ~0) and were refused as "not
        # ordered along the cable" though their order was right and they were 0.3 m away
        (lambda s: s - 2.0 * np.outer((s - s[0]) @ _chord(s), _chord(s)),
         "the points are on average .* from the model's prediction, each from its nearest "
         "point .*: the cable is not where the plan has it"),
    ],
    ids=["reversed", "shuffled", "shorter-cable", "elsewhere", "mirrored"],
)
def test_an_absurd_measurement_is_refused_with_the_reason(plans, make, reason):
    doc, _ = plans["demo"]
    stable = _stabilized(doc)
    measured = make(_measure(stable[3], n_points=100))
    with pytest.raises(CorrectionRefused, match=reason):
        correct_plan(doc.cable, doc.shapes, doc.grippers, 3, measured, stabilized=stable)


def _assert_within(corrections, limits):
    for p in corrections:
        for start, bound in ((0, limits.max_translation), (3, limits.max_rotation),
                             (6, limits.max_translation), (9, limits.max_rotation)):
            assert np.linalg.norm(p[start : start + 3]) <= bound * (1 + 1e-9)


def test_a_correction_beyond_the_limits_is_held_at_them_and_e_beyond_is_refused(plans):
    """A cable 5 times softer needs more than 1 mm / 0.57 degrees of clip correction: the fit is
    held at those limits, with the warning naming them; a measurement asking for E beyond the
    modulus limit by more than 2 sd is refused."""
    doc, _ = plans["demo"]
    stable = _stabilized(doc)
    softer = doc.cable.with_modulus(0.2 * doc.cable.youngs_modulus)
    truth = equilibrium(softer, stable[3], doc.grippers.clip_poses(3)).shape
    tight = CorrectionLimits(max_translation=1e-3, max_rotation=0.01)
    result = correct_plan(doc.cable, doc.shapes, doc.grippers, 3, truth, stabilized=stable,
                          limits=tight, predict=False)
    _assert_within(result.clip_corrections, tight)
    assert any("held at the limits 1 mm / 1 degrees" in w for w in result.warnings)
    with pytest.raises(CorrectionRefused, match="times off"):
        correct_plan(doc.cable, doc.shapes, doc.grippers, 3, truth, stabilized=stable,
                     limits=CorrectionLimits(max_modulus_factor=2.0))


def test_bad_arguments_are_named(plans):
    doc, _ = plans["demo"]
    last = len(doc.shapes) - 1
    measured = _stabilized(doc)[3]
    for at in (last, -1, 2.5):
        with pytest.raises(ValueError, match="at:"):
            correct_plan(doc.cable, doc.shapes, doc.grippers, at, measured)
    with pytest.raises(ValueError, match="mode"):
        correct_plan(doc.cable, doc.shapes, doc.grippers, 3, measured, mode="fast")
    with pytest.raises(ValueError, match="reference"):
        correct_plan(doc.cable, doc.shapes, doc.grippers, 3, measured, reference="wish")
    with pytest.raises(ValueError, match="max_translation"):
        CorrectionLimits(max_translation=0.0)
    with pytest.raises(ValueError, match="noise"):
        Plant(doc.cable, noise=-1.0)
    for fit_links in (50, 10, 0):  # not a multiple of n = 20 at least n
        with pytest.raises(ValueError, match=f"fit_links: got {fit_links}.*multiple"):
            correct_plan(doc.cable, doc.shapes, doc.grippers, 3, measured, fit_links=fit_links)


# -- documents and the command ------------------------------------------------------------------
def _x_half_measurement(doc, tmp_path, at=3):
    """The demo's cable at E x0.5 measured at shape ``at`` (a registered-shape CSV), and the
    closed-loop run it was measured on."""
    truth = Plant(doc.cable.with_links(100).with_modulus(0.5 * doc.cable.youngs_modulus))
    run = run_closed_loop(truth, doc.cable, doc.shapes, doc.grippers, [],
                          stabilized=_stabilized(doc))
    shapes_file = tmp_path / "measured.csv"
    write_shapes(shapes_file, [RegisteredShape(_measure(run.open_loop[at]), label=f"xi_{at}",
                                               frame_id=doc.frame_id)])
    return shapes_file, run


def test_dloplan_correct_writes_the_corrected_plan_program_and_report(plans, tmp_path):
    """E x0.5 at shape 3 of the demo: written, and dloplan verify passes what was written. (At
    E x2 the whole path's robot program fails continuity from the approach: the YuMi's arm
    angle is chosen over the whole path, and the corrected tail changes it for the head; the
    command refuses, naming that check.)"""
    doc, plan_path = plans["demo"]
    at = 3
    shapes_file, run = _x_half_measurement(doc, tmp_path, at)
    out = tmp_path / "out"
    code = main(["correct", str(plan_path), "--at", str(at), "--measured", str(shapes_file),
                 "-o", str(out), "-q", "--json"])
    assert code in (0, 1)
    corrected = read_plan(out / "plan.json")
    # a corrected plan is a plan: its stored stabilized shapes are equilibria of the cable it
    # states, dloplan verify passes it, and its cell is the plan's
    assert main(["verify", str(out / "plan.json"), "-q"]) == 0
    assert corrected.robot is not None
    assert np.allclose(corrected.robot.cell["base_position"], doc.robot.cell["base_position"])
    assert len(corrected.correction["predicted"]) == len(doc.shapes) - at - 1
    report = json.loads((out / "correction.json").read_text())
    direct = correct_document(doc, at, _measure(run.open_loop[at]))
    assert corrected.cable.youngs_modulus == pytest.approx(direct.cable.youngs_modulus)
    assert corrected.cable.youngs_modulus < 0.7 * doc.cable.youngs_modulus
    assert corrected.trajectory.n_knots == len(doc.shapes)
    assert len(corrected.stabilized) == len(doc.shapes)
    assert report["corrected_error"][-1] < report["open_loop_error"][-1]
    assert (out / "rapid").is_dir() and len(list((out / "rapid").glob("*.mod"))) == 2
    rows = (out / "trajectory.csv").read_text().splitlines()
    assert len(rows) > 3
    assert "open-loop" in (out / "correction.txt").read_text()
    # its report says that it is a corrected plan, where and how (it read as the plan it
    # corrects: the title, E and every line the plan's own)
    assert main(["export", str(out / "plan.json"), "--format", "report", "-o",
                 str(tmp_path / "report.html"), "-q"]) == 0
    html = (tmp_path / "report.html").read_text()
    assert "dloplan corrected plan:" in html and f"corrected at shape {at}: E" in html
    # the clips fitted on the refined chain (the default: 60 links at n = 20), said so; the
    # plan's own chain when asked (--fit-links 20); a count not a multiple of n is refused
    assert report["fit_links"] == 60
    assert "a chain of 60 links" in (out / "correction.txt").read_text()
    own = tmp_path / "own"
    assert main(["correct", str(plan_path), "--at", str(at), "--measured", str(shapes_file),
                 "-o", str(own), "-q", "--fit-links", "20"]) in (0, 1)
    assert json.loads((own / "correction.json").read_text())["fit_links"] == 20
    assert main(["correct", str(plan_path), "--at", str(at), "--measured", str(shapes_file),
                 "-o", str(tmp_path / "bad"), "-q", "--fit-links", "50"]) == 2
    assert not (tmp_path / "bad").exists()
    # the plant clamps the model's L / n: told so (--grip known), the clamp is neither estimated
    # nor in the interval
    known = tmp_path / "known"
    assert main(["correct", str(plan_path), "--at", str(at), "--measured", str(shapes_file),
                 "-o", str(known), "-q", "--grip", "known"]) in (0, 1)
    report = json.loads((known / "correction.json").read_text())
    assert report["clamp_length"] == pytest.approx(doc.cable.rest_link_length)
    assert report["grip_sd"] == 0.0 and "known" in report["grip_note"]
    assert report["uncertainty"]["grip"] == 0.0
    assert main(["verify", str(known / "plan.json"), "-q"]) == 0
    # E told (--modulus known): kept at the plan's, no modulus term in the interval; the bias
    # still estimated
    told = tmp_path / "told"
    assert main(["correct", str(plan_path), "--at", str(at), "--measured", str(shapes_file),
                 "-o", str(told), "-q", "--modulus", "known"]) in (0, 1, 2)
    if (told / "correction.json").exists():
        report = json.loads((told / "correction.json").read_text())
        assert report["youngs_modulus"] == doc.cable.youngs_modulus
        assert report["log_modulus_sd"] == 0.0 and report["uncertainty"]["modulus"] == 0.0
        assert report["modulus_alpha_correlation"] == 0.0  # E known: nothing to correlate
        assert report["discretization_alpha"] > 0.5


def test_dloplan_correct_refuses_what_verify_would_fail_and_prints_its_warnings(
        plans, tmp_path, capsys, monkeypatch):
    """E x2 at shape 3 of the demo with a controller that must return the verified joints
    exactly (round-trip tolerance 0: its IK never does): the whole path's program fails its
    round trip: exit 2, the check named, nothing written. (With the YuMi in the controller's
    semantics the x2 correction's own program passes, min joint margin 16.7 deg, so the failure
    is made in the check.) The tolerance back, the x2 correction is written and verified. The
    plan's own prediction plus noise: nothing to gain (the gain check), exit 2, the plan kept
    and the reason printed."""
    doc, plan_path = plans["demo"]
    truth = Plant(doc.cable.with_links(100).with_modulus(2 * doc.cable.youngs_modulus))
    run = run_closed_loop(truth, doc.cable, doc.shapes, doc.grippers, [],
                          stabilized=_stabilized(doc))
    for name, shape in (("x2", run.open_loop[3]), ("plan", _stabilized(doc)[3])):
        write_shapes(tmp_path / f"{name}.csv", [RegisteredShape(_measure(shape), label="xi_3",
                                                                frame_id=doc.frame_id)])
    out = tmp_path / "out"
    args = ["correct", str(plan_path), "--at", "3", "-o", str(out), "-q", "--measured"]
    with monkeypatch.context() as strict:
        strict.setattr("dloplan.robot.yumi_program.ROUND_TRIP_TOLERANCE", 0.0)
        assert main([*args, str(tmp_path / "x2.csv")]) == 2
    err = capsys.readouterr().err
    assert "robot program (the whole path" in err and "round trip" in err
    assert not out.exists()
    assert main([*args, str(tmp_path / "x2.csv")]) in (0, 1)
    assert main(["verify", str(out / "plan.json"), "-q"]) == 0
    capsys.readouterr()
    assert main([*args, str(tmp_path / "plan.csv"), "-o", str(tmp_path / "kept")]) == 2
    assert "the plan is kept" in capsys.readouterr().err
    assert not (tmp_path / "kept").exists()


def _rapid_start(folder):
    """Per arm (left, right) of a written RAPID program: the start joints [deg] in physical
    order (axis 7 third), the first robtarget's eax_a [deg] and every robtarget's label."""
    import re

    out = []
    for side in "LR":
        text = (folder / "rapid" / f"DloPlan{side}.mod").read_text(encoding="utf-8")
        start = re.search(r"dlo_start := \[\[([^\]]*)\],\[([^,]*),", text)
        axes = [float(v) for v in start.group(1).split(",")]
        eax = re.search(r"CONST robtarget dlo_p00 := \[.*\],\[([^,]*),", text)
        labels = re.findall(r"CONST robtarget dlo_p\d+ := .*;  ! (.*)", text)
        out.append((np.array([*axes[:2], float(start.group(2)), *axes[2:]]),
                    float(eax.group(1)), labels))
    return out


def test_the_remaining_program_starts_from_the_joints_that_hold_the_cable(plans, tmp_path):
    """Round 9: the YuMi's remaining motion (from the measured shape K on) had an approach and a
    retreat (the cable is held) and a fresh joint solution (another arm angle: 147.3 deg at its
    approach against the 137.2 deg the arm holds the cable with). It starts at shape K from the
    joints the plan's program holds the cable with, each arm angle kept."""
    doc, plan_path = plans["demo"]
    at, out = 3, tmp_path / "out"
    shapes_file, _ = _x_half_measurement(doc, tmp_path, at)
    assert main(["correct", str(plan_path), "--at", str(at), "--measured", str(shapes_file),
                 "-o", str(out), "-q"]) == 0
    held = next(t for t in doc.robot.program["targets"] if t["label"] == f"shape {at}")
    remaining = len(doc.shapes) - at
    for arm, (joints, eax, labels) in zip(("left", "right"), _rapid_start(out), strict=True):
        assert labels == [f"shape {k}" for k in range(remaining)]  # no approach, no retreat
        np.testing.assert_allclose(joints, held["arms"][arm]["joints_deg"], atol=1e-5)
        assert eax == pytest.approx(held["arms"][arm]["arm_angle_deg"], abs=1e-5)
    text = (out / "rapid" / "DloPlanL.mod").read_text(encoding="utf-8")
    assert "no approach or retreat" in text and "g_GripIn" not in text


def test_a_remaining_program_that_cannot_start_from_the_held_joints_is_written_with_a_warning(
        plans, tmp_path, monkeypatch, capsys):
    """The arm holding the cable with another arm angle (2.7 deg from a joint limit): the
    program from it fails its joint limits; one from a fresh solution passes. It is written,
    exit 1, and the warning names the held program's failure and the arm angles to take."""
    from dloplan.app import correct as app_correct
    from dloplan.robot import RobotCell, forward
    from dloplan.robot.armangle import arm_angle, wrap
    from dloplan.robot.kinematics import joint_margin, solve_many

    doc, plan_path = plans["demo"]
    at = 3
    held = app_correct.held_arms(doc, at)
    cell = RobotCell()
    arm = cell.robot.arms[0]
    p, r = forward(arm, held.joints[0])
    theta = wrap(arm_angle(arm, held.joints[0]) - np.radians(120.0))
    q, ok, _, _ = solve_many(arm, p[None], r.as_matrix()[None], held.joints[0][None],
                             cell.reach.ik, np.array([theta]))
    assert ok[0] and np.degrees(joint_margin(arm, q[0])) < 5.0  # same pose, near a limit
    other = app_correct.HeldArms(held.left_clip, np.stack([q[0], held.joints[1]]))
    monkeypatch.setattr(app_correct, "held_arms", lambda doc, at: other)
    out = tmp_path / "out"
    shapes_file, _ = _x_half_measurement(doc, tmp_path, at)
    assert main(["correct", str(plan_path), "--at", str(at), "--measured", str(shapes_file),
                 "-o", str(out), "-q"]) == 1
    err = capsys.readouterr().err
    assert f"the remaining motion from shape {at}): from the joints that hold the cable it " \
           "fails (" in err
    assert "joint limits at shape 0 (left arm: 2." in err
    assert "arm angles left " in err and f"(held {np.degrees(theta):.1f})" in err
    assert f"bring the arms there at shape {at}, the cable held" in err
    (left, _, labels), _ = _rapid_start(out)
    assert labels[0] == "shape 0" and np.abs(left - np.degrees(q[0])).max() > 10.0


def test_a_corrected_panda_plan_goes_on_from_the_joints_and_placement_that_hold_the_cable(
        tmp_path):
    """The sagging demo on the Panda pair (placed 0.2 m further by the placement search): the
    remaining motion from shape 3 on was verified afresh, its joints tracked from the arms'
    home poses through the corrected path and a placement searched again: the seven-joint arm
    started 3.5 deg (joints 1 and 3) from the joints holding the cable. Now its ROS trajectory
    starts at the held joints (to the file's 1e-9 rad) and the job keeps the plan's placement."""
    import yaml

    data = yaml.safe_load(SCENARIOS["demo"].read_text(encoding="utf-8"))
    data.update(cable={**data["cable"], "n_links": MODEL_LINKS}, outputs=["json"],
                robot={"cell": {"preset": "panda_pair"}, "place": True},
                repair={"placement": True})
    scenario = tmp_path / "panda.yaml"
    scenario.write_text(yaml.safe_dump(data), encoding="utf-8")
    assert main(["plan", str(scenario), "-o", str(tmp_path / "plan"), "-q"]) in (0, 1)
    doc = read_plan(tmp_path / "plan" / "plan.json")
    at, out = 3, tmp_path / "out"
    shapes_file, _ = _x_half_measurement(doc, tmp_path, at)
    assert main(["correct", str(tmp_path / "plan" / "plan.json"), "--at", str(at),
                 "--measured", str(shapes_file), "-o", str(out), "-q"]) == 0
    held = next(t for t in doc.robot.program["targets"] if t["label"] == f"shape {at}")
    for arm in ("left", "right"):
        first = yaml.safe_load((out / "ros_joints" / f"dloplan_{arm}_joint_trajectory.yaml")
                               .read_text(encoding="utf-8"))["points"][0]["positions"]
        np.testing.assert_allclose(np.degrees(first), held["arms"][arm]["joints_deg"], atol=1e-6)
    remaining = read_plan(out / "plan.json").robot.program
    assert remaining["offset"] == pytest.approx(doc.robot.program["offset"], abs=1e-12)
    assert remaining["assignment"]["left_clip"] == doc.robot.program["assignment"]["left_clip"]


def test_the_held_joints_of_a_knot_the_program_dropped_are_those_of_the_shape_before(plans):
    """A described cell's program drops a knot the arms reach in no time (the same pose as the
    shape before): the arms hold the cable there with the joints of the shape before, not with
    a fresh solution (``held_arms`` gave None, and the remaining motion was solved afresh)."""
    from dataclasses import replace

    from dloplan.app import correct as app_correct

    doc, _ = plans["demo"]
    record = doc.robot.program
    dropped = replace(doc, robot=replace(doc.robot, program={
        **record, "targets": [t for t in record["targets"] if t["label"] != "shape 3"]}))
    before = next(t for t in record["targets"] if t["label"] == "shape 2")
    held = app_correct.held_arms(dropped, 3)
    np.testing.assert_array_equal(np.degrees(held.joints[0]),
                                  np.array(before["arms"]["left"]["joints_deg"]))
    assert held.left_clip == record["assignment"]["left_clip"]


def test_held_joints_that_do_not_hold_the_first_pose_leave_it_unreached():
    """``check_path(held=True)``: pose 0 is the held joints; where their TCP is not at it (here
    1 mm off), the pose is reported not reached, naming how far, instead of solved afresh."""
    from dloplan.robot.kinematics import forward
    from dloplan.robot.path import check_path
    from dloplan.robot.urdf_cell import panda_pair

    cell = panda_pair()
    joints = [arm.home for arm in cell.arms]
    poses = [forward(arm, q) for arm, q in zip(cell.arms, joints, strict=True)]
    pos = np.array([[p for p, _ in poses]] * 2)
    rot = Rotation.concatenate([r for _, r in poses] * 2)
    check = check_path(cell, pos, rot, seeds=joints, held=True)
    assert check.reachable.all()
    for q, held in zip(check.joints, joints, strict=True):
        np.testing.assert_array_equal(q[0], held)  # the held joints themselves, not a solution
    moved = pos + [0.0, 0.0, 1e-3]
    check = check_path(cell, moved, rot, seeds=joints, held=True)
    assert not check.reachable[0].any() and not check.ok
    assert any("the joints holding the cable put the TCP 1 mm" in m for m in check.messages), \
        check.messages


def test_dloplan_correct_refuses_an_absurd_measurement_and_writes_nothing(plans, tmp_path,
                                                                         capsys):
    doc, plan_path = plans["demo"]
    shapes_file = tmp_path / "measured.json"
    write_shapes(shapes_file, [RegisteredShape(_measure(_stabilized(doc)[3])[::-1],
                                               frame_id=doc.frame_id)])
    out = tmp_path / "out"
    code = main(["correct", str(plan_path), "--at", "3", "--measured", str(shapes_file),
                 "-o", str(out), "-q"])
    assert code == 2
    assert "reverse them" in capsys.readouterr().err
    assert not out.exists()


def test_closed_loop_success_probability_over_sampled_cables(plans):
    """Four cables with E scattered by a factor up to 2.5 (plant n = 40): more of them end within
    2.5 mm of the target with one correction than without (final errors [mm], open -> closed:
    x0.45 10.0 -> 4.1, x1.6 12.6 -> 2.2, x2.5 19.9 -> 3.5 (its clips held at the 20 degree
    limit: it asks for 21); x0.7 3.0 refused: its predicted gain, 1.4 mm, within 2 sd of zero
    with the clamp length not told (it would have reached 1.7))."""
    doc, _ = plans["demo"]
    cable = doc.cable
    last = len(doc.shapes) - 1
    factors = [0.45, 0.7, 1.6, 2.5]
    rows = [closed_loop_sample(cable, doc.shapes, doc.grippers,
                               cable.with_links(40).with_modulus(f * cable.youngs_modulus),
                               [last // 2], seed=k, stabilized=_stabilized(doc))
            for k, f in enumerate(factors)]
    for row in (rows[0], rows[2], rows[3]):
        assert row["corrections"] == 1
        assert row["closed_loop_error"] < 0.7 * row["open_loop_error"]
    assert rows[1]["corrections"] == 0 and "the plan is kept" in rows[1]["refusal"]
    assert rows[1]["closed_loop_error"] == rows[1]["open_loop_error"]
    success = closed_loop_success(rows, 2.5e-3)
    assert (success.trials, success.refused) == (4, 1)
    assert success.open_loop[0] == 0.0 and success.closed_loop[0] == 0.25
    assert success.closed_loop[1] <= success.closed_loop[0] <= success.closed_loop[2]
    assert "closed loop" in success.message
    with pytest.raises(ValueError, match="tolerance"):
        closed_loop_success(rows, 0.0)


def test_the_mirrored_job_gets_the_mirrored_correction(plans):
    """Reflect everything through the vertical plane y = 0 (gravity is in it): the corrected clip
    positions reflect (M p), the rotation vectors are axial (-M phi), the errors are equal."""
    doc, _ = plans["ethernet-3d"]
    m = np.diag([1.0, -1.0, 1.0])
    stable = _stabilized(doc)
    at = 3
    truth = equilibrium(doc.cable.with_modulus(2 * doc.cable.youngs_modulus), stable[at],
                        doc.grippers.clip_poses(at)).shape
    measured = _measure(truth, n_points=150)
    g = doc.grippers
    mirrored = GripperPath(
        positions=g.positions @ m, method=g.method, twist=-g.twist,
        rotations=tuple(Rotation.from_matrix(m @ r.as_matrix() @ m) for r in g.rotations))
    results = [correct_plan(doc.cable, shapes, grippers, at, points, stabilized=s)
               for shapes, grippers, points, s in ((doc.shapes, g, measured, stable),
                                                    (doc.shapes @ m, mirrored, measured @ m,
                                                     stable @ m))]
    assert results[0].model.youngs_modulus == pytest.approx(results[1].model.youngs_modulus,
                                                           rel=1e-6)
    p, q = (r.clip_corrections.reshape(-1, 2, 2, 3) for r in results)
    assert np.allclose(q[:, :, 0], p[:, :, 0] @ m, atol=1e-7)
    assert np.allclose(q[:, :, 1], -(p[:, :, 1] @ m), atol=1e-6)
    assert np.allclose(results[0].corrected_error, results[1].corrected_error, atol=1e-8)


def test_corrected_poses_out_of_the_robots_reach_are_refused(plans):
    """The whole corrected path's program is made on the plan's cell: clip poses moved 1.5 m
    away are refused, naming the robot program (the plan itself passes)."""
    from dataclasses import replace

    from dloplan.app.correct import check_correction

    doc, _ = plans["demo"]
    stable = _stabilized(doc)
    result = correct_document(doc, 3, resample_by_arc_length(stable[3], 300))
    corrected, remaining = check_correction(doc, result, verify=False)
    assert corrected.robot.ok and remaining.robot.ok
    assert corrected.robot.cell.keys() == doc.robot.cell.keys()
    assert np.allclose(corrected.robot.cell["base_position"], doc.robot.cell["base_position"])
    g = result.grippers
    far = g.positions.copy()
    far[5:] += [1.5, 0.0, 0.0]  # 1.5 m further away from the robot
    moved = GripperPath(positions=far, rotations=g.rotations, method=g.method, twist=g.twist)
    from dloplan.correct.step import sliced_grippers
    from dloplan.trajectory import trajectory_from_grippers

    moved_result = replace(result, grippers=moved, trajectory=trajectory_from_grippers(moved),
                           remaining=trajectory_from_grippers(sliced_grippers(moved, 3)))
    with pytest.raises(CorrectionRefused, match="robot program"):
        check_correction(doc, moved_result, verify=False)


def test_the_planned_reference_also_corrects_the_plans_own_drift_within_the_limits(plans):
    """With the cable exactly as modelled, aiming at the planned shapes instead of the stabilized
    ones corrects the plan's stabilization drift: the 3D Ethernet target (21 mm off when
    stabilized) comes 3x closer; the demo target (76 mm off) would need 52 degrees of clip
    rotation: the fit is held at the 20 degree limit, with the warning."""
    doc, _ = plans["ethernet-3d"]
    stable = _stabilized(doc)
    exact = resample_by_arc_length(stable[3], 300)
    result = correct_plan(doc.cable, doc.shapes, doc.grippers, 3, exact, stabilized=stable,
                          reference="planned")
    assert np.allclose(result.reference, doc.shapes[4:])
    assert result.corrected_error[-1] < result.open_loop_error[-1] / 3
    doc, _ = plans["demo"]
    stable = _stabilized(doc)
    result = correct_plan(doc.cable, doc.shapes, doc.grippers, 3,
                          resample_by_arc_length(stable[3], 300), stabilized=stable,
                          reference="planned", predict=False)
    _assert_within(result.clip_corrections, CorrectionLimits())
    assert any("held at the limits 30 mm / 20 degrees" in w for w in result.warnings)


# -- strict input (issue 35, 36) ----------------------------------------------------------------
def test_a_measurement_in_another_frame_or_unit_or_too_sparse_is_refused(plans, tmp_path):
    from dloplan.app.correct import measured_points

    doc, _ = plans["demo"]
    shape = _measure(_stabilized(doc)[3], n_points=100)
    other = tmp_path / "camera.csv"
    write_shapes(other, [RegisteredShape(shape, frame_id="camera_link", label="xi_3")])
    with pytest.raises(ValueError, match="'camera_link', the plan is in 'world'"):
        measured_points(other, 3, doc.frame_id)
    base = tmp_path / "robot_base.csv"  # the vision files' name of the planner's frame
    write_shapes(base, [RegisteredShape(shape, frame_id="robot_base", label="xi_3")])
    assert np.allclose(measured_points(base, 3, doc.frame_id), shape, atol=1e-9)
    with pytest.raises(CorrectionRefused, match="millimetres"):
        correct_document(doc, 3, 1e3 * shape)
    with pytest.raises(CorrectionRefused, match="2 points"):
        correct_document(doc, 3, shape[[0, -1]])


def test_a_measurement_equal_to_the_plan_plus_noise_leaves_e_unchanged(plans):
    """Plan plus 1 mm noise: no information on E beyond the noise; E is kept, with the reason
    among the warnings (it moved E by -29 % / +11 % before)."""
    for name in SCENARIOS:
        doc, _ = plans[name]
        for seed in range(3):
            # the E update (the fast answer: no predictions, so no gain check)
            result = correct_document(doc, 3, _measure(_stabilized(doc)[3], seed=seed),
                                      predict=False)
            if result.model.youngs_modulus != doc.cable.youngs_modulus:
                # informed: then the change is within 3 sd and small
                assert abs(np.log(result.model.youngs_modulus / doc.cable.youngs_modulus)) \
                    < 3 * result.model.log_sd + 0.05
            else:
                assert any("does not inform E" in w for w in result.warnings)


def test_e_ten_times_off_is_refused(plans):
    """The 'more than 10 times off' refusal is reachable: the trust region's factor-2 steps do
    not count against the Gauss-Newton steps."""
    doc, _ = plans["demo"]
    stable = _stabilized(doc)
    softer = doc.cable.with_modulus(doc.cable.youngs_modulus / 15.0)
    truth = equilibrium(softer, stable[3], doc.grippers.clip_poses(3)).shape
    with pytest.raises(CorrectionRefused, match="times off"):
        correct_document(doc, 3, _measure(truth))


def test_the_prediction_interval_holds_the_unexplained_residual(plans):
    doc, _ = plans["ethernet-3d"]
    cable = doc.cable
    last = len(doc.shapes) - 1
    plant = Plant(cable.with_links(100).with_modulus(2 * cable.youngs_modulus), noise=NOISE,
                  n_measured=200, seed=1, clamp=0.8 * cable.rest_link_length)
    run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, [last // 2],
                          stabilized=_stabilized(doc))
    (correction,) = run.corrections
    low, high = correction.prediction_interval
    assert correction.predicted_error >= correction.model.residual_after
    assert low <= run.closed_loop_error <= high


@pytest.mark.parametrize("name", list(SCENARIOS))
@pytest.mark.parametrize("factor", [1.0, 2.0])
def test_an_unknown_grip_is_estimated_with_e_and_the_bias(plans, name, factor):
    """A gripper that clamps 0.8 L / n (20 mm of the 25 mm model link; issue 35): the clamp
    length is estimated from the measurement at K with E and the bias, the correction then
    reaches further than with the model's grip, and the interval covers the plant's result.
    Measured (chain plant, seed 1): the clamp comes out 21-22.3 mm (a third of the change short:
    the response is a half-link difference, GRIP_LINEARITY); final error 3D 3.72 -> 1.17 mm at E
    x2 and 2.90 -> 0.81 at E x1, demo 4.51 -> 3.36 and 4.82 -> 2.17 (grip="model" -> estimated).
    """
    doc, _ = plans[name]
    cable = doc.cable
    last = len(doc.shapes) - 1
    errors = {}
    for grip in ("estimate", "model"):
        plant = Plant(cable.with_links(100).with_modulus(factor * cable.youngs_modulus),
                      noise=NOISE, n_measured=200, seed=1, clamp=0.8 * cable.rest_link_length)
        run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, [last // 2],
                              stabilized=_stabilized(doc), trajectory=doc.trajectory, grip=grip)
        errors[grip] = run.closed_loop_error
        if grip == "model" and run.refusals:  # a quarter link of clamp: no significant gain
            assert "the plan is kept" in run.refusals[0]
            continue
        (correction,) = run.corrections
        low, high = correction.prediction_interval
        assert low <= run.closed_loop_error <= high
        model = correction.model
        if grip == "model":
            assert not model.grip_estimated and model.grip == 0.0
            continue
        assert model.grip_estimated
        clamp = correction.report()["clamp_length"]
        assert 0.8 * cable.rest_link_length <= clamp <= 0.92 * cable.rest_link_length
        assert "clamp length" in model.grip_note
    assert errors["estimate"] < 0.8 * errors["model"]


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_a_measurement_offset_is_estimated_and_taken_out(plans, name):
    """A camera whose calibration is 5.4 mm off (issue 35: the measurement's offset): read off
    the held points, which lie on the clips whatever E, the bias and the clamp length are, it
    is recovered within the noise (1 mm per coordinate; measured, seed 1: 0.3-0.9 mm off per
    component), taken out of the measurement, and the correction ends where it ends without
    an offset (3D 0.87 -> 0.93 mm, demo 2.98 -> 3.01). Taken as zero, the same offset makes the
    correction ask for E x9.4 for the plant's x2 (3D: it ends 3.31 mm off, not 0.91) or a 24
    degree turn (demo: held at the 20 degree limit, it ends 3.59 mm off, not 3.01)."""
    doc, _ = plans[name]
    cable = doc.cable
    last = len(doc.shapes) - 1
    offset = np.array([0.003, -0.002, 0.004])
    runs = {}
    for shift, mode in ((offset, "estimate"), (np.zeros(3), "estimate"), (offset, "none")):
        plant = Plant(cable.with_links(100).with_modulus(2 * cable.youngs_modulus), noise=NOISE,
                      n_measured=200, seed=1, clamp=cable.rest_link_length, offset=tuple(shift))
        runs[np.any(shift != 0), mode] = run_closed_loop(
            plant, cable, doc.shapes, doc.grippers, [last // 2], stabilized=_stabilized(doc),
            trajectory=doc.trajectory, offset=mode)
    run, plain = runs[True, "estimate"], runs[False, "estimate"]
    assert runs[True, "none"].refusals or \
        runs[True, "none"].closed_loop_error > 1.15 * run.closed_loop_error
    (correction,) = run.corrections
    model = correction.model
    assert model.offset_estimated and "taken out" in model.offset_note
    assert np.all(np.abs(model.offset - offset) < NOISE)
    assert model.offset_sd < NOISE and correction.uncertainty["offset"] == 0.0
    assert correction.report()["offset"] == pytest.approx(model.offset.tolist())
    assert "measurement offset" in correction.message
    assert abs(run.closed_loop_error - plain.closed_loop_error) < 0.2e-3
    low, high = correction.prediction_interval
    assert low <= run.closed_loop_error <= high
    # no offset: what the held points show is noise, not applied, its size in the interval
    (unshifted,) = plain.corrections
    assert not unshifted.model.offset_estimated
    assert unshifted.uncertainty["offset"] > 0.0 and "does not tell" in unshifted.model.offset_note
    low, high = unshifted.prediction_interval
    assert low <= plain.closed_loop_error <= high


def test_the_offset_is_read_off_the_held_points():
    """measured_offset: the mean of the four held points' residuals, whatever the others do
    (there E, the bias and the clamp length act); its sd from their scatter about it."""
    from dloplan.correct.model_error import measured_offset

    rng = np.random.default_rng(4)
    residual = rng.normal(scale=0.01, size=(21, 3))  # the free points: anything
    held = [0, 1, -2, -1]
    residual[held] = [0.002, -0.001, 0.003]
    offset, sds = measured_offset(residual)
    np.testing.assert_allclose(offset, [0.002, -0.001, 0.003], atol=1e-15)
    assert np.all(sds < 1e-15)
    noise = rng.normal(scale=1e-3, size=(4, 3))
    residual[held] += noise - noise.mean(axis=0)
    offset, sds = measured_offset(residual)
    np.testing.assert_allclose(offset, [0.002, -0.001, 0.003], atol=1e-15)
    assert sds == pytest.approx(np.full(3, np.sqrt(np.sum((noise - noise.mean(axis=0)) ** 2) / 9)
                                        / 2))


def test_the_model_error_fit_and_its_standard_deviations():
    """fit_model_error recovers (delta, alpha) with beta 0 when the data hold no grip, and
    parameter_sds then finds beta within 2 sd of 0 (the clamp stays the model's); an amplitude
    out of its bounds is held there and the others refitted."""
    from dloplan.correct.model_error import fit_model_error, parameter_sds

    rng = np.random.default_rng(3)
    j, d, g = (rng.normal(size=(21, 3)) for _ in range(3))
    noise = rng.normal(size=(21, 3))
    delta, (alpha, beta) = fit_model_error(j, [d, g], 0.3 * j + 0.5 * d + 0.01 * noise)
    assert delta == pytest.approx(0.3, abs=0.01) and alpha == pytest.approx(0.5, abs=0.01)
    left = 0.3 * j + 0.5 * d + 0.01 * noise - delta * j - alpha * d - beta * g
    sds = parameter_sds(j, [d, g], left)
    assert abs(beta) < 2 * sds[2]  # no grip in the data: not significant
    # a clipped amplitude is held at its bound and the others refitted
    delta, (alpha, beta) = fit_model_error(j, [d, g], 0.3 * j - 1.0 * d + 0.2 * g)
    assert alpha == 0.0
    assert beta == pytest.approx(0.2, abs=0.15)


def test_the_warm_service_answers_as_the_command_corrects(plans, monkeypatch, capsys):
    import io

    doc, plan_path = plans["demo"]
    stiffer = doc.cable.with_modulus(2 * doc.cable.youngs_modulus)
    points = _measure(equilibrium(stiffer, _stabilized(doc)[3], doc.grippers.clip_poses(3)).shape)
    service = CorrectionService(doc)
    answers = [service.correct(3, points) for _ in range(2)]
    direct = correct_document(doc, 3, points)
    for answer in answers:
        assert answer["ok"], answer.get("error")
        assert answer["correction"]["youngs_modulus"] == pytest.approx(
            direct.cable.youngs_modulus, rel=1e-9)
        assert answer["program"]["ok"]
    assert service.correct(3, points[:2])["error"].startswith("measured: 2 points")
    # the fast answer: the same remaining motion, without predictions and program check
    fast = service.correct(3, points, predict=False, check_program=False)
    assert fast["ok"] and fast["program"] is None and "predicted_error" not in fast["correction"]
    assert fast["correction"]["clip_corrections"] == answers[0]["correction"]["clip_corrections"]
    assert fast["remaining"] == answers[0]["remaining"]
    lines = [json.dumps({"at": 3, "points": points.tolist()}),
             json.dumps({"at": 3, "points": (1e3 * points).tolist(), "units": "mm"}),
             json.dumps({"at": 3, "points": points.tolist(), "frame_id": "camera_link"}),
             "not json"]
    monkeypatch.setattr("sys.stdin", io.StringIO("\n".join(lines) + "\n"))
    assert main(["correct", str(plan_path), "--serve", "-q"]) == 0
    replies = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["ok"] for r in replies] == [True, True, False, False]
    assert replies[0]["correction"]["youngs_modulus"] == pytest.approx(
        replies[1]["correction"]["youngs_modulus"], rel=1e-6)
    assert "camera_link" in replies[2]["error"]


def test_a_hand_edited_plan_is_refused(plans, tmp_path, capsys):
    """A plan whose recorded (verified) program was edited by hand: refused (exit 2, the field
    named), as verify and export refuse it (issue 36)."""
    doc, plan_path = plans["demo"]
    data = json.loads(plan_path.read_text())
    arms = data["robot"]["program"]["targets"][2]["arms"]
    arms[next(iter(arms))]["joints_deg"][0] += 5.0
    edited = tmp_path / "edited.json"
    edited.write_text(json.dumps(data))
    shapes = tmp_path / "m.csv"
    write_shapes(shapes, [RegisteredShape(_measure(_stabilized(doc)[3]), label="xi_3",
                                          frame_id=doc.frame_id)])
    assert main(["correct", str(edited), "--at", "3", "--measured", str(shapes), "-o",
                 str(tmp_path / "out"), "-q"]) == 2
    assert "edited after dloplan wrote it" in capsys.readouterr().err  # its checksum
    # with the checksum forged too, the recorded program is still checked against the plan
    from dloplan.app.document_file import CHECKSUM, content_checksum

    edited.write_text(json.dumps({**data, CHECKSUM: content_checksum(data)}))
    assert main(["correct", str(edited), "--at", "3", "--measured", str(shapes), "-o",
                 str(tmp_path / "out"), "-q"]) == 2
    assert "plan.robot" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_the_modulus_estimate_is_honest_on_a_shape_it_was_not_tuned_on(plans):
    """The sd(ln E) the correction reports is the scatter of its estimate: the 3D job measured
    at shape 2 (no benchmark row corrects there) on the 100-link plant at E x2, 16 noise draws
    of 1 mm on 200 points. Measured: errors in units of the reported sd have mean +0.04 and sd
    0.77, and 2 sd covers the plant's E 16 times of 16. (At shape 1 the sd is 0.18, the
    Cramer-Rao bound of that measurement with alpha's prior, 0.177: seed 1 of the benchmark
    draws E 1.2 sd low, 0.80 of the plant's, and its correction ends 1.36 times the floor.)"""
    doc, _ = plans["ethernet-3d"]
    cable, at, factor = doc.cable, 2, 2.0
    plant = Plant(cable.with_links(100).with_modulus(factor * cable.youngs_modulus),
                  clamp=cable.rest_link_length)
    shape = run_closed_loop(plant, cable, doc.shapes, doc.grippers, [],
                            stabilized=doc.stabilized).open_loop[at]
    z = []
    for seed in range(16):
        c = correct_plan(cable, doc.shapes, doc.grippers, at,
                         _measure(shape, seed=100 + seed), stabilized=doc.stabilized,
                         grip="known", predict=False, measured_links=100)
        assert not c.model.note and 0.05 < c.model.log_sd < 0.3  # E updated, told to 5-30 %
        z.append(np.log(c.model.youngs_modulus / (factor * cable.youngs_modulus))
                 / c.model.log_sd)
    z = np.array(z)
    assert abs(z.mean()) < 0.5 and 0.5 < z.std(ddof=1) < 1.5
    assert np.sum(np.abs(z) <= 2.0) >= 14


def test_the_early_correction_reaches_the_floor_when_its_offset_is_not_a_false_one(plans):
    """The 3D job corrected at shape 1 (E x2, seed 1, grip known). Shape 1 tells ln E with sd
    0.18-0.2 (its Cramer-Rao bound with alpha's prior: nearly straight), and the target moves
    4.6 mm per unit ln E. This draw ended 1.36 times the floor with E 1.2 sd low: the held
    points' scatter had put a measurement offset of (0.4, 0.5, -0.3) mm at the chi 95 % level
    (their shared error along the clips' axes left out, model_error.offset_covariance) and
    taking it out of a nearly straight shape took the sag E is read from. With the offset's
    covariance it is not applied: E within 1 sd, and the correction ends at the floor (0.99).
    Without noise it reaches the floor estimated or told (E 2.01 times the plan's). Bounds: the
    issue's 1.15 with noise, 1.05 without (measured 1.01)."""
    doc, _ = plans["ethernet-3d"]
    cable, last = doc.cable, len(doc.shapes) - 1
    runs = {}
    for noise, kind in ((NOISE, "estimate"), (0.0, "estimate"), (0.0, "known")):
        plant = Plant(cable.with_links(100).with_modulus(2.0 * cable.youngs_modulus),
                      noise=noise, n_measured=200, seed=1, clamp=cable.rest_link_length)
        model = cable.with_modulus((2.0 if kind == "known" else 1.0) * cable.youngs_modulus)
        runs[noise, kind] = run_closed_loop(plant, model, doc.shapes, doc.grippers, [1],
                                            stabilized=doc.stabilized,
                                            trajectory=doc.trajectory, grip="known",
                                            modulus=kind)
    floor = reachable_error(plant, doc.grippers.clip_poses(last), runs[0.0, "known"].reference,
                            runs[0.0, "known"].open_loop[-1])
    noisy = runs[NOISE, "estimate"].corrections[0].model
    assert not noisy.offset_estimated
    error = np.log(noisy.youngs_modulus / (2.0 * cable.youngs_modulus))
    assert abs(error) < noisy.log_sd and 0.1 < noisy.log_sd < 0.3
    assert runs[NOISE, "estimate"].closed_loop_error <= 1.15 * floor
    exact = runs[0.0, "estimate"].corrections[0].model
    assert abs(np.log(exact.youngs_modulus / (2.0 * cable.youngs_modulus))) < 0.02
    known = runs[0.0, "known"].corrections[0]
    assert known.model.youngs_modulus == 2.0 * cable.youngs_modulus
    assert known.model.log_sd == 0.0 and known.uncertainty["modulus"] == 0.0
    for kind in ("estimate", "known"):
        assert runs[0.0, kind].closed_loop_error <= 1.05 * floor
    low, high = known.prediction_interval
    assert low <= runs[0.0, "known"].closed_loop_error <= high


def test_no_shape_of_the_u_demo_tells_e_while_its_target_depends_on_it(u_demo):
    """Why the U demo's corrections end above the floor (issue 35): the U is bent by the clips,
    not by gravity, so its shapes hardly depend on E/m (the only way E enters statics). The
    shape's mean response to ln E is 0.010-0.013 mm at shapes 1-4 and 0.11 mm at the target:
    with 1 mm of noise on 200 points ln E is told to sd 5-6 at mid-path (the correction keeps
    the plan's E and says why), while a factor 2 in E moves the target by 0.07 mm, about half
    the floor (0.12 mm at E x2)."""
    doc = u_demo[MODEL_LINKS]
    cable, last = doc.cable, len(doc.shapes) - 1
    response = [float(np.mean(np.linalg.norm(equilibrium_sensitivity(
        cable, doc.stabilized[j], doc.grippers.clip_poses(j)).log_modulus, axis=1)))
        for j in range(1, last + 1)]
    assert max(response[: last // 2 + 1]) < 0.02e-3  # shapes 1 .. 4: below 0.02 mm per ln E
    assert response[-1] > 5 * max(response[: last // 2])  # the target depends on E
    plant = Plant(cable.with_links(100).with_modulus(2.0 * cable.youngs_modulus), noise=NOISE,
                  n_measured=200, seed=1, clamp=cable.rest_link_length)
    run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, [last // 2],
                          stabilized=doc.stabilized, grip="known")
    (correction,) = run.corrections
    assert correction.model.log_sd > 3.0  # sd(ln E): the measurement does not tell E
    assert correction.model.youngs_modulus == cable.youngs_modulus
    assert "does not inform E" in correction.model.note


def test_one_correction_cannot_bring_the_u_demos_plants_of_unknown_e_to_their_floors(u_demo):
    """Why no correction of the U demo meets 1.15 times the floor at every E it cannot tell
    (issue 35). Its shapes before the target do not tell E (above), so plants at E x0.5 and x2
    measured with the same noise get the same correction (E kept at the plan's, the same bias
    fitted), and each is compared with its own floor. For any one clip correction p and
    weights w (sum 1), max_k r_k(p) >= sum_k w_k r_k(p) >= B(w) = min_q sum_k w_k r_k(q)
    (shared_floor): with equal weights B = 1.24, so one of the two ends at least 1.24 times its
    floor whatever the correction does (the benchmark's rows: 0.94 and 1.61). Checked too:
    alone, B is the plant's least mean distance, at most its floor (a least-squares fit's mean
    distance: 0.85 at x0.5); a plant given twice is the plant once; the closed loops' ratios
    obey the bound. Bounds: B > 1.15 (the issue's target; measured 1.24), the closed loops'
    larger ratio >= B."""
    doc = u_demo[MODEL_LINKS]
    cable, last = doc.cable, len(doc.shapes) - 1
    clips, reference = doc.grippers.clip_poses(last), doc.stabilized[-1]
    plants, guesses, floors, closed = [], [], [], []
    for factor in (0.5, 2.0):
        plant = Plant(cable.with_links(100).with_modulus(factor * cable.youngs_modulus),
                      noise=NOISE, n_measured=200, seed=1, clamp=cable.rest_link_length)
        run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, [last // 2],
                              stabilized=doc.stabilized, grip="known")
        (correction,) = run.corrections
        assert correction.model.youngs_modulus == cable.youngs_modulus  # E not told: kept
        plants.append(plant)
        guesses.append(run.open_loop[-1])
        floors.append(reachable_error(plant, clips, reference, run.open_loop[-1]))
        closed.append(run.closed_loop_error / floors[-1])
    alone, (ratio,) = shared_floor(plants[:1], clips, reference, guesses[:1], floors[:1])
    assert alone == pytest.approx(ratio) and 0.5 < alone <= 1.0 + 1e-9
    twice, _ = shared_floor(plants[:1] * 2, clips, reference, guesses[:1] * 2, floors[:1] * 2)
    assert twice == pytest.approx(alone, rel=1e-6)
    bound, ratios = shared_floor(plants, clips, reference, guesses, floors)
    assert bound > 1.15
    assert max(ratios) >= bound - 1e-9  # the minimizer is one correction: above the bound
    assert max(closed) >= bound
    with pytest.raises(ValueError, match="weights"):
        shared_floor(plants, clips, reference, guesses, floors, weights=[1.0, -1.0])


def test_shared_floor_is_the_same_from_starts_a_resolution_apart(u_demo):
    """shared_floor's objective is the plants' solves, known only to their resolution (each
    stops at its tolerance, so a start moved by 1e-9 m moves the equilibria by about as much),
    and a sum of distances with a kink where its minimizer brings a point onto the wanted shape
    (the U's middle point). The U demo's plant at E x0.5 (n = 100, clamping the model's link)
    started from its shape at the target clips and from three shapes within 1e-9 m of it: the
    same bound to 1e-6 each time, the ratio at the minimizer the bound (one plant). (L-BFGS-B
    on central differences of the objective, before: four bounds 3.8e-3 apart, each stalled at
    the kink above the minimum; from the study's continuation's start, a failed line search.)"""
    doc = u_demo[MODEL_LINKS]
    cable, last = doc.cable, len(doc.shapes) - 1
    clips, reference = doc.grippers.clip_poses(last), doc.stabilized[-1]
    plant = Plant(cable.with_links(100).with_modulus(0.5 * cable.youngs_modulus),
                  clamp=cable.rest_link_length)
    shape, ok, _ = plant.hold(resample_by_arc_length(reference, 101), clips)
    assert ok
    floor = 6.0e-5  # [m] about the plant's (reachable_error): a scale, any positive one bounds
    rng = np.random.default_rng(3)
    bounds = []
    for moved in (0.0, *(plant.resolution * rng.uniform(-1.0, 1.0, (3, *shape.shape)))):
        bound, (ratio,) = shared_floor([plant], clips, reference, [shape + moved], [floor])
        assert bound == pytest.approx(ratio, rel=1e-12)
        bounds.append(bound)
    assert max(bounds) - min(bounds) <= 1e-6 * min(bounds)


def test_the_parameter_covariance_is_the_scatter_of_the_fit_correlation_included():
    """A known answer: y = c_E J + c_a d + noise with J and d overlapping (both sag-like, as on
    the 3D job's shape 1), fitted with alpha's prior. Over 400 noise draws the fitted (c_E, c_a)
    scatter as parameter_covariance says -- the sds within 10 % and the correlation (about
    -0.9 here) within 0.1 -- which the gain check carries to the target (step._gain_sd)."""
    from dloplan.correct.model_error import fit_model_error, parameter_covariance

    s = np.linspace(0.0, 1.0, 21)
    jacobian = np.stack([0 * s, 0 * s, -np.sin(np.pi * s)], axis=1) * 1e-3
    d = np.stack([0.3 * np.sin(2 * np.pi * s), 0 * s, -np.sin(np.pi * s) ** 2], axis=1) * 1e-3
    prior, noise = (1.6, 0.5), 0.3e-3
    rng = np.random.default_rng(7)
    fits, covariances = [], []
    for _ in range(400):
        y = 0.2 * jacobian + 1.6 * d + rng.normal(scale=noise, size=jacobian.shape)
        step, (alpha,) = fit_model_error(jacobian, [d], y, prior)
        fits.append((step, alpha))
        covariances.append(parameter_covariance(jacobian, [d], y - step * jacobian - alpha * d,
                                                prior))
    fits = np.array(fits)
    predicted = np.mean(covariances, axis=0)
    measured = np.cov(fits.T)
    assert np.allclose(np.sqrt(np.diag(measured)), np.sqrt(np.diag(predicted)), rtol=0.1)
    rho = predicted[0, 1] / np.sqrt(predicted[0, 0] * predicted[1, 1])
    assert rho < -0.5
    assert measured[0, 1] / np.sqrt(measured[0, 0] * measured[1, 1]) == pytest.approx(rho,
                                                                                    abs=0.1)


def test_corrected_early_and_again_the_3d_job_reaches_the_floor(plans):
    """Measured again at mid-path after an early correction (3D job, E x2, seed 1, grip
    known). The second correction is made when it predicts a significant gain, refused (the
    plan as corrected kept) when the first already reached the floor; the closed loop ends at
    the floor either way. (When the first correction ended 1.36 times the floor, from a false
    measurement offset, the second predicted a gain of 0.31 mm and was made only with ln E and
    alpha's correlation in the gain's sd, -0.7: added as if independent it was refused.)
    Bound: 1.05 times the floor (measured 0.99-1.01)."""
    doc, _ = plans["ethernet-3d"]
    cable, last = doc.cable, len(doc.shapes) - 1
    plant = Plant(cable.with_links(100).with_modulus(2.0 * cable.youngs_modulus), noise=NOISE,
                  n_measured=200, seed=1, clamp=cable.rest_link_length)
    run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, [1, last // 2],
                          stabilized=doc.stabilized, trajectory=doc.trajectory, grip="known")
    assert run.corrections[0].at == 1
    assert len(run.corrections) + len(run.refusals) == 2
    assert all("gain" in reason and "the plan is kept" in reason for reason in run.refusals)
    floor = reachable_error(plant, doc.grippers.clip_poses(last), run.reference,
                            run.open_loop[-1])
    assert run.closed_loop_error <= 1.05 * floor
    low, high = run.corrections[-1].prediction_interval
    assert low <= run.closed_loop_error <= high


def test_fitted_on_a_refined_chain_the_u_demos_clips_reach_the_floor_with_e_told(u_demo):
    """Issue 35: the U demo's floor is a tenth of a millimetre (0.115 mm at E x2), and told the
    plant's E the correction fitted on the plan's n = 20 chain plus the measured bias alpha d
    ended 1.40, 1.21, 1.10 times it (seeds 1-3: the chain's prediction of the 100-link cable's
    target is 0.02-0.04 mm off). Fitted on the refined chain (60 links, each gripper clamping 3
    of them, the plan's grip L / n; the share of alpha d the chain resolves, 2 (1 - 1/3), taken
    off) every seed ends closer: 1.26, 1.08, 1.01 (seeds 4-6: 1.03, 1.01, 1.07 for 1.02, 1.10,
    1.20). The corrected plan stays the plan's model: its stored shapes are the n = 20 chain's
    stable equilibria at the corrected clips. Bounds: the issue's 1.15 for the mean of the
    refined fits, above it for the plan's chain (1.24); each refined fit below the plan chain's
    (by 0.09-0.14 of the floor here)."""
    doc = u_demo[MODEL_LINKS]
    cable, last = doc.cable, len(doc.shapes) - 1
    real = cable.with_modulus(2.0 * cable.youngs_modulus)
    ratios = {MODEL_LINKS: [], None: []}
    floor = None
    for seed in (1, 2, 3):
        plant = Plant(real.with_links(100), noise=NOISE, n_measured=200, seed=seed,
                      clamp=cable.rest_link_length)
        for links in ratios:
            run = run_closed_loop(plant, real, doc.shapes, doc.grippers, [last // 2],
                                  stabilized=doc.stabilized, trajectory=doc.trajectory,
                                  grip="known", modulus="known", fit_links=links)
            if floor is None:
                floor = reachable_error(plant, doc.grippers.clip_poses(last), run.reference,
                                        run.open_loop[-1])
            ratios[links].append(run.closed_loop_error / floor)
            (correction,) = run.corrections
            low, high = correction.prediction_interval
            assert low <= run.closed_loop_error <= high
    assert np.mean(ratios[MODEL_LINKS]) > 1.15 >= np.mean(ratios[None])
    assert np.all(np.array(ratios[None]) < np.array(ratios[MODEL_LINKS]))
    assert correction.fit_links == 60 and correction.report()["fit_links"] == 60
    for j, shape in enumerate(correction.equilibria, start=last // 2 + 1):
        assert shape.shape == (cable.n_points, 3)
        settled = equilibrium(correction.cable, shape, correction.grippers.clip_poses(j))
        assert settled.success
        assert np.max(np.linalg.norm(settled.shape - shape, axis=1)) < 1e-6


def test_the_offsets_covariance_holds_the_ends_along_the_clips(plans):
    """A measurement of the model's own shape (the 3D job's shape 1, 1 mm noise on 200 points)
    has no offset. The held points' scatter alone put an offset at the chi 95 % level in 29 %
    of 300 noise draws (their errors along the clips' axes are shared: the smoothed curve starts
    and ends where the first and last points lie, each as noisy as one point); with that shared
    part in the covariance (model_error.offset_covariance) in 5 %, as the level says. Bounds:
    at most 10 % (3 binomial sd above 5 % for 300 draws) with it, more than 15 % without; the
    noise's sd recovered within 5 % (measured 1.01 mm)."""
    from dloplan.correct.measurement import noise_sd
    from dloplan.correct.model_error import measured_offset, offset_covariance

    doc, _ = plans["ethernet-3d"]
    x, u = doc.stabilized[1], doc.grippers.clip_poses(1).u_axes
    scores, plain, sigmas = [], [], []
    for seed in range(300):
        points = _measure(x, seed=seed)
        y = resample_measured(points, x, doc.cable.length)
        offset, sds = measured_offset(y - x)
        sigma = noise_sd(points, y)
        covariance = offset_covariance(sds, u, sigma)
        scores.append(offset @ np.linalg.solve(covariance, offset))
        plain.append(np.sum((offset / sds) ** 2))
        sigmas.append(sigma)
    chi95 = 7.815
    assert np.mean(np.array(scores) >= chi95) <= 0.10
    assert np.mean(np.array(plain) >= chi95) > 0.15
    assert np.mean(sigmas) == pytest.approx(NOISE, rel=0.05)


def test_the_refined_chain_is_the_multiple_of_n_nearest_to_sixty_links():
    """fit_links_for: the multiple k n of the plan's n nearest to FIT_LINKS (60), at least n;
    a count asked for must be a multiple of n (n: the plan's own chain); the refined chain
    resolves alpha_k = 2 (1 - 1/k) of the discretization error (alpha_prior of n against k n)."""
    from dloplan.correct.step import FitModel, fit_links_for

    assert [fit_links_for(n) for n in (6, 12, 20, 30, 50, 100)] == [60, 60, 60, 60, 50, 100]
    assert fit_links_for(20, 20) == 20 and fit_links_for(20, 100) == 100
    fit = FitModel.of(catalogue_cable("ethernet", n_links=20), 60)
    assert fit.clamp_links == 3 and fit.cable.n_links == 60
    assert fit.share == pytest.approx(2.0 * (1.0 - 1.0 / 3.0))
    # each gripper clamps the plan's grip, L / n
    assert fit.cable.rest_link_length * fit.clamp_links == pytest.approx(fit.cable.length / 20)


@pytest.mark.parametrize("mode", ["target", "all"])
@pytest.mark.parametrize("fit_links", [None, MODEL_LINKS])
def test_the_predictions_are_the_equilibria_plus_the_bias_each_evaluated_anew(plans, mode,
                                                                             fit_links):
    """correct_plan evaluates the target's bias once (its directions also feed the gain check):
    the predictions are still the updated model's continuations plus the bias (ModelUpdate.
    bias, each evaluated anew) at each shape, the target's on the fit model (FitModel.predict),
    within what two solves to the solvers' tolerance allow (the continuations' solves start
    warm, the fit chain's target is the clip fit's: _prediction_tolerance), and the bias's
    amplitudes those refined solves started cold give at the updated E to 1e-8 of the bias
    (the modulus fit starts them from the previous E's; they stop at a force residual of
    1e-10 of the cable's force scale, and d is a difference of two shapes a fraction 1 / n
    of their size: 3e-9 here)."""
    from dloplan.correct.model_error import alpha_prior, fit_model_error, model_error_directions
    from dloplan.correct.step import FitModel, fit_links_for
    from dloplan.sim import continuation

    doc, _ = plans["demo"]
    stable, at = _stabilized(doc), 3
    plant = Plant(doc.cable.with_modulus(1.5 * doc.cable.youngs_modulus).with_links(100),
                  clamp=doc.cable.rest_link_length)
    truth, ok, _ = plant.hold(resample_by_arc_length(stable[at], 101),
                              doc.grippers.clip_poses(at))
    assert ok
    result = correct_plan(doc.cable, doc.shapes, doc.grippers, at, _measure(truth, seed=1),
                          stabilized=stable, trajectory=doc.trajectory, mode=mode,
                          fit_links=fit_links)
    m, model = result.model, result.cable
    assert m.discretization > 0.0 and m.youngs_modulus != m.youngs_modulus_before
    clips = [doc.grippers.clip_poses(j) for j in range(at + 1, len(doc.shapes))]
    corrected_clips = [c for c in map(result.grippers.clip_poses,
                                      range(at + 1, len(doc.shapes)))]
    links = fit_links_for(MODEL_LINKS, fit_links)
    fit = FitModel.of(model, links) if links > MODEL_LINKS else None
    for states, poses, predicted in (
            ([eq.shape for eq in continuation(model, m.state, clips)], clips, result.open_loop),
            (result.equilibria, corrected_clips, result.corrected)):
        expected = [x + m.bias(model, x, c) for x, c in zip(states, poses, strict=True)]
        if fit is not None:
            expected[-1] = fit.predict(m, model, states[-1], poses[-1])
        assert np.max(np.abs(np.array(expected) - predicted)) <= _prediction_tolerance(result)
    # the amplitudes from cold-started directions at the updated E
    d, g = model_error_directions(model, m.state, doc.grippers.clip_poses(at),
                                  grip=m.grip != 0.0)
    directions = [d] if g is None else [d, g]
    cold = fit_model_error(np.zeros_like(d), directions, result.measured - m.offset - m.state,
                           alpha_prior(MODEL_LINKS))[1]
    scale = np.max(np.abs(m.bias(model, m.state, doc.grippers.clip_poses(at))))
    assert abs(cold[0] - m.discretization) * np.max(np.abs(d)) < 1e-8 * scale


def _solve_error(cable, shapes):
    """How far a converged equilibrium solve may be from the equilibrium [m], the largest over
    ``shapes`` (near the equilibria of ``cable``): the Newton loop stops once the largest free
    force is below tau (sim.result.residual_tolerance), and a force residual r leaves the shape
    H_ff^-1 r off, |H_ff^-1 r| <= |r|_2 / lambda_min(H_ff) <= sqrt(N) tau / lambda_min (N free
    points). The free Hessian of the model's clamp (one link per gripper) is taken for any
    clamp: a longer clamp's is its principal submatrix, whose lambda_min is no smaller."""
    from dloplan.sim import free_hessian
    from dloplan.sim.result import residual_tolerance

    bound = 0.0
    for x in shapes:
        lowest = np.linalg.eigvalsh(free_hessian(cable, x).toarray())[0]
        assert lowest > 0.0
        tau = residual_tolerance(cable, x=x)
        bound = max(bound, np.sqrt(cable.n_points - 4) * tau / lowest)
    return bound


def _prediction_tolerance(result):
    """The largest change of a prediction [m] that two solves of the same equilibria to the
    solvers' tolerance can make (_solve_error of each chain at the corrected equilibria): a
    prediction is (1 - alpha) x + (alpha - beta) R[y_2] + beta R[y_3] (x the model's
    equilibrium, y_2 and y_3 the refined chain's clamped over 2 and 3 links, R a resampling,
    which does not lengthen a difference), the target's on the fit chain y_k + (alpha -
    alpha_k)(R[y_2] - x) + beta (R[y_3] - R[y_2]); each solved twice (warm and cold) differs by
    up to twice its bound."""
    from dloplan.correct.model_error import clamped_equilibrium, refined_cable
    from dloplan.correct.step import FitModel

    m, model = result.model, result.cable
    poses = [result.grippers.clip_poses(j) for j in range(result.at + 1, result.at + 1
                                                           + len(result.equilibria))]
    fine = refined_cable(model)
    refined = [clamped_equilibrium(fine, resample_by_arc_length(x, fine.n_points), c, 2)[0]
               for x, c in zip(result.equilibria, poses, strict=True)]
    errors = [_solve_error(model, result.equilibria), _solve_error(fine, refined)]
    if result.fit_links > model.n_links:
        fit = FitModel.of(model, result.fit_links)
        errors.append(_solve_error(fit.cable, [fit.hold(result.equilibria[-1], poses[-1]).shape]))
    return 2.0 * (1.0 + 2.0 * abs(m.discretization) + 2.0 * abs(m.grip)) * max(errors)


def _cold_predictions(result, grippers, at, limits):
    """The predictions of a correction evaluated anew, every solve started as before the warm
    starts: the continuations from the measured state with each solve starting from the
    previous equilibrium (sim.continuation), the target's fit-chain equilibrium from the
    model's shape (FitModel.hold), the target's directions solved there; and the gain check's
    verdict on them (None: passed, else the refusal)."""
    from dloplan.correct.model_error import model_error_directions
    from dloplan.correct.step import FitModel, check_gain
    from dloplan.sim import continuation

    m, model, last = result.model, result.cable, grippers.n_shapes - 1
    planned = [grippers.clip_poses(j) for j in range(at + 1, last + 1)]
    corrected_clips = [result.grippers.clip_poses(j) for j in range(at + 1, last + 1)]
    states = [np.array([eq.shape for eq in continuation(model, m.state, poses)])
              for poses in (planned, corrected_clips)]
    if result.mode == "all" and result.equilibria is not None:  # the fit's own states
        states[1] = result.equilibria
    fit = (FitModel.of(model, result.fit_links) if result.fit_links > model.n_links else None)
    out = []
    for shapes, poses in zip(states, (planned, corrected_clips), strict=True):
        biased = [x + m.bias(model, x, c) for x, c in zip(shapes, poses, strict=True)]
        if fit is not None:
            biased[-1] = fit.predict(m, model, shapes[-1], poses[-1])
        out.append(np.array(biased))
    d, g = model_error_directions(model, states[1][-1], corrected_clips[-1], grip=True)
    directions = {"modulus": equilibrium_sensitivity(model, states[1][-1],
                                                     corrected_clips[-1]).log_modulus,
                  "discretization": d, "grip": g}
    try:
        check_gain(out[0][-1], out[1][-1], result.reference[-1], directions, m,
                   limits.gain_significance)
    except CorrectionRefused as exc:
        return out, states[1], str(exc)
    return out, states[1], None


@pytest.mark.parametrize(("job", "factor", "at", "mode", "fit_links"), [
    ("ethernet-3d", 2.0, 3, "target", None), ("ethernet-3d mirrored", 0.5, 2, "target", None),
    ("ethernet-3d", 2.0, 4, "target", 20), ("u12", 10.0, 3, "target", None),
    ("u12", 2.0, 4, "all", None), ("demo", 2.0, 3, "all", None), ("u20", 0.5, 3, "target", 20),
    ("demo", 0.5, -2, "target", None), ("ethernet-3d", 2.0, -2, "all", None)])
def test_warm_started_predictions_agree_with_cold_ones_to_the_solvers_tolerance(
        plans, u_demo, job, factor, at, mode, fit_links):
    """The predictions reuse the clip fit's solves and start the others warm (each continuation
    step from the previous equilibrium moved by the plan's own step; mode "target": the open
    loop's target where the fit started, the corrected target's equilibrium where it ended):
    on jobs, cables, n, E factors, modes and fit chains (refined, fit_links=None, or the plan's)
    these were not tuned on (the sagging demo at n = 12-100 was), the clips and the model update
    are the same bit for bit (decided before any prediction), the predictions agree with cold
    ones (sim.continuation, each target solved anew) within the bound two solves to the solvers'
    residual tolerance allow (_prediction_tolerance: 2-5e-5 m here; the differences seen are
    1e-12 - 1e-10 m), and so does the gain check's verdict; at = -2: the last shape before the
    target (the target alone is left)."""
    if job.startswith("u"):
        doc = u_demo[int(job[1:])]
        cable, shapes, grippers, stable = doc.cable, doc.shapes, doc.grippers, doc.stabilized
    else:
        doc, _ = plans[job.split()[0]]
        cable, shapes, grippers, stable = doc.cable, doc.shapes, doc.grippers, doc.stabilized
        if job.endswith("mirrored"):  # through the vertical plane y = 0
            m = np.diag([1.0, -1.0, 1.0])
            shapes, stable = shapes @ m, stable @ m
            grippers = GripperPath(
                positions=grippers.positions @ m, method=grippers.method, twist=-grippers.twist,
                rotations=tuple(Rotation.from_matrix(m @ r.as_matrix() @ m)
                                for r in grippers.rotations))
    at %= len(shapes)
    plant = Plant(cable.with_modulus(factor * cable.youngs_modulus).with_links(100),
                  clamp=cable.rest_link_length)
    truth, ok, _ = plant.hold(resample_by_arc_length(stable[at], 101), grippers.clip_poses(at))
    assert ok
    limits = CorrectionLimits()
    measured = _measure(truth, seed=2)
    options = dict(stabilized=stable, mode=mode, limits=limits, fit_links=fit_links)
    fast = correct_plan(cable, shapes, grippers, at, measured, predict=False, **options)
    try:
        result = correct_plan(cable, shapes, grippers, at, measured, **options)
    except CorrectionRefused as exc:  # the gain check: the same verdict on cold predictions
        assert str(exc).startswith("gain:")
        _, _, verdict = _cold_predictions(fast, grippers, at, limits)
        assert verdict is not None and ("is lost" in verdict) == ("is lost" in str(exc))
        return
    assert np.array_equal(result.clip_corrections, fast.clip_corrections)
    assert result.model.youngs_modulus == fast.model.youngs_modulus
    assert result.model.discretization == fast.model.discretization
    cold, cold_equilibria, verdict = _cold_predictions(result, grippers, at, limits)
    tolerance = _prediction_tolerance(result)
    assert tolerance < 0.1 * NOISE  # a bound that tells: a tenth of the noise
    assert np.max(np.abs(result.equilibria - cold_equilibria)) <= tolerance
    assert np.max(np.abs(result.open_loop - cold[0])) <= tolerance
    assert np.max(np.abs(result.corrected - cold[1])) <= tolerance
    assert verdict is None  # passed on both
    # not by a gain the tolerance could take (each final error moves by at most the tolerance)
    assert result.open_loop_error[-1] - result.corrected_error[-1] > 2 * tolerance


def test_a_gain_refusal_states_what_2_sd_is(monkeypatch):
    """The gain check's refusal said "a gain of 2.35 mm is within 2 sd (1.73 mm; ...)": the
    number was one sd, and the line read as a contradiction (the unseen-case sweep's
    correction with a shape from another plan). It now names both."""
    monkeypatch.setattr(correct_step, "_gain_sd", lambda *args: 1.73e-3)  # sd of the gain [m]
    reference = np.zeros((5, 3))
    open_loop = reference + [0.0, 0.0, 2.35e-3]   # final error 2.35 mm, corrected 0
    with pytest.raises(CorrectionRefused) as refused:
        correct_step.check_gain(open_loop, reference, reference, {}, None, 2.0)
    message = str(refused.value)
    assert "predicted gain, 2.35 mm" in message
    assert "within 2 sd of zero (2 sd = 3.46 mm, sd 1.73 mm" in message
    assert "the plan is kept" in message


def test_the_modulus_fits_refined_solves_start_where_the_model_moved(plans):
    """update_modulus solves the refined chain (2 n links) once per Gauss-Newton step, each
    started from the previous step's refined equilibrium moved as the model's equilibrium moved
    (the departure R[x_2n] - R[x_n] carried to the new E). Started from the previous E's refined
    shape as it was, the solve after the first step of E x1.5 at n = 100 crawled through 34 and
    20 Newton iterations (the previous E's sag, on stiff axial links); now each takes at most
    6, and the amplitude alpha it gives is the one the refined solves started cold at the
    final E give, to 1e-8 m of the bias (4e-10 m seen)."""
    import dloplan.sim.statics as statics
    from dloplan.correct.model_error import (
        alpha_prior,
        clamped_equilibrium,
        fit_model_error,
        model_error_directions,
    )
    from dloplan.correct.step import update_modulus

    doc, _ = plans["demo"]
    at, cable = 3, doc.cable.with_links(100)
    clips = doc.grippers.clip_poses(at)
    model = equilibrium(cable, resample_by_arc_length(_stabilized(doc)[at], cable.n_points),
                        clips).shape
    plant = cable.with_links(200).with_modulus(1.5 * cable.youngs_modulus)  # clamps L / 100
    truth = clamped_equilibrium(plant, resample_by_arc_length(model, plant.n_points), clips, 2)[0]
    measured = resample_by_arc_length(truth, cable.n_points)
    solves, newton = [], statics.newton_positions

    def counted(x, first, *args):
        out = newton(x, first, *args)
        solves.append((len(x), first, out[1] - args[10]))  # points, first free, iterations
        return out

    statics.newton_positions = counted
    try:
        update = update_modulus(cable, measured, clips, guess=model, discretization=True,
                                grip=True, measured_links=200)
    finally:
        statics.newton_positions = newton
    refined = [it for points, first, it in solves if points == plant.n_points and first == 3]
    assert update.steps >= 2 and len(refined) >= 3
    assert update.youngs_modulus == pytest.approx(1.5 * cable.youngs_modulus, rel=1e-3)
    assert max(refined) <= 6
    d, g = model_error_directions(cable.with_modulus(update.youngs_modulus), update.state, clips,
                                  grip=update.grip != 0.0)
    cold = fit_model_error(np.zeros_like(d), [d] if g is None else [d, g],
                           measured - update.offset - update.state, alpha_prior(100, 200))[1]
    assert abs(cold[0] - update.discretization) * np.max(np.abs(d)) < 1e-8


def test_the_message_names_the_floor_of_the_predicted_final_error(plans, tmp_path):
    """Round 12: on the UR5e pair's plan (E x0.2 measured, `--gain-sd 0`) the line read
    "predicted final error 0.4 mm open loop, 0.9 mm corrected" where the gain line and
    correction.txt's table said 0.35 -> 0.14 mm: the corrected figure was floored at what the
    model could not explain at shape K (docs/correction.md), the open loop's not, so the line
    read as if the correction made the target worse. It gives the corrected prediction's error
    (what the interval is around) and names the floor apart."""
    from dataclasses import replace

    from dloplan.app.correct import measured_points

    doc, _ = plans["demo"]
    at = 3
    shapes_file, _ = _x_half_measurement(doc, tmp_path, at)
    correction = correct_document(doc, at, measured_points(shapes_file, at, doc.frame_id))
    corrected = correction.corrected_error[-1]
    floored = replace(correction, uncertainty={**correction.uncertainty,
                                               "unexplained": corrected + 5e-3})
    line = floored.message
    assert floored.predicted_error == pytest.approx(corrected + 5e-3)
    assert f"{1e3 * corrected:.1f} mm corrected" in line
    assert (f"not below the {1e3 * floored.predicted_error:.1f} mm the model could not explain "
            f"at shape {at}") in line
    low, high = floored.prediction_interval
    assert f"(interval {1e3 * low:.1f} - {1e3 * high:.1f} mm)" in line
    # not floored: no floor named
    plain = replace(correction, uncertainty={**correction.uncertainty, "unexplained": 0.0})
    assert "could not explain" not in plain.message
    assert f"{1e3 * corrected:.1f} mm corrected (interval" in plain.message
