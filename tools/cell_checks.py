"""Checks of the unseen-case sweep's third round (``tools/unseen_sweep.py``, ``--only r3/``) on the
programs of a described cell (two UR5e, two Panda), read the way their controllers read them.

Nothing here uses dloplan's kinematics: each arm's forward kinematics is the vendor's published
table (Universal Robots' DH parameters of the UR5e; Franka's modified DH parameters of the Panda
with its flange and hand), and the limits are the vendor's published numbers. What is taken from
the plan document is what the user installs: where each base stands (``robot.cell``), the TCP
offset, the placement offset the programs' headers name. :func:`cell_problems` reads

* the URScript programs (``urscript/*.script``): every ``movej``'s joints (or ``movel``'s pose
  in the arm's base frame) against the plan's TCP at that waypoint; each ``movej``'s average
  joint speed ``|dq| / t`` against the limit; every blend radius against half of the TCP
  segments it joins (UR's controller does not blend across overlapping radii) and, where it is
  not zero, the corner it cuts;
* the PC streamer's samples (``ur_rtde/*.csv``) and the ROS 2 trajectories
  (``ros_joints/*.yaml``): the joint names and order (the vendor description's names after the
  prefix), the TCP at every sample against the plan's trajectory (``trajectory.csv`` moved by
  the placement, its clock stopped over the gripper actions), the TCP's orientation at every
  target, and the joint speeds and accelerations by finite differences (and the ROS files' own
  velocities and accelerations) against the vendor's limits;
* the descriptions' limits against the vendor's (:data:`VENDOR`).
"""

from __future__ import annotations

import ast
import csv
import json
import re
import sys
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
# the tests' readers of the written programs: one reader of each format
from program_readers import read_samples, read_trajectory, stream_settings  # noqa: E402

TCP_TOLERANCE = 1e-4
"""A waypoint's TCP within 0.1 mm of the plan's [m] (9 decimals written)."""
ANGLE_TOLERANCE = 1e-3
"""A waypoint's TCP orientation within 1 mrad of the plan's [rad]."""
PATH_TOLERANCE = 1e-3
"""Every sample's TCP within 1 mm of the plan's trajectory at that time [m] (docs/cells.md: the
sampled joints keep the TCP within 0.5 mm of the planned path; the plan's trajectory is
interpolated linearly between its 50 Hz rows)."""

UR5E_DH = {"d": (0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996),
           "a": (0.0, -0.425, -0.3922, 0.0, 0.0, 0.0),
           "alpha": (np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0)}
"""Universal Robots, "DH parameters for calculations of kinematics and dynamics" (UR5e): the
controller's ``base`` to ``tool0`` (standard DH)."""
PANDA_MDH = {"a": (0.0, 0.0, 0.0, 0.0825, -0.0825, 0.0, 0.088),
             "d": (0.333, 0.0, 0.316, 0.0, 0.384, 0.0, 0.0),
             "alpha": (0.0, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2)}
"""Franka Emika, "Robot and interface specifications", Denavit-Hartenberg parameters (Craig's
convention), ``panda_link0`` to joint 7; the flange is 0.107 m along z and the hand turned by
-pi/4 about it."""
VENDOR = {
    "ur5e": {"joints": ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                        "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"),
             "velocity": (np.pi,) * 6, "acceleration": None, "jerk": None,
             "lower": (-2 * np.pi, -2 * np.pi, -np.pi, -2 * np.pi, -2 * np.pi, -2 * np.pi),
             "upper": (2 * np.pi, 2 * np.pi, np.pi, 2 * np.pi, 2 * np.pi, 2 * np.pi)},
    "panda": {"joints": tuple(f"panda_joint{k}" for k in range(1, 8)),
              "velocity": (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61),
              "acceleration": (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0),
              "jerk": (7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0),
              "lower": (-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973),
              "upper": (2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973)},
}
"""Published limits [rad, rad/s, rad/s^2]: UR5e technical specifications (180 deg/s every joint,
+-360 deg; ``ur_description``'s ``joint_limits.yaml`` keeps the elbow within +-180 deg, no
acceleration limit published); Franka's FCI limits (q_min/q_max, dq_max, ddq_max, dddq_max)."""


