"""The one program model of every cell (dloplan.robot.program): a program slowed for its
joint speeds is exactly the program made on its slowed timing (re-timing solves nothing again),
the speed rows are those of the motion the writers sample, and a described cell's program that
fails only along the time law says so."""

from __future__ import annotations

import numpy as np
from robot_plans import example_plan

from dloplan.robot import robot_program
from dloplan.robot.actions import program_timeline
from dloplan.robot.program import RobotProgram
from dloplan.robot.tracked_program import TrackedTargets, tracked_moves
from dloplan.robot.urdf_cell import ur5e_pair, verify_on_cell
from dloplan.trajectory import MotionLimits, trajectory_from_grippers

EXAMPLE = "m2_uniform_curvature_usb.yaml"


def _fast(grippers, left_clip, speed):
    """The plan's path timed at ``speed`` [m/s] (accelerations and jerks in proportion): fast
    enough to take a joint over its speed limit."""
    limits = MotionLimits(speed=speed, acceleration=10 * speed, jerk=100 * speed,
                          angular_speed=10 * speed, angular_acceleration=100 * speed,
                          angular_jerk=1000 * speed)
    return trajectory_from_grippers(grippers, left_clip=left_clip, limits=limits)


def _same_rows(a, b):
    assert [r.to_dict() for r in a.checks] == [r.to_dict() for r in b.checks]


def test_a_slowed_yumi_program_is_the_program_of_its_own_timing():
    _, grippers, trajectory, job = example_plan(EXAMPLE)
    fast = _fast(grippers, trajectory.arm_clips[0], 50.0)
    slowed = robot_program(grippers, fast, job.robot)
    assert slowed.trajectory is not fast  # it was over a limit, and re-timed
    fresh = robot_program(grippers, slowed.trajectory, job.robot)
    assert fresh.trajectory is slowed.trajectory  # within the limits: not slowed again
    for name in ("positions", "quaternions", "confdata", "arm_angles", "times", "durations",
                 "speeds", "zones", "motion_times", "motion_joints"):
        np.testing.assert_array_equal(getattr(slowed.targets, name),
                                      getattr(fresh.targets, name), err_msg=name)
    for a in range(2):
        np.testing.assert_array_equal(slowed.joints[a], fresh.joints[a])
    np.testing.assert_array_equal(slowed.joint_speed, fresh.joint_speed)
    _same_rows(slowed, fresh)
    assert slowed.message == fresh.message


def test_a_slowed_cell_program_is_the_program_of_its_own_timing():
    _, grippers, trajectory, _ = example_plan(EXAMPLE)
    fast = _fast(grippers, trajectory.arm_clips[0], 50.0)
    slowed = robot_program(grippers, fast, ur5e_pair())
    assert slowed.trajectory is not fast
    fresh = robot_program(grippers, slowed.trajectory, ur5e_pair())
    assert fresh.trajectory is slowed.trajectory
    np.testing.assert_array_equal(slowed.times, fresh.times)
    for a in range(2):
        np.testing.assert_array_equal(slowed.joints[a], fresh.joints[a])
    np.testing.assert_array_equal(slowed.joint_speed, fresh.joint_speed)
    _same_rows(slowed, fresh)


def _written_speed_ratio(program, limits) -> float:
    """The largest joint speed, as a fraction of the limit, of what the writers write: the
    program's timeline (its motion along its own trajectory, gripper actions included) sampled
    at 1 kHz."""
    _, samples = program_timeline(program, program.trajectory).samples(1000.0, order=1)
    return max(float((np.abs(s[1]) / limit).max()) for s, limit in zip(samples, limits,
                                                                        strict=True))


def test_the_speed_rows_are_those_of_the_written_motion():
    """What the writers sample is what the speed rows checked: the written joints' largest
    speed reaches the checked peak (the check samples each move on 200 instants and at its
    law's phase boundaries, the writers at 1 kHz: within 1 %) and never exceeds it."""
    _, grippers, trajectory, job = example_plan(EXAMPLE)
    yumi = robot_program(grippers, trajectory, job.robot)
    cell = robot_program(grippers, trajectory, ur5e_pair())
    for program in (yumi, cell):
        arms = program.cell.arms
        checked = max(r.value for r in program.checks if r.check == "joint speed")
        written = _written_speed_ratio(program, [arm.max_velocity for arm in arms])
        assert checked > 0.05
        assert abs(written - checked) <= 0.01 * checked, (written, checked)


def test_a_cell_program_failing_along_the_time_law_says_so():
    """The path passes, a joint is over its speed limit (the fast timing, not slowed): the
    program fails, and its message names the joint speed (the path's verdict alone said
    ok)."""
    _, grippers, trajectory, _ = example_plan(EXAMPLE)
    fast = _fast(grippers, trajectory.arm_clips[0], 50.0)
    plan = verify_on_cell(ur5e_pair(), fast)
    assert plan.verdict.ok, plan.verdict.message
    program = RobotProgram(plan.cell, TrackedTargets(plan, 0), plan.verdict.joints,
                           tracked_moves(plan), plan.verdict.rows).retimed(fast)
    assert not program.ok
    assert {r.check for r in program.failures} <= {"joint speed", "joint acceleration"}
    assert "cell FAILS: joint speed at shape" in program.message
    assert "cell ok" not in program.message
