"""Timed dual-arm TCP trajectories: speed limits, synchronization, interpolation, bad input.

Tolerances: segment speeds are distance / duration with the duration set by the limiting
quantity, so limits hold to round-off (relative 1e-9); finite differences of samples are
chords of straight lines (exact for positions) and slerp steps (exact angles), also 1e-9.
"""

from __future__ import annotations

import numpy as np
import pytest
from gripper_paths import bending_path, curved_hose, turnover_path
from scipy.spatial.transform import Rotation

from dloplan.grippers import gripper_path
from dloplan.trajectory import (
    DEFAULT_MAX_ANGULAR_SPEED,
    DEFAULT_MAX_SPEED,
    Trajectory,
    dual_arm_trajectory,
    trajectory_from_grippers,
)


@pytest.fixture(scope="module")
def hose_trajectory():
    cable = curved_hose()
    path, _ = turnover_path(cable.rest_shape)
    return trajectory_from_grippers(gripper_path(path, method="auto", cable=cable))


@pytest.fixture(scope="module")
def bending_trajectory():
    return trajectory_from_grippers(gripper_path(bending_path(), method="minimal"))


@pytest.mark.parametrize("name", ["hose_trajectory", "bending_trajectory"])
def test_sampled_speeds_never_exceed_the_limits(name, request):
    traj = request.getfixturevalue(name)
    samples = traj.sample(500.0)
    dt = np.diff(samples.times)
    assert np.all(dt > 0)
    speed = np.linalg.norm(np.diff(samples.positions, axis=0), axis=-1) / dt[:, None]
    assert np.max(speed) <= DEFAULT_MAX_SPEED * (1 + 1e-9)
    for rot in samples.rotations:
        omega = (rot[:-1].inv() * rot[1:]).magnitude() / dt
        assert np.max(omega) <= DEFAULT_MAX_ANGULAR_SPEED * (1 + 1e-9)


@pytest.mark.parametrize("name", ["hose_trajectory", "bending_trajectory"])
def test_the_slower_arm_sets_each_segment_and_runs_at_its_limit(name, request):
    traj = request.getfixturevalue(name)
    speed, omega = traj.segment_speeds()
    assert np.all(speed <= traj.max_speed * (1 + 1e-12))
    assert np.all(omega <= traj.max_angular_speed * (1 + 1e-12))
    saturation = np.maximum(speed / traj.max_speed, omega / traj.max_angular_speed).max(axis=1)
    assert np.allclose(saturation, 1.0, atol=1e-12)


def test_both_arms_arrive_at_every_knot_together(bending_trajectory):
    traj = bending_trajectory
    at = traj.at(traj.times)
    assert np.allclose(at.positions, traj.positions, atol=1e-15)
    for arm in (0, 1):
        diff = (at.rotations[arm].inv() * traj.rotations[arm]).magnitude()
        assert np.max(diff) < 1e-12
    samples = traj.sample(100.0)
    assert samples.times[0] == 0.0 and samples.times[-1] == traj.duration
    assert np.allclose(samples.positions[-1], traj.positions[-1], atol=1e-15)


def test_segments_are_straight_lines_and_constant_rate_slerps(bending_trajectory):
    traj = bending_trajectory
    k = 3
    t0, t1 = traj.times[k], traj.times[k + 1]
    fractions = np.linspace(0.0, 1.0, 11)
    at = traj.at(t0 + fractions * (t1 - t0))
    for arm in (0, 1):
        p0, p1 = traj.positions[k, arm], traj.positions[k + 1, arm]
        assert np.allclose(at.positions[:, arm], p0 + fractions[:, None] * (p1 - p0), atol=1e-15)
        step = traj.rotations[arm][k : k + 1].inv() * traj.rotations[arm][k + 1 : k + 2]
        angles = (traj.rotations[arm][k : k + 1].inv() * at.rotations[arm]).magnitude()
        assert np.allclose(angles, fractions * step.magnitude()[0], atol=1e-12)


