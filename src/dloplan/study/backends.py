"""Where the work runs: serially, in local processes, or on a Dask cluster.

Every backend offers the same operation, :meth:`Backend.map`: apply ``function(shared, item)``
to every item and yield ``(position, result)`` pairs as they complete. ``shared`` (the nominal
problem: cable, shapes, obstacles) is sent to each worker once, not with every item; items are
small (a chunk's parameters). At most ``max_in_flight`` items are submitted at a time, so a
study of a million samples never queues a million futures, and results stream back to be
written as they arrive.

The result of an item depends only on the item (no worker state, no random numbers drawn on the
worker), so every backend produces the same results; only their completion order differs.

* :class:`SerialBackend`: in this process (debugging, small studies, benchmarks' baseline).
* :class:`ProcessBackend`: ``concurrent.futures.ProcessPoolExecutor`` with ``workers``
  processes (a ``forkserver`` context on POSIX, which never forks a threaded parent; its
  server preloads a study's modules and kernels, :mod:`dloplan.warm_study`, so that workers
  start in milliseconds, warm). The workers leave Ctrl-C
  to the caller and end on SIGTERM or SIGHUP, running their task's clean-up
  (:func:`dloplan.interrupts.worker_signals`); an error or a signal in the caller ends them at
  once (:func:`dloplan.processes.end_pool`) rather than waiting for their tasks.
* :class:`DaskBackend`: a ``dask.distributed.Client`` given by the caller, or one connected to
  a scheduler address (``tcp://HOST:PORT``) and closed at the end. Dask is imported only here,
  and only when this backend is made.

:func:`map_jobs` is the one function a caller needs (a study, or a batch of scenario files).
"""

from __future__ import annotations

import gc
import multiprocessing
import os
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any

from ..interrupts import task, worker_signals
from ..processes import end_pool, start_forkserver, submit_whole

_SHARED: Any = None  # the shared object inside a worker process (set by the initializer)

STUDY_PRELOAD = ("dloplan.warm_study",)
""":class:`ProcessBackend`'s default preload: a study's modules and compiled kernels."""


def _install_shared(shared) -> None:
    """A local worker's start: its signals, the map's ``shared`` object, and what it holds now
    -- the server's preloaded modules and kernels (about 130 000 tracked objects), ``shared``
    -- frozen out of the garbage collector's scans (``gc.freeze``): they live as long as the
    worker, and each full collection the tasks trigger scanned them all (about 0.08 ms a
    sample of a 1024-sample closed-loop column when one fell in it, docs/performance.md,
    branch cl8)."""
    global _SHARED
    worker_signals()
    _SHARED = shared
    gc.freeze()


def _call_with_installed(function: Callable, item):
    with task():
        return function(_SHARED, item)


def _call(function: Callable, shared, item):
    return function(shared, item)


class Backend:
    """Base of the backends: ``map(function, items, shared)`` yields (position, result)."""

    workers: int = 1

    def map(self, function: Callable, items: Iterable, shared=None) -> Iterator[tuple[int, Any]]:
        raise NotImplementedError

    def start(self) -> None:
        """Get ready for :meth:`map` ahead of it, where that takes a while (nothing here)."""

    def close(self) -> None:
        """Release the backend's resources (processes, the client it opened)."""

    def __enter__(self) -> Backend:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def describe(self) -> str:
        return type(self).__name__


class SerialBackend(Backend):
    """Run every item in this process, in order."""

    def map(self, function, items, shared=None):
        for position, item in enumerate(items):
            yield position, function(shared, item)

    def describe(self) -> str:
        return "serial"


def _bounded(submit: Callable, items: Iterable, limit: int, wait_any: Callable):
    """Submit items keeping at most ``limit`` pending; yield (position, future) as they finish."""
    pending: dict = {}
    iterator = iter(enumerate(items))
    exhausted = False
    while True:
        while not exhausted and len(pending) < limit:
            try:
                position, item = next(iterator)
            except StopIteration:
                exhausted = True
                break
            pending[submit(item)] = position
        if not pending:
            return
        for future in wait_any(list(pending)):
            yield pending.pop(future), future


class ProcessBackend(Backend):
    """Local worker processes (``concurrent.futures.ProcessPoolExecutor``).

    Parameters
    ----------
    workers : int, optional
        Number of processes; default ``os.cpu_count()``.
    max_in_flight : int, optional
        Items submitted ahead of completion; default 4 per worker.
    preload : sequence of str
        Modules the server the workers are forked from imports first (a ``forkserver``; the
        first backend to start it sets them for the process): by default
        :mod:`dloplan.warm_study`, which loads a study's kernels too, so that no worker loads
        them again; ``("dloplan.study.evaluate",)`` imports numpy, scipy and the solver only.
    """

    def __init__(self, workers: int | None = None, max_in_flight: int | None = None,
                 preload: Sequence[str] = STUDY_PRELOAD) -> None:
        workers = (os.cpu_count() or 1) if workers is None else workers
        if isinstance(workers, bool) or int(workers) != workers or workers < 1:
            raise ValueError(f"workers: got {workers!r}, expected an integer >= 1")
        self.workers = int(workers)
        self.max_in_flight = _limit(max_in_flight, self.workers)
        if "forkserver" in multiprocessing.get_all_start_methods():
            self._context = multiprocessing.get_context("forkserver")
            # the server imports (and warms) once; workers fork from it ready
            self._context.set_forkserver_preload(list(preload))
        else:  # pragma: no cover - Windows
            self._context = multiprocessing.get_context("spawn")

    def start(self) -> None:
        """Start the workers' server now, without waiting for its preload (which a first
        worker waits for): it warms up while the caller does something else, e.g. plans.
        Out of the reach of a terminal's Ctrl-C (:func:`dloplan.processes.start_forkserver`)."""
        start_forkserver(self._context)

    def map(self, function, items, shared=None):
        self.start()
        pool = ProcessPoolExecutor(self.workers, mp_context=self._context,
                                   initializer=_install_shared, initargs=(shared,))

        def submit(item):
            return submit_whole(pool, _call_with_installed, function, item)

        def wait_any(futures):
            return wait(futures, return_when=FIRST_COMPLETED).done

        try:
            for position, future in _bounded(submit, items, self.max_in_flight, wait_any):
                yield position, future.result()
        except (Exception, KeyboardInterrupt):  # an error, a signal: nobody wants the tasks
            end_pool(pool)
            raise
        finally:  # also when the consumer stops early: drop what has not started
            pool.shutdown(wait=True, cancel_futures=True)

    def describe(self) -> str:
        return f"{self.workers} local processes"


