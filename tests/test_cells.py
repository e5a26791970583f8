"""Cells from robot descriptions: FK against the vendors' DH tables, the YuMi unchanged by the
move to a description, IK round trips on every cell, capsules, path verification and placement.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dloplan.robot import arm_clearance, forward, yumi
from dloplan.robot.chain import CellArm, capsules, in_base_frame
from dloplan.robot.described import pair_clearance
from dloplan.robot.description import (
    capsule_from_points,
    capsules_from_points,
    load_arm,
    vendored,
)
from dloplan.robot.kinematics import IKOptions, inverse
from dloplan.robot.kinematics import forward as chain_forward
from dloplan.robot.path import ReachOptions, check_path
from dloplan.robot.placement import search_cell_placement
from dloplan.robot.urdf_cell import (
    PRESETS,
    ArmSpec,
    cell_from_specs,
    ur5e_pair,
    yumi_cell,
)

pytest.importorskip("yourdfpy")

POSITION_TOL = 1e-4  # 0.1 mm
ANGLE_TOL = np.radians(0.05)


def program_check(cell, positions, rotations, **settings):
    """The path check with a described cell's program settings (``ReachOptions.cell_program``)."""
    return check_path(cell, positions, rotations, options=ReachOptions.cell_program(**settings))


@cache
def cell(name):
    return PRESETS[name]()


def _dh_standard(q, d, a, alpha):
    """Universal Robots' convention: T = prod Rz(q) Tz(d) Tx(a) Rx(alpha)."""
    t = np.eye(4)
    for qi, di, ai, al in zip(q, d, a, alpha, strict=True):
        c, s, ca, sa = np.cos(qi), np.sin(qi), np.cos(al), np.sin(al)
        t = t @ np.array([[c, -s * ca, s * sa, ai * c], [s, c * ca, -c * sa, ai * s],
                          [0, sa, ca, di], [0, 0, 0, 1]])
    return t


def _dh_modified(q, d, a, alpha):
    """Franka's (Craig's) convention: T = prod Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(q_i) Tz(d_i)."""
    t = np.eye(4)
    for qi, di, ai, al in zip(q, d, a, alpha, strict=True):
        c, s, ca, sa = np.cos(qi), np.sin(qi), np.cos(al), np.sin(al)
        t = t @ np.array([[c, -s, 0, ai], [s * ca, c * ca, -sa, -di * sa],
                          [s * sa, c * sa, ca, di * ca], [0, 0, 0, 1]])
    return t


# Universal Robots, "DH parameters for calculations of kinematics and dynamics", UR5e.
UR5E_D = (0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996)
UR5E_A = (0.0, -0.425, -0.3922, 0.0, 0.0, 0.0)
UR5E_ALPHA = (np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0)
# Franka Emika, "Robot and interface specifications", Denavit-Hartenberg parameters (Craig),
# then the flange d = 0.107 m.
PANDA_A = (0.0, 0.0, 0.0, 0.0825, -0.0825, 0.0, 0.088, 0.0)
PANDA_D = (0.333, 0.0, 0.316, 0.0, 0.384, 0.0, 0.0, 0.107)
PANDA_ALPHA = (0.0, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2, 0.0)


def _pose(arm, q):
    p, r = chain_forward(arm, q)
    t = np.eye(4)
    t[:3, :3], t[:3, 3] = r.as_matrix(), p
    return t


def test_ur5e_fk_equals_the_published_dh_table():
    arm = CellArm("left", load_arm(vendored("ur5e.urdf"), "tool0"))
    # Zero pose: UR's table gives the flange at (a2 + a3, -(d4 + d6), d1 - d5).
    np.testing.assert_allclose(_pose(arm, np.zeros(6))[:3, 3], [-0.8172, -0.2329, 0.0628],
                               atol=1e-12)
    rng = np.random.default_rng(3)
    for q in rng.uniform(-np.pi, np.pi, (20, 6)):
        np.testing.assert_allclose(_pose(arm, q), _dh_standard(q, UR5E_D, UR5E_A, UR5E_ALPHA),
                                   atol=1e-12)