def test_a_straight_translation_takes_distance_over_speed():
    """0.9 m at 100 mm/s: the 9 s of the thesis' use case (Table 7.3)."""
    positions = np.zeros((4, 2, 3))
    positions[:, 0, 0] = [0.0, 0.3, 0.6, 0.9]
    positions[:, 1, 0] = positions[:, 0, 0] + 0.4
    rot = Rotation.identity(4)
    traj = dual_arm_trajectory(positions, (rot, rot))
    assert traj.duration == pytest.approx(9.0, rel=1e-12)
    slow = dual_arm_trajectory(positions, (rot, rot), max_speed=0.05)
    assert slow.duration == pytest.approx(18.0, rel=1e-12)


def test_a_pure_rotation_is_timed_by_the_angular_limit():
    positions = np.zeros((2, 2, 3))
    left = Rotation.from_rotvec([[0, 0, 0], [0, 0, 0.5]])
    right = Rotation.identity(2)
    traj = dual_arm_trajectory(positions, (left, right), max_angular_speed=0.25)
    assert traj.duration == pytest.approx(2.0, rel=1e-12)


def test_a_segment_where_nothing_moves_takes_no_time_and_samples_fine():
    positions = np.zeros((3, 2, 3))
    positions[2, :, 2] = 0.1
    rot = Rotation.identity(3)
    traj = dual_arm_trajectory(positions, (rot, rot))
    assert np.allclose(traj.times, [0.0, 0.0, 1.0])
    samples = traj.sample(10.0)
    assert len(samples.times) == 11
    assert np.allclose(samples.positions[:, 0, 2], np.linspace(0, 0.1, 11))
    still = dual_arm_trajectory(positions[:1], (rot[:1], rot[:1]))
    assert still.duration == 0.0 and len(still.sample(10.0).times) == 1


def test_left_clip_and_tcp_offset():
    g = gripper_path(bending_path(), method="minimal")
    offset = Rotation.from_rotvec([0, np.pi / 2, 0])
    swapped = trajectory_from_grippers(g, left_clip=1, tcp_in_clip=offset)
    assert swapped.arm_clips == (1, 0)
    assert np.array_equal(swapped.positions[:, 0], g.positions[:, 1])
    tcp_x = swapped.rotations[0].apply([1.0, 0.0, 0.0])
    clip_u = g.rotations[1].apply(offset.apply([1.0, 0.0, 0.0]))
    assert np.allclose(tcp_x, clip_u, atol=1e-12)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(max_speed=0.0), "max_speed: got 0.0"),
        (dict(max_speed=-0.1), "max_speed"),
        (dict(max_speed=float("nan")), "max_speed"),
        (dict(max_angular_speed=0), "max_angular_speed"),
        (dict(left_clip=2), "left_clip"),
        (dict(tcp_in_clip=np.eye(3)), "tcp_in_clip"),
    ],
)
def test_bad_limits_and_options(kwargs, match):
    g = gripper_path(bending_path(), method="minimal")
    with pytest.raises(ValueError, match=match):
        trajectory_from_grippers(g, **kwargs)


def test_bad_rate_and_poses(bending_trajectory):
    with pytest.raises(ValueError, match="rate"):
        bending_trajectory.sample(0.0)
    rot = Rotation.identity(3)
    with pytest.raises(ValueError, match=r"positions: expected shape \(n_knots, 2, 3\)"):
        dual_arm_trajectory(np.zeros((3, 3)), (rot, rot))
    with pytest.raises(ValueError, match="rotations: expected two scipy Rotations of 3"):
        dual_arm_trajectory(np.zeros((3, 2, 3)), (rot, Rotation.identity(2)))
    with pytest.raises(ValueError, match="times"):
        Trajectory(np.array([0.0, 2.0, 1.0]), np.zeros((3, 2, 3)), (rot, rot))
