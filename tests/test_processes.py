"""The worker processes a command starts are ended with it, whenever its signal comes."""

from __future__ import annotations

import multiprocessing.forkserver
import os
import signal
from concurrent.futures import ProcessPoolExecutor

import pytest

from dloplan.interrupts import Interrupted, catching_interrupts
from dloplan.processes import end_forkserver, end_pool, running, submit_whole

pytestmark = pytest.mark.skipif("forkserver" not in multiprocessing.get_all_start_methods(),
                                reason="workers forked from a forkserver (POSIX)")


def test_a_signal_while_a_task_starts_its_worker_leaves_no_worker_behind(monkeypatch,
                                                                      terminal_sigint):
    """Ctrl-C arrives after the server forked the task's worker and before the pool recorded
    its id (the moment is forced: the signal is sent as the parent reads the new worker's id).
    The worker must be one the pool ends, not an orphan left waiting for tasks for ever (it held
    the pipes of a test that ran ``dloplan plan`` and interrupted it, once in a loaded suite)."""
    forked = []
    read_signed = multiprocessing.forkserver.read_signed

    def read_then_interrupt(fd):
        value = read_signed(fd)
        if not forked:  # the first read is the new worker's id
            forked.append(value)
            os.kill(os.getpid(), signal.SIGINT)
        return value

    monkeypatch.setattr(multiprocessing.forkserver, "read_signed", read_then_interrupt)
    pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("forkserver"))
    try:
        with catching_interrupts(), pytest.raises(Interrupted):
            try:
                submit_whole(pool, os.getpid)
            finally:  # what dloplan.cli does on a signal
                end_pool(pool)
                end_forkserver()
        assert forked, "no worker was started"
        assert not running(forked[0]), "the worker outlived its pool and its server"
    finally:
        for pid in forked:  # a failure must not leave it to the next test
            if running(pid):
                os.kill(pid, signal.SIGKILL)
