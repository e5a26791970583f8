"""Exports: ROS 2 MultiDOFJointTrajectory, CSV, atomic writes (ABB RAPID: tests/test_rapid.py).

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
from gripper_paths import turned_hose_plan
from scipy.spatial.transform import Rotation

from dloplan import output_files as files
from dloplan.io.export import (
    multi_dof_trajectory_msg,
    write_ros_trajectory,
    write_trajectory_csv,
)

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_export")


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


def test_a_knot_where_nothing_moves_is_one_point_of_strictly_increasing_time():
    """Two equal consecutive poses (a job whose start is its target plans a path out and back
    through one repeated shape) make a segment of zero duration; a trajectory controller
    refuses points whose times do not increase strictly (the knots were written at 57.4 ms
    twice)."""
    from dloplan.trajectory import dual_arm_trajectory

    positions = np.array([[[0.40, 0.10, 0.20], [0.40, -0.10, 0.20]],
                          [[0.40, 0.10, 0.25], [0.40, -0.10, 0.25]],
                          [[0.40, 0.10, 0.25], [0.40, -0.10, 0.25]],
                          [[0.40, 0.10, 0.20], [0.40, -0.10, 0.20]]])
    turn = Rotation.from_euler("x", [[0.0], [10.0], [10.0], [0.0]], degrees=True)
    trajectory = dual_arm_trajectory(positions, (turn, turn))
    assert trajectory.times[2] == trajectory.times[1]   # the law's repeated knot
    msg = multi_dof_trajectory_msg(trajectory)
    stamps = [p["time_from_start"]["sec"] * 10**9 + p["time_from_start"]["nanosec"]
              for p in msg["points"]]
    assert len(stamps) == 3 and np.all(np.diff(stamps) > 0)
    assert [p["transforms"][0]["translation"]["z"] for p in msg["points"]] == [0.20, 0.25, 0.20]


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
        write_trajectory_csv(target, plan[3], rate=float("nan"))
    assert target.read_text() == "old plan"

    def broken_fsync(fd):
        raise OSError("disk full")

    monkeypatch.setattr(files.os, "fsync", broken_fsync)
    with pytest.raises(OSError, match="disk full"):
        write_trajectory_csv(target, plan[3])
    assert target.read_text() == "old plan"
    assert os.listdir(tmp_path) == ["plan.json"]
