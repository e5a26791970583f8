"""The command under attack: absurd input, Ctrl-C, two runs on one folder, file permissions.

Every absurd input exits 2 with one line naming the field or file and writes nothing; an
interrupted run exits 130 and leaves the output folder as it was; two runs on one folder leave
one run's complete output; files are created with the process' umask.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from signal_runs import describe_process, group_members, interruptible
from test_cli import STIFF, write

from dloplan.cli import EXIT_FAILURE, EXIT_INTERRUPTED, EXIT_OK, EXIT_WARNINGS, main

SMALL = {**STIFF, "cable": {"name": "pa12", "n_links": 8}, "planner": {"n_shapes": 2},
         "outputs": ["json", "csv", "report"]}


def _place(data, position):
    job = json.loads(json.dumps(data))
    job["start"]["placement"]["position"] = position
    return job


ABSURD = [
    (_place(SMALL, [1e12, -0.25, 0.2]), "start: a point 1e+12 m from the origin"),
    ({**SMALL, "cable": {"name": "pa12", "n_links": 3}}, "cable.n_links"),
    ({**SMALL, "cable": {"name": "pa12", "n_links": 5000}}, "cable.n_links"),
    ({**SMALL, "trajectory": {"tcp_speed": -1}}, "trajectory.tcp_speed"),
    ({**SMALL, "planner": {"n_shapes": 10 ** 6}}, "planner.n_shapes"),
]


@pytest.mark.parametrize("data, fragment", ABSURD)
def test_absurd_input_exits_2_with_one_line_and_writes_nothing(tmp_path, capsys, data,
                                                                fragment):
    out = tmp_path / "out"
    code = main(["plan", str(write(tmp_path, data)), "-o", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == EXIT_FAILURE
    assert fragment in err and len(err.splitlines()) == 1, err
    assert not out.exists()


def test_files_that_are_not_job_files(tmp_path, capsys):
    binary = tmp_path / "bin.yaml"
    binary.write_bytes(b"\x00\xff\xfe\x00 binary")
    huge = tmp_path / "huge.yaml"
    with huge.open("w") as handle:  # 1.3 M points, as a registration dump might be
        handle.write("cable: {name: pa12}\nstart: {kind: straight}\ntarget:\n  kind: points\n"
                     "  points:\n")
        handle.write("  - [0.0, 0.0, 0.0]\n" * 600_000)
    for path, fragment in ((binary, "not a text file"), (huge, "more than the 10 MB"),
                           (tmp_path / "missing.yaml", "cannot read the file")):
        assert main(["plan", str(path), "-o", str(tmp_path / "out")]) == EXIT_FAILURE
        err = capsys.readouterr().err.strip()
        assert str(path) in err and fragment in err and len(err.splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_cli_overrides_pass_the_schema(tmp_path, capsys):
    example = Path(__file__).parents[1] / "examples" / "study_m2_ethernet.yaml"
    for samples in ("0", "-5"):
        out = tmp_path / f"study{samples}"
        assert main(["study", str(example), "--samples", samples, "-o", str(out)]) == \
            EXIT_FAILURE
        err = capsys.readouterr().err.strip()
        assert "--samples" in err and len(err.splitlines()) == 1
        assert not out.exists()
    bare = write(tmp_path, SMALL)  # no study: section: nothing to vary
    assert main(["study", str(bare), "-o", str(tmp_path / "s")]) == EXIT_FAILURE
    assert "nothing to vary" in capsys.readouterr().err


def test_an_output_folder_with_other_files_is_refused(tmp_path, capsys):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("precious")
    assert main(["plan", str(write(tmp_path, SMALL)), "-o", str(mine), "-q"]) == EXIT_FAILURE
    assert "other files than a dloplan output" in capsys.readouterr().err
    assert [p.name for p in mine.iterdir()] == ["thesis.tex"]


def test_files_follow_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        assert main(["plan", str(write(tmp_path, SMALL)), "-o", str(tmp_path / "out"),
                     "-q"]) in (EXIT_OK, EXIT_WARNINGS)
    finally:
        os.umask(old)
    out = tmp_path / "out"
    assert (out.stat().st_mode & 0o777) == 0o755
    for path in out.rglob("*"):
        expected = 0o755 if path.is_dir() else 0o644
        assert (path.stat().st_mode & 0o777) == expected, path


def _dloplan(*args, **kwargs) -> subprocess.Popen:
    """``dloplan ARGS`` with the default SIGINT disposition (:func:`interruptible`) and Python's
    fault handler on, so that :func:`_communicate` can show where a run that hangs is stuck."""
    return subprocess.Popen([sys.executable, "-m", "dloplan", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=interruptible,
                            env={**os.environ, "PYTHONFAULTHANDLER": "1"}, **kwargs)


def _communicate(process: subprocess.Popen, timeout: float) -> tuple[str, str]:
    """The run's output once it ends; a run still going after ``timeout`` [s] is aborted
    (SIGABRT: the fault handler prints every thread's stack) and the test fails with it."""
    try:
        return process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGABRT)
        _, stderr = process.communicate(timeout=30)
        pytest.fail(f"dloplan still ran {timeout:g} s after the signal; its stacks:\n{stderr}")


