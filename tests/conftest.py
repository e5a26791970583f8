"""Shared fixtures: reference shapes and standard clip set-ups."""

from __future__ import annotations

# ruff: noqa: E402 - the imports below follow the BLAS variables, set before numpy loads
from dloplan.cli import use_command_blas_threads

# The tests run dloplan's commands in-process (dloplan.cli.main): their BLAS runs as the
# command's does, on one thread (set before numpy loads; the xdist workers inherit it). With
# OpenBLAS's default threads, two workers on 2 cores spin on each other's core.
use_command_blas_threads()

import json
import signal
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dloplan.sim.clips import ClipPoses

REFERENCE = Path(__file__).parent / "reference"


def load_reference(name: str) -> dict:
    """A reference solution copied from shared/reference (see tests/reference/README.md)."""
    return json.loads((REFERENCE / f"{name}.json").read_text())


def level_clips(distance: float, z: float = 0.0) -> ClipPoses:
    """Two clips at (0, 0, z) and (distance, 0, z), end links horizontal, u inward."""
    return ClipPoses(
        np.array([[0.0, 0.0, z], [distance, 0.0, z]]),
        Rotation.from_euler("z", [[0.0], [180.0]], degrees=True),
    )


def sagging_guess(cable, distance: float, depth: float = -0.1) -> np.ndarray:
    """A rough start between level clips: a half sine of the given depth [m]."""
    n = cable.n_links
    s = np.linspace(0.0, 1.0, n + 1)
    l = cable.rest_link_length
    x = np.linspace(-l / 2, distance + l / 2, n + 1)
    return np.stack([x, np.zeros(n + 1), depth * np.sin(np.pi * s)], axis=1)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture
def terminal_sigint():
    """SIGINT as in a terminal (Python's KeyboardInterrupt handler) for the test, whatever the
    runner inherited: started in the background of a non-interactive shell, SIGINT is ignored
    and dloplan, rightly, does not catch it (``catching_interrupts`` keeps it ignored)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.hookimpl(trylast=True)  # after pytest-xdist's worker has named the groups
def pytest_collection_modifyitems(config, items):
    """The modules that run whole on one worker (``xdist_group``, ``make test``'s ``--dist
    loadgroup``) first: xdist hands out work in collection order, and a long group started last
    would run alone while the other worker idles. Order within each part is kept.

    On a worker of ``--dist loadgroup``, grouped tests whose ids lack their group (``@name``,
    what xdist schedules by) are warned about: with such a pytest and pytest-xdist pair (pytest
    9.2, xdist 3.8) the groups silently vanish and every module-scoped fixture is computed on
    both workers."""
    if getattr(config.option, "loadgroup", False):
        lost = [item.nodeid for item in items
                if item.get_closest_marker("xdist_group") is not None and "@" not in item.nodeid]
        if lost:
            warnings.warn(pytest.PytestWarning(
                f"--dist loadgroup: {len(lost)} tests marked xdist_group are not grouped (e.g. "
                f"{lost[0]}): this pytest and pytest-xdist do not work together; their module "
                f"fixtures run on both workers (see pyproject.toml)"), stacklevel=1)
    items.sort(key=lambda item: item.get_closest_marker("xdist_group") is None)
