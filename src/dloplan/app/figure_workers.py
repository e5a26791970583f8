"""A plan's figures drawn on worker processes while the run goes on.

matplotlib is the slowest part of writing a plan (five figures as PNG, about 2 s of CPU on the
slow host; the SVG copies of ``--svg`` are a second drawing of each, 1.5-1.8 times that; its
import alone about 0.7 s). :class:`FigureWorkers` takes that off the run's critical path:

- on POSIX the workers are forked from a server process (multiprocessing's ``forkserver``),
  started with the command (:func:`dloplan.plots.worker.start_server`), that imported
  matplotlib and drew a first figure once while the plan was being made
  (:mod:`dloplan.plots.warm`): each worker starts warm when the first figure is sent, two cost
  one matplotlib import, and none imports dloplan's solvers (a drawing holds plain arrays);
- :meth:`FigureWorkers.draft` draws a plan's figures as soon as it is planned, while its robot
  program is made and it is verified (``run_job``'s ``planned`` hook): before the program only
  those no program or repair changes (:func:`~dloplan.app.report.lasting_drawings`), the others
  when the program passes (a plan whose program fails is repaired: its path, shapes and motion
  figures would be drawn for nothing, beside the repair on a 2-core machine);
- a harness job's drafts (made before its verification, a second or more) are drawn by one
  process fewer than the cores (at least one): on 2 cores a second drawing process would take
  turns with the run itself on the run's core, and the run is the critical path; when the run
  waits for its figures (``render``) the other processes join and take the drafts not started
  yet. A scenario's drafts use every process (kept to one, its figures went into the tail);
- :meth:`FigureWorkers.render` is the ``figures`` writer: the final document's figures are the
  drafts whose inputs (every array, compared exactly) it still has; the others (a repaired plan)
  are drawn then. The files are the same as :func:`dloplan.app.report.write_figures` writes.
  A drawing carries its formats (:class:`dloplan.plots.figures.Drawing`), so a draft drawn as
  PNG only is not reused for a request with SVG: that figure is drawn again.

Everything is drawn into the run's staging folder (:func:`dloplan.output_files.staged_folder`), so
an error or a signal leaves nothing half-written: the workers leave Ctrl-C to the command
(:func:`dloplan.interrupts.worker_signals`); a run that ends well closes them (what has not
started is cancelled, what has is waited for), one that fails or is interrupted ends them at once
(:func:`dloplan.processes.end_pool`), before the staging folder goes.
"""

from __future__ import annotations

import hashlib
import multiprocessing
import os
import pickle
import shutil
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from pathlib import Path

from ..interrupts import shielded
from ..pipeline.document import PlanDocument
from ..plots import worker
from ..plots.figures import PNG
from ..processes import end_pool, submit_whole
from .report import figure_drawings, lasting_drawings

DRAFTS = ".figures"
"""The folder (inside the staging folder) the workers draw into; removed when done."""


def _key(drawing) -> str:
    """The identity of a figure: its name, function, every input, byte for byte, and its
    formats."""
    return hashlib.blake2b(pickle.dumps(drawing), digest_size=16).hexdigest()


