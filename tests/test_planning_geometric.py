"""Basic and advanced geometric stages (thesis 4.3, 4.4): exactness, gradients, scaling."""

from __future__ import annotations

import numpy as np
import pytest
from planning_cases import arc, folding_case

from dloplan.geometry import bending_angles, link_lengths, shape_length
from dloplan.planning.geometric import (
    advanced_cost,
    advanced_hessian,
    advanced_path,
    advanced_problem,
    advanced_terms,
    basic_path,
    step_weights,
    transversal_cost,
)
from dloplan.planning.tuning import AdvancedWeights, BasicWeights


def test_basic_stage_is_the_exact_minimizer_with_equal_straight_steps():
    _, start, target = folding_case()
    path = basic_path(start, target, 5)
    _, grad = transversal_cost(path, step_weights(BasicWeights(), 5))
    # the gradient of a quadratic at its solve: zero to round-off of the coordinates (~1e-16 m)
    assert np.max(np.abs(grad)) < 1e-13
    steps = np.diff(path, axis=0)
    np.testing.assert_allclose(steps, np.broadcast_to((target - start) / 6, steps.shape),
                               atol=1e-14)


def test_basic_steps_are_inverse_to_their_weights():
    _, start, target = folding_case()
    weights = BasicWeights(steps=[1.0, 2.0, 4.0], final=0.5)
    path = basic_path(start, target, 3, weights)
    w = step_weights(weights, 3)
    _, grad = transversal_cost(path, w)
    assert np.max(np.abs(grad)) < 1e-13
    # each point moves on its straight line, step k proportional to 1 / w_k
    steps = np.diff(path, axis=0)
    expected = (1 / w)[:, None, None] / np.sum(1 / w) * (target - start)
    np.testing.assert_allclose(steps, expected, atol=1e-14)


def _perturbed_problem(seed=0):
    cable, start, target = folding_case()
    basic = basic_path(start, target, 5)
    problem = advanced_problem(basic, cable.length)
    rng = np.random.default_rng(seed)
    inner = basic[1:-1] / cable.length + 0.01 * rng.standard_normal(basic[1:-1].shape)
    return problem, inner, rng


@pytest.mark.parametrize("term", ["transversal", "delta", "clip", "beta"])
def test_advanced_term_gradients_match_finite_differences(term):
    problem, inner, rng = _perturbed_problem()
    _, grad = advanced_terms(problem, inner)[term]
    for _ in range(3):
        d = rng.standard_normal(inner.shape)
        h = 1e-6
        fd = (advanced_terms(problem, inner + h * d)[term][0]
              - advanced_terms(problem, inner - h * d)[term][0]) / (2 * h)
        # central differences: truncation ~h^2 and round-off ~1e-16/h relative -> 1e-7
        assert fd == pytest.approx(float(np.sum(grad * d)), rel=1e-7, abs=1e-9)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_advanced_cost_is_the_sum_of_the_reference_terms(seed):
    # the compiled link-length and angle pass against the numpy terms, on perturbed 3-D shapes
    # and with other weights and another n and S: equal to round-off of sums of ~n S terms
    cable, start, target = folding_case()
    weights = AdvancedWeights(steps=3.0, final=7.0, delta=50.0, clip=0.1, beta=2.0)
    basic = basic_path(start, target, 5 + 2 * seed)
    problem = advanced_problem(basic, cable.length, weights if seed else None)
    rng = np.random.default_rng(seed)
    inner = basic[1:-1] / cable.length + 0.01 * rng.standard_normal(basic[1:-1].shape)
    value, grad = advanced_cost(problem, inner)
    terms = advanced_terms(problem, inner).values()
    assert value == pytest.approx(sum(v for v, _ in terms), rel=1e-12)
    reference = sum(g for _, g in terms)
    np.testing.assert_allclose(grad, reference, rtol=0, atol=1e-12 * np.abs(reference).max())


def test_advanced_cost_equals_the_thesis_sums_on_the_reference_problem():
    # n0 = 10, S0 = 5: J is eq. 4.17 with positions over L, delta over l, L / Delta_clip, rad
    problem, inner, _ = _perturbed_problem(1)
    w = AdvancedWeights()
    path = np.concatenate([problem.start[None], inner, problem.target[None]])
    steps = np.diff(path, axis=0)
    transversal = np.sum(step_weights(w, 5)[:, None, None] * steps**2)
    delta = np.sum(((link_lengths(inner) - problem.start_links) * 10) ** 2)
    clips = 0.5 * (inner[:, -1] + inner[:, -2] - inner[:, 0] - inner[:, 1])
    clip = np.sum(1 / np.linalg.norm(clips, axis=1))
    beta = np.sum((bending_angles(inner) - problem.basic_angles) ** 2)
    thesis = transversal + w.delta * delta + w.clip * clip + w.beta * beta
    assert advanced_cost(problem, inner)[0] == pytest.approx(thesis, rel=1e-12)


