"""Peak joint speeds and accelerations along the time law (closed forms, finite differences in
time, the overlap of two moves at a fly-by target), slowing a program that exceeds a joint's
speed limit, the hard joint margin, and the frames a user teaches (the robot standing on the
scenario's table)."""

from __future__ import annotations

import numpy as np
import pytest
from robot_plans import ON_ONE_WORKER, example_plan

from dloplan.robot import RobotCell, robot_program
from dloplan.robot.motion import JointMotion
from dloplan.robot.path import ReachOptions
from dloplan.robot.peaks import motion_peaks
from dloplan.robot.urdf_cell import ur5e_pair
from dloplan.trajectory import MotionLimits, trajectory_from_grippers
from dloplan.trajectory.timelaw import Profile

pytestmark = ON_ONE_WORKER

LAW = Profile.jerk_limited(2.0, 8.0, 60.0)  # u: rest to rest, cruising at 2 /s


def segment_peaks(path, law, max_velocity, max_acceleration):
    """The peaks of one move of one arm along ``law``, as a tuple (speed ratio, its joint,
    acceleration ratio, its joint, largest acceleration)."""
    path = np.asarray(path, dtype=float)
    motion = JointMotion(((path,),), (law,), np.array([0.0]), np.array([0.0, law.duration]))
    p = motion_peaks(motion, [max_velocity], [max_acceleration])[0]
    return (p.speed[0], p.speed_joint[0], p.acceleration[0], p.acceleration_joint[0],
            p.largest_acceleration[0])


def test_linear_joint_path_peaks_are_the_laws():
    # q(s) = q0 + s dq: dq/dt = dq u', d2q/dt2 = dq u''; the law's own peak rate (exact) and
    # its acceleration limit 8 /s^2 (reached). Central differences are exact on a line.
    dq = np.array([0.3, -1.2, 0.0])
    path = np.linspace(0.0, 1.0, 11)[:, None] * dq + [0.1, 0.2, 0.3]
    limits = np.array([1.0, 3.0, 1.0])
    speed, joint, accel, accel_joint, largest = segment_peaks(
        path, LAW, limits, np.array([np.inf, 20.0, np.inf]))
    assert speed == pytest.approx(1.2 * LAW.peak_rate() / 3.0, rel=1e-9)
    assert joint == 1 and accel_joint == 1
    assert largest == pytest.approx(1.2 * 8.0, rel=1e-6)
    assert accel == pytest.approx(1.2 * 8.0 / 20.0, rel=1e-6)


def test_curved_joint_path_against_differences_in_time():
    # q(s) = sin(3 s) on 41 sub-steps: the peaks of dq/dt and d2q/dt2 along the law equal
    # those of q(u(t)) differentiated numerically in time (1e-5 s steps) within the error of
    # the spline through the sub-steps (h = 0.025: O(h^3) on q', O(h^2) on q''; 3e-3 relative
    # on the speed, 1e-2 on the acceleration) and of the time grid (200 samples per move).
    s = np.linspace(0.0, 1.0, 41)
    speed, _, accel, _, largest = segment_peaks(np.sin(3 * s)[:, None], LAW, [1.0], [1.0])
    t = np.arange(0.0, LAW.duration, 1e-5)
    q = np.sin(3 * LAW.evaluate(t)[0])
    dq = np.gradient(q, t)
    ddq = np.gradient(dq, t)
    assert speed == pytest.approx(np.abs(dq).max(), rel=3e-3)
    assert largest == pytest.approx(np.abs(ddq).max(), rel=1e-2)
    assert accel == pytest.approx(largest, rel=1e-12)


def test_peaks_are_up_to_twice_the_average():
    # The jerk-limited law cruises above the average rate: a segment whose average joint
    # speed is 0.6 of the limit peaks above it (what the old check, on averages, passed).
    average = 1.0 / LAW.duration
    path = np.linspace(0.0, 1.0, 11)[:, None] * (0.6 / average)
    speed = segment_peaks(path, LAW, [1.0], [np.inf])[0]
    assert speed > 1.0 and speed == pytest.approx(0.6 * LAW.peak_rate() / average, rel=1e-9)


