"""SIGINT, SIGTERM and SIGHUP to real commands, under load: each ends the command and every process
it started, with exit 128 + signal, one line, the output folder as it was, nothing left beside it
(no lock, no staging folder, no temporary file). A few representative moments run here; every
command, signal and moment runs in benchmarks/signal_sweep.py (tests/signal_runs.py is the
machinery of both).

Concurrent runs of a command never touch each other's files: two exports of ros_joints into one
folder leave files that read back; two studies into one folder: the second is refused at once.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from signal_runs import busy_loop, interruptible, leftovers, signal_run, snapshot
from test_cli import STIFF, write

from dloplan.cli import EXIT_FAILURE, EXIT_INTERRUPTED, EXIT_OK, EXIT_WARNINGS, main
from dloplan.interrupts import Interrupted

# one worker (make test: --dist loadgroup): the module's small plan (with its figures) is made
# once, and the commands signalled under load do not also run beside each other
pytestmark = pytest.mark.xdist_group("test_signals")

SMALL = {**STIFF, "cable": {"name": "pa12", "n_links": 8}, "planner": {"n_shapes": 2},
         "outputs": ["json", "csv", "report"]}
STUDY = Path(__file__).parents[1] / "examples" / "study_m2_ethernet.yaml"


@pytest.fixture
def load():
    """One core kept busy beside the command: by a busy loop, or, where the suite runs a test
    worker on every core (``make test``: 2 workers on 2 cores), by the other workers, which
    run their tests meanwhile (this module's group starts first). A loop beside them only
    spun: about a core's time per signalled command, for the load that was already there."""
    if int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")) >= (os.cpu_count() or 1):
        yield
        return
    busy = busy_loop()
    yield
    busy.kill()
    busy.wait()


@pytest.fixture(scope="module")
def planned_once(tmp_path_factory):
    """A small job and its output folder, planned once for the module."""
    folder = tmp_path_factory.mktemp("planned")
    job = write(folder, SMALL)
    out = folder / "out"
    assert main(["plan", str(job), "-o", str(out), "-q"]) in (EXIT_OK, EXIT_WARNINGS)
    return job, out


@pytest.fixture
def planned(planned_once, tmp_path):
    """The small job and a copy of its planned ``out``: the folder a signal must leave as it
    was."""
    job, out = planned_once
    shutil.copytree(out, tmp_path / "out")
    return Path(shutil.copy(job, tmp_path / job.name)), tmp_path / "out"


@pytest.mark.parametrize("signum, marker, to_group", [
    (signal.SIGTERM, "robot program", False),  # figures drawn on the workers, verification runs
    (signal.SIGHUP, "planned", True),  # the terminal closed: the whole group gets it
    (signal.SIGINT, "loaded", False),  # Ctrl-C to the command alone, the server warming up
])
def test_a_signal_ends_plan_and_its_workers_leaving_the_folder_as_it_was(
        planned, load, signum, marker, to_group):
    job, out = planned
    outcome = signal_run(["plan", str(job), "-o", str(out), "--verify"], out, signum,
                         marker=marker, to_group=to_group)
    assert outcome.reached, outcome.stderr  # the moment came before the plan was done
    assert outcome.problems() == [], outcome.stderr
    assert (out / "plan.json").exists()  # the previous output, untouched


def test_sigterm_to_a_batch_ends_its_pool_and_each_worker_cleans_up(tmp_path, load):
    """The batch's workers plan into staged folders of their own: SIGTERM to the command ends
    them with SIGTERM, each removes its staging folder and lock."""
    jobs = [str(write(tmp_path, SMALL, f"job{k}.yaml")) for k in range(3)]
    out = tmp_path / "batch"
    outcome = signal_run(["plan", *jobs, "--workers", "2", "-o", str(out)], out,
                         signal.SIGTERM, processes=4, delay=2.0)  # command, server, 2 workers
    if not outcome.reached:
        pytest.skip("the batch ended before the signal (a fast host)")
    assert outcome.problems() == [], outcome.stderr
    assert not out.exists() or all(not leftovers(sub) for sub in out.iterdir())
    assert_kept_plans(out, outcome.last_line, of=3)


def assert_kept_plans(out: Path, last_line: str, of: int) -> None:
    """The batch's folder holds only complete plans, and the last line names each of them (or
    says that nothing was written)."""
    planned = sorted(out.iterdir()) if out.exists() else []
    if not planned:
        assert last_line.endswith("(nothing written)"), last_line
        return
    assert f"(kept {len(planned)} of {of} plans, each complete: " in last_line, last_line
    assert last_line.endswith("; nothing else written)"), last_line
    for folder in planned:
        assert str(folder) in last_line and (folder / "plan.json").exists(), folder


def test_a_batch_interrupted_names_the_plans_it_kept_also_one_published_unheard_of(
        tmp_path, monkeypatch, capsys):
    """A batch keeps each plan it completed (each folder written whole); the interrupt's line
    says which, instead of "nothing written" -- also the plan a worker published just before
    the signal, whose result never came back (here job1's: planned, then interrupted)."""
    import dloplan.app.files as files

    planned = files.plan_file

    def interrupted_after_the_second(options, path):
        if path.endswith("job2.yaml"):
            raise AssertionError("the batch goes on after the signal")
        result = planned(options, path)
        if path.endswith("job1.yaml"):
            raise Interrupted(signal.SIGTERM)
        return result

    monkeypatch.setattr(files, "plan_file", interrupted_after_the_second)
    jobs = [str(write(tmp_path, SMALL, f"job{k}.yaml")) for k in range(3)]
    out = tmp_path / "batch"
    assert main(["plan", *jobs, "--no-figures", "-o", str(out)]) == 128 + signal.SIGTERM
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith("dloplan: interrupted by SIGTERM (kept 2 of 3 plans"), last
    assert sorted(p.name for p in out.iterdir()) == ["job0", "job1"]
    assert_kept_plans(out, last, of=3)


def test_sigterm_to_a_study_ends_its_pool_and_keeps_only_complete_chunks(tmp_path, load):
    """A study keeps what it completed, to resume (docs/study.md): every file in its folder is
    complete, no temporary file or lock is left, and the next run resumes from it."""
    out = tmp_path / "study"
    outcome = signal_run(["study", str(STUDY), "--workers", "2", "--samples", "64", "--csv",
                          "-o", str(out)], out, signal.SIGTERM, marker="chunk 1/")
    if not outcome.reached:
        pytest.skip("the study ended before the signal (a fast host)")
    assert outcome.problems() == [], outcome.stderr
    chunks = sorted((out / "chunks").glob("*.csv"))
    if (out / "manifest.json").exists():  # the line names the folder, and its chunks
        assert f"(kept the study folder {out} with {len(chunks)} of " in outcome.last_line or \
            f"(kept the study's table and summary in {out}" in outcome.last_line, outcome.stderr
    else:
        assert outcome.last_line.endswith("(nothing written)"), outcome.stderr
    for chunk in chunks:
        lines = chunk.read_text().splitlines()
        assert len(lines) > 1 and all(line.count(",") == lines[0].count(",") for line in lines)


def test_a_keyboard_interrupt_that_compiled_code_turned_into_another_error(
        tmp_path, monkeypatch, capsys):
    """Ctrl-C inside compiled or extension code can surface as a SystemError ("returned a
    result with an exception set") or an ImportError; the command still ends with 130, one
    line, nothing written."""
    import dloplan.app.load as load

    resolved = load.resolve_mapping  # what `plan` calls on the job file's mapping

    def cut_short(*args, **kwargs):
        job = resolved(*args, **kwargs)
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise SystemError("<built-in function solve> returned a result with an exception "
                              "set") from exc
        return job

    monkeypatch.setattr(load, "resolve_mapping", cut_short)
    out = tmp_path / "out"
    assert main(["plan", str(write(tmp_path, SMALL)), "-o", str(out)]) == EXIT_INTERRUPTED
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == "dloplan: interrupted (nothing written)" and "Traceback" not in err
    assert not out.exists() and not leftovers(out)


WORKER_TASK = """
import os, signal, sys
from dloplan.interrupts import shielded, task, worker_signals
from dloplan.output_files import staged_folder

class SignalsInItsFinalizer:
    def __del__(self):
        os.kill(os.getpid(), signal.SIGTERM)
        sum(range(1000))  # the handler runs here: its exception is dropped by the finalizer

worker_signals()
with task(), staged_folder(sys.argv[2]) as staging:
    (staging / "plan.json").write_text("{}")
    if sys.argv[1] == "shielded":
        with shielded():  # a kernel loading (dloplan.jit.shielded_load)
            os.kill(os.getpid(), signal.SIGTERM)
            (staging / "loaded").write_text("the shielded block ran to its end")
            print("shielded block done", flush=True)
    else:
        SignalsInItsFinalizer()
        print("task went on", flush=True)
print("published", flush=True)
"""


@pytest.mark.parametrize("where", ["shielded", "finalizer"])
def test_a_worker_signalled_in_shielded_code_or_a_finalizer_cleans_up_and_ends(tmp_path, where):
    """A pool worker's SIGTERM inside shielded code (a kernel loading) is held until the block
    ends; one dropped by a finalizer is raised again before the task's folder is published.
    Either way the staging folder and the lock are removed, nothing is published, and the
    worker ends with 143 without an "Exception ignored" traceback."""
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-c", WORKER_TASK, where, str(out)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 128 + signal.SIGTERM, run.stderr
    assert "published" not in run.stdout and "Exception ignored" not in run.stderr, run.stderr
    assert ("shielded block done" if where == "shielded" else "task went on") in run.stdout
    assert not out.exists() and not leftovers(out) and list(tmp_path.iterdir()) == []


def _dloplan(*args) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "dloplan", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=interruptible)


