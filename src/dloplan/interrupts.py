"""Ctrl-C that cannot be lost.

Python turns SIGINT into a :class:`KeyboardInterrupt` raised in the main thread at the next
byte code. When that byte code belongs to a finalizer or to a callback that C code called
through ctypes (llvmlite's, while numba compiles a kernel; observed under load), Python reports the
exception as "Exception ignored", with a traceback, and drops it: the run goes on and writes its
output although the user asked it to stop. The command line installs :func:`catching_interrupts`,
which records the interrupt and keeps such a dropped interrupt off the terminal, and the places
where a run makes progress or publishes its files call :func:`raise_if_interrupted`, so a dropped
interrupt is raised again there, before anything is written.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

_pending = threading.Event()


def raise_if_interrupted() -> None:
    """Raise :class:`KeyboardInterrupt` if Ctrl-C came while :func:`catching_interrupts` was on
    (again, if it was dropped where it was first raised)."""
    if _pending.is_set():
        raise KeyboardInterrupt


def _interrupted(signum, frame) -> None:
    _pending.set()
    raise KeyboardInterrupt


def _unraisable_unless_interrupt(previous_hook):
    """A :data:`sys.unraisablehook` that stays silent on the recorded interrupt (it is raised
    again by :func:`raise_if_interrupted`) and passes every other unraisable exception on."""
    def hook(unraisable) -> None:
        if not (_pending.is_set() and issubclass(unraisable.exc_type, KeyboardInterrupt)):
            previous_hook(unraisable)
    return hook


@contextmanager
def catching_interrupts() -> Iterator[None]:
    """Record Ctrl-C for :func:`raise_if_interrupted` while the block runs, and keep an interrupt
    dropped by a finalizer or a ctypes callback off the terminal (main thread only; elsewhere, and
    where SIGINT is ignored, the block runs unchanged)."""
    if threading.current_thread() is not threading.main_thread() \
            or signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        yield
        return
    previous = signal.signal(signal.SIGINT, _interrupted)
    previous_hook = sys.unraisablehook
    sys.unraisablehook = _unraisable_unless_interrupt(previous_hook)
    _pending.clear()
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        sys.unraisablehook = previous_hook
        _pending.clear()
