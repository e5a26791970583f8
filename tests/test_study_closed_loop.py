"""`dloplan study` with a ``correction:`` section: closed-loop success beside open loop.

The seam: the closed-loop probability the command prints and stores in summary.json is what
:func:`dloplan.correct.closed_loop_success` computes from the per-sample rows it stores.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from dloplan.cli import main
from dloplan.correct import closed_loop_success
from dloplan.study.spec import StudyError, parse_study

# one worker (make test: --dist loadgroup): its module-scoped plan and batch case are made once
pytestmark = pytest.mark.xdist_group("test_study_closed_loop")

DEMO = Path(__file__).resolve().parent / "data" / "sagging_demo.yaml"


@pytest.mark.parametrize(("section", "field"), [
    ({"at": -1}, "study.correction.at"),
    ({"noise": 1.0}, "study.correction.at"),  # at is required
    ({"at": 2, "noise": -1.0}, "study.correction.noise"),
    ({"at": 2, "tolerance": 0}, "study.correction.tolerance"),
    ({"at": 2, "every": 3}, "study.correction.every"),
    ({"at": 2, "method": "fast"}, "study.correction.method"),
])
def test_the_correction_section_is_validated_by_the_study_schema(section, field):
    with pytest.raises(StudyError, match=field.replace(".", r"\.")):
        parse_study({"parameters": {"youngs_modulus": {"spread": 30}}, "correction": section})


def _scenario(tmp_path, correction, samples=3):
    data = yaml.safe_load(DEMO.read_text(encoding="utf-8"))
    data["study"] = {"samples": samples, "seed": 2, "chunk_size": samples,
                     "parameters": {"youngs_modulus": {"spread": 60}},
                     "correction": correction}
    path = tmp_path / "study.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def test_the_study_reports_what_closed_loop_success_computed(tmp_path, capsys):
    scenario = _scenario(tmp_path, {"at": 3, "noise": 1.0, "tolerance": 4.0})
    out = tmp_path / "study"
    assert main(["study", str(scenario), "-o", str(out), "-q", "--csv"]) == 0
    stored = json.loads((out / "closed_loop.json").read_text(encoding="utf-8"))
    rows = stored["rows"]
    assert [r["sample"] for r in rows] == [0, 1, 2]
    assert stored["correction"]["method"] == "linearized"  # the default
    expected = closed_loop_success(rows, 4e-3, method="linearized")
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["closed_loop"]["open_loop"] == pytest.approx(list(expected.open_loop))
    assert summary["closed_loop"]["closed_loop"] == pytest.approx(list(expected.closed_loop))
    assert summary["closed_loop"]["trials"] == 3
    assert summary["closed_loop"]["method"] == "linearized"
    printed = capsys.readouterr().out
    assert f"one correction: {expected.message}" in printed
    assert "closed loop (linearized correction)" in printed
    assert (out / "study_closed_loop.png").exists()
    assert "one correction" in (out / "report.html").read_text(encoding="utf-8")
    # the rows are real closed-loop runs: the samples' E differ, and so do their errors
    assert len({round(r["open_loop_error"], 9) for r in rows}) == 3
    assert all(r["corrections"] == 1 or r["refusal"] for r in rows)


def test_a_checkpoint_at_the_target_is_refused(tmp_path, capsys):
    scenario = _scenario(tmp_path, {"at": 7}, samples=1)
    assert main(["study", str(scenario), "-o", str(tmp_path / "s"), "-q", "--csv"]) == 2
    assert "study.correction.at: got 7, expected a shape 0 .. 6" in capsys.readouterr().err


def test_the_correction_section_does_not_change_the_study_identity():
    """The closed loop runs after the table: changing it keeps the completed chunks."""
    from study_cases import hanging_problem

    from dloplan.study.run import problem_fingerprint

    problem = hanging_problem()
    base = {"samples": 4, "parameters": {"youngs_modulus": {"spread": 30}}}
    plain = problem_fingerprint(problem, parse_study(base))
    corrected = problem_fingerprint(problem, parse_study({**base, "correction": {"at": 1}}))
    other = problem_fingerprint(problem, parse_study({**base, "samples": 5}))
    assert plain == corrected != other


@pytest.mark.parametrize("method", ["linearized", "exact"])
def test_the_closed_loop_rows_do_not_depend_on_the_backend(method):
    from dloplan.app import load_scenario, run_job
    from dloplan.correct import closed_loop_study
    from dloplan.pipeline.stages import settled_shapes
    from dloplan.study import ProcessBackend, draw_samples
    from dloplan.study.spec import CorrectionSpec

    job = load_scenario(DEMO)
    doc = run_job(job, check_robot=False)
    spec = parse_study({"samples": 3, "seed": 4, "parameters": {"youngs_modulus": {"spread": 40}}})
    samples = draw_samples(spec, doc.cable, doc.obstacles)
    correction = CorrectionSpec(at=3, noise=1.0, tolerance=4.0, method=method)
    runs = []
    for backend in (None, ProcessBackend(2)):  # chunks of 2 samples: several tasks a worker
        runs.append(closed_loop_study(doc.cable, doc.shapes, doc.grippers, samples, correction,
                                      stabilized=settled_shapes(doc), trajectory=doc.trajectory,
                                      backend=backend, chunk_size=2))
    (serial, serial_success), (parallel, parallel_success) = runs
    assert [r["sample"] for r in parallel] == [0, 1, 2]
    assert json.dumps(parallel) == json.dumps(serial)  # NaN (no estimate) equal to NaN
    assert parallel_success == serial_success
    assert serial_success.method == method
    assert len({r["open_loop_error"] for r in serial}) == 3  # three different plants


EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "study_m2_ethernet.yaml"


@pytest.fixture(scope="module")
def example_plan():
    from dloplan.app import load_scenario, run_job

    return run_job(load_scenario(EXAMPLE), check_robot=False)


def test_the_linearized_closed_loop_runs_in_chunks_of_a_quarter_of_its_samples(
        example_plan, monkeypatch):
    """Without a chunk size the linearized column cuts its samples into chunks of a quarter of
    them (two tasks for each of two workers) within 16 .. 256, whatever the backend (a chunk's
    rounds cost a fixed share: few large chunks); a chunk size given is kept. The rows are the
    same to the round-off of the chunk's batched sums."""
    from dloplan.correct import closed_loop_study, probability
    from dloplan.correct.probability import linearized_chunk_size
    from dloplan.pipeline.stages import settled_shapes
    from dloplan.study import draw_samples
    from dloplan.study.spec import CorrectionSpec

    assert [linearized_chunk_size(n) for n in (1, 40, 64, 100, 1024, 4096)] == \
        [16, 16, 16, 25, 256, 256]
    doc = example_plan
    spec = parse_study({"samples": 40, "seed": 1,
                        "parameters": {"youngs_modulus": {"spread": 40}}})
    samples = draw_samples(spec, doc.cable, doc.obstacles)
    sizes, chunk = [], probability.linearized_chunk

    def counted(plan, items):
        sizes.append(len(items))
        return chunk(plan, items)

    monkeypatch.setattr(probability, "linearized_chunk", counted)
    runs = [closed_loop_study(doc.cable, doc.shapes, doc.grippers, samples,
                              CorrectionSpec(at=3, noise=1.0, tolerance=4.0),
                              stabilized=settled_shapes(doc), trajectory=doc.trajectory,
                              chunk_size=size)[0] for size in (None, 40)]
    assert sizes == [16, 16, 8, 40]
    for a, b in zip(*runs, strict=True):
        assert a["refusal"] == b["refusal"] and a["corrections"] == b["corrections"]
        assert a["open_loop_error"] == b["open_loop_error"] or np.isnan(b["open_loop_error"])
        assert a["closed_loop_error"] == pytest.approx(b["closed_loop_error"], abs=1e-12,
                                                       nan_ok=True)


