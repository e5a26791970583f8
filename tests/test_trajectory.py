"""Timed dual-arm TCP trajectories: time law and limits, synchronization, fly-by, cycle, bad input.

Tolerances: the limits are checked on samples 1 ms apart by finite differences (chords of
the motion: a k-th difference over k ms is the mean of the k-th derivative over that window,
so it can never exceed the true peak) within 1 % (the issue's tolerance; the jerk-limited
law holds them to round-off, the overlap speeds of a fly-by to the 0.25 ms grid they are
checked on). Arrival times are found on a 0.1 ms grid and compared within 1 ms (the issue's).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from gripper_paths import bending_path, curved_hose, turnover_path
from scipy.spatial.transform import Rotation

from dloplan.grippers import gripper_path
from dloplan.trajectory import (
    DEFAULT_GRASP_TIME,
    DEFAULT_RELEASE_TIME,
    GripperAction,
    MotionLimits,
    Trajectory,
    dual_arm_trajectory,
    plan_cycle,
    sample_times,
    trajectory_from_grippers,
)

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_trajectory")

STEP = 1e-3  # [s] the sampling of the limits
LIMITS = MotionLimits()


@pytest.fixture(scope="module")
def hose_grippers():
    cable = curved_hose()
    path, _ = turnover_path(cable.rest_shape)
    return gripper_path(path, method="auto", cable=cable)


@pytest.fixture(scope="module")
def bending_grippers():
    return gripper_path(bending_path(), method="minimal")


@pytest.fixture(scope="module")
def bending_trajectory(bending_grippers):
    return trajectory_from_grippers(bending_grippers)


def _differences(traj: Trajectory):
    """Finite-difference speed, acceleration, jerk (N, 2) and the angular ones at 1 ms."""
    t = np.arange(0.0, traj.duration, STEP)
    s = traj.at(t)
    linear = [np.linalg.norm(np.diff(s.positions, k, axis=0), axis=-1) / STEP**k
              for k in (1, 2, 3)]
    # rotation vectors of each sample relative to the first: differences of the body rotation
    angular = []
    for rot in s.rotations:
        step = (rot[:-1].inv() * rot[1:]).as_rotvec() / STEP  # (N-1, 3) body angular velocity
        angular.append([np.linalg.norm(step, axis=-1),
                        np.linalg.norm(np.diff(step, 1, axis=0), axis=-1) / STEP,
                        np.linalg.norm(np.diff(step, 2, axis=0), axis=-1) / STEP**2])
    return linear, angular


def _assert_within(traj: Trajectory, limits: MotionLimits, rel: float = 0.01):
    linear, angular = _differences(traj)
    for value, limit in zip(linear, (limits.speed, limits.acceleration, limits.jerk),
                            strict=True):
        assert value.max() <= limit * (1 + rel)
    for arm in angular:
        for value, limit in zip(arm, (limits.angular_speed, limits.angular_acceleration,
                                      limits.angular_jerk), strict=True):
            assert value.max() <= limit * (1 + rel)
    return linear, angular


@pytest.mark.parametrize("zone", [0.0, 0.01])
@pytest.mark.parametrize("name", ["hose_grippers", "bending_grippers"])
def test_the_time_law_respects_every_limit_at_1ms(name, zone, request):
    grippers = request.getfixturevalue(name)
    traj = trajectory_from_grippers(grippers, zone=zone)
    linear, angular = _assert_within(traj, LIMITS)
    # and it is time-optimal: some limit is reached (within the 1 % of the sampling)
    reached = max(linear[0].max() / LIMITS.speed,
                  max(a[0].max() for a in angular) / LIMITS.angular_speed)
    assert reached > 0.99
    # the analytic kinematics agree with the differences and stay within the limits
    kin = traj.kinematics(np.linspace(0.0, traj.duration, 4001))
    assert kin.speed.max() <= LIMITS.speed * (1 + 1e-9)
    assert kin.acceleration.max() <= LIMITS.acceleration * (1 + 1e-9)
    assert kin.jerk.max() <= LIMITS.jerk * (1 + 1e-9)
    assert kin.angular_speed.max() <= LIMITS.angular_speed * (1 + 1e-9)


def test_other_limits_are_respected_too(hose_grippers):
    slow = MotionLimits(speed=0.05, acceleration=0.2, jerk=1.0, angular_speed=0.3,
                        angular_acceleration=1.0, angular_jerk=20.0)
    traj = trajectory_from_grippers(hose_grippers, limits=slow)
    _assert_within(traj, slow)


def _arrival(traj: Trajectory, arm: int, k: int) -> float:
    """When the arm is nearest knot k around the knot's time (0.1 ms grid)."""
    lo, hi = max(0.0, traj.times[k] - 0.05), min(traj.duration, traj.times[k] + 0.05)
    t = np.arange(lo, hi + 1e-12, 1e-4)
    s = traj.at(t)
    gap = np.linalg.norm(s.positions[:, arm] - traj.positions[k, arm], axis=-1)
    gap += 0.1 * (traj.rotations[arm][k : k + 1].inv() * s.rotations[arm]).magnitude()
    near = np.flatnonzero(gap <= gap.min() + 1e-12)
    return float(t[near].mean())


