"""Torsion: material frames, twist energy, directional bending, equilibrium and path report."""

from __future__ import annotations

import numpy as np
import pytest
from gripper_paths import curved_hose, turnover_path
from scipy.spatial.transform import Rotation

from dloplan.cable import catalogue_cable
from dloplan.frames import minimal_rotation
from dloplan.geometry import tangents
from dloplan.physics.rod_frames import (
    discrete_twist,
    material_curvatures,
    rotate_about,
    transported_directors,
)
from dloplan.physics.twist import (
    TwistChain,
    chart_directors,
    twist_derivatives,
    twist_energy,
)
from dloplan.sim import equilibrium
from dloplan.sim.clips import ClipPoses, clip_poses_from_shape
from dloplan.sim.torsion import (
    equilibrium_with_twist,
    rest_clip_poses,
    twist_along_path,
)

WEIGHTLESS = (0.0, 0.0, 0.0)


def straight(cable):
    x = np.zeros((cable.n_points, 3))
    x[:, 0] = cable.rest_link_length * np.arange(cable.n_points)
    return x


def turned_last_clip(clips: ClipPoses, angle: float) -> ClipPoses:
    """The last clip turned by ``angle`` about its own u-axis."""
    last = clips.rotations[1] * Rotation.from_rotvec([angle, 0.0, 0.0])
    return ClipPoses(clips.positions, Rotation.concatenate([clips.rotations[0], last]))


# -- frames ------------------------------------------------------------------------------------
def test_discrete_twist_of_frames_turned_about_a_straight_axis():
    t = np.tile([0.0, 0.0, 1.0], (4, 1))
    angles = np.array([0.0, 0.3, -0.5, 2.0])  # steps within (-pi, pi]
    d1 = rotate_about(np.tile([1.0, 0.0, 0.0], (4, 1)), t, angles)
    assert discrete_twist(t, d1) == pytest.approx(np.diff(angles), abs=1e-14)


def test_parallel_transport_has_no_twist_and_curvature_norm_is_the_turning_angle():
    rng = np.random.default_rng(4)
    x = np.cumsum(rng.normal(size=(9, 3)), axis=0)
    t = tangents(x)
    first = np.cross(t[0], [0.0, 0.0, 1.0])
    d1 = transported_directors(x, first / np.linalg.norm(first))
    assert np.abs(discrete_twist(t, d1)).max() < 1e-13
    beta = np.arccos(np.clip(np.einsum("ij,ij->i", t[:-1], t[1:]), -1, 1))
    omega = material_curvatures(t, d1)
    assert np.linalg.norm(omega, axis=-1) == pytest.approx(np.stack([beta, beta], 1), rel=1e-12)


# -- exact derivatives ---------------------------------------------------------------------------
@pytest.mark.parametrize("curved", [False, True])
def test_gradient_and_hessian_match_finite_differences(curved):
    """Positions and angles, away from the chart's centre (general t != t0, theta != 0).

    Central differences with h = 1e-7 (gradient) and 1e-6 (Hessian from the exact gradient):
    truncation and rounding errors are ~1e-9 relative, so 1e-6 relative is a strict check.
    """
    cable = curved_hose(6) if curved else catalogue_cable("pa12", n_links=6)
    tc = TwistChain.from_cable(cable, natural_twist=0.7)
    rng = np.random.default_rng(0)
    n = cable.n_links
    x0 = np.cumsum(rng.normal(size=(n + 1, 3)) * 0.02, axis=0)
    t0 = tangents(x0)
    side = np.cross(t0[0], [0.0, 0.0, 1.0])
    d0 = transported_directors(x0, side / np.linalg.norm(side))
    x = x0 + rng.normal(size=x0.shape) * 0.003
    theta = rng.normal(size=n) * 0.3

    def total(x, theta):
        return twist_energy(tc, x, chart_directors(x, t0, d0, theta))

    def flat_gradient(z):
        d = twist_derivatives(tc, z[: 3 * (n + 1)].reshape(-1, 3), t0, d0, z[3 * (n + 1):])
        return np.concatenate([(d.twist_gradient + d.direction_gradient).ravel(),
                               d.angle_gradient])

    d = twist_derivatives(tc, x, t0, d0, theta)
    assert d.twist_energy + d.direction_energy == pytest.approx(total(x, theta), rel=1e-12)
    z = np.concatenate([x.ravel(), theta])
    h = 1e-7
    numeric = np.array([
        (total(*split(z + h * e, n)) - total(*split(z - h * e, n))) / (2 * h)
        for e in np.eye(len(z))
    ])
    exact = flat_gradient(z)
    assert np.abs(numeric - exact).max() < 1e-6 * np.abs(exact).max()
    h = 1e-6
    numeric_h = np.stack([(flat_gradient(z + h * e) - flat_gradient(z - h * e)) / (2 * h)
                          for e in np.eye(len(z))], axis=1)
    assembled = np.zeros_like(numeric_h)
    for i in range(1, n):
        idx = [*range(3 * (i - 1), 3 * i), 3 * (n + 1) + i - 1, *range(3 * i, 3 * i + 3),
               3 * (n + 1) + i, *range(3 * (i + 1), 3 * (i + 2))]
        assembled[np.ix_(idx, idx)] += d.blocks[i - 1]
    assert np.abs(assembled - numeric_h).max() < 1e-6 * np.abs(numeric_h).max()
    assert np.abs(assembled - assembled.T).max() < 1e-10 * np.abs(assembled).max()