def test_two_exports_into_one_folder_leave_files_that_read_back(tmp_path):
    """Two exports of the same joint trajectories into one folder at once: one writes, the
    other is refused while it holds the folder (or writes after it); every file reads back."""
    example = yaml.safe_load((Path(__file__).parents[1] / "examples" / "cells" /
                              "ur5e_pair_usb.yaml").read_text())
    planned = tmp_path / "plan"  # plan.json alone: what the exports read
    assert main(["plan", str(write(tmp_path, {**example, "outputs": ["json"]})), "-o",
                 str(planned), "-q"]) in (EXIT_OK, EXIT_WARNINGS)
    target = tmp_path / "joints"
    runs = [_dloplan("export", str(planned / "plan.json"), "--format", "ros_joints", "-o",
                     str(target), "-q") for _ in range(4)]
    results = [(run.wait(300), run.stderr.read()) for run in runs]
    assert any(code == EXIT_OK for code, _ in results), results
    for code, err in results:
        assert code == EXIT_OK or (code == EXIT_FAILURE and "another dloplan run" in err), err
    files = sorted(target.glob("*_joint_trajectory.yaml"))
    assert len(files) == 2 and not leftovers(target)
    assert len(list(target.glob("*.yaml"))) == 3  # and the gripper actions
    for path in files:
        message = yaml.safe_load(path.read_text())
        assert len(message["points"]) > 1 and len(message["joint_names"]) == 6
    assert yaml.safe_load((target / "dloplan_gripper_actions.yaml").read_text())["actions"]


def test_a_second_study_into_the_same_folder_is_refused_before_any_work(tmp_path):
    out = tmp_path / "study"
    first = _dloplan("study", str(STUDY), "--samples", "8", "--csv", "-o", str(out))
    line = first.stderr.readline()  # the first holds the folder from its start
    assert "loaded" in line or line.startswith("["), line
    before = snapshot(out)
    second = subprocess.run([sys.executable, "-m", "dloplan", "study", str(STUDY),
                             "--samples", "8", "--csv", "-o", str(out), "-q"],
                            capture_output=True, text=True, timeout=300)
    first_code = first.wait(600)
    if first_code == EXIT_OK and not before and second.returncode == EXIT_OK:
        pytest.skip("the first study ended before the second started")
    assert first_code == EXIT_OK, first.stderr.read()
    assert second.returncode == EXIT_FAILURE, second.stderr
    err = second.stderr.strip().splitlines()
    assert len(err) == 1 and "another dloplan run" in err[0], err
    summary = json.loads((out / "summary.json").read_text())
    assert summary and not leftovers(out)
    assert os.listdir(out)  # the first study's output, whole
