"""Gripper frames along a path (thesis 4.6): geometry, method properties, Fig. 4.28, bad input.

Tolerances: frames are built from closed forms (cross products, scipy rotations), so
orthonormality, det = 1 and u-axis alignment hold to round-off: 1e-12 for one shape, 1e-9
after the accumulation of a few tens of rotations. The SLSQP comparison of the minimal
rotation uses 1e-5, the optimizer's own tolerance.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from gripper_paths import bending_path, curved_hose, turnover_path
from scipy.optimize import minimize_scalar
from scipy.spatial.transform import Rotation

from dloplan.cable import catalogue_cable
from dloplan.frames import frame_from_axis, minimal_rotation
from dloplan.grippers import (
    as_initial_frames,
    body_frames,
    clip_axes,
    gripper_path,
    relative_twist,
)
from dloplan.sim.clips import clip_poses_from_shape

METHOD_KWARGS = {
    "auxiliary": dict(method="auxiliary", aux=[0.3, 1.0, 0.2]),
    "minimal": dict(method="minimal"),
    "rigid": dict(method="rigid"),
}


@pytest.mark.parametrize("method", sorted(METHOD_KWARGS))
def test_frames_orthonormal_right_handed_and_u_on_end_links(method):
    path = bending_path()
    g = gripper_path(path, **METHOD_KWARGS[method])
    assert g.method == method and g.n_shapes == len(path)
    mats = g.matrices
    eye = np.broadcast_to(np.eye(3), mats.shape)
    assert np.allclose(np.swapaxes(mats, -1, -2) @ mats, eye, atol=1e-12, rtol=0)
    assert np.allclose(np.linalg.det(mats), 1.0, atol=1e-12, rtol=0)
    # explicit right-handedness: u x v = w
    assert np.allclose(np.cross(g.axis(0), g.axis(1)), g.axis(2), atol=1e-12, rtol=0)
    first = path[:, 1] - path[:, 0]
    last = path[:, -2] - path[:, -1]
    expected_u = (
        np.stack([first, last], 1) / np.linalg.norm(np.stack([first, last], 1), axis=-1)[..., None]
    )
    assert np.allclose(g.u_axes, expected_u, atol=1e-9, rtol=0)
    mid = 0.5 * (path[:, [0, -1]] + path[:, [1, -2]])
    assert np.array_equal(g.positions, mid)


def test_clip_axes_match_the_single_shape_clips():
    path = bending_path()
    positions, u = clip_axes(path)
    for k in (0, 4, len(path) - 1):
        clips = clip_poses_from_shape(path[k])
        assert np.allclose(clips.positions, positions[k], atol=1e-15)
        assert np.allclose(clips.u_axes, u[k], atol=1e-12)


def test_clip_poses_of_a_gripper_path_hold_the_shape():
    path = bending_path()
    g = gripper_path(path, method="minimal")
    clips = g.clip_poses(3)
    link = np.linalg.norm(path[3, 1] - path[3, 0])
    held = clips.held_points(link)
    assert np.allclose(held[[0, 1]], path[3, [0, 1]], atol=1e-12)


@pytest.mark.parametrize(
    "a, b",
    [
        ([1, 0, 0], [0, 1, 0]),
        ([0.2, -0.5, 0.8], [0.9, 0.1, -0.3]),
        ([0, 0, 1], [0, 1e-7, 1]),
        ([1, 0, 0], [-1, 1e-9, 0]),
        ([0.3, 0.4, 0.5], [0.3, 0.4, 0.5]),
    ],
)
def test_minimal_rotation_satisfies_thesis_constraints_and_has_least_angle(a, b):
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    rot = minimal_rotation(a, b)[0]
    r = rot.as_matrix()
    x = r - np.eye(3)  # eq. 4.25
    assert np.allclose(r.T @ r, np.eye(3), atol=1e-12)  # eq. 4.27
    assert np.isclose(np.linalg.det(r), 1.0, atol=1e-12)  # eq. 4.28
    assert np.allclose(r @ a, b, atol=1e-12)  # eq. 4.29
    # every rotation taking a to b is R Rot(a, phi); none has a smaller angle or ||X||^2 (4.26)
    angle = rot.magnitude()
    cost = np.sum(x**2)
    assert np.isclose(cost, 4.0 * (1.0 - np.cos(angle)), atol=1e-12)
    for phi in np.linspace(-np.pi, np.pi, 73):
        other = rot * Rotation.from_rotvec(phi * a)
        assert np.allclose(other.apply(a), b, atol=1e-12)
        assert other.magnitude() >= angle - 1e-12
        assert np.sum((other.as_matrix() - np.eye(3)) ** 2) >= cost - 1e-12
    assert np.isclose(angle, np.arccos(np.clip(a @ b, -1, 1)), atol=1e-7)


def test_minimal_rotation_equals_the_thesis_optimization():
    """Minimize the thesis' cost ||R - I||^2 (eq. 4.26) numerically over every feasible rotation
    (eqs. 4.27-4.29): R(phi) = Rot(b, phi) R0, with R0 = F(b) F(a)^T built from two unrelated
    frames; the optimum is the closed form to the optimizer's tolerance (1e-6)."""
    a = np.array([0.2, -0.5, 0.8]) / np.linalg.norm([0.2, -0.5, 0.8])
    b = np.array([0.7, 0.1, 0.3]) / np.linalg.norm([0.7, 0.1, 0.3])
    r0 = frame_from_axis(b)[0] * frame_from_axis(a)[0].inv()
    assert np.allclose(r0.apply(a), b, atol=1e-12)

    def cost(phi):
        r = (Rotation.from_rotvec(phi * b) * r0).as_matrix()
        return np.sum((r - np.eye(3)) ** 2)

    res = minimize_scalar(cost, bounds=(-np.pi, np.pi), method="bounded", options={"xatol": 1e-10})
    assert res.success
    best = (Rotation.from_rotvec(res.x * b) * r0).as_matrix()
    assert np.allclose(best, minimal_rotation(a, b)[0].as_matrix(), atol=1e-6)


