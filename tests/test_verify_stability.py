"""Elastic stability: Euler buckling of a clamped chain, a hanging cable, solver agreement."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from dloplan.cable import Cable, catalogue_cable
from dloplan.physics.chain import SpringChain, gradient, link_tensions
from dloplan.sim.clips import ClipPoses
from dloplan.sim.statics import equilibrium, free_hessian
from dloplan.verify.stability import (
    band_eigenpairs,
    elastic_stability,
    path_stability,
    quickest_method,
    stiffness_scale,
)

WEIGHTLESS = (0.0, 0.0, 0.0)
FACING = Rotation.from_rotvec([[0, 0, 0], [0, 0, math.pi]])  # u-axes +x and -x: clamped, facing


def straight_between(cable: Cable, distance: float) -> np.ndarray:
    """The straight equilibrium of a weightless cable whose clips are ``distance`` apart."""
    n = cable.n_links
    held = ClipPoses(np.array([[0, 0, 0], [distance, 0, 0.0]]), FACING).held_points(
        cable.rest_link_length
    )
    x = np.zeros((n + 1, 3))
    x[[0, 1, -2, -1]] = held
    x[1:-1, 0] = np.linspace(held[1, 0], held[2, 0], n - 1)
    return x


def test_euler_buckling_load_of_the_clamped_chain():
    # Rod model k_b = EI/l. Joint i carries the bending of the dual cell from mid-link i-1 to
    # mid-link i, so joints 1..n-1 cover exactly the cable between the two clip points (the
    # middles of the end links); the overhangs from clip point to end point are rigid. The
    # clamped column is therefore (n - 1) l long, and the clamped-clamped load is
    # P = 4 pi^2 EI / ((n - 1) l)^2. Discretization error O(1/n^2): 0.2 % at n = 40.
    cable = Cable(length=0.5, diameter=0.003, mass=0.01, youngs_modulus=2.5e6, n_links=40)
    l = cable.rest_link_length
    chain = SpringChain.from_cable(cable, WEIGHTLESS)
    rest_distance = (cable.n_links - 1) * l

    def smallest(distance):
        return elastic_stability(cable, straight_between(cable, distance), gravity=WEIGHTLESS,
                                 k=1, method="sparse").smallest

    # the straight compressed shape is an equilibrium (no net force on a free point)
    x = straight_between(cable, 0.999 * rest_distance)
    assert np.max(np.abs(gradient(chain, x)[2:-2])) < 1e-9
    # compress by moving the clips together until the smallest eigenvalue crosses zero
    assert smallest(rest_distance * (1 - 1e-7)) > 0 > smallest(rest_distance * (1 - 1e-3))
    critical = brentq(smallest, rest_distance * (1 - 1e-3), rest_distance * (1 - 1e-7),
                      xtol=1e-15)
    load = -link_tensions(chain, straight_between(cable, critical))[1]  # compression [N]
    euler = 4 * math.pi**2 * cable.bending_stiffness / rest_distance**2
    assert abs(load / euler - 1) < 0.02
    # the other lengths one might pick are off by about 5 %: the choice is testable
    assert abs(load / (4 * math.pi**2 * cable.bending_stiffness / cable.length**2) - 1) > 0.04
    # the buckling mode is the clamped-clamped first mode 1 - cos(2 pi s / L_eff), transverse
    stab = elastic_stability(cable, straight_between(cable, critical), gravity=WEIGHTLESS)
    mode = stab.modes[0]
    assert np.allclose(mode[:, 0], 0, atol=1e-6)  # no axial part
    s = (np.arange(cable.n_points) - 0.5) * l  # arc length from the first clip point
    transverse = mode[:, 1] if np.abs(mode[:, 1]).max() > np.abs(mode[:, 2]).max() else mode[:, 2]
    shape = 1 - np.cos(2 * np.pi * s / rest_distance)
    inner = slice(2, -2)
    corr = abs(np.dot(transverse[inner], shape[inner])) / (
        np.linalg.norm(transverse[inner]) * np.linalg.norm(shape[inner]))
    assert corr > 0.99
    # two bending planes: the first eigenvalue is double at the straight column
    assert abs(stab.eigenvalues[1] - stab.eigenvalues[0]) < 1e-6 * stab.scale
    assert not stab.stable  # at the critical load it is neutral


def test_hanging_cable_between_level_clips_is_stable():
    cable = catalogue_cable("usb", 20)
    clips = ClipPoses(np.array([[0, 0, 0.3], [0.35, 0, 0.3]]), FACING)
    guess = np.zeros((21, 3))
    guess[:, 0] = np.linspace(-0.05, 0.45, 21)
    eq = equilibrium(cable, guess, clips)
    stab = elastic_stability(cable, eq.shape)
    assert stab.stable and stab.is_equilibrium
    assert stab.smallest > 1.0 * stab.scale  # gravity stiffens it well beyond bending alone
    assert "stable" in stab.message


def skewed_ethernet() -> tuple[Cable, np.ndarray]:
    """An Ethernet cable (n = 30) held with its clips facing, one lifted and moved sideways: its
    equilibrium, a cable and shape with no symmetry."""
    cable = catalogue_cable("ethernet", 30)
    clips = ClipPoses(np.array([[0, 0, 0], [0.3, 0.05, 0.02]]), FACING)
    guess = np.zeros((31, 3))
    guess[:, 0] = np.linspace(-0.05, 0.45, 31)
    return cable, equilibrium(cable, guess, clips).shape


def test_sparse_and_dense_eigen_solves_agree():
    cable, x = skewed_ethernet()
    sparse = elastic_stability(cable, x, k=4, method="sparse")
    dense = elastic_stability(cable, x, k=4, method="dense")
    np.testing.assert_allclose(sparse.eigenvalues, dense.eigenvalues, rtol=1e-8)
    for a, b in zip(sparse.modes, dense.modes, strict=True):
        assert abs(abs(np.sum(a * b)) - 1) < 1e-6  # the same unit modes up to sign
    assert np.all(sparse.modes[:, [0, 1, -2, -1]] == 0)  # held points do not move


def test_the_sparse_eigen_solve_repeats_bit_for_bit():
    """ARPACK's own random start advances from call to call (the eigenvalues then differ in the
    15th digit, and a plan document is not repeatable); the seeded start makes every call the
    same."""
    cable, x = skewed_ethernet()
    runs = [elastic_stability(cable, x, k=4, method="sparse") for _ in range(4)]
    for run in runs[1:]:
        assert np.array_equal(run.eigenvalues, runs[0].eigenvalues)
        assert np.array_equal(run.modes, runs[0].modes)


def test_the_band_solver_agrees_with_the_dense_one():
    # the continuation's solver (LAPACK's banded eigen-solver on the Hessian band): the same
    # eigenvalues to round-off (100 eps ||H||_inf, the floor of the stability threshold: H's
    # entries are axial stiffnesses, lambda_1 a bending one), modes, threshold and verdict
    cable, x = skewed_ethernet()
    band = elastic_stability(cable, x, k=3, method="band")
    dense = elastic_stability(cable, x, k=3, method="dense")
    floor = 100 * np.finfo(float).eps * abs(free_hessian(cable, x)).sum(axis=1).max()
    np.testing.assert_allclose(band.eigenvalues, dense.eigenvalues, rtol=0, atol=floor)
    for a, b in zip(band.modes, dense.modes, strict=True):
        assert abs(abs(np.sum(a * b)) - 1) < 1e-8
    assert band.threshold == pytest.approx(dense.threshold, rel=1e-12)
    assert (band.stable, band.residual) == (dense.stable, dense.residual)
    # and a saddle (negative lambda_1) is one for both
    column = Cable(length=0.5, diameter=0.003, mass=0.01, youngs_modulus=2.5e6, n_links=12)
    x = straight_between(column, 0.9 * 11 * column.rest_link_length)
    saddle = [elastic_stability(column, x, gravity=WEIGHTLESS, method=m) for m in ("band", "dense")]
    assert not saddle[0].stable and not saddle[1].stable
    floor = 100 * np.finfo(float).eps * abs(free_hessian(column, x)).sum(axis=1).max()
    np.testing.assert_allclose(saddle[0].eigenvalues, saddle[1].eigenvalues, rtol=0, atol=floor)


def test_band_eigenpairs_of_random_banded_matrices(rng):
    # against numpy's dense eigh of the full symmetric matrix; the band's unused corner entries
    # (j + i >= N) hold garbage that must be ignored by both the solver and the norm
    for n_dof, width in ((7, 3), (30, 8), (45, 8)):
        band = rng.normal(size=(width + 1, n_dof))
        full = np.zeros((n_dof, n_dof))
        for i in range(width + 1):
            full += np.diag(band[i, : n_dof - i], -i) + (np.diag(band[i, : n_dof - i], i)
                                                         if i else 0)
        values, vectors, norm = band_eigenpairs(band, k=3)
        expected = np.linalg.eigh(full)
        np.testing.assert_allclose(values, expected[0][:3], rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(np.abs(vectors.T @ expected[1][:, :3]), np.eye(3),
                                   atol=1e-8)
        assert norm == pytest.approx(np.abs(full).sum(axis=1).max(), rel=1e-13)
    assert quickest_method(12) == "band" and quickest_method(200) == "auto"


def test_a_saddle_is_not_stable_and_a_non_equilibrium_is_named():
    cable = Cable(length=0.5, diameter=0.003, mass=0.01, youngs_modulus=2.5e6, n_links=12)
    # a straight column compressed well past its buckling load: an unstable equilibrium
    x = straight_between(cable, 0.9 * (cable.n_links - 1) * cable.rest_link_length)
    stab = elastic_stability(cable, x, gravity=WEIGHTLESS)
    assert stab.is_equilibrium and not stab.stable and stab.smallest < 0
    assert "not stable" in stab.message
    # the same shape under gravity is not an equilibrium at all
    heavy = elastic_stability(cable, x)
    assert not heavy.is_equilibrium and not heavy.stable
    assert "not an equilibrium" in heavy.message


def test_stiffness_scale_is_the_unloaded_simply_supported_eigenvalue():
    # lambda_ref = (k_b/l^2)(pi l/L)^4; converges to B l pi^4 / L^4 (B = k_b l).
    cable = catalogue_cable("pu", 50)
    l = cable.rest_link_length
    assert stiffness_scale(cable) == pytest.approx(
        cable.bending_stiffness * l * math.pi**4 / cable.length**4, rel=1e-12)


def test_path_stability_and_bad_inputs():
    cable = catalogue_cable("usb", 8)
    x = np.zeros((9, 3))
    x[:, 0] = np.linspace(0, 0.5, 9)
    with pytest.raises(ValueError, match="shapes"):
        path_stability(cable, np.zeros((2, 5, 3)))
    with pytest.raises(ValueError, match="k: got 0"):
        elastic_stability(cable, x, k=0)
    with pytest.raises(ValueError, match="rtol"):
        elastic_stability(cable, x, rtol=-1.0)
    with pytest.raises(ValueError, match="method"):
        elastic_stability(cable, x, method="lanczos")
    results = path_stability(cable, np.stack([x, x]), gravity=WEIGHTLESS)
    assert len(results) == 2 and all(r.stable for r in results)  # taut straight cable


def test_the_shortest_cable_n4_has_its_hessian_and_eigenvalues():
    """n = 4 (the schema's least) leaves one free point, 3 dof: fewer than the Hessian band's
    rows. `dloplan plan --verify` failed on it with scipy's 'Offset -4 out of bounds'. The
    banded eigenvalues and the row-sum norm equal those of the dense matrix (to 1e-9)."""
    from dloplan.physics.chain import hessian_band
    from dloplan.sim.statics import free_band

    cable = catalogue_cable("pa12", n_links=4)
    x = np.stack([np.linspace(0, cable.length, 5), np.zeros(5), np.full(5, 0.2)], axis=1)
    x[2, 2] -= 0.01  # a slightly bent shape: bending and axial terms both enter
    band = free_band(hessian_band(SpringChain.from_cable(cable), x), slice(2, 3))
    dense = free_hessian(cable, x).toarray()
    assert dense.shape == (3, 3) and np.allclose(dense, dense.T)
    values, _, norm = band_eigenpairs(band, k=3)
    np.testing.assert_allclose(values, np.linalg.eigvalsh(dense), rtol=1e-9)
    assert norm == pytest.approx(np.abs(dense).sum(axis=1).max(), rel=1e-9)
    assert elastic_stability(cable, x).eigenvalues.shape == (3,)
