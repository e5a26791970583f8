"""One plan per job: every command that plans a job file gets the plan ``dloplan plan`` writes.

``plan``, ``study`` (its nominal plan), ``simulate JOB`` and ``correct JOB`` all call
:func:`dloplan.pipeline.make_plan` (plan, check, repair, check again). Qualitative test 1 is the
case that told them apart: ``plan`` repaired it (turned and moved on the table, grasps rolled)
while ``study`` and ``simulate`` of the job file planned it without the repair, shapes up to
0.39 m apart. The floor's own rule (nothing in ``dloplan.pipeline`` knows files, pydantic or
the application) is checked on its imports.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
import yaml

from dloplan.app import read_plan
from dloplan.cli import main
from dloplan.exit_codes import EXIT_FAILURE, EXIT_OK, EXIT_WARNINGS
from dloplan.geometry import resample_by_arc_length
from dloplan.vision.shapes_io import RegisteredShape, write_shapes

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def test_plan_study_simulate_and_correct_of_a_job_file_use_one_plan(tmp_path, monkeypatch):
    """The same shapes (bit for bit: plan.json writes round-tripping floats), gripper poses and
    verdict for ``plan``, ``study``, ``simulate`` and ``correct`` of qualitative test 1 (with a
    study section of two samples added; ``correct`` given the job file and a measured shape)."""
    import dloplan.app.correct
    import dloplan.app.study
    import dloplan.pipeline.stages

    data = yaml.safe_load((EXAMPLES / "qualitative1_curved_pa12.yaml").read_text())
    data["study"] = {"samples": 2, "seed": 1, "parameters": {"youngs_modulus": {"spread": 5}}}
    data["outputs"] = ["json", "rapid"]  # what is read back below (no figures, no report)
    job = tmp_path / "qualitative1.yaml"
    job.write_text(yaml.safe_dump(data))

    seen = {}

    def spying(name, function):
        def spy(doc, *args, **kwargs):
            seen[name] = doc
            return function(doc, *args, **kwargs)
        return spy

    monkeypatch.setattr(dloplan.app.study, "study_problem_of",
                        spying("study", dloplan.app.study.study_problem_of))
    monkeypatch.setattr(dloplan.pipeline.stages, "simulate_plan",
                        spying("simulate", dloplan.pipeline.stages.simulate_plan))
    monkeypatch.setattr(dloplan.app.correct, "correct_and_check",
                        spying("correct", dloplan.app.correct.correct_and_check))

    assert main(["plan", str(job), "-o", str(tmp_path / "plan"), "-q"]) in (EXIT_OK,
                                                                            EXIT_WARNINGS)
    planned = read_plan(tmp_path / "plan" / "plan.json")
    assert [r["kind"] for r in planned.repairs] == ["reach"]  # the case: a repaired plan
    assert planned.placement is not None and planned.placement.applied
    # the cycle is the written motion's (a repair that tried a slowed program and then kept
    # another, unslowed one once left the slowed cycle, 12.34 s, over an 8.20 s motion)
    assert planned.cycle["motion_time"] == pytest.approx(planned.trajectory.duration,
                                                         rel=1e-12)
    modules = sorted((tmp_path / "plan" / "rapid").glob("*.mod"))
    assert len(modules) == 2
    for module in modules:  # each says where the cable must lie
        header = module.read_text().split("PERS tasks")[0]
        assert "! Place the cable where dloplan moved the job: " \
            f"{planned.placement.message};" in header, module
    assert main(["study", str(job), "-o", str(tmp_path / "study"), "-q", "--csv",
                 "--no-figures"]) == EXIT_OK
    assert (tmp_path / "study" / "report.html").exists()  # the study drew no figure for it
    assert not list((tmp_path / "study").glob("*.png"))
    assert main(["simulate", str(job), "-q"]) in (EXIT_OK, EXIT_WARNINGS)
    # correct plans the job file as plan does; the measured shape (the plan's own shape 2 and
    # 1 mm of noise) is nothing worth correcting, so it may keep the plan (exit 2, named)
    measured = tmp_path / "measured.csv"
    points = resample_by_arc_length(planned.stabilized[2], 200)
    write_shapes(measured, [RegisteredShape(
        points + np.random.default_rng(0).normal(scale=1e-3, size=points.shape),
        label="xi_2", frame_id=planned.frame_id)])
    assert main(["correct", str(job), "--at", "2", "--measured", str(measured), "-q",
                 "-o", str(tmp_path / "corrected")]) in (EXIT_OK, EXIT_WARNINGS, EXIT_FAILURE)
    for name in ("study", "simulate", "correct"):
        doc = seen[name]
        assert np.array_equal(doc.shapes, planned.shapes), name
        assert np.array_equal(doc.stabilized, planned.stabilized), name
        assert np.array_equal(doc.grippers.positions, planned.grippers.positions), name
        assert doc.ok == planned.ok and doc.failed_checks == planned.failed_checks, name
        assert [(r["kind"], r["change"]) for r in doc.repairs] == \
            [(r["kind"], r["change"]) for r in planned.repairs], name


def _imports(path: Path, package: str) -> set[str]:
    """Every module a source file imports (relative imports resolved; function-level too)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                names.add(".".join(base + ([node.module] if node.module else [])))
            else:
                names.add(node.module)
    return names


