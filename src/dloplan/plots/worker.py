"""What a figure worker process runs (:mod:`dloplan.app.figure_workers`): matplotlib and the
figure functions of :mod:`dloplan.plots.figures`, none of dloplan's solvers.

A :class:`dloplan.plots.figures.Drawing` holds plain arrays, so a worker that only imported
this module (and matplotlib) draws it: the workers are forked from a server process that
imported matplotlib and drew a first figure once (:mod:`dloplan.plots.warm`), so each starts
warm without importing numba, scipy or the planner.
"""

from __future__ import annotations

import io
import multiprocessing
from pathlib import Path

from ..interrupts import task, worker_signals
from ..processes import start_forkserver

_warm = False


def warm_up() -> None:
    """Import matplotlib (with its 3D axes) and draw a tiny figure with a 3D axes and a title
    as PNG (thrown away): fonts and the PNG backend are loaded before a plan's first figure
    (the SVG backend, for the occasional ``--svg``, loads with the first SVG). Does nothing the
    second time in a process."""
    global _warm
    if _warm:
        return
    from .figures import pyplot

    plt = pyplot()
    figure = plt.figure(figsize=(1, 1))
    axes = figure.add_subplot(projection="3d")
    axes.set_title("[N²]")
    figure.savefig(io.BytesIO(), format="png")
    plt.close(figure)
    _warm = True


def start() -> None:
    """A worker's start: Ctrl-C is the parent's to handle, SIGTERM and SIGHUP end it
    (:func:`dloplan.interrupts.worker_signals`); matplotlib warmed up (at once when the worker
    was forked from a warm server)."""
    worker_signals()
    warm_up()


def draw(drawing, folder: Path) -> list[Path]:
    """Draw one :class:`~dloplan.plots.figures.Drawing` into ``folder``, in its formats."""
    with task():
        return drawing.save(folder)


def context():
    """Where the workers come from: forked from a warm server (``forkserver``, preloading
    :mod:`dloplan.plots.warm`) where the platform has one, else forked from this process, else
    spawned. A server already started (by a study's backend) keeps its own preload; the
    workers then warm up themselves (:func:`start`)."""
    methods = multiprocessing.get_all_start_methods()
    if "forkserver" in methods:
        server = multiprocessing.get_context("forkserver")
        server.set_forkserver_preload(["dloplan.plots.warm"])
        return server
    return multiprocessing.get_context("fork" if "fork" in methods else None)


def start_server() -> None:
    """Start the workers' server now, without waiting for it: it imports matplotlib while this
    process imports the planner (the first worker's start waits until the server is warm, about
    1 s). Nothing to do where the platform has no server. Started out of the reach of a
    terminal's Ctrl-C (:func:`dloplan.processes.start_forkserver`): the command handles it and
    ends the server."""
    start_forkserver(context())