@pytest.mark.parametrize("predict_from", [None, 1, 2])
@pytest.mark.parametrize(("plant_links", "clamp"), [(10, 1), (25, 2)])
def test_the_batched_plants_are_plant_hold_stop_by_stop_bit_for_bit(example_plan, plant_links,
                                                                     clamp, predict_from):
    """drive_plants runs Plant.hold's kernels in its order: the same shapes, bit for bit, for
    plants stiffer, softer and heavier than the model, clamping one link or two, each stop
    from the one before or (``predict_from``) from the secant prediction of the two before."""
    import numpy as np

    from dloplan.correct.plant_batch import drive_plants
    from dloplan.geometry import resample_by_arc_length
    from dloplan.sim import interpolate_clips
    from dloplan.study.evaluate import perturbed_cable

    doc = example_plan
    cable, grippers = doc.cable, doc.grippers
    plants = [perturbed_cable(cable, cable.youngs_modulus * e, cable.mass / cable.length * m,
                              cable.length).with_links(plant_links)
              for e, m in ((1.0, 1.0), (0.5, 1.05), (2.0, 0.95))]
    stops = [grippers.clip_poses(0)]
    for j in range(1, grippers.n_shapes):
        stops += interpolate_clips(grippers.clip_poses(j - 1), grippers.clip_poses(j), [0.5, 1.0])
    start = resample_by_arc_length(doc.shapes[0], plant_links + 1)
    count = len(plants)
    drive = drive_plants(plants, [clamp] * count, np.repeat(start[None], count, axis=0),
                         np.repeat(np.array([c.positions for c in stops])[None], count, axis=0),
                         np.repeat(np.array([c.rotations.as_quat() for c in stops])[None], count,
                                   axis=0), gravity=(0.0, 0.0, -9.81),
                         predict_from=predict_from)
    assert list(drive.failed) == [-1] * count
    _assert_held_stop_by_stop(drive, plants, stops, start, cable, clamp, predict_from)


def test_plant_chains_joined_and_taken_drive_as_made_directly(example_plan):
    """PlantChains made once, joined (the clip fit's chain per E across rounds) and taken
    apart (a study's plants for their corrected run): the same constants, so the same shapes
    as drive_plants of the cables, bit for bit."""
    import numpy as np

    from dloplan.correct.plant_batch import PlantChains, drive_chains, drive_plants
    from dloplan.geometry import resample_by_arc_length
    from dloplan.study.evaluate import perturbed_cable

    doc, gravity = example_plan, (0.0, 0.0, -9.81)
    cable, grippers = doc.cable, doc.grippers
    plants = [perturbed_cable(cable, cable.youngs_modulus * e, cable.mass / cable.length,
                              cable.length) for e in (0.5, 1.0, 2.0)]
    joined = PlantChains.join([PlantChains.of(plants[:2], gravity),
                               PlantChains.of(plants[2:], gravity)])
    stops = [grippers.clip_poses(j) for j in range(grippers.n_shapes)]
    start = resample_by_arc_length(doc.shapes[0], cable.n_points)
    positions = np.array([c.positions for c in stops])[None]
    quaternions = np.array([c.rotations.as_quat() for c in stops])[None]
    for index in ([2, 0], [1]):
        count = len(index)
        args = ([1] * count, np.repeat(start[None], count, axis=0),
                np.repeat(positions, count, axis=0), np.repeat(quaternions, count, axis=0))
        got = drive_chains(joined.take(index), *args, gravity=gravity)
        want = drive_plants([plants[i] for i in index], *args, gravity=gravity)
        assert np.array_equal(got.shapes, want.shapes)
        assert list(got.failed) == list(want.failed) == [-1] * count


@pytest.mark.parametrize("axial_modulus", [None, 2.0e9])
def test_plant_chains_at_moduli_are_made_of_the_cables_at_those_moduli_bit_for_bit(
        example_plan, axial_modulus):
    """PlantChains.at_moduli (the clip fit's chain at each sample's E: Cable's properties
    evaluated for all the moduli at once, no cable made) holds every field of PlantChains.of
    of the cables at those moduli, bit for bit: the chains' constants, the tolerance, the
    stiffest spring and the stiff-axial flag; with E_a = E (k_s moves with E) and with an axial
    modulus of its own (k_s kept, stiff_axial from the ratio). A row's cable and chain, made
    when asked for (a saddle's escape), are those of the cable at its E."""
    import numpy as np

    from dloplan.correct.plant_batch import PlantChains
    from dloplan.physics.chain import SpringChain

    cable = example_plan.cable.with_links(3 * example_plan.cable.n_links)
    if axial_modulus is not None:
        cable = replace(cable, axial_modulus=axial_modulus)
    gravity = (0.0, 0.0, -9.81)
    moduli = cable.youngs_modulus * np.array([0.37, 1.0, 2.9, 1.0 / 3.0, 1e-3])
    got = PlantChains.at_moduli(cable, moduli, gravity)
    want = PlantChains.of([cable.with_modulus(e) for e in moduli], gravity)
    assert len(got) == len(want) == len(moduli)
    for name in ("link", "length", "tolerance", "stiff", "stiff_axial"):
        assert np.array_equal(getattr(got, name), getattr(want, name)), name
        assert getattr(got, name).dtype == getattr(want, name).dtype, name
    if axial_modulus is not None:
        assert list(got.stiff_axial) == [True, True, True, True, True]
    for a, b in zip(got.constants, want.constants, strict=True):
        assert np.array_equal(a, b)
        assert a.dtype == b.dtype and a.shape == b.shape
    for b, e in enumerate(moduli):
        assert repr(got.cable(b)) == repr(cable.with_modulus(e)) == repr(want.cable(b))
        made, wanted = got.chain(b, gravity), SpringChain.from_cable(want.cable(b), gravity)
        assert (made.k_axial, made.k_bending, made.contact_stiffness, made.stiff_axial) == \
            (wanted.k_axial, wanted.k_bending, wanted.contact_stiffness, wanted.stiff_axial)
    joined = PlantChains.join([want, got]).take([7, 1])
    assert joined.cable(0).youngs_modulus == moduli[2] and np.isnan(joined.moduli[1])
    assert joined.cable(1) is want.cables[1]


