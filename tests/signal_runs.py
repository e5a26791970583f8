"""Real signals sent to real ``dloplan`` commands, and what they leave behind.

The machinery of ``tests/test_signals.py`` (a few moments in the default suite) and of
``benchmarks/signal_sweep.py`` (every command, signal and moment; it prints the outcomes and
times). A command runs as ``python -m dloplan.cli`` in a session of its own, so every process it
starts (the figure workers' forkserver and workers, a pool's workers) is found by its process
group; the signal goes to the command alone (``kill PID``, ``timeout``, a supervisor) or to the
whole group (a terminal's Ctrl-C or hang-up). An outcome is bad when the command does not exit
with ``128 + signal``, prints a traceback, changes its output folder, leaves a lock, a staging
folder or a temporary file, or a process of its group (or a pipe it holds) outlives it.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

HANG = 30.0
"""[s] What counts as a hang: a command (or a process it started) still there this long after
the signal. Not a timing claim: the measured times are printed by benchmarks/signal_sweep.py."""


def interruptible() -> None:
    """The default dispositions of SIGINT and SIGHUP in the child: a test runner started in the
    background of a non-interactive shell ignores SIGINT (under nohup, SIGHUP), its children
    inherit that, and the command rightly leaves an ignored signal ignored."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGHUP, signal.SIG_DFL)


def busy_loop() -> subprocess.Popen:
    """A process that keeps one core busy (load beside the test workers); kill it after."""
    return subprocess.Popen([sys.executable, "-c", "while True: pass"])


def group_members(pgid: int) -> list[int]:
    """Live (not zombie) processes of the process group ``pgid``."""
    members = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()  # after "pid (comm)": state ppid pgrp ...
        if fields[0] != "Z" and int(fields[2]) == pgid:
            members.append(int(entry))
    return members


def describe_process(pid: int) -> str:
    """A live process for a failure message: its state, where the kernel has it wait, its
    parent and its command line (what is left when it has gone meanwhile)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        wchan = Path(f"/proc/{pid}/wchan").read_text()
        command = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return "gone"
    return f"state {stat[0]}, waits in {wchan or '-'}, parent {stat[1]}: {command.strip()}"


def snapshot(folder: Path) -> dict:
    """Every file under ``folder`` -> its bytes (empty when it does not exist)."""
    if not folder.exists():
        return {}
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def leftovers(folder: Path) -> list[str]:
    """Locks, staging folders and temporary files of ``folder`` (beside it and inside it)."""
    name = folder.name
    found = [p.name for p in folder.parent.glob(f".{name}.*")]
    if folder.exists():
        found += [str(p.relative_to(folder)) for p in folder.rglob(".*")]
    return sorted(found)


@dataclass
class Outcome:
    """What a signal at one moment did to one command."""

    label: str
    signum: int
    moment: str
    code: int | None = None
    stderr: str = ""
    reached: bool = True  # the moment came before the command ended by itself
    exited_after: float = float("nan")  # [s] signal -> the command's exit
    gone_after: float = float("nan")  # [s] signal -> every process of its group gone, pipes shut
    survivors: list = field(default_factory=list)
    changed: bool = False
    left: list = field(default_factory=list)

    @property
    def before_start(self) -> bool:
        """The signal came while the interpreter itself started, before dloplan's first line
        (:mod:`dloplan.console`): the process ended by the signal's default action, which a
        shell reports as the same 128 + signal, with nothing started or written."""
        return self.code == -self.signum and not self.stderr.strip()

    @property
    def last_line(self) -> str:
        """The last line the command printed on stderr (``""`` for none)."""
        lines = self.stderr.strip().splitlines()
        return lines[-1] if lines else ""

    def problems(self) -> list[str]:
        """What went wrong (empty when nothing did); a moment that was not reached (the
        command had ended by itself) is no problem of the signal's."""
        if not self.reached:
            return []
        found = []
        expected = 128 + self.signum
        if self.code != expected and not self.before_start:
            found.append(f"exit {self.code}, expected {expected}")
        if "Traceback" in self.stderr or "Exception ignored" in self.stderr:
            found.append("traceback on stderr")
        if self.stderr.strip() and "dloplan: interrupted" not in self.last_line:
            found.append(f"last line {self.last_line!r}")
        if self.survivors:
            found.append(f"processes outlived the command: {self.survivors}")
        if self.changed and "(kept " not in self.last_line:
            found.append("the output folder changed, and the last line names nothing kept")
        if self.left:
            found.append(f"left behind: {self.left}")
        return found


def _reader(stream, lines: list, event_on: str | None, event: threading.Event) -> None:
    for line in stream:
        lines.append(line)
        if event_on is not None and event_on in line:
            event.set()
    event.set()  # EOF: the moment will not come (or came)


def signal_run(argv: list[str], output: Path, signum: int, *, marker: str | None = None,
               processes: int = 0, delay: float = 0.0, to_group: bool = False,
               cwd: Path | None = None, label: str = "") -> Outcome:
    """Run ``dloplan ARGV`` and send ``signum`` ``delay`` seconds after the first stderr line
    holding ``marker`` and once its group has ``processes`` live processes (the command, the
    forkserver, workers), to the command or to its whole group.

    Returns the :class:`Outcome`: exit code, stderr, what is left of the group and when it was
    gone, whether ``output`` changed and what is left beside it.
    """
    before = snapshot(output)
    moment = (f"{delay:g} s after {marker!r}" if marker else f"{delay:g} s") + \
        (f" and {processes} processes" if processes else "") + (" (group)" if to_group else "")
    outcome = Outcome(label or " ".join(argv[:1]), signum, moment)
    process = subprocess.Popen([sys.executable, "-m", "dloplan", *argv], cwd=cwd,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True, preexec_fn=interruptible,
                               env={**os.environ, "PYTHONFAULTHANDLER": "1"})
    lines: list[str] = []
    seen = threading.Event()
    reader = threading.Thread(target=_reader, args=(process.stderr, lines, marker, seen),
                              daemon=True)
    reader.start()
    drain = threading.Thread(target=process.stdout.read, daemon=True)
    drain.start()
    if marker is not None:
        seen.wait(HANG * 10)
    while len(group_members(process.pid)) < processes and process.poll() is None:
        time.sleep(0.01)
    time.sleep(delay)
    if process.poll() is not None:
        outcome.reached = False
    try:
        if to_group:
            os.killpg(process.pid, signum)
        else:
            os.kill(process.pid, signum)
    except ProcessLookupError:
        outcome.reached = False
    sent = time.monotonic()
    try:
        process.wait(HANG)
        outcome.exited_after = time.monotonic() - sent
    except subprocess.TimeoutExpired:  # hung: the fault handler prints its threads' stacks
        process.send_signal(signal.SIGABRT)
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.wait(5.0)
    deadline = sent + HANG
    while time.monotonic() < deadline and (group_members(process.pid) or reader.is_alive()
                                           or drain.is_alive()):
        time.sleep(0.01)
        reader.join(0.0)
        drain.join(0.0)
    outcome.gone_after = time.monotonic() - sent
    outcome.survivors = group_members(process.pid)
    for pid in outcome.survivors:  # do not leave them to the next test
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    if process.poll() is None:
        process.kill()
    outcome.code = process.wait()
    reader.join(5.0)
    outcome.stderr = "".join(lines)
    outcome.changed = snapshot(output) != before
    outcome.left = leftovers(output)
    return outcome
