"""`dloplan study` with a ``correction:`` section: closed-loop success beside open loop.

The seam: the closed-loop probability the command prints and stores in summary.json is what
:func:`dloplan.correct.closed_loop_success` computes from the per-sample rows it stores.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from dloplan.cli import main
from dloplan.correct import closed_loop_success
from dloplan.study.spec import StudyError, parse_study

DEMO = Path(__file__).resolve().parent / "data" / "sagging_demo.yaml"


@pytest.mark.parametrize(("section", "field"), [
    ({"at": -1}, "study.correction.at"),
    ({"noise": 1.0}, "study.correction.at"),  # at is required
    ({"at": 2, "noise": -1.0}, "study.correction.noise"),
    ({"at": 2, "tolerance": 0}, "study.correction.tolerance"),
    ({"at": 2, "every": 3}, "study.correction.every"),
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
    expected = closed_loop_success(rows, 4e-3)
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["closed_loop"]["open_loop"] == pytest.approx(list(expected.open_loop))
    assert summary["closed_loop"]["closed_loop"] == pytest.approx(list(expected.closed_loop))
    assert summary["closed_loop"]["trials"] == 3
    printed = capsys.readouterr().out
    assert f"one correction: {expected.message}" in printed
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


def test_the_closed_loop_rows_do_not_depend_on_the_backend():
    from dloplan.app import load_scenario, run_job
    from dloplan.correct import closed_loop_study
    from dloplan.pipeline.stages import settled_shapes
    from dloplan.study import ProcessBackend, draw_samples
    from dloplan.study.spec import CorrectionSpec

    job = load_scenario(DEMO)
    doc = run_job(job, check_robot=False)
    spec = parse_study({"samples": 3, "seed": 4, "parameters": {"youngs_modulus": {"spread": 40}}})
    samples = draw_samples(spec, doc.cable, doc.obstacles)
    correction = CorrectionSpec(at=3, noise=1.0, tolerance=4.0)
    runs = []
    for backend in (None, ProcessBackend(2)):
        runs.append(closed_loop_study(doc.cable, doc.shapes, doc.grippers, samples, correction,
                                      stabilized=settled_shapes(doc), trajectory=doc.trajectory,
                                      backend=backend))
    (serial, serial_success), (parallel, parallel_success) = runs
    assert [r["sample"] for r in parallel] == [0, 1, 2]
    assert json.dumps(parallel) == json.dumps(serial)  # NaN (no estimate) equal to NaN
    assert parallel_success == serial_success
    assert len({r["open_loop_error"] for r in serial}) == 3  # three different plants
