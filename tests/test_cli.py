"""The dloplan command: exit codes, one-line errors, machine-readable output."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from program_readers import check_every_program
from test_scenario import BAD

from dloplan.cli import EXIT_CHECK_FAILED, EXIT_FAILURE, EXIT_OK, EXIT_WARNINGS, main
from dloplan.pipeline.document import cycle_actions

ALONG_Y = {"euler": [0, 0, 90]}  # cables across the YuMi's front, within both arms' reach
STIFF = {
    "cable": {"name": "pa12", "n_links": 10},
    "start": {"kind": "straight",
              "placement": {"position": [0.4, -0.25, 0.2], "rotation": ALONG_Y}},
    "target": {"kind": "arc", "angle": 60,
               "placement": {"position": [0.35, -0.22, 0.25], "rotation": ALONG_Y}},
}


def write(tmp_path, data, name="job.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def test_check_passes_a_stable_job(tmp_path, capsys):
    code = main(["check", str(write(tmp_path, STIFF)), "-q"])
    out = capsys.readouterr().out
    assert code == EXIT_OK, out
    assert "target stability" in out


def test_check_warns_on_an_unstable_target_and_reports_json(tmp_path, capsys):
    soft = {**STIFF, "cable": {"name": "usb", "n_links": 10}}
    code = main(["check", str(write(tmp_path, soft)), "-q", "--json"])
    summary = json.loads(capsys.readouterr().out)
    assert code == EXIT_WARNINGS
    assert summary["warnings"] == 1 and summary["errors"] == 0


def test_check_fails_when_the_target_sits_in_an_obstacle(tmp_path, capsys):
    data = {**STIFF, "obstacles": [{"type": "box", "center": [0.3, 0.0, 0.2],
                                    "size": [0.4, 0.6, 0.4]}]}
    code = main(["check", str(write(tmp_path, data)), "-q"])
    out = capsys.readouterr().out
    assert code == EXIT_FAILURE
    assert "ERROR" in out and "collides" in out


def test_check_refuses_what_plan_refuses_before_planning_ends_closer_than_the_grippers(
        tmp_path, capsys):
    """A target arc of 340 deg holds its clips 27 mm apart, closer than the YuMi's two
    grippers can be (45.1 mm): ``dloplan plan`` refuses it before planning (exit 2), and
    ``dloplan check`` passed it (exit 0, every line ok). It is now an error of the check, the
    same line as the plan's refusal."""
    data = {**STIFF, "target": {**STIFF["target"], "angle": 340}}
    job = str(write(tmp_path, data))
    code = main(["check", job, "-q"])
    lines = capsys.readouterr().out.splitlines()
    assert code == EXIT_FAILURE
    errors = [line for line in lines if line.startswith("ERROR")]
    assert len(errors) == 1 and errors[0].startswith("ERROR   target grip distance: its clips")
    assert main(["plan", job, "-o", str(tmp_path / "out"), "-q"]) == EXIT_FAILURE
    refusal = capsys.readouterr().err
    assert errors[0].split(": ", 1)[1] in refusal


def test_check_says_that_plan_searches_a_placement_when_an_arm_cannot_reach(capsys):
    """Qualitative test 1 as shipped: its start is out of the left arm's reach where it lies,
    and dloplan plan places the job elsewhere on the table (its file allows it: exit 0); the
    check says so."""
    example = Path(__file__).resolve().parents[1] / "examples" / "qualitative1_curved_pa12.yaml"
    assert main(["check", str(example), "-q"]) == EXIT_FAILURE
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("ERROR"))
    assert "start robot reach: the left arm cannot reach" in line
    assert line.endswith("dloplan plan will search where on the table to turn and shift the "
                         "job so that both arms reach, and move it there if the job allows it "
                         "(repair: {placement: true} or --allow-placement; docs/repair.md)")


@pytest.mark.parametrize("command", ["check", "plan"])
def test_a_plan_document_given_as_a_job_points_to_verify(tmp_path, capsys, command):
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps({"format": "dloplan-plan", "version": 2, "units": "m",
                                "cable": {}, "shapes": []}))
    output = ["-o", str(tmp_path / "out")] if command == "plan" else []
    code = main([command, str(plan), "-q", *output])
    err = capsys.readouterr().err.strip()
    assert code == EXIT_FAILURE
    assert len(err.splitlines()) == 1 and "a plan document" in err and "dloplan verify" in err
    assert "version" not in err and not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "content, fragment",
    [
        ("[1, 2]", "expected a mapping"),
        ("cable: {name: copper}\nstart: {kind: straight}\ntarget: {kind: straight}", "copper"),
    ],
)
def test_bad_scenarios_exit_2_with_one_line(tmp_path, capsys, content, fragment):
    path = tmp_path / "bad.yaml"
    path.write_text(content)
    assert main(["check", str(path)]) == EXIT_FAILURE
    err = capsys.readouterr().err.strip()
    assert fragment in err and len(err.splitlines()) == 1


def test_schema_and_cables(capsys):
    assert main(["schema"]) == EXIT_OK
    assert json.loads(capsys.readouterr().out)["title"] == "dloplan scenario"
    assert main(["cables"]) == EXIT_OK
    assert "k_b [N m]" in capsys.readouterr().out


def test_version_is_the_installed_packages(capsys):
    """``dloplan --version`` prints ``dloplan.__version__``, which the package metadata (read
    by setuptools from that attribute) repeats: one version, written once."""
    from importlib.metadata import version

    import dloplan

    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"dloplan {dloplan.__version__}"
    assert version("dloplan") == dloplan.__version__


EXAMPLES = sorted(p for p in (Path(__file__).parents[1] / "examples").glob("*.yaml")
                  if not p.name.startswith(("identify", "harness_")) or
                  p.name == "harness_phase1_obstacle.yaml") + sorted(
    (Path(__file__).parents[1] / "examples" / "cells").glob("*.yaml"))

