"""Vendor programs from a verified cell path: URScript (syntax checked by a small parser, the
waypoints read back equal the verified ones) and ROS 2 joint trajectories (values equal the
verified IK)."""

from __future__ import annotations

import re
from functools import cache

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from dloplan.io.ros_joints import hermite_velocities, write_joint_trajectories
from dloplan.io.urscript import write_urscript
from dloplan.robot.chain import in_base_frame
from dloplan.robot.kinematics import forward, inverse
from dloplan.robot.urdf_cell import check_cell_path, panda_pair, ur5e_pair

pytest.importorskip("yourdfpy")

FUNCTIONS = {"movej", "movel", "set_tcp", "set_standard_digital_out", "textmsg",
             "get_standard_digital_in", "sync"}
NUMBER = r"-?\d+(?:\.\d+)?(?:e-?\d+)?"
LIST = rf"p?\[{NUMBER}(?:, {NUMBER})*\]"
ARGUMENT = rf"(?:{LIST}|{NUMBER}|True|False|\"[^\"]*\"|[a-z]+={NUMBER})"
CALL = re.compile(rf"^(?:while not )?([a-z_]+)\(((?:{ARGUMENT}(?:, {ARGUMENT})*)?)\):?$")


def parse_urscript(text: str) -> dict:
    """A small URScript checker: balanced ``def``/``while`` ... ``end`` blocks, only known
    functions, numeric lists of 6 numbers, every number finite. Returns the program name and
    the argument lists of every ``movej`` / ``movel`` (floats)."""
    depth, name, moves, called = 0, None, [], False
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if line.startswith("def "):
            assert depth == 0, f"nested def: {line}"
            match = re.fullmatch(r"def ([a-z_][a-z0-9_]*)\(\):", line)
            assert match, line
            name, depth = match.group(1), 1
            continue
        if line == "end":
            depth -= 1
            assert depth >= 0, "end without block"
            continue
        if depth == 0:
            assert line == f"{name}()", f"top-level statement other than the call: {line}"
            called = True
            continue
        match = CALL.match(line)
        assert match, f"not a known statement: {line}"
        function = match.group(1)
        if line.startswith("while not "):
            assert function == "get_standard_digital_in", line
            depth += 1
            continue
        assert function in FUNCTIONS, f"unknown function {function}"
        for values in re.findall(r"\[([^\]]*)\]", match.group(2)):
            numbers = [float(v) for v in values.split(", ")]
            assert len(numbers) == 6 and np.all(np.isfinite(numbers)), line
        if function in ("movej", "movel"):
            lists = re.findall(r"\[([^\]]*)\]", match.group(2))
            keywords = dict(re.findall(rf"([a-z])=({NUMBER})", match.group(2)))
            moves.append((function, [float(v) for v in lists[0].split(", ")],
                          {k: float(v) for k, v in keywords.items()}))
    assert depth == 0, "unbalanced blocks"
    assert called, "the program is never called"
    return {"name": name, "moves": moves}


@cache
def _verified():
    """A verified UR5e pair path: cell, verdict, times, TCP poses."""
    cell = ur5e_pair()
    n = 6
    pos = np.zeros((n, 2, 3))
    rots = []
    down = Rotation.from_rotvec([np.pi, 0, 0])
    for k, t in enumerate(np.linspace(0, 1, n)):
        pos[k, 0] = [0.45 + 0.05 * t, 0.2 - 0.05 * t, 0.1 + 0.1 * t]
        pos[k, 1] = [0.45 + 0.05 * t, -0.2 + 0.05 * t, 0.1 + 0.1 * t]
        rots += [Rotation.from_rotvec([0, 0, 0.3 * t]) * down,
                 Rotation.from_rotvec([0, 0, -0.3 * t]) * down]
    rot = Rotation.from_quat([r.as_quat() for r in rots])
    verdict = check_cell_path(cell, pos, rot)
    assert verdict.ok, verdict.message
    times = np.linspace(0.0, 5.0, n)
    return cell, verdict, times, pos, rot


def test_urscript_movej_parses_and_reads_back_the_verified_joints(tmp_path):
    cell, verdict, times, _, _ = _verified()
    tcp = [np.concatenate([arm.tcp_offset, arm.tcp_rotation.as_rotvec()]) for arm in cell.arms]
    files = write_urscript(tmp_path, times, verdict.joints, tcp_offsets=tcp, blend=0.001)
    assert [f.name for f in files] == ["dloplan_left.script", "dloplan_right.script"]
    for a, path in enumerate(files):
        program = parse_urscript(path.read_text())
        assert program["name"] == f"dloplan_{cell.arms[a].name}"
        moves = program["moves"]
        assert [m[0] for m in moves] == ["movej"] * len(times)
        joints = np.array([m[1] for m in moves])
        np.testing.assert_allclose(joints, verdict.joints[a], atol=1e-9)
        durations = [m[2]["t"] for m in moves[1:]]
        np.testing.assert_allclose(durations, np.diff(times), atol=1e-9)
        assert moves[-1][2]["r"] == 0.0 and moves[1][2]["r"] == 0.001
        # The joints read back reach the verified TCP (0.1 mm / 0.05 deg).
        p, r = forward(cell.arms[a], joints)
        p0, r0 = forward(cell.arms[a], verdict.joints[a])
        assert np.abs(p - p0).max() < 1e-4
        assert (r * r0.inv()).magnitude().max() < np.radians(0.05)


