"""Vendor programs from a verified cell path: URScript (syntax checked by a small parser, the
waypoints read back equal the verified ones, the gripper hooks and the planned actions at their
waypoints) and ROS 2 joint trajectories (the verified IK at the targets' instants, held while
the gripper acts)."""

from __future__ import annotations

import re
from functools import cache

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from dloplan.io.ros_joints import write_joint_trajectories
from dloplan.io.urscript import write_urscript
from dloplan.robot.actions import ProgramTimeline, action_clock, place_actions
from dloplan.robot.chain import in_base_frame
from dloplan.robot.kinematics import forward, inverse
from dloplan.robot.motion import JointMotion
from dloplan.robot.path import ReachOptions, check_path
from dloplan.robot.urdf_cell import panda_pair, ur5e_pair
from dloplan.trajectory import GripperAction
from dloplan.trajectory.timelaw import Profile

pytest.importorskip("yourdfpy")

FUNCTIONS = {"movej", "movel", "set_tcp", "set_standard_digital_out", "textmsg",
             "get_standard_digital_in", "sync", "sleep", "set_tool_digital_out"}
NUMBER = r"-?\d+(?:\.\d+)?(?:e-?\d+)?"
LIST = rf"p?\[{NUMBER}(?:, {NUMBER})*\]"
ARGUMENT = rf"(?:{LIST}|{NUMBER}|True|False|\"[^\"]*\"|[a-z]+={NUMBER})"
CALL = re.compile(rf"^(?:while not )?([a-z_]+)\(((?:{ARGUMENT}(?:, {ARGUMENT})*)?)\):?$")


def program_check(cell, positions, rotations, **settings):
    """The path check with a described cell's program settings (``ReachOptions.cell_program``)."""
    return check_path(cell, positions, rotations, options=ReachOptions.cell_program(**settings))


def parse_urscript(text: str) -> dict:
    """A small URScript checker: balanced ``def``/``while`` ... ``end`` blocks, functions
    defined in the program (its hooks, one level deep) or known, numeric lists of 6 numbers,
    every number finite. Returns the program name, the argument lists of every ``movej`` /
    ``movel`` (floats) and the calls of the program's own functions with the waypoint (moves
    so far, minus one) they follow."""
    depth, name, moves, called, defined, hooks = 0, None, [], False, set(), []
    for raw in text.splitlines():
        line = raw.split("#")[0].strip()
        if not line:
            continue
        if line.startswith("def "):
            assert depth <= 1, f"nested def: {line}"
            match = re.fullmatch(r"def ([a-z_][a-z0-9_]*)\(\):", line)
            assert match, line
            if depth == 0:
                name = match.group(1)
            else:
                defined.add(match.group(1))
            depth += 1
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
        if function in defined:
            hooks.append((function, len(moves) - 1))
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
    return {"name": name, "moves": moves, "hooks": hooks}


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
    verdict = program_check(cell, pos, rot)
    assert verdict.ok, verdict.message
    times = np.linspace(0.0, 5.0, n)
    return cell, verdict, times, pos, rot


def _base_poses(cell, pos, rot):
    """(M, 2, 3) TCP positions [m] and rotation vectors [rad] in each arm's base frame."""
    base_pos, base_rv = zip(*(in_base_frame(arm, pos[:, a],
                                            Rotation.from_matrix(rot.as_matrix()
                                                                 .reshape(-1, 2, 3, 3)[:, a]))
                              for a, arm in enumerate(cell.arms)), strict=True)
    return np.stack(base_pos, 1), np.stack(base_rv, 1)


def test_urscript_movej_parses_and_reads_back_the_verified_joints(tmp_path):
    cell, verdict, times, pos, rot = _verified()
    tcp = [np.concatenate([arm.tcp_offset, arm.tcp_rotation.as_rotvec()]) for arm in cell.arms]
    files = write_urscript(tmp_path, times, verdict.joints, tcp_offsets=tcp, blend=0.001,
                           tcp_positions=_base_poses(cell, pos, rot)[0])
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
    tcp_pos, tcp_rv = _base_poses(cell, pos, rot)
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
    with pytest.raises(ValueError, match="tcp_positions: required for a blend"):
        write_urscript(tmp_path, times, verdict.joints, blend=0.01)
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


def _timeline(joints, arrivals, actions) -> ProgramTimeline:
    """A timeline through per-arm target joints (K, J) reached at ``arrivals`` [s], straight in
    joint space, each move jerk-limited to fit its interval."""
    paths = tuple(tuple(np.linspace(q[m], q[m + 1], 3) for m in range(len(q) - 1))
                  for q in joints)
    laws = []
    for d in np.diff(arrivals):
        law = Profile.jerk_limited(2.0 / d, 8.0 / d**2, 64.0 / d**3)
        assert law.duration <= d
        laws.append(law)
    starts = np.asarray(arrivals[1:]) - [law.duration for law in laws]
    motion = JointMotion(paths, tuple(laws), starts, np.asarray(arrivals, float))
    placed = place_actions(actions, np.arange(len(arrivals)))
    return ProgramTimeline(motion, action_clock(motion.arrivals, placed), placed)