PROGRAM_FILES = {"rapid": "DloPlanL.mod", "urscript": "dloplan_left.script",
                 "ur_rtde": "dloplan_ur_pair.py",
                 "ros_joints": "dloplan_left_joint_trajectory.yaml"}
"""A file each robot program format writes into its folder."""


DRAWN_EXAMPLE = "harness_phase1_obstacle"
"""The example whose end-to-end test draws its figures: the one with an obstacle and the table,
so its path and stabilized figures draw the obstacle's edges and the table. The plan figures are
five functions of the plan's arrays, with no branch for an example; drawn for each example
they were about a tenth of the suite's CPU (docs/performance.md, branch tt7). They are tested
as figures in test_plan_document (every figure of a plan, read back), test_figure_workers (the
workers' drafts and repairs), test_report (the page in a browser) and the harness job's outputs
below."""


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.stem)
def test_every_example_plans_end_to_end(tmp_path, capsys, example):
    out = tmp_path / "out"
    drawn = example.stem == DRAWN_EXAMPLE
    code = main(["plan", str(example), "-o", str(out), "-q", "--json",
                 *([] if drawn else ["--no-figures"])])
    summary = json.loads(capsys.readouterr().out)
    written = {Path(p).name for p in summary["written"]}
    assert {"plan.json", "report.html"} <= written
    assert ("planned_path.png" in written) == drawn
    programs = (yaml.safe_load(example.read_text()).get("robot") or {}).get("programs",
                                                                             ["rapid"])
    # every example passes its robot program's checks, repaired when needed (docs/repair.md)
    assert code in (EXIT_OK, EXIT_WARNINGS), summary
    assert summary["ok"] is True
    assert all((out / p / PROGRAM_FILES[p]).exists() for p in programs), programs
    assert "trajectory.csv" in written
    from dloplan.app import read_plan

    doc = read_plan(out / "plan.json")
    n_shapes = yaml.safe_load(example.read_text())["planner"]["n_shapes"] + 2
    assert doc.shapes.shape[0] == n_shapes
    lengths = np.linalg.norm(np.diff(doc.shapes, axis=1), axis=2).sum(axis=1)
    assert np.allclose(lengths, doc.cable.length, rtol=0.03)  # sane: every shape near L
    assert doc.trajectory.duration > 0
    # every planned gripper action is in every program the cell takes (parsed back)
    assert set(check_every_program(doc, out)) >= set(programs)


BAD_FILES = [
    ("cable: {name: usb}\nstart: {kind: straight}\n", "target: Field required"),
    ("cable: {name: usb}\nstart: {kind: straight}\ntarget: {kind: points, points: [[0, 0, 0], "
     "[2, 0, 0], [3, 0, 0]]}\n", "target: the shape is 3 m long but the cable is 0.5 m"),
    ("cable: {name: usb}\nstart: {kind: straight}\ntarget: {kind: points, points: [[0, 0, 0], "
     "[250, 0, 0], [500, 0, 0]]}\n", "millimetres"),
    ("cable: {name: usb}\nstart: {kind: straight}\ntarget: {kind: straight}\nobstacles:\n"
     "  - {type: box, center: [0.25, 0, 0], size: [0.6, 0.2, 0.2]}\n", "collides"),
    ("cable: {name: usb, length: -1}\nstart: {kind: straight}\ntarget: {kind: straight}\n",
     "cable.length"),
    ("not: [a, scenario", "not valid YAML"),
]


@pytest.mark.parametrize("content, fragment", BAD_FILES)
def test_bad_plans_exit_2_and_write_nothing(tmp_path, capsys, content, fragment):
    path = tmp_path / "bad.yaml"
    path.write_text(content)
    out = tmp_path / "out"
    code = main(["plan", str(path), "-o", str(out)])
    captured = capsys.readouterr()
    assert code == EXIT_FAILURE
    assert fragment in captured.err + captured.out
    assert not out.exists() or not any(out.iterdir())


def test_export_formats_from_a_plan(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["plan", str(write(tmp_path, {**STIFF, "outputs": ["json"]})), "-o", str(out),
                 "-q"]) in (EXIT_OK, EXIT_WARNINGS)
    plan_json = out / "plan.json"
    for fmt, target in (("csv", "t.csv"), ("ros", "t.yaml"), ("rapid", "rapid"),
                        ("json", "copy.json")):
        assert main(["export", str(plan_json), "--format", fmt, "-o", str(tmp_path / target),
                     "-q"]) == EXIT_OK
    assert (tmp_path / "rapid" / "DloPlanR.mod").exists()
    assert "positions in m" in (tmp_path / "t.csv").read_text().splitlines()[0]


def test_no_figures_draws_none_and_writes_the_report_without_them(tmp_path, capsys,
                                                                  monkeypatch):
    """``plan --no-figures`` on a job asking for figures and a report: no figure is drawn (no
    figure process started, nothing drawn in the run), no ``figures/`` folder, the report
    without figures; the plan and its program are written. The batch mode passes it on."""
    import dloplan.app.figure_workers
    import dloplan.app.report
    import dloplan.plots.worker
    from dloplan.app.files import plan_file

    def forbidden(*args, **kwargs):
        raise AssertionError("a figure was drawn or a figure process started")

    monkeypatch.setattr(dloplan.plots.worker, "start_server", forbidden)
    monkeypatch.setattr(dloplan.app.figure_workers, "FigureWorkers", forbidden)
    monkeypatch.setattr(dloplan.app.report, "figure_drawings", forbidden)
    job = write(tmp_path, {**STIFF, "planner": {"n_shapes": 2},
                           "outputs": ["json", "rapid", "figures", "report"]})
    out = tmp_path / "out"
    assert main(["plan", str(job), "-o", str(out), "-q", "--no-figures"]) in (EXIT_OK,
                                                                               EXIT_WARNINGS)
    assert sorted(p.name for p in out.iterdir()) == ["plan.json", "rapid", "report.html"]
    page = (out / "report.html").read_text()
    assert "verdict: ok" in page and "<figure>" not in page
    result = plan_file({"output": str(tmp_path / "batch"), "verify": False,
                        "figures": False}, str(job))
    assert result.code in (EXIT_OK, EXIT_WARNINGS), result.line
    assert result.folder == str(tmp_path / "batch" / "job")  # what a batch's --json names
    assert not (tmp_path / "batch" / "job" / "figures").exists()
    assert (tmp_path / "batch" / "job" / "report.html").exists()