class DaskBackend(Backend):
    """A Dask distributed cluster.

    Parameters
    ----------
    client : dask.distributed.Client, optional
        A connected client (kept open at the end).
    scheduler : str, optional
        A scheduler address ``tcp://HOST:PORT`` to connect to instead (the client is closed at
        the end).
    max_in_flight : int, optional
        Tasks submitted ahead of completion; default 4 per worker thread.
    """

    def __init__(self, client=None, scheduler: str | None = None,
                 max_in_flight: int | None = None) -> None:
        if (client is None) == (scheduler is None):
            raise ValueError("DaskBackend: give exactly one of client or scheduler")
        distributed = import_distributed()
        self._owned = client is None
        if client is None:
            if not isinstance(scheduler, str) or "://" not in scheduler:
                raise ValueError(f"scheduler: got {scheduler!r}, expected an address like "
                                 "tcp://HOST:PORT")
            try:
                client = distributed.Client(scheduler, timeout="20s")
            except OSError as exc:
                raise ValueError(f"scheduler: cannot connect to {scheduler} ({exc})") from None
            except Exception as exc:  # noqa: BLE001 - a service that is not a Dask scheduler
                # fails the client's handshake in its own ways (MemoryError, struct.error,
                # AssertionError: a traceback, exit 1, for a web server's port)
                raise ValueError(f"scheduler: {scheduler} answered, but not as a Dask scheduler "
                                 f"({type(exc).__name__}: {str(exc)[:80]}); expected the "
                                 "address of a running Dask scheduler") from None
        self.client = client
        threads = sum(client.nthreads().values()) or 1
        self.workers = threads
        self.max_in_flight = _limit(max_in_flight, threads)

    def map(self, function, items, shared=None):
        distributed = import_distributed()
        client = self.client
        shared_future = client.scatter(shared, broadcast=True, hash=False)

        def submit(item):
            return client.submit(_call, function, shared_future, item, pure=False)

        def wait_any(futures):
            return distributed.wait(futures, return_when="FIRST_COMPLETED").done

        try:
            for position, future in _bounded(submit, items, self.max_in_flight, wait_any):
                result = future.result()
                future.release()
                yield position, result
        finally:
            shared_future.release()

    def close(self) -> None:
        if self._owned:
            self.client.close()

    def describe(self) -> str:
        return f"Dask cluster at {self.client.scheduler.address} ({self.workers} threads)"


def _limit(max_in_flight: int | None, workers: int) -> int:
    if max_in_flight is None:
        return 4 * workers
    if isinstance(max_in_flight, bool) or int(max_in_flight) != max_in_flight or \
            max_in_flight < 1:
        raise ValueError(f"max_in_flight: got {max_in_flight!r}, expected an integer >= 1")
    return int(max_in_flight)


def import_distributed():
    """``dask.distributed``, or an ImportError naming the extra to install."""
    try:
        import dask.distributed as distributed
    except ImportError as exc:  # pragma: no cover - dask is installed with the study extra
        raise ImportError("the Dask backend needs dask.distributed: "
                          "pip install 'dloplan[study]'") from exc
    return distributed


def make_backend(workers: int | None = None, scheduler: str | None = None,
                 client=None, preload: Sequence[str] = STUDY_PRELOAD) -> Backend:
    """The backend a command line or a caller asks for.

    ``client`` or ``scheduler``: :class:`DaskBackend`; ``workers=1``: :class:`SerialBackend`;
    otherwise :class:`ProcessBackend` with ``workers`` processes (default: every core) and
    its server's ``preload``.
    """
    if client is not None or scheduler is not None:
        if workers is not None:
            raise ValueError("workers: not used with a Dask scheduler or client; size the "
                             "cluster instead")
        return DaskBackend(client=client, scheduler=scheduler)
    if workers == 1:
        return SerialBackend()
    return ProcessBackend(workers, preload=preload)


def map_jobs(function: Callable, items: Iterable, backend: Backend | None = None, *,
             shared=None) -> Iterator[tuple[int, Any]]:
    """Apply ``function(shared, item)`` to every item on a backend, yielding as they complete.

    Parameters
    ----------
    function : callable
        A module-level function (it is pickled by reference to reach the workers).
    items : iterable
        The work items, each small (they travel with every task).
    backend : Backend, optional
        Default: :class:`SerialBackend`.
    shared : object, optional
        Sent once to every worker and passed as the first argument.

    Yields
    ------
    (int, object)
        The item's position in ``items`` and its result, in completion order.
    """
    backend = backend or SerialBackend()
    yield from backend.map(function, items, shared)