def test_the_pipeline_floor_knows_no_files_pydantic_or_application():
    """Nothing in dloplan.pipeline, nor any dloplan module it imports (transitively, lazy
    imports included), imports pydantic, the application (dloplan.app, dloplan.cli) or the
    scenario schema (file units); and the floor itself opens no file."""
    src = ROOT / "src"

    def source(module: str) -> Path | None:
        path = src / Path(*module.split("."))
        return path / "__init__.py" if (path / "__init__.py").exists() else \
            path.with_suffix(".py") if path.with_suffix(".py").exists() else None

    floor = [str(p.relative_to(src).with_suffix("")).replace("/", ".").removesuffix(".__init__")
             for p in (src / "dloplan" / "pipeline").rglob("*.py")]
    seen, todo, outside = set(), list(floor), {}
    while todo:
        module = todo.pop()
        if module in seen:
            continue
        seen.add(module)
        path = source(module)
        package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
        for name in _imports(path, package):
            if name.startswith("dloplan."):
                parts = name.split(".")
                todo += [".".join(parts[:k]) for k in range(2, len(parts) + 1)
                         if source(".".join(parts[:k]))]
            else:
                outside.setdefault(name.split(".")[0], set()).add(module)
    assert "pydantic" not in outside, outside.get("pydantic")
    assert not {m for m in seen if m.startswith(("dloplan.app", "dloplan.cli"))}
    assert "dloplan.io.scenario" not in seen
    for module in floor:
        text = source(module).read_text()
        assert "open(" not in text and "read_text(" not in text and "write_text(" not in text, \
            module


def test_an_end_that_sags_into_the_table_is_refused_with_the_lift_that_clears_it():
    """Qualitative test 1 with the softer PU hose (the unseen-case sweep's cable swap): held by
    its clips 2 cm above the table, the start sags into it. The refusal said where and by how
    much, not what was expected; it now names the lift that clears it, and that lift does."""
    from dloplan.app.load import resolve_mapping
    from dloplan.obstacles.collisions import check_shape
    from dloplan.pipeline.stages import plan_path
    from dloplan.sim.statics import stabilize

    data = yaml.safe_load((EXAMPLES / "qualitative1_curved_pa12.yaml").read_text())
    data["cable"] = {**data["cable"], "name": "pu"}
    job = resolve_mapping(data, "qualitative 1, PU hose")
    with pytest.raises(ValueError, match="start: the stabilized start collides") as refused:
        plan_path(job)
    message = str(refused.value)
    assert "expected it clear of every obstacle" in message
    lift = float(message.split("lift it by ")[1].split(" mm")[0]) * 1e-3
    assert lift > 0
    start = stabilize(job.start + [0.0, 0.0, lift + 1e-4], job.cable).shape
    assert not check_shape(start, job.obstacles, job.cable.diameter / 2).colliding


