"""A program's joints along its time law (dloplan.robot.motion), tested as physics.

- Velocities and accelerations are the time derivatives of the positions: central finite
  differences of the sampled motion agree to O(h^2) (tolerances from the step and the largest
  jerk); this holds across overlapping moves (a fly-by target) and across a hold for a gripper
  action (the arms at rest: zero velocity and acceleration on both sides).
- The sampled joints stay on the verified motion: exactly at every verified sub-step; between
  them the spline's TCP leaves the planned straight TCP path by a fraction of a millimetre on the
  UR5e example (FK of the sampled joints against the trajectory's TCP at the same instant).
- The ROS 2 files written from a plan carry velocities and accelerations that are the finite
  differences of their positions (parsed back).
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from program_readers import read_trajectory
from robot_plans import ON_ONE_WORKER, example_plan

from dloplan.robot.actions import action_clock, place_actions
from dloplan.robot.motion import (
    SAMPLE_GAP,
    ActionClock,
    JointMotion,
    program_samples,
    sample_times,
)
from dloplan.trajectory import GripperAction
from dloplan.trajectory.timelaw import Profile

pytestmark = ON_ONE_WORKER


def _finite_differences(times, values):
    """Second-order first derivative on a (possibly non-uniform) time grid."""
    return np.gradient(values, times, axis=0, edge_order=2)


def _motion(overlap: float = 0.0) -> JointMotion:
    rng = np.random.default_rng(3)
    q = rng.uniform(-1, 1, (4, 7))
    paths = tuple(tuple(np.linspace(q[m], q[m + 1], 9) + 0.05 * np.sin(
        np.linspace(0, 2 * np.pi, 9))[:, None] * rng.normal(size=7) for m in range(3))
                  for _ in range(2))
    laws = (Profile.jerk_limited(1.5, 8.0, 60.0), Profile.jerk_limited(2.0, 6.0, 40.0),
            Profile.jerk_limited(1.0, 5.0, 50.0))
    starts = np.zeros(3)
    for m in (1, 2):
        starts[m] = starts[m - 1] + laws[m - 1].duration - (overlap if m == 1 else 0.0)
    arrivals = np.r_[0.0, starts[1] + overlap / 2, starts[2], starts[2] + laws[2].duration]
    return JointMotion(paths, laws, starts, arrivals)


@pytest.mark.parametrize("overlap", [0.0, 0.1])
def test_velocities_and_accelerations_are_the_derivatives_of_the_positions(overlap):
    motion = _motion(overlap)
    h = 1e-4
    t = np.linspace(0.0, motion.duration, 2001)
    for a, (q, qd, qdd) in enumerate(motion.sample(t)):
        assert q.shape == (2001, 7)
        fd_v = (motion.sample(t + h, 0)[a][0] - motion.sample(t - h, 0)[a][0]) / (2 * h)
        fd_a = (motion.sample(t + h, 1)[a][1] - motion.sample(t - h, 1)[a][1]) / (2 * h)
        # O(h^2) with jerks of tens of rad/s^3 (O(h) where the jerk jumps, at a phase
        # boundary): 1e-6 of the largest velocity, 1e-2 of the largest acceleration
        assert np.abs(fd_v - qd).max() < 1e-6 * max(1.0, np.abs(qd).max())
        assert np.abs(fd_a - qdd).max() < 1e-2 * max(1.0, np.abs(qdd).max())


def test_the_motion_passes_every_verified_sub_step_and_rests_at_stops():
    motion = _motion()
    for a in range(2):
        for m, path in enumerate(motion.paths[a]):
            law = motion.profiles[m]
            s = np.linspace(0.0, 1.0, len(path))
            # the instants at which the move's parameter is s (bisection on the monotone law)
            tau = np.array([_invert(law, x) for x in s])
            q = motion.sample(motion.starts[m] + tau, 0)[a][0]
            assert np.abs(q - path).max() < 1e-9
    at_rest = motion.sample(motion.arrivals, 2)
    for _, qd, qdd in at_rest:
        assert np.abs(qd).max() < 1e-12 and np.abs(qdd).max() < 1e-9


def _invert(law: Profile, s: float) -> float:
    lo, hi = 0.0, law.duration
    if s >= 1.0:
        return hi
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if law.evaluate(np.array([mid]))[0, 0] < s else (lo, mid)
    return 0.5 * (lo + hi)


def test_gripper_actions_hold_the_arms_and_the_clock_runs_on():
    motion = _motion()
    actions = (GripperAction("grasp", 0, 0.5), GripperAction.regrasp_at(2, 0.4, 0.5),
               GripperAction("release", 3, 0.4))
    placed = place_actions(actions, np.arange(4))
    clock = action_clock(motion.arrivals, placed)
    assert isinstance(clock, ActionClock)
    assert np.allclose(clock.hold, [0.5, 0.0, 0.9, 0.4])
    assert clock.end == pytest.approx(motion.duration + 1.8)
    t = np.linspace(0.0, clock.end, 4001)
    tau = clock.motion_time(t)
    assert np.all(np.diff(tau) >= -1e-15) and tau[-1] == pytest.approx(motion.duration)
    values = program_samples(motion, clock, t)
    for q, qd, _ in values:
        fd = _finite_differences(t, q)
        assert np.abs(fd - qd).max() < 2e-3 * np.abs(qd).max()
        for m, hold in enumerate(clock.hold):
            inside = (t >= clock.arrive[m]) & (t <= clock.leave[m])
            if hold:
                assert np.ptp(q[inside], axis=0).max() < 1e-12
                assert np.abs(qd[inside]).max() < 1e-12


def test_sample_instants_increase_strictly_and_hold_every_target_instant():
    clock = ActionClock.of(np.array([0.0, 0.0100000004, 0.73, 1.25]),
                           np.array([0.5, 0.0, 0.9, 0.4]))
    times = sample_times(clock, 100.0)
    assert np.all(np.diff(times) >= SAMPLE_GAP)
    assert set(clock.arrive) <= set(times) and set(clock.leave) <= set(times)
    assert times[0] == 0.0 and times[-1] == clock.end


def _worst_tcp_gap(program, trajectory) -> float:
    """[m] the largest distance of the sampled joints' TCP (FK, 1500 instants) from the
    trajectory's TCP at the same motion time."""
    from dloplan.robot.kinematics import forward

    motion = program.joint_motion(trajectory)
    t = np.linspace(0.0, motion.duration, 1500)
    joints = motion.sample(t, 0)
    planned = trajectory.law.blend(trajectory.positions, t)[0]  # (N, 2, 3) clip points
    columns = [1, 0] if program.targets.plan.swapped else [0, 1]
    worst = 0.0
    for a, arm in enumerate(program.cell.arms):
        position, _ = forward(arm, joints[a][0])
        target = planned[:, columns[a]] + program.targets.plan.offset
        worst = max(worst, float(np.linalg.norm(position - target, axis=1).max()))
    return worst


