"""The mass-spring energy: exact gradients and Hessians, invariances, closed forms."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dloplan import catalogue_cable
from dloplan.geometry import as_shape
from dloplan.physics import (
    SpringChain,
    bending_angles,
    energy,
    energy_terms,
    forces,
    gradient,
    hessian,
    link_tensions,
)


def arc_rest_shape(cable, total_angle=1.5):
    """Points with equal chords l turning by a constant angle: a curved rest shape."""
    n = cable.n_links
    turn = total_angle / (n - 1)
    headings = turn * np.arange(n)
    steps = np.stack([np.cos(headings), np.zeros(n), np.sin(headings)], 1)
    return np.vstack([np.zeros(3), np.cumsum(steps, 0)]) * cable.rest_link_length


def chains(n=8):
    straight = catalogue_cable("ethernet", n_links=n)
    curved = replace(straight, rest_shape=arc_rest_shape(straight))
    return {"straight": (straight, SpringChain.from_cable(straight)),
            "curved": (curved, SpringChain.from_cable(curved))}


def finite_difference(f, x, eps=1e-7):
    out = []
    for i in np.ndindex(x.shape):
        xp, xm = x.copy(), x.copy()
        xp[i] += eps
        xm[i] -= eps
        out.append((f(xp) - f(xm)) / (2 * eps))
    return np.array(out)


@pytest.mark.parametrize("kind", ["straight", "curved"])
def test_gradient_and_hessian_match_finite_differences(kind, rng):
    # central differences with eps = 1e-7 m are accurate to ~1e-8 relative here
    cable, chain = chains()[kind]
    base = cable.rest_shape if cable.rest_shape is not None else arc_rest_shape(cable, 0.0)
    for _ in range(3):
        x = base + 0.01 * rng.standard_normal(base.shape)
        g = gradient(chain, x)
        g_fd = finite_difference(lambda y: energy(chain, y), x).reshape(x.shape)
        assert np.max(np.abs(g - g_fd)) < 1e-6 * np.max(np.abs(g))
        h = hessian(chain, x).toarray()
        h_fd = finite_difference(lambda y: gradient(chain, y).ravel(), x).reshape(h.shape).T
        assert np.max(np.abs(h - h_fd)) < 1e-6 * np.max(np.abs(h))
        assert np.array_equal(h, h.T)


def test_per_term_hessians_add_up(rng):
    cable, chain = chains()["curved"]
    x = cable.rest_shape + 0.01 * rng.standard_normal(cable.rest_shape.shape)
    total = hessian(chain, x).toarray()
    parts = hessian(chain, x, ("axial",)).toarray() + hessian(chain, x, ("bending",)).toarray()
    assert np.allclose(total, parts, rtol=0, atol=1e-12 * np.abs(total).max())


@pytest.mark.parametrize("kind", ["straight", "curved"])
def test_rest_shape_has_zero_elastic_force_in_any_rigid_placement(kind, rng):
    cable, _ = chains()[kind]
    weightless = SpringChain.from_cable(cable, gravity=(0, 0, 0))
    rest = cable.rest_shape if cable.rest_shape is not None else arc_rest_shape(cable, 0.0)
    for rotation in Rotation.random(5, random_state=1):
        placed = rotation.apply(rest) + rng.standard_normal(3)
        f = forces(weightless, placed)
        assert np.max(np.abs(f.axial)) < 1e-9
        assert np.max(np.abs(f.bending)) < 1e-9
        assert float(energy(weightless, placed)) < 1e-15


def test_energy_and_forces_are_invariant_under_rigid_motion(rng):
    cable, _ = chains()["curved"]
    chain = SpringChain.from_cable(cable, gravity=(0, 0, 0))
    x = cable.rest_shape + 0.02 * rng.standard_normal(cable.rest_shape.shape)
    rotation = Rotation.random(random_state=3)
    moved = rotation.apply(x) + np.array([0.3, -0.2, 0.1])
    assert float(energy(chain, moved)) == pytest.approx(float(energy(chain, x)), rel=1e-10)
    f, f_moved = forces(chain, x), forces(chain, moved)
    assert np.allclose(rotation.apply(f.bending), f_moved.bending, atol=1e-10)
    assert np.allclose(rotation.apply(f.axial), f_moved.axial, atol=1e-8)


def test_hookes_law_on_a_stretched_straight_cable():
    cable = catalogue_cable("pu", n_links=10)
    chain = SpringChain.from_cable(cable, gravity=(0, 0, 0))
    strain = 1e-3
    x = np.stack([np.linspace(0, cable.length * (1 + strain), 11), np.zeros(11), np.zeros(11)], 1)
    tension = cable.youngs_modulus * cable.area * strain  # F = E A dL / L
    assert np.allclose(link_tensions(chain, x), tension)
    f = forces(chain, x).axial
    assert f[0, 0] == pytest.approx(tension) and f[-1, 0] == pytest.approx(-tension)
    assert np.allclose(f[1:-1], 0.0, atol=1e-9 * tension)


def test_gravity_energy_and_batches():
    cable = catalogue_cable("usb", n_links=6)
    chain = SpringChain.from_cable(cable)
    x = np.zeros((7, 3))
    x[:, 0] = np.linspace(0, 0.5, 7)
    lifted = x + [0, 0, 0.1]
    terms = energy_terms(chain, lifted)
    assert float(terms["gravity"]) == pytest.approx(cable.mass * 9.81 * 0.1)
    batch = np.stack([x, lifted])
    assert np.allclose(energy(chain, batch), [energy(chain, x), energy(chain, lifted)])
    assert gradient(chain, batch).shape == (2, 7, 3)


def test_straight_and_folded_joints_are_finite():
    # beta = 0 (straight) and beta = pi (folded back) must not produce NaN
    cable = catalogue_cable("usb", n_links=4)
    curved = replace(cable, rest_shape=arc_rest_shape(cable, 1.0))
    straight = np.stack([np.linspace(0, 0.5, 5), np.zeros(5), np.zeros(5)], 1)
    folded = straight.copy()
    folded[3:, 0] = 2 * folded[2, 0] - folded[3:, 0]
    for c in (cable, curved):
        chain = SpringChain.from_cable(c)
        for x in (straight, folded):
            assert np.all(np.isfinite(gradient(chain, x)))
            assert np.all(np.isfinite(hessian(chain, x).toarray()))
    assert np.allclose(bending_angles(folded), [0.0, np.pi, 0.0])


@pytest.mark.parametrize(
    "points, fragment",
    [
        (np.zeros((5, 4)), "shape \\(k, 3\\)"),
        (np.zeros((4, 3)), "4 points given, expected 5"),
        (np.array([[0, 0, 0], [1, np.inf, 0], [2, 0, 0], [3, 0, 0], [4, 0, 0]]), "non-finite"),
        ("abc", "expected"),
    ],
)
def test_bad_shapes_are_named(points, fragment):
    with pytest.raises(ValueError, match=fragment):
        as_shape(points, 5, "shape")


def test_planar_points_are_placed_in_the_xz_plane():
    x = as_shape([[0, 0], [1, 2]], name="shape")
    assert np.array_equal(x, [[0, 0, 0], [1, 0, 2]])
