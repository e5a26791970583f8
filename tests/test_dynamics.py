"""The thesis' dynamic simulator (eq. 3.24) against the static solver."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import level_clips, sagging_guess

from dloplan import catalogue_cable
from dloplan.sim import ClipTrajectory, equilibrium, settle, simulate, stabilize


def test_time_stepping_to_rest_agrees_with_the_static_solver():
    cable = catalogue_cable("ethernet", n_links=10)
    clips = level_clips(0.4)
    guess = sagging_guess(cable, 0.4, -0.08)
    static = equilibrium(cable, guess, clips)
    start = static.shape.copy()
    start[2:-2, 2] += 0.01  # lift the free points: the cable falls back
    dynamic = settle(cable, start, clips, rest_speed=1e-4)
    assert dynamic.converged, dynamic.message
    assert dynamic.iterations > 1000
    assert np.abs(dynamic.shape - static.shape).max() < 0.5e-3  # [m], the bound
    via_stabilize = stabilize(start, cable, method="dynamic", rest_speed=1e-4)
    assert np.abs(via_stabilize.shape - dynamic.shape).max() < 1e-12


def test_moving_clips_drag_the_cable_and_it_settles_where_statics_says():
    cable = catalogue_cable("usb", n_links=8)
    start = equilibrium(cable, sagging_guess(cable, 0.42), level_clips(0.42))
    end_clips = level_clips(0.3, z=0.05).moved(translation=(0.05, 0.0, 0.0))
    trajectory = ClipTrajectory(np.array([0.0, 0.5]), [start.clips, end_clips])
    run = simulate(cable, start.shape, trajectory, duration=3.0, youngs_modulus_cap=1e6,
                   rest_speed=1e-4)
    assert run.settled, run.message
    final = run.shapes[-1]
    assert np.allclose(final[[0, 1, -2, -1]], end_clips.held_points(cable.rest_link_length))
    static = equilibrium(cable, final, end_clips)
    assert np.abs(final - static.shape).max() < 1e-3


def test_ground_plane_is_one_sided():
    cable = catalogue_cable("usb", n_links=8)
    clips = level_clips(0.25, z=0.1)
    hanging = equilibrium(cable, sagging_guess(cable, 0.25), clips, gravity=(0, 0, 0)).shape
    assert hanging[:, 2].min() < -0.05  # without the table it would hang through it
    start = np.maximum(hanging, [-np.inf, -np.inf, 0.0])
    # the loop cut off at the table has links 20-25 % short: the copper axial springs throw the
    # cable up (8.6 cm at 0.1 s) before it falls back onto the table (at rest there by 0.6 s)
    run = simulate(cable, start, clips, duration=1.0, ground=True, youngs_modulus_cap=1e6)
    assert run.shapes[:, :, 2].min() >= 0.0
    assert np.isclose(run.shapes[-1, :, 2].min(), 0.0, atol=1e-9)  # it lies on the table


def test_a_run_continued_from_its_last_state_is_the_run_in_one_piece():
    """``simulate(initial_velocity=)`` from a run's last shape and :attr:`Simulation.velocity`,
    the clip motion shifted to start there, takes the same explicit steps as one run through
    (the replay continues a harness section's implicit part explicitly, docs/decisions.md):
    the clips move for 0.5 s and the run is split at 0.2 s, with the cable still swinging
    (free points faster than 0.05 m/s): a restart at rest is 1 mm off 0.05 s later."""
    cable = catalogue_cable("usb", n_links=8)
    start = equilibrium(cable, sagging_guess(cable, 0.42), level_clips(0.42))
    end_clips = level_clips(0.3, z=0.05).moved(translation=(0.05, 0.0, 0.0))
    times, poses = np.array([0.0, 0.5]), [start.clips, end_clips]
    options = dict(youngs_modulus_cap=1e6, record_interval=0.01)
    whole = simulate(cable, start.shape, ClipTrajectory(times, poses), duration=0.6, **options)
    first = simulate(cable, start.shape, ClipTrajectory(times, poses), duration=0.2, **options)
    begin = first.steps * first.dt
    assert np.abs(first.velocity[2:-2]).max() > 0.05  # the free points [m/s]
    later = ClipTrajectory(times - begin, poses)
    then = simulate(cable, first.shapes[-1], later, duration=0.6 - begin,
                    initial_velocity=first.velocity, **options)
    assert first.steps + then.steps == whole.steps
    np.testing.assert_allclose(then.shapes[-1], whole.shapes[-1], atol=1e-12)
    at_rest = simulate(cable, first.shapes[-1], later, duration=0.6 - begin, **options)
    assert np.abs(at_rest.shapes[5] - then.shapes[5]).max() > 5e-4  # 0.05 s after the split


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_too_large_a_time_step_is_reported():
    cable = catalogue_cable("pa12", n_links=8)
    with pytest.raises(FloatingPointError, match="diverged"):
        simulate(cable, sagging_guess(cable, 0.4), level_clips(0.4), duration=0.1,
                 dt=100 * cable.time_step())


@pytest.mark.parametrize(
    "kwargs, fragment",
    [
        (dict(duration=0.0), "duration"),
        (dict(duration=1.0, dt=-1.0), "dt"),
        (dict(duration=1e9), "max_steps"),
    ],
)
def test_bad_simulation_settings(kwargs, fragment):
    cable = catalogue_cable("usb", n_links=8)
    with pytest.raises(ValueError, match=fragment):
        simulate(cable, sagging_guess(cable, 0.4), level_clips(0.4), **kwargs)


def test_clip_trajectory_validates_times():
    with pytest.raises(ValueError, match="strictly increasing"):
        ClipTrajectory(np.array([0.0, 0.0]), [level_clips(0.4), level_clips(0.3)])
    with pytest.raises(ValueError, match="one time per clip pose"):
        ClipTrajectory(np.array([0.0]), [level_clips(0.4), level_clips(0.3)])


@pytest.mark.parametrize("axial, atol", [("copper", 1e-11), ("thesis", 1e-12)])
@pytest.mark.parametrize("damping", ["absolute", "relative"])
def test_compiled_stepping_matches_a_plain_numpy_euler_loop(damping, axial, atol):
    # eq. 3.24 written out with the numpy reference gradient; the same steps to round-off (the
    # copper axial springs, 800 times E's, carry forces whose round-off is as many times larger:
    # the two loops part by up to 5e-12 m over the 300 steps)
    from dloplan.physics.chain import SpringChain, gradient

    cable = catalogue_cable("usb", n_links=8)
    cable = cable if axial == "copper" else replace(cable, axial_modulus=None)  # E_a = E
    start = equilibrium(cable, sagging_guess(cable, 0.3), level_clips(0.3)).shape
    start[2:-2, 2] -= 0.05  # sagging below the ground plane z = 0, which pushes it back up
    end = level_clips(0.25, z=0.02)
    trajectory = ClipTrajectory(np.array([0.0, 0.01]), [level_clips(0.3), end])
    dt = 2e-5
    run = simulate(cable, start, trajectory, duration=300 * dt, dt=dt, damping=damping,
                   ground=True, record_interval=100 * dt)
    chain = SpringChain.from_cable(cable)
    x, v = start.copy(), np.zeros_like(start)
    held = [0, 1, -2, -1]
    previous = trajectory.held_points(np.array([0.0]), cable.rest_link_length)[0]
    x[held] = previous
    mass = cable.point_masses[:, None]
    for step in range(1, 301):
        if damping == "relative":
            drag = np.zeros_like(v)
            drag[1:] += v[1:] - v[:-1]
            drag[:-1] += v[:-1] - v[1:]
        else:
            drag = v
        v = v + (-gradient(chain, x) - cable.k_damping * drag) / mass * dt
        x = x + v * dt
        target = trajectory.held_points(np.array([step * dt]), cable.rest_link_length)[0]
        v[held] = (target - previous) / dt
        x[held] = previous = target
        v[:, 2] = np.where(x[:, 2] < 0, np.maximum(v[:, 2], 0.0), v[:, 2])
        x[:, 2] = np.maximum(x[:, 2], 0.0)
        if step % 100 == 0:
            k = step // 100
            assert np.isclose(run.times[k], step * dt)
            assert np.max(np.abs(run.shapes[k] - x)) < atol
    assert run.steps == 300 and len(run.times) == 4
    assert np.max(np.abs(run.shapes[0] - start)) == 0.0  # the shape as given


def test_the_compiled_held_targets_are_the_trajectorys_held_points():
    # sim.stepping.held_targets (the stepping's clip targets, per chunk) against the numpy
    # path of ClipTrajectory.held_points (lerp, slerp, x-axes): turning clips (slerp's sine
    # weights: libm's sine against numpy's vectorized one, equal to a few 1e-17 m), moving
    # clips that do not turn (linear weights: bit for bit), a quaternion sign flip (the
    # shorter arc), times before the first key and after the last (held), a single pose
    from scipy.spatial.transform import Rotation

    from dloplan.sim.clips import ClipPoses
    from dloplan.sim.stepping import held_targets

    turns = Rotation.from_euler("zyx", [[0, 0, 0], [40, 10, 5], [40, 10, 5], [-120, 30, 0],
                                        [-130, 31, 2]], degrees=True)
    poses = [ClipPoses(np.array([[0.01 * k, 0.0, 0.02 * k], [0.3, 0.05 * k, 0.0]]),
                       Rotation.concatenate([turns[k], turns[(k + 2) % 5]])) for k in range(5)]
    quats = np.stack([p.rotations.as_quat() for p in poses])
    quats[3, 1] *= -1.0  # the same rotations; q . q' < 0 across a key
    positions = np.stack([p.positions for p in poses])
    turning = ClipTrajectory.sampled([0.0, 0.2, 0.5, 0.7, 1.0], positions, quats)
    level = np.broadcast_to([0.0, 0.0, 0.0, 1.0], quats.shape)  # the clips keep their frames
    moving = ClipTrajectory.sampled([0.0, 0.2, 0.5, 0.7, 1.0], positions, level)
    times = np.concatenate([[-0.1], np.arange(20001) * 5e-5, [1.0, 1.3]])
    for clips, link, tolerance in ((turning, 0.012, 2e-16), (moving, 0.03, 0.0),
                                   (ClipTrajectory.hold(poses[2]), 0.02, 0.0)):
        out = np.empty((len(times), 4, 3))
        held_targets(clips.times, np.stack([p.positions for p in clips.poses]),
                     np.stack([p.rotations.as_quat() for p in clips.poses]), times, link, out)
        assert np.max(np.abs(out - clips.held_points(times, link))) <= tolerance
        assert np.allclose(np.linalg.norm(out[:, 1] - out[:, 0], axis=1), link, atol=1e-15)
