"""Signals that end a run: Ctrl-C (SIGINT), SIGTERM and SIGHUP, none of them lost.

:func:`catching_interrupts` (the command line's) turns each of :data:`SIGNALS` into an
:class:`Interrupted` exception raised in the main thread, a :class:`KeyboardInterrupt` that
carries the signal: every ``finally`` and ``except BaseException`` on its way runs, so the
staging folder and the lock of :func:`dloplan.output_files.staged_folder` are removed and the
worker processes are ended (:mod:`dloplan.processes`) before the command exits with ``128 + signal``
(:func:`exit_code`: 130 for Ctrl-C, 143 for SIGTERM, 129 for SIGHUP).

Python raises the exception at the next byte code. When that byte code belongs to a finalizer or
to a callback that C code called through ctypes (llvmlite's, while numba compiles a kernel;
observed under load), Python reports the exception as "Exception ignored", with a traceback, and
drops it; C code may also turn it into another exception (a ``SystemError`` of a function that
"returned a result with an exception set", an ``ImportError`` of a module whose import it cut
short). The signal is therefore also recorded (:func:`pending_signal`): a dropped interrupt is
kept off the terminal and raised again where the run makes progress or publishes its files
(:func:`raise_if_interrupted`), and the command line reads any exception that ends a run after a
signal as that signal (:func:`interrupt_of`). Clean-up code runs :func:`shielded`: a second signal
is recorded, not raised into the middle of the clean-up.

A worker process of a pool (:func:`worker_signals`, its initializer) leaves Ctrl-C to its parent
(ignored: a terminal sends it to the whole process group) and ends on SIGTERM or SIGHUP: inside a
task (:func:`task`) by :class:`Interrupted`, so the task's clean-up runs before it ends, between
tasks at once.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP")
                if hasattr(signal, name))
"""The signals that end a run cleanly (SIGHUP: the terminal closed; not on Windows)."""


class Interrupted(KeyboardInterrupt):
    """A signal that ends the run (a :class:`KeyboardInterrupt`, so code that handles Ctrl-C
    handles every one of :data:`SIGNALS`)."""

    def __init__(self, signum: int = signal.SIGINT) -> None:
        super().__init__(signum)
        self.signum = int(signum)

    @property
    def name(self) -> str:
        """``SIGINT``, ``SIGTERM``, ``SIGHUP``."""
        return signal.Signals(self.signum).name

    @property
    def exit_code(self) -> int:
        """The shell's code of a process ended by the signal: ``128 + signum``."""
        return exit_code(self.signum)


def exit_code(signum: int) -> int:
    """``128 + signum``: 130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP."""
    return 128 + int(signum)


_pending: list[int] = []  # the signals received while catching_interrupts was on, in order
_shields = [0]  # nesting depth of shielded() blocks in the main thread
_busy = [False]  # a worker process is running a task (task())
_worker = [False]  # this process is a pool's worker (worker_signals())
_ending: list[int] = []  # the signal a busy worker is ending by (its clean-up running)


def pending_signal() -> int | None:
    """The first signal received while :func:`catching_interrupts` was on, or ``None``."""
    return _pending[0] if _pending else None


def raise_if_interrupted() -> None:
    """Raise :class:`Interrupted` if a signal came while :func:`catching_interrupts` was on
    (again, if it was dropped where it was first raised)."""
    if _pending and not _shields[0]:
        raise Interrupted(_pending[0])


def _chain(exc: BaseException) -> Iterator[BaseException]:
    """``exc`` and the exceptions it came from (each one's cause, else its context), once."""
    seen = set()
    link: BaseException | None = exc
    while link is not None and id(link) not in seen:
        seen.add(id(link))
        yield link
        link = link.__cause__ or link.__context__


def interrupt_of(exc: BaseException) -> Interrupted | None:
    """The interrupt that ended a run with ``exc``: ``exc`` itself, a :class:`KeyboardInterrupt`
    in its chain (a ``SystemError`` or ``ImportError`` that compiled code made of it), or any
    exception after a recorded signal; ``None`` for an ordinary error."""
    for link in _chain(exc):
        if isinstance(link, Interrupted):
            return link
        if isinstance(link, KeyboardInterrupt):
            return Interrupted(pending_signal() or signal.SIGINT)
    signum = pending_signal()
    return None if signum is None else Interrupted(signum)


KEPT = "kept: "
"""The prefix of an exception's note naming what the ended run kept (:func:`keeping`)."""