def test_the_ur5e_samples_follow_the_planned_tcp_path():
    """FK of the sampled joints against the trajectory's TCP at the same motion time, on the
    UR5e example: the spline through the verified sub-steps stays within 0.5 mm and 0.05 deg
    of the straight TCP path between them."""
    pytest.importorskip("yourdfpy")
    from dloplan.pipeline.stages import plan_program

    _, grippers, trajectory, job = example_plan("cells/ur5e_pair_usb.yaml")
    program = plan_program(job.robot, grippers, trajectory)
    assert program.ok, program.message
    assert _worst_tcp_gap(program, trajectory) < 5e-4


def test_a_move_whose_joint_motion_leaves_the_tcp_line_gets_more_sub_steps(monkeypatch):
    """The UR5e example's job on a pair 1.2 m apart (sweep round 7): its moves of 17-19 mm got
    one sub-step each (2 cm steps), the joints ran linearly between the knots and the TCP left
    the straight line by 1.11 mm while every check passed. The path check now measures the
    motion between the sub-steps and tracks such a move again with more of them: the samples
    stay within the bound; where the refinements cannot bring a move within it, the
    continuity check fails naming the distance."""
    pytest.importorskip("yourdfpy")
    import dataclasses

    import dloplan.robot.path
    from dloplan.robot.line_deviation import LINE_TOLERANCE
    from dloplan.robot.tracked_program import tracked_program
    from dloplan.robot.urdf_cell import ur5e_pair

    _, _, trajectory, job = example_plan("cells/ur5e_pair_usb.yaml")
    wide = ur5e_pair(separation=1.2, tcp_offset=0.15, tool_radius=0.045)
    cell = dataclasses.replace(job.robot, left=wide.left, right=wide.right,
                               source=wide.source, place=False)
    # where the placement search put it (job shifted by -0.1 m in y)
    trajectory = dataclasses.replace(trajectory, positions=trajectory.positions + [0, -0.1, 0])
    program = tracked_program(cell, trajectory)
    assert program.ok, program.message
    assert _worst_tcp_gap(program, trajectory) < LINE_TOLERANCE
    assert max(len(move) for move in program.moves[1]) > 2  # a refined move: > 1 sub-step
    monkeypatch.setattr(dloplan.robot.path, "REFINEMENTS", 0)
    program = tracked_program(cell, trajectory)
    failed = [row for row in program.checks if not row.ok]
    assert failed and {row.check for row in failed} == {"continuity"}
    assert max(float(row.note.split(" by ")[1].split()[0]) for row in failed) > 1.0
    assert "the joint motion leaves the straight TCP line by" in program.message