def test_minimal_rotation_keeps_frames_when_u_does_not_turn():
    path = bending_path()
    shifted = path[0][None] + np.linspace(0, 0.3, 6)[:, None, None] * np.array([1.0, 2.0, -0.5])
    initial = Rotation.concatenate([clip_poses_from_shape(path[0]).rotations])
    initial = initial * Rotation.from_rotvec([[0.7, 0, 0], [-1.1, 0, 0]])  # user rolls about u
    g = gripper_path(shifted, method="minimal", initial=initial)
    for clip in (0, 1):
        assert np.allclose(g.rotations[clip].as_matrix(), initial[clip].as_matrix(), atol=1e-12)
    assert g.warnings == ()


def test_fig_4_28_minimal_rotation_twists_a_turned_over_hose_rigid_rotation_does_not():
    cable = curved_hose()
    path, turns = turnover_path(cable.rest_shape)
    minimal = gripper_path(path, method="minimal", cable=cable)
    rigid = gripper_path(path, method="rigid", cable=cable)
    # the end links of a 10-link quarter arc are 81 degrees apart (not 90), so the first clip's
    # u-axis sweeps a cone instead of a great circle: about 175 degrees, "about 180" (Fig. 4.28)
    assert abs(np.degrees(minimal.twist[-1])) == pytest.approx(180.0, abs=10.0)
    assert not minimal.success and any("twist" in w for w in minimal.warnings)
    assert np.max(np.abs(rigid.twist)) < 1e-9
    assert rigid.success
    # the rigid method moves both clip frames exactly with the hose: F_i = R_i F_0
    for clip in (0, 1):
        expected = turns * rigid.rotations[clip][0:1]
        diff = (expected.inv() * rigid.rotations[clip]).magnitude()
        assert np.max(diff) < 1e-9
    auto = gripper_path(path, method="auto", cable=cable)
    assert auto.method == "rigid" and "curved" in auto.message