def test_held_chains_are_held_equilibria_bit_for_bit(example_plan):
    """hold_chains (the linearized correction's model at shape K, on chains made once per E)
    is held_equilibria item by item, bit for bit, also for an item the compiled loop hands
    back (clips at the edge of the cable's reach: held_equilibria's equilibrium() refuses it,
    None) and one with no stable equilibrium there."""
    import numpy as np
    from scipy.spatial.transform import Rotation

    from dloplan.correct.plant_batch import PlantChains, hold_chains
    from dloplan.sim.batch import HANDED_BACK, held_equilibria

    doc, gravity = example_plan, (0.0, 0.0, -9.81)
    cable = doc.cable
    moduli = cable.youngs_modulus * np.array([0.5, 1.0, 3.0, 0.8])
    clips = [doc.grippers.clip_poses(j) for j in (1, len(doc.shapes) - 1, 2, 3)]
    positions = np.array([c.positions for c in clips])
    quaternions = np.array([c.rotations.as_quat() for c in clips])
    far = positions[3, 1] - positions[3, 0]  # item 3: clips pulled apart beyond the reach
    positions[3, 1] = positions[3, 0] + far * (1.2 * cable.length / np.linalg.norm(far))
    guesses = np.array([doc.shapes[j] for j in (1, len(doc.shapes) - 1, 2, 3)])
    got = hold_chains(PlantChains.at_moduli(cable, moduli, gravity), guesses, positions,
                      quaternions, gravity=gravity)
    want = held_equilibria([cable.with_modulus(e) for e in moduli], np.arange(4), guesses,
                           positions, Rotation.from_quat(quaternions.reshape(-1, 4)),
                           gravity=gravity)
    assert want.refused[3] and not want.success[3]
    for b in range(4):
        if want.success[b]:
            assert np.array_equal(got[b], want.shapes[b]), b
        else:
            assert got[b] is None, b
    assert sum(x is not None for x in got) == 3
    assert HANDED_BACK < 0


def _assert_held_stop_by_stop(drive, plants, stops, start, cable, clamp, predict_from=None):
    """Plant.hold stop by stop, each from the shape before (from stop ``predict_from`` on, from
    continuation_guess of the two before, ``start`` the one before stop 0), is the drive's."""
    import numpy as np

    from dloplan.correct.plant import Plant, continuation_guess

    for b, plant_cable in enumerate(plants):
        plant = Plant(plant_cable, clamp=cable.rest_link_length)
        assert plant.clamp_links == clamp
        x, before = start, start
        for s, clips in enumerate(stops):
            predicted = predict_from is not None and s >= max(predict_from, 1)
            guess = continuation_guess(x, before) if predicted else x
            before = x
            x, ok, _ = plant.hold(guess, clips, (0.0, 0.0, -9.81))
            assert ok
            assert np.array_equal(drive.shapes[b, s], x), (b, s)


@pytest.mark.parametrize("predict_from", [None, 2])
def test_a_plant_at_a_saddle_is_finished_by_plant_hold(example_plan, monkeypatch, predict_from):
    """A sample the compiled loop hands back (its Newton loop stopped at a saddle: here, made
    to at stop 3) is finished stop by stop by Plant.hold, from the same guesses (the secant
    prediction with ``predict_from``): the same shapes, bit for bit."""
    import numpy as np

    from dloplan.correct import plant_batch
    from dloplan.geometry import resample_by_arc_length
    from dloplan.sim.compiled import SADDLE
    from dloplan.study.evaluate import perturbed_cable

    kernel = plant_batch.drive_clamped

    def stopped_at_a_saddle(*args):
        kernel(*args)
        shapes, done, outcomes = args[-6], args[-5], args[-4]
        done[0], outcomes[0] = 3, SADDLE
        shapes[0, 3:] = np.nan  # what the loop would not have computed

    monkeypatch.setattr(plant_batch, "drive_clamped", stopped_at_a_saddle)
    doc = example_plan
    cable, grippers = doc.cable, doc.grippers
    plants = [perturbed_cable(cable, 0.6 * cable.youngs_modulus, cable.mass / cable.length,
                              cable.length)]
    stops = [grippers.clip_poses(j) for j in range(grippers.n_shapes)]
    start = resample_by_arc_length(doc.shapes[0], cable.n_points)
    drive = plant_batch.drive_plants(
        plants, [1], start[None], np.array([c.positions for c in stops])[None],
        np.array([c.rotations.as_quat() for c in stops])[None], gravity=(0.0, 0.0, -9.81),
        predict_from=predict_from)
    assert list(drive.failed) == [-1]
    _assert_held_stop_by_stop(drive, plants, stops, start, cable, 1, predict_from)


# (E, mass per length, length) factors, none of them used to tune the linearized correction:
# E x0.5 .. x3 and the measurement asking for E beyond the x10 limit either way
AGREEMENT_SAMPLES = [(0.5, 1.0, 1.0), (2.0, 1.0, 1.0), (0.05, 1.0, 1.0), (20.0, 1.0, 1.0),
                     (1.0, 1.0, 1.02), (0.7, 1.05, 1.0), (1.4, 0.95, 1.0), (3.0, 1.0, 0.99),
                     (0.3, 1.0, 1.0), (1.6, 1.0, 1.0)]


