"""Exports: ROS 2 MultiDOFJointTrajectory, CSV, ABB RAPID, atomic writes.

Tolerances: JSON floats are written with Python's round-tripping repr, so positions and times
come back bit-identical; rotations come back as the same rotation to 1e-12 rad (quaternion
normalization). RAPID robtargets are printed with 6 decimals in mm and 9 in the quaternion and
must match the plan within 0.01 mm (the issue's bound) and 1e-8 per quaternion component.
"""

from __future__ import annotations

import csv
import json
import os
import re

import numpy as np
import pytest
import yaml
from gripper_paths import turned_hose_plan
from scipy.spatial.transform import Rotation

from dloplan.io import files
from dloplan.io.export import (
    multi_dof_trajectory_msg,
    write_ros_trajectory,
    write_trajectory_csv,
)
from dloplan.io.rapid import RapidSettings, rapid_modules, write_rapid


@pytest.fixture(scope="module")
def plan():
    return turned_hose_plan()  # twisted: has warnings


def _same_rotations(a: Rotation, b: Rotation, tol: float = 1e-12) -> bool:
    return len(a) == len(b) and float(np.max((a.inv() * b).magnitude())) < tol


# -- ROS 2 trajectory_msgs/MultiDOFJointTrajectory -----------------------------------------------
def test_ros_trajectory_yaml_is_the_message(plan, tmp_path):
    trajectory = plan[3]
    path = write_ros_trajectory(tmp_path / "traj.yaml", trajectory)
    msg = yaml.safe_load(path.read_text())
    assert set(msg) == {"header", "joint_names", "points"}
    assert msg["header"] == {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "world"}
    assert msg["joint_names"] == ["left_tcp", "right_tcp"]
    assert len(msg["points"]) == trajectory.n_knots
    for k, point in enumerate(msg["points"]):
        assert set(point) == {"transforms", "velocities", "accelerations", "time_from_start"}
        t = point["time_from_start"]["sec"] + 1e-9 * point["time_from_start"]["nanosec"]
        assert 0 <= point["time_from_start"]["nanosec"] < 1_000_000_000
        assert t == pytest.approx(trajectory.times[k], abs=1e-9)
        for arm, tf in enumerate(point["transforms"]):
            pos = [tf["translation"][c] for c in "xyz"]
            quat = [tf["rotation"][c] for c in "xyzw"]
            assert np.allclose(pos, trajectory.positions[k, arm], atol=1e-15)
            assert quat[3] >= 0
            assert _same_rotations(Rotation.from_quat([quat]), trajectory.rotations[arm][k : k + 1])


def test_ros_trajectory_sampled_json(plan, tmp_path):
    trajectory = plan[3]
    path = write_ros_trajectory(tmp_path / "traj.json", trajectory, rate=20.0)
    msg = json.loads(path.read_text())
    assert msg == multi_dof_trajectory_msg(trajectory, rate=20.0)
    assert len(msg["points"]) == len(trajectory.sample(20.0).times)
    with pytest.raises(ValueError, match="fmt"):
        write_ros_trajectory(tmp_path / "x.txt", trajectory, fmt="xml")


# -- CSV -------------------------------------------------------------------------------------------
def test_csv_header_units_and_rows(plan, tmp_path):
    trajectory = plan[3]
    path = write_trajectory_csv(tmp_path / "traj.csv", trajectory, rate=50.0)
    lines = path.read_text().splitlines()
    assert lines[0].startswith("#") and "x-y-z-w" in lines[0] and "positions in m" in lines[0]
    header = next(csv.reader([lines[1]]))
    assert header[:8] == [
        "time [s]",
        "left x [m]",
        "left y [m]",
        "left z [m]",
        "left qx",
        "left qy",
        "left qz",
        "left qw",
    ]
    assert header[8] == "right x [m]" and header[-1] == "right qw"
    table = np.loadtxt(path, delimiter=",", skiprows=2)
    samples = trajectory.sample(50.0)
    assert np.allclose(table[:, 0], samples.times, atol=1e-12)
    for arm, col in ((0, 1), (1, 8)):
        assert np.allclose(table[:, col : col + 3], samples.positions[:, arm], atol=1e-11)
        quats = table[:, col + 3 : col + 7]
        assert np.all(quats[:, 3] >= 0)
        assert np.allclose(np.linalg.norm(quats, axis=1), 1.0, atol=1e-10)
        assert _same_rotations(Rotation.from_quat(quats), samples.rotations[arm], 1e-9)


