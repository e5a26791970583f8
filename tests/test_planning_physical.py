"""Physical stage (thesis 4.5): exact gradients, force reduction, target check, decoupling."""

from __future__ import annotations

import numpy as np
import pytest
from planning_cases import arc, folding_case

from dloplan.geometry import link_lengths, shape_length
from dloplan.physics.chain import SpringChain
from dloplan.planning.geometric import advanced_path, basic_path
from dloplan.planning.physical import (
    WEIGHTLESS,
    ThesisCost,
    held_conformed,
    minimize_shape,
    physical_stage,
    preprocess_target,
    reference_force,
)
from dloplan.planning.result import stage_forces
from dloplan.planning.tuning import PHYSICAL_WEIGHTS
from dloplan.sim.clips import HELD_INDICES, clip_poses_from_shape, place_held_points
from dloplan.sim.statics import equilibrium

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_planning_physical")


@pytest.fixture(scope="module")
def geometric():
    cable, start, target = folding_case()
    path, _ = advanced_path(basic_path(start, target, 5), cable.length)
    return cable, path


def test_held_conformed_places_the_held_points_like_the_clips(geometric):
    # the direct formula against the clips' frames, on shapes it was not written for: random
    # 3-D points of another scale, and the folding path's shapes; the held links get length l
    # about the middle of the end links, pointing the same way
    cable, path = geometric
    rng = np.random.default_rng(7)
    for shape in [*path, 3.0 * rng.standard_normal((cable.n_links + 1, 3))]:
        reference = place_held_points(shape, clip_poses_from_shape(shape), cable.rest_link_length)
        conformed = held_conformed(shape, cable)
        np.testing.assert_allclose(conformed, reference, rtol=0, atol=1e-14 * np.ptp(shape))
        held = link_lengths(conformed)[[0, -1]]
        np.testing.assert_allclose(held, cable.rest_link_length, rtol=1e-13)
        np.testing.assert_allclose(conformed[0] + conformed[1], shape[0] + shape[1], atol=1e-13)
    collapsed = path[2].copy()
    collapsed[-1] = collapsed[-2]
    with pytest.raises(ValueError, match="shape: an end link has zero length"):
        held_conformed(collapsed, cable)


@pytest.mark.parametrize("family", ["soft", "medium", "stiff"])
def test_thesis_cost_gradient_matches_finite_differences(geometric, family):
    cable, path = geometric
    chain = SpringChain.from_cable(cable, WEIGHTLESS)
    shape = held_conformed(path[3], cable)
    cost = ThesisCost(chain, shape, PHYSICAL_WEIGHTS[family], cable.rest_link_length,
                      reference_force(cable))
    rng = np.random.default_rng(2)
    x = shape + 1e-3 * rng.standard_normal(shape.shape)
    grad = cost.gradient(x)
    for _ in range(3):
        d = rng.standard_normal(x.shape)
        h = 1e-7  # [m]; the axial forces make the cost steep: small h, relative tol 1e-6
        fd = (cost.value(x + h * d) - cost.value(x - h * d)) / (2 * h)
        assert fd == pytest.approx(float(np.sum(grad * d)), rel=1e-6)


