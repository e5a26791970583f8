"""Exports: plan JSON round trip, ROS 2 MultiDOFJointTrajectory, CSV, atomic writes (ABB RAPID:
tests/test_rapid.py).

Tolerances: JSON floats are written with Python's round-tripping repr, so positions and times
come back bit-identical; rotations come back as the same rotation to 1e-12 rad (quaternion
normalization).
"""

from __future__ import annotations

import csv
import json
import os

import numpy as np
import pytest
import yaml
from gripper_paths import curved_hose, turnover_path
from scipy.spatial.transform import Rotation

from dloplan.cable import Cable, catalogue_cable
from dloplan.grippers import gripper_path
from dloplan.io import files
from dloplan.io.export import (
    PLAN_VERSION,
    multi_dof_trajectory_msg,
    plan_document,
    plan_from_document,
    read_plan_json,
    write_plan_json,
    write_ros_trajectory,
    write_trajectory_csv,
)
from dloplan.trajectory import trajectory_from_grippers


@pytest.fixture(scope="module")
def plan():
    cable = curved_hose()
    shapes, _ = turnover_path(cable.rest_shape)
    grippers = gripper_path(shapes, method="minimal", cable=cable)  # twisted: has warnings
    trajectory = trajectory_from_grippers(grippers)
    return cable, shapes, grippers, trajectory


def _same_rotations(a: Rotation, b: Rotation, tol: float = 1e-12) -> bool:
    return len(a) == len(b) and float(np.max((a.inv() * b).magnitude())) < tol


# -- plan JSON -------------------------------------------------------------------------------------
def test_plan_json_round_trips(plan, tmp_path):
    cable, shapes, grippers, trajectory = plan
    extra = {"planner": {"iterations": 12, "costs": np.array([1.5, 0.25])}}
    path = write_plan_json(
        tmp_path / "plan.json", cable, shapes, grippers, trajectory, ["a warning"], extra
    )
    doc = read_plan_json(path)
    assert doc.version == PLAN_VERSION and doc.frame_id == "world"
    for name in (
        "length",
        "diameter",
        "mass",
        "youngs_modulus",
        "poisson_ratio",
        "n_links",
        "bending",
        "masses",
        "damping_ratio",
        "name",
    ):
        assert getattr(doc.cable, name) == getattr(cable, name)
    assert np.array_equal(doc.cable.rest_shape, cable.rest_shape)
    assert doc.cable.is_curved
    assert np.array_equal(doc.shapes, shapes)
    g = doc.grippers
    assert g.method == grippers.method and g.success == grippers.success
    assert g.message == grippers.message and g.warnings == grippers.warnings
    assert np.array_equal(g.positions, grippers.positions)
    assert np.array_equal(g.twist, grippers.twist)
    assert g.max_twist == grippers.max_twist
    for clip in (0, 1):
        assert _same_rotations(g.rotations[clip], grippers.rotations[clip])
    t = doc.trajectory
    assert np.array_equal(t.times, trajectory.times)
    assert np.array_equal(t.positions, trajectory.positions)
    assert t.arm_clips == trajectory.arm_clips
    assert (t.max_speed, t.max_angular_speed) == (
        trajectory.max_speed,
        trajectory.max_angular_speed,
    )
    for arm in (0, 1):
        assert _same_rotations(t.rotations[arm], trajectory.rotations[arm])
    assert doc.warnings == ("a warning",)
    assert doc.extra == {"planner": {"iterations": 12, "costs": [1.5, 0.25]}}
    # a second write of what was read gives the same document
    again = plan_document(
        doc.cable, doc.shapes, doc.grippers, doc.trajectory, doc.warnings, doc.extra
    )
    _assert_same_document(again, json.loads(path.read_text()))