def test_ctrl_c_exits_130_and_leaves_the_folder_as_it_was(tmp_path):
    out = tmp_path / "out"
    assert main(["plan", str(write(tmp_path, SMALL)), "-o", str(out), "-q"]) in (EXIT_OK,
                                                                                  EXIT_WARNINGS)
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    slow = {**SMALL, "cable": {"name": "ethernet", "n_links": 40}, "planner": {"n_shapes": 30}}
    process = _dloplan("plan", str(write(tmp_path, slow, "slow.yaml")), "-o", str(out),
                       "--verify")
    first = process.stderr.readline()  # the job is loaded: planning has started
    time.sleep(1.0)
    process.send_signal(signal.SIGINT)
    stdout, stderr = _communicate(process, 120)
    stderr = first + stderr
    assert process.returncode == EXIT_INTERRUPTED, stderr
    assert stderr.strip().splitlines()[-1] == "dloplan: interrupted (nothing written)"
    assert "Traceback" not in stderr
    after = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".out")) == []


@pytest.mark.parametrize("when", ["while the figure server warms up", "while figures are drawn"])
def test_ctrl_c_in_a_terminal_stops_every_process_quietly(tmp_path, when):
    """A terminal's Ctrl-C goes to the whole process group: the command, the figure workers'
    server (busy importing matplotlib early on) and the workers (drawing later). The command
    ends with 130 and writes nothing; no process prints a traceback or outlives it."""
    out = tmp_path / "out"
    process = _dloplan("demo", "-o", str(out), start_new_session=True)
    if when == "while the figure server warms up":
        while len(group_members(process.pid)) < 2:  # the server is started (importing)
            assert process.poll() is None, process.communicate()
            time.sleep(0.01)
        first = ""
    else:
        first = ""
        while "cycle" not in first:  # the plan is made: its figures are being drawn
            line = process.stderr.readline()
            assert line, "the demo ended before its figures were drawn"
            first += line
    os.killpg(process.pid, signal.SIGINT)
    _, stderr = _communicate(process, 120)
    stderr = first + stderr  # everything the group wrote: the pipe closes when all have gone
    assert process.returncode == EXIT_INTERRUPTED, stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr, stderr
    assert not out.exists()
    deadline = time.monotonic() + 10.0
    while group_members(process.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    survivors = {pid: describe_process(pid) for pid in group_members(process.pid)}
    assert not survivors, f"a process of the command outlived it by 10 s: {survivors}"


def test_two_runs_on_one_folder_leave_one_complete_output(tmp_path):
    out = tmp_path / "out"
    jobs = [write(tmp_path, SMALL, "a.yaml"),
            write(tmp_path, {**SMALL, "cable": {"name": "pa12", "n_links": 9}}, "b.yaml")]
    runs = [_dloplan("plan", str(job), "-o", str(out), "-q") for job in jobs]
    results = [run.communicate(timeout=300) for run in runs]
    codes = [run.returncode for run in runs]
    assert any(code in (EXIT_OK, EXIT_WARNINGS) for code in codes), results
    for code, (_, err) in zip(codes, results, strict=True):
        assert code in (EXIT_OK, EXIT_WARNINGS) or "another dloplan run" in err, err
    doc = json.loads((out / "plan.json").read_text())
    page = (out / "report.html").read_text()
    n_links = doc["cable"]["n_links"]
    winner = jobs[0] if n_links == 8 else jobs[1]
    assert doc["source"] == str(winner) and str(winner) in page  # one run's files, not a mix
    comment = (out / "trajectory.csv").read_text().splitlines()[0]
    assert f"duration {doc['trajectory']['duration']:.6g} s" in comment
    assert not list(tmp_path.glob(".out.*"))


def test_a_run_killed_before_its_clean_up_leaves_nothing_behind_the_next_run(tmp_path):
    """timeout's SIGTERM ends a run without its clean-up: its lock and its staging folder stay
    beside the output folder; the next run takes the lock over and removes the folder."""
    from dloplan.output_files import OUTPUT_MARK, staged_folder

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    out = tmp_path / "out"
    (tmp_path / ".out.lock").write_text(str(dead.pid))
    (tmp_path / ".out.tmp-killed").mkdir()
    (tmp_path / ".out.tmp-killed" / OUTPUT_MARK).write_text("{}")
    with staged_folder(out) as staging:
        (staging / OUTPUT_MARK).write_text("{}")
    assert (out / OUTPUT_MARK).exists()
    assert not list(tmp_path.glob(".out.*"))


def test_a_plan_that_fails_a_check_writes_no_robot_program(tmp_path, capsys):
    far = json.loads(json.dumps(SMALL))
    far["target"]["placement"]["position"] = [0.9, -0.22, 0.25]  # beyond the YuMi's reach
    far["outputs"] = ["json", "csv", "rapid", "report"]
    out = tmp_path / "out"
    # the robot program's checks fail (they run without --verify); --no-repair: this is about
    # what is written, the repair's refusal of such a job is tested in test_repair.py
    code = main(["plan", str(write(tmp_path, far)), "-o", str(out), "--no-repair", "-q"])
    assert code == 3, capsys.readouterr()
    assert (out / "plan.json").exists() and (out / "report.html").exists()
    assert not (out / "rapid").exists() and not (out / "trajectory.csv").exists()


def test_the_demo_prints_no_warning(tmp_path, capsys):
    assert main(["demo", "-o", str(tmp_path / "demo")]) == EXIT_OK
    captured = capsys.readouterr()
    assert "warning" not in (captured.out + captured.err).lower()
    assert "verdict: ok" in captured.out
    report = (tmp_path / "demo" / "report.html").read_text()
    assert report.split("<p>", 1)[1].startswith("verdict: ok")  # the report opens with it


def test_a_dropped_ctrl_c_is_raised_again_before_anything_is_written(tmp_path, monkeypatch,
                                                                      capsys, terminal_sigint):
    """A KeyboardInterrupt raised inside a finalizer or a ctypes callback is reported as
    "Exception ignored" and dropped (seen in llvmlite's finalizers while numba compiles under
    load); the CLI records the signal, keeps the dropped one off the terminal and raises it again
    at the next progress line, so the run still ends with 130, one line and nothing written."""
    import dloplan.app.files

    planned = dloplan.app.files.make_plan

    class Finalized:
        def __del__(self):  # where llvmlite's finalizers met the interrupt
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.5)

    def dropping_the_interrupt(*args, **kwargs):
        Finalized()  # collected at once: its KeyboardInterrupt is unraisable
        return planned(*args, **kwargs)

    monkeypatch.setattr(dloplan.app.files, "make_plan", dropping_the_interrupt)
    monkeypatch.setattr(sys, "unraisablehook", sys.__unraisablehook__)  # not pytest's: print it
    out = tmp_path / "out"
    assert main(["plan", str(write(tmp_path, SMALL)), "-o", str(out)]) == EXIT_INTERRUPTED
    stderr = capsys.readouterr().err
    assert stderr.strip().splitlines()[-1] == "dloplan: interrupted (nothing written)"
    assert "Exception ignored" not in stderr and "Traceback" not in stderr
    assert not out.exists() and not list(tmp_path.glob(".out*"))
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
