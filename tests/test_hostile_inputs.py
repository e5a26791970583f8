"""Every hostile input of tests/hostile_corpus.py ends the same way: exit 2, one line on stderr
naming the file or field, the value and what was expected, nothing written, no traceback, no
hang (a case still running after 10 s fails). Run in-process through ``dloplan.cli.main``;
``test_the_console_script_on_endless_inputs`` runs a few through the console script, where the
process' own behaviour (its exit code, its stderr) is what matters.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hostile_corpus import CASES, ROOT, SMALL, Case, World, write_yaml

from dloplan.cli import EXIT_FAILURE, main

# one worker (make test: --dist loadgroup): the world (a plan with its figures) is made once
pytestmark = pytest.mark.xdist_group("test_hostile_inputs")

HANG = 10.0
"""[s] A case still running after this long is a hang (a bad outcome, not a timing claim)."""


class Hang(Exception):
    """Raised by the alarm in a case that runs longer than :data:`HANG`."""


def _files(folder: Path) -> dict:
    """Every file under ``folder`` -> its hash (symlinks and special files by their name)."""
    found = {}
    for path in sorted(folder.rglob("*")):
        if path.is_symlink() or not path.is_file():
            found[str(path)] = "special"
        else:
            found[str(path)] = hashlib.blake2b(path.read_bytes(), digest_size=16).hexdigest()
    return found


@pytest.fixture(scope="session")
def pristine_world(tmp_path_factory) -> World:
    """The good files the cases start from: a small job and its plan (made once)."""
    from dloplan.vision import RegisteredShape, write_shapes

    folder = tmp_path_factory.mktemp("world")
    job = write_yaml(folder, SMALL)
    assert main(["plan", str(job), "-o", str(folder / "planned"), "-q"]) in (0, 1)
    plan = folder / "planned" / "plan.json"
    data = json.loads(plan.read_text())
    measured = write_shapes(folder / "measured.csv", [RegisteredShape(
        np.asarray(data["stabilized"][1]), frame_id=data["frame_id"], label="xi_1")])
    identification = folder / "identify.yaml"
    shutil.copy(ROOT / "examples" / "identify_ethernet.yaml", identification)
    study = folder / "study.yaml"
    shutil.copy(ROOT / "examples" / "study_m2_ethernet.yaml", study)
    urdf = folder / "ur5e.urdf"
    shutil.copy(ROOT / "src" / "dloplan" / "robot" / "data" / "ur5e.urdf", urdf)
    return World(folder, job, plan, identification, measured, urdf, study)


@pytest.fixture
def world(pristine_world, tmp_path_factory) -> World:
    """The world, put back as it was after a case that changed it (which fails that case)."""
    before = _files(pristine_world.folder)
    copy = tmp_path_factory.mktemp("pristine") / "world"
    shutil.copytree(pristine_world.folder, copy, symlinks=True)
    yield pristine_world
    if _files(pristine_world.folder) != before:
        shutil.rmtree(pristine_world.folder)
        shutil.copytree(copy, pristine_world.folder, symlinks=True)
    shutil.rmtree(copy)


def _argv(case: Case, world: World, folder: Path) -> tuple[list[str], Path]:
    made = case.make(folder, world) if case.make is not None else None
    out = folder / "out"
    names = {"job": world.job, "plan": world.plan, "ident": world.identification,
             "measured": world.measured, "urdf": world.urdf, "study": world.study,
             "world": world.folder, "f": made, "out": out}
    return [part.format(**{k: str(v) for k, v in names.items()}) for part in case.argv], out


def _alarm(signum, frame):
    raise Hang(f"still running after {HANG} s")


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_a_hostile_input_exits_2_with_one_line_and_writes_nothing(case, world, tmp_path,
                                                                   capsys):
    folder = tmp_path / "case"
    folder.mkdir()
    argv, out = _argv(case, world, folder)
    before_world, before_case = _files(world.folder), _files(folder)
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, HANG)
    try:
        code = main(argv)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert code == EXIT_FAILURE, (code, captured.err[-3000:], captured.out[-2000:])
    assert len(err) == 1, captured.err
    assert "Traceback" not in captured.err
    for fragment in case.fragments:
        assert fragment in err[0], (fragment, err[0])
    assert not out.exists(), f"{out} was written"
    assert _files(world.folder) == before_world, "a file of the world changed"
    assert _files(folder) == before_case, "the case's folder changed"


@pytest.mark.parametrize("command", [["plan", "/dev/zero"], ["verify", "/dev/urandom"],
                                     ["identify", "--design", "--cable", "ethernet", "--points",
                                      "1000000000"]])
def test_the_console_script_on_endless_inputs(command, tmp_path):
    """What the issue found exhausting memory, through the console script: exit 2, one line."""
    done = subprocess.run([sys.executable, "-c", "from dloplan.cli import run; run()",
                           *command, "-o", str(tmp_path / "out")] if command[0] == "plan" else
                          [sys.executable, "-c", "from dloplan.cli import run; run()", *command],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == EXIT_FAILURE, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert not (tmp_path / "out").exists()


def test_a_full_disk_is_one_line_naming_the_file(world, tmp_path, capsys, monkeypatch):
    """"No space left on device" alone does not say which file: the line names it, and nothing
    is left half-written (a tiny tmpfs would do the same; the write is made to fail here)."""
    import errno
    import os

    from dloplan import output_files as files

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(files.os, "fsync", full)
    out = tmp_path / "exported" / "trajectory.csv"
    assert main(["export", str(world.plan), "--format", "csv", "-o", str(out)]) == EXIT_FAILURE
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"dloplan: error: {out}: No space left on device"]
    assert not (tmp_path / "exported").exists()