def test_the_linearized_closed_loop_agrees_with_the_exact_correction(example_plan):
    """The study's linearized closed loop against correct_plan per sample (the command's
    algorithm), on the study example at K = 3, noise seeds 11-20.

    Tolerances, and why: the plant and its measurement are the same computation (the open
    loop bit for bit, the same refusals of the measurement and of E beyond its limit); the
    derivatives are tabulated along ln E at the plan's clips instead of re-computed at each
    estimate, so E comes out within 1 % and a corrected final error within 0.5 mm (measured
    with the clips fitted on the refined chain: E within 0.06 %, errors within 0.30 mm at E
    x0.3 and x0.5, at most 0.24 mm elsewhere, 2-5 % of the open loop's error; before it, 0.46
    mm at E x3); the gain check compares two numbers that both move with the derivatives, so a
    sample within a few per cent of its threshold may be decided the other way (none of the ten
    now; before the refined chain E x0.5: a gain of 5.16 mm against 2 sd of 5.22 mm).
    """
    import math

    from dloplan.correct.linearized import linearized_rows, nominal_correction
    from dloplan.correct.probability import ClosedLoopPlan, closed_loop_row
    from dloplan.pipeline.stages import settled_shapes
    from dloplan.study.spec import CorrectionSpec

    doc = example_plan
    cable, gravity = doc.cable, (0.0, 0.0, -9.81)
    items = [(index, cable.youngs_modulus * e, cable.mass / cable.length * m, cable.length * l)
             for index, (e, m, l) in enumerate(AGREEMENT_SAMPLES, start=11)]
    stable = settled_shapes(doc)
    nominal = nominal_correction(cable, doc.shapes, doc.grippers, 3, stabilized=stable,
                                 gravity=gravity)
    linearized = linearized_rows(nominal, items, noise=1e-3, n_measured=200)
    plan = ClosedLoopPlan(cable, doc.shapes, doc.grippers, CorrectionSpec(at=3), stable,
                          doc.trajectory, gravity)
    exact = [closed_loop_row(plan, item) for item in items]
    agree = 0
    for a, b in zip(linearized, exact, strict=True):
        assert a["sample"] == b["sample"]
        assert a["open_loop_error"] == b["open_loop_error"]  # the same plant, bit for bit
        if a["corrections"] != b["corrections"]:
            continue
        agree += 1
        if a["corrections"]:
            assert a["youngs_modulus_estimate"] == pytest.approx(b["youngs_modulus_estimate"],
                                                                 rel=0.01)
            assert abs(a["closed_loop_error"] - b["closed_loop_error"]) <= 5e-4
        else:  # refused by both, for the same kind of reason, and run open loop
            assert a["closed_loop_error"] == a["open_loop_error"]
            assert a["refusal"].split(":")[:2] == b["refusal"].split(":")[:2]
            assert math.isnan(a["youngs_modulus_estimate"])
    assert agree >= len(items) - 1
    modulus = [r["refusal"] for r in linearized if "modulus:" in r["refusal"]]
    assert len(modulus) == 2  # E x0.05 and x20: beyond the x10 limit by more than 2 sd


@pytest.mark.parametrize("grip", [True, False])
@pytest.mark.parametrize("held", [False, True])
def test_the_normal_equations_fit_is_the_model_error_fit(example_plan, grip, held):
    """fit_amplitudes (normal equations, a batch of residuals) against fit_model_error and
    parameter_covariance (SVD least squares, one residual each) on the example's directions at
    shape 3 and noisy residuals: equal to 1e-8 relative (round-off of a 3 x 33 system), the
    bounds' clipping included."""
    import numpy as np

    from dloplan.correct.linearized import nominal_correction
    from dloplan.correct.model_error import (
        alpha_prior,
        fit_model_error,
        parameter_covariance,
        standard_deviations,
    )
    from dloplan.correct.normal_fits import fit_amplitudes
    from dloplan.pipeline.stages import settled_shapes

    doc = example_plan
    nominal = nominal_correction(doc.cable, doc.shapes, doc.grippers, 3,
                                 stabilized=settled_shapes(doc), gravity=(0.0, 0.0, -9.81))
    at = nominal.table.at(np.log(doc.cable.youngs_modulus))
    directions = [at["d_k"], at["g_k"]] if grip else [at["d_k"]]
    jacobian = np.zeros_like(at["d_k"]) if held else at["modulus_k"]
    prior = alpha_prior(doc.cable.n_links, 100)
    rng = np.random.default_rng(7)
    residuals = np.array([  # E softer and stiffer, alpha inside and beyond its bounds
        scale * at["modulus_k"] + 1.5 * at["d_k"] * (1 + scale)
        + rng.normal(scale=3e-4, size=jacobian.shape) for scale in (0.2, -0.1, 0.5, -1.2)])
    fits = fit_amplitudes(None if held else jacobian, directions, residuals, prior)
    assert len(fits) == len(residuals)
    for residual, (step, amplitudes, sds, _) in zip(residuals, fits, strict=True):
        want_step, want = fit_model_error(jacobian, directions, residual, prior)
        left = residual - want_step * jacobian - sum(
            c * d for c, d in zip(want, directions, strict=True))
        want_sds = standard_deviations(parameter_covariance(jacobian, directions, left, prior))
        assert step == pytest.approx(want_step, rel=1e-8, abs=1e-12)
        assert amplitudes == pytest.approx(want, rel=1e-8, abs=1e-12)
        assert sds == pytest.approx(want_sds, rel=1e-8, abs=1e-12)


def test_a_measurement_refused_is_refused_alike(example_plan):
    """With 60 mm of noise every measurement is refused (the smoothed shape far longer than
    the cable): the linearized rows are the exact method's, messages included."""
    from dloplan.correct.linearized import linearized_rows, nominal_correction
    from dloplan.correct.probability import ClosedLoopPlan, closed_loop_row
    from dloplan.pipeline.stages import settled_shapes
    from dloplan.study.spec import CorrectionSpec

    doc = example_plan
    cable, gravity, stable = doc.cable, (0.0, 0.0, -9.81), settled_shapes(doc)
    items = [(index, cable.youngs_modulus * e, cable.mass / cable.length, cable.length)
             for index, e in enumerate((0.5, 1.0, 2.0))]
    nominal = nominal_correction(cable, doc.shapes, doc.grippers, 3, stabilized=stable,
                                 gravity=gravity)
    rows = linearized_rows(nominal, items, noise=0.06, n_measured=200)
    plan = ClosedLoopPlan(cable, doc.shapes, doc.grippers, CorrectionSpec(at=3, noise=60.0),
                          stable, doc.trajectory, gravity)
    assert rows == [closed_loop_row(plan, item) for item in items]
    assert all(row["refusal"].startswith("shape 3: measured: the shape is") for row in rows)


