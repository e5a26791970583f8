"""Readers of the written robot programs, and the check that every planned gripper action is in
them: each program's files are parsed back (RAPID modules, URScript, the ROS 2 trajectories and
action list, the UR pair's streamer and samples) and compared with the plan document's cycle
and the verified joints it records (plan.json ``robot.program.targets``), not with text made by
the writers' code path."""

from __future__ import annotations

import ast
import csv
import re
from pathlib import Path

import numpy as np
import yaml
from robot_plans import read_module

from dloplan.app.writers import WRITERS, program_files
from dloplan.pipeline.document import cycle_actions

CALLS = {"g_GripIn": "close", "g_GripOut": "open"}
HOOKS = {"dloplan_grip_close()": "close", "dloplan_grip_open()": "open"}


def expected_commands(doc) -> list[tuple[int, str, str, float]]:
    """(knot, action, command, wait [s]) of every gripper command of the plan's cycle, in the
    order they run, from the document's cycle section."""
    return [(a.knot, a.name, c, w) for a in cycle_actions(doc.cycle) for c, w in a.commands()]


def knot_joints(doc) -> dict[int, dict[str, np.ndarray]]:
    """Shape (knot) -> arm -> the verified joints [rad] the plan document records there."""
    out = {}
    for target in doc.robot.program["targets"]:
        if target["label"].startswith("shape "):
            out[int(target["label"].split()[1])] = {
                arm: np.radians(values["joints_deg"]) for arm, values in target["arms"].items()}
    return out


# -- RAPID --------------------------------------------------------------------------------------
def rapid_commands(text: str) -> list[tuple[str, str, float]]:
    """(label of the target the arm stands at, command, wait [s]) of every SmartGripper call
    of the motion procedure after the first MoveAbsJ, read from a module; asserts each call is
    preceded by a WaitSyncTask and runs outside synchronized mode."""
    module = read_module(text)
    labels = dict(re.findall(r"CONST robtarget (\w+) := .*?;  ! (.+)$", text, re.M))
    first = sorted(labels)[0]
    body = module["procs"]["dloplan_move"]
    start = next(i for i, line in enumerate(body) if line.startswith("MoveAbsJ dlo_start"))
    where, synced, out = labels[first], False, []
    for i in range(start + 1, len(body)):
        line = body[i]
        if line.startswith("MoveL "):
            assert synced, line
            where = labels[line.split()[1]]
        elif line.startswith("SyncMoveOn"):
            synced = True
        elif line.startswith("SyncMoveOff"):
            synced = False
        call = line.split(";")[0].split(" ")[0].split("\\")[0]
        if call in CALLS:
            assert not synced and body[i - 1].startswith("WaitSyncTask "), body[i - 1:i + 1]
            wait = re.fullmatch(r"WaitTime ([0-9.]+);", body[i + 1])
            assert wait, body[i + 1]
            out.append((where, CALLS[call], float(wait.group(1))))
    return out


def check_rapid(doc, folder: Path) -> None:
    expected = [(f"shape {k}", c, w) for k, _, c, w in expected_commands(doc)]
    modules = sorted(Path(folder).glob("*.mod"))
    assert len(modules) == 2, modules
    for path in modules:
        got = rapid_commands(path.read_text())
        assert [(label, c) for label, c, _ in got] == [(label, c) for label, c, _ in expected], \
            path
        assert np.allclose([w for *_, w in got], [w for *_, w in expected], atol=5e-5), path


# -- URScript -----------------------------------------------------------------------------------
def urscript_commands(text: str) -> tuple[list, list, dict]:
    """Waypoint joints (the start's and every movej's), (waypoint, command, wait) of every hook
    call after the start handshake, and the hooks' bodies."""
    lines = [line.strip() for line in text.splitlines()]
    hooks = {}
    for command in ("close", "open"):
        i = lines.index(f"def dloplan_grip_{command}():")
        hooks[command] = lines[i + 1]
    start = lines.index("end", lines.index(next(x for x in lines if x.startswith("while not"))))
    joints = [ast.literal_eval(re.match(r"movej\((\[.*?\])", next(
        x for x in lines if x.startswith("movej("))).group(1))]
    out = []
    for i in range(start + 1, len(lines)):
        line = lines[i]
        if line.startswith("movej("):
            joints.append(ast.literal_eval(re.match(r"movej\((\[.*?\])", line).group(1)))
        call = line.split("#")[0].strip()
        if call in HOOKS:
            wait = re.fullmatch(r"sleep\(([0-9.]+)\)", lines[i + 1])
            assert wait, lines[i + 1]
            out.append((len(joints) - 1, HOOKS[call], float(wait.group(1))))
    return joints, out, hooks


