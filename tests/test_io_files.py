"""Files in and out under attack: bounded reads, locks, unique temporary files, a full disk."""

from __future__ import annotations

import errno
import os
import subprocess
import sys

import pytest

from dloplan import output_files as files
from dloplan.inputs import read_text
from dloplan.output_files import (
    atomic_file,
    atomic_write_texts,
    output_lock,
    refuse_overwriting_inputs,
    staged_files,
    staged_folder,
)


def test_read_text_refuses_what_is_not_a_bounded_regular_text_file(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    loop = tmp_path / "loop"
    loop.symlink_to(tmp_path / "loop2")
    (tmp_path / "loop2").symlink_to(loop)
    big = tmp_path / "big.yaml"
    big.write_text("x" * 1001)
    binary = tmp_path / "bin.yaml"
    binary.write_bytes(b"\xff\xfe\x00")
    cases = [("/dev/zero", "not a regular file"), (fifo, "not a regular file"),
             (tmp_path, "not a regular file"), (loop, "symbolic links"),
             (tmp_path / "none", "No such file"), (big, "more than the 0.001 MB"),
             (binary, "not a text file")]
    for path, fragment in cases:
        with pytest.raises(ValueError, match=fragment) as info:
            read_text(path, 1000, "job file")
        assert str(path) in str(info.value)
    assert read_text(big, 1001) == "x" * 1001


def test_a_job_file_with_a_byte_order_mark_reads_as_without(tmp_path):
    """Notepad and spreadsheets write UTF-8 with a byte-order mark; YAML and JSON job files read
    the same with it (json.loads refused it, YAML read the first key as '\\ufeffcable')."""
    from dloplan.io.scenario import read_mapping

    job = {"cable": {"name": "usb"}, "start": {"kind": "straight"}}
    for suffix, text in ((".yaml", "cable: {name: usb}\nstart: {kind: straight}\n"),
                         (".json", '{"cable": {"name": "usb"}, "start": {"kind": "straight"}}')):
        path = tmp_path / f"job{suffix}"
        path.write_bytes(b"\xef\xbb\xbf" + text.encode())
        assert read_text(path).startswith(text[:5])
        assert read_mapping(path) == job


def test_a_full_disk_names_the_file_and_leaves_the_old_one(tmp_path, monkeypatch):
    target = tmp_path / "out.csv"
    target.write_text("old")

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(files.os, "fsync", full)
    with pytest.raises(OSError) as info:
        atomic_write_texts({target: "new"})
    assert info.value.filename == str(target) and info.value.errno == errno.ENOSPC
    assert target.read_text() == "old" and os.listdir(tmp_path) == ["out.csv"]

    def full_writer(path):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(OSError) as info, atomic_file(tmp_path / "figure.png") as temp:
        full_writer(temp)
    assert info.value.filename == str(tmp_path / "figure.png")
    assert os.listdir(tmp_path) == ["out.csv"]


def test_two_writers_of_one_file_use_two_temporary_files(tmp_path):
    target = tmp_path / "a.svg"
    with atomic_file(target) as first, atomic_file(target) as second:
        assert first != second and first.parent == second.parent == tmp_path
        first.write_text("first")
        second.write_text("second")
    assert target.read_text() == "first"  # the outer one replaced last
    assert os.listdir(tmp_path) == ["a.svg"]


def test_a_lock_is_refused_while_held_and_taken_over_when_its_owner_died(tmp_path):
    out = tmp_path / "out"
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time; from dloplan.output_files import output_lock\n"
        f"with output_lock({str(out)!r}):\n"
        "    print('held', flush=True); time.sleep(60)")],
        stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(ValueError, match=f"another dloplan run \\(process {holder.pid}\\)"):
            with output_lock(out):
                pass
    finally:
        holder.kill()
        holder.wait()
    # killed: its lock file stays, nobody holds it; the next run takes it over
    assert (tmp_path / ".out.lock").exists()
    (tmp_path / ".out.tmp-dead").mkdir()
    with output_lock(out):
        assert (tmp_path / ".out.lock").read_text() == str(os.getpid())
    assert sorted(os.listdir(tmp_path)) == []


