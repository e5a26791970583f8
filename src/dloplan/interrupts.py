"""Ctrl-C that cannot be lost.

Python turns SIGINT into a :class:`KeyboardInterrupt` raised in the main thread at the next
byte code. When that byte code belongs to a callback that C code called through ctypes (LLVM's,
while numba compiles a kernel; observed under load), the exception is printed as "Exception
ignored" and dropped: the run goes on and writes its output although the user asked it to stop.
The command line installs :func:`catching_interrupts`, which also records the interrupt, and the
places where a run makes progress or publishes its files call :func:`raise_if_interrupted`, so a
dropped interrupt is raised again there, before anything is written.
"""

from __future__ import annotations

import signal
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


@contextmanager
def catching_interrupts() -> Iterator[None]:
    """Record Ctrl-C for :func:`raise_if_interrupted` while the block runs (main thread only;
    elsewhere, and where SIGINT is ignored, the block runs unchanged)."""
    if threading.current_thread() is not threading.main_thread() \
            or signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        yield
        return
    previous = signal.signal(signal.SIGINT, _interrupted)
    _pending.clear()
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        _pending.clear()
