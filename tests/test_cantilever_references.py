"""Cantilevers against the independent elastica references, shape by shape (not only the tip).

References (tests/reference/README.md): a planar elastica solver (solve_bvp) for L = 1 m,
EI = 1 N m^2, clamped horizontally at the origin; a dead tip load P (alpha = P L^2 / EI, checked
against Bisshopp & Drucker 1945) or its own weight q (Gamma = q L^3 / EI). The dloplan chain is
held by its first link with the clip point at the clamp (the chain is l/2 longer, so the elastic
part beyond the clamp is L); point i sits at arc length s_i = (i - 1/2) l from the clamp.

Tolerance: the shape error is first order in l here (the clamp sits at the middle of the held
link, whose half beyond the clamp is straight): measured 0.13-0.29 mm at n = 80 and about twice
that at n = 40. The test asks for every point within 0.5 mm (0.05 % of L) at n = 80 and an error
that falls by at least 40 % when l is halved.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import load_reference
from scipy.spatial.transform import Rotation

from dloplan.cable import Cable
from dloplan.physics import SpringChain
from dloplan.sim import ClipPoses, equilibrium

GRAVITY = 9.81


def held_cantilever(n: int, tip_load: float = 0.0, weight: float = 0.0):
    """Equilibrium of an n-link chain clamped at its clip point (0, 0, 0), x along the cable.

    ``tip_load`` [N] hangs on the last point; ``weight`` [N/m] is spread over the chain.
    """
    length = n / (n - 0.5)  # the elastic part beyond the clip point is 1 m
    d = 0.01
    cable = Cable(length=length, diameter=d, mass=max(weight * length / GRAVITY, 1e-12),
                  n_links=n, youngs_modulus=1.0 / (np.pi * d**4 / 64), bending="rod")
    chain = SpringChain.from_cable(cable)
    if weight == 0.0:
        chain = replace(chain, point_masses=np.zeros(n + 1))
    if tip_load:
        masses = chain.point_masses.copy()
        masses[-1] += tip_load / GRAVITY
        chain = replace(chain, point_masses=masses)
    l = cable.rest_link_length
    clips = ClipPoses(np.array([[0.0, 0, 0], [1.0, 0, 0]]), Rotation.identity(2))
    guess = np.stack([np.arange(n + 1) * l - l / 2, np.zeros(n + 1), np.zeros(n + 1)], 1)
    eq = equilibrium(cable, guess, clips, chain=chain, held="first",
                     gravity=np.array([0.0, 0.0, -GRAVITY]))
    assert eq.converged, eq.message
    return eq.shape, l


def shape_error(shape: np.ndarray, l: float, ref: dict) -> float:
    """Largest distance [m] of the chain's free points from the reference curve at equal s."""
    s = (np.arange(len(shape)) - 0.5) * l
    inside = (s >= 0) & (s <= ref["L"] + 1e-12)
    x = np.interp(s[inside], ref["s"], ref["x"])
    z = np.interp(s[inside], ref["s"], ref["z"])
    return float(np.max(np.hypot(shape[inside, 0] - x, shape[inside, 2] - z)))


@pytest.mark.parametrize("name, kwargs", [
    ("cantilever_tipload_alpha1", {"tip_load": 1.0}),
    ("cantilever_tipload_alpha2", {"tip_load": 2.0}),
    ("cantilever_selfweight_gamma1", {"weight": 1.0}),
    ("cantilever_selfweight_gamma5", {"weight": 5.0}),
    ("cantilever_selfweight_gamma10", {"weight": 10.0}),
])
def test_cantilever_shapes_match_the_elastica_and_converge(name, kwargs):
    ref = load_reference(name)
    assert ref["EI"] == 1.0 and ref["L"] == 1.0
    errors = {n: shape_error(*held_cantilever(n, **kwargs), ref) for n in (40, 80)}
    assert errors[80] < 5e-4, errors
    assert errors[80] < 0.6 * errors[40], errors  # converges under refinement
    shape, _ = held_cantilever(80, **kwargs)
    assert shape[-1, [0, 2]] == pytest.approx([ref["tip"]["x"], ref["tip"]["z"]], abs=3e-3)
