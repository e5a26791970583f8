"""The plan document: typed sections, one writer and one reader, version 1 files still load,
and every output made from the document says what the document says.

Tolerances: JSON floats are written with Python's round-tripping repr, so positions, times and
every section's numbers come back bit-identical; rotations come back as the same rotation to
1e-12 rad (quaternion normalization).
"""

from __future__ import annotations

import csv
import json
import re
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from gripper_paths import turned_hose_plan
from scipy.spatial.transform import Rotation

from dloplan.app import WRITERS, load_scenario, read_plan, run_job, write_outputs, write_plan
from dloplan.cable import Cable, catalogue_cable
from dloplan.pipeline.document import (
    PLAN_VERSION,
    PlanDocument,
    document_from_dict,
    document_to_dict,
)

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_plan_document")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
DATA = Path(__file__).resolve().parent / "data"


@pytest.fixture(scope="module")
def pieces():
    return turned_hose_plan()  # twisted: has warnings


@pytest.fixture(scope="module")
def planned():
    """A real plan with every section, its robot program passing, verified (M2, USB cable)."""
    job = load_scenario(EXAMPLES / "m2_uniform_curvature_usb.yaml")
    from dloplan.pipeline.stages import verify_plan, with_verification

    doc = run_job(job)
    return with_verification(doc, verify_plan(doc, snap=False))


def _same_rotations(a: Rotation, b: Rotation, tol: float = 1e-12) -> bool:
    return len(a) == len(b) and float(np.max((a.inv() * b).magnitude())) < tol