def test_panda_fk_equals_franka_dh_parameters():
    arm = CellArm("left", load_arm(vendored("panda.urdf"), "panda_link8"))
    # Zero pose: flange at x = 0.088, z = 0.333 + 0.316 + 0.384 - 0.107, pointing down.
    zero = _pose(arm, np.zeros(7))
    np.testing.assert_allclose(zero[:3, 3], [0.088, 0.0, 0.926], atol=1e-12)
    np.testing.assert_allclose(zero[:3, :3], np.diag([1.0, -1.0, -1.0]), atol=1e-12)
    rng = np.random.default_rng(4)
    for q in rng.uniform(arm.lower, arm.upper, (20, 7)):
        expected = _dh_modified(np.append(q, 0.0), PANDA_D, PANDA_A, PANDA_ALPHA)
        np.testing.assert_allclose(_pose(arm, q), expected, atol=1e-12)


def test_panda_hand_tcp_is_franka_hand_frame():
    """panda_hand is link 8 turned by -45 deg about z; the TCP 0.1034 m further along z."""
    arm = cell("panda_pair").left
    flange = CellArm("x", load_arm(vendored("panda.urdf"), "panda_link8"),
                     base_position=arm.base_position)
    q = arm.home
    expected = _pose(flange, q) @ np.block([
        [Rotation.from_rotvec([0, 0, -np.pi / 4]).as_matrix(), np.array([[0, 0, 0.1034]]).T],
        [np.zeros((1, 3)), np.ones((1, 1))]])
    np.testing.assert_allclose(_pose(arm, q), expected, atol=1e-12)


def test_yumi_from_its_vendored_urdf_equals_robot_yumi():
    """The vendored yumi.urdf, read like any description (yourdfpy), gives the chains of
    dloplan.robot.yumi (the YuMi cell's arms): the same FK to 1e-9 and the same arm-arm
    capsule clearance (its capsules are written as cylinders of the same axes and radii)."""
    from dloplan.robot.description import load_arm, vendored

    robot, described = yumi(), yumi_cell()
    assert described.left is not None and described.shared_base
    rng = np.random.default_rng(5)
    q = {a.name: rng.uniform(a.lower, a.upper, (200, 7)) for a in robot.arms}
    loaded = []
    for old in robot.arms:
        urdf = load_arm(vendored("yumi.urdf"), f"yumi_link_7_{old.name[0]}",
                        base_link="yumi_body", name=f"yumi_{old.name}")
        new = CellArm(old.name, urdf, tcp_offset=old.tcp_offset, tcp_rotation=old.tcp_rotation,
                      home=old.home)
        loaded.append(new)
        assert new.joint_names == old.joint_names
        np.testing.assert_allclose(new.lower, old.lower, atol=0)
        np.testing.assert_allclose(new.max_velocity, old.max_velocity, atol=0)
        p0, r0 = forward(old, q[old.name])
        p1, r1 = chain_forward(new, q[old.name])
        np.testing.assert_allclose(p1, p0, atol=1e-9)
        np.testing.assert_allclose(r1.as_matrix(), r0.as_matrix(), atol=1e-9)
    expected, _ = arm_clearance(robot.left, q["left"], robot.right, q["right"])
    got, _ = arm_clearance(loaded[0], q["left"], loaded[1], q["right"], shared_base=True)
    np.testing.assert_allclose(got, expected, atol=1e-9)
    np.testing.assert_allclose(pair_clearance(described, q["left"], q["right"]), expected,
                               atol=1e-12)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_ik_of_fk_round_trips_on_every_cell(name):
    """Random joint vectors (hence reachable poses): IK from a seed 0.3 rad away reaches the
    pose within 0.1 mm / 0.05 deg; from the home pose with restarts nearly always."""
    rng = np.random.default_rng(6)
    options = IKOptions(restarts=8)
    for arm in cell(name).arms:
        q = rng.uniform(arm.lower, arm.upper, (25, arm.n_joints))
        pos, rot = chain_forward(arm, q)
        from_home = 0
        for i in range(len(q)):
            seeded = inverse(arm, pos[i], rot[i], seed=q[i] + rng.normal(0, 0.3, arm.n_joints),
                             options=options)
            assert seeded.success, seeded.message
            p, r = chain_forward(arm, seeded.q)
            assert np.linalg.norm(p - pos[i]) < POSITION_TOL
            assert (r * rot[i].inv()).magnitude() < ANGLE_TOL
            assert np.all((seeded.q >= arm.lower) & (seeded.q <= arm.upper))
            from_home += inverse(arm, pos[i], rot[i], options=options).success
        assert from_home >= 22, f"{name} {arm.name}: {from_home}/25 from home"


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_compiled_chain_ik_is_the_numpy_reference(name):
    """Every cell's compiled solve (the one solve of :mod:`dloplan.robot.kinematics`) and its
    numpy reference iterate alike, from random seeds to reachable poses and to poses out of
    reach (where the error stalls): the same iterations and verdict; a converged solve's
    joints to 1e-9 rad, a failed one's errors to 0.1 %."""
    from dloplan.robot.kinematics import solve_from, solve_reference

    rng = np.random.default_rng(8)
    options = IKOptions()
    verdicts = []
    for arm in cell(name).arms:
        q = rng.uniform(arm.lower, arm.upper, (10, arm.n_joints))
        pos, rot = chain_forward(arm, q)
        pos[::3] += [0.6, 0.0, 0.5]
        for i in range(len(q)):
            seed = np.clip(q[i] + rng.normal(0.0, 0.6, arm.n_joints), arm.lower, arm.upper)
            mine = solve_from(arm, pos[i], rot[i].as_matrix(), seed, options)
            ref = solve_reference(arm, pos[i], rot[i].as_matrix(), seed, options)
            assert (mine.iterations, mine.success) == ref[3:]
            tolerance = 1e-9 if ref[4] else 1e-3
            assert np.abs(mine.q - ref[0]).max() < tolerance
            assert mine.position_error == pytest.approx(ref[1], rel=1e-3, abs=1e-12)
            assert mine.angle_error == pytest.approx(ref[2], rel=1e-3, abs=1e-12)
            verdicts.append(ref[4])
    assert any(verdicts) and not all(verdicts)


