"""The compiled closed-form twist kernels against the jet reference and finite differences.

Tolerances: the kernels evaluate the closed forms of physics/twist_compiled.py, the reference
differentiates the same energies by second-order forward differentiation, so they agree to
round-off (1e-12 relative to the largest entry; observed ~1e-15). The finite-difference checks
use central differences of the energy itself in the chart (h = 1e-6 m for the gradient:
truncation ~h^2/L^2 ~ 1e-8 relative; h = 1e-5 m and 1e-5 rad for the Hessian from second
differences: truncation ~1e-7 and rounding ~eps |U| / h^2 ~ 1e-8 relative), so 1e-5 relative is
a strict check of closed forms that were wrong by O(1).
"""

from __future__ import annotations

import numpy as np
import pytest
from gripper_paths import curved_hose

from dloplan.cable import catalogue_cable
from dloplan.geometry import tangents
from dloplan.physics.rod_frames import discrete_twist, rotate_about, transported_directors
from dloplan.physics.twist import (
    TwistChain,
    centred_twist_derivatives,
    chart_directors,
    twist_derivatives,
    twist_energy,
    twist_energy_terms,
)
from dloplan.physics.twist_compiled import (
    carry_directors,
    interleaved_band,
    link_tangents,
    moved_directors,
    twist_angles,
    twist_energies,
    twist_load,
)
from dloplan.sim.stepping import twist_angle_factor


def random_state(cable, seed, bend=0.02):
    """A random crooked shape with randomly turned (unit, perpendicular) directors."""
    rng = np.random.default_rng(seed)
    n = cable.n_links
    x = np.cumsum(rng.normal(size=(n + 1, 3)) * bend, axis=0)
    t = tangents(x)
    side = np.cross(t[0], [0.0, 0.0, 1.0])
    d1 = transported_directors(x, side / np.linalg.norm(side))
    return x, rotate_about(d1, t, rng.normal(size=n) * 0.8)


CASES = [("ethernet", False, 12), ("pa12", False, 7), ("curved", True, 9), ("curved", True, 4)]


def cable_of(name, n):
    return curved_hose(n) if name == "curved" else catalogue_cable(name, n_links=n)


@pytest.mark.parametrize(("name", "curved", "n"), CASES)
@pytest.mark.parametrize("natural_twist", [0.0, 1.3])
def test_compiled_twist_derivatives_match_the_jet_reference(name, curved, n, natural_twist):
    cable = cable_of(name, n)
    tc = TwistChain.from_cable(cable, natural_twist)
    assert tc.directional == curved
    for seed in range(3):
        x, d1 = random_state(cable, seed)
        fast = centred_twist_derivatives(tc, x, d1)
        ref = twist_derivatives(tc, x, tangents(x), d1, np.zeros(n))
        for field in ("twist_gradient", "direction_gradient", "angle_gradient", "blocks"):
            a, b = getattr(fast, field), getattr(ref, field)
            scale = max(np.abs(b).max(), np.abs(ref.blocks).max() * 1e-3)
            assert np.abs(a - b).max() <= 1e-12 * scale, field
        terms = twist_energy_terms(tc, x, d1)
        u_t, u_d = twist_energies(x, d1, *tc.constants)
        for value, exact in ((fast.twist_energy, terms["twist"]), (u_t, terms["twist"]),
                             (fast.direction_energy, terms["bending_direction"]),
                             (u_d, terms["bending_direction"])):
            assert value == pytest.approx(exact, rel=1e-12, abs=1e-15 * tc.k_bending)


@pytest.mark.parametrize(("name", "curved", "n"), [CASES[1], CASES[3]])
def test_closed_forms_match_finite_differences_of_the_energy(name, curved, n):
    """Gradient and Hessian at the chart's centre against differences of U^t + U^d."""
    cable = cable_of(name, n)
    tc = TwistChain.from_cable(cable, 0.4)
    x0, d0 = random_state(cable, 7)
    t0 = tangents(x0)

    def energy(z):
        x = z[: 3 * (n + 1)].reshape(-1, 3)
        return twist_energy(tc, x, chart_directors(x, t0, d0, z[3 * (n + 1):]))

    d = centred_twist_derivatives(tc, x0, d0)
    z0 = np.concatenate([x0.ravel(), np.zeros(n)])
    m = len(z0)
    eye = np.eye(m)
    h = 1e-6
    numeric = np.array([(energy(z0 + h * e) - energy(z0 - h * e)) / (2 * h) for e in eye])
    exact = np.concatenate([(d.twist_gradient + d.direction_gradient).ravel(), d.angle_gradient])
    assert np.abs(numeric - exact).max() < 1e-6 * np.abs(exact).max()
    h = 1e-5
    numeric_h = np.empty((m, m))
    for i in range(m):
        for j in range(i + 1):
            a, b = h * eye[i], h * eye[j]
            numeric_h[i, j] = numeric_h[j, i] = (
                energy(z0 + a + b) - energy(z0 + a - b) - energy(z0 - a + b)
                + energy(z0 - a - b)) / (4 * h * h)
    assembled = np.zeros((m, m))
    for i in range(1, n):
        idx = [*range(3 * (i - 1), 3 * i), 3 * (n + 1) + i - 1, *range(3 * i, 3 * i + 3),
               3 * (n + 1) + i, *range(3 * (i + 1), 3 * (i + 2))]
        assembled[np.ix_(idx, idx)] += d.blocks[i - 1]
    assert np.abs(assembled - numeric_h).max() < 1e-5 * np.abs(numeric_h).max()