def test_advanced_stage_keeps_folding_shapes_near_the_cable_length():
    # thesis Table 4.2: basic shapes shrink (0.66 L mid-path), advanced ones stay near L
    cable, start, target = folding_case()
    basic = basic_path(start, target, 5)
    advanced, status = advanced_path(basic, cable.length)
    basic_mid = shape_length(basic[3]) / cable.length
    assert basic_mid < 0.7
    assert status.success, status.message
    assert np.min(shape_length(advanced) / cable.length) > 0.95  # thesis reached 0.90
    assert np.max(shape_length(advanced) / cable.length) < 1.01  # not over-stretched


def test_advanced_path_is_unit_invariant():
    cable_m, start_m, target_m = folding_case()
    cable_mm, start_mm, target_mm = folding_case(scale=1000.0)
    path_m, _ = advanced_path(basic_path(start_m, target_m, 5), cable_m.length)
    path_mm, _ = advanced_path(basic_path(start_mm, target_mm, 5), cable_mm.length)
    # the same dimensionless problem; the optimum is flat, so round-off (1e-16) amplified by
    # some 500 quasi-Newton iterations shows up at 1e-7 L
    np.testing.assert_allclose(path_mm / 1000.0, path_m, atol=1e-6 * cable_m.length)


def test_advanced_path_is_invariant_to_a_rigid_motion():
    # a rotation keeping the plane of the planar problem (a general 3D rotation lets round-off
    # break the planar symmetry, and the path may leave the plane to another local minimum)
    from scipy.spatial.transform import Rotation

    cable, start, target = folding_case()
    rot = Rotation.from_euler("y", 37, degrees=True)
    shift = np.array([0.3, -0.2, 0.5])
    path, _ = advanced_path(basic_path(start, target, 5), cable.length)
    moved, _ = advanced_path(basic_path(rot.apply(start) + shift, rot.apply(target) + shift, 5),
                             cable.length)
    np.testing.assert_allclose(moved, rot.apply(path.reshape(-1, 3)).reshape(path.shape) + shift,
                               atol=1e-5 * cable.length)


def test_step_weights_reject_a_wrong_count():
    with pytest.raises(ValueError, match="weights.steps"):
        step_weights(BasicWeights(steps=[1.0, 2.0]), 5)


def test_a_3d_turn_is_planned_through_the_same_code():
    cable, start, _ = folding_case()
    target = arc(cable.length, np.pi / 2, cable.n_links, origin=(0.1, 0.1, 0.05))
    target[:, 1] += np.linspace(0.0, 0.15, cable.n_points) ** 2  # leave the plane
    target = target[0] + (target - target[0]) * cable.length / shape_length(target)
    advanced, status = advanced_path(basic_path(start, target, 5), cable.length)
    assert status.success
    assert np.min(shape_length(advanced) / cable.length) > 0.95


def test_advanced_hessian_matches_finite_differences_of_the_gradient():
    problem, inner, rng = _perturbed_problem(3)
    hess = advanced_hessian(problem, inner)
    assert abs(hess - hess.T).max() < 1e-9 * abs(hess).max()
    d = rng.standard_normal(inner.shape)
    h = 1e-6
    fd = (advanced_cost(problem, inner + h * d)[1] - advanced_cost(problem, inner - h * d)[1])
    fd = fd.ravel() / (2 * h)
    # central differences of an exact gradient: relative error ~1e-7 of the largest entry
    np.testing.assert_allclose(hess @ d.ravel(), fd, atol=1e-6 * np.abs(fd).max())


def test_lbfgs_option_reaches_a_no_better_point_than_newton():
    cable, start, target = folding_case()
    basic = basic_path(start, target, 5)
    _, newton = advanced_path(basic, cable.length)
    _, lbfgs = advanced_path(basic, cable.length, method="L-BFGS-B", max_iterations=3000)
    assert newton.success and newton.cost <= lbfgs.cost + 1e-9
    with pytest.raises(ValueError, match="method"):
        advanced_path(basic, cable.length, method="BFGS")


def test_next_shift_follows_the_ratio_of_actual_to_predicted_decrease():
    from dloplan.planning.geometric import (
        RATIO_GOOD,
        RATIO_POOR,
        SHIFT_DECREASE,
        SHIFT_FLOOR,
        SHIFT_START,
        next_shift,
    )

    assert next_shift(0.0, -np.inf) == SHIFT_START  # rejected: damp from the start value
    assert next_shift(1e-2, -np.inf) == pytest.approx(1e-1)
    assert next_shift(1e-2, 0.5 * RATIO_POOR) == pytest.approx(1e-1)  # poor model: damp more
    mid = 0.5 * (RATIO_POOR + RATIO_GOOD)
    assert next_shift(1e-2, mid) == 1e-2  # fair model: keep
    assert next_shift(1e-2, 1.0) == pytest.approx(1e-2 / SHIFT_DECREASE)  # good: relax
    assert next_shift(SHIFT_FLOOR, 1.0) == 0.0  # ... to a pure Newton step
