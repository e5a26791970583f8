"""The Cable: derived constants (thesis eqs. 3.1-3.23) and input validation."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from dloplan import CATALOGUE_NAMES, Cable, catalogue_cable


def test_derived_constants_follow_the_thesis_equations():
    c = Cable(length=0.5, diameter=0.005, mass=0.010, youngs_modulus=7.5e6, n_links=10,
              poisson_ratio=0.4, bending="thesis", masses="equal")
    l = 0.05
    area = math.pi * 0.005**2 / 4
    inertia = math.pi * 0.005**4 / 64
    assert c.rest_link_length == pytest.approx(l)
    assert np.allclose(c.point_masses, 0.010 / 11)  # eq. 3.1
    assert c.k_axial == pytest.approx(7.5e6 * area / l)  # eq. 3.10
    assert c.k_bending == pytest.approx(3 * 7.5e6 * inertia / l)  # eq. 3.13
    g = 7.5e6 / (2 * 1.4)
    assert c.k_twist == pytest.approx(g * 2 * inertia / l)  # eq. 3.16, Ip = 2 I
    m_i = 0.010 / 11
    assert c.k_damping == pytest.approx(2 * 0.05 * math.sqrt(m_i * c.k_axial))  # eq. 3.23
    assert c.time_step() == pytest.approx(math.sqrt(m_i * l / c.k_axial))  # 3.8.2


def test_rod_model_is_three_times_softer_in_bending():
    thesis = catalogue_cable("pu", bending="thesis")
    rod = catalogue_cable("pu", bending="rod")
    assert thesis.k_bending == pytest.approx(3 * rod.k_bending)
    assert rod.bending_stiffness == pytest.approx(rod.youngs_modulus * rod.second_moment)


def test_consistent_masses_put_half_links_at_the_ends():
    c = catalogue_cable("usb", n_links=10)
    assert c.point_masses.sum() == pytest.approx(c.mass)
    assert c.point_masses[0] == pytest.approx(c.mass / 20)
    assert c.point_masses[5] == pytest.approx(c.mass / 10)


def test_time_step_cap_enlarges_the_step_of_stiff_cables():
    c = catalogue_cable("pa12")
    assert c.time_step(1e7) == pytest.approx(c.time_step() * math.sqrt(1e9 / 1e7))
    assert c.time_step(1e12) == pytest.approx(c.time_step())


def test_catalogue_has_the_four_thesis_cables():
    assert set(CATALOGUE_NAMES) == {"usb", "ethernet", "pu", "pa12"}
    moduli = {name: catalogue_cable(name).youngs_modulus for name in CATALOGUE_NAMES}
    assert moduli == {"usb": 2.5e6, "ethernet": 7.5e6, "pu": 1e8, "pa12": 1e9}


def test_with_links_resamples_a_curved_rest_shape():
    c = catalogue_cable("pa12", n_links=10)
    turn = 0.15  # [rad] between consecutive links: equal chords l turning at constant rate
    headings = turn * np.arange(10)
    steps = np.stack([np.cos(headings), np.zeros(10), np.sin(headings)], 1) * c.rest_link_length
    rest = np.vstack([np.zeros(3), np.cumsum(steps, 0)])
    curved = replace(c, rest_shape=rest)
    assert curved.is_curved and not c.is_curved
    assert np.allclose(curved.rest_angles, turn)
    finer = curved.with_links(20)
    assert finer.n_links == 20 and finer.rest_shape.shape == (21, 3)
    # the same arc: total turning kept within a link's worth
    assert finer.rest_angles.sum() == pytest.approx(curved.rest_angles.sum(), rel=0.1)


@pytest.mark.parametrize(
    "field, value, fragment",
    [
        ("length", 0.0, "length"),
        ("length", -1.0, "length"),
        ("diameter", -0.001, "diameter"),
        ("mass", 0.0, "mass"),
        ("youngs_modulus", 0.0, "youngs_modulus"),
        ("youngs_modulus", float("nan"), "youngs_modulus"),
        ("poisson_ratio", 0.6, "poisson_ratio"),
        ("poisson_ratio", -1.0, "poisson_ratio"),
        ("n_links", 2, "n_links"),
        ("n_links", 3.5, "n_links"),
        ("bending", "stiff", "bending"),
        ("masses", "heavy", "masses"),
    ],
)
def test_bad_parameters_name_the_field(field, value, fragment):
    params = dict(length=0.5, diameter=0.005, mass=0.01, youngs_modulus=7.5e6)
    params[field] = value
    with pytest.raises(ValueError, match=fragment):
        Cable(**params)


def test_bad_rest_shapes_are_rejected():
    c = catalogue_cable("usb", n_links=4)
    with pytest.raises(ValueError, match="rest_shape: 4 points given, expected 5"):
        replace(c, rest_shape=np.zeros((4, 3)))
    straight = np.stack([np.linspace(0, 0.5, 5), np.zeros(5), np.zeros(5)], 1)
    with pytest.raises(ValueError, match="link lengths"):
        replace(c, rest_shape=straight * 1.1)
    bad = straight.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        replace(c, rest_shape=bad)


def test_unknown_catalogue_name():
    with pytest.raises(ValueError, match="unknown catalogue name 'copper'"):
        catalogue_cable("copper")