def split(z, n):
    return z[: 3 * (n + 1)].reshape(-1, 3), z[3 * (n + 1):]


# -- twist of a straight cable -------------------------------------------------------------------
def test_twisted_straight_cable_carries_a_uniform_torque():
    """Torque G I_p alpha / L_c with L_c = (n - 1) l, the length between the clip points.

    The clips grip the middles of the end links, so the twisted length is L - l: at n = 20 the
    torque matches G I_p alpha / L_c to 1e-9 (the discrete model is exact for uniform twist)
    and the continuum G I_p alpha / L only to 1/(n - 1) = 5 %; at n = 200 within 1 % of that.
    """
    alpha = 1.0
    for n, reference_length, tolerance in ((20, None, 1e-9), (200, "L", 0.01)):
        cable = catalogue_cable("pu", n_links=n)
        clips = turned_last_clip(rest_clip_poses(cable), alpha)
        # start far from the answer: all the twist on the last interior point
        start = transported_directors(straight(cable), clips.rotations[0].apply([0, 1.0, 0]))
        eq = equilibrium_with_twist(cable, straight(cable), clips, directors=start,
                                    gravity=WEIGHTLESS)
        assert eq.success, eq.message
        assert eq.iterations > 0
        length = cable.length if reference_length else (n - 1) * cable.rest_link_length
        torque = cable.shear_modulus * cable.polar_moment * alpha / length
        assert np.abs(eq.torques) == pytest.approx(np.full(n - 1, torque), rel=tolerance)
        assert np.ptp(eq.torques) < 1e-9 * torque  # uniformly distributed
        assert abs(eq.total_twist) == pytest.approx(alpha, rel=1e-9)
        # the moment on the last clip about its u-axis opposes the turn, equal to the torque
        u_last = clips.u_axes[1]
        assert -eq.clip_wrenches[1, 3:] @ u_last == pytest.approx(
            abs(eq.torques[-1]), rel=1e-9)
        assert np.abs(eq.shape - straight(cable)).max() < 1e-12  # twist alone does not bend


def test_natural_twist_is_the_rest_state():
    cable = catalogue_cable("usb", n_links=12)
    theta = 2.0
    at_rest = equilibrium_with_twist(cable, straight(cable), rest_clip_poses(cable, theta),
                                     natural_twist=theta, gravity=WEIGHTLESS)
    assert at_rest.success and at_rest.twist_energy < 1e-25
    assert at_rest.twist == pytest.approx(np.full(11, theta / 11), abs=1e-12)
    untwisted = equilibrium_with_twist(cable, straight(cable), rest_clip_poses(cable),
                                       natural_twist=theta, gravity=WEIGHTLESS)
    assert untwisted.torques == pytest.approx(np.full(11, -cable.k_twist * theta / 11), rel=1e-9)


def test_more_than_half_a_turn_is_tracked_along_a_path():
    cable = catalogue_cable("pu", n_links=10)
    clips = rest_clip_poses(cable)
    angles = np.linspace(0.0, 1.5 * np.pi, 7)
    report = twist_along_path(cable, np.stack([straight(cable)] * 7),
                              [turned_last_clip(clips, a) for a in angles], gravity=WEIGHTLESS)
    assert all(eq.success for eq in report.equilibria)
    assert -report.twist == pytest.approx(angles, abs=1e-9)  # not wrapped to -pi/2
    assert not report.success and "twists the cable" in report.message


# -- naturally curved hose -----------------------------------------------------------------------
def test_curved_hose_held_at_rest_has_zero_energy_in_any_rigid_placement():
    cable = curved_hose(12)
    clips = rest_clip_poses(cable)
    rng = np.random.default_rng(1)
    for _ in range(4):
        turn = Rotation.random(random_state=rng)
        shift = rng.normal(size=3)
        placed = turn.apply(cable.rest_shape) + shift
        eq = equilibrium_with_twist(cable, placed, clips.moved(shift, turn), gravity=WEIGHTLESS)
        assert eq.success, eq.message
        assert abs(eq.energy) < 1e-12  # J; the bending energy scale is k_b = 0.05 J
        assert np.abs(eq.shape - placed).max() < 1e-10