def test_ik_out_of_reach_is_reported_not_raised():
    arm = cell("ur5e_pair").left
    result = inverse(arm, arm.shoulder + [2.0, 0.0, 0.0], Rotation.identity())
    assert not result.success and "out of reach" in result.message


def test_capsule_from_points_encloses_and_is_tight_for_a_cylinder():
    rng = np.random.default_rng(8)
    # Points on a cylinder of radius 0.05 about an inclined axis from a to b.
    a, b = np.array([0.1, -0.2, 0.3]), np.array([0.3, 0.1, 0.2])
    axis = (b - a) / np.linalg.norm(b - a)
    u = np.cross(axis, [0, 0, 1.0])
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    # A regular grid on the surface (random samples would tilt the principal axis).
    t, phi = (g.ravel() for g in np.meshgrid(np.linspace(0, 1, 41),
                                             np.linspace(0, 2 * np.pi, 64, endpoint=False)))
    pts = a + t[:, None] * (b - a) + 0.05 * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v)
    p0, p1, r = capsule_from_points(pts)
    assert r == pytest.approx(0.05, abs=1e-3)
    assert abs(abs((p1 - p0) @ axis) - np.linalg.norm(b - a)) < 0.01
    blob = rng.normal(0, 0.1, (500, 3)) * [1.0, 0.3, 0.2]
    for caps in ([capsule_from_points(blob)], capsules_from_points(blob)):
        dist = np.min([_point_segment(blob, q0, q1) - radius for q0, q1, radius in caps], axis=0)
        assert np.all(dist <= 1e-12)


def _point_segment(points, p0, p1):
    d = p1 - p0
    s = np.clip((points - p0) @ d / max(d @ d, 1e-300), 0.0, 1.0)
    return np.linalg.norm(points - (p0 + s[:, None] * d), axis=1)