def moved_state(seed):
    """A random state, its points moved by about 4 mm and random turns of its links."""
    x, d1 = random_state(curved_hose(8), seed)
    rng = np.random.default_rng(seed + 2)
    return x, x + rng.normal(size=x.shape) * 0.004, d1, rng.normal(size=len(d1)) * 0.5


def test_moved_directors_are_the_chart_directors_made_orthonormal():
    x, x_new, d1, angles = moved_state(3)
    out = np.empty_like(d1)
    moved_directors(x, x_new, d1, angles, out)
    reference = chart_directors(x_new, tangents(x), d1, angles)
    assert np.abs(out - reference).max() < 1e-12
    assert np.abs(np.einsum("ij,ij->i", out, tangents(x_new))).max() < 1e-14


@pytest.mark.parametrize(("name", "n"), [("ethernet", 12), ("pa12", 7), ("usb", 3)])
@pytest.mark.parametrize("natural_twist", [0.0, 1.3])
def test_twist_load_is_the_jet_reference_gradient(name, n, natural_twist):
    """The dynamic simulator's one-pass U^t gradient against the forward-mode reference, and
    its constant angle Hessian k_t tridiag(-1, 2, -1) against the reference blocks."""
    cable = catalogue_cable(name, n_links=n)
    tc = TwistChain.from_cable(cable, natural_twist)
    k_t, rest_twist = tc.constants[:2]
    for seed in range(3):
        x, d1 = random_state(cable, seed)
        ref = twist_derivatives(tc, x, tangents(x), d1, np.zeros(n))
        t, lengths = np.empty((n, 3)), np.empty(n)
        link_tangents(x, t, lengths)
        assert np.abs(t - tangents(x)).max() < 1e-15
        assert lengths == pytest.approx(np.linalg.norm(np.diff(x, axis=0), axis=1), rel=1e-15)
        point_grad, angle_grad = np.empty_like(x), np.empty(n)
        u_t = twist_load(t, lengths, d1, k_t, rest_twist, point_grad, angle_grad)
        assert u_t == pytest.approx(twist_energy_terms(tc, x, d1)["twist"], rel=1e-12)
        scale = np.abs(ref.blocks).max() * 1e-3
        assert np.abs(point_grad - ref.twist_gradient).max() <= 1e-12 * scale
        assert np.abs(angle_grad - ref.angle_gradient).max() <= 1e-12 * scale
        angle_hessian = np.zeros((n, n))
        for s in range(n - 1):
            angle_hessian[np.ix_([s, s + 1], [s, s + 1])] += ref.blocks[s][np.ix_([3, 7], [3, 7])]
        free = angle_hessian[1:-1, 1:-1]
        assert np.abs(free - k_t * (2 * np.eye(n - 2) - np.eye(n - 2, k=1)
                                    - np.eye(n - 2, k=-1))).max() < 1e-12 * k_t
    band, factor = np.empty((2, n - 2)), np.empty((2, n - 2))
    assert twist_angle_factor(k_t, n, band, factor)
    lower = np.diag(factor[0]) + np.diag(factor[1, :-1], -1)  # factor[1, j] = L[j + 1, j]
    assert lower @ lower.T == pytest.approx(free + 2e-12 * k_t * np.eye(n - 2), rel=1e-12,
                                            abs=1e-12 * k_t)  # Cholesky round-off