def test_auto_uses_minimal_rotation_for_a_straight_cable():
    cable = catalogue_cable("usb", n_links=10)
    g = gripper_path(bending_path(), method="auto", cable=cable)
    assert g.method == "minimal"


def test_rigid_rotation_follows_any_rigid_motion_of_a_curved_shape():
    rng = np.random.default_rng(7)
    shape = bending_path()[4]
    turns = Rotation.from_rotvec(np.cumsum(rng.normal(scale=0.3, size=(9, 3)), axis=0))
    turns = Rotation.concatenate([Rotation.identity(), turns])
    path = np.stack([t.apply(shape) + rng.normal(size=3) for t in turns])
    g = gripper_path(path, method="rigid")
    for clip in (0, 1):
        diff = ((turns * g.rotations[clip][0:1]).inv() * g.rotations[clip]).magnitude()
        assert np.max(diff) < 1e-9
    assert np.max(np.abs(g.twist)) < 1e-9


@pytest.mark.parametrize("method", sorted(METHOD_KWARGS))
def test_twist_does_not_depend_on_the_world_frame(method):
    path = bending_path()
    world = Rotation.from_rotvec([0.4, -0.2, 0.9])
    kwargs = dict(METHOD_KWARGS[method])
    g = gripper_path(path, **kwargs)
    if method == "auxiliary":
        kwargs["aux"] = world.apply(kwargs["aux"])
    moved = gripper_path(world.apply(path.reshape(-1, 3)).reshape(path.shape) + 1.0, **kwargs)
    assert np.allclose(g.twist, moved.twist, atol=1e-9)


def test_relative_twist_measures_a_roll_of_one_clip_about_its_axis():
    first = Rotation.from_rotvec(np.tile([0.3, -0.2, 0.5], (7, 1)))
    start = Rotation.from_rotvec([1.0, 0.4, -0.3])
    u_last = start.apply([1.0, 0.0, 0.0])
    rolls = np.linspace(0.0, 3.0 * np.pi, 7)  # beyond pi: the twist is unwrapped
    last = Rotation.from_rotvec(rolls[:, None] * u_last) * start
    assert np.allclose(relative_twist(first, last), rolls, atol=1e-12)
    with pytest.raises(ValueError, match="equal length"):
        relative_twist(first, last[:3])


def test_relative_twist_ignores_bending():
    """Both clips turned about a common axis perpendicular to both u-axes (pure bending in a
    plane) give no twist."""
    first0 = Rotation.from_matrix(np.eye(3))
    last0 = Rotation.from_rotvec([0, 0, np.pi])  # u along -x, facing the first clip
    bend = np.linspace(0, 1.0, 5)
    first = Rotation.from_rotvec(bend[:, None] * [0, 1.0, 0]) * first0
    last = Rotation.from_rotvec(-bend[:, None] * [0, 1.0, 0]) * last0
    assert np.allclose(relative_twist(first, last), 0.0, atol=1e-12)


def test_rigid_rotation_on_straight_shapes_falls_back_to_minimal_rotation_with_a_warning():
    straight = np.stack([np.linspace(0, 0.5, 11), np.zeros(11), np.zeros(11)], 1)
    turns = Rotation.from_rotvec(np.linspace(0, 1.0, 5)[:, None] * [0, 0, 1.0])
    path = np.stack([t.apply(straight) for t in turns])
    rigid = gripper_path(path, method="rigid")
    minimal = gripper_path(path, method="minimal")
    assert any("minimal rotation" in w and "first clip" in w for w in rigid.warnings)
    for clip in (0, 1):
        diff = (rigid.rotations[clip].inv() * minimal.rotations[clip]).magnitude()
        assert np.max(diff) < 1e-12