# -- RAPID -----------------------------------------------------------------------------------------
_NUM = r"[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?"
_ROBTARGET = re.compile(
    r"^\s*CONST robtarget (\w+) := \[\[(.*?)\],\[(.*?)\],\[(.*?)\],\[(.*?)\]\];$", re.M
)
_MOVEL = re.compile(r"^\s*MoveL (\w+) \\ID:=(\d+), (\w+), (\w+), (\w+) \\WObj:=(\w+);$", re.M)


def _numbers(text: str) -> list[float]:
    items = text.split(",")
    assert all(re.fullmatch(_NUM, item) or item == "9E+09" for item in items), text
    return [float(item) for item in items]


def parse_rapid(text: str) -> dict:
    """Read a generated module back: declarations, robtargets and the synchronized moves."""
    module = re.search(r"^MODULE (\w+)$", text, re.M)
    assert module and text.rstrip().endswith("ENDMODULE")
    targets = {
        name: dict(trans=_numbers(t), rot=_numbers(r), conf=_numbers(c), extax=_numbers(e))
        for name, t, r, c, e in _ROBTARGET.findall(text)
    }
    proc = re.search(r"PROC (\w+)\(\)\n(.*?)\n\s*ENDPROC", text, re.S)
    body = [line.strip() for line in proc.group(2).splitlines()]
    return dict(
        module=module.group(1),
        tasks=re.search(r'PERS tasks (\w+)\{2\} := \[\["(\w+)"\],\["(\w+)"\]\];', text).groups(),
        syncidents=re.findall(r"VAR syncident (\w+);", text),
        speed=_numbers(re.search(r"CONST speeddata dlo_speed := \[(.*?)\];", text).group(1)),
        targets=targets,
        procedure=proc.group(1),
        body=body,
        moves=_MOVEL.findall(text),
    )


def test_rapid_modules_parse_back_to_the_plan(plan):
    trajectory = plan[3]
    settings = RapidSettings(
        tools=("GripperL", "GripperR"), wobj="wobjTable", robconf=((1, 2, 0, 4), (-1, 0, 1, 4))
    )
    modules = rapid_modules(trajectory, settings)
    assert list(modules) == ["T_ROB_L", "T_ROB_R"]
    parsed = {task: parse_rapid(text) for task, text in modules.items()}
    ids = []
    for arm, p in enumerate(parsed.values()):
        assert p["module"] == settings.modules[arm]
        assert p["tasks"] == ("dlo_tasks", "T_ROB_L", "T_ROB_R")
        assert p["syncidents"] == ["dlo_sync_on", "dlo_sync_off"]
        assert p["speed"] == pytest.approx([100.0, np.degrees(1.0), 5000, 1000], abs=1e-6)
        assert p["body"][0] == "ConfL \\Off;"
        assert p["body"][1] == "SyncMoveOn dlo_sync_on, dlo_tasks;"
        assert p["body"][-2] == "SyncMoveOff dlo_sync_off;"
        assert len(p["moves"]) == trajectory.n_knots == len(p["targets"])
        quats = trajectory.rotations[arm].as_quat(scalar_first=True)
        for k, (name, _id, speed, zone, tool, wobj) in enumerate(p["moves"]):
            assert (speed, zone, tool, wobj) == (
                "dlo_speed",
                "fine",
                settings.tools[arm],
                "wobjTable",
            )
            target = p["targets"][name]
            assert (
                np.max(np.abs(np.array(target["trans"]) - 1000 * trajectory.positions[k, arm]))
                < 0.01
            )
            rot = np.array(target["rot"])
            assert rot[0] >= 0  # canonical sign, w first
            assert np.allclose(np.abs(rot), np.abs(quats[k]), atol=1e-8)
            read = Rotation.from_quat(rot, scalar_first=True)
            assert (read.inv() * trajectory.rotations[arm][k]).magnitude() < 1e-8
            assert target["conf"] == list(settings.robconf[arm])
            assert target["extax"][0] == settings.arm_angles[arm] and target["extax"][1] == 9e9
        ids.append([int(m[1]) for m in p["moves"]])
    assert ids[0] == ids[1] and len(set(ids[0])) == len(ids[0]) and ids[0] == sorted(ids[0])


