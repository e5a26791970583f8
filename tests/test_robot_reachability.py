"""Path reachability of a cable job by both YuMi arms, and the placement search."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dloplan.frames import frame_from_axis
from dloplan.robot import (
    ReachOptions,
    check_path,
    check_reachability,
    forward,
    search_placement,
    tcp_poses_from_clips,
    yumi,
)

ROBOT = yumi()


def _cable_job(n_shapes=8):
    """Clip poses of a 0.5 m cable lying across the table 0.38 m in front of the robot,
    lifted by 0.1 m and bent while the clips close in (clip 0 on the robot's right)."""
    pos = np.zeros((n_shapes, 2, 3))
    u = np.zeros((n_shapes, 2, 3))
    for k, t in enumerate(np.linspace(0.0, 1.0, n_shapes)):
        half = 0.2 - 0.05 * t
        pos[k, 0] = [0.38 + 0.05 * t, -half, 0.05 + 0.1 * t]
        pos[k, 1] = [0.38 + 0.05 * t, half, 0.05 + 0.1 * t]
        angle = 0.6 * t
        u[k, 0] = [np.sin(angle), np.cos(angle), 0.0]  # inward, toward +y
        u[k, 1] = [np.sin(angle), -np.cos(angle), 0.0]
    rot = frame_from_axis(u.reshape(-1, 3))
    return pos, Rotation.from_quat(rot.as_quat().reshape(n_shapes, 2, 4))


def _assert_within_limits(result):
    for a, arm in enumerate(ROBOT.arms):
        assert np.all(result.q[:, a] >= arm.lower) and np.all(result.q[:, a] <= arm.upper)


def test_cable_job_in_front_of_robot_is_reachable():
    pos, rot = _cable_job()
    result = check_reachability(pos, rot)
    assert result.success, result.messages
    assert result.reachable.all() and result.continuous.all()
    assert result.clip_of_arm == (1, 0)  # clip 1 is on the robot's left (+y)
    assert result.min_clearance > 0.0
    _assert_within_limits(result)
    # the joint values reproduce the TCP targets (tolerance of the IK: 1e-5 m, 1e-5 rad)
    tcp_pos, tcp_rot = tcp_poses_from_clips(
        ROBOT, pos[:, [1, 0]], Rotation.from_matrix(rot.as_matrix()[:, [1, 0]]))
    turn = Rotation.from_rotvec([0, 0, np.pi])
    for a, arm in enumerate(ROBOT.arms):
        p, r = forward(arm, result.q[:, a])
        target = Rotation.from_matrix(tcp_rot.as_matrix()[:, a])
        target = target * turn if result.grip_turned[a] else target
        np.testing.assert_allclose(p, tcp_pos[:, a], atol=2e-5)
        assert np.all((r * target.inv()).magnitude() < 2e-5)
    # continuous joint motion: between neighbouring shapes (2.5 cm, 5 deg apart) no joint
    # moves by more than 0.5 rad
    assert np.abs(np.diff(result.q, axis=0)).max() < 0.5


def test_out_of_reach_pose_names_arm_and_pose():
    pos, rot = _cable_job()
    pos = pos.copy()
    pos[5, 0] += [0.5, 0.0, 0.0]  # clip 0 (right arm) of shape 5 pulled 0.5 m away
    result = check_reachability(pos, rot)
    assert not result.success
    assert not result.reachable[5, 1] and result.reachable[:, 0].all()
    assert np.delete(result.reachable[:, 1], 5).all()
    assert any(m.startswith("right arm, pose 5: not reachable") for m in result.messages)
    _assert_within_limits(result)


def test_check_path_follows_tcp_targets_and_flags_a_lost_motion():
    # TCP targets straight from FK of a joint path: reachable and continuous.
    q_path = np.linspace(ROBOT.left.home, ROBOT.left.home + [0.3, 0.2, 0.2, 0.2, 0.3, 0.3, 0.3],
                         5)
    q_right = np.linspace(ROBOT.right.home, ROBOT.right.home - 0.2, 5)
    p_l, r_l = forward(ROBOT.left, q_path)
    p_r, r_r = forward(ROBOT.right, q_right)
    pos = np.stack([p_l, p_r], axis=1)
    rot = Rotation.from_matrix(np.stack([r_l.as_matrix(), r_r.as_matrix()], axis=1))
    result = check_path(ROBOT, pos, rot, seeds=np.stack([q_path[0], q_right[0]]))
    assert result.reachable.all() and result.continuous.all(), result.messages
    # redundancy: the elbow may settle elsewhere, but the TCP is where the targets put it
    np.testing.assert_allclose(forward(ROBOT.left, result.q[:, 0])[0], p_l, atol=2e-5)
    # a target 1 m away in the middle: that pose is unreachable, the rest not affected
    pos = pos.copy()
    pos[2, 0] += [1.0, 0.0, 0.0]
    result = check_path(ROBOT, pos, rot, seeds=np.stack([q_path[0], q_right[0]]))
    assert not result.reachable[2, 0] and result.reachable[[0, 1, 3, 4], 0].all()
    assert any(m.startswith("left arm, pose 2: not reachable") for m in result.messages)


def test_placement_search_repairs_a_misplaced_job():
    pos, rot = _cable_job(n_shapes=5)
    misplaced = pos + [0.3, 0.15, 0.0]
    assert not check_reachability(misplaced, rot).success
    placement = search_placement(misplaced, rot, extent=(0.35, 0.35, 0.0), step=0.05)
    assert placement.success, placement.message
    assert placement.reachability.success
    # applying the offset makes the job reachable
    again = check_reachability(misplaced, rot, offset=placement.offset)
    assert again.success
    assert placement.offset[2] == 0.0
    assert np.linalg.norm(placement.offset) <= np.linalg.norm([0.35, 0.35])


def test_verdict_only_check_gives_the_complete_checks_verdict():
    # offsets on a grid around the reachable job: some pass, some lose a pose or a motion (far
    # out, behind, low), some collide (clips pushed together); the verdict-only check stops at
    # the first failure but must agree with the complete check on every one, and on a pass it
    # is the complete check (same rows, same grips, same clearance)
    pos, rot = _cable_job(n_shapes=5)
    quick = ReachOptions(verdict_only=True)
    squeezed = pos.copy()
    squeezed[:, 0, 1] += 0.15
    squeezed[:, 1, 1] -= 0.15
    verdicts = []
    for job in (pos, squeezed):
        for offset in ([0, 0, 0], [0.25, 0, 0], [0.45, 0.2, 0], [-0.3, 0, 0], [0, 0.3, -0.2],
                       [0.1, -0.1, 0.1]):
            full = check_reachability(job, rot, offset=offset)
            fast = check_reachability(job, rot, offset=offset, options=quick)
            assert fast.success == full.success, (offset, full.message, fast.message)
            verdicts.append(full.success)
            if full.success:
                np.testing.assert_array_equal(fast.q, full.q)
                np.testing.assert_array_equal(fast.clearance, full.clearance)
                assert fast.grip_turned == full.grip_turned
            else:  # the failure found first (its grip may differ from the complete check's)
                assert fast.messages
    assert any(verdicts) and not all(verdicts)  # both verdicts were exercised
    # the search with verdict-only checks lands on the same offset
    misplaced = pos + [0.3, 0.15, 0.0]
    a = search_placement(misplaced, rot, extent=(0.35, 0.35, 0.0), step=0.05)
    b = search_placement(misplaced, rot, extent=(0.35, 0.35, 0.0), step=0.05, options=quick)
    assert a.success and b.success
    np.testing.assert_array_equal(a.offset, b.offset)
    assert a.candidates == b.candidates


def test_bad_inputs_raise_value_error():
    pos, rot = _cable_job(3)
    with pytest.raises(ValueError, match="gripper_positions"):
        check_reachability(pos[:, 0], rot)
    with pytest.raises(ValueError, match="gripper_rotations"):
        check_reachability(pos, rot[:2])
    with pytest.raises(ValueError, match="assignment"):
        check_reachability(pos, rot, assignment="both")
    with pytest.raises(ValueError, match="offset"):
        check_reachability(pos, rot, offset=(0.1, 0.2))
    with pytest.raises(ValueError, match="step"):
        search_placement(pos, rot, step=0.0)
    with pytest.raises(ValueError, match="step_length"):
        ReachOptions(step_length=-1.0)


def test_reach_rows_and_the_placement_see_the_robot_where_the_cell_places_it():
    # The same job seen from a YuMi turned 90 deg and standing elsewhere (on a table 0.1 m
    # down) is the same job for the robot: the rows of the placed cell on the placed path
    # equal those of the robot at the origin on the path itself (the rows once checked a
    # default YuMi at the origin, whatever the cell said).
    from dloplan.grippers import GripperPath
    from dloplan.robot import RobotCell
    from dloplan.robot.plugins import placement_message, reach_rows

    pos, rot = _cable_job(5)
    quats = rot.as_quat()
    rots = tuple(Rotation.from_quat(quats[:, c]) for c in range(2))
    here = GripperPath(pos, rots, "minimal", np.zeros(len(pos)))
    turn, shift = Rotation.from_euler("z", 90, degrees=True), np.array([0.3, -0.2, 0.1])
    there = GripperPath(turn.apply(pos.reshape(-1, 3)).reshape(pos.shape) + shift,
                        tuple(turn * r for r in rots), "minimal", np.zeros(len(pos)))
    placed = RobotCell(base_position=shift, base_rotation=turn)
    expected = reach_rows(RobotCell(), here)
    assert all(r["reachable_left"] and r["reachable_right"] for r in expected)
    got = reach_rows(placed, there)
    assert [(r["reachable_left"], r["reachable_right"]) for r in got] == \
        [(r["reachable_left"], r["reachable_right"]) for r in expected]
    np.testing.assert_allclose([r["joint_margin"] for r in got],
                               [r["joint_margin"] for r in expected], atol=1e-6)
    assert placement_message(placed, there, None) == placement_message(RobotCell(), here, None)


def test_ik_at_targets_reaches_what_forward_kinematics_put_there():
    """The one IK-at-targets loop (the YuMi's pre-check, a described cell's placement score):
    targets made by forward kinematics of a smooth joint path are reached, each solution puts
    the TCP on its target; a target out of reach is missed, and with ``stop`` so is every
    target after it, while without it the loop goes on (seeded from the last reached target,
    or from the miss's closest try)."""
    from dloplan.robot import IKOptions, forward, yumi
    from dloplan.robot.reachability import ik_at_targets

    arm = yumi().left
    path = arm.home + np.linspace(0.0, 0.3, 6)[:, None] * np.sin(np.arange(arm.n_joints) + 1.0)
    pos, rot = forward(arm, path)
    mats = rot.as_matrix()
    q, hits = ik_at_targets(arm, pos, mats, IKOptions())
    assert hits.all()
    reached, _ = forward(arm, q)
    assert np.abs(reached - pos).max() < 2e-5  # the IK's tolerance, 1e-5 m
    far = pos.copy()
    far[2] += [5.0, 0.0, 0.0]  # 5 m away: beyond the arm's reach
    for stop, expected in ((True, [1, 1, 0, 0, 0, 0]), (False, [1, 1, 0, 1, 1, 1])):
        for seed_from_miss in (False, True):
            _, hits = ik_at_targets(arm, far, mats, IKOptions(), stop=stop,
                                    seed_from_miss=seed_from_miss)
            assert hits.tolist() == [bool(e) for e in expected], (stop, seed_from_miss)


def test_the_search_pre_checks_grips_made_once_answer_as_each_translation_solved_afresh():
    """A placement search asks IK at the targets about many translations of one path; its
    grips (the TCP orientations, each arm's grip and the grip turned by pi, as ``ik_at_targets``
    solves them) are made once (``TargetGrips``): every translation's answer, with and without
    ``stop``, is that of its own TCP poses (``tcp_poses_from_clips``) solved afresh, the better
    grip per arm."""
    from dataclasses import replace

    from dloplan.robot.path import TURN_Z
    from dloplan.robot.reachability import TargetGrips, ik_at_targets

    pos, rot = _cable_job(5)
    pos, rot = pos[:, [1, 0]], Rotation.from_matrix(rot.as_matrix()[:, [1, 0]])
    options = ReachOptions()
    grips = TargetGrips(ROBOT, rot, options)
    quick = replace(options.ik, restarts=0)
    answers = set()
    for offset in ([0.0, 0.0, 0.0], [0.2, 0.0, 0.0], [0.3, 0.0, 0.2], [0.0, 0.0, 0.45]):
        moved = pos + offset
        tcp_pos, tcp_rot = tcp_poses_from_clips(ROBOT, moved, rot)
        for stop in (False, True):
            afresh = np.zeros((len(pos), 2), dtype=bool)
            for a, arm in enumerate(ROBOT.arms):
                tries = [ik_at_targets(arm, tcp_pos[:, a], m[:, a], quick, stop=stop)[1]
                         for m in (tcp_rot.as_matrix(), tcp_rot.as_matrix() @ TURN_Z)]
                afresh[:, a] = tries[0] if tries[0].all() or tries[0].sum() >= tries[1].sum() \
                    else tries[1]
                if stop and not afresh[:, a].all():
                    break
            got = grips.reached(moved, stop=stop)
            assert got.tolist() == afresh.tolist(), (offset, stop)
            answers.add(bool(got.all()))
    assert answers == {True, False}  # reached at some translations, not at others
