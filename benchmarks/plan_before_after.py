"""Behaviour kept across a refactoring: every example planned by two versions of dloplan, compared.

Run (from the repository root)::

    git archive BASE | tar -x -C /tmp/base          # the old code and its examples
    python benchmarks/plan_before_after.py run old --src /tmp/base/src --examples /tmp/base/examples
    python benchmarks/plan_before_after.py run new --src src --examples examples
    python benchmarks/plan_before_after.py compare old new

``run`` plans every job file of ``EXAMPLES`` and ``EXAMPLES/cells`` with ``dloplan plan FILE``
(and the embedded ``dloplan demo``), each in a fresh interpreter whose ``dloplan`` is the one in
``SRC`` (PYTHONPATH), into ``--out/LABEL/NAME/`` (default /tmp/plan_before_after), and records
the exit code. Identification files are skipped (no job to plan). Extra command-line options for
``dloplan plan`` follow ``--``.

``compare`` reads both folders and prints, per example, the exit codes and the largest
difference of

* the planned and the stabilized shapes, the gripper positions [m] and frames (quaternions),
  the trajectory's knot times [s] and poses (``plan.json``);
* the robot program as recorded in ``plan.json`` (``robot.program``: every target's joints
  [deg]; its check rows and message, compared as they are: the first differing row is shown)
  and the program files written (``rapid/``, ``urscript/``, ``ur_rtde/``, ``ros_joints/``,
  ``trajectory.csv``, ``trajectory.yaml``: compared as text, so any change of a digit counts);

and which files only one version wrote. A difference of 0.0 everywhere is what "behaviour kept"
means; where a seam changes a plan on purpose the row says so and the reason is the caller's to
give.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

PROGRAM_FILES = ("rapid", "urscript", "ur_rtde", "ros_joints", "trajectory.csv",
                 "trajectory.yaml")
"""What a robot runs: compared as text."""


def job_files(examples: Path) -> list[Path]:
    """The job files of ``examples`` and ``examples/cells`` (identification files left out)."""
    import yaml

    files = sorted(examples.glob("*.yaml")) + sorted((examples / "cells").glob("*.yaml"))
    jobs = []
    for path in files:
        data = yaml.safe_load(path.read_text())
        if isinstance(data, dict) and "identify" in data and "start" not in data:
            continue
        jobs.append(path)
    return jobs


def run(label: str, src: Path, examples: Path, out: Path, extra: list[str]) -> None:
    """Plan every example with the dloplan of ``src`` into ``out/label``."""
    folder = out / label
    folder.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "PYTHONPATH": str(src.resolve())}
    codes = {}
    for name, argv in [("demo", ["demo"])] + [
            (path.stem, ["plan", str(path.resolve()), *extra]) for path in job_files(examples)]:
        target = folder / name
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", "from dloplan.cli import main; import sys; "
                               "sys.exit(main(sys.argv[1:]))", *argv, "-o", str(target), "-q"],
                              env=env, capture_output=True, text=True)
        codes[name] = {"code": done.returncode, "stdout": done.stdout, "stderr": done.stderr,
                       "seconds": time.perf_counter() - t0}
        print(f"{label} {name}: exit {done.returncode} ({time.perf_counter() - t0:.0f} s)",
              flush=True)
    (folder / "codes.json").write_text(json.dumps(codes, indent=1))


def _plan_arrays(plan: dict) -> dict[str, np.ndarray]:
    """The arrays of a plan.json compared (missing sections as empty arrays)."""
    out = {"shapes": np.asarray(plan["shapes"], float),
           "stabilized": np.asarray(plan.get("stabilized") or [], float)}
    grippers = plan.get("grippers")
    if grippers is not None:
        for clip, poses in grippers["clips"].items():
            out[f"gripper {clip} positions"] = np.array(
                [[p["pose"]["position"][k] for k in "xyz"] for p in poses])
            out[f"gripper {clip} quaternions"] = np.array(
                [[p["pose"]["orientation"][k] for k in "xyzw"] for p in poses])
    trajectory = plan.get("trajectory")
    if trajectory is not None:
        out["trajectory times"] = np.array([p["time"] for p in trajectory["points"]])
        out["trajectory poses"] = np.array(
            [[[pose["pose"]["position"][k] for k in "xyz"]
              + [pose["pose"]["orientation"][k] for k in "xyzw"] for pose in p["poses"]]
             for p in trajectory["points"]])
    robot = plan.get("robot")
    if robot is not None:
        out["program joints [deg]"] = np.array(
            [np.concatenate([arm["joints_deg"] for arm in target["arms"].values()])
             for target in robot["program"]["targets"]], float)
    return out


def _difference(a: np.ndarray, b: np.ndarray) -> float | str:
    if a.shape != b.shape:
        return f"shape {a.shape} vs {b.shape}"
    return float(np.max(np.abs(a - b))) if a.size else 0.0


def _checks(plan: dict) -> list[dict]:
    """The robot program's check rows and message as recorded in a plan.json (none without a
    robot program)."""
    program = (plan.get("robot") or {}).get("program") or {}
    return list(program.get("checks", [])) + [{"message": program.get("message")}]


def _program_texts(folder: Path) -> dict[str, str]:
    texts = {}
    for name in PROGRAM_FILES:
        path = folder / name
        files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else \
            [path] if path.is_file() else []
        for file in files:
            texts[str(file.relative_to(folder))] = file.read_text()
    return texts


def compare(out: Path, old: str, new: str) -> int:
    """Print the differences between ``out/old`` and ``out/new``; the number of examples that
    differ."""
    codes = {label: json.loads((out / label / "codes.json").read_text()) for label in (old, new)}
    differing = 0
    for name in codes[old]:
        a, b = out / old / name, out / new / name
        after = codes[new].get(name, {}).get("code")
        line = [f"{name}: exit {codes[old][name]['code']} -> {after}"]
        if not (a / "plan.json").is_file() or not (b / "plan.json").is_file():
            line.append("no plan.json in " + ", ".join(
                label for label, f in ((old, a), (new, b)) if not (f / "plan.json").is_file()))
            print("; ".join(line))
            differing += 1
            continue
        arrays = [_plan_arrays(json.loads((f / "plan.json").read_text())) for f in (a, b)]
        diffs = {key: _difference(arrays[0][key], arrays[1][key])
                 for key in arrays[0] if key in arrays[1]}
        keys = set(arrays[0]) ^ set(arrays[1])
        texts = [_program_texts(f) for f in (a, b)]
        checks = [_checks(json.loads((f / "plan.json").read_text())) for f in (a, b)]
        rows = [k for k in range(max(map(len, checks)))
                if k >= min(map(len, checks)) or checks[0][k] != checks[1][k]]
        changed = [k for k in texts[0] if k in texts[1] and texts[0][k] != texts[1][k]]
        only = sorted(set(texts[0]) ^ set(texts[1]))
        files = [sorted(str(p.relative_to(f)) for p in f.rglob("*") if p.is_file()
                        and "figures" not in p.parts) for f in (a, b)]
        worst = max((d for d in diffs.values() if isinstance(d, float)), default=0.0)
        shapes = [k for k, d in diffs.items() if not isinstance(d, float)]
        line.append(f"largest difference {worst:.3g}")
        if worst or shapes or keys or changed or only or rows:
            differing += 1
            line += [f"{k} {d}" for k, d in diffs.items() if d]
            if keys:
                line.append(f"sections in one only: {sorted(keys)}")
            if rows:
                line.append(f"robot checks differ: {len(rows)} of {len(checks[0])} rows "
                            f"(first: {checks[0][rows[0]] if rows[0] < len(checks[0]) else None}"
                            f" -> {checks[1][rows[0]] if rows[0] < len(checks[1]) else None})")
            if changed:
                line.append(f"program files differ: {changed}")
            if only:
                line.append(f"program files in one only: {only}")
        else:
            line.append(f"{len(texts[0])} program files identical")
        if files[0] != files[1]:
            line.append(f"files written: {old} {sorted(set(files[0]) - set(files[1]))} "
                        f"-> {new} {sorted(set(files[1]) - set(files[0]))}")
        print("; ".join(line))
    return differing


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=Path("/tmp/plan_before_after"))
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run")
    r.add_argument("label")
    r.add_argument("--src", type=Path, required=True)
    r.add_argument("--examples", type=Path, required=True)
    c = sub.add_parser("compare")
    c.add_argument("old")
    c.add_argument("new")
    # the options for dloplan plan follow "--" (argparse would not hand them to a subcommand)
    argv = sys.argv[1:] if argv is None else list(argv)
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    args = parser.parse_args(argv[:argv.index("--")] if "--" in argv else argv)
    if args.command == "run":
        run(args.label, args.src, args.examples, args.out, extra)
        return 0
    return 1 if compare(args.out, args.old, args.new) else 0


if __name__ == "__main__":
    sys.exit(main())