def test_the_table_made_node_by_node_when_needed_is_the_whole_table(example_plan):
    """The derivative table makes a node when an estimate first asks for its side beyond the
    nodes made (each from its neighbour): asked near the plan's E it holds a few nodes; asked
    in any order, in another table, after the whole range was made, every value interpolated
    is the same bit for bit."""
    import math

    import numpy as np

    from dloplan.correct.linearized import TABLE_STEP, nominal_correction
    from dloplan.pipeline.stages import settled_shapes

    doc = example_plan
    stable = settled_shapes(doc)

    def table():
        return nominal_correction(doc.cable, doc.shapes, doc.grippers, 3, stabilized=stable,
                                  gravity=(0.0, 0.0, -9.81)).table

    log_e0 = math.log(doc.cable.youngs_modulus)
    asked = log_e0 + np.array([0.3, -0.05, 0.0, 1.1, -0.6, 0.9, 2 * TABLE_STEP, -3.0, 5.0])
    lazy, whole = table(), table()
    assert len(lazy.log_moduli) == 1
    lazy.at(log_e0 + 0.3)
    assert len(lazy.log_moduli) == 3  # node 0, then the two up to 0.3 (2 steps of 0.17)
    whole.at(log_e0 + 10.0)
    whole.at(log_e0 - 10.0)
    assert len(whole.log_moduli) > 20
    names = ("state", "target", "modulus_k", "d_k", "g_t", "d_clips", "fine", "fine_clips")
    for x in asked:
        a, b = lazy.at(x), whole.at(x)
        for name in names:
            assert np.array_equal(a[name], b[name]), (x - log_e0, name)
    assert np.array_equal(lazy.log_moduli, whole.log_moduli)  # asked out to both ends


def test_the_tabulated_clip_derivatives_of_the_bias_are_its_central_differences(example_plan):
    """d d / d p and d g / d p at the target, tabulated from the clip sensitivities of the
    2 n-link equilibria d and g are differences of (their every other point for the arc-length
    resampling R_n), against central differences of model_error_directions at the model's
    equilibria at perturbed clips (1 mm, 10 mrad), each of the 12 clip coordinates: equal to
    2e-3 relative (measured at most 8e-4: the step's second-order error and R_n taken as every
    other point, the links' stretch being that of copper)."""
    import numpy as np

    from dloplan.correct.linearized import nominal_correction
    from dloplan.correct.model_error import model_error_directions
    from dloplan.pipeline.stages import settled_shapes
    from dloplan.sim import equilibrium
    from dloplan.sim.sensitivity import perturbed_clips

    doc, gravity = example_plan, (0.0, 0.0, -9.81)
    stable = settled_shapes(doc)
    nominal = nominal_correction(doc.cable, doc.shapes, doc.grippers, 3, stabilized=stable,
                                 gravity=gravity)
    at = nominal.table.at(np.log(doc.cable.youngs_modulus))
    clips = doc.grippers.clip_poses(len(stable) - 1)

    def directions(p):
        c = perturbed_clips(clips, p)
        x = equilibrium(doc.cable, at["target"], c, gravity=gravity).shape
        return model_error_directions(doc.cable, x, c, grip=True, gravity=gravity)

    for j in range(12):
        step = np.zeros(12)
        step[j] = 1e-3 if j % 6 < 3 else 1e-2
        (d_plus, g_plus), (d_minus, g_minus) = directions(step), directions(-step)
        column = np.eye(12)[j] * nominal.scale  # the table's scaled coordinates
        for name, plus, minus in (("d_clips", d_plus, d_minus), ("g_clips", g_plus, g_minus)):
            want = (plus - minus) / (2.0 * step[j])
            got = (at[name] @ column).reshape(want.shape)
            assert np.linalg.norm(got - want) <= 2e-3 * np.linalg.norm(want), (name, j)


BATCH_SAMPLES = [(e, m, l) for e in (0.3, 0.5, 0.7, 1.0, 1.4, 2.0, 3.0, 6.0)
                 for m, l in ((1.0, 1.0), (1.05, 0.99))]


@pytest.fixture(scope="module")
def batch_case(example_plan):
    """The study example's nominal correction at K = 3 and 16 samples (E x0.3 .. x6, two
    masses and lengths, noise seeds 30-45)."""
    from dloplan.correct.linearized import nominal_correction
    from dloplan.pipeline.stages import settled_shapes

    doc = example_plan
    cable = doc.cable
    items = [(index, cable.youngs_modulus * e, cable.mass / cable.length * m, cable.length * l)
             for index, (e, m, l) in enumerate(BATCH_SAMPLES, start=30)]
    nominal = nominal_correction(cable, doc.shapes, doc.grippers, 3,
                                 stabilized=settled_shapes(doc), gravity=(0.0, 0.0, -9.81))
    return nominal, items


def _assert_same_rows(rows, reference):
    """Sample by sample: the open loop bit for bit, the same decisions and reasons, E to
    1e-9 relative and the closed-loop error to 1e-8 m (:func:`test_the_batched_chunk_is_the_
    per_sample_chunk` says why)."""
    import math

    for a, b in zip(rows, reference, strict=True):
        assert a["sample"] == b["sample"]
        assert a["open_loop_error"] == b["open_loop_error"] or (
            math.isnan(a["open_loop_error"]) and math.isnan(b["open_loop_error"]))
        assert (a["corrections"], a["refusal"]) == (b["corrections"], b["refusal"])
        if a["corrections"]:
            assert a["youngs_modulus_estimate"] == pytest.approx(b["youngs_modulus_estimate"],
                                                                 rel=1e-9)
            assert abs(a["closed_loop_error"] - b["closed_loop_error"]) <= 1e-8
        else:
            assert a["closed_loop_error"] == b["closed_loop_error"] or (
                math.isnan(a["closed_loop_error"]) and math.isnan(b["closed_loop_error"]))


def test_the_batched_chunk_is_the_per_sample_chunk(batch_case):
    """linearized_rows with the chunk's model-update fits, clip fits and gain checks batched
    (the default) against every sample's correction run alone (batched=False), sample by
    sample.

    Tolerances, and why: the batch runs the same algorithm on stacked arrays, whose products
    are summed in another order (round-off, 1e-16 relative); each clip-fit trial is an
    equilibrium solved to the Newton tolerance (1e-10 of the force scale) from a guess that
    differs by that round-off, and the corrected plant's run starts from clips that differ as
    much, so E may move by round-off and a closed-loop error by what the solves' tolerance
    lets through: at most 1e-9 m measured on the bench's 1024 samples, 1e-8 m allowed. The
    decisions and refusals (their numbers printed to 0.01 mm) are the same: a gain check the
    batch cannot vouch for by more than round-off is made by check_gain itself."""
    from dloplan.correct.linearized import linearized_rows

    nominal, items = batch_case
    batched = linearized_rows(nominal, items, noise=1e-3, n_measured=200)
    alone = linearized_rows(nominal, items, noise=1e-3, n_measured=200, batched=False)
    _assert_same_rows(batched, alone)
    assert sum(r["corrections"] for r in alone) >= 3  # clip fits were batched and accepted
    assert any("gain:" in r["refusal"] for r in alone)  # and gain checks refused