def test_urscript_writes_the_gripper_actions_at_their_waypoints(tmp_path):
    cell, verdict, times, pos, rot = _verified()
    last = len(times) - 1
    placed = place_actions((GripperAction("grasp", 0, 0.5), GripperAction.regrasp_at(3, 0.4, 0.5),
                            GripperAction("release", last, 0.4)), np.arange(len(times)))
    files = write_urscript(tmp_path, times, verdict.joints, actions=placed, blend=0.001,
                           tcp_positions=_base_poses(cell, pos, rot)[0],
                           gripper={"output": 1, "tool": True, "closed": False})
    for path in files:
        text = path.read_text()
        program = parse_urscript(text)
        assert program["hooks"] == [("dloplan_grip_open", -1), ("dloplan_grip_close", 0),
                                    ("dloplan_grip_open", 3), ("dloplan_grip_close", 3),
                                    ("dloplan_grip_open", last)]
        assert "def dloplan_grip_close():\n    set_tool_digital_out(1, False)" in text
        assert re.findall(r"sleep\(([0-9.]+)\)", text) == ["0.500000000", "0.400000000",
                                                           "0.500000000", "0.400000000"]
        # no blend into the waypoint where the gripper acts
        assert program["moves"][3][2]["r"] == 0.0 and program["moves"][2][2]["r"] == 0.001
    with pytest.raises(ValueError, match="ready_output"):
        write_urscript(tmp_path, times, verdict.joints,
                       gripper={"output": 0, "tool": False, "closed": True})


@pytest.mark.parametrize("mode", ["movej", "movel"])
def test_urscript_blends_never_overlap(tmp_path, mode):
    """A blend radius wider than half a TCP segment is written as half of the shorter segment
    beside its waypoint (UR's controller does not blend across overlapping radii: the sweep's
    UR5e job with a 20 mm blend had 18 mm segments), and the header says so."""
    cell, verdict, times, pos, rot = _verified()
    tcp_pos, tcp_rv = _base_poses(cell, pos, rot)
    files = write_urscript(tmp_path, times, verdict.joints, tcp_positions=tcp_pos,
                           tcp_rotvecs=tcp_rv, mode=mode, blend=0.05)
    for a, path in enumerate(files):
        text = path.read_text()
        radii = np.array([m[2]["r"] for m in parse_urscript(text)["moves"][1:]])
        segments = np.linalg.norm(np.diff(tcp_pos[:, a], axis=0), axis=1)
        assert np.all(radii[:-1] + radii[1:] <= segments[1:] + 1e-9)
        assert radii[0] <= segments[0] / 2 + 1e-9 and radii[-1] == 0.0
        assert np.all(radii[:-1] > 0)
        assert "Blend radius 0.050000000 m reduced at 4 of 4 waypoints" in text


def test_ros_joint_trajectory_holds_the_verified_ik_while_the_gripper_acts(tmp_path):
    cell, verdict, times, _, _ = _verified()
    actions = (GripperAction("grasp", 0, 0.5), GripperAction.regrasp_at(2, 0.4, 0.5),
               GripperAction("release", len(times) - 1, 0.4))
    timeline = _timeline(verdict.joints, times, actions)
    files = write_joint_trajectories(tmp_path, timeline, [arm.joint_names for arm in cell.arms],
                                     joint_prefix=("left_", "right_"), rate=50.0)
    assert [f.name for f in files] == ["dloplan_left_joint_trajectory.yaml",
                                       "dloplan_right_joint_trajectory.yaml",
                                       "dloplan_gripper_actions.yaml"]
    rows = yaml.safe_load(files[2].read_text())["actions"]
    assert [(r["arm"], r["action"], r["command"], r["duration"]) for r in rows] == [
        (arm, action, command, wait) for action, command, wait in
        (("grasp", "close", 0.5), ("regrasp", "open", 0.4), ("regrasp", "close", 0.5),
         ("release", "open", 0.4)) for arm in ("left", "right")]
    clock = timeline.clock
    assert [r["time"] for r in rows[::2]] == pytest.approx(
        [0.0, clock.arrive[2], clock.arrive[2] + 0.4, clock.arrive[-1]])
    for a, path in enumerate(files[:2]):
        message = yaml.safe_load(path.read_text())
        assert message["joint_names"][0] == f"{cell.arms[a].name}_shoulder_pan_joint"
        points = message["points"]
        positions = np.array([p["positions"] for p in points])
        stamps = np.array([p["time_from_start"]["sec"] + 1e-9 * p["time_from_start"]["nanosec"]
                           for p in points])
        # every target at its instant, held over every gripper command there
        for k, (arrive, leave) in enumerate(zip(clock.arrive, clock.leave, strict=True)):
            inside = (stamps >= arrive - 1e-9) & (stamps <= leave + 1e-9)
            assert inside.any()
            np.testing.assert_allclose(positions[inside], np.broadcast_to(
                verdict.joints[a][k], positions[inside].shape), atol=1e-12)
        velocities = np.array([p["velocities"] for p in points])
        np.testing.assert_allclose(velocities[[0, -1]], 0.0)
        assert stamps[-1] == pytest.approx(clock.end, abs=1e-9)


def test_ros_joint_trajectory_of_a_seven_joint_cell(tmp_path):
    """Any number of joints (Panda: 7); positions only when asked."""
    cell = panda_pair()
    rng = np.random.default_rng(0)
    joints = [rng.uniform(arm.lower, arm.upper, (4, 7)) for arm in cell.arms]
    timeline = _timeline(joints, [0.0, 0.5, 1.25, 2.0], ())
    files = write_joint_trajectories(tmp_path, timeline, [arm.joint_names for arm in cell.arms],
                                     velocities=False)
    message = yaml.safe_load(files[1].read_text())
    assert message["joint_names"] == list(cell.right.joint_names)
    assert "velocities" not in message["points"][0]
    assert yaml.safe_load(files[2].read_text())["actions"] == []
    with pytest.raises(ValueError, match="joint_names"):
        write_joint_trajectories(tmp_path, timeline, [cell.left.joint_names[:6],
                                                      cell.right.joint_names])
