"""The ``dloplan`` console script (and ``python -m dloplan``): signals handled from its first
line, the garbage collector tuned for a command (:data:`GC_THRESHOLDS`).

Until :func:`dloplan.cli.main` installs its handlers
(:func:`dloplan.interrupts.catching_interrupts`) the interpreter starts and imports the command
line, a few hundred milliseconds on a loaded host.
A signal then would kill the process by the signal (SIGTERM, SIGHUP) or print a KeyboardInterrupt
traceback (SIGINT). Nothing has been started or written yet, so this module, imported first, ends
the process at once with the code of an interrupted run, ``128 + signal`` (installed by
:func:`run`, not on import). A signal that is
ignored when the command starts (``nohup``, a background job of a non-interactive shell) stays
ignored.
"""

from __future__ import annotations

import gc
import os
import signal

GC_THRESHOLDS = (50_000, 20, 20)
"""The command's garbage-collector thresholds (Python's default: 700, 10, 10). A command
imports numpy, scipy, numba and the planner (about 180 000 tracked objects) and its kernels and
plan documents allocate many more; at the default, collections scan that heap again and again:
about 4 % of `plan --verify`'s CPU (qualitative-1, six runs alternating: 3.52 -> 3.39 s CPU,
4.36 -> 4.21 s wall, docs/performance.md). Cyclic garbage waits for 50 000 allocations instead
of 700: a few megabytes at most."""


def _before_start(signum, frame) -> None:
    os._exit(128 + signum)


def run() -> None:
    """The command (:func:`dloplan.cli.run`), its signals handled from this first line on, its
    garbage collector at :data:`GC_THRESHOLDS`."""
    gc.set_threshold(*GC_THRESHOLDS)
    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        signum = getattr(signal, name, None)
        if signum is not None and signal.getsignal(signum) is not signal.SIG_IGN:
            signal.signal(signum, _before_start)
    from .cli import run as command

    command()