def test_overlapping_moves_add_their_joint_speeds():
    # Two moves of the same straight joint path overlapping by half a law: during the overlap
    # both run at once, so the peak of the first move is at least its own cruise rate and at
    # most twice it; the sum of the two laws' rates sampled in time is the truth.
    dq = np.array([1.0])
    path = np.linspace(0.0, 1.0, 5)[:, None] * dq
    half = LAW.duration / 2
    motion = JointMotion(((path, path + dq),), (LAW, LAW), np.array([0.0, half]),
                         np.array([0.0, LAW.duration, LAW.duration + half]))
    first = motion_peaks(motion, [[1.0]], [[np.inf]])[0].speed[0]
    t = np.linspace(0.0, LAW.duration, 20001)
    truth = (LAW.evaluate(t, 1)[1] + LAW.evaluate(t - half, 1)[1]).max()
    assert LAW.peak_rate() < first <= 2 * LAW.peak_rate()
    assert first == pytest.approx(truth, rel=1e-3)


def _fast(grippers, left_clip, speed):
    limits = MotionLimits(speed=speed, acceleration=10 * speed, jerk=100 * speed,
                          angular_speed=10 * speed, angular_acceleration=100 * speed,
                          angular_jerk=1000 * speed)
    return trajectory_from_grippers(grippers, left_clip=left_clip, limits=limits)


def test_a_yumi_program_over_a_joint_speed_limit_is_slowed():
    _, grippers, trajectory, job = example_plan("m2_uniform_curvature_usb.yaml")
    fast = _fast(grippers, trajectory.arm_clips[0], 50.0)
    program = robot_program(grippers, fast, job.robot)
    assert program.ok, program.message
    assert program.trajectory is not fast
    assert program.trajectory.duration > fast.duration
    assert program.joint_speed.max() <= 1.0
    assert program.joint_speed.max() > 0.9  # slowed to 98 % of the limit, not beyond
    # the program's timing is the slowed trajectory's: RAPID's \T are its segments
    inner = program.targets.durations[1:-1]
    np.testing.assert_allclose(inner, program.trajectory.segment_durations, atol=1e-12)
    # unchanged where nothing was over: the plan's own trajectory is kept
    assert robot_program(grippers, trajectory, job.robot).trajectory is trajectory


def test_a_described_cell_over_a_joint_speed_limit_is_slowed():
    _, grippers, trajectory, _ = example_plan("m2_uniform_curvature_usb.yaml")
    cell = ur5e_pair()
    fast = _fast(grippers, trajectory.arm_clips[0], 50.0)
    program = robot_program(grippers, fast, cell)
    speeds = [r for r in program.checks if r.check == "joint speed"]
    assert speeds and all(r.ok for r in speeds)
    assert max(r.value for r in speeds) > 0.9
    assert program.trajectory.duration > fast.duration
    np.testing.assert_allclose(program.times, program.trajectory.times[program.targets.shapes])


def test_the_joint_margin_is_a_hard_check():
    _, grippers, trajectory, job = example_plan("m2_uniform_curvature_usb.yaml")
    program = robot_program(grippers, trajectory, job.robot)
    margin = min(r.value for r in program.checks if r.check == "joint limits")
    assert program.ok and margin >= 5.0
    # a margin no solution has (the arm's smallest half range is 113 deg): refused, naming it
    strict = RobotCell(base_position=job.robot.base_position,
                       reach=ReachOptions(min_margin=np.radians(80.0)))
    refused = robot_program(grippers, trajectory, strict)
    assert not refused.ok and "joint limits" in refused.message
    assert "less than the 80 deg required" in refused.message


def test_the_robot_stands_on_the_scenario_table():
    # The examples' plan frame has the table top at z = 0: the robot's foot on it puts its
    # base frame 0.1 m up, and the work object (the plan's frame seen from the base) is the
    # table point below the base: [0, 0, -0.1] m. Without a table: the base frame itself,
    # the table at -0.1 m.
    _, _, _, job = example_plan("m2_uniform_curvature_usb.yaml")
    np.testing.assert_allclose(job.robot.base_position, [0.0, 0.0, 0.1])
    assert job.robot.table_height == 0.0
    position, rotation = job.robot.wobj_frame
    np.testing.assert_allclose(position, [0.0, 0.0, -0.1])
    assert rotation.magnitude() == 0.0
    _, _, _, planar = example_plan("fig4_8_straight_to_bent.yaml")
    np.testing.assert_allclose(planar.robot.base_position, 0.0)
    assert planar.robot.table_height == pytest.approx(-0.1)
    assert RobotCell().table_height == pytest.approx(-0.1)