def test_l_shaped_mesh_gets_two_capsules():
    rng = np.random.default_rng(9)
    leg1 = np.c_[rng.uniform(0, 0.3, 500), rng.normal(0, 0.01, 500), rng.normal(0, 0.01, 500)]
    leg2 = np.c_[rng.normal(0, 0.01, 500), rng.uniform(0, 0.3, 500), rng.normal(0, 0.01, 500)]
    pts = np.concatenate([leg1, leg2])
    caps = capsules_from_points(pts)
    assert len(caps) == 2
    assert max(r for _, _, r in caps) < capsule_from_points(pts)[2]


def test_urdf_primitives_become_capsules(tmp_path):
    urdf = tmp_path / "two.urdf"
    urdf.write_text("""<robot name="t">
      <link name="a"><collision><geometry><box size="0.1 0.4 0.2"/></geometry></collision></link>
      <link name="b"><collision><origin xyz="0 0 0.1"/><geometry><sphere radius="0.03"/>
        </geometry></collision></link>
      <link name="c"/>
      <joint name="j1" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 1 0"/>
      </joint>
      <joint name="f" type="fixed"><parent link="b"/><child link="c"/>
        <origin xyz="0 0 0.5"/></joint>
    </robot>""")
    arm = load_arm(urdf, "c")
    assert arm.joint_names == ("j1",)
    np.testing.assert_allclose([arm.lower[0], arm.upper[0]], [-2 * np.pi, 2 * np.pi])
    np.testing.assert_allclose(arm.tip_xyz, [0, 0, 0.5])
    # Box: along its longest (y) axis, radius the half diagonal of the other two sides.
    np.testing.assert_allclose(arm.radii, [0.5 * np.hypot(0.1, 0.2), 0.03])
    np.testing.assert_allclose(arm.capsules[0], [[0, -0.2 + arm.radii[0], 0],
                                                 [0, 0.2 - arm.radii[0], 0]], atol=1e-12)
    np.testing.assert_array_equal(arm.capsule_link, [-1, 0])
    with pytest.raises(ValueError, match="tip_link"):
        load_arm(urdf, "nope")
    with pytest.raises(ValueError, match="missing.urdf: cannot read the file"):
        load_arm(tmp_path / "missing.urdf", "c")
    with pytest.raises(ValueError, match="base_link"):
        load_arm(urdf, "a", base_link="c")


def test_prismatic_joint_on_the_chain_is_refused(tmp_path):
    urdf = tmp_path / "p.urdf"
    urdf.write_text("""<robot name="p"><link name="a"/><link name="b"/>
      <joint name="s" type="prismatic"><parent link="a"/><child link="b"/>
      <limit lower="0" upper="1" velocity="1" effort="1"/></joint></robot>""")
    with pytest.raises(ValueError, match="prismatic"):
        load_arm(urdf, "b")


def _cable_path(cell_name, n=8, x0=0.45, half0=0.2, z0=0.1, mirror=False):
    """Two TCPs pointing down holding a cable that shortens, rises and twists."""
    pos = np.zeros((n, 2, 3))
    rots = []
    down = Rotation.from_rotvec([np.pi, 0, 0])
    for k, t in enumerate(np.linspace(0, 1, n)):
        half = half0 - 0.05 * t
        pos[k, 0] = [x0 + 0.05 * t, half, z0 + 0.1 * t]
        pos[k, 1] = [x0 + 0.05 * t, -half, z0 + 0.1 * t]
        rots += [Rotation.from_rotvec([0, 0, 0.3 * t]) * down,
                 Rotation.from_rotvec([0, 0, -0.3 * t]) * down]
    rot = Rotation.from_quat([r.as_quat() for r in rots])
    if mirror:  # y -> -y, and the arms swap
        pos = pos[:, ::-1] * [1, -1, 1]
        m = np.diag([1.0, -1.0, 1.0])
        mats = rot.as_matrix().reshape(n, 2, 3, 3)[:, ::-1]
        mats = m @ mats @ m  # the mirror image of a frame, made right-handed again
        rot = Rotation.from_matrix(mats.reshape(-1, 3, 3))
    return pos, rot