def test_body_frames_are_undefined_only_on_straight_stretches():
    _, defined = body_frames(bending_path())
    assert defined.all()
    straight = np.stack([np.linspace(0, 0.5, 11), np.zeros(11), np.zeros(11)], 1)
    _, defined = body_frames(straight[None])
    assert not defined.any()


def test_a_large_frame_step_is_reported():
    cable = curved_hose()
    path, _ = turnover_path(cable.rest_shape, n_inner=1)  # 90 degrees per step
    g = gripper_path(path, method="rigid")
    assert any("turns by 90.0 degrees" in w for w in g.warnings)


def test_initial_frame_off_the_u_axis_is_aligned_and_reported():
    path = bending_path()
    initial = Rotation.from_rotvec([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    g = gripper_path(path, method="minimal", initial=initial)
    assert any("initial" in w for w in g.warnings)
    assert np.allclose(g.u_axes[0], clip_axes(path)[1][0], atol=1e-12)


# -- failures and bad input ------------------------------------------------------------------------
def test_auxiliary_vector_parallel_to_a_u_axis_is_reported_with_shape_and_clip():
    path = bending_path()
    u = clip_axes(path)[1]
    with pytest.raises(ValueError, match=r"aux: .*last clip's u-axis at shape 5"):
        gripper_path(path, method="auxiliary", aux=u[5, 1] + [0.0, 0.0, 1e-4])


def test_zero_length_end_link_is_rejected():
    path = bending_path().copy()
    path[2, -2] = path[2, -1]
    with pytest.raises(ValueError, match=r"shape 2, last clip: the end link has zero length"):
        gripper_path(path, method="minimal")


@pytest.mark.parametrize(
    "initial, match",
    [
        (np.stack([np.diag([1.0, 1.0, -1.0]), np.eye(3)]), "first clip's frame is not a rotation"),
        (np.stack([np.eye(3), 1.1 * np.eye(3)]), "last clip's frame is not a rotation"),
        (np.eye(3), r"expected \(2, 3, 3\)"),
        (Rotation.identity(), "holding 2 rotations"),
    ],
)
def test_user_frame_that_is_not_a_rotation_is_rejected(initial, match):
    with pytest.raises(ValueError, match=match):
        gripper_path(bending_path(), method="minimal", initial=initial)


def test_user_frame_matrices_are_accepted():
    mats = Rotation.from_rotvec([[0.1, 0.2, 0.3], [0.0, 1.0, 0.0]]).as_matrix()
    frames = as_initial_frames(mats)
    assert np.allclose(frames[1].as_matrix()[0], mats[1])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(method="auto"), "cable: method 'auto' needs the cable"),
        (dict(method="spin"), "method: got 'spin'"),
        (dict(method="auxiliary", aux=[0, 0, 0]), "aux: got"),
        (dict(method="auxiliary", initial=Rotation.identity(2)), "initial: the auxiliary"),
        (dict(method="minimal", max_twist=0.0), "max_twist"),
        (dict(method="auto", cable=catalogue_cable("usb", n_links=7)), "expected cable.n_points"),
    ],
)
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gripper_path(bending_path(), **kwargs)


@pytest.mark.parametrize(
    "path, match",
    [
        (np.zeros((3, 4, 2)), r"expected shape \(n_shapes, n_points, 3\)"),
        (np.full((2, 5, 3), np.nan), "non-finite"),
        (np.zeros((2, 1, 3)), "need at least 2"),
        ("abc", "path"),
    ],
)
def test_malformed_paths(path, match):
    with pytest.raises(ValueError, match=match):
        gripper_path(path, method="minimal")


