"""The ``dloplan`` console script (and ``python -m dloplan``): signals handled from its first line.

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

import os
import signal


def _before_start(signum, frame) -> None:
    os._exit(128 + signum)


def run() -> None:
    """The command (:func:`dloplan.cli.run`), its signals handled from this first line on."""
    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        signum = getattr(signal, name, None)
        if signum is not None and signal.getsignal(signum) is not signal.SIG_IGN:
            signal.signal(signum, _before_start)
    from .cli import run as command

    command()