def test_carry_directors_is_moved_directors_in_place():
    x, x_new, d1, angles = moved_state(4)
    n = len(d1)
    moved = np.empty_like(d1)
    moved_directors(x, x_new, d1, angles, moved)
    t, lengths = np.empty_like(d1), np.empty(n)
    link_tangents(x, t, lengths)
    carried = d1.copy()
    assert carry_directors(t, lengths, x_new, carried, angles, 1, n - 1)
    assert np.abs(carried[1:-1] - moved[1:-1]).max() < 1e-14
    assert np.array_equal(carried[[0, -1]], d1[[0, -1]])  # outside first .. stop - 1: kept
    assert np.abs(t - tangents(x_new)).max() < 1e-15
    assert lengths == pytest.approx(np.linalg.norm(np.diff(x_new, axis=0), axis=1), rel=1e-15)
    folded = x_new.copy()
    folded[5] = folded[3]  # link 4 turned back onto link 3: no frame can be carried there
    assert not carry_directors(t, lengths, folded, d1.copy(), angles, 1, n - 1)


def test_interleaved_band_is_the_joint_hessian():
    """The band against a dense assembly of the points' band and the stencil blocks."""
    rng = np.random.default_rng(2)
    n, link = 6, 0.05
    n_pos, n_dof = 3 * (n + 1), 4 * n + 3
    dense_pos = np.zeros((n_pos, n_pos))
    for k in range(9):  # a symmetric band of half width 8 (points up to two apart)
        values = rng.normal(size=n_pos - k)
        dense_pos += np.diag(values, -k) + (np.diag(values, k) if k else 0)
    point = np.arange(n_pos) // 3
    dense_pos[np.abs(point[:, None] - point[None, :]) >= 3] = 0.0  # as in a chain's band
    band_pos = np.zeros((9, n_pos))
    for k in range(9):
        band_pos[k, : n_pos - k] = np.diag(dense_pos, -k)
    blocks = rng.normal(size=(n - 1, 11, 11))
    blocks = blocks + blocks.transpose(0, 2, 1)
    band = np.empty((11, n_dof))
    interleaved_band(band_pos, blocks, link, band)
    q = (4 * np.arange(n + 1)[:, None] + np.arange(3)).ravel()
    dense = np.zeros((n_dof, n_dof))
    dense[np.ix_(q, q)] = dense_pos
    scale = np.ones(11)
    scale[[3, 7]] = 1.0 / link
    for s in range(n - 1):
        dense[4 * s : 4 * s + 11, 4 * s : 4 * s + 11] += blocks[s] * np.outer(scale, scale)
    expected = np.zeros_like(band)
    for k in range(11):
        expected[k, : n_dof - k] = np.diag(dense, -k)
    assert np.abs(band - expected).max() < 1e-14 * np.abs(expected).max()


# one worker (make test: --dist loadgroup): the generic loop's Python calls compile an overload of
# twist_trial that the warm-up does not (9 s of CPU); both cases need it, and on two workers at
# the same moment both compiled it
@pytest.mark.xdist_group("test_twist_compiled_generic_loop")
@pytest.mark.parametrize("curved", [False, True])
def test_compiled_twist_loop_follows_the_generic_loop(curved):
    """The compiled Newton loop against the generic one (a table far below forces the generic
    loop; its contact energy is zero): the same iterations and energies, points to 1e-12 m."""
    from scipy.spatial.transform import Rotation

    from dloplan.obstacles.shapes import Table
    from dloplan.sim.clips import ClipPoses
    from dloplan.sim.torsion import equilibrium_with_twist, rest_clip_poses

    cable = curved_hose(12) if curved else catalogue_cable("pu", n_links=12)
    clips = rest_clip_poses(cable, natural_twist=0.3)
    turned = clips.rotations[1] * Rotation.from_rotvec([1.2, 0.0, 0.0])
    clips = ClipPoses(clips.positions + [[0, 0, 0], [-0.02, 0.01, 0.0]],
                      Rotation.concatenate([clips.rotations[0], turned]))
    guess = cable.rest_shape if curved else (
        np.arange(cable.n_points)[:, None] * [cable.rest_link_length, 0, 0])
    fast = equilibrium_with_twist(cable, guess, clips, natural_twist=0.3)
    generic = equilibrium_with_twist(cable, guess, clips, natural_twist=0.3,
                                     contacts=[Table(height=-10.0)])
    assert fast.success and generic.success
    assert fast.iterations == generic.iterations
    assert np.abs(fast.shape - generic.shape).max() < 1e-12
    assert np.abs(fast.directors - generic.directors).max() < 1e-10
    assert fast.energy_history == pytest.approx(generic.energy_history, rel=1e-10)
    assert fast.twist_energy == pytest.approx(generic.twist_energy, rel=1e-9)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_twist_angles_match_the_reference(seed):
    cable = curved_hose(9)
    x, d1 = random_state(cable, seed, bend=0.05)
    out = np.empty(cable.n_links - 1)
    twist_angles(x, d1, out)
    assert np.abs(out - discrete_twist(tangents(x), d1)).max() < 1e-12
