"""Figures drawn on worker processes are the figures drawn in the run itself, byte for byte (PNG),
whether a draft is reused or the plan changed after it; nothing of the drafts is left behind."""

from __future__ import annotations

import json
import pickle
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dloplan.app import load_scenario, run_job
from dloplan.app.figure_workers import DRAFTS, FigureWorkers
from dloplan.app.files import plan_into
from dloplan.app.report import write_figures

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def job():
    return load_scenario(EXAMPLES / "m2_uniform_curvature_usb.yaml")


@pytest.fixture(scope="module")
def doc(job):
    return run_job(job)


def _pngs(paths) -> dict[str, bytes]:
    return {Path(p).name: Path(p).read_bytes() for p in paths if Path(p).suffix == ".png"}


def test_a_draft_is_the_figure_drawn_here(doc, tmp_path):
    here = write_figures(doc, tmp_path / "here")
    staging = tmp_path / "staging"
    staging.mkdir()
    workers = FigureWorkers(staging, 1)
    try:
        workers.draft(doc)
        drawn = workers.render(doc, staging / "figures")
    finally:
        workers.close()
    assert [p.name for p in drawn] == [p.name for p in here]
    assert all(p.parent == staging / "figures" for p in drawn)
    assert _pngs(drawn) == _pngs(here)
    assert not (staging / DRAFTS).exists()
    assert sorted(p.name for p in staging.iterdir()) == ["figures"]


def test_a_plan_changed_after_its_draft_is_drawn_again(doc, tmp_path):
    moved = replace(doc, shapes=doc.shapes + np.array([0.0, 0.0, 0.01]))
    here = write_figures(moved, tmp_path / "here")
    staging = tmp_path / "staging"
    staging.mkdir()
    workers = FigureWorkers(staging, 2)
    try:
        workers.draft(doc)  # the plan before a repair moved it
        drawn = workers.render(moved, staging / "figures")
    finally:
        workers.close()
    assert _pngs(drawn) == _pngs(here)
    first = write_figures(doc, tmp_path / "first")
    assert _pngs(first)["planned_path.png"] != _pngs(drawn)["planned_path.png"]
    assert sorted(p.name for p in staging.iterdir()) == ["figures"]


def test_the_planned_hook_sees_the_final_figures_before_the_robot_program(job, doc):
    """run_job hands the plan to the figure workers before its robot program is made: the
    drafts drawn then are the final document's figures (same inputs, so they are reused)."""
    from dloplan.app.report import figure_drawings

    seen = []
    final = run_job(job, planned=seen.append)
    assert len(seen) == 1 and seen[0].program is None and final.program is not None
    assert [pickle.dumps(d) for d in figure_drawings(seen[0])] == \
        [pickle.dumps(d) for d in figure_drawings(final)]  # the workers' key: inputs byte for byte
    assert len(figure_drawings(final)) == len(figure_drawings(doc)) >= 4


def test_plan_into_writes_the_same_files_with_and_without_workers(job, tmp_path):
    def strip(data):
        if isinstance(data, dict):
            return {k: strip(v) for k, v in data.items() if k not in ("timings", "timings_s")}
        return [strip(v) for v in data] if isinstance(data, list) else data

    _, inline = plan_into(job, tmp_path / "inline")
    _, parallel = plan_into(job, tmp_path / "parallel", figure_workers=1)
    names = [p.relative_to(tmp_path / "inline") for p in inline]
    assert names == [p.relative_to(tmp_path / "parallel") for p in parallel]
    for name in names:
        a, b = (tmp_path / "inline" / name), (tmp_path / "parallel" / name)
        if name.name == "plan.json":
            assert strip(json.loads(a.read_text())) == strip(json.loads(b.read_text()))
        elif name.suffix != ".svg":  # SVGs carry their date and random ids
            assert a.read_bytes() == b.read_bytes(), name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["inline", "parallel"]


def test_workers_are_counted(tmp_path):
    with pytest.raises(ValueError, match="workers: expected at least 1 process, got 0"):
        FigureWorkers(tmp_path, 0)