def _dh(theta, d, a, alpha):
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],
                     [0, sa, ca, d], [0, 0, 0, 1]])


def _mdh(theta, d, a, alpha):
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st, 0, a], [st * ca, ct * ca, -sa, -d * sa],
                     [st * sa, ct * sa, ca, d * ca], [0, 0, 0, 1]])


def vendor_fk(kind: str, q) -> np.ndarray:
    """(4, 4) the flange (UR5e ``tool0``; the Panda's hand) in the arm's base frame for joints
    ``q`` [rad], from the vendor's tables alone."""
    t = np.eye(4)
    if kind == "ur5e":
        for k, qk in enumerate(q):
            t = t @ _dh(qk, UR5E_DH["d"][k], UR5E_DH["a"][k], UR5E_DH["alpha"][k])
        return t
    for k, qk in enumerate(q):
        t = t @ _mdh(qk, PANDA_MDH["d"][k], PANDA_MDH["a"][k], PANDA_MDH["alpha"][k])
    hand = np.eye(4)
    hand[:3, :3] = Rotation.from_euler("z", -np.pi / 4).as_matrix()
    hand[2, 3] = 0.107
    return t @ hand


class Cell:
    """The installed cell as the plan document records it: per arm the base pose in the world,
    the TCP offset on the flange, the vendor's arm; the placement that moves the plan's
    trajectory to where the programs run it."""

    def __init__(self, data: dict, doc):
        from dloplan.pipeline.document import document_cell

        self.data = data
        self.cell = document_cell(doc)
        self.arms = {}
        for arm in self.cell.arms:
            n = len(arm.description.lower)
            kind = {6: "ur5e", 7: "panda"}.get(n)
            self.arms[arm.name] = {"kind": kind, "arm": arm,
                                   "base_position": np.asarray(arm.base_position, float),
                                   "base_rotation": arm.base_rotation,
                                   "tcp": np.asarray(arm.tcp_offset, float),
                                   "tcp_rotation": arm.tcp_rotation}
        placement = data.get("placement") or {}
        self.offset = np.asarray(placement.get("offset", data["robot"]["program"]["offset"]),
                                 float)
        self.yaw = float(placement.get("yaw", 0.0))
        self.pivot = np.asarray(placement.get("pivot", (0.0, 0.0, 0.0)), float)

    def tcp_world(self, side: str, q) -> tuple[np.ndarray, Rotation]:
        """The TCP of arm ``side`` at joints ``q`` in the world [m]: vendor FK, the cell's base."""
        arm = self.arms[side]
        flange = vendor_fk(arm["kind"], q)
        p_base = flange[:3, :3] @ arm["tcp"] + flange[:3, 3]
        r_base = Rotation.from_matrix(flange[:3, :3]) * arm["tcp_rotation"]
        return (arm["base_rotation"].apply(p_base) + arm["base_position"],
                arm["base_rotation"] * r_base)

    def moved(self, points: np.ndarray) -> np.ndarray:
        """The plan's trajectory points (..., 3) where the placement puts them [m]."""
        turn = Rotation.from_euler("z", self.yaw)
        return turn.apply(points.reshape(-1, 3) - self.pivot).reshape(points.shape) \
            + self.pivot + self.offset


def _cell(folder: Path) -> Cell:
    from dloplan.app.document_file import read_plan

    data = json.loads((folder / "plan.json").read_text())
    return Cell(data, read_plan(folder / "plan.json"))


def _targets(data: dict) -> list[dict]:
    return data["robot"]["program"]["targets"]


