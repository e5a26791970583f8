"""Segment-segment distance against closed forms and brute force; arm-arm capsule clearance."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from dloplan.robot import arm_clearance, capsules, forward, inverse, segment_distance, yumi


def test_parallel_segments():
    # two parallel unit segments 0.3 apart, overlapping along their length: distance 0.3
    d = segment_distance([0, 0, 0], [1, 0, 0], [0.5, 0.3, 0], [1.5, 0.3, 0])
    np.testing.assert_allclose(d, 0.3, atol=1e-15)
    # parallel and collinear with a gap of 0.25 between the ends
    d = segment_distance([0, 0, 0], [1, 0, 0], [1.25, 0, 0], [2, 0, 0])
    np.testing.assert_allclose(d, 0.25, atol=1e-15)
    # parallel, offset along the line past the end: end-to-end distance sqrt(0.5^2 + 0.3^2)
    d = segment_distance([0, 0, 0], [1, 0, 0], [1.5, 0.3, 0], [2.5, 0.3, 0])
    np.testing.assert_allclose(d, np.hypot(0.5, 0.3), atol=1e-15)


def test_skew_and_crossing_segments():
    # perpendicular segments crossing (in projection) at a height h: distance h
    d = segment_distance([-1, 0, 0], [1, 0, 0], [0.2, -1, 0.4], [0.2, 1, 0.4])
    np.testing.assert_allclose(d, 0.4, atol=1e-15)
    # intersecting segments: 0
    np.testing.assert_allclose(segment_distance([-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0]),
                               0.0, atol=1e-15)
    # perpendicular, the second beyond the first's end: closest points are (1,0,0), (2,0,0.5)
    d = segment_distance([-1, 0, 0], [1, 0, 0], [2, -1, 0.5], [2, 1, 0.5])
    np.testing.assert_allclose(d, np.hypot(1.0, 0.5), atol=1e-15)


def test_degenerate_segments_are_points():
    np.testing.assert_allclose(segment_distance([0, 0, 0], [0, 0, 0], [3, 4, 0], [3, 4, 0]), 5.0)
    # point to segment: perpendicular foot inside, and beyond the end
    np.testing.assert_allclose(segment_distance([0.5, 2, 0], [0.5, 2, 0], [0, 0, 0], [1, 0, 0]),
                               2.0)
    np.testing.assert_allclose(segment_distance([0, 0, 0], [1, 0, 0], [3, 0, 4], [3, 0, 4]),
                               np.hypot(2, 4))


def test_random_segments_against_brute_force():
    # The closed form is the minimum: never above a dense sampling of both segments, and
    # within the sampling resolution (1/400 of a segment, < 0.01 for these sizes) of it.
    rng = np.random.default_rng(7)
    p0, p1, q0, q1 = rng.normal(size=(4, 50, 3))
    exact = segment_distance(p0, p1, q0, q1)
    s = np.linspace(0, 1, 401)[:, None, None]
    a = p0 + s * (p1 - p0)  # (401, 50, 3)
    b = q0 + s * (q1 - q0)
    brute = np.linalg.norm(a[:, None] - b[None, :], axis=-1).min(axis=(0, 1))
    assert np.all(exact <= brute + 1e-12)
    np.testing.assert_allclose(exact, brute, atol=0.01)
    # symmetric in its arguments
    np.testing.assert_allclose(segment_distance(q0, q1, p0, p1), exact, atol=1e-12)


def test_capsules_enclose_link_origins_and_follow_fk():
    robot = yumi()
    arm = robot.right
    q = arm.home
    ends, radii, links = capsules(arm, q)
    assert ends.shape == (8, 2, 3) and radii.shape == (8,)
    assert links.tolist() == [0, 1, 2, 3, 4, 5, 6, 6]  # links 1..7, the gripper on link 7
    # the gripper capsule ends within its radius of the flange axis, below the TCP
    p_tcp, r_tcp = forward(arm, q)
    axis_dist = segment_distance(ends[7, 0], ends[7, 1], p_tcp, p_tcp)
    assert axis_dist > 0.0 and axis_dist < 0.05


def test_arm_clearance_home_is_free_and_touching_tcps_collide():
    robot = yumi()
    gap, pair = arm_clearance(robot.left, robot.left.home, robot.right, robot.right.home)
    # home: grippers 0.3 m apart; the closest capsules are the shoulders (link 1), whose
    # mounts are 0.145 m apart
    assert 0.0 < gap < 0.1
    assert tuple(pair) == (0, 0)
    # both TCPs driven to the same point in front of the robot: the grippers overlap
    target = np.array([0.4, 0.0, 0.2])
    down = forward(robot.right, robot.right.home)[1]
    res_l = inverse(robot.left, target, down)
    res_r = inverse(robot.right, target, down)
    assert res_l.success and res_r.success
    q_l, q_r = res_l.q, res_r.q
    gap, pair = arm_clearance(robot.left, q_l, robot.right, q_r)
    assert gap < -0.05
    # same TCP pose: the same wrist/gripper capsules of both arms coincide and overlap most
    assert pair[0] == pair[1] and pair[0] >= 5


def test_tcps_closer_than_the_grippers_depths_collide_whatever_the_joints():
    """``CellArm.tcp_depth``: a ball of that radius about the TCP lies inside the gripper's
    capsule, so two arms whose TCPs are closer than the sum of their depths overlap at any
    joints (random postures of both arms, the right arm's base moved to put its TCP there);
    at the YuMi that is 45 mm, so a 3 cm cable cannot be held by both grippers."""
    robot = yumi()
    left, right = robot.left, robot.right
    least = left.tcp_depth + right.tcp_depth
    assert 0.044 < least < 0.046 and left.tcp_depth == right.tcp_depth
    rng = np.random.default_rng(7)
    for _ in range(40):
        q_l = rng.uniform(left.description.lower, left.description.upper)
        q_r = rng.uniform(right.description.lower, right.description.upper)
        direction = rng.normal(size=3)
        wanted = forward(left, q_l)[0] + 0.99 * least * direction / np.linalg.norm(direction)
        moved = replace(right, base_position=right.base_position + wanted
                        - forward(right, q_r)[0])
        assert np.linalg.norm(forward(moved, q_r)[0] - forward(left, q_l)[0]) < least
        assert arm_clearance(left, q_l, moved, q_r)[0] < 0.0
    # a tool capsule from the flange to the TCP (a described cell's tool_radius): its radius
    assert replace(right, tool_radius=0.2).tcp_depth == 0.2