def _assert_same(a, b, where="doc"):
    """Equal structure and values; floats equal to 1e-12 (re-normalized quaternions)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), where
        for key in a:
            _assert_same(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _assert_same(x, y, f"{where}[{i}]")
    elif isinstance(a, float):
        assert b == pytest.approx(a, rel=1e-12, abs=1e-15), where
    else:
        assert a == b, where


def test_the_pieces_round_trip(pieces, tmp_path):
    cable, shapes, grippers, trajectory = pieces
    doc = PlanDocument(cable, shapes, grippers, trajectory, ("a warning",), source="x.yaml")
    back = read_plan(write_plan(tmp_path / "plan.json", doc))
    assert back.version == PLAN_VERSION and back.frame_id == "world" and back.source == "x.yaml"
    for f in fields(cable):
        if f.name != "rest_shape":
            assert getattr(back.cable, f.name) == getattr(cable, f.name), f.name
    assert np.array_equal(back.cable.rest_shape, cable.rest_shape) and back.cable.is_curved
    assert np.array_equal(back.shapes, shapes)
    g = back.grippers
    assert (g.method, g.success, g.message, g.warnings, g.max_twist) == (
        grippers.method, grippers.success, grippers.message, grippers.warnings,
        grippers.max_twist)
    assert np.array_equal(g.positions, grippers.positions) and np.array_equal(g.twist,
                                                                             grippers.twist)
    for clip in (0, 1):
        assert _same_rotations(g.rotations[clip], grippers.rotations[clip])
    t = back.trajectory
    assert np.array_equal(t.times, trajectory.times)
    assert np.array_equal(t.positions, trajectory.positions)
    assert t.arm_clips == trajectory.arm_clips
    for arm in (0, 1):
        assert _same_rotations(t.rotations[arm], trajectory.rotations[arm])
    assert back.warnings == ("a warning",)
    written = json.loads((tmp_path / "plan.json").read_text())
    assert written.pop("checksum").startswith("sha256:")  # of the file's content, not a section
    _assert_same(document_to_dict(back), written)


def test_a_planned_document_round_trips_every_section(planned, tmp_path):
    back = read_plan(write_plan(tmp_path / "plan.json", planned))
    _assert_same(document_to_dict(planned), document_to_dict(back))
    assert np.array_equal(back.stabilized, planned.stabilized)
    assert np.array_equal(back.stages.basic, planned.stages.basic)
    assert back.forces["physical"].axial_mean.shape == (planned.cable.n_points,)
    assert back.clip_wrenches.shape == (len(planned.shapes), 2, 6)
    assert back.verification.ok == planned.verification.ok
    assert back.verification.table() == planned.verification.table()
    assert [type(o) for o in back.obstacles] == [type(o) for o in planned.obstacles]
    assert back.ok == planned.ok


def test_poses_are_ros_shaped_with_canonical_quaternions(pieces):
    data = document_to_dict(PlanDocument(*pieces))
    pose = data["grippers"]["clips"]["first"][0]
    assert pose["header"] == {"frame_id": "world"}
    assert list(pose["pose"]["orientation"]) == ["x", "y", "z", "w"]
    point = data["trajectory"]["points"][3]
    assert set(point["time_from_start"]) == {"sec", "nanosec"}
    ws = [p["pose"]["orientation"]["w"] for clip in ("first", "last")
          for p in data["grippers"]["clips"][clip]]
    assert min(ws) >= 0.0
    assert data["quaternion_order"] == "xyzw" and data["units"]["length"] == "m"


def test_a_plan_without_grippers_and_trajectory_round_trips(pieces):
    cable, shapes, _, _ = pieces
    back = document_from_dict(json.loads(json.dumps(document_to_dict(PlanDocument(cable,
                                                                                  shapes)))))
    assert back.grippers is None and back.trajectory is None
    assert np.array_equal(back.shapes, shapes)
    straight = Cable(length=0.5, diameter=0.003, mass=0.01, youngs_modulus=1e6, n_links=10)
    assert document_from_dict(document_to_dict(PlanDocument(straight, shapes))).cable \
        .rest_shape is None


def test_a_version_1_file_still_loads():
    """Written by dloplan 0.1 (jobs.plan_extra): every section comes back typed."""
    doc = read_plan(DATA / "plan_v1_fig4_8.json")
    assert doc.version == 1 and doc.source.endswith("fig4_8_straight_to_bent.yaml")
    assert doc.stabilized.shape == doc.shapes.shape
    assert doc.stages.basic.shape == doc.shapes.shape and doc.stages.family == "medium"
    assert doc.forces["physical"].bending_mean.shape == (doc.cable.n_points,)
    assert doc.clip_wrenches.shape == (len(doc.shapes), 2, 6)
    assert doc.target_check.stable and doc.twist.twist.shape == (len(doc.shapes),)
    # and the current pipeline plans the same file to the same shapes
    again = run_job(load_scenario(EXAMPLES / "fig4_8_straight_to_bent.yaml"))
    assert np.allclose(again.shapes, doc.shapes, rtol=0, atol=1e-9)
    assert np.allclose(again.stabilized, doc.stabilized, rtol=0, atol=1e-9)


def test_a_version_1_file_is_read_with_a_warning_that_its_edits_cannot_be_detected(tmp_path,
                                                                                    capsys):
    """A version-1 document has no checksum: edited by hand (here its source; the sweep changed
    its cable's length) it verified and exported with exit 0 as if dloplan had planned it.
    ``verify``, ``export`` and ``compare`` (as ``simulate`` and ``correct``) still read it (old
    plans stay readable), with one warning line and exit 1; ``--json`` of export lists the
    warning. A checked (version-2) document exits 0."""
    from dloplan.cli import main

    data = json.loads((DATA / "plan_v1_fig4_8.json").read_text())
    data["source"] = "edited by hand"
    edited = tmp_path / "v1.json"
    edited.write_text(json.dumps(data))
    line = (f"warning: {edited}: a version-1 plan document has no checksum, so an edit to it "
            "cannot be detected: re-plan to get a checked document (dloplan plan)")
    assert main(["verify", str(edited), "--no-snap", "--no-replay", "--no-robot", "-q"]) == 1
    assert line in capsys.readouterr().err
    assert main(["export", str(edited), "--format", "csv", "-o", str(tmp_path / "a.csv"),
                 "-q", "--json"]) == 1
    captured = capsys.readouterr()
    assert line in captured.err and json.loads(captured.out)["warnings"] == [line[9:]]
    shapes = tmp_path / "shapes.json"
    shapes.write_text(json.dumps({"format": "dloplan-shapes", "version": 1, "units": "m",
                                  "shapes": [{"points": s} for s in data["shapes"]]}))
    assert main(["compare", str(edited), str(shapes), "-q"]) == 1
    assert line in capsys.readouterr().err
    checked = tmp_path / "v2.json"
    write_plan(checked, read_plan(DATA / "plan_v1_fig4_8.json"))
    assert main(["verify", str(checked), "--no-snap", "--no-replay", "--no-robot", "-q"]) == 0
    assert "warning" not in capsys.readouterr().err


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda d: d.update(format="other"), "not a 'dloplan-plan' document"),
        (lambda d: d.update(version=PLAN_VERSION + 1), "plan.version"),
        (lambda d: d.pop("shapes"), "plan: missing 'shapes'"),
        (lambda d: d["cable"].update(color="red"), "plan.cable"),
        (lambda d: d["grippers"]["clips"].pop("last"), "grippers.clips: missing 'last'"),
        (lambda d: d["grippers"]["clips"]["first"][2]["pose"]["position"].pop("y"),
         r"grippers.clips.first\[2\].pose.position: missing 'y'"),
        (lambda d: d["trajectory"]["points"][1]["poses"][0]["header"].update(frame_id="base"),
         "frame_id: got 'base'"),
        (lambda d: d["trajectory"]["points"][1].update(time=-1.0), "trajectory.times"),
        # the times halved by hand (round 10): the law's knots, named with both values
        (lambda d: [p.update(time=p["time"] / 2) for p in d["trajectory"]["points"]],
         r"trajectory.law: knot 1 at 1.0\d+ s, the trajectory's time 0.5\d+ s \(11 knots "
         r"differ\); expected the law's knot times to be the trajectory's times"),
        (lambda d: d.update(stages={"basic": []}), "plan.stages: missing 'advanced'"),
        (lambda d: d.update(obstacles=[{"type": "sphere"}]), r"plan.obstacles\[0\].type"),
    ],
)
def test_malformed_documents_are_rejected_by_name(pieces, edit, match):
    data = json.loads(json.dumps(document_to_dict(PlanDocument(*pieces))))
    edit(data)
    with pytest.raises(ValueError, match=match):
        document_from_dict(data)


def test_pieces_that_do_not_fit_are_rejected(pieces, tmp_path):
    cable, shapes, grippers, _ = pieces
    with pytest.raises(ValueError, match="shapes: 11 points per shape"):
        PlanDocument(catalogue_cable("usb", n_links=12), shapes)
    with pytest.raises(ValueError, match="grippers: 12 shapes, expected 5"):
        PlanDocument(cable, shapes[:5], grippers)
    with pytest.raises(ValueError, match="frame_id"):
        PlanDocument(cable, shapes, frame_id="")
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    with pytest.raises(ValueError, match="not valid JSON"):
        read_plan(bad)
    job = tmp_path / "job.yaml"  # a job file where a plan is expected: say what to do
    job.write_text("cable: {name: usb}\n")
    with pytest.raises(ValueError, match=r"a YAML job file, not a plan document: plan it first"):
        read_plan(job)
    with pytest.raises(ValueError, match="cannot read"):
        read_plan(tmp_path / "missing.json")


# -- every writer writes what the document says ------------------------------------------------
def test_every_writer_writes_the_document(planned, tmp_path):
    # URScript and the RTDE streamer: 6-joint UR arms; correction: a corrected plan's report
    # (tests/test_correct.py)
    yumi = tuple(name for name in WRITERS if name not in ("urscript", "ur_rtde", "correction"))
    for name in ("urscript", "ur_rtde"):
        with pytest.raises(ValueError, match=f"{name}: the cell 'yumi' takes rapid, ros_joints"):
            write_outputs(planned, tmp_path / "ur", (name,))
    with pytest.raises(ValueError, match="correction: the plan is not a corrected plan"):
        write_outputs(planned, tmp_path / "report", ("correction",))
    written = write_outputs(planned, tmp_path, yumi)
    names = {p.relative_to(tmp_path).parts[0] for p in written}
    assert names == {WRITERS[name].target for name in yumi}
    doc = read_plan(tmp_path / "plan.json")  # json: the document itself
    _assert_same(document_to_dict(planned), document_to_dict(doc))
    trajectory = doc.trajectory

    rows = list(csv.reader((tmp_path / "trajectory.csv").read_text().splitlines()[1:]))
    table = np.array(rows[1:], dtype=float)  # csv: samples of the document's trajectory
    samples = trajectory.sample(100.0)
    assert np.allclose(table[:, 0], samples.times, atol=1e-12)
    assert np.allclose(table[:, 1:4], samples.positions[:, 0], atol=1e-12)
    assert np.allclose(table[:, 8:11], samples.positions[:, 1], atol=1e-12)

    msg = yaml.safe_load((tmp_path / "trajectory.yaml").read_text())  # ros
    ros_times = [p["time_from_start"]["sec"] + 1e-9 * p["time_from_start"]["nanosec"]
                 for p in msg["points"]]
    assert np.allclose(ros_times, samples.times, atol=1e-9)
    first = msg["points"][-1]["transforms"][1]["translation"]
    assert np.allclose([first[k] for k in "xyz"], trajectory.positions[-1, 1], atol=1e-12)

    modules = sorted((tmp_path / "rapid").glob("*.mod"))  # rapid: the document's program
    assert len(modules) == 2
    targets = doc.robot.program["targets"]
    for module, arm in zip(modules, ("left", "right"), strict=True):
        written = [[float(v) for v in m] for m in re.findall(
            r"CONST robtarget \w+ := \[\[([-\d.eE+]+),([-\d.eE+]+),([-\d.eE+]+)\]",
            module.read_text())]
        recorded = [1e3 * np.array(t["arms"][arm]["position"]) for t in targets]
        assert np.allclose(written, recorded, atol=1e-5)

    from dloplan.app.report import figure_names

    pngs = {p.stem for p in (tmp_path / "figures").glob("*.png")}  # figures
    assert pngs == set(figure_names(doc))
    page = (tmp_path / "report.html").read_text()  # report: the document's shapes and verdict
    payload = page.split('id="plan-data" type="application/json">')[1].split("</script>")[0]
    assert np.allclose(json.loads(payload.replace("<\\/", "</"))["shapes"], doc.shapes,
                       atol=1e-6)
    assert "verdict: " in page and doc.source in page


def test_the_report_of_a_plan_read_back_is_the_same_page(planned, tmp_path):
    first = write_outputs(planned, tmp_path / "a", ("report",))
    again = write_outputs(read_plan(tmp_path / "a" / "plan.json"), tmp_path / "b", ("report",))
    page = [p for p in first if p.name == "report.html"][0].read_text()
    assert page == [p for p in again if p.name == "report.html"][0].read_text()


def test_an_unknown_format_is_named(planned, tmp_path):
    with pytest.raises(ValueError, match=r"formats: unknown \['pdf'\]"):
        write_outputs(replace(planned), tmp_path, ("pdf",))


def test_write_outputs_takes_svg_as_the_figures_copies(planned, tmp_path):
    """``svg`` among the formats (a job's output name, not a writer) writes each figure as SVG
    too; without ``figures`` or ``report`` beside it, it is refused before anything is written."""
    written = write_outputs(planned, tmp_path / "a", ("figures", "svg"))
    figures = [p for p in written if p.parent.name == "figures"]
    assert sorted(p.stem for p in figures if p.suffix == ".svg") == \
        sorted(p.stem for p in figures if p.suffix == ".png") != []
    assert sorted(written) == sorted(p for p in (tmp_path / "a").rglob("*") if p.is_file())
    with pytest.raises(ValueError, match="outputs: 'svg' writes the figures as SVG too"):
        write_outputs(planned, tmp_path / "b", ("json", "svg"))
    assert not (tmp_path / "b").exists()


def test_the_exported_program_is_the_verified_one(planned, tmp_path):
    """A plan read back rebuilds exactly the robot program it records (verified = exported);
    a document whose recorded program was altered is refused."""
    from dloplan.pipeline.stages import program_of

    assert planned.robot.ok and planned.program is not None
    back = read_plan(write_plan(tmp_path / "plan.json", planned))
    assert back.program is None
    rebuilt = program_of(back)
    for a in range(2):
        assert np.array_equal(rebuilt.joints[a], planned.program.joints[a])
    assert np.array_equal(rebuilt.targets.positions, planned.program.targets.positions)
    data = json.loads((tmp_path / "plan.json").read_text())
    data["robot"]["program"]["targets"][2]["arms"]["left"]["joints_deg"][0] += 1.0
    with pytest.raises(ValueError, match="differs from the verified one"):
        program_of(document_from_dict(data))


def test_a_re_timed_plan_keeps_its_arms_and_limits_and_checks_its_program_again(planned):
    """``export --speed``: the same arms, acceleration, jerk and zones; the cycle and the robot
    program made again for the new timing."""
    from dloplan.pipeline.stages import retimed

    slower = retimed(planned, speed=0.05)
    old, new = planned.trajectory, slower.trajectory
    assert new.arm_clips == old.arm_clips and np.array_equal(new.positions, old.positions)
    assert new.law.limits.speed == 0.05
    assert new.law.limits.acceleration == old.law.limits.acceleration
    assert new.duration > old.duration
    assert slower.cycle["motion_time"] == pytest.approx(new.duration)
    durations = [p.program.targets.durations.sum() for p in (slower, planned)]
    assert slower.robot.ok and durations[0] > durations[1]


def test_a_re_timed_harness_plan_reports_the_new_timing_in_its_harness_section(tmp_path):
    """``export --speed 0.05`` of a harness plan wrote a trajectory of 9.05 s and a cycle
    section of 10.85 s, and its harness section, which the report prints, kept the planned
    "cycle 7.90 s = motion 6.10 s ... at 100 mm/s" and phase times. The harness section is
    timed again with the cycle; its tensioning numbers stay (the same knots)."""
    from dloplan.app import load_job, make_plan
    from dloplan.app.report import summary_lines
    from dloplan.pipeline.stages import retimed

    data = yaml.safe_load((Path(__file__).parents[1] / "examples" / "harness_pu.yaml")
                          .read_text())
    data["harness"]["pegs"][0]["base"] = [0.38, 0.0, 0.0]
    (tmp_path / "hose.yaml").write_text(yaml.safe_dump(data))
    planned = make_plan(load_job(tmp_path / "hose.yaml"), check_robot=False)
    slower = retimed(planned, speed=0.05)
    harness, times = slower.harness, slower.trajectory.times
    assert slower.trajectory.duration > planned.trajectory.duration
    assert harness["motion_time"] == slower.trajectory.duration
    assert harness["cycle_time"] == pytest.approx(slower.cycle["cycle_time"])
    assert harness["cycle"] == slower.cycle["breakdown"]
    for name, (a, b) in harness["knots"].items():
        assert harness["phase_times"][name] == (times[a], times[b])
    assert harness["message"].startswith(f"cycle {slower.cycle['cycle_time']:.2f} s = motion "
                                         f"{slower.trajectory.duration:.2f} s")
    assert " at 50 mm/s; " in harness["message"]
    assert harness["offset"] == planned.harness["offset"]
    assert harness["message"].split(" mm/s; ", 1)[1] == \
        planned.harness["message"].split(" mm/s; ", 1)[1]
    assert f"phase1: 0.00 s to {times[harness['knots']['phase1'][1]]:.2f} s" in \
        summary_lines(slower)


def test_export_writes_no_trajectory_of_a_plan_that_failed_a_check(planned, tmp_path):
    """dloplan plan withholds robot programs and trajectories of a failed plan; dloplan export
    wrote trajectory.csv of it with exit 0 (a target 3 m out of reach)."""
    from dloplan.app.files import export_plan
    from dloplan.app.writers import WriteOptions

    assert planned.failed_checks == [] and planned.ok
    failed = replace(planned, harness={"success": False})
    assert failed.failed_checks == ["harness"] and not failed.ok
    for name in ("csv", "ros", "rapid"):
        with pytest.raises(ValueError, match=rf"^{name}: not written, the plan failed a check "
                                             r"\(harness; dloplan verify"):
            export_plan(failed, name, tmp_path / name, WriteOptions())
        assert not (tmp_path / name).exists()
    assert export_plan(failed, "json", tmp_path / "plan.json", WriteOptions())
    assert export_plan(planned, "csv", tmp_path / "ok.csv", WriteOptions())