def test_a_sample_the_clip_batch_cannot_fit_is_fitted_alone(batch_case, monkeypatch):
    """A sample fit_clips_batch hands back (``fitted`` False, p = 0 at its start: here all
    but the first, as if their normal equations were not finite) is fitted by the per-sample
    loop: the rows are the per-sample path's (with p = 0 kept, the gain check would refuse the
    corrections the per-sample path accepts, at least two of them handed back)."""
    import dloplan.correct.linearized as linearized

    nominal, items = batch_case
    batch = linearized.fit_clips_batch
    handed_back = []

    def every_other(jacobians, fine, moves, starts, *args):
        p, x, fitted = batch(jacobians, fine, moves, starts, *args)
        back = np.arange(len(p)) >= 1
        p[back], x[back], fitted[back] = 0.0, starts[back], False
        handed_back.append(int(np.sum(back)))
        return p, x, fitted

    monkeypatch.setattr(linearized, "fit_clips_batch", every_other)
    rows = linearized.linearized_rows(nominal, items, noise=1e-3, n_measured=200)
    monkeypatch.undo()
    alone = linearized.linearized_rows(nominal, items, noise=1e-3, n_measured=200,
                                       batched=False)
    assert handed_back and handed_back[0] >= 2
    _assert_same_rows(rows, alone)


def _linear_clip_problem(count: int, size: int, k: int, seed: int) -> dict:
    """fit_clips_batch's arguments for a linear model (the fine chain's Jacobian at its every
    k-th point is the fitted one, so a trial's linear guess is its equilibrium) of ``count``
    samples on ``size`` points, no bias motion, reference 0."""
    from dloplan.correct.step import CorrectionLimits

    rng = np.random.default_rng(seed)
    jacobians = rng.normal(size=(count, 3 * size, 12)) * 1e-2
    starts = np.zeros((count, k * (size - 1) + 1, 3))
    fine = np.zeros((count, 3 * len(starts[0]), 12))
    for b in range(count):
        fine[b].reshape(-1, 3, 12)[::k] = jacobians[b].reshape(-1, 3, 12)
    return {"jacobians": jacobians, "fine": fine, "moves": np.zeros_like(jacobians),
            "starts": starts, "bias": rng.normal(size=(count, size, 3)) * 1e-4,
            "reference": np.zeros((size, 3)), "scale": np.ones(12),
            "limits": CorrectionLimits(), "clamp_links": k}


def test_the_clip_batch_leaves_a_sample_it_cannot_fit_and_fits_the_others_alike():
    """fit_clips_batch on a linear model (the equilibrium is the guess): a sample with a
    non-finite Jacobian is not fitted (p = 0 at its start), and the others come out as when
    batched without it, to round-off; each fit ends on the limits' projection or the
    least-squares solution of the linear problem."""
    from dloplan.correct.clip_batch import fit_clips_batch

    problem = _linear_clip_problem(3, 11, 2, 3)
    problem["jacobians"][1, 0, 0] = np.nan

    def solve(index, p, guesses):
        return list(guesses)

    p, x, fitted = fit_clips_batch(**problem, trials=2, solve=solve)
    assert fitted.tolist() == [True, False, True]
    assert np.all(p[1] == 0.0) and np.all(x[1] == problem["starts"][1])
    keep = [0, 2]
    p2, x2, fitted2 = fit_clips_batch(
        **{name: value[keep] if name in ("jacobians", "fine", "moves", "starts", "bias")
           else value for name, value in problem.items()}, trials=2, solve=solve)
    assert fitted2.all()
    np.testing.assert_allclose(p[keep], p2, rtol=1e-12, atol=1e-18)
    for b in keep:  # the linear least-squares fit (no limit reached at these sizes)
        best = np.linalg.lstsq(problem["jacobians"][b], -problem["bias"][b].ravel(),
                               rcond=None)[0]
        np.testing.assert_allclose(p[b], best, rtol=1e-3, atol=1e-9)


def test_a_model_fitted_on_its_own_links_is_corrected_by_the_linearized_loop():
    """A model of 60 links fits its clips on its own chain (k = 1, :func:`~dloplan.correct.step.
    fit_links_for`): the model's chains at shape K and the clip fit's at the same E are kept
    apart (main before branch cl3 stored both under (E, 1) and failed with a KeyError as soon
    as E was updated); both samples, E x0.5 and x2, are corrected, E estimated within x1.5 of
    the truth, and the batched chunk is the per-sample one."""
    import numpy as np
    from scipy.spatial.transform import Rotation

    from dloplan.cable import GRAVITY, catalogue_cable
    from dloplan.correct.linearized import linearized_rows, nominal_correction
    from dloplan.grippers import gripper_path
    from dloplan.shapes import arc_shape, place, straight_shape
    from dloplan.sim import equilibrium

    n = 60
    cable = catalogue_cable("ethernet", n)
    turn = Rotation.from_euler("z", 90, degrees=True)
    path = np.stack([place(straight_shape(cable.length, n), (0.35, -0.25, 0.15), turn)]
                    + [place(arc_shape(cable.length, n, np.radians(a)), (0.3, -0.2, 0.15), turn)
                       for a in (60.0, 120.0)])
    grippers = gripper_path(path, method="auxiliary")
    stable = [equilibrium(cable, s, grippers.clip_poses(j), gravity=GRAVITY).shape
              for j, s in enumerate(path)]
    nominal = nominal_correction(cable, path, grippers, 1, stabilized=stable, gravity=GRAVITY)
    assert nominal.clamp_links == 1
    weight = cable.mass / cable.length
    items = [(0, 0.5 * cable.youngs_modulus, weight, cable.length),
             (1, 2.0 * cable.youngs_modulus, weight, cable.length)]
    rows = linearized_rows(nominal, items, noise=1e-4, n_measured=200)
    alone = linearized_rows(nominal, items, noise=1e-4, n_measured=200, batched=False)
    for row, one, (_, e, _, _) in zip(rows, alone, items, strict=True):
        assert row["corrections"] == one["corrections"] == 1, row["refusal"]
        assert row["closed_loop_error"] < row["open_loop_error"]
        assert 1 / 1.5 < row["youngs_modulus_estimate"] / e < 1.5
        assert row["youngs_modulus_estimate"] == pytest.approx(one["youngs_modulus_estimate"],
                                                               rel=1e-9)
        assert row["closed_loop_error"] == pytest.approx(one["closed_loop_error"], abs=1e-8)