def _assert_same_document(a, b, where="doc"):
    """Equal structure and values; floats equal to 1e-12 (re-normalized quaternions)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), where
        for key in a:
            _assert_same_document(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _assert_same_document(x, y, f"{where}[{i}]")
    elif isinstance(a, float):
        assert b == pytest.approx(a, rel=1e-12, abs=1e-15), where
    else:
        assert a == b, where


def test_plan_json_poses_are_ros_shaped_with_canonical_quaternions(plan):
    doc = plan_document(*plan)
    pose = doc["grippers"]["clips"]["first"][0]
    assert pose["header"] == {"frame_id": "world"}
    assert set(pose["pose"]) == {"position", "orientation"}
    assert set(pose["pose"]["position"]) == set("xyz")
    assert list(pose["pose"]["orientation"]) == ["x", "y", "z", "w"]
    point = doc["trajectory"]["points"][3]
    assert set(point["time_from_start"]) == {"sec", "nanosec"}
    ws = [
        p["pose"]["orientation"]["w"]
        for clip in ("first", "last")
        for p in doc["grippers"]["clips"][clip]
    ]
    assert min(ws) >= 0.0
    assert doc["quaternion_order"] == "xyzw" and doc["units"]["length"] == "m"


def test_plan_without_grippers_and_trajectory_round_trips(plan):
    cable, shapes, _, _ = plan
    doc = plan_from_document(json.loads(json.dumps(plan_document(cable, shapes))))
    assert doc.grippers is None and doc.trajectory is None
    assert np.array_equal(doc.shapes, shapes)
    straight = Cable(length=0.5, diameter=0.003, mass=0.01, youngs_modulus=1e6, n_links=10)
    assert plan_from_document(plan_document(straight, shapes)).cable.rest_shape is None


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda d: d.update(format="other"), "not a 'dloplan-plan' document"),
        (lambda d: d.update(version=PLAN_VERSION + 1), "plan.version"),
        (lambda d: d.pop("shapes"), "plan: missing 'shapes'"),
        (lambda d: d["cable"].update(color="red"), "plan.cable"),
        (lambda d: d["grippers"]["clips"].pop("last"), "grippers.clips: missing 'last'"),
        (
            lambda d: d["grippers"]["clips"]["first"][2]["pose"]["position"].pop("y"),
            r"grippers.clips.first\[2\].pose.position: missing 'y'",
        ),
        (
            lambda d: d["trajectory"]["points"][1]["poses"][0]["header"].update(frame_id="base"),
            "frame_id: got 'base'",
        ),
        (lambda d: d["trajectory"]["points"][1].update(time=-1.0), "times"),
    ],
)
def test_malformed_plan_documents_are_rejected_by_name(plan, edit, match):
    doc = json.loads(json.dumps(plan_document(*plan)))
    edit(doc)
    with pytest.raises(ValueError, match=match):
        plan_from_document(doc)


def test_plan_writer_rejects_pieces_that_do_not_fit(plan, tmp_path):
    cable, shapes, grippers, trajectory = plan
    with pytest.raises(ValueError, match="shapes: 11 points per shape"):
        plan_document(catalogue_cable("usb", n_links=12), shapes)
    with pytest.raises(ValueError, match="grippers: 12 shapes, expected 5"):
        plan_document(cable, shapes[:5], grippers)
    with pytest.raises(ValueError, match="extra: not JSON-serializable"):
        plan_document(cable, shapes, extra={"bad": object()})
    with pytest.raises(ValueError, match="frame_id"):
        plan_document(cable, shapes, frame_id="")
    with pytest.raises(ValueError, match="not valid JSON"):
        bad = tmp_path / "bad.json"
        bad.write_text("{")
        read_plan_json(bad)


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


# -- atomic writes --------------------------------------------------------------------------------
def test_a_failed_write_leaves_no_half_written_file(plan, tmp_path, monkeypatch):
    target = tmp_path / "plan.json"
    target.write_text("old plan")
    with pytest.raises(ValueError):
        write_plan_json(target, plan[0], plan[1], extra={"bad": object()})
    assert target.read_text() == "old plan"

    def broken_fsync(fd):
        raise OSError("disk full")

    monkeypatch.setattr(files.os, "fsync", broken_fsync)
    with pytest.raises(OSError, match="disk full"):
        write_trajectory_csv(target, plan[3])
    assert target.read_text() == "old plan"
    assert os.listdir(tmp_path) == ["plan.json"]