def test_curved_hose_follows_a_half_turn_of_both_clips_about_the_chord():
    """The curvature plane turns with the clips: at every angle the stabilized hose is the
    rest shape turned with them, up to its sag under gravity (0.02 mm for stiff PA12)."""
    cable = curved_hose(12)
    clips = rest_clip_poses(cable)
    rest = cable.rest_shape
    chord = (rest[-1] - rest[0]) / np.linalg.norm(rest[-1] - rest[0])
    middle = 0.5 * (rest[0] + rest[-1])
    eq = None
    for angle in np.linspace(0.0, np.pi, 7):
        turn = Rotation.from_rotvec(angle * chord)
        held = ClipPoses(turn.apply(clips.positions - middle) + middle, turn * clips.rotations)
        eq = equilibrium_with_twist(cable, rest if eq is None else eq.shape, held,
                                    directors=None if eq is None else eq.directors)
        assert eq.success, eq.message
        expected = turn.apply(rest - middle) + middle
        assert np.abs(eq.shape - expected).max() < 5e-4
        assert abs(eq.total_twist) < 1e-4
    bulge = rest[6] - middle
    assert (eq.shape[6] - middle) @ bulge < -0.5 * bulge @ bulge  # the curve is on the other side


# -- torsion adds nothing to an untwisted planar problem ----------------------------------------
@pytest.mark.parametrize("name", ["ethernet", "pa12"])
def test_untwisted_planar_problem_is_unchanged(name):
    cable = catalogue_cable(name, n_links=20)
    clips = ClipPoses(np.array([[0.0, 0, 0], [0.4, 0, 0]]),
                      Rotation.from_euler("z", [[0.0], [180.0]], degrees=True))
    guess = straight(cable) - [cable.rest_link_length / 2, 0, 0]
    plain = equilibrium(cable, guess, clips)
    twisted = equilibrium_with_twist(cable, guess, clips)
    assert plain.success and twisted.success
    assert np.abs(twisted.shape - plain.shape).max() < 1e-6
    assert twisted.twist_energy < 1e-20
    assert twisted.energy == pytest.approx(plain.energy, rel=1e-9)
    assert twisted.forces.total[2:-2] == pytest.approx(np.zeros((17, 3)), abs=1e-8)


# -- Fig. 4.28: a curved hose turned over --------------------------------------------------------
def test_turning_a_curved_hose_over_with_minimal_rotation_frames_twists_it():
    """Thesis Fig. 4.28: the arc-shaped PA12 hose turned over (180 degrees about its last link's
    axis, S = 6). Frames propagated by minimal rotation leave the last clip unturned: about half
    a turn of twist between the clips (the hose takes 150-165 degrees of it as twist, the rest
    as bending), against none when the frames turn rigidly with the hose."""
    from dloplan.grippers import relative_twist

    cable = curved_hose(10)
    start = rest_clip_poses(cable)
    path, turns = turnover_path(cable.rest_shape, n_inner=6)
    poses = [clip_poses_from_shape(shape) for shape in path]
    rigid = [ClipPoses(p.positions, turn * start.rotations) for p, turn in zip(poses, turns,
                                                                               strict=True)]
    frames = [start.rotations]
    for before, after in zip(poses[:-1], poses[1:], strict=True):
        frames.append(minimal_rotation(before.u_axes, after.u_axes) * frames[-1])
    minimal = [ClipPoses(p.positions, r) for p, r in zip(poses, frames, strict=True)]

    twisting = twist_along_path(cable, path, minimal)
    following = twist_along_path(cable, path, rigid)
    assert all(eq.converged for eq in twisting.equilibria + following.equilibria)
    assert following.success and np.abs(following.twist).max() < np.radians(0.5)
    assert not twisting.success
    assert np.radians(135) < abs(twisting.twist[-1]) < np.radians(200)
    assert np.all(np.diff(np.abs(twisting.twist)) > 0)  # grows shape by shape
    assert twisting.twist_energy[-1] > 1e4 * max(following.twist_energy.max(), 1e-12)
    clip_twist = relative_twist(Rotation.concatenate([m.rotations[0] for m in minimal]),
                                Rotation.concatenate([m.rotations[1] for m in minimal]))
    assert abs(clip_twist[-1]) == pytest.approx(np.pi, abs=np.radians(5))