@pytest.mark.parametrize("zone", [0.0, 0.01])
def test_both_arms_reach_each_planned_shape_at_the_same_time(bending_grippers, zone):
    traj = trajectory_from_grippers(bending_grippers, zone=zone)
    assert (traj.zones[1:-1] > 0).any() == (zone > 0)
    moving = np.r_[True, traj.segment_durations > 0]
    for k in np.flatnonzero(moving):
        left, right = _arrival(traj, 0, k), _arrival(traj, 1, k)
        assert abs(left - right) < 1e-3
        if traj.zones[k] == 0.0:  # a fly-by knot's time is the middle of its blend instead
            assert abs(left - traj.times[k]) < 1e-3
    if zone == 0.0:  # fine points: exactly at the knot poses at the knot times
        at = traj.at(traj.times)
        assert np.allclose(at.positions, traj.positions, atol=1e-12)
        for arm in (0, 1):
            assert (at.rotations[arm].inv() * traj.rotations[arm]).magnitude().max() < 1e-9


def test_a_fly_by_cuts_corners_by_less_than_the_zone_and_saves_time(bending_grippers):
    fine = trajectory_from_grippers(bending_grippers)
    zone = 0.01
    fly = trajectory_from_grippers(bending_grippers, zone=zone)
    assert fly.duration < fine.duration
    at = fly.at(fly.times)
    assert np.linalg.norm(at.positions - fly.positions, axis=-1).max() <= zone * (1 + 1e-9)
    assert np.allclose(at.positions[[0, -1]], fly.positions[[0, -1]], atol=1e-12)
    # a stop where the cable must settle stays a stop
    stopped = trajectory_from_grippers(bending_grippers, zone=zone, stops=[3])
    assert stopped.zones[3] == 0.0 and stopped.zones[2] > 0.0
    assert np.allclose(stopped.at(stopped.times[3:4]).positions[0], stopped.positions[3],
                       atol=1e-12)


def test_a_straight_move_takes_the_closed_form_s_curve_time():
    """Rest to rest over d with cruise: T = d / v + v / a + a / j (v >= a^2 / j)."""
    positions = np.zeros((2, 2, 3))
    positions[1, :, 0] = 0.3
    rot = Rotation.identity(2)
    traj = dual_arm_trajectory(positions, (rot, rot))
    assert traj.duration == pytest.approx(0.3 / 0.1 + 0.1 / 1.0 + 1.0 / 10.0, rel=1e-9)
    # without cruise (short move, jerk-limited triangle): T = 4 (d / (2 j))^(1/3)
    positions[1, :, 0] = 1e-4
    short = dual_arm_trajectory(positions, (rot, rot))
    assert short.duration == pytest.approx(4 * (1e-4 / 20.0) ** (1 / 3), rel=1e-9)


