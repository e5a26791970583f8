"""Small study problems shared by the study tests: a cable hanging between level clips."""

from __future__ import annotations

import numpy as np
from conftest import level_clips, sagging_guess

from dloplan.cable import catalogue_cable
from dloplan.obstacles import Box, Table
from dloplan.sim.statics import equilibrium
from dloplan.study import study_problem

ALL_PARAMETERS = ("youngs_modulus", "mass_per_length", "length", "clip_position",
                  "clip_orientation", "obstacle_position")


def hanging_problem(name: str = "ethernet", n_links: int = 8, distances=(0.08, 0.11, 0.14),
                    height: float = 0.2, obstacles: bool = False):
    """A path of ``len(distances)`` shapes, the clips moving apart at ``height`` [m].

    With the Ethernet cable and clips 8-14 cm apart the cable hangs in a loop whose depth
    depends on the ratio of weight to bending stiffness (q L^3 / EI ~ 100): its sag falls
    strictly as E rises (checked for E/E0 in 0.3-3).

    The planned shapes are equilibria of the nominal cable (as the planner's physical stage
    delivers them), so the nominal plan passes the target check.
    """
    cable = catalogue_cable(name, n_links=n_links)
    shapes, clips = [], []
    for d in distances:
        guess = sagging_guess(cable, d, -0.05)
        guess[:, 2] += height
        clip = level_clips(d, height)
        shapes.append(equilibrium(cable, guess, clip).shape)
        clips.append(clip)
    extra = []
    if obstacles:
        extra = [Box((0.07, 0.0, 0.02), (0.05, 0.05, 0.04), 0.0, "block"), Table(0.0)]
    return study_problem(cable, np.stack(shapes), clips, extra)


def tables_equal(a: dict, b: dict) -> bool:
    """Same columns, same values bit for bit (NaN equal to NaN)."""
    if list(a) != list(b):
        return False
    for name in a:
        x, y = a[name], b[name]
        if x.dtype.kind == "f":
            if not np.array_equal(x, y, equal_nan=True):
                return False
        elif not np.array_equal(x, y):
            return False
    return True