def test_a_job_without_figures_starts_no_figure_process(tmp_path, capsys, monkeypatch):
    """A job whose ``outputs`` draw nothing (no ``figures``, no ``report``) starts no figure
    workers' server: the command reads the job file before it imports the planner and starts
    the server only for a job that may draw (it used to start it for every ``plan`` without
    ``--no-figures``: matplotlib imported for nothing). Its files are written as before."""
    import dloplan.plots.worker

    def forbidden(*args, **kwargs):
        raise AssertionError("the figure server was started for a job that draws nothing")

    monkeypatch.setattr(dloplan.plots.worker, "start_server", forbidden)
    job = write(tmp_path, {**STIFF, "planner": {"n_shapes": 2}, "outputs": ["json", "rapid"]})
    out = tmp_path / "out"
    assert main(["plan", str(job), "-o", str(out), "-q"]) in (EXIT_OK, EXIT_WARNINGS)
    assert sorted(p.name for p in out.iterdir()) == ["plan.json", "rapid"]


@pytest.mark.parametrize(("outputs", "draws"), [
    (None, True), (["json", "report"], True), (["figures"], True), (["json", "csv"], False),
    ([], False), ("json", True), ([["json"]], True)])
def test_which_job_files_may_draw_figures(outputs, draws):
    """Read before validation: only a list of output names without ``figures`` and ``report``
    draws nothing; no ``outputs:`` means the default outputs (figures among them), and what
    is not a list of names is left to the validation (which refuses it) as one that may."""
    from dloplan.app.schema import DEFAULT_OUTPUTS
    from dloplan.io.job_file import draws_figures, may_draw_figures

    data = dict(STIFF) if outputs is None else {**STIFF, "outputs": outputs}
    assert may_draw_figures(data) is draws
    assert draws_figures(DEFAULT_OUTPUTS)


