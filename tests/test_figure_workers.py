"""Figures drawn on worker processes are the figures drawn in the run itself, byte for byte (PNG),
whether a draft is reused or the plan changed after it; nothing of the drafts is left behind."""

from __future__ import annotations

import json
import pickle
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from dloplan.app import load_scenario, run_job
from dloplan.app.figure_workers import DRAFTS, FigureWorkers
from dloplan.app.files import plan_into
from dloplan.app.report import write_figures

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_figure_workers")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def job():
    return load_scenario(EXAMPLES / "m2_uniform_curvature_usb.yaml")


@pytest.fixture(scope="module")
def doc(job):
    return run_job(job)


@pytest.fixture(scope="module")
def here(doc, tmp_path_factory):
    """The plan's figures drawn in this process (write_figures), the reference the workers'
    files are compared with: drawn once for the module's tests (read only), not once a test."""
    return write_figures(doc, tmp_path_factory.mktemp("here"))


@pytest.fixture(scope="module")
def moved(doc):
    """The plan moved 10 mm up after its draft (as a repair would change it)."""
    return replace(doc, shapes=doc.shapes + np.array([0.0, 0.0, 0.01]))


@pytest.fixture(scope="module")
def moved_here(moved, tmp_path_factory):
    """The moved plan's figures drawn in this process, once for the module."""
    return write_figures(moved, tmp_path_factory.mktemp("moved"))


def _pngs(paths) -> dict[str, bytes]:
    return {Path(p).name: Path(p).read_bytes() for p in paths if Path(p).suffix == ".png"}


def test_a_draft_is_the_figure_drawn_here(doc, here, tmp_path):
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


def test_a_plan_changed_after_its_draft_is_drawn_again(doc, here, moved, moved_here, tmp_path):
    staging = tmp_path / "staging"
    staging.mkdir()
    workers = FigureWorkers(staging, 2)
    try:
        workers.draft(doc)  # the plan before a repair moved it
        drawn = workers.render(moved, staging / "figures")
    finally:
        workers.close()
    assert _pngs(drawn) == _pngs(moved_here)
    assert _pngs(here)["planned_path.png"] != _pngs(drawn)["planned_path.png"]
    assert sorted(p.name for p in staging.iterdir()) == ["figures"]


def test_the_planned_hook_sees_the_final_figures_before_and_after_the_robot_program(job, doc):
    """run_job hands the plan to the figure workers before its robot program is made,
    provisionally (the figures no program or repair changes: forces and lengths), and again
    with its program when that passes (all of them): the drafts drawn then are the final
    document's figures (same inputs, so they are reused)."""
    from dloplan.app.report import figure_drawings, lasting_drawings

    seen = []
    final = run_job(job, planned=lambda d, provisional=False: seen.append((d, provisional)))
    assert [provisional for _, provisional in seen] == [True, False] and final.program.ok
    assert seen[0][0].program is None and seen[1][0].program is final.program
    assert [pickle.dumps(d) for d in figure_drawings(seen[1][0])] == \
        [pickle.dumps(d) for d in figure_drawings(final)]  # the workers' key: inputs byte for byte
    lasting = [pickle.dumps(d) for d in lasting_drawings(seen[0][0])]
    assert [d.name for d in lasting_drawings(final)] == ["forces", "lengths"]
    assert lasting == [pickle.dumps(d) for d in lasting_drawings(final)]
    assert len(figure_drawings(final)) == len(figure_drawings(doc)) >= 4


def test_a_provisional_draft_draws_the_lasting_figures_and_render_the_rest(doc, here, tmp_path):
    """Drafted provisionally (before the robot program), only the forces and lengths are sent;
    render() draws the others: the same files as drawn here."""
    staging = tmp_path / "staging"
    staging.mkdir()
    workers = FigureWorkers(staging, 2, drafting=1)
    sent = []
    submit = workers._submit
    try:
        workers._submit = lambda drawing: sent.append(drawing.name) or submit(drawing)
        workers.draft(doc, provisional=True)
        drafted = list(sent)
        assert [pool._max_workers for pool in workers._pools] == [2]  # a scenario's: both
        drawn = workers.render(doc, staging / "figures")
    finally:
        workers.close()
    assert drafted == ["forces", "lengths"]
    assert sent == drafted + [p.stem for p in here if p.suffix == ".png"]
    assert _pngs(drawn) == _pngs(here)