def test_fig_4_28_holds_for_shapes_settled_under_gravity():
    """End to end: every shape of the turned-over hose settled by the statics solver (its clips
    held) before the clip frames are extracted; the clips hold the end links, so the clip
    frames, and the verdict, are those of the planned shapes."""
    from dloplan.sim.statics import stabilize

    cable = curved_hose()
    path, _ = turnover_path(cable.rest_shape)
    settled = [stabilize(shape, cable) for shape in path]
    assert all(eq.converged for eq in settled)
    settled = np.stack([eq.shape for eq in settled])
    assert np.max(np.abs(settled - path)) > 1e-4  # gravity did move the inner points
    minimal = gripper_path(settled, method="minimal", cable=cable)
    auto = gripper_path(settled, method="auto", cable=cable)
    assert abs(np.degrees(minimal.twist[-1])) == pytest.approx(180.0, abs=10.0)
    assert auto.method == "rigid" and np.max(np.abs(auto.twist)) < 1e-9


def test_each_clip_roll_shows_a_turn_over_the_relative_twist_misses():
    """A shape turned over about its last link: zero relative twist, but the last clip rolls
    180 deg about the cable (the first clip's u-axis sweeps a cone, so its roll against
    parallel transport is the cone's geometric phase, less than 180 deg)."""
    from gripper_paths import arc, turnover_path

    shape = arc(10, 0.5, np.radians(120))
    shapes, _ = turnover_path(shape)
    rigid = gripper_path(shapes, method="rigid")
    assert np.abs(rigid.twist).max() < np.radians(1.0)
    assert np.degrees(abs(rigid.roll[-1, 1])) == pytest.approx(180.0, abs=1.0)
    assert 10.0 < np.degrees(abs(rigid.roll[-1, 0])) < 170.0
    assert "each clip rolls up to 18" in rigid.message


def test_auto_takes_rigid_rotation_when_minimal_rotation_would_twist():
    """A bent shape turned over on a cable whose rest shape is straight: minimal rotation twists
    the cable by ~180 deg (Fig. 4.28), so auto takes the method its warning recommends."""
    from gripper_paths import arc, turnover_path

    from dloplan.cable import catalogue_cable

    shapes, _ = turnover_path(arc(10, 0.5, np.radians(120)))
    cable = catalogue_cable("pa12", n_links=10)
    minimal = gripper_path(shapes, method="minimal", cable=cable)
    assert not minimal.success and "try method 'rigid'" in " ".join(minimal.warnings)
    auto = gripper_path(shapes, method="auto", cable=cable)
    assert auto.method == "rigid" and auto.success
    assert "minimal rotation would twist the cable" in auto.message


def test_the_plan_warns_of_the_twist_the_torsion_model_finds_not_of_the_frames_estimate():
    """The frames' relative twist is an estimate of the cable's twist; where the torsion model
    has run (every plan: ``plan_twist``) its twist is the plan's check (the repair's
    ``twist_failures``, ``export``). A plan whose frames turn 17-32 deg against each other but
    whose cable the torsion model finds untwisted (M1 at n = 20 after its twist repair) warned
    "the cable would be twisted" and exited 1; its frames' other warnings stay."""
    from types import SimpleNamespace

    from dloplan.pipeline.stages import frame_warnings

    cable = curved_hose()
    path, _ = turnover_path(cable.rest_shape)
    minimal = gripper_path(path, method="minimal", cable=cable)
    assert not minimal.success and minimal.twist_warning in minimal.warnings
    other = "a frame step of the path"
    frames = replace(minimal, warnings=(*minimal.warnings, other))
    untwisted = SimpleNamespace(success=True, message="largest twist 0.0 degrees")
    assert frame_warnings(frames, untwisted) == [w for w in frames.warnings
                                                 if w != minimal.twist_warning]
    assert other in frame_warnings(frames, untwisted)
    twisted = SimpleNamespace(success=False, message="largest twist 175.0 degrees")
    assert frame_warnings(frames, twisted)[-1] == "twist: largest twist 175.0 degrees"
    rigid = gripper_path(path, method="rigid", cable=cable)
    assert rigid.twist_warning is None
