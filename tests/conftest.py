"""Shared fixtures: reference shapes and standard clip set-ups."""

from __future__ import annotations

import json
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


def pytest_collection_modifyitems(config, items):
    """The modules that run whole on one worker (``xdist_group``, ``make test``'s ``--dist
    loadgroup``) first: xdist hands out work in collection order, and a long group started last
    would run alone while the other worker idles. Order within each part is kept."""
    items.sort(key=lambda item: item.get_closest_marker("xdist_group") is None)