def test_the_plan_command_leaves_numpy_testing_and_f2py_unrun(tmp_path):
    """``dloplan plan`` makes ``numpy.testing`` and ``numpy.f2py`` lazy before scipy's import
    (``dloplan.lazy_modules``): scipy's namespace clone finds them without running them (they
    used to be imported by every command, with unittest and f2py's Fortran parser), and they
    still work when used. A scenario's plan imports neither the harness package nor the
    study's sampling, backends, run and summary (imported where a harness job or a study needs
    them), nor scipy.interpolate and scipy.optimize (the program's joint spline is dloplan's
    own: dloplan.robot.joint_spline)."""
    import subprocess
    import sys

    job = write(tmp_path, {**STIFF, "planner": {"n_shapes": 2}, "outputs": ["json"]})
    code = ("import sys\n"
            "from dloplan.cli import main\n"
            f"code = main(['plan', {str(job)!r}, '-o', {str(tmp_path / 'out')!r}, '-q'])\n"
            "ran = [m for m in ('numpy.testing._private.utils', 'numpy.f2py.crackfortran',"
            " 'unittest', 'dloplan.harness', 'dloplan.study.sampling', 'dloplan.study.backends',"
            " 'dloplan.study.run', 'dloplan.study.summary', 'scipy.interpolate', 'scipy.optimize',"
            " 'scipy.spatial.transform')"
            " if m in sys.modules]\n"
            "import numpy\n"
            "numpy.testing.assert_allclose(1.0, 1.0)\n"
            "print(code, ran, callable(numpy.f2py.run_main))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    exit_code, rest = done.stdout.strip().splitlines()[-1].split(" ", 1)
    assert int(exit_code) in (EXIT_OK, EXIT_WARNINGS)
    assert rest == "['scipy.spatial.transform'] True"


def assert_the_whole_harness_job(out, figures=True):
    """A harness job's outputs in ``out``: its four phases timed in plan.json, the RAPID
    modules, the report and the force figures (none with ``figures`` False: ``--no-figures``);
    the regrasp in the slots and the planned waits in the RAPID modules and the ROS 2
    trajectories (parsed back against plan.json's cycle)."""
    from dloplan.app import read_plan

    assert (out / "rapid" / "DloPlanL.mod").exists() and (out / "report.html").exists()
    assert (out / "figures" / "forces_phase2.png").exists() == figures
    doc = read_plan(out / "plan.json")
    assert set(doc.harness["phase_times"]) == {"phase1", "phase2", "insertion", "tensioning"}
    assert [a.name for a in cycle_actions(doc.cycle)] == ["grasp", "regrasp", "release"]
    assert check_every_program(doc, out) == ["rapid", "ros_joints"]


@pytest.mark.parametrize("name", ["usb", "ethernet"])  # the PU hose's: the verified test below
def test_a_harness_scenario_runs_the_whole_job(tmp_path, capsys, name):
    """Every output but the figures, which the PU hose's verified job below draws (the harness
    figures are functions of the plan's arrays, with no branch for a job; drawn for each job
    they were about 3 s of CPU each, docs/performance.md, branch tt10)."""
    example = Path(__file__).parents[1] / "examples" / f"harness_{name}.yaml"
    out = tmp_path / "out"
    code = main(["plan", str(example), "-o", str(out), "-q", "--json", "--no-figures"])
    summary = json.loads(capsys.readouterr().out)
    assert code in (EXIT_OK, EXIT_WARNINGS) and summary["ok"]
    assert set(summary["harness"]["phase_times"]) == {"phase1", "phase2", "insertion",
                                                      "tensioning"}
    assert_the_whole_harness_job(out, figures=False)


def test_a_harness_job_writes_the_outputs_it_asks_for(tmp_path, capsys):
    """``outputs: [json]`` in a harness file writes plan.json and nothing else (the harness
    job used to write its figures, report and program whatever the file asked)."""
    data = yaml.safe_load((Path(__file__).parents[1] / "examples" / "harness_usb.yaml")
                          .read_text())
    data["outputs"] = ["json"]
    job = tmp_path / "harness.yaml"
    job.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    assert main(["plan", str(job), "-o", str(out), "-q"]) in (EXIT_OK, EXIT_WARNINGS)
    assert sorted(p.name for p in out.iterdir()) == ["plan.json"]


def test_batch_mode_plans_several_files_on_two_workers(tmp_path, capsys):
    examples = Path(__file__).parents[1] / "examples"
    files = [str(examples / "m2_uniform_curvature_pa12.yaml"), str(tmp_path / "bad.yaml")]
    (tmp_path / "bad.yaml").write_text("cable: {name: copper}\n")
    code = main(["plan", *files, "-o", str(tmp_path / "out"), "--workers", "2", "-q"])
    out = capsys.readouterr().out
    assert code == EXIT_FAILURE  # the worst of the batch
    assert "planned 2 scenarios: 1 ok" in out or "1 with warnings" in out
    assert (tmp_path / "out" / "m2_uniform_curvature_pa12" / "plan.json").exists()
    assert not (tmp_path / "out" / "bad").exists()


def test_a_batch_counts_a_skipped_identification_file_as_skipped(tmp_path, capsys):
    """An identification file in a batch is skipped (exit 1, pointing to ``dloplan
    identify``); the summary counted it "with warnings", as if it had been planned. It is
    counted from what the batch did with the file, not from its status line's text: a job
    file whose name ends as that line does was counted skipped, and "-1 with warnings"."""
    examples = Path(__file__).parents[1] / "examples"
    (tmp_path / "bad.yaml").write_text("cable: {name: copper}\n")
    odd = write(tmp_path, {**STIFF, "planner": {"n_shapes": 1}, "outputs": ["json"]},
                "skipped (an identification file: use dloplan identify).yaml")
    code = main(["plan", str(examples / "identify_ethernet.yaml"), str(tmp_path / "bad.yaml"),
                 str(odd), "-o", str(tmp_path / "out"), "-q", "--no-verify"])
    out = capsys.readouterr().out
    assert code == EXIT_FAILURE
    assert ("planned 3 scenarios: 1 ok, 0 with warnings, 0 failed a check, 1 could not be "
            "planned, 1 skipped (identification files: dloplan identify)") in out


def test_a_batch_with_json_prints_json(tmp_path, capsys):
    """``plan A B --json`` printed the text summary (sweep round 10): every command's
    ``--json`` is a machine-readable summary on stdout. The batch's is each file's exit code,
    folder and status line in the files' order (the workers finish in any order), the counts
    and the batch's exit code (the worst of its files); a
    bad file's line names the file once (it read "bad.yaml: error: bad.yaml: ...")."""
    examples = Path(__file__).parents[1] / "examples"
    bad = write(tmp_path, {**STIFF, "cable": {"name": "pa12", "n_links": 3}}, "bad.yaml")
    good = write(tmp_path, {**STIFF, "planner": {"n_shapes": 1}, "outputs": ["json"]})
    ident = str(examples / "identify_ethernet.yaml")
    code = main(["plan", ident, str(bad), str(good), "-o", str(tmp_path / "out"), "-q",
                 "--no-verify", "--json", "--workers", "2"])
    summary = json.loads(capsys.readouterr().out)
    assert code == EXIT_FAILURE == summary["exit_code"]
    assert [f["path"] for f in summary["files"]] == [ident, str(bad), str(good)]
    assert [f["exit_code"] for f in summary["files"]] == [EXIT_WARNINGS, EXIT_FAILURE, EXIT_OK]
    assert [f["skipped"] for f in summary["files"]] == [True, False, False]
    assert summary["files"][2]["folder"] == str(tmp_path / "out" / "job")
    assert summary["files"][1]["folder"] is None
    assert summary["files"][1]["line"] == (f"{bad}: error: cable.n_links: Input should be "
                                           "greater than or equal to 4 (got 3)")
    assert {k: summary[k] for k in ("ok", "warnings", "failed_check", "not_planned",
                                     "skipped")} == {"ok": 1, "warnings": 0, "failed_check": 0,
                                                     "not_planned": 1, "skipped": 1}


def test_a_batch_plans_into_the_folder_that_holds_its_files(tmp_path, capsys):
    """``plan jobs/a.yaml jobs/b.yaml -o jobs`` was refused, "-o jobs: it would replace
    jobs/a.yaml, an input of this command" (sweep round 10), though a batch replaces only
    ``jobs/a/`` and ``jobs/b/`` and leaves the job files beside them. A batch folder that holds
    an input is still refused, naming it; a single plan replaces ``-o`` whole, as before."""
    quick = {**STIFF, "planner": {"n_shapes": 1}, "outputs": ["json"]}
    jobs = tmp_path / "jobs"
    jobs.mkdir()
    files = [str(write(jobs, quick, "a.yaml")), str(write(jobs, quick, "b.yaml"))]
    assert main(["plan", *files, "-o", str(jobs), "-q", "--no-verify"]) == EXIT_OK
    assert sorted(p.name for p in jobs.iterdir()) == ["a", "a.yaml", "b", "b.yaml"]
    assert (jobs / "a" / "plan.json").exists() and (jobs / "b" / "plan.json").exists()
    capsys.readouterr()
    inside = write(jobs / "a", quick, "a.yaml")  # the batch would replace jobs/a/
    assert main(["plan", str(inside), files[1], "-o", str(jobs), "-q"]) == EXIT_FAILURE
    assert (f"-o {jobs}: the batch's folder {jobs / 'a'}: it would replace {inside}, an input "
            "of this command") in capsys.readouterr().err
    assert main(["plan", files[0], "-o", str(jobs), "-q"]) == EXIT_FAILURE
    assert f"-o {jobs}: it would replace {files[0]}" in capsys.readouterr().err
    assert inside.exists() and (jobs / "b" / "plan.json").exists()


def test_a_batch_whose_files_share_a_name_is_refused_before_any_plan(tmp_path, capsys):
    """Two files of one name in two folders (or one file twice) would be planned into one
    ``OUT/<stem>/``: the second plan replaced the first one's files after the first status line
    had named them (on two workers the second was refused by the first one's lock). Refused at
    once, exit 2, nothing written, the line naming both files, the folder and what is
    expected."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    first = write(tmp_path / "a", STIFF)
    second = write(tmp_path / "b", {**STIFF, "cable": {"name": "usb", "n_links": 10}})
    out = tmp_path / "out"
    for files in ([first, second], [first, tmp_path / "b" / ".." / "a" / "job.yaml"],
                  [first, write(tmp_path, STIFF, "job.json")]):
        code = main(["plan", *map(str, files), "-o", str(out), "-q", "--no-figures"])
        err = capsys.readouterr().err
        assert code == EXIT_FAILURE, err
        assert str(out / "job") in err and "expected" in err, err
        assert not out.exists()
    assert str(first) in err and "job.json" in err


def test_simulate_refuses_a_harness_plan_whose_replay_is_verify_s(tmp_path, capsys):
    """``dloplan simulate`` of a harness plan replayed the whole cable without the board's
    fixtures and contacts and exited 1 ("the moving cable enters table by 81.6 mm") for a plan
    whose phase-by-phase replay (``dloplan verify``) passes. Refused, exit 2, naming what
    replays it; a harness job file (YAML or JSON) before it is planned."""
    from dloplan.app import load_job, make_plan, write_plan

    data = yaml.safe_load((Path(__file__).parents[1] / "examples" / "harness_pu.yaml")
                          .read_text())
    data["harness"]["pegs"][0]["base"] = [0.38, 0.0, 0.0]
    data["outputs"] = ["json"]
    job = write(tmp_path, data, "hose.yaml")
    plan = write_plan(tmp_path / "plan.json", make_plan(load_job(job), check_robot=False))
    as_json = tmp_path / "hose.json"  # a job file in JSON, not a plan document: not planned
    as_json.write_text(json.dumps(data))
    for path in (plan, job, as_json):
        assert main(["simulate", str(path), "-q"]) == EXIT_FAILURE
        err = capsys.readouterr().err
        assert "harness" in err and "dloplan verify" in err and "expected a" in err, err


def test_study_command_writes_the_table_figures_and_report(tmp_path, capsys):
    example = Path(__file__).parents[1] / "examples" / "study_m2_ethernet.yaml"
    out = tmp_path / "study"
    assert main(["study", str(example), "--samples", "8", "-o", str(out), "-q"]) == EXIT_OK
    assert "success" in capsys.readouterr().out
    assert (out / "results.parquet").exists() and (out / "report.html").exists()
    assert (out / "study_tornado.png").exists()


def test_compare_a_plan_with_shifted_registered_shapes(tmp_path, capsys):
    from dloplan.app import read_plan
    from dloplan.vision import RegisteredShape, write_shapes

    out = tmp_path / "out"
    main(["plan", str(write(tmp_path, {**STIFF, "outputs": ["json"]})), "-o", str(out), "-q"])
    capsys.readouterr()
    doc = read_plan(out / "plan.json")
    shifted = [RegisteredShape(s + [0.005, 0, 0], "world", f"xi_{k}")
               for k, s in enumerate(doc.shapes)]
    write_shapes(tmp_path / "trial.csv", shifted)
    code = main(["compare", str(out / "plan.json"), str(tmp_path / "trial.csv"),
                 "-o", str(tmp_path / "cmp"), "--json", "-q", "--svg"])
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert code == EXIT_OK
    assert rows[-1][0] == "all" and rows[-1][5] == pytest.approx(0.005, abs=1e-6)
    assert (tmp_path / "cmp" / "report.html").exists()
    # --svg end to end (its writer is tested alone in test_compare.py): each figure as PNG
    # and SVG, nothing else
    figures = sorted(p.name for p in (tmp_path / "cmp").iterdir() if p.suffix != ".html")
    assert figures == ["registered_shapes.png", "registered_shapes.svg", "shape_errors.png",
                       "shape_errors.svg"]
    assert "<svg" in (tmp_path / "cmp" / "shape_errors.svg").read_text()


def test_simulate_and_verify_a_plan(tmp_path, capsys):
    out = tmp_path / "out"
    main(["plan", str(write(tmp_path, {**STIFF, "outputs": ["json"]})), "-o", str(out), "-q"])
    capsys.readouterr()
    assert main(["simulate", str(out / "plan.json"), "-q", "--json"]) == EXIT_OK
    assert json.loads(capsys.readouterr().out)["ok"]
    assert main(["verify", str(out / "plan.json"), "-q", "--json", "--no-replay"]) == EXIT_OK
    assert json.loads(capsys.readouterr().out)["ok"]
    assert main(["verify", str(out / "plan.json"), "-q", "--no-replay", "--no-snap",
                 "--place"]) == EXIT_OK
    assert "placement: offset" in capsys.readouterr().out


def test_verify_exits_1_when_its_verification_warns(tmp_path, capsys, monkeypatch):
    """A harness plan's phase may pass with a warning (the PU harness job at n = 40: "phase2:
    the cable rests up to 11.4 mm from the plan's shapes"): ``plan --verify`` exited 1 with it
    and ``dloplan verify`` of the plan printed it, listed it in ``--json``'s warnings and
    exited 0 (sweep round 10). A verification's warnings are verify's own: exit 1."""
    from dataclasses import fields

    import dloplan.app
    from dloplan.verify import Verification

    warning = "phase2: the cable rests up to 11.4 mm from the plan's shapes (tolerance 10.0 mm)"

    class Warned(Verification):
        warnings = property(lambda self: (warning,))

    verify = dloplan.app.verify_plan

    def warned(*args, **options):
        result = verify(*args, **options)
        return Warned(**{f.name: getattr(result, f.name) for f in fields(result)})

    monkeypatch.setattr(dloplan.app, "verify_plan", warned)
    out = tmp_path / "out"
    main(["plan", str(write(tmp_path, {**STIFF, "planner": {"n_shapes": 1},
                                       "outputs": ["json"]})), "-o", str(out), "-q"])
    capsys.readouterr()
    assert main(["verify", str(out / "plan.json"), "-q", "--no-replay", "--no-snap",
                 "--no-robot"]) == EXIT_WARNINGS
    plain = verify(dloplan.app.read_plan(out / "plan.json"), snap=False, replay=False,
                   robot=False)
    assert plain.ok and plain.warnings == ()  # a plain plan's checks pass or fail


@pytest.mark.parametrize("data, fragment", BAD, ids=[f"bad{k}" for k in range(len(BAD))])
def test_every_malformed_scenario_exits_2_with_one_line_and_writes_nothing(
    tmp_path, capsys, data, fragment
):
    path = tmp_path / "job.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    assert main(["plan", str(path), "-o", str(out)]) == EXIT_FAILURE
    err = capsys.readouterr().err.strip()
    assert fragment in err and len(err.splitlines()) == 1
    assert not out.exists()


def test_an_unreadable_scenario_file(tmp_path, capsys):
    assert main(["plan", str(tmp_path / "missing.yaml"), "-o", str(tmp_path / "out")]) == 2
    assert "cannot read" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_planner_family_and_weight_overrides(tmp_path, capsys):
    data = {**STIFF, "planner": {"n_shapes": 2, "family": "soft",
                                 "weights": {"advanced": {"clip": 0.02}}}, "outputs": ["json"]}
    assert main(["plan", str(write(tmp_path, data)), "-o", str(tmp_path / "a"), "-q",
                 "--json"]) in (EXIT_OK, EXIT_WARNINGS)
    assert json.loads(capsys.readouterr().out)["family"] == "soft"  # PA12 alone would be stiff
    bad = {**data, "planner": {"weights": {"advanced": {"stretchiness": 1.0}}}}
    assert main(["plan", str(write(tmp_path, bad, "bad.yaml")), "-o", str(tmp_path / "b"),
                 "-q"]) == EXIT_FAILURE
    assert "stretchiness" in capsys.readouterr().err


@pytest.mark.slow
def test_a_harness_plan_is_verified_per_phase_by_plan_and_by_verify(tmp_path, capsys):
    """`plan --verify` on a harness job prints the verdict table per phase (the PU hose's
    passes: exit 0 or 1), the plan document records it, and `dloplan verify` of that document
    reports the same table (the same checks on the same document); the whole job's outputs
    are written as without --verify."""
    example = Path(__file__).parents[1] / "examples" / "harness_pu.yaml"
    out = tmp_path / "out"
    assert main(["plan", str(example), "-o", str(out), "-q", "--verify"]) in (EXIT_OK,
                                                                             EXIT_WARNINGS)
    assert_the_whole_harness_job(out)
    printed = capsys.readouterr().out
    table = printed[printed.index("phase      held by"):printed.index("robot check")].strip()
    assert [line.split()[0] for line in table.splitlines()[1:6]] == [
        "phase1", "phase2", "insertion", "regrasp", "tensioning"]
    assert table.splitlines()[-1].startswith("verdict: ok")
    recorded = json.loads((out / "plan.json").read_text())["verification"]
    assert [row["phase"] for row in recorded["phases"]][-1] == "tensioning"
    assert main(["verify", str(out / "plan.json"), "-q"]) == EXIT_OK
    again = capsys.readouterr().out
    assert again[again.index("phase      held by"):].startswith(table)
    assert main(["verify", str(out / "plan.json"), "-q", "--json", "--no-replay",
                 "--no-snap", "--tensile-limit", "0.5"]) == EXIT_CHECK_FAILED
    data = json.loads(capsys.readouterr().out)
    failed = [row for row in data["phases"] if row["verdict"] == "FAILED"]
    assert [row["phase"] for row in failed] == ["tensioning"]
    assert "rated load 0.5 N" in " ".join(failed[0]["notes"])


def test_check_a_harness_board(tmp_path, capsys):
    example = Path(__file__).parents[1] / "examples" / "harness_usb.yaml"
    assert main(["check", str(example)]) == EXIT_OK
    assert "board" in capsys.readouterr().out
    far = tmp_path / "far.yaml"
    far.write_text(example.read_text().replace("position: [0.50, 0.15, 0.0315]",
                                               "position: [0.50, 0.45, 0.0315]"))
    assert main(["check", str(far)]) == EXIT_FAILURE
    assert "out of reach" in capsys.readouterr().err


def test_a_cable_to_identify_is_identified_then_planned(tmp_path, capsys):
    # thesis Fig. 6.11 in one command: measured shape -> E -> family, weights -> plan
    example = Path(__file__).parents[1] / "examples" / "identify_ethernet.yaml"
    data = yaml.safe_load(example.read_text())  # lengths in mm, E: identify
    data["start"] = {"kind": "straight", "placement": {"position": [400, -250, 150],
                                                       "rotation": {"euler": [0, 0, 90]}}}
    data["target"] = {"kind": "arc", "angle": 90, "placement": {
        "position": [350, -220, 180], "rotation": {"euler": [0, 0, 90]}}}
    data["planner"] = {"n_shapes": 3}
    data["outputs"] = ["json"]
    out = tmp_path / "out"
    assert main(["plan", str(write(tmp_path, data)), "-o", str(out), "-q"]) in (EXIT_OK,
                                                                                EXIT_WARNINGS)
    from dloplan.app import read_plan

    doc = read_plan(out / "plan.json")
    identified = doc.identification.youngs_modulus
    assert identified == pytest.approx(7.5e6, rel=0.05)  # the synthetic truth
    assert doc.cable.youngs_modulus == identified
    without = {k: v for k, v in data.items() if k != "identify"}
    assert main(["plan", str(write(tmp_path, without, "no_identify.yaml")), "-o",
                 str(tmp_path / "x")]) == EXIT_FAILURE
    assert "no identify section" in capsys.readouterr().err


def test_the_help_states_the_exit_code_verify_returns_on_a_failed_check(capsys):
    assert main(["--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())  # argparse wraps the lines
    assert f"dynamic replay (exit {EXIT_CHECK_FAILED} when a check fails)" in text


@pytest.mark.parametrize("command, option", [
    ("export", "--speed"), ("export", "--angular-speed"), ("export", "--rate"),
    ("verify", "--tolerance"), ("verify", "--tensile-limit")])
@pytest.mark.parametrize("value", ["0", "-1", "nan"])
def test_options_that_must_be_positive_refuse_zero_negative_and_nan(tmp_path, capsys, command,
                                                                    option, value):
    """--speed 0 used to keep the plan's speed silently, --tolerance -1 was ignored."""
    output = ["--format", "csv", "-o", str(tmp_path / "t.csv")] if command == "export" else []
    assert main([command, str(tmp_path / "plan.json"), *output, f"{option}={value}"]) == \
        EXIT_FAILURE
    err = capsys.readouterr().err
    assert f"argument {option}: got '{value}', expected a finite number > 0" in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("value", ["-1", "nan", "inf", "two"])
def test_gain_sd_is_refused_by_its_option_name(tmp_path, capsys, value):
    """``correct --gain-sd`` was a bare float: -1, nan and inf reached the library and were
    refused as ``limits.gain_significance`` (a name the command line does not have; inf
    "expected a number >= 0"), after the plan had been read."""
    assert main(["correct", str(tmp_path / "plan.json"), "--at", "1", "--measured",
                 str(tmp_path / "m.csv"), f"--gain-sd={value}"]) == EXIT_FAILURE
    err = capsys.readouterr().err
    assert f"argument --gain-sd: got '{value}', expected a finite number >= 0" in err
    assert len(err.strip().splitlines()) == 1


def test_the_robot_table_prints_no_negative_zero():
    """A worst value of -0.0 (a clearance rounded from below) prints as 0, not "-0"."""
    from dloplan.cli import program_table

    table = program_table([{"check": "assignment", "ok": True, "worst": -0.0, "unit": "mm",
                            "where": "shape 0, both"}])
    assert "-0" not in table and " 0 mm" in table


@pytest.mark.parametrize("given", [None, "2"])
def test_the_command_runs_openblas_on_one_thread_unless_told(given):
    """The console script sets OPENBLAS_NUM_THREADS=1 before numpy loads (cli.BLAS_THREADS);
    a value the caller set is kept."""
    import os
    import subprocess
    import sys

    code = ("import atexit, os, sys; "
            "atexit.register(lambda: print(os.environ.get('OPENBLAS_NUM_THREADS'), "
            "'numpy' in sys.modules)); sys.argv = ['dloplan', '--version']; "
            "from dloplan.cli import run; run()")
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if given is not None:
        env["OPENBLAS_NUM_THREADS"] = given
    done = subprocess.run([sys.executable, "-c", code],
                          capture_output=True, text=True, env=env, check=True)
    assert done.stdout.split()[-2:] == [given or "1", "False"]  # set before numpy loaded


def test_the_console_script_runs_the_command_with_its_gc_thresholds(monkeypatch):
    """``dloplan`` (console.run) sets the collector's thresholds before the command's imports
    and hands over to cli.run; the signal handlers it installs are put back after."""
    import gc
    import signal

    import dloplan.cli
    from dloplan import console

    seen = []
    monkeypatch.setattr(dloplan.cli, "run", lambda: seen.append(gc.get_threshold()))
    thresholds = gc.get_threshold()
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    try:
        console.run()
    finally:
        gc.set_threshold(*thresholds)
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
    assert seen == [console.GC_THRESHOLDS]


def test_json_is_json_for_study_cables_and_design(tmp_path, capsys):
    """``--json`` promises a machine-readable summary on stdout for every command; ``study``,
    ``cables`` and ``identify --design`` printed their text tables instead (the unseen-case
    sweep parsed every command's stdout)."""
    import json

    example = Path(__file__).parents[1] / "examples" / "study_m2_ethernet.yaml"
    out = tmp_path / "study"
    assert main(["study", str(example), "--samples", "2", "--csv", "-o", str(out), "-q",
                 "--json"]) == EXIT_OK
    study = json.loads(capsys.readouterr().out)
    assert study["plan_ok"] is True and study["summary"]["n_samples"] == 2
    assert 0 <= study["summary"]["n_success"] <= 2 and Path(study["report"]).exists()
    assert main(["cables", "--json"]) == EXIT_OK
    cables = json.loads(capsys.readouterr().out)
    assert set(cables["cables"]) == {"usb", "ethernet", "pu", "pa12"}
    assert cables["cables"]["usb"]["d [m]"] == pytest.approx(0.003)
    assert main(["identify", "--design", "--cable", "usb", "--modulus", "2.5e6", "-q",
                 "--json"]) == EXIT_OK
    design = json.loads(capsys.readouterr().out)
    assert design["recommended"] == design["scores"][0]["design"]
    assert all(s["usable"] == (s["informative"] and s["robust"]) for s in design["scores"])


def test_an_export_that_exits_1_says_why(tmp_path, capsys):
    """`export` judges the plan's twist by the plan's own twist check (the torsion model's
    twist under the clip frames, pipeline.repair.failures.twist_failures). It exited 1 when the
    clip frames turned against each other more than the gripper path's limit though the plan
    passed that check (the sweep's M1 at n = 20 and qualitative 2 reversed: 17 and 32 deg, the
    twist repair having rolled the clips against the torsion model's twist, which is 0 under
    them): now exit 0 with the turn as a note. A plan whose torsion-model twist is over the
    limit exits 1 with a warning that says so (it exited 0). A plan within both exits 0."""
    from dataclasses import replace

    from dloplan.app import read_plan
    from dloplan.app.document_file import write_plan

    out = tmp_path / "out"
    assert main(["plan", str(write(tmp_path, {**STIFF, "outputs": ["json"]})), "-o", str(out),
                 "-q"]) in (EXIT_OK, EXIT_WARNINGS)
    capsys.readouterr()
    assert main(["export", str(out / "plan.json"), "--format", "csv", "-o",
                 str(tmp_path / "a.csv"), "-q", "--json"]) == EXIT_OK
    assert json.loads(capsys.readouterr().out)["warnings"] == []
    doc = read_plan(out / "plan.json")
    turned = replace(doc, grippers=replace(doc.grippers, success=False,
                                           twist=doc.grippers.twist + np.radians(20.0)))
    write_plan(tmp_path / "turned.json", turned)
    assert main(["export", str(tmp_path / "turned.json"), "--format", "csv", "-o",
                 str(tmp_path / "b.csv"), "-q", "--json"]) == EXIT_OK
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    line = ("grippers: the clip frames turn 20.0 deg against each other, more than 15 deg, but "
            "the torsion model's twist under them is ")
    assert report["warnings"] == [] and report["notes"][0].startswith(line)
    assert "(the plan's twist check passes; " in report["notes"][0]
    assert f"note: {line}" in captured.err and "warning" not in captured.err
    twisted = replace(doc, twist=replace(doc.twist, twist=doc.twist.twist + np.radians(20.0)))
    write_plan(tmp_path / "twisted.json", twisted)
    assert main(["export", str(tmp_path / "twisted.json"), "--format", "csv", "-o",
                 str(tmp_path / "c.csv"), "-q", "--json"]) == EXIT_WARNINGS
    captured = capsys.readouterr()
    line = "twist: the plan fails its twist check: twist "
    assert json.loads(captured.out)["warnings"][0].startswith(line)
    assert f"warning: {line}" in captured.err


def test_an_export_of_a_plan_that_failed_a_check_exits_3(tmp_path, capsys):
    """``export --format json`` (or ``report``) of a plan that failed a check wrote it for
    inspection with exit 0 (sweep round 10: a harness plan whose phase 2 failed its replay),
    where ``plan`` exits 3 on the same document and ``simulate`` and ``study`` exit 3 on it
    after their work. It is written, with their line and exit 3; a robot program of it stays
    refused (exit 2, nothing written)."""
    from dataclasses import replace

    from dloplan.app import read_plan
    from dloplan.app.document_file import write_plan

    out = tmp_path / "out"
    main(["plan", str(write(tmp_path, {**STIFF, "planner": {"n_shapes": 1},
                                       "outputs": ["json"]})), "-o", str(out), "-q"])
    capsys.readouterr()
    doc = read_plan(out / "plan.json")
    write_plan(tmp_path / "failed.json", replace(doc, harness={"success": False}))
    for name in ("json", "report"):
        target = tmp_path / f"export.{name}"
        assert main(["export", str(tmp_path / "failed.json"), "--format", name, "-o",
                     str(target), "-q", "--json"]) == EXIT_CHECK_FAILED
        captured = capsys.readouterr()
        assert json.loads(captured.out)["plan_ok"] is False and target.exists()
        assert "the plan failed a check (harness)" in captured.err
    assert main(["export", str(tmp_path / "failed.json"), "--format", "csv", "-o",
                 str(tmp_path / "failed.csv"), "-q"]) == EXIT_FAILURE
    assert not (tmp_path / "failed.csv").exists()
    assert main(["export", str(out / "plan.json"), "--format", "json", "-o",
                 str(tmp_path / "ok.json"), "-q"]) in (EXIT_OK, EXIT_WARNINGS)


def test_verify_of_a_harness_plan_whose_tensioning_failed_exits_3(tmp_path, capsys):
    """``verify`` of a harness plan (or job) whose tensioning failed when planned exited 2,
    "plan.harness.offset: none ... nothing to verify", as for bad input, where ``plan`` exits
    3 on the same job and ``simulate`` and ``study`` exit 3 on a plan that failed a check
    (sweep round 10: the USB job at n = 8, the Ethernet job with its fixtures 3 cm farther
    out). Exit 3 with the reason and the line they print."""
    from dataclasses import replace

    from dloplan.app import read_plan
    from dloplan.app.document_file import write_plan

    out = tmp_path / "out"
    main(["plan", str(write(tmp_path, {**STIFF, "planner": {"n_shapes": 1},
                                       "outputs": ["json"]})), "-o", str(out), "-q"])
    capsys.readouterr()
    failed = replace(read_plan(out / "plan.json"), harness={
        "success": False, "offset": None, "message": "the link tension reaches 26.2 N"})
    write_plan(tmp_path / "failed.json", failed)
    assert main(["verify", str(tmp_path / "failed.json"), "-q", "--json"]) == EXIT_CHECK_FAILED
    captured = capsys.readouterr()
    assert json.loads(captured.out)["ok"] is False
    assert ("nothing to verify: the harness job's tensioning failed when planned (the link "
            "tension reaches 26.2 N)") in captured.err
    assert "the plan failed a check (harness)" in captured.err


def test_simulate_of_a_cable_that_stretches_reports_the_replay_not_a_registration(tmp_path,
                                                                                  capsys):
    """``simulate --modulus-cap 1000``: the capped cable stretches to about 2.8 times its length
    under gravity; simulate exited 2 with "registered[1]: registered shape is 1.4 m long ...
    are its points shuffled, not in metres?", about shapes the user never gave. The stretch
    is the simulation's result: the replay fails (exit 1) and the table compares the shapes."""
    out = tmp_path / "out"
    main(["plan", str(write(tmp_path, {**STIFF, "outputs": ["json"]})), "-o", str(out), "-q"])
    capsys.readouterr()
    assert main(["simulate", str(out / "plan.json"), "-q", "--json",
                 "--modulus-cap", "1000"]) == EXIT_WARNINGS
    captured = capsys.readouterr()
    result = json.loads(captured.out)
    assert not result["ok"] and "deviates" in result["message"]
    assert result["rows"][-1][0] == "all" and result["rows"][-1][5] > 0.01  # [m]
    assert "registered" not in captured.err
