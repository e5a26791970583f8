"""The kernel warm-up that `make` runs after installing (dloplan.warmup)."""

from __future__ import annotations

import pytest

from dloplan import warmup


def test_an_exercise_runs_in_a_pool_process_and_is_reported():
    lines = []
    assert warmup.warm(workers=1, progress=lines.append, exercises=["study"])
    assert lines[0].startswith("warm-up: study ") and "FAILED" not in lines[0]
    assert "kernels compiled and cached in" in lines[-1]


def test_a_failing_exercise_is_named_with_its_error(monkeypatch):
    def broken():
        raise ValueError("no such scenario")

    monkeypatch.setitem(warmup.EXERCISES, "broken", broken)
    name, _, error = warmup.run_exercise("broken")
    assert name == "broken" and error == "ValueError: no such scenario"


def test_every_exercise_is_a_documented_function():
    assert list(warmup.EXERCISES)[:3] == ["plan path", "robot program", "twist"]
    assert all(callable(f) and f.__doc__ for f in warmup.EXERCISES.values())


def test_bad_worker_count_is_refused(capsys):
    with pytest.raises(SystemExit) as exit_:
        warmup.main(["--workers", "0"])
    assert exit_.value.code == 2
    assert "--workers: got 0, expected an integer >= 1" in capsys.readouterr().err


@pytest.mark.parametrize("given", [None, "2"])
def test_the_exercises_run_blas_on_one_thread_unless_told(monkeypatch, given):
    """As the command (dloplan.cli.BLAS_THREADS): the pool's processes inherit the variable;
    a value the caller set is kept."""
    import os

    seen = []
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    if given is not None:
        monkeypatch.setenv("OPENBLAS_NUM_THREADS", given)
    monkeypatch.setattr(warmup, "warm", lambda workers: seen.append(
        os.environ.get("OPENBLAS_NUM_THREADS")) or True)
    assert warmup.main([]) == 0
    assert seen == [given or "1"]


def test_the_harness_exercise_is_a_harness_job_with_pegs_and_fixtures():
    """The embedded harness job resolves (a schema change would otherwise show only as a FAILED
    line of make's warm-up), with the contacts whose kernels it is there to compile."""
    from dloplan.app.load import resolve_mapping
    from dloplan.pipeline.job import HarnessJob

    job = resolve_mapping(warmup.HARNESS, "warm-up harness")
    assert isinstance(job, HarnessJob)
    assert len(job.board.pegs) == 1 and len(job.board.fixtures) == 2


def test_the_warm_up_writes_bytecode_even_when_told_not_to(monkeypatch):
    """The exercises' processes write the bytecode of what they import (``make`` installs
    with ``uv pip install``, no byte-compiling), also under PYTHONDONTWRITEBYTECODE (the pool
    inherits the environment)."""
    import os
    import sys

    seen = []
    monkeypatch.setenv("PYTHONDONTWRITEBYTECODE", "1")
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    monkeypatch.setattr(warmup, "warm", lambda workers: seen.append(
        (os.environ.get("PYTHONDONTWRITEBYTECODE"), sys.dont_write_bytecode)) or True)
    assert warmup.main([]) == 0
    assert seen == [(None, False)]


def test_a_process_started_with_dash_b_writes_bytecode_once_told(tmp_path):
    """What the pool's initializer does in each of its interpreters, which multiprocessing
    starts with ``-B`` where the warm-up's own interpreter saw PYTHONDONTWRITEBYTECODE."""
    import subprocess
    import sys

    (tmp_path / "probe.py").write_text("VALUE = 1\n")
    code = ("import sys; from dloplan.warmup import write_bytecode; write_bytecode(); "
            f"sys.path.insert(0, {str(tmp_path)!r}); import probe")
    subprocess.run([sys.executable, "-B", "-c", code], check=True, timeout=60)
    assert [path.name.split(".")[0] for path in (tmp_path / "__pycache__").glob("*.pyc")] \
        == ["probe"]