def _plan_trajectory(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    """(T,) times [s] and (T, 2, 3) left and right TCP positions of ``trajectory.csv``."""
    rows = [r for r in csv.reader(line for line in (folder / "trajectory.csv").open()
                                  if not line.startswith("#"))]
    data = np.array(rows[1:], dtype=float)
    return data[:, 0], np.stack([data[:, 1:4], data[:, 8:11]], axis=1)


def _plan_time(times: np.ndarray, holds: list[tuple[float, float]]) -> np.ndarray:
    """The plan's clock at program times ``times``: the program's clock stands still over each
    ``(start, duration)`` hold of the gripper actions."""
    out = times.astype(float).copy()
    for start, duration in holds:
        out -= np.clip(times - start, 0.0, duration)
    return out


def _check_limits(kind: str, arm, side: str) -> list[str]:
    vendor = VENDOR[kind]
    problems = []
    desc = arm.description
    for name, ours, theirs in (("velocity", desc.max_velocity, vendor["velocity"]),
                               ("lower limit", desc.lower, vendor["lower"]),
                               ("upper limit", desc.upper, vendor["upper"])):
        ours = np.asarray(ours, float)
        if np.abs(ours - np.asarray(theirs)).max() > 1e-3:
            problems.append(f"{side} {kind}: joint {name}s {np.round(ours, 4).tolist()}, the "
                            f"vendor's {np.round(theirs, 4).tolist()}")
    if vendor["acceleration"] is not None:
        ours = getattr(arm, "max_acceleration", None)
        if ours is None or np.abs(np.asarray(ours) - vendor["acceleration"]).max() > 1e-3:
            problems.append(f"{side} {kind}: joint accelerations {ours}, the vendor's "
                            f"{vendor['acceleration']}")
    return problems


def _knot_pose_problems(cell: Cell, side: str, where: str, q, target: dict) -> list[str]:
    p, r = cell.tcp_world(side, q)
    want = np.asarray(target["arms"][side]["position"], float)
    problems = []
    if np.linalg.norm(p - want) > TCP_TOLERANCE:
        problems.append(f"{where}: TCP at {np.round(p, 5).tolist()} m, the plan's at "
                        f"{np.round(want, 5).tolist()} ({np.linalg.norm(p - want) * 1e3:.2f} mm)")
    angle = (Rotation.from_rotvec(target["arms"][side]["rotvec"]).inv() * r).magnitude()
    if angle > ANGLE_TOLERANCE:
        problems.append(f"{where}: TCP turned {np.degrees(angle):.3f} deg from the plan's")
    return problems


def _urscript_problems(cell: Cell, folder: Path, data: dict) -> list[str]:
    problems = []
    targets = _targets(data)
    knots = [t for t in targets if t["label"].startswith("shape ")]
    for side, arm in cell.arms.items():
        path = folder / "urscript" / f"dloplan_{side}.script"
        text = path.read_text()
        tcp = re.search(r"set_tcp\(p(\[.*?\])\)", text)
        if tcp and np.abs(np.asarray(ast.literal_eval(tcp.group(1)))
                          - np.r_[arm["tcp"], 0, 0, 0]).max() > 1e-9:
            problems.append(f"urscript {side}: set_tcp {tcp.group(1)}, the cell's TCP "
                            f"{arm['tcp'].tolist()}")
        moves = re.findall(r"^\s*(movej|movel)\((p?\[.*?\]), (.*)\)$", text, re.M)
        if len(moves) != len(knots):
            problems.append(f"urscript {side}: {len(moves)} moves, the plan has {len(knots)} "
                            f"waypoints")
            continue
        previous = None
        radii, points = [], []
        for k, ((command, values, rest), target) in enumerate(zip(moves, knots, strict=True)):
            where = f"urscript {side} waypoint {k}"
            if command == "movej":
                q = np.asarray(ast.literal_eval(values))
                problems += _knot_pose_problems(cell, side, where, q, target)
                points.append(cell.tcp_world(side, q)[0])
                t = re.search(r"t=([\d.]+)", rest)
                if previous is not None and t:
                    rate = np.abs(q - previous) / float(t.group(1))
                    ratio = (rate / np.asarray(VENDOR[arm["kind"]]["velocity"])).max()
                    if ratio > 1.0:
                        problems.append(f"{where}: movej averages {ratio:.0%} of a joint's "
                                        f"speed limit")
                previous = q
            else:
                pose = np.asarray(ast.literal_eval(values[1:]))
                p = arm["base_rotation"].apply(pose[:3]) + arm["base_position"]
                r = arm["base_rotation"] * Rotation.from_rotvec(pose[3:])
                want = np.asarray(target["arms"][side]["position"], float)
                if np.linalg.norm(p - want) > TCP_TOLERANCE:
                    problems.append(f"{where}: movel pose at {np.round(p, 5).tolist()} m, the "
                                    f"plan's TCP at {np.round(want, 5).tolist()}")
                angle = (Rotation.from_rotvec(target["arms"][side]["rotvec"]).inv()
                         * r).magnitude()
                if angle > ANGLE_TOLERANCE:
                    problems.append(f"{where}: movel pose turned {np.degrees(angle):.3f} deg "
                                    f"from the plan's")
                points.append(p)
            radius = re.search(r"r=([\d.]+)", rest)
            radii.append(float(radius.group(1)) if radius else 0.0)
        points = np.asarray(points)
        segments = np.linalg.norm(np.diff(points, axis=0), axis=1)
        for k in range(1, len(points) - 1):
            if radii[k] > 0 and radii[k] > min(segments[k - 1], segments[k]) / 2 + 1e-9:
                problems.append(f"urscript {side} waypoint {k}: blend radius "
                                f"{radii[k] * 1e3:.1f} mm over half of its segments "
                                f"({segments[k - 1] * 1e3:.1f}, {segments[k] * 1e3:.1f} mm): "
                                f"overlapping blends")
                break
    return problems


def _sampled_problems(cell: Cell, folder: Path, data: dict, label: str, times: np.ndarray,
                      joints: dict[str, np.ndarray], holds, velocities=None,
                      accelerations=None) -> list[str]:
    """The TCP along a sampled program and its joint rates (``joints``: side -> (N, J))."""
    problems = []
    plan_t, plan_p = _plan_trajectory(folder)
    at = _plan_time(times, holds)
    sides = list(cell.arms)
    dt = np.diff(times)
    for a, side in enumerate(sides):
        arm = cell.arms[side]
        q = joints[side]
        tcp = np.array([cell.tcp_world(side, qk)[0] for qk in q])
        want = cell.moved(np.column_stack([np.interp(at, plan_t, plan_p[:, a, k])
                                           for k in range(3)]))
        gap = np.linalg.norm(tcp - want, axis=1)
        if gap.max() > PATH_TOLERANCE:
            k = int(gap.argmax())
            problems.append(f"{label} {side}: TCP {gap.max() * 1e3:.2f} mm from the plan's "
                            f"trajectory at t = {times[k]:.3f} s")
        for target in _targets(data):
            time = target.get("time")
            if time is None:
                continue
            k = int(np.argmin(np.abs(at - time)))
            if abs(at[k] - time) < 1e-6:
                problems += _knot_pose_problems(cell, side, f"{label} {side} "
                                                f"{target['label']}", q[k], target)
        vendor = VENDOR[arm["kind"]]
        speed = np.abs(np.diff(q, axis=0)) / dt[:, None]
        ratio = (speed / np.asarray(vendor["velocity"])).max()
        if ratio > 1.0:
            problems.append(f"{label} {side}: joint speed {ratio:.0%} of the vendor's limit "
                            f"(finite differences)")
        if velocities is not None:
            v = velocities[side]
            mid = 0.5 * (v[1:] + v[:-1])
            diff = np.abs(mid * dt[:, None] - np.diff(q, axis=0)).max()
            if diff > 1e-4:
                problems.append(f"{label} {side}: velocities disagree with the positions by "
                                f"{diff:.1e} rad a step")
            ratio = (np.abs(v) / np.asarray(vendor["velocity"])).max()
            if ratio > 1.0:
                problems.append(f"{label} {side}: velocities {ratio:.0%} of the vendor's limit")
        if vendor["acceleration"] is not None:
            acc = np.abs(np.diff(q, 2, axis=0)) / (dt[1:, None] * dt[:-1, None])
            if accelerations is not None:
                acc = np.abs(accelerations[side])
            ratio = (acc / np.asarray(vendor["acceleration"])).max()
            if ratio > 1.0:
                problems.append(f"{label} {side}: joint acceleration {ratio:.0%} of the "
                                f"vendor's limit")
        if vendor["jerk"] is not None and accelerations is not None:
            jerk = np.abs(np.diff(accelerations[side], axis=0)) / dt[:, None]
            ratio = (jerk / np.asarray(vendor["jerk"])).max()
            if ratio > 1.0:
                k = int(np.argmax((jerk / np.asarray(vendor["jerk"])).max(axis=1)))
                problems.append(f"{label} {side}: joint jerk {ratio:.0%} of the vendor's limit "
                                f"at t = {times[k]:.3f} s")
    return problems


def _ros_problems(cell: Cell, folder: Path, data: dict) -> list[str]:
    problems = []
    actions = yaml.safe_load((folder / "ros_joints" / "dloplan_gripper_actions.yaml")
                             .read_text())["actions"]
    holds = sorted({(a["time"], a["duration"]) for a in actions if a["arm"] == "left"})
    prefixes = data["robot"]["cell"]["writers"]["ros_joints"].get("joint_prefix") or ["", ""]
    times, joints, vel, acc = None, {}, {}, {}
    for a, (side, arm) in enumerate(cell.arms.items()):
        path = folder / "ros_joints" / f"dloplan_{side}_joint_trajectory.yaml"
        written = yaml.safe_load(path.read_text())["joint_names"]
        names = [f"{prefixes[a]}{n}" for n in VENDOR[arm["kind"]]["joints"]]
        if written != names:
            problems.append(f"ros {side}: joint_names {written}, the controller's {names}")
        times, fields = read_trajectory(path)
        joints[side] = fields["positions"]
        if "velocities" in fields:
            vel[side], acc[side] = fields["velocities"], fields["accelerations"]
    return problems + _sampled_problems(cell, folder, data, "ros", times, joints, holds,
                                        vel or None, acc or None)


def _rtde_problems(cell: Cell, folder: Path, data: dict) -> list[str]:
    settings = stream_settings(folder / "ur_rtde" / "dloplan_ur_pair.py")
    holds = sorted({(t, wait) for t, *_, wait in settings["ACTIONS"]})
    times, left, right = read_samples(folder / "ur_rtde" / settings["SAMPLES"])
    return _sampled_problems(cell, folder, data, "ur_rtde", times, {"left": left,
                                                                    "right": right}, holds)


def cell_problems(folder: Path) -> list[str]:
    """What in a described cell's programs in ``folder`` disagrees with ``folder/plan.json``
    or the vendor's published kinematics and limits (see the module); empty when they agree."""
    folder = Path(folder)
    data = json.loads((folder / "plan.json").read_text())
    cell = _cell(folder)
    problems = []
    for side, arm in cell.arms.items():
        if arm["kind"] is None:
            return [f"{side}: no vendor table for a {len(arm['arm'].description.lower)}-joint "
                    f"arm"]
        problems += _check_limits(arm["kind"], arm["arm"], side)
        for target in _targets(data):
            q = np.radians(target["arms"][side]["joints_deg"])
            problems += _knot_pose_problems(cell, side, f"plan.json {side} {target['label']}",
                                            q, target)
    if (folder / "urscript").is_dir():
        problems += _urscript_problems(cell, folder, data)
    if (folder / "ur_rtde").is_dir():
        problems += _rtde_problems(cell, folder, data)
    if (folder / "ros_joints").is_dir():
        problems += _ros_problems(cell, folder, data)
    return problems
