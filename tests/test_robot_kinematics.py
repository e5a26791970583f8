"""YuMi forward/inverse kinematics: FK against the URDF composed by hand, Jacobian against finite
differences, IK(FK(q)) round trips, joint limits, unreachable poses."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dloplan.robot import (
    IKOptions,
    forward,
    inverse,
    jacobian,
    joint_margin,
    link_frames,
    manipulability,
    yumi,
    yumi_arm,
)
from dloplan.robot.yumi import Gripper

ROBOT = yumi()

# Right arm of yumi.urdf (rtb-data 1.0.1, yumi_description), joint <origin> elements as
# written in the file, physical order, with ABB's controller data where they differ
# (docs/decisions.md, "YuMi kinematics"): the mount (joint 1) and joint 3's x and z.
URDF_RIGHT = [
    ((0.0537106, -0.0725734, 0.4150099), (-0.979068206212, -0.569210975216, -2.316178620014)),
    ((0.03, 0.0, 0.1), (1.57079632679, 0.0, 0.0)),
    ((-0.03, 0.17283, 0.0), (-1.57079632679, 0.0, 0.0)),
    ((-0.0405, 0.0, 0.07867), (1.57079632679, -1.57079632679, 0.0)),
    ((0.0405, 0.16461, 0.0), (-1.57079632679, 0.0, 0.0)),
    ((-0.027, 0.0, 0.10039), (1.57079632679, 0.0, 0.0)),
    ((0.027, 0.029, 0.0), (-1.57079632679, 0.0, 0.0)),
]


def _homogeneous(xyz, rpy):
    """URDF origin as a 4x4 matrix: R = Rz(yaw) Ry(pitch) Rx(roll), written out by hand."""
    r, p, y = rpy
    rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    t = np.eye(4)
    t[:3, :3] = rz @ ry @ rx
    t[:3, 3] = xyz
    return t


def _hand_fk(q):
    """The URDF chain composed by hand: T = prod_i Origin_i Rz(q_i), then link 7 -> tool0
    (7 mm out, turned by pi about z) -> TCP (114.2 mm along tool0's z)."""
    t = np.eye(4)
    for (xyz, rpy), qi in zip(URDF_RIGHT, q, strict=True):
        t = t @ _homogeneous(xyz, rpy) @ _homogeneous((0, 0, 0), (0, 0, qi))
    return t @ _homogeneous((0, 0, 0.007), (0, 0, np.pi)) @ _homogeneous((0, 0, 0.1142),
                                                                          (0, 0, 0))


@pytest.mark.parametrize("q", [np.zeros(7), np.array([0.3, -0.5, 1.0, -0.8, 2.0, 0.7, -1.5])])
def test_fk_matches_urdf_composed_by_hand(q):
    # Independent 4x4 composition of the URDF text; agreement to 1e-12 m (round-off).
    position, rotation = forward(ROBOT.right, q)
    t = _hand_fk(q)
    np.testing.assert_allclose(position, t[:3, 3], atol=1e-12)
    np.testing.assert_allclose(rotation.as_matrix(), t[:3, :3], atol=1e-12)


def test_fk_zero_configuration_known_values():
    # Zero configuration, right arm: shoulder (joint 1 origin) exactly at the mount, and the
    # TCP at the value of the hand composition above (0.6331, 0.0754, 0.3536) m +- 0.1 mm.
    frames = link_frames(ROBOT.right, np.zeros(7))
    np.testing.assert_allclose(frames.positions[0], [0.0537106, -0.0725734, 0.4150099],
                               atol=1e-12)
    np.testing.assert_allclose(frames.positions[7], [0.6331, 0.0754, 0.3536], atol=1e-4)
    # The TCP lies 7 + 114.2 mm from link 7 along its z-axis (tool0, then the SmartGripper's
    # tool data) and its x-axis is link 7's turned by pi (tool0's orientation).
    link_z = frames.rotations[6][:, 2]
    np.testing.assert_allclose(frames.positions[7] - frames.positions[6], 0.1212 * link_z,
                               atol=1e-12)
    np.testing.assert_allclose(frames.rotations[7][:, 0], -frames.rotations[6][:, 0],
                               atol=1e-12)


def test_arms_mirror_each_other():
    # The URDF mounts are mirror images of each other up to rounding of their rpy (a few
    # mrad), so the home TCPs mirror across the x-z plane within 2 mm.
    left, _ = forward(ROBOT.left, ROBOT.left.home)
    right, _ = forward(ROBOT.right, ROBOT.right.home)
    np.testing.assert_allclose(left * [1, -1, 1], right, atol=2e-3)


def test_base_placement_moves_everything_rigidly():
    rot = Rotation.from_euler("z", 30, degrees=True)
    moved = yumi_arm("left", base_position=(0.1, -0.2, 0.7), base_rotation=rot)
    q = np.array([0.2, -0.4, 0.5, -0.6, 0.7, 0.8, -0.9])
    p0, r0 = forward(ROBOT.left, q)
    p1, r1 = forward(moved, q)
    np.testing.assert_allclose(p1, rot.apply(p0) + [0.1, -0.2, 0.7], atol=1e-12)
    np.testing.assert_allclose((r1 * (rot * r0).inv()).magnitude(), 0.0, atol=1e-12)


def test_jacobian_matches_finite_differences():
    rng = np.random.default_rng(3)
    arm = ROBOT.left
    for _ in range(3):
        q = rng.uniform(arm.lower, arm.upper)
        jac = jacobian(arm, q)
        h = 1e-6
        p0, r0 = forward(arm, q)
        for i in range(7):
            dq = np.zeros(7)
            dq[i] = h
            p1, r1 = forward(arm, q + dq)
            np.testing.assert_allclose((p1 - p0) / h, jac[:3, i], atol=1e-5)
            np.testing.assert_allclose((r1 * r0.inv()).as_rotvec() / h, jac[3:, i], atol=1e-5)


def _round_trip(arm, rng, n, seed_noise):
    errors, successes = [], 0
    for _ in range(n):
        q = rng.uniform(arm.lower, arm.upper)
        p, r = forward(arm, q)
        seed = None if seed_noise is None else q + rng.normal(0.0, seed_noise, 7)
        opts = IKOptions(restarts=0) if seed_noise is None else IKOptions()
        res = inverse(arm, p, r, seed=seed, options=opts)
        assert np.all(res.q >= arm.lower) and np.all(res.q <= arm.upper)
        p_ik, r_ik = forward(arm, res.q)
        errors.append((np.linalg.norm(p_ik - p), np.degrees((r_ik * r.inv()).magnitude())))
        successes += res.success
    return np.array(errors), successes / n


@pytest.mark.parametrize("side", ["left", "right"])
def test_ik_reproduces_fk_from_nearby_seed(side):
    # Random joint values within the limits; seeded 0.1 rad (rms per joint) away. Every solve
    # must reproduce the TCP within 0.1 mm and 0.05 deg (issue 13).
    arm = ROBOT.left if side == "left" else ROBOT.right
    errors, rate = _round_trip(arm, np.random.default_rng(11), 40, 0.1)
    assert rate == 1.0
    assert errors[:, 0].max() < 1e-4
    assert errors[:, 1].max() < 0.05


def test_ik_success_rate_from_home_is_reported():
    # From the home pose alone (its wrist flip included, no random restarts) random poses are
    # often found on another branch or not at all: the rate is printed for the report; it is
    # far from zero and every success is exact.
    arm = ROBOT.right
    errors, rate = _round_trip(arm, np.random.default_rng(5), 30, None)
    print(f"IK success rate from the home pose: {rate:.0%}")
    assert rate > 0.3


def test_unreachable_pose_is_reported_not_raised():
    arm = ROBOT.right
    far = inverse(arm, np.array([1.2, -0.2, 0.1]), Rotation.identity())
    assert not far.success and "out of reach" in far.message
    # inside the reach bound, but pointing up from beside the body: IK fails, closest q kept
    near = inverse(arm, np.array([0.0, -0.1, 0.1]), Rotation.identity())
    assert not near.success and "not converged" in near.message
    assert near.position_error > 1e-3
    for res in (far, near):
        assert np.all(res.q >= arm.lower) and np.all(res.q <= arm.upper)


def test_ik_of_a_rotation_matrix_is_that_of_its_rotation():
    """inverse() takes the target's (3, 3) matrix as well as a scipy Rotation (the loops over
    many targets: reach_at_targets, the path check's sub-steps): the same solve bit for bit,
    given the rows of one batch Rotation's as_matrix(), which are each single Rotation's (what
    the loops rely on, checked here for scipy's from_matrix round trip and a Slerp)."""
    from scipy.spatial.transform import Slerp

    arm = ROBOT.right
    rng = np.random.default_rng(3)
    q = np.clip(arm.mid + rng.normal(0.0, 0.5, (6, 7)), arm.lower, arm.upper)
    poses = [forward(arm, qk) for qk in q]
    mats = np.stack([r.as_matrix() for _, r in poses]) + rng.normal(0.0, 1e-9, (6, 3, 3))
    batch = Rotation.from_matrix(mats).as_matrix()
    singles = [Rotation.from_matrix(m) for m in mats]
    assert np.array_equal(batch, np.stack([r.as_matrix() for r in singles]))
    sub = Slerp([0.0, 1.0], Rotation.from_matrix(mats[:2]))(np.arange(1, 9) / 8)
    assert np.array_equal(sub.as_matrix(), np.stack([sub[s].as_matrix() for s in range(8)]))
    for (p, _), m, r in zip(poses, batch, singles, strict=True):
        by_matrix = inverse(arm, p + 0.01, m, seed=arm.mid)
        by_rotation = inverse(arm, p + 0.01, r, seed=arm.mid)
        assert np.array_equal(by_matrix.q, by_rotation.q)
        assert (by_matrix.success, by_matrix.position_error, by_matrix.message) == \
            (by_rotation.success, by_rotation.position_error, by_rotation.message)


def test_substep_rotations_are_each_moves_slerp():
    """The path check's sub-step rotations of every move in one batch
    (:func:`dloplan.robot.path.substep_rotations`) are bit for bit those of a scipy Slerp per
    move (what the check made before): random poses, slightly non-orthogonal as computed
    ones are, a half turn, a move without rotation, 1 to 9 sub-steps."""
    from scipy.spatial.transform import Slerp

    from dloplan.robot.path import substep_rotations

    rng = np.random.default_rng(11)
    mats = Rotation.random(9, random_state=4).as_matrix() + rng.normal(0.0, 1e-9, (9, 3, 3))
    mats[3] = mats[2]  # no rotation
    mats[6] = mats[5] @ Rotation.from_euler("z", 180, degrees=True).as_matrix()
    counts = rng.integers(1, 10, 8)
    batch = substep_rotations(mats, counts)
    assert len(batch) == 8
    for k, n in enumerate(counts, start=1):
        slerp = Slerp([0.0, 1.0], Rotation.from_matrix(mats[k - 1:k + 1]))
        assert np.array_equal(batch[k - 1], slerp(np.arange(1, n + 1) / n).as_matrix())
    assert substep_rotations(mats[:1], counts[:0]) == []


def test_joint_margin_and_manipulability():
    arm = ROBOT.left
    q = arm.mid.copy()
    np.testing.assert_allclose(joint_margin(arm, q), np.min(arm.upper - arm.lower) / 2)
    q[3] = arm.upper[3] - 0.01
    np.testing.assert_allclose(joint_margin(arm, q), 0.01)
    # sqrt(det(J J^T)) equals the product of the Jacobian's singular values.
    q = np.array([0.2, -0.4, 0.5, -0.6, 0.7, 0.8, -0.9])
    sv = np.linalg.svd(jacobian(arm, q), compute_uv=False)
    np.testing.assert_allclose(manipulability(arm, q), np.prod(sv), rtol=1e-10)


def test_tcp_offset_is_configurable():
    q = np.array([0.2, -0.4, 0.5, -0.6, 0.7, 0.8, -0.9])
    short = yumi_arm("right", gripper=Gripper(tcp_offset=(0.0, 0.0, 0.0)))
    p_flange, r_flange = forward(short, q)
    p_tcp, _ = forward(ROBOT.right, q)  # r_flange: tool0's orientation
    np.testing.assert_allclose(p_tcp - p_flange, r_flange.apply([0, 0, 0.1142]), atol=1e-12)


def test_bad_inputs_raise_value_error():
    arm = ROBOT.left
    with pytest.raises(ValueError, match="position"):
        inverse(arm, [0.3, 0.1], Rotation.identity())
    for rotation in (np.eye(2), np.full((3, 3), np.nan), [[1, 0, 0], [0, 1, 0], [0, 0, 1]]):
        with pytest.raises(ValueError, match="rotation"):
            inverse(arm, [0.3, 0.1, 0.1], rotation)
    with pytest.raises(ValueError, match="seed"):
        inverse(arm, [0.3, 0.1, 0.1], Rotation.identity(), seed=np.zeros(6))
    with pytest.raises(ValueError, match="q"):
        forward(arm, [0.0, np.nan, 0, 0, 0, 0, 0])
    with pytest.raises(ValueError, match="side"):
        yumi_arm("middle")
    with pytest.raises(ValueError, match="max_step"):
        IKOptions(max_step=0.0)


@pytest.mark.parametrize("side", ["left", "right"])
def test_compiled_ik_is_the_numpy_reference(side):
    """The compiled solve (the IK's) and the numpy references iterate alike: from random seeds
    to reachable poses (free, the arm angle held, the polish near a limit with min_margin) and
    to poses out of reach, the same iterations and verdict; a converged solve's joints to
    1e-9 rad (round-off through a converging damped Newton iteration), a failed one's errors to
    0.1 % (100 steps pressed against the joint limits, where round-off grows)."""
    from dloplan.robot import armangle
    from dloplan.robot.kinematics import solve_from, solve_reference

    arm = getattr(yumi(), side)
    rng = np.random.default_rng(7)
    cases = 0
    for k in range(24):
        q_true = rng.uniform(arm.lower, arm.upper)
        position, rotation = forward(arm, q_true)
        target = rotation.as_matrix()
        if k % 4 == 3:
            position = position + [0.4, 0.0, 0.3]  # likely out of reach: a failed solve
        seed = np.clip(q_true + rng.normal(0.0, 0.6, 7), arm.lower, arm.upper)
        options = IKOptions(min_margin=0.3 if k % 3 == 0 else 0.0)
        held = float(armangle.arm_angle(arm, q_true)) if k % 5 == 1 else None
        mine = solve_from(arm, position, target, seed, options, held)
        q, perr, aerr, iterations, ok = (
            solve_reference(arm, position, target, seed, options) if held is None else
            armangle.solve_reference(arm, position, target, seed, options, held))
        assert (mine.iterations, mine.success) == (iterations, ok), (k, mine, perr, aerr)
        if ok:
            assert np.abs(mine.q - q).max() < 1e-9
            assert mine.position_error == pytest.approx(perr, abs=1e-12)
            assert mine.angle_error == pytest.approx(aerr, abs=1e-12)
        else:  # 100 steps against the joint limits: round-off grows, the failure is the same
            assert np.abs(mine.q - q).max() < 1e-3
            assert mine.position_error == pytest.approx(perr, rel=1e-3)
            assert mine.angle_error == pytest.approx(aerr, rel=1e-3)
        cases += ok
    assert 6 <= cases <= 22  # both verdicts were exercised


def test_compiled_rotation_log_near_pi_and_zero():
    """The compiled logarithm map equals the numpy one at 0, pi (where the skew part vanishes)
    and in between, to round-off. Called as the IK calls it (into a vector, the overload the
    warm-up compiles): a wrapper returning a new vector, for this test only, was compiled by
    the suite after the warm-up."""
    from dloplan.robot.ik_compiled import rotation_log_into
    from dloplan.robot.kinematics import rotation_log

    rng = np.random.default_rng(3)
    axes = rng.normal(size=(30, 3))
    angles = np.concatenate([[0.0, 1e-9, 1e-7, np.pi, np.pi - 1e-4, np.pi - 2e-3],
                             rng.uniform(0.0, np.pi, 24)])
    for axis, angle in zip(axes, angles, strict=True):
        m = Rotation.from_rotvec(angle * axis / np.linalg.norm(axis)).as_matrix()
        assert np.allclose(rotation_log_into(m, np.empty(3)), rotation_log(m), atol=1e-12)


def test_damped_step_is_the_levenberg_marquardt_step():
    """The hand-written Cholesky step solves the damped normal equations: it is LAPACK's
    solution to rounding (relative to the conditioning), for square and wide Jacobians, well
    and badly conditioned, and its residual ``J^T (J dq - e) + mu dq`` vanishes."""
    from dloplan.robot.ik_compiled import damped_step

    rng = np.random.default_rng(11)
    for rows, n in ((7, 7), (6, 7), (6, 6)):
        for mu in (1e-6, 1e-3, 1.0):
            for rank_drop in (0, 1):
                jac = rng.normal(size=(rows, n))
                if rank_drop:  # a singular Jacobian: only the damping keeps the step finite
                    jac[-1] = jac[0]
                err = rng.normal(size=rows)
                step = damped_step(jac, err, mu, np.empty((n, n)), np.empty(n))
                normal = jac.T @ jac + mu * np.eye(n)
                expected = np.linalg.solve(normal, jac.T @ err)
                bound = 1e-13 * np.linalg.cond(normal) * np.abs(expected).max()
                assert np.abs(step - expected).max() <= bound
                assert np.abs(normal @ step - jac.T @ err).max() <= 1e-10 * np.abs(
                    jac.T @ err).max()


def test_solve_many_is_one_reference_solve_per_problem():
    """solve_many (tracking: no null-space motion, no polish) is the reference solve of each
    problem with ``null_gain = 0``: free and with the arm angle held, converging and failing."""
    from dloplan.robot import armangle
    from dloplan.robot.kinematics import IKOptions, solve_many, solve_reference

    arm = yumi().right
    rng = np.random.default_rng(5)
    q_true = rng.uniform(arm.lower, arm.upper, (12, 7))
    positions, rotations = forward(arm, q_true)
    positions[::4] += [0.5, 0.0, 0.4]  # out of reach
    targets = rotations.as_matrix()
    seeds = np.clip(q_true + rng.normal(0.0, 0.3, q_true.shape), arm.lower, arm.upper)
    options = IKOptions()
    tracking = IKOptions(null_gain=0.0)
    for held in (None, armangle.arm_angle(arm, q_true)):
        q, ok, perr, aerr = solve_many(arm, positions, targets, seeds, options, held)
        for k in range(len(q)):
            ref = (solve_reference(arm, positions[k], targets[k], seeds[k], tracking,
                                   give_up=False)
                   if held is None else armangle.solve_reference(
                       arm, positions[k], targets[k], seeds[k], tracking, held[k],
                       give_up=False))
            assert ok[k] == ref[4]
            assert np.abs(q[k] - ref[0]).max() < (1e-9 if ref[4] else 1e-3)
            assert perr[k] == pytest.approx(ref[1], rel=1e-3, abs=1e-12)
            assert aerr[k] == pytest.approx(ref[2], rel=1e-3, abs=1e-12)
        assert 0 < ok.sum() < len(q)