def test_a_rejected_chord_step_ends_the_clip_fit():
    """The linearized clip fit makes CHORD_TRIALS = 1 trial per iteration: the first step
    that raises the cost ends the fit at the point already reached, with no second, more
    damped trial (with the Jacobian frozen the damping after a rejection, about 1e-3 of
    diag(J^T J), leaves the step the same to that share; on the bench's 1024 samples a
    second trial was accepted once). Here the model is linear but the second trial's
    equilibrium is pushed off (its cost rises): the fit solves two equilibria and keeps the
    first step, where a second trial per iteration would have solved a third."""
    from dloplan.correct.clip_batch import fit_clips_batch
    from dloplan.correct.linearized import CHORD_TRIALS

    problem = _linear_clip_problem(1, 11, 2, 5)
    calls = []

    def solve(index, p, guesses):
        calls.append(p.copy())
        return [g + (1e-2 if len(calls) > 1 else 0.0) for g in guesses]

    p, x, fitted = fit_clips_batch(**problem, trials=CHORD_TRIALS, solve=solve)
    assert fitted.all()
    assert len(calls) == 2
    np.testing.assert_array_equal(p[0], calls[0][0])  # the first, accepted step


def test_the_fit_chain_restarted_newton_finds_the_same_equilibria_in_fewer_iterations(
        batch_case):
    """drive_chains(restart=True), the clip-fit trials' Newton loop (an unshifted step after
    every very successful one), against Plant.hold's loop (restart False) on the fit chain of
    the study example at the target, at twelve E between x0.25 and x4, each from the table's
    equilibrium interpolated to its E (as the updated E's first solve starts) moved by the
    table's clip Jacobian for a correction of 2 mm and 1 degree (sd; none for every other one).
    The interpolated guess stretches the stiff axial springs enough that the Hessian is
    indefinite there; the shift climbs to make it definite and, divided by 8 a step, still
    damped the next steps.

    Tolerances, and why: both loops stop at a residual force within the same tolerance (1e-10
    of the force scale), on a chain whose softest mode at the target is about 1e-8 of the
    Hessian's scale (the stiff axial springs), so the two stopping points may differ by that
    residual over that stiffness: at most 2e-8 m measured on the bench's trials, 1e-6 m allowed
    (1e-3 of the 1 mm measurement noise). Fewer iterations: 82 -> 68 here when written (5.0 ->
    4.35 per solve on the bench's 1024 samples)."""
    import math

    from scipy.spatial.transform import Rotation

    from dloplan.correct.plant_batch import PlantChains, drive_chains
    from dloplan.sim.clips import ClipPoses
    from dloplan.sim.sensitivity import perturbed_clips

    nominal, _ = batch_case
    positions, quaternions = nominal.poses
    target = ClipPoses(positions[-1], Rotation.from_quat(quaternions[-1]))
    rng = np.random.default_rng(9)
    cables, starts, moved, quats = [], [], [], []
    for j, factor in enumerate(np.exp(np.linspace(-1.4, 1.4, 12))):
        modulus = nominal.cable.youngs_modulus * factor
        at = nominal.table.at(math.log(modulus))
        p = np.concatenate([rng.normal(size=3) * 2e-3, rng.normal(size=3) * 0.0175] * 2) * (j % 2)
        clips = perturbed_clips(target, p)
        cables.append(nominal.fit_cable.with_modulus(modulus))
        starts.append(at["fine"] + (at["fine_clips"] @ (p * nominal.scale)).reshape(-1, 3))
        moved.append(clips.positions[None])
        quats.append(clips.rotations.as_quat()[None])
    chains = PlantChains.of(cables, nominal.gravity)
    runs = [drive_chains(chains, [nominal.clamp_links] * len(cables), starts, moved, quats,
                         gravity=nominal.gravity, restart=restart) for restart in (False, True)]
    assert list(runs[0].failed) == list(runs[1].failed) == [-1] * len(cables)
    assert np.max(np.abs(runs[0].shapes - runs[1].shapes)) <= 1e-6
    assert np.sum(runs[1].iterations) < 0.9 * np.sum(runs[0].iterations)


def test_the_batched_fits_are_fit_estimate_and_hand_back_a_singular_system(batch_case):
    """fit_estimates (each residual against its own columns, stacked normal equations)
    against fit_estimate one by one: equal to 1e-9 relative (round-off of a p x 33 system),
    a residual whose alpha lies beyond its bound (a bias 20 times the largest) held there
    alike; a batch with a singular system (a zero direction) is handed back whole, for
    fit_estimate's library fit."""
    from dloplan.correct.model_error import BOUNDS, alpha_prior
    from dloplan.correct.normal_fits import columns_of, fit_estimate, fit_estimates

    nominal, _ = batch_case
    prior = alpha_prior(nominal.cable.n_links, nominal.plant_links)
    rng = np.random.default_rng(5)
    cases = []
    for log_e, alpha in ((-0.4, 0.3), (0.0, 0.6), (0.5, 20 * BOUNDS[0][1]), (0.9, 0.1)):
        at = nominal.table.at(float(np.log(nominal.cable.youngs_modulus)) + log_e)
        directions = (at["d_k"], at["g_k"])
        residual = (0.05 * at["modulus_k"] + alpha * at["d_k"] + 0.2 * at["g_k"]
                    + rng.normal(size=at["d_k"].shape) * 1e-4)
        cases.append((at["modulus_k"], directions, residual))

    def batch(cases):
        return fit_estimates(np.array([columns_of(j, d) for j, d, _ in cases]),
                             np.array([r.ravel() for _, _, r in cases]), 1, prior)

    values, final = batch(cases)
    assert final.all()
    for (jacobian, directions, residual), v in zip(cases, values, strict=True):
        np.testing.assert_allclose(v, fit_estimate(jacobian, list(directions), residual,
                                                   prior), rtol=1e-9, atol=1e-15)
    assert values[2][1] == BOUNDS[0][1]  # held at alpha's bound
    jacobian, (d, g), residual = cases[1]
    values, final = batch(cases[:1] + [(jacobian, (np.zeros_like(d), g), residual)])
    assert not final.any()
    assert np.all(np.isfinite(fit_estimate(jacobian, [np.zeros_like(d), g], residual,
                                           prior)))


