"""The processes a run starts, ended at once when it is interrupted or fails.

A command may start worker processes: the figure workers (:mod:`dloplan.app.figure_workers`), a
batch run's or a study's local pool (:mod:`dloplan.study.backends`), all forked from
multiprocessing's ``forkserver``, a process of its own. Shutting a pool down waits for its
running tasks (seconds: a figure, a chunk of a study); when the run is interrupted or fails
nobody wants their results, so :func:`end_pool` ends the workers instead, and
:func:`end_forkserver` ends the server (which, while it imports its preload, would otherwise
outlive the command by a second or more, holding the caller's pipes). A worker ended with SIGTERM
runs the clean-up of its task (:func:`dloplan.interrupts.worker_signals`). Every pool's server is
started by :func:`start_forkserver`, out of the reach of a terminal's Ctrl-C, and every task is
sent by :func:`submit_whole`, so that a worker it starts is one :func:`end_pool` knows.
"""

from __future__ import annotations

import multiprocessing.forkserver
import multiprocessing.resource_tracker
import os
import signal
import time
from concurrent.futures import Future, ProcessPoolExecutor

from .interrupts import raise_if_interrupted, shielded

HANGUP = {signal.SIGHUP} if hasattr(signal, "SIGHUP") else set()
"""SIGHUP where the platform has it."""


def start_forkserver(context) -> None:
    """Start multiprocessing's forkserver now, if ``context`` uses one, with Ctrl-C blocked.

    The signal mask is kept across the server's ``exec`` and by every worker forked from it, so
    a terminal's Ctrl-C, sent to the whole process group, never reaches them (not even while
    the server imports its preload, when Python would print the interrupted import's
    traceback): the command handles it and ends them. SIGTERM and SIGHUP reach them (the server
    dies, a worker runs its task's clean-up: :func:`dloplan.interrupts.worker_signals`). A signal
    to this process meanwhile is held and raised after (:func:`dloplan.interrupts.shielded`), so
    the server is started whole or not at all. The signal's disposition is left alone: a Ctrl-C
    arriving meanwhile waits in the mask, not discarded.
    """
    if context.get_start_method() != "forkserver":
        return
    with shielded():
        # The server starts multiprocessing's resource tracker first. The tracker ignores
        # SIGINT and SIGTERM (and unblocks them when it is started), not SIGHUP: a terminal's
        # hang-up would kill it and the command would print its complaints. So it is started
        # here first with SIGHUP blocked (kept across its exec), then the server with SIGINT.
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, *HANGUP})
        try:
            multiprocessing.resource_tracker.ensure_running()
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
            multiprocessing.forkserver.ensure_running()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    raise_if_interrupted()


def submit_whole(pool: ProcessPoolExecutor, function, *args) -> Future:
    """``pool.submit(function, *args)`` with signals held until it returns, then raised.

    A submission may start a worker (a pool forked from a ``forkserver`` starts them as tasks
    come). A signal raised in the middle of that start, after the server forked the worker and
    before the pool recorded its id, left a worker nobody knew: :func:`end_pool` could not end
    it, and it outlived the command, waiting for tasks for ever, holding the caller's pipes (seen
    once as a plan interrupted with Ctrl-C whose test never saw its pipes close, under load).
    Held, the signal is raised once the worker is in the pool's table.
    """
    with shielded():
        future = pool.submit(function, *args)
    raise_if_interrupted()
    return future


GRACE = 2.0
"""[s] A worker is given this long to end after SIGTERM (its task's clean-up), then killed.
A worker that answers ends in milliseconds, and the wait ends as soon as none runs. It was 0.5 s:
once, in a fresh-clone make test under load, a SIGTERMed batch left a worker's staging folder
and lock behind, most likely a worker killed before its clean-up had run."""


def running(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie does not: it has ended, unreaped)."""
    try:
        with open(f"/proc/{pid}/stat") as handle:
            return handle.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False
    except OSError:  # no /proc (not Linux): ask the kernel
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True
        return True


def _signal_all(pids, signum: int) -> None:
    for pid in pids:
        try:
            os.kill(pid, signum)
        except ProcessLookupError:
            pass


def _end(processes, grace: float) -> None:
    """SIGTERM to each process, then SIGKILL to those still running after ``grace`` seconds.

    The processes are told by their ids, not by multiprocessing's view of them: a worker forked
    from a forkserver that has died (a terminal's hang-up reaches the whole group) is reported
    ended by multiprocessing (it learns of its end from the server) while it still runs."""
    pids = [p.pid for p in processes if p.pid is not None]
    for signum in (signal.SIGTERM, signal.SIGKILL):
        _signal_all([pid for pid in pids if running(pid)], signum)
        deadline = time.monotonic() + grace
        while any(running(pid) for pid in pids) and time.monotonic() < deadline:
            time.sleep(0.01)
    for process in processes:
        process.join(0.0)


MANAGER_WAIT = 2.0
"""[s] How long :func:`end_pool` waits for the pool's manager thread once the workers are gone."""


def end_pool(pool: ProcessPoolExecutor, grace: float = GRACE) -> None:
    """End a process pool now: tasks not started are cancelled, the workers are sent SIGTERM
    (killed after ``grace`` seconds), the pool is shut down (Python 3.14's
    ``ProcessPoolExecutor.terminate_workers``).

    The pool's manager thread is waited for at most :data:`MANAGER_WAIT` seconds, not without
    end: a worker ended while it was sending its result leaves half a message in the result
    pipe, and the thread, reading it, waits for the rest for ever (seen as a study that
    SIGTERM did not end, 1 run in 10-20 under load; the parent holds the pipe's writing end,
    so no end of file comes). Such a thread is left blocked: the command ends with ``os._exit``
    (:func:`dloplan.cli.run`), which does not wait for threads.
    """
    # The pool's processes and manager thread: documented only from Python 3.14 on
    # (terminate_workers); before, the executor's own attributes.
    processes = list((getattr(pool, "_processes", None) or {}).values())
    manager = getattr(pool, "_executor_manager_thread", None)
    try:
        _end(processes, grace)
    finally:
        pool.shutdown(wait=False, cancel_futures=True)
        if manager is not None:
            manager.join(MANAGER_WAIT)


def end_forkserver(grace: float = GRACE) -> None:
    """End multiprocessing's forkserver of this process, if it started one (SIGTERM, then
    SIGKILL after ``grace`` seconds); the next pool starts a new one."""
    # The server is module state of multiprocessing.forkserver (its pid and the pipe that keeps
    # it alive); its stop() closes that pipe and waits for it, so it is sent SIGTERM first.
    server = getattr(multiprocessing.forkserver, "_forkserver", None)
    pid = getattr(server, "_forkserver_pid", None)
    if pid is None:
        return
    try:
        os.kill(pid, signal.SIGTERM)
    except ProcessLookupError:
        pass
    deadline = time.monotonic() + grace
    while time.monotonic() < deadline:
        if os.waitid(os.P_PID, pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None:
            break
        time.sleep(0.01)
    else:
        os.kill(pid, signal.SIGKILL)
    server._stop()