# -- inputs ----------------------------------------------------------------------------------------
def test_bad_inputs_are_named():
    cable = catalogue_cable("usb", n_links=8)
    clips = rest_clip_poses(cable)
    with pytest.raises(ValueError, match="directors"):
        equilibrium_with_twist(cable, straight(cable), clips, directors=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="natural_twist"):
        equilibrium_with_twist(cable, straight(cable), clips, natural_twist=float("nan"))
    with pytest.raises(ValueError, match="guess"):
        equilibrium_with_twist(cable, np.zeros((4, 3)), clips)
    with pytest.raises(ValueError, match="path"):
        twist_along_path(cable, np.zeros((2, 4, 3)), [clips, clips])
    with pytest.raises(ValueError, match="clip_sequence"):
        twist_along_path(cable, np.stack([straight(cable)] * 2), [clips])
    with pytest.raises(ValueError, match="max_twist"):
        twist_along_path(cable, np.stack([straight(cable)] * 2), [clips] * 2, max_twist=-1.0)


def test_joint_band_interleaves_the_position_hessian_and_the_twist_blocks():
    """The banded Newton matrix over (x, y, z, l theta) per point equals the dense assembly."""
    from dloplan.physics.chain import SpringChain, band_to_sparse, hessian
    from dloplan.sim.torsion import _joint_derivatives

    cable = curved_hose(7)
    tc = TwistChain.from_cable(cable, 0.4)
    chain = SpringChain.from_cable(cable)
    rng = np.random.default_rng(2)
    x = cable.rest_shape + rng.normal(size=(8, 3)) * 0.004
    d1 = transported_directors(x, np.cross(tangents(x)[0], [0, 0, 1.0]) / np.linalg.norm(
        np.cross(tangents(x)[0], [0, 0, 1.0])))
    link = cable.rest_link_length
    g, band, _, td = _joint_derivatives(chain, tc, x, d1, link)
    n = cable.n_links
    points = 4 * np.arange(n + 1)[:, None] + np.arange(3)
    dense = np.zeros((4 * n + 3, 4 * n + 3))
    dense[np.ix_(points.ravel(), points.ravel())] = hessian(chain, x).toarray()
    scale = np.ones(11)
    scale[[3, 7]] = 1 / link
    for s in range(n - 1):
        dense[4 * s: 4 * s + 11, 4 * s: 4 * s + 11] += td.blocks[s] * np.outer(scale, scale)
    assert band_to_sparse(band).toarray() == pytest.approx(dense, abs=1e-9 * np.abs(dense).max())


def test_dynamic_simulation_with_torsion_settles_on_the_static_twisted_equilibrium():
    # the simulator carries massless twist angles along (one Newton step per time step): run to
    # rest it must land where the static solver with torsion does, not where the untwisted does
    from conftest import level_clips, sagging_guess

    from dloplan.sim import simulate

    # the thesis' one modulus (the default): copper axial springs (COMPOSITE_AXIAL_MODULI) need a
    # 28 times shorter explicit step than the capped E's (replays cap E_a, REPLAY_AXIAL_CAP)
    cable = catalogue_cable("usb", n_links=8, axial_modulus=None)
    clips = level_clips(0.35)
    roll = Rotation.from_rotvec([0.75 * np.pi, 0.0, 0.0])  # the last clip turned about its u
    twisted = ClipPoses(clips.positions, Rotation.concatenate([clips.rotations[0],
                                                              clips.rotations[1] * roll]))
    untwisted = equilibrium(cable, sagging_guess(cable, 0.35), clips).shape
    static = equilibrium_with_twist(cable, untwisted, twisted)
    assert static.success and abs(np.degrees(static.total_twist)) > 100
    run = simulate(cable, untwisted, twisted, duration=3.0, youngs_modulus_cap=3e5,
                   rest_speed=1e-4, torsion=True)
    assert run.settled
    effect = np.abs(untwisted - static.shape).max()
    assert effect > 3e-4  # the twist moves the cable
    assert np.abs(run.shapes[-1] - static.shape).max() < 0.1 * effect


def test_a_diverging_dynamic_run_with_torsion_is_reported_as_divergence():
    # dt 10 times the hose's stable step: the links fold over within a few dozen steps, where
    # the carried frames are undefined; reported like any divergence, naming the time step
    from conftest import level_clips, sagging_guess

    from dloplan.sim import simulate

    cable = curved_hose(8)
    start = equilibrium(cable, sagging_guess(cable, 0.3), level_clips(0.3)).shape
    with pytest.raises(FloatingPointError, match="dt = 0.0001 s too large"):
        simulate(cable, start, level_clips(0.28), duration=0.05, dt=1e-4, torsion=True)