@pytest.mark.parametrize("name", ["ur5e_pair", "panda_pair"])
def test_cable_path_verifies_on_the_arm_pairs(name):
    c = cell(name)
    pos, rot = _cable_path(name)
    verdict = program_check(c, pos, rot)
    assert verdict.ok, verdict.message
    assert {row.check for row in verdict.rows} == {"reach", "joint limits", "continuity",
                                                   "clearance", "table clearance"}
    # Verified joints give the targets back.
    for a, arm in enumerate(c.arms):
        p, r = chain_forward(arm, verdict.joints[a])
        assert np.abs(p - pos[:, a]).max() < POSITION_TOL
        assert (r * Rotation.from_matrix(rot.as_matrix().reshape(-1, 2, 3, 3)[:, a]).inv()
                ).magnitude().max() < ANGLE_TOL
    mirrored = program_check(c, *_cable_path(name, mirror=True))
    assert mirrored.ok, mirrored.message
    np.testing.assert_allclose(mirrored.clearance, verdict.clearance, atol=0.02)


def test_crossed_arms_table_and_reach_are_refused():
    c = cell("ur5e_pair")
    pos, rot = _cable_path("ur5e_pair")
    crossed = program_check(c, pos[:, ::-1].copy(),
                            Rotation.from_matrix(rot.as_matrix().reshape(-1, 2, 3, 3)[:, ::-1]
                                                 .reshape(-1, 3, 3)))
    low = program_check(c, pos - [0, 0, 0.12], rot)
    far = program_check(c, pos + [1.2, 0, 0], rot)
    assert not crossed.ok and "clearance" in crossed.message
    assert not low.ok and "table clearance" in low.message
    assert not far.ok and "reach" in far.message and not far.reachable.any()


def test_placement_search_moves_a_far_job_back():
    c = cell("ur5e_pair")
    pos, rot = _cable_path("ur5e_pair")
    shifted = pos + [0.45, 0.0, 0.0]
    assert not program_check(c, shifted, rot).ok
    candidates = [[0.0, 0.0, 0.0], [-0.25, 0.0, 0.0], [-0.45, 0.0, 0.0], [-0.45, 0.3, 0.0]]
    offset, verdict = search_cell_placement(c, shifted, rot, offsets=candidates)
    assert verdict.ok, verdict.message
    # The shifts back toward the arms reach everything; the one that shifts least along y.
    assert offset[0] < 0 and offset[1] == 0.0


def test_cell_from_specs_two_urdfs_equals_preset():
    preset = ur5e_pair()
    path = str(vendored("ur5e.urdf"))
    specs = [ArmSpec(path, "tool0", base_position=(0.0, y, 0.0), base_rpy=(0.0, 0.0, np.pi),
                     tcp_offset=(0.0, 0.0, 0.15), tool_radius=0.045,
                     home=tuple(preset.left.home)) for y in (0.4, -0.4)]
    built = cell_from_specs("mine", *specs)
    assert not built.shared_base
    q = preset.left.home + 0.2
    for a in range(2):
        np.testing.assert_allclose(chain_forward(built.arms[a], q)[0],
                                   chain_forward(preset.arms[a], q)[0], atol=1e-12)
        np.testing.assert_allclose(capsules(built.arms[a], q)[0], capsules(preset.arms[a], q)[0],
                                   atol=1e-12)


def test_in_base_frame_inverts_the_placement():
    arm = cell("ur5e_pair").right
    q = arm.home + 0.1
    pos, rot = chain_forward(arm, q)
    local = CellArm("right", arm.description, tcp_offset=arm.tcp_offset)
    p_base, rv = in_base_frame(arm, pos, rot)
    p_local, r_local = chain_forward(local, q)
    np.testing.assert_allclose(p_base, p_local, atol=1e-12)
    np.testing.assert_allclose(Rotation.from_rotvec(rv).as_matrix(), r_local.as_matrix(),
                               atol=1e-12)


def test_options_are_used():
    c = cell("ur5e_pair")
    pos, rot = _cable_path("ur5e_pair")
    strict = program_check(c, pos, rot, min_clearance=0.5)
    assert not strict.ok and "clearance" in strict.message