class FigureWorkers:
    """Worker processes drawing the figures of the plans of one run into ``staging``.

    A first whole draft (a harness job's, made before its long verification) is drawn by
    ``drafting`` processes: on a machine with a core or two, one, so that the run itself (the
    critical path) keeps a core of its own; when the run waits for its figures (:meth:`render`)
    the other ``workers - drafting`` processes (started idle with that draft, so that they join
    at once) take the drafts not started yet and the figures drawn anew. A scenario's drafts
    (provisional first) are drawn by one pool of ``workers`` processes (:meth:`draft`).

    Parameters
    ----------
    staging : pathlib.Path
        The run's staging folder; drafts are drawn into ``staging/.figures/`` and moved into the
        ``figures/`` folder by :meth:`render`.
    workers : int
        Number of processes once the run waits for its figures (the command line's 2).
    formats : tuple of str
        The formats the drafts are drawn in (:data:`dloplan.plots.figures.PNG`, or
        :data:`~dloplan.plots.figures.WITH_SVG`): those :meth:`render` will be asked for.
    drafting : int, optional
        Number of processes drawing a first whole draft (a harness job's) while the run goes
        on, 1 to ``workers``; default ``workers``, but no more than the cores this process may
        use less one (:func:`usable_cores`), and at least 1.

    Attributes
    ----------
    drafting : int
        Processes drawing a first whole draft while the run goes on.
    """

    def __init__(self, staging: Path, workers: int = 2, formats: tuple[str, ...] = PNG,
                 drafting: int | None = None) -> None:
        if workers < 1:
            raise ValueError(f"workers: expected at least 1 process, got {workers}")
        if drafting is None:
            drafting = max(1, min(workers, usable_cores() - 1))
        if not 1 <= drafting <= workers:
            raise ValueError(f"drafting: expected 1 to {workers} processes, got {drafting}")
        worker.start_server()  # at once if the command has not started it yet
        self.drafting = drafting
        self._workers = workers
        self._pools: list[ProcessPoolExecutor] = []  # made by the first draft or render
        self._sent: list[list[Future]] = []  # per pool, the drawings sent to it
        self._waiting = 0  # processes that join when the run waits (a harness job's)
        self._spare: ProcessPoolExecutor | None = None  # those, started with the first draft
        self._scratch = Path(staging) / DRAFTS
        self._drafts: dict[str, Future] = {}
        self._formats = tuple(formats)

    def _submit(self, drawing) -> Future:
        key = _key(drawing)
        if key not in self._drafts:
            lane = min(range(len(self._pools)),
                       key=lambda i: sum(not f.done() for f in self._sent[i]))
            self._drafts[key] = submit_whole(self._pools[lane], worker.draw, drawing,
                                             self._scratch / key)
            self._sent[lane].append(self._drafts[key])
        return self._drafts[key]

    def _start(self, processes: int) -> None:
        """The first pool, of ``processes``; the other processes (``workers`` in all) kept
        back, forked idle now, so that they join at once (:meth:`_all_hands`)."""
        self._pools.append(_pool(processes))
        self._sent.append([])
        self._waiting = self._workers - processes
        if self._waiting:
            self._spare = _pool(self._waiting)
            for _ in range(self._waiting):
                submit_whole(self._spare, os.getpid)

    def _all_hands(self) -> None:
        """The run waits for its figures, or soon will: start the processes kept back while it
        went on, and take back the drafts not started yet (:meth:`render` and :meth:`draft`
        send those they need again, to whichever processes have the least to draw)."""
        if not self._waiting:
            return
        self._pools.append(self._spare)
        self._sent.append([])
        self._waiting, self._spare = 0, None
        for key in [key for key, future in self._drafts.items() if future.cancel()]:
            del self._drafts[key]

    def draft(self, doc: PlanDocument, provisional: bool = False) -> None:
        """Start drawing the figures of ``doc`` (a planned document, before its verification);
        ``provisional`` (before its robot program): only those that neither the program nor a
        repair changes (:func:`~dloplan.app.report.lasting_drawings`).

        A run whose first draft is provisional (a scenario's, whose program, verification and
        repairs follow) draws on one pool of ``workers`` processes, as it always did: measured,
        its figures kept to fewer processes went into the figures' tail; one whose first draft
        is whole (a harness job's, before its verification of a second or more) on the
        ``drafting`` processes, the others joining at :meth:`render`."""
        if not self._pools:
            self._start(self._workers if provisional else self.drafting)
        try:
            for drawing in (lasting_drawings(doc, self._formats) if provisional
                            else figure_drawings(doc, self._formats)):
                self._submit(drawing)
        except BrokenProcessPool:  # a worker died: render() draws the figures here
            pass

    def render(self, doc: PlanDocument, folder: Path,
               formats: tuple[str, ...] = PNG) -> list[Path]:
        """The ``figures`` writer: every figure of ``doc`` in ``formats`` in ``folder``, drafts
        reused where their inputs and formats are unchanged; the paths in the order of
        :func:`dloplan.app.report.write_figures`."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        drawings = figure_drawings(doc, formats)
        try:  # every figure sent before any is waited for: the new ones are drawn side by side
            if not self._pools:  # nothing drafted: every process draws
                self._start(self._workers)
            self._all_hands()
            futures = [self._submit(drawing) for drawing in drawings]
            drawn = [(drawing, future.result()) for drawing, future in zip(drawings, futures,
                                                                            strict=True)]
        except BrokenProcessPool:  # a worker died (killed, out of memory): draw them here
            drawn = [(drawing, drawing.save(self._scratch / _key(drawing)))
                     for drawing in drawings]
        written = []
        for _, paths in drawn:
            for path in paths:
                written.append(path.replace(folder / path.name))
        self._finish()
        return written

    def _finish(self) -> None:
        """Cancel the drafts nobody wants, wait for those already drawing, drop the drafts."""
        for future in self._drafts.values():
            future.cancel()
        for future in self._drafts.values():
            if not future.cancelled():
                future.exception()  # waits; a stale draft's error is of no interest
        self._drafts.clear()
        shutil.rmtree(self._scratch, ignore_errors=True)

    def close(self) -> None:
        """Stop the workers: what has not started is cancelled, what has is waited for."""
        try:
            self._finish()
        finally:
            for pool in self._pools + [self._spare] * (self._spare is not None):
                pool.shutdown(wait=True, cancel_futures=True)

    def abort(self) -> None:
        """End the workers at once (the run failed or was interrupted: no drawing is wanted);
        their drafts are removed."""
        with shielded():
            for pool in self._pools + [self._spare] * (self._spare is not None):
                end_pool(pool)
            shutil.rmtree(self._scratch, ignore_errors=True)


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the platform tells it)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _pool(processes: int) -> ProcessPoolExecutor:
    """``processes`` figure workers, forked from the warm server (:func:`.worker.context`)."""
    return ProcessPoolExecutor(processes, mp_context=worker.context(), initializer=worker.start)


@contextmanager
def figure_workers(staging: Path, workers: int, formats: tuple[str, ...] = PNG):
    """:class:`FigureWorkers` for one run (drafts in ``formats``), closed at its end; ``None``
    (figures drawn by the writer itself) for ``workers == 0`` or inside a daemonic process (a
    batch run's worker, which may not start processes of its own)."""
    if workers == 0 or multiprocessing.current_process().daemon:
        yield None
        return
    pool = FigureWorkers(staging, workers, formats)
    try:
        yield pool
    except BaseException:
        pool.abort()
        raise
    pool.close()
