"""Running studies: nominal reproduction, a monotone physical case, resume, file formats."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import spearmanr
from study_cases import ALL_PARAMETERS, hanging_problem, tables_equal

from dloplan.interrupts import kept_of
from dloplan.study import (
    draw_samples,
    evaluate_chunk,
    evaluate_sample,
    parse_study,
    read_table,
    run_study,
)
from dloplan.study.evaluate import OUTCOME_COLUMNS
from dloplan.study.run import chunk_items

PROBLEM = hanging_problem(obstacles=True)


def test_zero_spread_reproduces_the_nominal_result_in_every_sample():
    zero = {name: {"spread": 0.0} for name in ALL_PARAMETERS}
    result = run_study(PROBLEM, {"samples": 6, "chunk_size": 4, "parameters": zero})
    t = result.table
    s = PROBLEM.n_shapes
    assert len(t["sample"]) == 6 * s
    assert np.array_equal(t["shape"], np.tile(np.arange(s), 6))
    assert t["converged"].all() and t["stable"].all() and not t["collision"].any()
    # the warm start is the nominal equilibrium itself: Newton re-converges to it within its
    # force tolerance (1e-10 of the force scale), i.e. far below a micrometre
    assert t["deviation"].max() < 1e-9
    nominal_sag = 0.2 - PROBLEM.nominal[:, :, 2].min(axis=1)
    planned = np.linalg.norm(PROBLEM.nominal - PROBLEM.planned, axis=2).max(axis=1)
    np.testing.assert_allclose(t["sag"], np.tile(nominal_sag, 6), rtol=0, atol=1e-9)
    np.testing.assert_allclose(t["displacement"], np.tile(planned, 6), rtol=0, atol=1e-9)
    assert result.summary.n_success == 6 and result.summary.probability == 1.0
    assert result.summary.sensitivities == ()


def test_sag_falls_as_e_rises_and_e_drives_the_sag_criterion():
    problem = hanging_problem()
    # E alone: the sag of every shape is a strictly decreasing function of E
    only_e = run_study(problem, {"samples": 12, "chunk_size": 6,
                                 "parameters": {"youngs_modulus": {"spread": 50}}})
    t = only_e.table
    for k in range(problem.n_shapes):
        rows = t["shape"] == k
        order = np.argsort(t["youngs_modulus"][rows])
        assert np.all(np.diff(t["sag"][rows][order]) < 0)
    # E among other errors, with a "sag below the nominal sag of the first shape" criterion
    limit_mm = 1e3 * (0.2 - problem.nominal[0, :, 2].min())
    study = {"samples": 40, "chunk_size": 10, "seed": 3,
             "parameters": {"youngs_modulus": {"spread": 50},
                            "mass_per_length": {"spread": 3},
                            "clip_position": {"spread": 0.2}},
             "criteria": {"max_sag": limit_mm, "max_deviation": 100, "target_threshold": 100}}
    result = run_study(problem, study)
    per_sample = result.table["shape"] == 0
    e = result.table["youngs_modulus"][per_sample]
    ok = result.table["sag"].reshape(-1, problem.n_shapes).max(axis=1) <= limit_mm * 1e-3
    high = e > np.median(e)
    assert ok[high].mean() > ok[~high].mean() + 0.5
    summary = result.summary
    assert 0 < summary.n_success < 40 and summary.ranked_by == "failure"
    assert summary.failures == {"stable": 0, "deviation": 0, "collision": 0, "target": 0,
                                "sag": 40 - summary.n_success}
    first = summary.sensitivities[0]
    assert first.parameter == "youngs_modulus"
    # stiffer cables fail less; a failure decided by E alone at a median split would give
    # rho = -sqrt(3)/2 = -0.87, the other errors blur it a little
    assert first.rho_failure < -0.6
    assert spearmanr(e, ok).statistic == pytest.approx(-first.rho_failure)


class Stop(Exception):
    pass


@pytest.mark.parametrize("file_format", ["parquet", "csv"])
def test_interrupted_study_resumes_to_the_same_table(tmp_path, file_format):
    study = {"samples": 20, "chunk_size": 4, "seed": 11,
             "parameters": {"youngs_modulus": {"spread": 30}, "clip_position": {"spread": 1},
                            "obstacle_position": {"spread": 3}}}
    whole = run_study(PROBLEM, study)

    seen = []

    def stop_after_two(progress):
        seen.append(progress.chunk)
        if len(seen) == 2:
            raise Stop

    folder = tmp_path / "study"
    with pytest.raises(Stop) as stopped:
        run_study(PROBLEM, study, out=folder, progress=stop_after_two,
                  file_format=file_format)
    assert kept_of(stopped.value) == (f"the study folder {folder} with 2 of 5 chunks complete "
                                      "(the same command resumes from it)")
    assert sorted(p.name for p in (folder / "chunks").iterdir()) == [
        f"chunk-0000{k}.{file_format}" for k in (0, 1)]
    assert not (folder / f"results.{file_format}").exists()
    lines = []
    resumed = run_study(PROBLEM, study, out=folder, file_format=file_format,
                        progress=lambda p: lines.append(p.line()))
    assert resumed.chunks_resumed == 2 and resumed.chunks_run == 3
    assert lines[0].startswith("chunk 3/5, 12/20 samples")
    assert tables_equal(resumed.table, whole.table)
    manifest = json.loads((folder / "manifest.json").read_text())
    dtypes = {k: v["dtype"] for k, v in manifest["columns"].items()}
    assert tables_equal(read_table(folder / f"results.{file_format}", dtypes), whole.table)
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["n_success"] == whole.summary.n_success
    # a finished study resumed again evaluates nothing
    again = run_study(PROBLEM, study, out=folder, file_format=file_format)
    assert again.chunks_run == 0 and tables_equal(again.table, whole.table)


def test_parquet_carries_units(tmp_path):
    import pyarrow.parquet as pq

    run_study(PROBLEM, {"samples": 3, "parameters": {"youngs_modulus": {"spread": 10}}},
              out=tmp_path)
    schema = pq.read_schema(tmp_path / "results.parquet")
    assert schema.field("youngs_modulus").metadata[b"unit"] == b"Pa"
    assert schema.field("clip_force").metadata[b"unit"] == b"N"
    assert len(schema.metadata[b"fingerprint"]) == 64


def test_another_study_in_the_same_folder_is_refused(tmp_path):
    study = {"samples": 4, "parameters": {"youngs_modulus": {"spread": 10}}}
    run_study(PROBLEM, study, out=tmp_path)
    with pytest.raises(ValueError, match="holds a different study"):
        run_study(PROBLEM, {**study, "seed": 1}, out=tmp_path)
    fresh = run_study(PROBLEM, {**study, "seed": 1}, out=tmp_path, resume=False)
    assert fresh.chunks_run == 1


def test_a_sample_out_of_reach_is_recorded_not_raised():
    # clips 37 cm apart: the free part (6 of 8 links) must span 30.75 cm, which a cable
    # shorter than 41 cm (nominal 50 cm) cannot: those samples are out of reach
    problem = hanging_problem(distances=(0.30, 0.37))
    result = run_study(problem, {"samples": 10, "parameters": {"length": {"spread": 10}}})
    t = result.table
    short = (t["length"] < 0.40) & (t["shape"] == 1)
    assert short.any()
    assert not t["converged"][short].any()
    assert all("out of reach" in m for m in t["message"][short])
    assert np.isnan(t["deviation"][short]).all()
    assert result.summary.failures["stable"] >= short.sum()


@pytest.mark.parametrize("problem", [PROBLEM, hanging_problem(distances=(0.30, 0.37))],
                         ids=["obstacles", "reach"])
def test_a_chunk_is_its_samples_evaluated_one_by_one(problem):
    # the batched chunk (one compiled loop for every sample and shape) against the readable
    # per-sample evaluation through equilibrium(): the same rows bit for bit, refusals
    # (clips out of reach, a cable with a negative mass) and their messages included; a study
    # refuses a spread that draws a negative mass, so two samples' masses are negated here
    study = parse_study({"samples": 24, "seed": 3, "parameters": {
        "youngs_modulus": {"spread": 40},
        "mass_per_length": {"spread": 20, "distribution": "uniform"}, "length": {"spread": 10},
        "clip_position": {"spread": 3}, "clip_orientation": {"spread": 3},
        "obstacle_position": {"spread": 10}}})
    samples = draw_samples(study, problem.cable, problem.obstacles)
    chunk = chunk_items(samples, 24, [0])[0]
    chunk["mass_per_length"][[3, 12]] *= -1.0
    table = evaluate_chunk(problem, chunk)
    params = [name for name in chunk if name != "sample"]
    rows = {name: [] for name in OUTCOME_COLUMNS}
    for j in range(24):
        one = evaluate_sample(problem, {name: float(chunk[name][j]) for name in params})
        for name in OUTCOME_COLUMNS:
            rows[name].extend(one[name])
    reference = {name: np.asarray(rows[name], dtype=table[name].dtype) for name in rows}
    assert tables_equal({name: table[name] for name in OUTCOME_COLUMNS}, reference)
    messages = set(table["message"])
    assert any(m.startswith("sample: mass:") for m in messages)  # the cable cannot be built
    if problem is not PROBLEM:
        assert any("out of reach" in m for m in messages)
    assert table["converged"].sum() > len(table["converged"]) // 2


def _turned(problem, degrees: float):
    """``problem`` turned on the table by ``degrees`` about the vertical through the origin:
    shapes, clips and obstacles (a box turned about its own vertical too)."""
    from dataclasses import replace

    from scipy.spatial.transform import Rotation

    from dloplan.obstacles import Box, Table
    from dloplan.sim.clips import ClipPoses

    turn = Rotation.from_euler("z", degrees, degrees=True)

    def obstacle(o):
        if isinstance(o, Table):
            return o
        assert isinstance(o, Box)
        return replace(o, center=tuple(turn.apply(o.center)), yaw=o.yaw + np.radians(degrees))

    return replace(problem, planned=turn.apply(problem.planned.reshape(-1, 3)).reshape(
        problem.planned.shape), nominal=turn.apply(problem.nominal.reshape(-1, 3)).reshape(
        problem.nominal.shape), clips=tuple(ClipPoses(turn.apply(c.positions), turn * c.rotations)
                                            for c in problem.clips),
        obstacles=tuple(obstacle(o) for o in problem.obstacles))


STUDY_EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "study_m2_ethernet.yaml"


@pytest.mark.parametrize("case", ["example", "box"])
def test_a_job_turned_on_the_table_gets_the_same_samples_turned(case):
    """Round 9: the clip and obstacle offsets were drawn in the world frame, so the same job
    turned 90 deg on the table got other samples (other verdicts and metrics). They are drawn in the
    job's frame on the table: each sample's verdicts and metrics are the same, its offsets
    turned with the job."""
    from scipy.spatial.transform import Rotation

    from dloplan.app import load_scenario, run_job
    from dloplan.app.study import study_problem_of, study_spec
    from dloplan.study import study_frame

    if case == "example":  # the shipped study: the cable along +y, the job frame the world's
        job = load_scenario(STUDY_EXAMPLE)
        problem = study_problem_of(run_job(job, check_robot=False))
        spec = study_spec(job, samples=24)
        assert study_frame(problem.clips[0]).magnitude() == 0.0
    else:  # clips along x, a box and the table; every offset varied
        problem = PROBLEM
        spec = {"samples": 24, "seed": 3, "parameters": {
            name: {"spread": 3.0 if "position" in name else 0.1} for name in ALL_PARAMETERS}}
    turned = _turned(problem, 90.0)
    first, second = run_study(problem, spec), run_study(turned, spec)
    a, b = first.table, second.table
    for name in OUTCOME_COLUMNS:
        if a[name].dtype.kind == "f":
            np.testing.assert_allclose(b[name], a[name], rtol=1e-6, atol=1e-9, err_msg=name)
        else:
            np.testing.assert_array_equal(b[name], a[name], err_msg=name)
    turn = Rotation.from_euler("z", 90.0, degrees=True)
    for prefix, count in (("clip", 2), ("obstacle", len(problem.obstacles))):
        for k in range(count):
            d = [f"{prefix}{k}_d{axis}" for axis in "xyz"]
            np.testing.assert_allclose(np.stack([b[c] for c in d], axis=-1),
                                       turn.apply(np.stack([a[c] for c in d], axis=-1)),
                                       atol=1e-15)
    assert first.summary.n_success == second.summary.n_success
    assert first.summary.n_success not in (0, len(first.samples))  # verdicts that can differ