def test_rapid_robtargets_agree_with_abb_motion_program_exec(plan):
    """Independent cross-check: the same poses through abb_motion_program_exec's RAPID writer."""
    abb = pytest.importorskip("abb_motion_program_exec")
    trajectory = plan[3]
    ours = {task: parse_rapid(text) for task, text in rapid_modules(trajectory).items()}
    for arm, task in enumerate(("T_ROB_L", "T_ROB_R")):
        program = abb.MotionProgram(timestamp="2024-01-01-00-00-00-0000")
        angle = RapidSettings().arm_angles[arm]
        for k in range(trajectory.n_knots):
            quat = trajectory.rotations[arm][k].as_quat(canonical=True, scalar_first=True)
            target = abb.robtarget(
                list(1000.0 * trajectory.positions[k, arm]),
                list(quat),
                abb.confdata(0, 0, 0, 4),
                [angle] + [9e9] * 5,
            )
            program.MoveL(target, abb.v100, abb.fine)
        text = program.get_program_rapid(sync_move=True)
        theirs = re.findall(r"MoveL \[\[(.*?)\],\[(.*?)\],\[(.*?)\],\[(.*?)\]\], \\ID:=", text)
        assert len(theirs) == trajectory.n_knots
        for (name, *_), (trans, rot, conf, extax) in zip(ours[task]["moves"], theirs, strict=True):
            mine = ours[task]["targets"][name]
            assert np.max(np.abs(np.array(mine["trans"]) - np.array(_floats(trans)))) < 0.01
            assert np.allclose(mine["rot"], _floats(rot), atol=1e-8)
            assert mine["conf"] == _floats(conf)
            assert mine["extax"] == pytest.approx(_floats(extax))


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",")]


def test_rapid_settings_are_validated(plan):
    with pytest.raises(ValueError, match=r"tools \(right\): got 'tool 0'"):
        RapidSettings(tools=("tool0", "tool 0"))
    with pytest.raises(ValueError, match="wobj"):
        RapidSettings(wobj="9wobj")
    with pytest.raises(ValueError, match="different task"):
        RapidSettings(tasks=("T_ROB_L", "T_ROB_L"))
    with pytest.raises(ValueError, match=r"robconf \(left\)"):
        RapidSettings(robconf=((0, 0, 4), (0, 0, 0, 4)))
    with pytest.raises(ValueError, match="trajectory: expected a Trajectory"):
        rapid_modules(plan[2])


def test_write_rapid_writes_one_module_file_per_task(plan, tmp_path):
    written = write_rapid(tmp_path / "rapid", plan[3])
    assert {p.name for p in written.values()} == {"DloPlanL.mod", "DloPlanR.mod"}
    assert written["T_ROB_L"].read_text() == rapid_modules(plan[3])["T_ROB_L"]


# -- atomic writes --------------------------------------------------------------------------------
def test_a_failed_write_leaves_no_half_written_file(plan, tmp_path, monkeypatch):
    target = tmp_path / "plan.json"
    target.write_text("old plan")
    with pytest.raises(ValueError):
        write_trajectory_csv(target, plan[3], rate=float("nan"))
    assert target.read_text() == "old plan"

    def broken_fsync(fd):
        raise OSError("disk full")

    monkeypatch.setattr(files.os, "fsync", broken_fsync)
    with pytest.raises(OSError, match="disk full"):
        write_trajectory_csv(target, plan[3])
    assert target.read_text() == "old plan"
    assert os.listdir(tmp_path) == ["plan.json"]


def test_rapid_files_are_written_both_or_none(plan, tmp_path, monkeypatch):
    folder = tmp_path / "rapid"
    folder.mkdir()
    (folder / "DloPlanL.mod").write_text("old left")
    calls = []

    def fsync_failing_second(fd):
        calls.append(fd)
        if len(calls) == 2:
            raise OSError("disk full")

    monkeypatch.setattr(files.os, "fsync", fsync_failing_second)
    with pytest.raises(OSError):
        write_rapid(folder, plan[3])
    assert sorted(os.listdir(folder)) == ["DloPlanL.mod"]
    assert (folder / "DloPlanL.mod").read_text() == "old left"