def check_urscript(doc, folder: Path, gripper: dict) -> None:
    expected = expected_commands(doc)
    joints = knot_joints(doc)
    setter = "set_tool_digital_out" if gripper["tool"] else "set_standard_digital_out"
    for arm in ("left", "right"):
        waypoints, got, hooks = urscript_commands((Path(folder) / f"dloplan_{arm}.script")
                                                  .read_text())
        assert hooks == {c: f"{setter}({gripper['output']}, "
                            f"{gripper['closed'] if c == 'close' else not gripper['closed']})"
                         for c in ("close", "open")}
        assert [(c, w) for _, c, w in got] == pytest_approx([(c, w) for _, _, c, w in expected])
        for (waypoint, _, _), (knot, *_) in zip(got, expected, strict=True):
            assert np.abs(np.asarray(waypoints[waypoint]) - joints[knot][arm]).max() < 1e-8


def pytest_approx(pairs):
    import pytest

    return [(c, pytest.approx(w, abs=1e-9)) for c, w in pairs]


# -- ROS 2 --------------------------------------------------------------------------------------
def read_trajectory(path: Path) -> tuple[np.ndarray, dict]:
    """Times [s] and per field (positions, velocities, accelerations) the (N, J) arrays."""
    message = yaml.safe_load(Path(path).read_text())
    points = message["points"]
    times = np.array([p["time_from_start"]["sec"] + 1e-9 * p["time_from_start"]["nanosec"]
                      for p in points])
    fields = {key: np.array([p[key] for p in points]) for key in points[0]
              if key != "time_from_start"}
    return times, fields


def check_held(times, q, start, wait, joints, what) -> None:
    """The arm stands at ``joints`` over [start, start + wait] (every sample there)."""
    inside = (times >= start - 1e-9) & (times <= start + wait + 1e-9)
    assert inside.sum() >= 2, what
    assert np.abs(q[inside] - joints).max() < 1e-7, what


def check_ros_joints(doc, folder: Path) -> None:
    expected = expected_commands(doc)
    joints = knot_joints(doc)
    rows = yaml.safe_load((Path(folder) / "dloplan_gripper_actions.yaml").read_text())["actions"]
    for arm in ("left", "right"):
        mine = [r for r in rows if r["arm"] == arm]
        assert [(r["knot"], r["action"], r["command"]) for r in mine] == \
            [(k, a, c) for k, a, c, _ in expected]
        assert np.allclose([r["duration"] for r in mine], [w for *_, w in expected], atol=1e-12)
        times, fields = read_trajectory(Path(folder) / f"dloplan_{arm}_joint_trajectory.yaml")
        for r in mine:
            check_held(times, fields["positions"], r["time"], r["duration"],
                       joints[r["knot"]][arm], (arm, r))
        # consecutive commands of one action follow each other
        for a, b in zip(mine, mine[1:], strict=False):
            assert b["time"] >= a["time"] + a["duration"] - 1e-9


# -- the UR pair's streamer ---------------------------------------------------------------------
def stream_settings(path: Path) -> dict:
    """The settings block of a written streamer, evaluated as literals."""
    text = Path(path).read_text()
    block = text.split("# --- settings (written by dloplan) ---\n")[1].split(
        "# --- end of settings ---")[0]
    out = {}
    for node in ast.parse(block).body:
        target = node.targets[0] if isinstance(node, ast.Assign) else node.target
        out[target.id] = ast.literal_eval(node.value)
    return out


def read_samples(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    with open(path, encoding="utf-8") as handle:
        rows = list(csv.reader(x for x in handle if not x.startswith("#")))
    data = np.array(rows[1:], dtype=float)
    return data[:, 0], data[:, 1:7], data[:, 7:]


def check_ur_rtde(doc, folder: Path) -> None:
    expected = expected_commands(doc)
    joints = knot_joints(doc)
    settings = stream_settings(Path(folder) / "dloplan_ur_pair.py")
    actions = settings["ACTIONS"]
    assert [(a, c) for _, c, a, _ in actions] == [(a, c) for _, a, c, _ in expected]
    assert np.allclose([w for *_, w in actions], [w for *_, w in expected], atol=1e-9)
    times, left, right = read_samples(Path(folder) / settings["SAMPLES"])
    assert np.allclose(np.diff(times), 1 / settings["RATE"], atol=1e-9)
    for (t, _, _, wait), (knot, *_) in zip(actions, expected, strict=True):
        for arm, q in (("left", left), ("right", right)):
            check_held(times, q, t, wait, joints[knot][arm], (arm, knot, t))


def check_every_program(doc, out: Path) -> list[str]:
    """Write every program format the document's robot program takes that is not in ``out``
    yet, and check every planned gripper action is in each (parsed back); returns the
    formats checked."""
    from dloplan.pipeline.stages import program_of

    program = program_of(doc)
    for name in program.formats:
        folder = out / WRITERS[name].target
        if not folder.exists():
            program_files(program, folder, name, doc.trajectory, cycle_actions(doc.cycle))
        if name == "rapid":
            check_rapid(doc, folder)
        elif name == "urscript":
            check_urscript(doc, folder, program.cell.writers["urscript"]["gripper"])
        elif name == "ur_rtde":
            check_ur_rtde(doc, folder)
        else:
            check_ros_joints(doc, folder)
    return list(program.formats)
