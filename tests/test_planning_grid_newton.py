"""The advanced stage's grid Newton solver: band kernels, GMRES, the system it solves, and the
plans it gives against sparse LU (the previous implementation)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from planning_cases import arc, folding_case
from scipy.sparse.linalg import splu
from scipy.spatial.transform import Rotation

import dloplan
from dloplan.geometry import shape_length
from dloplan.planning.geometric import (
    advanced_hessian,
    advanced_path,
    advanced_problem,
    basic_path,
    hessian_values,
)
from dloplan.planning.grid_newton import (
    GridNewton,
    band_lu,
    band_lu_solve,
    band_matvec,
    block_tridiagonal_factor,
    block_tridiagonal_solve,
    folded_order,
    galerkin_blocks,
    gmres,
    grid_layout,
    plane_of,
    prolong,
    restrict,
    scatter_add,
)


def _random_band(n, kl, rng, zero_diagonal=False):
    dense = np.zeros((n, n))
    for d in range(-kl, kl + 1):
        idx = np.arange(max(0, -d), min(n, n - d))
        dense[idx, idx + d] = rng.standard_normal(idx.size)
    if zero_diagonal:  # only partial pivoting gets through
        dense[np.arange(0, n, 3), np.arange(0, n, 3)] = 0.0
    ab = np.zeros((n, 3 * kl + 1))
    for j in range(n):
        for i in range(max(0, j - kl), min(n, j + kl + 1)):
            ab[j, 2 * kl + i - j] = dense[i, j]
    return dense, ab


@pytest.mark.parametrize("zero_diagonal", [False, True])
def test_band_lu_solves_like_a_dense_solver(zero_diagonal):
    rng = np.random.default_rng(1)
    dense, ab = _random_band(60, 5, rng, zero_diagonal)
    b = rng.standard_normal(60)
    np.testing.assert_allclose(band_matvec(np.ascontiguousarray(ab[:, 5:]), 5, b), dense @ b,
                               rtol=0, atol=1e-13 * np.abs(dense @ b).max())
    piv, ok = band_lu(ab, 5)
    assert ok
    x = band_lu_solve(ab, 5, piv, b)
    np.testing.assert_allclose(x, np.linalg.solve(dense, b), rtol=1e-10, atol=1e-10)


def test_band_lu_reports_a_singular_band():
    _, ab = _random_band(10, 2, np.random.default_rng(2))
    ab[4] = 0.0  # an empty column
    assert not band_lu(ab, 2)[1]


def test_block_tridiagonal_solve_is_a_dense_solve_also_with_indefinite_blocks():
    # symmetric indefinite diagonal blocks (a zero leading entry needs pivoting inside a block),
    # scalar couplings, a shift: against numpy's dense solve of the assembled matrix
    rng = np.random.default_rng(4)
    s, q, shift = 7, 5, 0.3
    blocks = rng.standard_normal((s, q, q))
    blocks = blocks + blocks.transpose(0, 2, 1) + 3.0 * np.eye(q)
    blocks[:, 0, 0] = -shift
    coupling = rng.standard_normal(s - 1)
    dense = np.zeros((s * q, s * q))
    for i in range(s):
        dense[i * q:(i + 1) * q, i * q:(i + 1) * q] = blocks[i] + shift * np.eye(q)
    for i in range(s - 1):
        dense[i * q:(i + 1) * q, (i + 1) * q:(i + 2) * q] = coupling[i] * np.eye(q)
        dense[(i + 1) * q:(i + 2) * q, i * q:(i + 1) * q] = coupling[i] * np.eye(q)
    inverses, ok = block_tridiagonal_factor(blocks, coupling, shift)
    assert ok
    b = rng.standard_normal(s * q)
    np.testing.assert_allclose(block_tridiagonal_solve(inverses, coupling, b),
                               np.linalg.solve(dense, b), rtol=0, atol=1e-10)
    blocks[3, :, 2] = 0.0  # a zero column in T_33 + shift I ...
    blocks[3, 2, 2] = -shift
    coupling[2] = 0.0  # ... not mended by the coupling to shape 2
    assert not block_tridiagonal_factor(blocks, coupling, shift)[1]


@pytest.mark.parametrize("coords", [(0, 2), (0, 1, 2)])
def test_restriction_and_prolongation_are_the_coarse_basis_and_its_transpose(coords):
    layout = grid_layout(7, 4, coords)
    z, s = layout.basis, layout.n_shapes
    m, q = z.shape
    np.testing.assert_allclose(z.T @ z, np.eye(q), atol=1e-14)  # orthonormal
    rng = np.random.default_rng(6)
    x, e = rng.standard_normal(s * m), rng.standard_normal(s * q)
    d = len(coords)
    np.testing.assert_allclose(restrict(x, layout.polynomials, d, s),
                               (x.reshape(s, m) @ z).ravel(), atol=1e-13)
    np.testing.assert_allclose(prolong(e, layout.polynomials, d, s),
                               (e.reshape(s, q) @ z.T).ravel(), atol=1e-13)


def test_scatter_add_is_bincount_in_the_same_order():
    rng = np.random.default_rng(5)
    slots, pick = rng.integers(0, 40, 500), rng.integers(0, 90, 500)
    values = rng.standard_normal(90) * 10.0 ** rng.integers(-8, 8, 90)
    # the same additions in the same order: equal bit for bit
    assert np.array_equal(scatter_add(slots, values, pick, 45),
                          np.bincount(slots, weights=values[pick], minlength=45))


def test_gmres_reaches_its_tolerance_on_a_nonsymmetric_system():
    rng = np.random.default_rng(3)
    a = np.eye(80) * 4 + rng.standard_normal((80, 80)) / 9
    b = rng.standard_normal(80)
    x, residual, iterations = gmres(lambda v: a @ v, lambda v: v / 4, b, 1e-12, 80)
    assert residual <= 1e-12 and iterations < 80
    np.testing.assert_allclose(x, np.linalg.solve(a, b), atol=1e-11)


def test_folded_order_makes_the_clip_points_neighbours():
    order = folded_order(11)
    assert sorted(order) == list(range(11))
    assert list(order[:4]) == [0, 10, 1, 9]


def _problem_at(inner_noise=0.01, seed=0, n_links=10, n_shapes=5, planar=False):
    cable, start, target = folding_case(n_links)
    if not planar:
        target = target.copy()
        target[:, 1] += 0.02 * np.sin(np.linspace(0, 3, cable.n_points))
    basic = basic_path(start, target, n_shapes)
    problem = advanced_problem(basic, cable.length)
    rng = np.random.default_rng(seed)
    noise = inner_noise * rng.standard_normal(basic[1:-1].shape)
    if planar:
        noise[..., 1] = 0.0
    return problem, basic[1:-1] / cable.length + noise, rng


@pytest.mark.parametrize("planar", [False, True])
def test_galerkin_blocks_are_the_coarse_projections_of_the_shapes_hessians(planar):
    # against dense Z^T H_ii Z from the band unpacked entry by entry, on a Hessian away from
    # the optimum (indefinite blocks); round-off of sums of ~100 terms of size up to max|H|
    problem, inner, _ = _problem_at(planar=planar)
    layout = grid_layout(problem.n_links, problem.n_shapes, (0, 2) if planar else (0, 1, 2))
    values, a = hessian_values(problem, inner)
    band = layout.band(values, a[:-1] + a[1:])
    kl, m, z = layout.half_band, layout.size // layout.n_shapes, layout.basis
    dense = np.zeros((layout.size, layout.size))
    for j in range(layout.size):
        for i in range(max(0, j - kl), min(layout.size, j + kl + 1)):
            dense[i, j] = band[j, 2 * kl + i - j]
    expected = np.stack([z.T @ dense[i * m:(i + 1) * m, i * m:(i + 1) * m] @ z
                         for i in range(layout.n_shapes)])
    blocks = galerkin_blocks(band, kl, z, layout.n_shapes)
    np.testing.assert_allclose(blocks, expected, rtol=0, atol=1e-12 * np.abs(band).max())
    # and the band holds no entry between two shapes, which the blocks could not see
    for i in range(1, layout.n_shapes):
        assert not np.any(dense[i * m:(i + 1) * m, :i * m])


@pytest.mark.parametrize("planar", [False, True])
def test_grid_system_is_the_sparse_hessian_and_solves_like_sparse_lu(planar):
    problem, inner, rng = _problem_at(planar=planar)
    coords = (0, 2) if planar else (0, 1, 2)
    layout = grid_layout(problem.n_links, problem.n_shapes, coords)
    values, a = hessian_values(problem, inner)
    system = GridNewton(layout, layout.band(values, a[:-1] + a[1:]), -a[1:-1])
    hess = advanced_hessian(problem, inner)
    keep = np.flatnonzero(np.isin(np.arange(hess.shape[0]) % 3, coords))
    sub = hess[keep][:, keep].tocsc()
    v = rng.standard_normal(inner.shape)
    v[..., [c for c in range(3) if c not in coords]] = 0.0
    # the same operator, in the solver's ordering
    np.testing.assert_allclose(layout.scatter(system.matvec(layout.gather(v))).ravel(),
                               hess @ v.ravel(), atol=1e-12 * np.abs(hess @ v.ravel()).max())
    rhs = layout.gather(v)
    for shift in (0.0, 3.0):
        step = system.solve(rhs, shift)
        assert step is not None
        exact = splu((sub + shift * sp.identity(sub.shape[0])).tocsc()).solve(v.ravel()[keep])
        # both to about 1e-12 relative residual; the Hessian's condition number is ~1e5 here
        np.testing.assert_allclose(layout.scatter(step).ravel()[keep], exact,
                                   atol=1e-9 * np.abs(exact).max())


def test_plane_of_finds_axis_planes_other_planes_and_none():
    _, start, target = folding_case()
    points = np.concatenate([start, target])
    assert plane_of(points) == (None, (0, 2))
    rot = Rotation.from_euler("xz", [30, 50], degrees=True)
    rotation, coords = plane_of(rot.apply(points) + 0.3)
    assert coords == (0, 1)
    normal_coordinate = (rot.apply(points) @ rotation.T)[:, 2]
    assert np.ptp(normal_coordinate) < 1e-14
    bent = points.copy()
    bent[3, 1] = 1e-3
    assert plane_of(bent) == (None, (0, 1, 2))


def _both(basic, length, **kw):
    p_gmres, s_gmres = advanced_path(basic, length, **kw)
    p_lu, s_lu = advanced_path(basic, length, linear_solver="lu", **kw)
    assert s_gmres.success and s_lu.success, (s_gmres.message, s_lu.message)
    return p_gmres, p_lu


@pytest.mark.parametrize("n_links, n_shapes", [(10, 5), (20, 12), (100, 5)])
def test_gmres_plans_equal_sparse_lu_plans(n_links, n_shapes):
    # the previous implementation (sparse LU of the full 3-D system) to 1e-9 m
    cable, start, target = folding_case(n_links)
    p_gmres, p_lu = _both(basic_path(start, target, n_shapes), cable.length)
    np.testing.assert_allclose(p_gmres, p_lu, rtol=0, atol=1e-9)


def test_gmres_plans_equal_sparse_lu_plans_on_a_mirrored_and_a_3d_job():
    cable, start, target = folding_case(16)
    mirror = np.array([-1.0, 1.0, 1.0])
    p_gmres, p_lu = _both(basic_path(start * mirror, target * mirror, 6), cable.length)
    np.testing.assert_allclose(p_gmres, p_lu, rtol=0, atol=1e-9)
    turn = arc(cable.length, np.pi / 2, cable.n_links, origin=(0.1, 0.1, 0.05))
    turn[:, 1] += np.linspace(0.0, 0.15, cable.n_points) ** 2  # leave the plane
    turn = turn[0] + (turn - turn[0]) * cable.length / shape_length(turn)
    p_gmres, p_lu = _both(basic_path(start, turn, 6), cable.length)
    np.testing.assert_allclose(p_gmres, p_lu, rtol=0, atol=1e-9)


def test_a_planar_job_in_a_tilted_plane_stays_in_its_plane_and_rotates_with_it():
    # solved in the plane (a 3-D solve may let round-off leave a planar saddle, see
    # docs/planner.md): the tilted job's path is the axis-plane path, rotated
    cable, start, target = folding_case()
    rot = Rotation.from_euler("xz", [25, 40], degrees=True)
    shift = np.array([0.1, -0.2, 0.3])
    path, _ = advanced_path(basic_path(start, target, 5), cable.length)
    tilted, status = advanced_path(basic_path(rot.apply(start) + shift,
                                              rot.apply(target) + shift, 5), cable.length)
    assert status.success
    np.testing.assert_allclose(tilted, rot.apply(path.reshape(-1, 3)).reshape(path.shape) + shift,
                               atol=1e-9)


def test_advanced_path_rejects_an_unknown_linear_solver():
    cable, start, target = folding_case()
    with pytest.raises(ValueError, match="linear_solver"):
        advanced_path(basic_path(start, target, 5), cable.length, linear_solver="cholesky")


def test_a_usb_cable_in_millimetres_plans_the_same_with_both_solvers():
    # another cable and unit: the dimensionless problem is the same for both solvers
    cable = dloplan.catalogue_cable("usb", n_links=12)
    start = arc(1000 * cable.length, 0.0, 12)
    target = arc(1000 * cable.length, 2.0, 12, origin=(150.0, 0.0, 40.0), heading=0.5)
    p_gmres, p_lu = _both(basic_path(start, target, 8), 1000 * cable.length)
    np.testing.assert_allclose(p_gmres, p_lu, rtol=0, atol=1e-9 * 1000)


def test_the_hessian_from_the_compiled_bands_equals_the_numpy_reference_blocks():
    # advanced_hessian takes the link and angle terms from the static core's compiled kernel;
    # the numpy kernels of dloplan.physics are the reference (same formulas, other code)
    from dloplan.physics.axial import axial_hessian_blocks
    from dloplan.physics.bending import bending_derivatives
    from dloplan.planning.geometric import C_BETA, C_DELTA

    problem, inner, _ = _problem_at(seed=4)
    n, s = problem.n_links, problem.n_shapes
    w = problem.weights
    values, a = hessian_values(problem, inner)
    reference = np.zeros((s, n + 1, 3, s, n + 1, 3))
    axial = w.delta * C_DELTA * n / s * axial_hessian_blocks(inner, 2.0, problem.start_links)
    bend = 2 * w.beta * C_BETA * n / s * bending_derivatives(inner, 1.0, problem.basic_angles)[1]
    clip = values[s * 9 * 3 * (n + 1):].reshape(s, 4, 3, 4, 3)
    points = [0, 1, n - 1, n]
    for i in range(s):
        for j in range(n):
            reference[i, j:j + 2, :, i, j:j + 2, :] += axial[i, j].reshape(2, 3, 2, 3)
        for j in range(n - 1):
            reference[i, j:j + 3, :, i, j:j + 3, :] += bend[i, j].reshape(3, 3, 3, 3)
        for p, jp in enumerate(points):
            for q, jq in enumerate(points):
                reference[i, jp, :, i, jq, :] += clip[i, p, :, q, :]
    size = s * (n + 1) * 3
    transversal = np.diag(a[:-1] + a[1:]) - np.diag(a[1:-1], 1) - np.diag(a[1:-1], -1)
    reference = reference.reshape(size, size) + np.kron(transversal, np.eye(3 * (n + 1)))
    hess = advanced_hessian(problem, inner).toarray()
    np.testing.assert_allclose(hess, reference, rtol=0, atol=1e-12 * np.abs(reference).max())