@contextmanager
def keeping(kept: Callable[[], str | None]) -> Iterator[None]:
    """Run the block; when an exception ends it, note on the exception what the run keeps of its
    work, ``kept()`` (complete outputs written before it ended: a batch's plans, a study's
    chunks; ``None`` for nothing), for the command's last line (:func:`kept_of`), which would
    otherwise say that nothing was written."""
    try:
        yield
    except BaseException as exc:
        what = kept()
        if what:
            exc.add_note(KEPT + what)
        raise


def kept_of(exc: BaseException) -> str | None:
    """What the run ended by ``exc`` kept (the notes of :func:`keeping` on ``exc`` and the
    exceptions it came from, ``"; "``-joined), or ``None``."""
    kept = [note[len(KEPT):] for link in _chain(exc) for note in getattr(link, "__notes__", ())
            if note.startswith(KEPT)]
    return "; ".join(kept) or None


def _interrupted(signum, frame) -> None:
    _pending.append(signum)
    if not _shields[0]:
        raise Interrupted(signum)


@contextmanager
def shielded() -> Iterator[None]:
    """Run clean-up code to its end: a signal that comes meanwhile is recorded (and raised by the
    next :func:`raise_if_interrupted`), not raised in the middle of it."""
    _shields[0] += 1
    try:
        yield
    finally:
        _shields[0] -= 1


def _unraisable_unless_interrupt(previous_hook):
    """A :data:`sys.unraisablehook` that stays silent on a recorded interrupt (it is raised
    again by :func:`raise_if_interrupted`) and passes every other unraisable exception on."""
    def hook(unraisable) -> None:
        if not (_pending and issubclass(unraisable.exc_type, KeyboardInterrupt)):
            previous_hook(unraisable)
    return hook


@contextmanager
def catching_interrupts() -> Iterator[None]:
    """Turn :data:`SIGNALS` into :class:`Interrupted` while the block runs, record them for
    :func:`raise_if_interrupted`, and keep an interrupt dropped by a finalizer or a ctypes
    callback off the terminal (main thread only; elsewhere the block runs unchanged). A signal
    that is ignored when the block starts (SIGINT of a job started in the background of a
    non-interactive shell, SIGHUP under ``nohup``) stays ignored."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {}
    for signum in SIGNALS:
        if signal.getsignal(signum) is not signal.SIG_IGN:
            previous[signum] = signal.signal(signum, _interrupted)
    previous_hook = sys.unraisablehook
    sys.unraisablehook = _unraisable_unless_interrupt(previous_hook)
    _pending.clear()
    _shields[0] = 0
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        sys.unraisablehook = previous_hook
        _pending.clear()


def _end_worker(signum, frame) -> None:
    if not _busy[0]:  # between tasks nothing to clean up
        os._exit(exit_code(_ending[0] if _ending else signum))
    _pending.append(signum)  # raised again where the task makes progress, if dropped
    if _ending or _shields[0]:
        # a second signal (the parent's SIGTERM after a terminal's SIGHUP) while the first's
        # clean-up runs, or a signal inside shielded code (a kernel loading): recorded only
        return
    _ending.append(signum)
    raise Interrupted(signum)


def worker_signals() -> None:
    """Signals of a pool's worker process (call it in the pool's initializer): Ctrl-C ignored
    (the parent handles it and ends its workers), SIGTERM and SIGHUP end the worker, inside a
    :func:`task` by :class:`Interrupted` (the task's clean-up runs), between tasks at once.

    Inside a task the signal is handled as :func:`catching_interrupts` handles it in a command:
    recorded, held back during :func:`shielded` code, raised again by
    :func:`raise_if_interrupted` when a finalizer or a ctypes callback dropped it (seen as a
    batch's worker that went on planning after SIGTERM until it was killed, its staging folder
    and lock left behind)."""
    _worker[0] = True
    _pending.clear()
    sys.unraisablehook = _unraisable_unless_interrupt(sys.unraisablehook)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for signum in SIGNALS:
        if signum != signal.SIGINT:
            signal.signal(signum, _end_worker)


@contextmanager
def task() -> Iterator[None]:
    """Mark a worker process busy while the block runs (see :func:`worker_signals`): a SIGTERM
    or SIGHUP raises :class:`Interrupted` in it, and once the block's clean-up has run the
    worker ends (with ``128 + signal``) instead of waiting for its next task."""
    _busy[0] = True
    try:
        yield
        if _worker[0]:
            raise_if_interrupted()  # a signal dropped on its way: the task's result is void
    except BaseException as exc:
        interrupt = interrupt_of(exc) if _worker[0] else None
        if interrupt is not None:
            os._exit(interrupt.exit_code)
        raise
    finally:
        _busy[0] = False