def test_ends_held_closer_than_the_grippers_allow_are_refused_at_once(tmp_path, capsys):
    """The demo's job with a 3 cm cable (the unseen-case sweep's short cable): its clips are
    27.5 mm apart, and the YuMi's grippers overlap whenever their TCPs are closer than 45 mm,
    whatever the joints. It was searched for 30-80 s (frame sets, grasps, placements) and
    refused as "no placement of the job on the table makes every pose reachable" (exit 3);
    it is now refused before planning, naming the distance and the least one (exit 2, nothing
    written). A 6 cm cable passes the check."""
    from dloplan.app.load import resolve_mapping
    from dloplan.pipeline.stages import check_grip_distance, run_job

    data = yaml.safe_load((ROOT / "src/dloplan/data/demo.yaml").read_text())
    data["cable"] = {**data["cable"], "length": 0.03}
    job = resolve_mapping(data, "demo, 3 cm cable")
    with pytest.raises(ValueError, match=r"start: its clips are 27\.5 mm apart \(cable 30\.0 mm "
                                         r"long\); expected at least 45\.1 mm"):
        run_job(job)
    run_job(job, check_robot=False)   # no robot program: nothing holds the clips
    data["cable"]["length"] = 0.06
    check_grip_distance(resolve_mapping(data, "demo, 6 cm cable"))
    data["cable"]["length"] = 0.03
    path = tmp_path / "short.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["plan", str(path), "--verify", "-q", "-o", str(tmp_path / "out")]) == 2
    assert "expected at least 45.1 mm" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_gripper_errors_and_warnings_name_the_job_files_fields():
    """The demo's job with an auxiliary vector along its start (the sweep's grip variants):
    the refusal named the library's parameter ("aux: the auxiliary vector ..."), a frame given
    off the cable warned as "initial: ..."; both now name the file's field."""
    from dloplan.app.load import resolve_mapping
    from dloplan.pipeline.stages import gripper_frames

    data = yaml.safe_load((ROOT / "src/dloplan/data/demo.yaml").read_text())
    data["grippers"] = {"method": "auxiliary", "auxiliary_vector": [0, 1, 0]}
    job = resolve_mapping(data, "demo, auxiliary vector along the cable")
    path = np.stack([job.start, job.target])
    with pytest.raises(ValueError, match=r"^grippers\.auxiliary_vector: the auxiliary vector "
                                         r"\[0\.0, 1\.0, 0\.0\] is 0\.00 degrees from the first"):
        gripper_frames(job, path)
    data["grippers"] = {"method": "minimal", "initial_frames": {"first": {"euler": [0, 90, 0]},
                                                                "last": {"euler": [0, 0, -90]}}}
    frames = gripper_frames(resolve_mapping(data, "demo, a frame off the cable"), path)
    assert [w.split(": ")[0] for w in frames.warnings] == ["grippers.initial_frames"]
    assert "90.0 degrees off the first shape's u-axis" in frames.warnings[0]


def test_a_motion_that_sweeps_through_the_wall_between_the_shapes_fails_its_verification():
    """The demo's job with its wall 0.4 m tall (the sweep's obstacle variants): the avoidance
    lifts the planned shapes over it (each stabilized shape clear), but the cable moving from
    shape 2 to shape 3 sweeps through the wall's top. `plan --verify` said "ok"; the replay
    now checks its records against the obstacles and fails, naming the wall and the segment."""
    from dloplan.app.load import resolve_mapping
    from dloplan.obstacles.collisions import check_path
    from dloplan.pipeline.stages import run_job, verify_plan

    data = yaml.safe_load((ROOT / "src/dloplan/data/demo.yaml").read_text())
    data["obstacles"] = [{"type": "box", "name": "wall", "center": [0.40, 0.0, 0.20],
                          "size": [0.03, 0.34, 0.40]}]
    doc = run_job(resolve_mapping(data, "demo, a 0.4 m wall"))
    assert not any(r.colliding for r in check_path(doc.stabilized, doc.obstacles,
                                                   doc.cable.diameter / 2))
    verification = verify_plan(doc)
    assert not verification.ok
    assert "the moving cable enters wall by" in verification.replay.message
    assert "between shapes 2 and 3" in verification.replay.message
