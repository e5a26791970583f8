"""The one program model of every cell (dloplan.robot.program): a program slowed for its
joint speeds is exactly the program made on its slowed timing (re-timing solves nothing again),
the speed rows are those of the motion the writers sample, and a described cell's program that
fails only along the time law says so."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from robot_plans import ON_ONE_WORKER, example_plan

from dloplan.robot import robot_program
from dloplan.robot.actions import program_timeline
from dloplan.robot.program import RobotProgram
from dloplan.robot.tracked_program import TrackedTargets, tracked_moves
from dloplan.robot.urdf_cell import ur5e_pair, verify_on_cell
from dloplan.trajectory import MotionLimits, trajectory_from_grippers

pytestmark = ON_ONE_WORKER

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


def _ros_joints_at_targets(program, folder) -> list[np.ndarray]:
    """Per arm the joints [rad] the written ROS 2 joint trajectories hold at the program's
    target arrivals (every cell takes ``ros_joints``)."""
    import yaml

    from dloplan.app.writers import program_files

    files = program_files(program, folder, "ros_joints", program.trajectory)
    clock = program_timeline(program, program.trajectory, ()).clock
    joints = []
    for path in files[:2]:
        points = yaml.safe_load(path.read_text())["points"]
        stamps = np.array([p["time_from_start"]["sec"] + 1e-9 * p["time_from_start"]["nanosec"]
                           for p in points])
        at = [int(np.argmin(np.abs(stamps - t))) for t in clock.arrive]
        np.testing.assert_allclose(stamps[at], clock.arrive, atol=1e-9)
        joints.append(np.array([points[i]["positions"] for i in at]))
    return joints


def _vendor_joints(program, folder) -> list[np.ndarray]:
    """Per arm the joints [rad] at the targets read back from the cell's vendor program: the
    YuMi's RAPID (the start jointtarget, ABB axes 1-6 and eax_a = axis 7, in degrees to 1e-6,
    of the first target; the targets themselves are robtargets), a UR pair's URScript (a
    ``movej`` per target); none for a cell that takes neither (the Panda pair)."""
    import re

    from robot_plans import read_module

    from dloplan.app.writers import program_files

    if "rapid" in program.formats:
        files = program_files(program, folder, "rapid", program.trajectory)
        joints = []
        for path in files:
            start = read_module(path.read_text())["declarations"]["dlo_start"][2]
            robax, extax = np.asarray(start[0]), np.asarray(start[1])
            joints.append(np.radians(np.r_[robax[:2], extax[0], robax[2:]])[None])
        return joints
    if "urscript" not in program.formats:
        return [np.zeros((0, arm.n_joints)) for arm in program.cell.arms]
    files = program_files(program, folder, "urscript", program.trajectory)
    return [np.array([[float(v) for v in m.split(",")]
                      for m in re.findall(r"movej\(\[([^\]]*)\]", path.read_text())])
            for path in files[:2]]


@pytest.mark.parametrize("example", ["m2_uniform_curvature_usb.yaml", "cells/ur5e_pair_usb.yaml",
                                     "cells/panda_pair_ethernet.yaml"])
def test_every_cells_program_is_read_back_and_checked_by_the_one_model(tmp_path, example):
    """The seam of the one program model: whatever the cell (the YuMi's plug-in, a URDF pair's),
    the program is a RobotProgram whose ``joints`` are per arm (M, n_arm) [rad]; the joints its
    files hold (ROS 2 for every cell, RAPID's start or URScript's ``movej`` s) read back to
    exactly those, its record (plan.json) holds them, and the same model checks them: the
    forward kinematics of the joints read back puts each TCP on the target the program
    records (within the IK's tolerance)."""
    from dloplan.robot.kinematics import forward

    _, grippers, trajectory, job = example_plan(example)
    program = robot_program(grippers, trajectory, job.robot)
    assert isinstance(program, RobotProgram) and program.ok, program.message
    record = program.to_dict()
    read = _ros_joints_at_targets(program, tmp_path / "ros")
    vendor = _vendor_joints(program, tmp_path / "vendor")
    for a, arm in enumerate(program.cell.arms):
        q = program.joints[a]
        assert q.shape == (program.n_targets, arm.n_joints)
        assert all(len(move) >= 2 and move.shape[1] == arm.n_joints
                   for move in program.moves[a])
        np.testing.assert_allclose(read[a], q, atol=1e-10)
        np.testing.assert_allclose(vendor[a], q[:len(vendor[a])], atol=1e-7)  # 1e-6 deg
        recorded = np.radians([t["arms"][arm.name]["joints_deg"] for t in record["targets"]])
        np.testing.assert_allclose(recorded, q, atol=1e-12)
        tcp, _ = forward(arm, read[a])
        targets = np.array([t["arms"][arm.name]["position"] for t in record["targets"]])
        assert np.abs(tcp - targets).max() < 1e-4


def test_a_program_out_of_reach_is_not_slowed_for_its_guessed_joints():
    """A program refused on reach keeps the plan's timing: its joints at the unreached poses are
    IK's closest guesses, not a motion to slow down for (slowed, an unreachable Ethernet job's
    refused plan reported a 100.6 s trajectory for the planned 2.3 s)."""
    _, grippers, trajectory, job = example_plan(EXAMPLE)
    far = replace(grippers, positions=grippers.positions + [0.0, 0.6, 0.0])
    fast = _fast(far, trajectory.arm_clips[0], 50.0)
    program = robot_program(far, fast, job.robot)
    failed = {row.check for row in program.failures}
    assert "reach" in failed and "joint speed" in failed, failed
    assert program.trajectory is fast