def test_the_velocity_only_law_is_distance_over_speed():
    """0.9 m at 100 mm/s: the 9 s of the thesis' use case (Table 7.3), a lower bound."""
    positions = np.zeros((4, 2, 3))
    positions[:, 0, 0] = [0.0, 0.3, 0.6, 0.9]
    positions[:, 1, 0] = positions[:, 0, 0] + 0.4
    rot = Rotation.identity(4)
    traj = dual_arm_trajectory(positions, (rot, rot), law="constant-speed")
    assert traj.duration == pytest.approx(9.0, rel=1e-12)
    assert traj.limits is None
    real = dual_arm_trajectory(positions, (rot, rot))
    assert real.duration == pytest.approx(9.0 + 3 * 0.2, rel=1e-9)  # three stops of 0.2 s
    ramp = dual_arm_trajectory(positions, (rot, rot), zone=0.05)
    assert 9.2 < ramp.duration < real.duration  # flies through the collinear knots


def test_a_pure_rotation_is_timed_by_the_angular_limits():
    positions = np.zeros((2, 2, 3))
    left = Rotation.from_rotvec([[0, 0, 0], [0, 0, 0.5]])
    right = Rotation.identity(2)
    traj = dual_arm_trajectory(positions, (left, right), max_angular_speed=0.25)
    # 0.5 rad at 0.25 rad/s, 100 rad/s^3; 10 rad/s^2 is not reached (0.25 < 10^2 / 100):
    # T = d / w + 2 sqrt(w / zeta)
    assert traj.duration == pytest.approx(0.5 / 0.25 + 2 * math.sqrt(0.25 / 100), rel=1e-9)
    old = dual_arm_trajectory(positions, (left, right), max_angular_speed=0.25,
                              law="constant-speed")
    assert old.duration == pytest.approx(2.0, rel=1e-12)


@pytest.mark.parametrize("zone", [0.0, 0.01])
@pytest.mark.parametrize("field", ["speed", "acceleration", "jerk", "angular_speed",
                                   "angular_acceleration", "angular_jerk"])
def test_slower_limits_never_shorten_the_cycle(hose_grippers, field, zone):
    base = trajectory_from_grippers(hose_grippers, zone=zone).duration
    for factor in (0.8, 0.5, 0.25):
        value = getattr(LIMITS, field) * factor
        limits = MotionLimits(**{**LIMITS.__dict__, field: value})
        slower = trajectory_from_grippers(hose_grippers, limits=limits, zone=zone).duration
        assert slower >= base * (1 - 1e-12)
        base = slower


def test_a_speed_scale_slows_its_segment_only(bending_trajectory, bending_grippers):
    k = bending_trajectory.n_knots - 1
    scale = np.ones(k)
    scale[2] = 0.5
    slow = trajectory_from_grippers(bending_grippers, speed_scale=scale)
    dt0, dt1 = bending_trajectory.segment_durations, slow.segment_durations
    assert dt1[2] > dt0[2] and np.allclose(np.delete(dt1, 2), np.delete(dt0, 2), rtol=1e-12)
    peak, _ = slow.segment_peak_speeds()
    assert peak[2].max() <= 0.5 * LIMITS.speed * (1 + 1e-9)
    # the callable hook sees the knot poses
    seen = []

    def hook(positions, rotations):
        seen.append(positions.shape)
        return scale

    hooked = trajectory_from_grippers(bending_grippers, speed_scale=hook)
    assert seen == [(k + 1, 2, 3)] and np.allclose(hooked.times, slow.times)


def test_the_segment_table_holds_what_a_robot_program_needs(bending_grippers):
    fly = trajectory_from_grippers(bending_grippers, zone=0.01, stops=[2])
    rows = fly.segment_table()
    assert len(rows) == fly.n_knots - 1
    assert [r["fine"] for r in rows] == list(fly.zones[1:] == 0)
    assert rows[-1]["fine"] and not rows[2]["fine"] and rows[1]["fine"]
    assert sum(r["duration"] for r in rows) == pytest.approx(fly.duration)
    speeds = np.array([r["speed"] for r in rows])
    assert speeds.max() <= LIMITS.speed * (1 + 1e-9)
    # peaks match the sampled motion of each segment (fine trajectory: segments apart)
    fine = trajectory_from_grippers(bending_grippers)
    peak, _ = fine.segment_peak_speeds()
    for k in range(fine.n_knots - 1):
        t = np.linspace(fine.times[k], fine.times[k + 1], 2001)
        assert fine.kinematics(t).speed.max(axis=0) == pytest.approx(peak[k], rel=1e-4,
                                                                     abs=1e-12)