@pytest.mark.parametrize("name", ["m2_uniform_curvature_usb.yaml", "cells/ur5e_pair_usb.yaml"])
def test_ros_trajectories_carry_consistent_velocities_and_accelerations(tmp_path, name):
    if name.startswith("cells"):
        pytest.importorskip("yourdfpy")
    from dloplan.app.writers import program_files
    from dloplan.pipeline.stages import default_cycle, plan_program

    _, grippers, trajectory, job = example_plan(name)
    program = plan_program(job.robot, grippers, trajectory)
    actions = default_cycle(trajectory, {"grasp": job.motion.grasp_time,
                                         "release": job.motion.release_time}).actions
    files = program_files(program, tmp_path, "ros_joints", trajectory, actions)
    for path in files[:2]:
        times, fields = read_trajectory(path)
        q, v, acc = fields["positions"], fields["velocities"], fields["accelerations"]
        assert np.all(np.diff(times) > 0)
        assert times[-1] > trajectory.duration  # the gripper waits are in the clock
        # central differences on the written grid (h <= 10 ms) against the written values,
        # within the Taylor bounds of a motion whose jerk j is bounded (piecewise continuous:
        # the law's phases, the spline's pieces): |dq/dt - fd| <= j h^2 / 6 and, the
        # acceleration only Lipschitz, |d2q/dt2 - fd| <= j h / 2 (twice that as margin), with
        # j the largest jerk the written accelerations show
        h = np.diff(times).max()
        jerk = np.abs(np.diff(acc, axis=0) / np.diff(times)[:, None]).max()
        inner = slice(1, -1)
        fd_v = _finite_differences(times, q)
        fd_a = _finite_differences(times, v)
        assert np.abs(fd_v - v)[inner].max() <= 2 * jerk * h**2 / 6
        assert np.abs(fd_a - acc)[inner].max() <= 2 * jerk * h / 2
        # and not trivially: the motion moves, the bound is well below its velocities
        assert jerk * h**2 < 0.05 * np.abs(v).max()
        assert np.abs(v[[0, -1]]).max() == 0 and np.abs(acc[[0, -1]]).max() < 1e-9


def test_the_yumi_approach_and_retreat_take_the_same_time_in_rapid_and_ros(tmp_path):
    """Round 12: the RAPID program's approach and retreat moves were timed as their length over
    the approach speed (``\\T:=1`` for 5 cm at 0.05 m/s, the plan's target times likewise),
    the ROS trajectories of the same program by the jerk-limited law at that speed (1.14 s):
    the two programs of one plan reached the grasp 0.14 s apart. Both take the jerk-limited
    law's duration, and the targets' times are the ROS trajectories' arrivals."""
    import yaml

    from dloplan.app.writers import program_files
    from dloplan.pipeline.stages import default_cycle, plan_program

    _, grippers, trajectory, job = example_plan("m2_uniform_curvature_usb.yaml")
    program = plan_program(job.robot, grippers, trajectory)
    actions = default_cycle(trajectory, {"grasp": job.motion.grasp_time,
                                         "release": job.motion.release_time}).actions
    files = program_files(program, tmp_path / "ros", "ros_joints", trajectory, actions)
    rapid = program_files(program, tmp_path / "rapid", "rapid", trajectory, actions)
    moves = re.findall(r"MoveL (\w+) \\ID:=\d+, \w+ \\T:=([0-9.]+)",
                       rapid[0].read_text(encoding="utf-8"))
    labels = dict(re.findall(r"CONST robtarget (\w+) := .*?!\s*(.+)$",
                             rapid[0].read_text(encoding="utf-8"), re.M))
    seconds = {labels[name]: float(t) for name, t in moves}
    rows = yaml.safe_load(files[-1].read_text(encoding="utf-8"))["actions"]
    grasp = next(r for r in rows if r["action"] == "grasp")
    release = next(r for r in rows if r["action"] == "release")
    times, _ = read_trajectory(files[0])
    # the move to shape 0 is the approach; the ROS clock reaches shape 0 at the grasp command
    assert seconds["shape 0"] == pytest.approx(grasp["time"], abs=1e-4)
    assert seconds["retreat"] == pytest.approx(
        times[-1] - release["time"] - release["duration"], abs=1e-4)
    target_times = [t["time"] for t in program.to_dict()["targets"]]
    assert target_times[1] == pytest.approx(grasp["time"], abs=1e-9)