def test_a_draft_drawn_without_svg_is_not_reused_for_a_request_with_svg(doc, tmp_path):
    """The formats are part of a drawing's key: drafts drawn as PNG only (the default) are not
    the figures of a render asked for PNG and SVG, which draws every figure again, with its SVG
    copy; drafts in the formats asked for are reused (nothing drawn again)."""
    from dloplan.plots.figures import WITH_SVG

    staging = tmp_path / "staging"
    staging.mkdir()
    for drafted, asked in ((None, WITH_SVG), (WITH_SVG, WITH_SVG)):
        workers = FigureWorkers(staging, 2, *([drafted] if drafted else []), drafting=2)
        sent, new = [], []
        submit = workers._submit

        def recorded(drawing, workers=workers, submit=submit, sent=sent, new=new):
            before = len(workers._drafts)
            future = submit(drawing)
            sent.append(drawing)
            new.append(len(workers._drafts) > before)
            return future

        try:
            workers.draft(doc)
            workers._submit = recorded
            drawn = workers.render(doc, staging / "figures", asked)
        finally:
            workers.close()
        svgs = sorted(p.stem for p in drawn if p.suffix == ".svg")
        pngs = sorted(p.stem for p in drawn if p.suffix == ".png")
        assert len(sent) == len(pngs) >= 4
        assert sum(new) == (len(pngs) if drafted != asked else 0)
        assert svgs == pngs
        assert all(d.formats == asked for d in sent)
        shutil.rmtree(staging / "figures")


def test_plan_into_writes_the_same_files_with_and_without_workers(job, tmp_path):
    def strip(data):
        if isinstance(data, dict):
            return {k: strip(v) for k, v in data.items()
                    if k not in ("timings", "timings_s", "checksum")}
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


def test_a_changed_plan_sends_every_figure_before_waiting_for_one(doc, moved, moved_here, tmp_path,
                                                                  monkeypatch):
    """render() of a plan whose drafts are stale sends all its figures to the workers first,
    then waits: they are drawn side by side, not one after the other."""
    from concurrent.futures import Future

    events = []
    staging = tmp_path / "staging"
    staging.mkdir()
    workers = FigureWorkers(staging, 2)
    submit, result = workers._submit, Future.result

    def recorded_submit(drawing):
        events.append("send")
        return submit(drawing)

    def recorded_result(future, timeout=None):
        events.append("wait")
        return result(future, timeout)

    monkeypatch.setattr(workers, "_submit", recorded_submit)
    monkeypatch.setattr(Future, "result", recorded_result)
    try:
        drawn = workers.render(moved, staging / "figures")
    finally:
        monkeypatch.undo()
        workers.close()
    n = len(events) // 2
    assert n >= 4 and events == ["send"] * n + ["wait"] * n
    assert _pngs(drawn) == _pngs(moved_here)


def test_the_repair_hands_its_repaired_plan_to_the_hook_before_verifying_it():
    """make_plan gives the planned hook the repaired plan too, as soon as a repair round is
    made: the figures drafted then are the final document's (fig4_8: its reach repair turns
    the job on the table)."""
    from dloplan.app import load_job, make_plan
    from dloplan.app.report import figure_drawings

    job = load_job(EXAMPLES / "fig4_8_straight_to_bent.yaml")
    calls = []
    final = make_plan(job, planned=lambda d, provisional=False: calls.append((d, provisional)))
    assert final.repairs and [provisional for _, provisional in calls] == [True, False]
    assert list(final.timings)[:2] == ["grip check", "target check"]  # the checks timed
    seen = [d for d, _ in calls]  # the planned plan (its program fails), the repaired one
    assert seen[0].program is None and seen[1].verification is None
    assert [pickle.dumps(d) for d in figure_drawings(seen[1])] == \
        [pickle.dumps(d) for d in figure_drawings(final)]
    assert [pickle.dumps(d) for d in figure_drawings(seen[0])] != \
        [pickle.dumps(d) for d in figure_drawings(final)]


def test_a_harness_job_hands_its_plan_to_the_hook_before_its_robot_program():
    """A wire-harness job's plan goes to the figure workers as soon as it is planned, before
    its robot program and its (long) verification: the drafts are the final figures."""
    from dloplan.app import load_job, make_plan
    from dloplan.app.report import figure_drawings

    seen = []
    final = make_plan(load_job(EXAMPLES / "harness_ethernet.yaml"), planned=seen.append)
    assert len(seen) == 1 and seen[0].program is None and final.program is not None
    assert "robot" not in seen[0].timings and final.timings["robot"] > 0  # the program timed
    assert [pickle.dumps(d) for d in figure_drawings(seen[0])] == \
        [pickle.dumps(d) for d in figure_drawings(final)]