def test_a_segment_where_nothing_moves_takes_no_time_and_samples_fine():
    positions = np.zeros((3, 2, 3))
    positions[2, :, 2] = 0.1
    rot = Rotation.identity(3)
    traj = dual_arm_trajectory(positions, (rot, rot))
    assert traj.times[0] == traj.times[1] == 0.0
    samples = traj.sample(10.0)
    assert samples.times[-1] == traj.duration
    assert np.allclose(samples.positions[-1], positions[-1], atol=1e-15)
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


def test_a_trajectory_from_knot_times_alone_is_the_velocity_only_law(bending_trajectory):
    traj = bending_trajectory
    legacy = Trajectory(traj.times, traj.positions, traj.rotations)
    assert legacy.law.kind == "constant-speed"
    k = 3
    t0, t1 = legacy.times[k], legacy.times[k + 1]
    fractions = np.linspace(0.0, 1.0, 11)
    at = legacy.at(t0 + fractions * (t1 - t0))
    p0, p1 = legacy.positions[k, 0], legacy.positions[k + 1, 0]
    assert np.allclose(at.positions[:, 0], p0 + fractions[:, None] * (p1 - p0), atol=1e-15)


def test_the_cycle_adds_the_gripper_actions(bending_trajectory):
    traj = bending_trajectory
    cycle = plan_cycle(traj)
    assert cycle.motion_time == pytest.approx(traj.duration)
    assert cycle.action_time == pytest.approx(DEFAULT_GRASP_TIME + DEFAULT_RELEASE_TIME)
    assert cycle.cycle_time == pytest.approx(traj.duration + 0.9)
    assert [p.name for p in cycle.phases] == ["grasp", "motion", "release"]
    last = traj.n_knots - 1
    regrasp = GripperAction.regrasp_at(4)
    phased = plan_cycle(traj, [GripperAction("grasp", 0, 0.3), regrasp,
                               GripperAction("release", last, 0.2)],
                        {"carry": (0, 5), "place": (5, last)})
    assert [p.name for p in phased.phases] == ["grasp", "carry", "regrasp", "carry", "place",
                                               "release"]
    b = phased.breakdown()
    assert b["carry"] == pytest.approx(traj.times[5])
    assert b["place"] == pytest.approx(traj.duration - traj.times[5])
    assert b["regrasp"] == pytest.approx(0.9)
    assert phased.cycle_time == pytest.approx(traj.duration + 0.3 + 0.9 + 0.2)
    # the phases follow each other without gaps
    assert all(a.end == pytest.approx(b.start) for a, b in
               zip(phased.phases, phased.phases[1:], strict=False))
    shifted = phased.knot_times(traj)
    assert shifted[0] == pytest.approx(0.3) and shifted[5] == pytest.approx(1.2 + traj.times[5])
    assert shifted[-1] == pytest.approx(phased.cycle_time - 0.2)
    assert "cycle" in phased.describe()


