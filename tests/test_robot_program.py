"""The robot program: arm assignment from the geometry, verified targets, and checks that fail
when they should (crossed clips, colliding wrists, a wrist asked to turn too far)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from robot_plans import ON_ONE_WORKER, PLAN_EXAMPLES, example_plan, harness_plan, mirrored
from scipy.spatial.transform import Rotation

from dloplan.frames import frame_from_axis
from dloplan.grippers import GripperPath
from dloplan.robot import (
    CHECKS,
    IKOptions,
    RobotCell,
    Tool,
    arm_angle,
    assign_arms,
    confdata,
    forward,
    inverse,
    robot_program,
    solve_many,
    yumi,
)
from dloplan.trajectory import trajectory_from_grippers

pytestmark = ON_ONE_WORKER

RUNNABLE = ("m1_sine_pu_hose.yaml", "m2_uniform_curvature_pa12.yaml",
            "m2_uniform_curvature_usb.yaml")
"""Examples whose program passes every check (the others are named in test_examples...)."""


def _program(name, cell=None):
    _, grippers, trajectory, _ = example_plan(name)
    return robot_program(grippers, trajectory, cell)


@pytest.mark.parametrize("name", PLAN_EXAMPLES)
def test_every_example_puts_the_left_arm_on_the_left(name):
    program = _program(name)
    y = program.cell.to_base(program.targets.positions)[..., 1].mean(axis=0)
    assert y[0] >= y[1]  # the left arm's targets on the robot's +y side
    assert set(CHECKS) == {row.check for row in program.checks}
    json.dumps(program.to_dict())  # the plan document can carry it
    if name in RUNNABLE:
        assert program.ok, program.message
        assert min(r.value for r in program.checks if r.check == "clearance") > 0
        assert y[0] - y[1] > 0.3
    else:  # a plan the robot cannot run says where (the target's label) and why
        assert not program.ok
        assert program.message.startswith("robot program FAILS: ")
        assert any(r.label in program.message for r in program.failures)


def test_a_mirrored_job_swaps_the_arms():
    _, grippers, trajectory, _ = example_plan("m2_uniform_curvature_usb.yaml")
    program = robot_program(grippers, trajectory)
    flipped = mirrored(grippers)
    other = robot_program(flipped, trajectory_from_grippers(
        flipped, max_speed=trajectory.max_speed, max_angular_speed=trajectory.max_angular_speed))
    assert other.targets.assignment.left_clip == 1 - program.targets.assignment.left_clip
    assert other.ok, other.message
    assert np.all(other.targets.positions[:, 0, 1] > other.targets.positions[:, 1, 1])
    # the same job mirrored: the same timing, targets mirrored arm for arm
    assert np.allclose(other.times, program.times)
    assert np.allclose(other.targets.positions[:, ::-1] * [1, -1, 1],
                       program.targets.positions, atol=1e-8)


def _still_path(positions, rotations):
    k = len(positions)
    return GripperPath(positions, rotations, "minimal", np.zeros(k))


def _flat_frames(k, clip0_turns=None):
    frames = frame_from_axis(np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]))
    first = Rotation.from_quat(np.tile(frames[0].as_quat(), (k, 1)))
    if clip0_turns is not None:
        first = Rotation.from_rotvec(np.outer(clip0_turns, [0.0, 0.0, 1.0])) * first
    return first, Rotation.from_quat(np.tile(frames[1].as_quat(), (k, 1)))


def test_clips_that_cross_are_refused_with_the_shapes_named():
    k = 6
    angle = np.linspace(0.0, np.pi, k)  # a 0.4 m cable turned end for end about the vertical
    half = 0.2 * np.stack([np.sin(angle), -np.cos(angle), 0 * angle], axis=1)
    pos = np.stack([[0.4, 0.0, 0.15] + half, [0.4, 0.0, 0.15] - half], axis=1)
    u = (pos[:, 1] - pos[:, 0]) / 0.4
    quats = frame_from_axis(np.concatenate([u, -u])).as_quat().reshape(2, k, 4)
    grippers = _still_path(pos, (Rotation.from_quat(quats[0]), Rotation.from_quat(quats[1])))
    assignment = assign_arms(grippers.positions, RobotCell())
    assert assignment.crossings == (3, 4, 5) and not assignment.ok
    program = robot_program(grippers, trajectory_from_grippers(grippers))
    assert not program.ok
    assert "assignment at shape 3" in program.message
    failed = [r.shape for r in program.failures if r.check == "assignment"]
    assert failed == [3, 4, 5]


def test_clips_too_close_for_two_wrists_fail_the_clearance():
    k = 4
    pos = np.zeros((k, 2, 3))
    pos[:, 0], pos[:, 1] = [0.4, -0.03, 0.15], [0.4, 0.03, 0.15]
    grippers = _still_path(pos, _flat_frames(k))
    program = robot_program(grippers, trajectory_from_grippers(grippers))
    rows = [r for r in program.checks if r.check == "clearance"]
    assert not any(r.ok for r in rows) and max(r.value for r in rows) < 0
    assert "clearance at approach" in program.message


def test_a_wrist_turned_too_far_fails_the_continuity():
    k = 6  # the right arm's clip turned 150 deg about the vertical per shape: 750 deg in all
    pos = np.zeros((k, 2, 3))
    pos[:, 0], pos[:, 1] = [0.4, -0.2, 0.15], [0.4, 0.2, 0.15]
    grippers = _still_path(pos, _flat_frames(k, np.radians(150.0) * np.arange(k)))
    program = robot_program(grippers, trajectory_from_grippers(grippers))
    assert not program.ok
    bad = [r for r in program.failures if r.check in ("continuity", "reach")]
    assert bad and all(r.arm == "right" for r in bad)


def test_the_program_holds_exactly_its_verified_targets():
    program = _program("m2_uniform_curvature_usb.yaml")
    written = program.targets  # the YuMi's plug-in: what RAPID is given
    for a, arm in enumerate(program.cell.arms):
        q = program.joints[a]  # (M, 7) [rad], physical order
        assert q.shape == (program.n_targets, 7)
        p, r = forward(arm, q)
        assert np.abs(p - written.positions[:, a]).max() < 2e-5  # IK tolerance 1e-5 m
        quat = Rotation.from_quat(written.quaternions[:, a], scalar_first=True)
        assert (quat.inv() * r).magnitude().max() < 2e-5
        # eax_a is the joints' arm angle (the controller's), not axis 7 (as before RobotWare 6)
        assert np.allclose(np.degrees(arm_angle(arm, q)), written.arm_angles[:, a], atol=1e-4)
        assert not np.allclose(np.degrees(q[:, 2]), written.arm_angles[:, a], atol=1.0)
        assert np.array_equal(confdata(q), written.confdata[:, a])
        # the replayed motion starts and ends on the verified joints, each move too
        assert np.allclose(written.motion_joints[0, a], q[0])
        assert np.allclose(written.motion_joints[-1, a], q[-1], atol=1e-3)
        for m, move in enumerate(program.moves[a]):
            np.testing.assert_array_equal(move[[0, -1]], q[[m, m + 1]])
    # the shapes' targets are the clip points (TCP on the clip), times the trajectory's
    _, grippers, trajectory, _ = example_plan("m2_uniform_curvature_usb.yaml")
    clips = grippers.positions[:, list(written.assignment.clips)]
    assert np.abs(written.positions[written.grasp:written.release + 1] - clips).max() < 1e-9
    assert written.path_duration == pytest.approx(trajectory.duration, rel=1e-12)
    # approach and retreat: cell.approach back along the TCP z-axis
    z = Rotation.from_quat(written.quaternions[0], scalar_first=True).apply([0, 0, 1])
    assert np.allclose(written.positions[0] + 0.05 * z, written.positions[1], atol=1e-8)
    assert np.all(np.diff(written.motion_times) >= 0)


def test_a_cell_without_approach_grasps_at_the_first_shape():
    """``robot: {approach: 0}`` (round 9: an IndexError, the moves' segments a float array):
    no approach or retreat target, the grasp at shape 0, the release at the last shape, every
    move a trajectory segment, and the program slowed and timed as with an approach."""
    _, grippers, trajectory, _ = example_plan("m2_uniform_curvature_usb.yaml")
    program = robot_program(grippers, trajectory, RobotCell(approach=0.0))
    with_approach = _program("m2_uniform_curvature_usb.yaml")
    written = program.targets
    assert program.ok, program.message
    assert written.labels == with_approach.labels[1:-1]
    assert (written.grasp, written.release) == (0, program.n_targets - 1)
    segments = written.move_segments
    assert segments.dtype.kind == "i"
    np.testing.assert_array_equal(segments, np.arange(program.n_targets - 1))
    assert written.path_duration == pytest.approx(trajectory.duration, rel=1e-12)
    assert written.times[-1] == pytest.approx(written.path_duration, rel=1e-12)
    # the shapes' targets are those of the program with an approach (its IK may choose
    # other joints: its first target is the approach pose)
    np.testing.assert_allclose(written.positions, with_approach.targets.positions[1:-1],
                               atol=1e-12)


def test_a_placed_robot_gives_the_same_joints():
    """Moving the work frame and the robot together changes nothing the robot does."""
    program = _program("m2_uniform_curvature_usb.yaml")
    shift, turn = np.array([0.3, -0.1, 0.05]), Rotation.from_euler("z", 30, degrees=True)
    _, grippers, trajectory, _ = example_plan("m2_uniform_curvature_usb.yaml")
    moved = GripperPath(turn.apply(grippers.positions.reshape(-1, 3)).reshape(-1, 2, 3) + shift,
                        tuple(turn * r for r in grippers.rotations), grippers.method,
                        grippers.twist)
    cell = RobotCell(base_position=shift, base_rotation=turn)
    other = robot_program(moved, trajectory_from_grippers(moved), cell)
    assert other.ok and other.targets.assignment.left_clip == program.targets.assignment.left_clip
    for a in range(2):
        assert np.abs(other.joints[a] - program.joints[a]).max() < 1e-6


def test_harness_job_program_passes():
    result = harness_plan()
    program = robot_program(result.grippers, result.trajectory)
    assert program.ok, program.message
    assert program.n_targets == result.trajectory.n_knots + 2


def test_held_arm_angle_ik():
    arm = yumi().left
    q = arm.home + np.array([0.3, 0.2, -0.4, 0.1, 0.5, -0.3, 0.4])
    p, r = forward(arm, q)
    psi = float(arm_angle(arm, q))
    res = inverse(arm, p, r, seed=q + 0.05, arm_angle=psi, options=IKOptions(restarts=0))
    assert res.success and abs(float(arm_angle(arm, res.q)) - psi) < 1e-5
    assert np.abs(res.q - q).max() < 1e-4  # isolated solution: the same joints back
    many, ok, perr, _ = solve_many(arm, np.stack([p, p]), np.stack([r.as_matrix()] * 2),
                                   np.stack([q + 0.05, q - 0.05]), IKOptions(), [psi, psi])
    assert ok.all() and perr.max() < 1e-5 and np.abs(many - q).max() < 1e-4
    with pytest.raises(ValueError, match="arm_angle"):
        inverse(arm, p, r, arm_angle=float("nan"))


def test_confdata_quadrants():
    q = np.radians([100.0, -20.0, 30.0, 10.0, -10.0, -5.0, 200.0])  # ABB 1, 2, 7, 3, 4, 5, 6
    # cf1: axis 1 in 90..180 -> 1; cf4: axis 4 in -90..0 -> -1; cf6: 200 deg -> 2;
    # cfx: axis 2 < 0 (4) + axis 3 > 0 (0) + axis 5 < 0 (1) = 5
    assert confdata(q).tolist() == [1, -1, 2, 5]
    assert confdata(yumi().left.home).tolist() == [0, 0, 0, 4]  # the usual YuMi posture


def test_cell_validation_and_defaults():
    cell = RobotCell()
    assert cell.tools[0].mass == 0.215 and "Grippers for IRB 14000" in cell.tools[0].source
    # the SmartGripper's TCP 114.2 mm along tool0, which is 7 mm along link 7 (turned by pi)
    assert np.allclose(cell.tools[0].tcp_offset, [0, 0, 0.1142])
    assert np.allclose(cell.robot.left.tcp_offset, [0, 0, 0.1212])
    placed = RobotCell(base_position=(0.1, 0.2, 0.0),
                       base_rotation=Rotation.from_euler("z", 90, degrees=True))
    pos, rot = placed.wobj_frame
    assert np.allclose(rot.apply([0.1, 0.2, 0.0]) + pos, 0.0)  # the base origin
    assert np.allclose(placed.to_base([[0.1, 0.2, 0.0]]), 0.0)
    with pytest.raises(ValueError, match="Tool.name"):
        Tool(name="tool 1")
    with pytest.raises(ValueError, match="Tool.mass"):
        Tool(mass=-1)
    with pytest.raises(ValueError, match="RobotCell.hold_force"):
        RobotCell(hold_force=30)
    with pytest.raises(ValueError, match="RobotCell.approach"):
        RobotCell(approach=-0.01)
    renamed = cell.with_names(tools=("GripperL", "GripperR"), wobj="wobjTable")
    assert [t.name for t in renamed.tools] == ["GripperL", "GripperR"]


def test_inputs_that_do_not_belong_together_are_refused():
    _, grippers, trajectory, _ = example_plan("m2_uniform_curvature_usb.yaml")
    _, other, other_trajectory, _ = example_plan("m1_sine_pu_hose.yaml")
    with pytest.raises(ValueError, match="trajectory: its knots"):
        robot_program(grippers, other_trajectory)
    with pytest.raises(ValueError, match="trajectory: expected a Trajectory"):
        robot_program(grippers, None)
    with pytest.raises(ValueError, match="cell: expected a RobotCell or a DescribedCell"):
        robot_program(grippers, trajectory, cell="yumi")


def test_the_side_rule_follows_a_turned_base():
    # One rule for every site (program, reachability's "auto", a described cell, the repair):
    # the clip on the robot's left in the robot's base frame goes to the left arm. A robot
    # turned by 180 deg about the vertical sees the plan's +y side as its right.
    from dloplan.pipeline.repair.rebuild import left_clip
    from dloplan.robot.reachability import check_reachability
    from dloplan.robot.urdf_cell import DescribedCell

    _, grippers, trajectory, _ = example_plan("m2_uniform_curvature_usb.yaml")
    plain = RobotCell()
    turned = RobotCell(base_position=(0.8, 0.0, 0.0),
                       base_rotation=Rotation.from_euler("z", 180, degrees=True))
    first = assign_arms(grippers.positions, plain).left_clip
    assert assign_arms(grippers.positions, turned).left_clip == 1 - first
    assert left_clip(grippers, turned) == 1 - first
    reach = check_reachability(grippers.positions, Rotation.from_matrix(grippers.matrices),
                               turned.robot)
    assert reach.clip_of_arm == (1 - first, first)
    arms = turned.robot.arms
    described = DescribedCell("yumi_turned", *arms, shared_base=True)
    assert assign_arms(grippers.positions, described).left_clip == 1 - first


@pytest.mark.parametrize("name", ["qualitative1_curved_pa12.yaml", "fig4_8_straight_to_bent.yaml",
                                  "m2_uniform_curvature_usb.yaml"])
def test_a_verdict_only_program_stops_at_its_first_failing_target(name):
    """``verdict_only`` (the reach repair's placements): a program that fails stops after the
    first target failing a check other than reach, untimed, its rows those of the complete
    program up to there but for its passing round trips, judged from the verified joints' own
    solutions (the same verdicts; the deviation no smaller) (qualitative-1's plan: no IK at
    the approach, nor its round trip); a
    program that passes (m2), or that tries the swapped assignment (fig4_8's plan: the arms
    collide at the approach), has every row, timed, and is the complete one once completed
    (its passing round trips enumerated)."""
    from dloplan.pipeline.repair.failures import program_failures

    _, grippers, trajectory, _ = example_plan(name)
    complete = robot_program(grippers, trajectory)
    verdict = robot_program(grippers, trajectory, verdict_only=True)
    assert verdict.ok == complete.ok
    if name != "qualitative1_curved_pa12.yaml":
        assert verdict.trajectory is complete.trajectory is not None
        assert verdict.message == complete.message
        assert verdict.completed().checks == complete.checks
        assert np.array_equal(verdict.times, complete.times)
        return
    assert verdict.trajectory is None  # untimed: never to be written
    head = complete.checks[:len(verdict.checks)]
    assert [(r.check, r.target, r.arm, r.ok) for r in verdict.checks] == [
        (r.check, r.target, r.arm, r.ok) for r in head]
    own = [r.check == "round trip" and r.ok for r in verdict.checks]
    assert any(own)  # judged from the verified joints' own solution, no enumeration
    for row, full, judged in zip(verdict.checks, head, own, strict=True):
        if judged:
            assert "own solution" in row.note and row.value >= full.value
        else:
            assert row == full
    first = program_failures(verdict)[0]
    assert first == program_failures(complete)[0]
    assert verdict.checks[-1].target == 0 and "approach" in first.message
    assert len(verdict.checks) < len(complete.checks) // 4


@pytest.mark.parametrize("name", ["qualitative1_curved_pa12.yaml",
                                  "m2_uniform_curvature_usb.yaml"])
def test_round_trips_on_demand_complete_to_the_complete_program(name):
    """``round_trips_on_demand`` (the plan's own program in ``make_plan``, which the reach
    repair replaces): a program that fails has every row and verdict of the complete program,
    the same failing rows and message, but its passing round trips judged from the verified
    joints' own solutions; ``completed()`` makes it the complete program row for row (the same
    record in the plan document). So does a program that passes (m2: its figures are started
    before it is completed)."""
    _, grippers, trajectory, _ = example_plan(name)
    complete = robot_program(grippers, trajectory)
    lazy = robot_program(grippers, trajectory, round_trips_on_demand=True)
    assert lazy.ok == complete.ok and lazy.message == complete.message
    assert lazy.failures == complete.failures
    assert [(r.check, r.target, r.arm, r.ok) for r in lazy.checks] == [
        (r.check, r.target, r.arm, r.ok) for r in complete.checks]
    assert np.array_equal(lazy.times, complete.times)
    own = [r for r in lazy.checks if "own solution" in r.note]
    assert own and all(r.check == "round trip" and r.ok for r in own)
    done = lazy.completed()
    assert done.completion is None and done.checks == complete.checks
    assert json.dumps(done.to_dict()) == json.dumps(complete.to_dict())
    assert done.completed() is done