def test_urscript_movel_poses_read_back_to_the_verified_joints(tmp_path):
    cell, verdict, times, pos, rot = _verified()
    base_pos, base_rv = zip(*(in_base_frame(arm, pos[:, a],
                                            Rotation.from_matrix(rot.as_matrix()
                                                                 .reshape(-1, 2, 3, 3)[:, a]))
                              for a, arm in enumerate(cell.arms)), strict=True)
    tcp_pos, tcp_rv = np.stack(base_pos, 1), np.stack(base_rv, 1)
    speeds = np.full((len(times) - 1, 2), 0.05)
    files = write_urscript(tmp_path, times, verdict.joints, tcp_positions=tcp_pos,
                           tcp_rotvecs=tcp_rv, speeds=speeds, mode="movel")
    for a, path in enumerate(files):
        arm = cell.arms[a]
        moves = parse_urscript(path.read_text())["moves"]
        assert moves[0][0] == "movej" and {m[0] for m in moves[1:]} == {"movel"}
        np.testing.assert_allclose(moves[0][1], verdict.joints[a][0], atol=1e-9)
        assert all(m[2]["v"] == 0.05 for m in moves[1:])
        # Each pose, from the arm's base frame back to the world, solved by IK seeded from the
        # verified solution, gives the verified joints back.
        for k, (_, pose, _) in enumerate(moves[1:], start=1):
            world = arm.base_rotation.apply(pose[:3]) + arm.base_position
            world_rot = arm.base_rotation * Rotation.from_rotvec(pose[3:])
            result = inverse(arm, world, world_rot, seed=verdict.joints[a][k])
            assert result.success
            np.testing.assert_allclose(result.q, verdict.joints[a][k], atol=np.radians(0.05))


def test_urscript_bad_input_names_the_field(tmp_path):
    _, verdict, times, _, _ = _verified()
    with pytest.raises(ValueError, match="mode"):
        write_urscript(tmp_path, times, verdict.joints, mode="servoj")
    with pytest.raises(ValueError, match="times"):
        write_urscript(tmp_path, times[::-1], verdict.joints)
    with pytest.raises(ValueError, match="tcp_positions"):
        write_urscript(tmp_path, times, verdict.joints, mode="movel")
    with pytest.raises(ValueError, match="start_input"):
        write_urscript(tmp_path, times, verdict.joints, start_input=9)
    with pytest.raises(ValueError, match=r"joints\[0\]"):
        write_urscript(tmp_path, times, [verdict.joints[0][:, :5], verdict.joints[1]])


def test_parser_rejects_broken_scripts():
    good = "def p():\n  movej([0, 0, 0, 0, 0, 0], t=1.0, r=0.0)\nend\np()\n"
    assert parse_urscript(good)["moves"][0][1] == [0.0] * 6
    for bad in (good.replace("end\n", ""), good.replace("movej", "movez"),
                good.replace("[0, 0, 0, 0, 0, 0]", "[0, 0, 0]"), good.replace("p()\n", "")):
        with pytest.raises(AssertionError):
            parse_urscript(bad)


def test_ros_joint_trajectory_values_equal_the_verified_ik(tmp_path):
    cell, verdict, times, _, _ = _verified()
    files = write_joint_trajectories(tmp_path, times, verdict.joints,
                                     [arm.joint_names for arm in cell.arms],
                                     joint_prefix=("left_", "right_"))
    for a, path in enumerate(files):
        message = yaml.safe_load(path.read_text())
        assert message["joint_names"][0] == f"{cell.arms[a].name}_shoulder_pan_joint"
        positions = np.array([p["positions"] for p in message["points"]])
        np.testing.assert_array_equal(positions, verdict.joints[a])
        stamps = [p["time_from_start"]["sec"] + 1e-9 * p["time_from_start"]["nanosec"]
                  for p in message["points"]]
        np.testing.assert_allclose(stamps, times, atol=1e-9)
        velocities = np.array([p["velocities"] for p in message["points"]])
        np.testing.assert_allclose(velocities[[0, -1]], 0.0)


def test_ros_joint_trajectory_of_a_seven_joint_cell(tmp_path):
    """Any number of joints (Panda: 7); positions written exactly."""
    cell = panda_pair()
    rng = np.random.default_rng(0)
    joints = [rng.uniform(arm.lower, arm.upper, (4, 7)) for arm in cell.arms]
    files = write_joint_trajectories(tmp_path, [0.0, 0.5, 1.25, 2.0], joints,
                                     [arm.joint_names for arm in cell.arms], velocities=False)
    message = yaml.safe_load(files[1].read_text())
    assert message["joint_names"] == list(cell.right.joint_names)
    assert "velocities" not in message["points"][0]
    np.testing.assert_array_equal([p["positions"] for p in message["points"]], joints[1])
    with pytest.raises(ValueError, match="times"):
        write_joint_trajectories(tmp_path, [0.0, 0.0, 1.0, 2.0], joints,
                                 [arm.joint_names for arm in cell.arms])


def test_hermite_velocities_are_exact_for_a_quadratic_on_uniform_times():
    """Central differences are exact for a quadratic at uniform spacing."""
    t = np.linspace(0, 2, 9)
    q = np.stack([t**2, 3 * t], 1)
    vel = hermite_velocities(t, q)
    np.testing.assert_allclose(vel[1:-1], np.stack([2 * t, 3 + 0 * t], 1)[1:-1], atol=1e-12)