def test_workers_are_counted(tmp_path):
    with pytest.raises(ValueError, match="workers: expected at least 1 process, got 0"):
        FigureWorkers(tmp_path, 0)
    with pytest.raises(ValueError, match="drafting: expected 1 to 2 processes, got 3"):
        FigureWorkers(tmp_path, 2, drafting=3)


@pytest.mark.parametrize(("cores", "drafting"), [(1, 1), (2, 1), (3, 2), (8, 2)])
def test_the_drafts_leave_the_run_a_core(tmp_path, monkeypatch, cores, drafting):
    """While the run goes on its drafts are drawn by one process fewer than the cores it may
    use (at least one, at most the workers): the run, the critical path, keeps a core."""
    from dloplan.app import figure_workers

    monkeypatch.setattr(figure_workers, "usable_cores", lambda: cores)
    workers = FigureWorkers(tmp_path, 2)
    try:
        assert workers.drafting == drafting
    finally:
        workers.close()


def test_the_waiting_run_hands_the_drafts_not_started_to_the_other_workers(doc, here,
                                                                            tmp_path):
    """Drafted on one process of two, the five figures queue behind the first; render() (the
    run now waits) starts the second process and sends those not started yet again, to the
    process with the least to draw: every figure drawn once, the files those drawn here,
    nothing left behind."""
    staging = tmp_path / "staging"
    staging.mkdir()
    workers = FigureWorkers(staging, 2, drafting=1)
    try:
        workers.draft(doc)  # a first whole draft (a harness job's): its verification is long
        assert len(workers._sent) == 1  # one process while the run goes on
        drawn = workers.render(doc, staging / "figures")
        taken = len(workers._sent[1])  # sent to the second process once the run waited
        cancelled = sum(f.cancelled() for f in workers._sent[0])
    finally:
        workers.close()
    assert taken >= 1 and cancelled >= taken
    assert len(workers._sent[0]) - cancelled + taken == len(here)  # each figure drawn once
    assert _pngs(drawn) == _pngs(here)
    assert sorted(p.name for p in staging.iterdir()) == ["figures"]


DRAW_ELSEWHERE = """
import pickle, sys
from pathlib import Path
from dloplan.plots import worker
drawings, folder = pickle.load(sys.stdin.buffer)
for drawing in drawings:
    worker.draw(drawing, Path(folder))
heavy = ("numba", "scipy", "dloplan.obstacles", "dloplan.sim")
print(" ".join(m for m in heavy if m in sys.modules))
"""


def test_a_worker_draws_without_the_solvers(doc, tmp_path):
    """A plan's drawings (here with a yawed box, a peg and the table) hold plain arrays: a fresh
    interpreter that imports only the worker's module draws them without importing numba, scipy
    or the obstacles, and draws the same PNGs as this process."""
    import subprocess
    import sys

    from dloplan.app.report import figure_drawings
    from dloplan.obstacles import Box, Cylinder, Table

    obstacles = (Box((0.4, 0.05, 0.03), (0.05, 0.08, 0.06), yaw=0.4),
                 Cylinder((0.3, -0.1, 0.0), 0.01, 0.08), Table(0.0))
    with_obstacles = replace(doc, obstacles=obstacles)
    here = _pngs(write_figures(with_obstacles, tmp_path / "here"))
    done = subprocess.run([sys.executable, "-c", DRAW_ELSEWHERE], check=True, capture_output=True,
                          input=pickle.dumps((figure_drawings(with_obstacles),
                                              str(tmp_path / "there"))))
    assert done.stdout.decode().strip() == ""
    assert _pngs((tmp_path / "there").iterdir()) == here


def test_obstacle_edges_lie_on_their_surfaces():
    """The outlines drawn are the obstacles' own: every edge point of a (yawed) box and a peg is
    on its surface (distance 0, and the box's 8 corners span its size), the table has none."""
    from dloplan.obstacles import Box, Cylinder, Table

    box = Box((0.4, 0.05, 0.03), (0.05, 0.08, 0.06), yaw=0.4)
    peg = Cylinder((0.3, -0.1, 0.0), 0.01, 0.08)
    for obstacle in (box, peg):
        points = np.concatenate(obstacle.edges())
        assert np.abs(obstacle.distance(points)).max() < 1e-12
        assert np.abs(obstacle.signed_distance(points)[0]).max() < 1e-12
    corners = np.unique(np.round(np.concatenate(box.edges()), 12), axis=0)
    assert len(corners) == 8
    local = (corners - box.center)[:, :2] @ np.array([[np.cos(0.4), -np.sin(0.4)],
                                                      [np.sin(0.4), np.cos(0.4)]])
    assert np.allclose(np.ptp(local, axis=0), box.size[:2])
    assert Table(0.0).edges() == []
