"""What a controller reads from every example's written program (issue 31): the robtargets
solved back, the joints of the ROS 2 trajectories at the targets, the peak joint speeds of the
written motion, and the YuMi's ``eax_a`` beside the arm angle of the verified joints.

Run: .venv/bin/python benchmarks/bench_controller.py [--before DIR] [EXAMPLE ...]

Every example (examples/*.yaml but identification and study jobs, and examples/cells/*.yaml) is
planned as ``dloplan plan`` plans it (:func:`dloplan.pipeline.make_plan`, repairs without
consent for a move) and its programs are written by the writers of ``dloplan plan``
(:func:`dloplan.app.writers.write_outputs`) into a temporary folder, then read back:

- **RAPID round trip** (the YuMi): each written robtarget (pose in the written work object,
  ``eax_a``, confdata) solved by the controller-semantics IK
  (:func:`dloplan.robot.robtarget.solve_robtarget`, no seed from the plan): the largest joint
  difference [deg] of the solution with the written confdata nearest the verified joints
  (inf: none has it), and how many targets have more than one solution with that confdata.
- **ROS 2 round trip** (every cell): the written trajectory's positions at every target's
  arrival instant against the verified joints [deg].
- **Gripper actions**: the planned commands of the plan's cycle (each action's open / close
  and the wait after it) against those written: RAPID's ``g_GripIn`` / ``g_GripOut`` and the
  ``WaitTime`` after each in every task (after the start move), the ROS 2 action list per arm.
- **Peak joint speed**: per arm the largest |velocity| / limit of the written ROS 2 trajectory
  (sampled at 500 Hz along the time law, the targets' instants added), beside the program
  check's own peak (its ``joint speed`` rows).
- **eax_a** (M2 USB and qualitative-2): per target and arm the written ``eax_a`` [deg] beside
  RobotWare's arm angle of the verified joints (:func:`dloplan.robot.armangle.arm_angle`, the
  cell's reference direction). ``--before DIR`` runs the same on a checkout of main before the
  controller semantics (``git archive e95960b src examples | tar -x -C DIR``; that tree's
  examples, its own writer: ``eax_a`` was ABB axis 7) in a subprocess and computes the arm
  angle of its verified joints as the controller would (today's arm model: ABB's geometry,
  the default cell's reference direction).

The numbers are facts of the programs, not timings; the planning takes minutes on the shared
host.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
EAX_EXAMPLES = ("m2_uniform_curvature_usb.yaml", "qualitative2_ethernet_3d.yaml")
RATE = 500.0
"""[Hz] Sampling of the written ROS 2 trajectories."""

_DECL = re.compile(r"^\s*(?:CONST|PERS) (robtarget|wobjdata) (\w+) := (.*?);", re.M)


def examples(folder: Path) -> list[Path]:
    """The plan and harness examples of ``folder`` and its cells."""
    plain = sorted(p for p in folder.glob("*.yaml")
                   if not p.name.startswith(("identify", "study")))
    return plain + sorted((folder / "cells").glob("*.yaml"))


def plan_document(path: Path):
    """The plan ``dloplan plan`` makes of the example (no placement consent)."""
    from dloplan.app import load_job
    from dloplan.pipeline import make_plan

    return make_plan(load_job(path))


def rapid_literal(text: str):
    """A RAPID aggregate literal as nested lists (its booleans and strings JSON's)."""
    return json.loads(text.replace("TRUE", "true").replace("FALSE", "false"))


def rapid_round_trip(program, folder: Path) -> tuple[float, int]:
    """Largest joint error [deg] of the written robtargets solved as the controller reads them,
    and the number of targets with more than one solution of the written confdata."""
    from scipy.spatial.transform import Rotation

    from dloplan.robot.robtarget import solve_robtarget

    cell = program.cell
    worst, ambiguous = 0.0, 0
    for a, module in enumerate(sorted(folder.glob("*.mod"))):  # DloPlanL, DloPlanR
        decl = {name: (kind, rapid_literal(value))
                for kind, name, value in _DECL.findall(module.read_text())}
        uframe = decl[cell.wobj][1][3]
        w_pos = np.array(uframe[0]) / 1e3
        w_rot = Rotation.from_quat(uframe[1], scalar_first=True)
        targets = sorted(n for n, (kind, _) in decl.items() if kind == "robtarget")
        arm = cell.robot.arms[a]  # in the plan's frame
        for m, name in enumerate(targets):
            trans, quat, conf, extax = decl[name][1]
            p = cell.base_rotation.apply(w_pos + w_rot.apply(np.array(trans) / 1e3)) + \
                cell.base_position
            r = cell.base_rotation * w_rot * Rotation.from_quat(quat, scalar_first=True)
            found = solve_robtarget(arm, p, r.as_matrix(), np.radians(extax[0]), conf)
            worst = max(worst, float(np.degrees(found.deviation(program.joints[a][m]))))
            ambiguous += len(found.matching) > 1
    return worst, ambiguous


def ros_round_trip(doc, program, folder: Path) -> tuple[float, list[float]]:
    """Largest joint error [deg] of the written ROS 2 trajectories at the targets' arrival
    instants, and per arm the peak |velocity| / limit of the written points."""
    import yaml

    from dloplan.pipeline.document import cycle_actions
    from dloplan.robot.actions import program_timeline

    timeline = program_timeline(program, doc.trajectory, cycle_actions(doc.cycle))
    arms = program.cell.robot.arms if hasattr(program.cell, "robot") else program.cell.arms
    joints = program.joints  # the YuMi's (M, 2, 7), a described cell's per arm (K, J)
    verified = list(joints) if isinstance(joints, tuple) else [joints[:, 0], joints[:, 1]]
    worst, peaks = 0.0, []
    for a, side in enumerate(("left", "right")):
        message = yaml.safe_load((folder / f"dloplan_{side}_joint_trajectory.yaml").read_text())
        points = message["points"]
        t = np.array([p["time_from_start"]["sec"] + 1e-9 * p["time_from_start"]["nanosec"]
                      for p in points])
        q = np.array([p["positions"] for p in points])
        v = np.array([p["velocities"] for p in points])
        at = np.abs(t[:, None] - timeline.clock.arrive[None]).argmin(axis=0)
        worst = max(worst, float(np.degrees(np.abs(q[at] - verified[a]).max())))
        peaks.append(float((np.abs(v) / arms[a].max_velocity).max()))
    return worst, peaks


def planned_commands(doc) -> list:
    """The plan's gripper commands in order: (open | close, wait [s])."""
    from dloplan.pipeline.document import cycle_actions

    return [(command, round(wait, 3)) for action in cycle_actions(doc.cycle)
            for command, wait in action.commands()]


def rapid_commands(folder: Path) -> list[list]:
    """Per task the gripper commands written after the start move: (open | close, the
    ``WaitTime`` after it [s])."""
    out = []
    for module in sorted(folder.glob("*.mod")):
        body = module.read_text().split("MoveAbsJ", 1)[1]
        calls = re.findall(r"g_Grip(In|Out)\b[^;]*;[^\n]*\n\s*WaitTime ([0-9.]+);", body)
        out.append([("close" if c == "In" else "open", round(float(w), 3)) for c, w in calls])
    return out


def ros_commands(folder: Path) -> list[list]:
    """Per arm the commands of the written ROS 2 action list: (command, duration [s])."""
    import yaml

    rows = yaml.safe_load((folder / "dloplan_gripper_actions.yaml").read_text())["actions"]
    return [[(r["command"], round(r["duration"], 3)) for r in rows if r["arm"] == side]
            for side in ("left", "right")]


def checked_peaks(program) -> list[float]:
    """Per arm the program check's own largest peak joint speed (its ``joint speed`` rows)."""
    names = [r.arm for r in program.checks if r.check == "joint speed"]
    arms = list(dict.fromkeys(names))
    return [max(r.value for r in program.checks if r.check == "joint speed" and r.arm == arm)
            for arm in arms]


def eax_beside_arm_angle(program) -> tuple[np.ndarray, np.ndarray]:
    """(M, 2) written eax_a [deg] and (M, 2) arm angle of the verified joints [deg]."""
    from dloplan.robot.armangle import arm_angle

    psi = np.stack([arm_angle(arm, program.joints[a])
                    for a, arm in enumerate(program.cell.arms)], axis=1)
    return np.asarray(program.targets.arm_angles), np.degrees(psi)


def wrapped(deg) -> np.ndarray:
    """Angles [deg] in (-180, 180]."""
    return 180.0 - np.mod(180.0 - np.asarray(deg, dtype=float), 360.0)


def print_eax(name: str, written, psi) -> None:
    diff = np.abs(wrapped(written - psi))
    print(f"  eax_a of {name}: largest |eax_a - arm angle| {diff.max():.3f} deg over "
          f"{diff.size} targets")
    print("    target   left eax_a  arm angle    right eax_a  arm angle")
    for m in range(len(written)):
        print(f"    {m:6d}  {written[m, 0]:10.3f} {psi[m, 0]:10.3f}   {written[m, 1]:10.3f} "
              f"{psi[m, 1]:10.3f}")


def after(paths) -> None:
    from dloplan.app.writers import write_outputs

    for path in paths:
        print(f"{path.relative_to(ROOT)}:")
        doc = plan_document(path)
        program = doc.program
        if program is None:
            print("  no robot program")
            continue
        print(f"  program ok {program.ok}: {program.message}")
        formats = ("rapid", "ros_joints") if "rapid" in program.formats else ("ros_joints",)
        with tempfile.TemporaryDirectory() as tmp:
            try:
                write_outputs(doc, tmp, formats)
            except ValueError as exc:
                print(f"  not written: {exc}")
                continue
            planned = planned_commands(doc)
            written = ros_commands(Path(tmp) / "ros_joints")
            if "rapid" in formats:
                worst, ambiguous = rapid_round_trip(program, Path(tmp) / "rapid")
                print(f"  RAPID round trip: largest joint error {worst:.4f} deg; "
                      f"{ambiguous} targets with another solution of the written confdata")
                written += rapid_commands(Path(tmp) / "rapid")
            worst, peaks = ros_round_trip(doc, program, Path(tmp) / "ros_joints")
        same = all(w == planned for w in written)
        print(f"  gripper actions: {len(planned)} planned commands {planned}; written "
              f"{'the same in every program and arm' if same else written}")
        print(f"  ROS 2 round trip: largest joint error at the targets {worst:.2e} deg")
        print("  peak joint speed / limit (written, sampled at "
              f"{RATE:.0f} Hz): left {peaks[0]:.3f}, right {peaks[1]:.3f}; the check's: "
              + ", ".join(f"{p:.3f}" for p in checked_peaks(program)))
        if path.name in EAX_EXAMPLES:
            print_eax(path.name, *eax_beside_arm_angle(program))


def dump_before(paths) -> None:
    """(In the before tree) the written eax_a and the verified joints of each example, JSON."""
    out = {}
    for path in paths:
        program = plan_document(path).program
        out[path.name] = {"eax": np.asarray(program.targets.arm_angles).tolist(),
                          "joints": np.asarray(program.joints).tolist()}
    print(json.dumps(out))


def before(folder: Path) -> None:
    from dloplan.robot import RobotCell

    env = dict(os.environ, PYTHONPATH=str(folder / "src"))
    paths = [str(folder / "examples" / name) for name in EAX_EXAMPLES]
    text = subprocess.run([sys.executable, __file__, "--dump", *paths], env=env, cwd=folder,
                          check=True, capture_output=True, text=True).stdout
    data = json.loads(text.strip().splitlines()[-1])
    from dloplan.robot.armangle import arm_angle

    arms = RobotCell().robot.arms
    for name in EAX_EXAMPLES:
        joints = np.array(data[name]["joints"])
        psi = np.degrees(np.stack([arm_angle(arm, joints[:, a]) for a, arm in enumerate(arms)],
                                  axis=1))
        print(f"before ({folder}):")
        print_eax(name, np.array(data[name]["eax"]), psi)


def main(argv) -> None:
    if argv[:1] == ["--dump"]:
        dump_before([Path(p) for p in argv[1:]])
        return
    if argv[:1] == ["--before"]:
        before(Path(argv[1]).resolve())
        argv = argv[2:]
    chosen = [p for p in examples(ROOT / "examples")
              if not argv or p.name in argv or p.stem in argv]
    after(chosen)


if __name__ == "__main__":
    main(sys.argv[1:])