def test_the_batched_gain_checks_pass_only_what_check_gain_passes():
    """clear_gains against check_gain on random predictions: every correction it passes
    check_gain passes; a correction that gains nothing (corrected = open loop) is never
    passed, and one that reaches the reference exactly is. judged_gains words a refusal only
    as check_gain words it."""
    from dloplan.correct.gain_batch import NAMES, clear_gains, judged_gains
    from dloplan.correct.measurement import CorrectionRefused
    from dloplan.correct.step import ModelUpdate, check_gain, parameter_sds

    rng = np.random.default_rng(7)
    count, size = 40, 11
    reference = rng.normal(size=(size, 3)) * 0.1
    open_loop = reference + rng.normal(size=(count, size, 3)) * 3e-3
    corrected = reference + rng.normal(size=(count, size, 3)) * rng.uniform(
        0.0, 4e-3, size=(count, 1, 1))
    corrected[0], corrected[1] = open_loop[0], reference
    directions = {name: rng.normal(size=(count, size, 3)) * 1e-3 for name in NAMES}
    updates = [ModelUpdate(1e6, 1e6 * float(np.exp(rng.normal() * 0.2)), 0.0, 0.0, 1,
                           reference, discretization=0.3, log_sd=0.1, grip=0.2, grip_sd=0.3,
                           discretization_sd=0.1, correlation=-0.5, log_prior_sd=1.15)
               for _ in range(count)]
    sds = np.array([[parameter_sds(u)[name] for name in NAMES] for u in updates])
    correlation = np.array([u.correlation for u in updates])
    clear = clear_gains(open_loop, corrected, reference, directions, sds, correlation, 2.0)
    assert not clear[0] and clear[1]
    # judged_gains: the same verdicts, and the refusals it words are check_gain's own reasons
    judged, refusals, _ = judged_gains(open_loop, corrected, reference, directions, sds,
                                    correlation, 2.0)
    assert np.array_equal(judged, clear)
    passed = worded = 0
    for b in range(count):
        try:
            check_gain(open_loop[b], corrected[b], reference,
                       {name: directions[name][b] for name in NAMES}, updates[b], 2.0)
            passed += 1
            assert refusals[b] is None
        except CorrectionRefused as exc:
            assert not clear[b]
            if refusals[b] is not None:
                assert refusals[b] == str(exc)
                worded += 1
    assert 2 <= int(np.sum(clear)) <= passed < count
    assert worded >= (count - passed) // 2  # the rest: the clamp check's, or near a threshold


def test_the_fit_chains_first_solve_at_an_updated_e_starts_from_the_tables_cubic(batch_case):
    """The clip fit's first solve at an updated E (the fit chain at the planned target clips)
    starts from the table's equilibria interpolated as a cubic Hermite in ln E, their
    d x / d ln E matched at both nodes (``Interpolated.hermite``), where it started from the
    linear interpolant: at eight E between the nodes, from x0.3 to x3, the cubic start is
    closer to the equilibrium by more than 10x (the interpolation error h^4 f'''' / 384
    against h^2 f'' / 8, h = ln 2 / 4) and the Newton loop needs fewer than half the
    iterations (1.0 against 5.0 per solve on the bench's 1024 samples when written).

    Tolerances, and why: both solves stop at a residual force within the same tolerance, so
    their equilibria may differ by that residual over the chain's softest stiffness (2e-8 m,
    as the restarted loop's test above); 1e-6 m allowed (1e-3 of the 1 mm measurement noise)."""
    import math

    from scipy.spatial.transform import Rotation

    from dloplan.correct.linearized import TABLE_STEP
    from dloplan.correct.plant_batch import PlantChains, drive_chains

    nominal, _ = batch_case
    positions, quaternions = nominal.poses
    log_e0 = math.log(nominal.cable.youngs_modulus)
    logs = log_e0 + TABLE_STEP * (np.arange(-7, 7, 1.75) + 0.4)  # none on a node
    at = [nominal.table.at(x) for x in logs]
    assert all(0.0 < a.w < 1.0 for a in at)
    chains = PlantChains.of([nominal.fit_cable.with_modulus(math.exp(x)) for x in logs],
                            nominal.gravity)
    moved = np.broadcast_to(positions[-1], (len(logs), 1, 2, 3))
    quats = np.broadcast_to(Rotation.from_quat(quaternions[-1]).as_quat(), (len(logs), 1, 2, 4))
    starts = {"linear": [a["fine"] for a in at],
              "cubic": [a.hermite("fine", "fine_modulus") for a in at]}
    runs = {name: drive_chains(chains, [nominal.clamp_links] * len(logs), guesses, moved, quats,
                               gravity=nominal.gravity, restart=True)
            for name, guesses in starts.items()}
    assert all(list(run.failed) == [-1] * len(logs) for run in runs.values())
    solved = runs["linear"].shapes[:, 0]
    assert np.max(np.abs(runs["cubic"].shapes[:, 0] - solved)) <= 1e-6
    off = {name: np.max(np.abs(np.array(guesses) - solved), axis=(1, 2))
           for name, guesses in starts.items()}
    assert np.all(off["cubic"] < 0.1 * off["linear"]), (off["cubic"], off["linear"])
    assert np.sum(runs["cubic"].iterations) < 0.5 * np.sum(runs["linear"].iterations)


def test_the_studys_plants_take_one_equilibrium_per_shape_the_two_substeps_equilibria(
        example_plan):
    """A study's plants follow the clip poses with one equilibrium per planned shape in both
    methods (the exact one's plant is the linearized one's, bit for bit: the agreement test),
    where :class:`Plant` takes two by default: the continuation reaches the same equilibria to
    the solver's tolerance (residual 1e-10 of the force scale: about 2e-8 m on these chains)
    for plants stiffer, softer, heavier and longer than the model."""
    from dloplan.correct import closed_loop_sample
    from dloplan.correct.linearized import SUBSTEPS
    from dloplan.correct.plant import Plant, run_closed_loop
    from dloplan.study.evaluate import perturbed_cable

    assert SUBSTEPS == 1
    doc = example_plan
    cable, gravity = doc.cable, (0.0, 0.0, -9.81)
    for seed, (e, m, length) in enumerate(((3.0, 1.0, 1.0), (0.3, 1.1, 1.0), (1.0, 1.0, 1.02))):
        plant = perturbed_cable(cable, cable.youngs_modulus * e, cable.mass / cable.length * m,
                                cable.length * length)
        runs = {substeps: run_closed_loop(Plant(plant, noise=1e-3, n_measured=200, seed=seed,
                                                substeps=substeps),
                                          cable, doc.shapes, doc.grippers, [], gravity=gravity)
                for substeps in (1, 2)}
        assert np.max(np.abs(runs[1].open_loop - runs[2].open_loop)) < 1e-8
        assert abs(runs[1].open_loop_error - runs[2].open_loop_error) < 1e-9
        row = closed_loop_sample(cable, doc.shapes, doc.grippers, plant, [], noise=1e-3,
                                 seed=seed, gravity=gravity)
        assert row["open_loop_error"] == runs[1].open_loop_error  # the study's plant
