"""A plan verified on a described cell: the cell section of a scenario, verify_on_cell on a
timed trajectory, and the example runner end to end (programs read back = verified)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from dloplan.robot.chain import forward
from dloplan.robot.urdf_cell import (
    PANDA_TCP_IN_CLIP,
    cell_from_mapping,
    panda_pair,
    ur5e_pair,
    verify_on_cell,
)
from dloplan.trajectory import dual_arm_trajectory

pytest.importorskip("yourdfpy")

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples" / "cells"


def _clip_trajectory(swap=False):
    """Clips of a cable held at both ends (clip frames: u along the cable, w up), timed."""
    n = 5
    pos = np.zeros((n, 2, 3))
    for k, t in enumerate(np.linspace(0, 1, n)):
        pos[k, 0] = [0.45, -0.2 + 0.05 * t, 0.1 + 0.05 * t]  # clip 0 on the robot's right
        pos[k, 1] = [0.45, 0.2 - 0.05 * t, 0.1 + 0.05 * t]
    clip = Rotation.from_matrix(np.tile(np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0],
                                                  [0.0, 0.0, 1.0]]), (n, 1, 1)))
    if swap:
        pos = pos[:, ::-1]
    return dual_arm_trajectory(pos, (clip, clip))


def test_verify_on_cell_assigns_by_side_and_uses_each_arms_grip():
    cell = ur5e_pair()
    plan = verify_on_cell(cell, _clip_trajectory(), place=False)
    assert plan.swapped  # clip 0 lies on the robot's right: it goes to the right arm
    assert plan.verdict.ok, plan.verdict.message
    assert np.all(plan.positions[:, 0, 1] > 0)  # left arm's TCP on the left
    np.testing.assert_allclose(plan.times, _clip_trajectory().times)
    same = verify_on_cell(cell, _clip_trajectory(swap=True), place=False)
    assert not same.swapped
    np.testing.assert_allclose(same.positions, plan.positions)
    # The verified joints hold the TCP at the clip with the arm's grip.
    p, r = forward(cell.left, plan.verdict.joints[0])
    np.testing.assert_allclose(p, plan.positions[:, 0], atol=1e-4)
    panda = verify_on_cell(panda_pair(), _clip_trajectory(), place=False)
    tcp_x = panda.rotations.as_matrix().reshape(-1, 2, 3, 3)[:, 0, :, 0]
    np.testing.assert_allclose(np.abs(tcp_x[:, 1]), 1.0, atol=1e-12)  # the cable's direction
    assert PANDA_TCP_IN_CLIP.as_matrix()[0, 0] == 1.0


def test_base_poses_are_the_tcp_in_each_arm_base_frame():
    cell = ur5e_pair()
    plan = verify_on_cell(cell, _clip_trajectory(), place=False)
    positions, rotvecs = plan.base_poses()
    for a, arm in enumerate(cell.arms):
        back = arm.base_rotation.apply(positions[:, a]) + arm.base_position
        np.testing.assert_allclose(back, plan.positions[:, a], atol=1e-12)
        assert np.all(np.linalg.norm(rotvecs[:, a], axis=1) <= np.pi + 1e-12)


def test_cell_from_mapping_presets_paths_and_errors():
    assert cell_from_mapping({"preset": "ur5e_pair", "separation": 1.0}).left.base_position[1] \
        == pytest.approx(0.5)
    data = yaml.safe_load((EXAMPLES / "panda_pair_ethernet.yaml").read_text())["robot"]["cell"]
    cell = cell_from_mapping(data, EXAMPLES)
    preset = panda_pair(separation=1.0)
    q = preset.left.home
    for a in range(2):
        np.testing.assert_allclose(forward(cell.arms[a], q)[0], forward(preset.arms[a], q)[0],
                                   atol=1e-12)
        np.testing.assert_allclose(cell.arms[a].tcp_in_clip.as_matrix(),
                                   PANDA_TCP_IN_CLIP.as_matrix())
    with pytest.raises(ValueError, match="robot.cell.preset"):
        cell_from_mapping({"preset": "kuka"})
    with pytest.raises(ValueError, match="separation"):
        cell_from_mapping({"preset": "ur5e_pair", "spacing": 1.0})
    with pytest.raises(ValueError, match=r"robot.cell.arms.left"):
        cell_from_mapping({"arms": {"left": {"urdf": "x.urdf"}, "right": {}}})
    bad = {"arms": {side: dict(data["arms"][side]) for side in ("left", "right")}}
    bad["arms"]["right"]["cable_along"] = "z"
    with pytest.raises(ValueError, match="cable_along"):
        cell_from_mapping(bad, EXAMPLES)
    with pytest.raises(ValueError, match="robot.cell"):
        cell_from_mapping({"arms": {"left": {}}})


@pytest.mark.slow
def test_ur5e_example_runs_end_to_end_and_programs_read_back(tmp_path):
    sys.path.insert(0, str(EXAMPLES))
    try:
        import run_cell
    finally:
        sys.path.remove(str(EXAMPLES))
    from test_urscript import parse_urscript

    assert run_cell.main([str(EXAMPLES / "ur5e_pair_usb.yaml"), "-o", str(tmp_path)]) == 0
    verdict = json.loads((tmp_path / "cell_verdict.json").read_text())
    assert verdict["ok"] and {row["check"] for row in verdict["rows"]} >= {"clearance",
                                                                           "continuity"}
    for arm in ("left", "right"):
        moves = parse_urscript((tmp_path / f"dloplan_{arm}.script").read_text())["moves"]
        message = yaml.safe_load((tmp_path / f"dloplan_{arm}_joint_trajectory.yaml").read_text())
        ros = np.array([p["positions"] for p in message["points"]])
        np.testing.assert_allclose(np.array([m[1] for m in moves]), ros, atol=1e-9)
    assert (tmp_path / "plan.json").is_file()


def test_ros_joints_writer_of_a_plan_document_is_the_verified_yumi_program(tmp_path):
    """The registry's ros_joints writer: per YuMi arm the verified joints at the target times."""
    from robot_plans import EXAMPLES as PLANS

    from dloplan.app import WRITERS, load_scenario, run_job

    doc = run_job(load_scenario(PLANS / "m2_uniform_curvature_usb.yaml"))
    program = doc.program
    assert program is not None and program.ok, program.message
    files = WRITERS["ros_joints"].write(doc, tmp_path / "ros_joints", None)
    assert [f.name for f in files] == ["dloplan_left_joint_trajectory.yaml",
                                       "dloplan_right_joint_trajectory.yaml"]
    for a, path in enumerate(files):
        message = yaml.safe_load(path.read_text())
        assert message["joint_names"] == list(program.cell.robot.arms[a].joint_names)
        np.testing.assert_array_equal([p["positions"] for p in message["points"]],
                                      program.joints[:, a])
        stamps = [p["time_from_start"]["sec"] + 1e-9 * p["time_from_start"]["nanosec"]
                  for p in message["points"]]
        np.testing.assert_allclose(stamps, program.times, atol=1e-9)