def test_a_gripper_action_needs_a_stop(bending_grippers):
    fly = trajectory_from_grippers(bending_grippers, zone=0.01)
    with pytest.raises(ValueError, match="flies by knot 4"):
        plan_cycle(fly, [GripperAction.regrasp_at(4)])
    stopped = trajectory_from_grippers(bending_grippers, zone=0.01, stops=[4])
    assert plan_cycle(stopped, [GripperAction.regrasp_at(4)]).action_time == pytest.approx(0.9)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(max_speed=0.0), "max_speed: got 0.0"),
        (dict(max_speed=-0.1), "max_speed"),
        (dict(max_speed=float("nan")), "max_speed"),
        (dict(max_angular_speed=0), "max_angular_speed"),
        (dict(limits={"speed": 0.1}), "limits: got dict"),
        (dict(zone=-0.01), "zone: got -0.01"),
        (dict(zone=0.01, law="constant-speed"), "zone: fly-by needs"),
        (dict(stops=[0]), "stops: got \\[0\\]"),
        (dict(speed_scale=[1.0]), "speed_scale"),
        (dict(law="trapezoid"), "law: got 'trapezoid'"),
        (dict(left_clip=2), "left_clip"),
        (dict(tcp_in_clip=np.eye(3)), "tcp_in_clip"),
    ],
)
def test_bad_limits_and_options(kwargs, match, bending_grippers):
    with pytest.raises(ValueError, match=match):
        trajectory_from_grippers(bending_grippers, **kwargs)


@pytest.mark.parametrize("field", ["speed", "acceleration", "jerk", "angular_speed",
                                   "angular_acceleration", "angular_jerk"])
@pytest.mark.parametrize("value", [0.0, -1.0, math.inf, "fast"])
def test_zero_or_negative_limits_are_clear_errors(field, value):
    with pytest.raises(ValueError, match=f"{field}: got {value!r}, expected a finite number > 0"):
        MotionLimits(**{field: value})


def test_bad_rate_poses_and_actions(bending_trajectory):
    with pytest.raises(ValueError, match="rate"):
        bending_trajectory.sample(0.0)
    rot = Rotation.identity(3)
    with pytest.raises(ValueError, match=r"positions: expected shape \(n_knots, 2, 3\)"):
        dual_arm_trajectory(np.zeros((3, 3)), (rot, rot))
    with pytest.raises(ValueError, match="rotations: expected two scipy Rotations of 3"):
        dual_arm_trajectory(np.zeros((3, 2, 3)), (rot, Rotation.identity(2)))
    with pytest.raises(ValueError, match="times"):
        Trajectory(np.array([0.0, 2.0, 1.0]), np.zeros((3, 2, 3)), (rot, rot))
    with pytest.raises(ValueError, match="grasp.duration: got 0"):
        GripperAction("grasp", 0, 0)
    with pytest.raises(ValueError, match="action: got 'wave'"):
        GripperAction("wave", 0, 1.0)
    with pytest.raises(ValueError, match="release.knot: got 99"):
        plan_cycle(bending_trajectory, [GripperAction("release", 99, 1.0)])
    with pytest.raises(ValueError, match="motion_phases"):
        plan_cycle(bending_trajectory, motion_phases={"a": (0, 3), "b": (4, 9)})



def test_the_scenario_trajectory_section_gives_the_limits():
    from pydantic import ValidationError

    from dloplan.app.resolve import motion_limits
    from dloplan.io.scenario import TrajectorySpec

    spec = TrajectorySpec(tcp_speed=0.05, acceleration=0.5, jerk=4.0, zone=0.01)
    assert motion_limits(spec, 1.0) == MotionLimits(speed=0.05, acceleration=0.5, jerk=4.0)
    assert motion_limits(spec, 1e-3) == MotionLimits(speed=5e-5, acceleration=5e-4,
                                                     jerk=4e-3)
    assert (spec.zone, spec.grasp_time, spec.release_time) == (0.01, 0.5, 0.4)
    for bad in ({"jerk": 0.0}, {"acceleration": -1.0}, {"zone": -0.01}):
        with pytest.raises(ValidationError, match=next(iter(bad))):
            TrajectorySpec(**bad)


def test_sampling_refuses_more_samples_than_memory_holds():
    """A plan re-timed at 1e-9 m/s lasts years: sampling it at 100 Hz is a one-line
    ValueError naming the rate, not a 170 GB allocation."""
    assert len(sample_times(3.0, 100.0)) == 301
    with pytest.raises(ValueError, match=r"rate: 100 Hz .* samples, more than 1e\+06"):
        sample_times(2.3e8, 100.0)