def test_a_failed_run_removes_the_parent_folders_it_made(tmp_path):
    out = tmp_path / "a" / "b" / "out"
    with pytest.raises(RuntimeError), staged_folder(out):
        raise RuntimeError("planning failed")
    assert os.listdir(tmp_path) == []


def test_staged_files_publish_all_or_nothing_beside_other_files(tmp_path):
    folder = tmp_path / "figs"
    folder.mkdir()
    (folder / "mine.txt").write_text("keep")
    with pytest.raises(RuntimeError), staged_files(folder) as staging:
        (staging / "one.png").write_text("1")
        raise RuntimeError("second figure failed")
    assert sorted(os.listdir(folder)) == ["mine.txt"]
    with staged_files(folder) as staging:
        (staging / "one.png").write_text("1")
        (staging / "two.png").write_text("2")
    assert sorted(os.listdir(folder)) == ["mine.txt", "one.png", "two.png"]
    assert sorted(os.listdir(tmp_path)) == ["figs"]


@pytest.mark.parametrize("output, inputs, refused", [
    ("OUT/plan.json", ["OUT/plan.json"], True),
    ("OUT", ["OUT/plan.json"], True),
    ("OUT/report.html", ["OUT/plan.json"], False),
    ("link", ["OUT/plan.json"], True),  # a symlink to OUT
    ("OUT2", ["OUT/plan.json"], False),
])
def test_an_output_that_is_or_holds_an_input_is_refused(tmp_path, monkeypatch, output, inputs,
                                                         refused):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "OUT").mkdir()
    (tmp_path / "OUT" / "plan.json").write_text("{}")
    (tmp_path / "link").symlink_to(tmp_path / "OUT")
    if refused:
        with pytest.raises(ValueError, match="an input of this command"):
            refuse_overwriting_inputs(output, inputs)
    else:
        refuse_overwriting_inputs(output, inputs)


def test_an_output_that_cannot_be_written_names_it_its_folder_and_what_is_expected(tmp_path):
    """An output under a file, or in a folder nobody may write to, is one line naming the
    output, the folder and what is expected, not the lock file beside it (an inner detail);
    an output folder that is a file says that a folder is expected (the sweep's round 2)."""
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    cases = [(output_lock, blocker / "out", "a-file is a file, not a folder"),
             (atomic_file, blocker / "deeper" / "t.csv", "a-file is a file, not a folder"),
             (output_lock, os.path.join("/proc", "dloplan-out"), "/proc: ")]
    for writer, target, reason in cases:
        with pytest.raises(OSError) as caught, writer(target):
            pass
        line = str(caught.value)
        assert str(target) in line and reason in line and "expected a path in a folder" in line
        assert ".lock" not in line, line
    for stage in (staged_folder, staged_files):
        with pytest.raises(ValueError, match="exists and is a file; expected a.* folder"), \
                stage(blocker):
            pass
    with pytest.raises(OSError) as caught:  # the multi-file writer: the same line
        atomic_write_texts({tmp_path / "ok.txt": "a", blocker / "deeper" / "t.txt": "b"})
    line = str(caught.value)
    assert "a-file is a file, not a folder" in line and "expected a path in a folder" in line
    assert blocker.read_text() == "x" and sorted(os.listdir(tmp_path)) == ["a-file"]


def test_a_file_written_onto_a_folder_names_the_folder(tmp_path):
    """``export --format csv -o FOLDER``: the line names the folder and that a file was
    expected, not the temporary file whose replace failed; the folder is left as it was."""
    folder = tmp_path / "out"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    for write in (lambda: atomic_write_texts({folder: "x"}),
                  lambda: atomic_file(folder).__enter__()):
        with pytest.raises(ValueError, match=f"^{folder}: is a folder; expected the path of a "
                                             "file"):
            write()
    assert os.listdir(tmp_path) == ["out"] and os.listdir(folder) == ["notes.txt"]