def test_the_reach_sphere_rejects_exactly_what_the_ik_gives_up_on():
    """within_reach (no IK) flags a target outside an arm's reach sphere where the IK itself
    answers "out of reach" without iterating, and only there."""
    from dloplan.robot.placement import within_reach

    c = cell("ur5e_pair")
    pos, rot = _cable_path("ur5e_pair")
    mats = rot.as_matrix().reshape(len(pos), 2, 3, 3)
    offsets = np.array([[0.0, 0.0, 0.0], [0.45, 0.0, 0.0], [0.9, 0.3, 0.0], [-0.3, 0.0, 0.6]])
    inside = within_reach(c, pos, offsets)
    assert inside.shape == (4, len(pos), 2) and inside[0].all() and not inside[2].any()
    for i, offset in enumerate(offsets):
        for k in range(len(pos)):
            for a, arm in enumerate(c.arms):
                result = inverse(arm, pos[k, a] + offset, Rotation.from_matrix(mats[k, a]),
                                 options=IKOptions(restarts=0))
                assert result.message.startswith("out of reach") == (not inside[i, k, a])


def test_the_placement_search_ranks_as_if_it_scored_every_candidate():
    """The bound-ordered scoring (candidates whose bound cannot reach the best three are never
    solved) picks the offset and verdict that scoring every candidate picks."""
    from dloplan.robot.placement import PLACEMENT_TRIES, target_score

    c = cell("ur5e_pair")
    pos, rot = _cable_path("ur5e_pair")
    shifted = pos + [0.3, 0.0, 0.0]
    mats = rot.as_matrix().reshape(len(pos), 2, 3, 3)
    grid = np.stack(np.meshgrid(np.arange(-0.6, 0.61, 0.15), np.arange(-0.3, 0.31, 0.15),
                                [0.0], indexing="ij"), -1).reshape(-1, 3)
    quick = IKOptions(restarts=1)
    scores = [target_score(c, shifted + o, mats, quick, -float(np.linalg.norm(o))) for o in grid]
    ranked = sorted(range(len(grid)), key=lambda i: scores[i], reverse=True)
    expected = next((i for i in ranked[:PLACEMENT_TRIES]
                     if program_check(c, shifted + grid[i], rot).ok), ranked[0])
    offset, verdict = search_cell_placement(c, shifted, rot, offsets=grid)
    np.testing.assert_array_equal(offset, grid[expected])
    assert verdict.ok == program_check(c, shifted + grid[expected], rot).ok


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("tries", [None, 1, 3])
def test_the_one_placement_search_equals_scoring_every_candidate(seed, tries):
    """search_offsets with random scores under random bounds (ties included) keeps what
    scoring every candidate, ranking (score, then the earlier candidate) and verifying the
    best ``tries`` in order keeps, and never scores a candidate that cannot rank."""
    from dloplan.robot.placement import search_offsets

    rng = np.random.default_rng(seed)
    c = cell("ur5e_pair")
    n = 40
    offsets = np.zeros((n, 3))
    bounds = rng.integers(0, 6, n).astype(float)
    scores = [None if rng.random() < 0.2 else (float(b - rng.integers(0, 3)),) for b in bounds]
    passes = rng.random(n) < 0.3
    rejected = rng.random(n) < 0.1
    scored = []

    def score(i):
        scored.append(i)
        return scores[i]

    for first_pass in (True, False):
        scored.clear()
        found = search_offsets(
            c, np.zeros((2, 2, 3)), offsets, score=score, tries=tries, first_pass=first_pass,
            bound=lambda i, inside: None if rejected[i] else (bounds[i],),
            verify=lambda i: ((bool(passes[i]), -i), i))
        ranked = sorted((i for i in range(n) if not rejected[i] and scores[i] is not None),
                        key=lambda i: (scores[i], -i), reverse=True)[:tries]
        verified = ranked
        if first_pass and passes[ranked].any():
            verified = ranked[:int(np.argmax(passes[ranked])) + 1]
        expected = max(verified, key=lambda i: (bool(passes[i]), -i)) if verified else None
        assert (found is None) == (expected is None)
        if found is not None:
            assert found[0] == found[1] == expected and found[2] == len(verified)
        assert not any(rejected[i] for i in scored)