@pytest.mark.parametrize("mode", ["equilibrium", "thesis"])
def test_physical_stage_lowers_forces_and_evens_the_links(geometric, mode):
    cable, path = geometric
    results = physical_stage(cable, path[1:-1], mode=mode)
    assert all(r.success for r in results), [r.message for r in results]
    shapes = np.stack([r.shape for r in results])
    # the held points stay where the geometric stage put the clips (held links at rest length)
    for r, g in zip(results, path[1:-1], strict=True):
        np.testing.assert_allclose(r.shape[list(HELD_INDICES)],
                                   held_conformed(g, cable)[list(HELD_INDICES)], atol=1e-12)
    ax_g, be_g = (np.linalg.norm(f, axis=-1) for f in stage_forces(cable, path[1:-1]))
    ax_p, be_p = (np.linalg.norm(f, axis=-1) for f in stage_forces(cable, shapes))
    # thesis 4.5.4: axial forces drop by orders of magnitude (mean and variance over the path)
    assert ax_p.mean(axis=0).mean() < 0.03 * ax_g.mean(axis=0).mean()
    assert ax_p.var(axis=0).mean() < 1e-3 * ax_g.var(axis=0).mean()
    # bending: the peaks are smoothed (Fig. 4.22) and the spread drops; the mean stays (the
    # geometric shapes' curvature is not removed, only redistributed)
    assert be_p.mean(axis=0).max() < 0.9 * be_g.mean(axis=0).max()
    assert be_p.var(axis=0).mean() < 0.95 * be_g.var(axis=0).mean()
    assert be_p.mean() < 1.1 * be_g.mean()
    # link lengths become uniform and the shapes keep the cable's length (3 %)
    spread = link_lengths(shapes).std(axis=1) / cable.rest_link_length
    assert spread.max() < 0.01 < link_lengths(path[1:-1]).std(axis=1).max() / cable.rest_link_length
    np.testing.assert_allclose(shape_length(shapes) / cable.length, 1.0, atol=0.03)


def test_equilibrium_mode_returns_a_force_free_shape(geometric):
    cable, path = geometric
    res = minimize_shape(cable, path[2], mode="equilibrium")
    axial, bending = stage_forces(cable, res.shape)
    net = np.linalg.norm((axial + bending)[2:-2], axis=1)
    scale = cable.k_bending / cable.rest_link_length
    assert net.max() < 1e-8 * scale  # the statics tolerance (rtol 1e-10 of its force scale)


def test_result_does_not_depend_on_the_processing_order(geometric):
    cable, path = geometric

    def reversed_map(function, items):
        items = list(items)
        return [function(x) for x in reversed(items)][::-1]

    for mode in ("equilibrium", "thesis"):
        forward = physical_stage(cable, path[1:-1], mode=mode)
        backward = physical_stage(cable, path[1:-1], mode=mode, map=reversed_map)
        shuffled = physical_stage(cable, path[[4, 1, 3, 5, 2]], mode=mode)
        for a, b in zip(forward, backward, strict=True):
            np.testing.assert_array_equal(a.shape, b.shape)
        for a, k in zip(shuffled, [4, 1, 3, 5, 2], strict=True):
            np.testing.assert_array_equal(a.shape, forward[k - 1].shape)


@pytest.mark.parametrize("mode", ["equilibrium", "thesis"])
def test_target_warning_fires_far_from_minimal_energy_and_not_near_it(mode):
    cable, _, target = folding_case()
    relaxed = equilibrium(cable, target, gravity=WEIGHTLESS).shape
    if mode == "thesis":  # the thesis mode's own fixed point is its "minimal energy" shape
        relaxed = minimize_shape(cable, relaxed, mode="thesis").shape
    quiet = preprocess_target(cable, relaxed, mode=mode)
    assert quiet.warning is None, quiet.warning
    assert quiet.displacement < 0.02
    # a V: two straight halves at a right angle, far from any minimal-energy shape
    half = cable.length / 2
    corner = np.concatenate([arc(half, 0.0, 5), arc(half, 0.0, 5, origin=(half, 0, 0),
                                                     heading=np.pi / 2)[1:]])
    loud = preprocess_target(cable, corner, mode=mode)
    assert loud.warning is not None and "far from a minimal-energy shape" in loud.warning
    assert loud.displacement > 0.02


def test_target_tolerance_is_validated():
    cable, _, target = folding_case()
    with pytest.raises(ValueError, match="target_tolerance"):
        preprocess_target(cable, target, tolerance=0.0)


def test_unknown_mode_is_rejected(geometric):
    cable, path = geometric
    with pytest.raises(ValueError, match="mode"):
        minimize_shape(cable, path[1], mode="dynamic")
