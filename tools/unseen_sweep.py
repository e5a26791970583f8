"""Unseen-case sweep: the CLI on variants of the shipped examples nobody designed.

Run (from the repository root, with the project's venv)::

    .venv/bin/python tools/unseen_sweep.py --quick            # ~40 runs, a few minutes
    .venv/bin/python tools/unseen_sweep.py                    # every variant of every example
    .venv/bin/python tools/unseen_sweep.py --only mirror      # the cases whose name has "mirror"

Each example job is varied -- mirrored (y -> -y: the arms swap sides), written in millimetres,
given every catalogue cable, n coarsened and refined, another grip method, moved rigidly
(turned about the vertical through the job and shifted on the table), run on the other robot
cells -- and run through ``plan`` (and ``plan --verify``), ``verify``, ``export`` in every
format, ``identify`` (other noise, fewer markers, metres), ``correct`` (measured shapes in
millimetres, in another frame, from another plan), ``compare`` and ``study`` (a few samples).
Every run has a timeout (``--timeout``, 60 s by default: a longer run is a hang).

Round 2 (``--only r2/``; ``r2/rapid``, ``r2/roundtrip``, ``r2/hostile``, ``r2/harness``,
``r2/refine``) checks where dloplan's model meets what it does not control
(``tools/sweep_checks.py``): the RAPID modules of YuMi jobs mirrored, turned 25 and -20 deg
and in mm read back as the controller reads them (robtargets, ``eax_a`` the arm angle, the
start jointtarget, the base frame and work object, both tasks' sync points, the joint speeds
of every MoveL against the limits and the plan's reported peaks), exported again and verified
again; files no example holds (duplicate keys, wrong types, NaN, negative and huge values,
empty lists, non-UTF-8 bytes, unknown keys in job, harness, shape and identification files;
outputs under a file, in /proc, onto a file or a foreign folder), each of which must exit 2
naming what it expects (``expect``); the harness jobs with other cables, a fixture moved,
fixtures closer, one fixture, mirrored, through ``plan --verify``; and one job at n = 10, 20,
40 and with two other grips, whose end shapes must agree within ``AGREEMENT * L / n``.

Round 3 (``--only r3/``; ``r3/cells``, ``r3/obstacle``, ``r3/identify``, ``r3/study``,
``r3/interrupt``, ``tools/sweep_round3.py``) reads the UR5e and Panda programs back with the
vendors' kinematics and limits, turns and mirrors the obstacle job and the identification, runs
studies on a Dask scheduler and with bad study sections, and interrupts studies,
identifications and plans with Ctrl-C.

For each run the table records the exit code, the one-line verdict, the wall time and the flags:

``traceback``   a Python traceback on stdout or stderr
``exit``        an exit code that contradicts the printed verdict (``--json``'s ``ok`` and
                ``warnings``: 0 needs ok and no warning, 1 ok with warnings, 3 not ok)
``warning``     a run reported as a success whose warnings say that a check failed
``half``        files left behind by a refusal (exit 2: nothing; exit 3: no robot program)
``nan``         NaN or inf in a written plan, trajectory or program
``invariance``  a result that physics says must not change did: the mirrored job's shapes and
                forces against the mirrored original, the rigidly moved job's internal forces,
                the job in mm against the job in m (``--tolerance``, metres and relative)
``message``     an error (exit 2) whose line does not name the field or value and what was
                expected (a heuristic: read the line)
``refusal``     a hostile case that did not exit 2
``rapid``       a RAPID module that reads back otherwise than the plan (round 2)
``round trip``  an export or verify of a plan that disagrees with the plan (round 2)
``discretization``, ``grip``  end shapes of one job that disagree across n or grips (round 2)
``check``       a round-2 check that could not run (its exception)
``json``        ``--json`` printed NaN or Infinity: Python reads it, strict JSON readers do not
``cell``        a described cell's program that reads back otherwise than the plan or the
                vendor's kinematics and limits (round 3, ``tools/cell_checks.py``)
``obstacle``, ``identify``, ``study``, ``interrupt``  round 3's checks (``tools/sweep_round3.py``)
``hang``        the run hit the timeout (wall time: on a shared machine read it with the CPU
                time of the runs that finished)

The table is printed and written as ``OUT/sweep.md`` and ``OUT/sweep.json`` (default
``/tmp/unseen_sweep``). Exit status 0 when no run was flagged, 1 otherwise.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import csv
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
CABLES = ("usb", "ethernet", "pu", "pa12")
LENGTH_KEYS = {"length", "diameter", "position", "center", "size", "min", "max", "base",
               "radius", "height", "amplitude", "tcp_speed", "threshold", "z_safety",
               "slot_width", "depth", "plate_height", "plate_size", "approach_height",
               "clearance", "max_offset", "base_position", "tcp_offset", "tool_radius",
               "separation", "points"}
"""Keys whose values are lengths in the file's units (a harness fixture's ``position`` too)."""
NOT_LENGTH_PARENTS = {"study", "identify", "weights", "initial_frames"}
"""Sections whose like-named keys are not lengths in file units (the study's are in mm)."""
PLAN_JOBS = ("m2_uniform_curvature_usb", "m2_uniform_curvature_pa12", "m1_sine_pu_hose",
             "qualitative2_ethernet_3d", "qualitative1_curved_pa12", "fig4_8_straight_to_bent",
             "harness_phase1_obstacle")
MEASURED_JOB = "qualitative2_ethernet_3d"
"""The job whose plan the correction and compare cases measure."""
QUICK_JOBS = ("m2_uniform_curvature_pa12", "qualitative2_ethernet_3d", "m1_sine_pu_hose")
HARNESS_JOBS = ("harness_usb", "harness_ethernet", "harness_pu")
FAILED_WORDS = re.compile(r"\b(fail(ed|s)?|unstable|not stable|unreachable|not reach|collid|"
                          r"collision at|exceed|violat|refused)\b", re.I)
HARMLESS_WARNINGS = re.compile(r"target is not stable under gravity|sags|E outside", re.I)
"""Warnings a success may carry: a sagging target is a documented exit 1 (docs/scenario.md)."""


@dataclass
class Case:
    """One CLI run of the sweep."""

    name: str
    argv: list[str]
    output: Path | None = None
    kind: str = "plan"                       # plan | verify | export | identify | correct | ...
    compare_with: tuple[str, str] | None = None   # (base case, transform) for invariance
    needs: str | None = None                 # a case whose plan.json this one reads
    reads: tuple[str, ...] = ()              # other cases whose plans it reads
    check: Callable[[Case, dict[str, Case]], list[str]] | None = None  # flags from its files
    expect: tuple[str, ...] = ()             # a refusal (exit 2) whose line names all these
    interrupt: float | None = None           # SIGINT to its process group after this [s]
    keep: bool = False                       # run on its output as it is (a resumed study)
    result: dict = field(default_factory=dict)


# ---------------------------------------------------------------------------------------------
# job transforms


def _scale_lengths(node, factor, parent=""):
    """``node`` with every length value multiplied by ``factor`` (recursively, by key)."""
    if isinstance(node, dict):
        out = {}
        for key, value in node.items():
            if parent in NOT_LENGTH_PARENTS:
                out[key] = value
            elif key in LENGTH_KEYS:
                out[key] = _scale_numbers(value, factor)
            else:
                out[key] = _scale_lengths(value, factor, key)
        return out
    if isinstance(node, list):
        return [_scale_lengths(v, factor, parent) for v in node]
    return node


def _scale_numbers(value, factor):
    if isinstance(value, bool):
        return value
    if isinstance(value, int | float):
        return value * factor
    if isinstance(value, list):
        return [_scale_numbers(v, factor) for v in value]
    return value


def to_millimetres(job: dict) -> dict:
    """The job written in millimetres (``units: mm``), every length times 1000."""
    if job.get("units", "m") != "m":
        raise ValueError("already in mm")
    out = _scale_lengths(copy.deepcopy(job), 1000.0)
    out["units"] = "mm"
    # the mass, E and angles are no lengths; a cable's "length" in the catalogue stays implied
    return out


def _rotation(spec: dict | None) -> Rotation:
    if not spec:
        return Rotation.identity()
    if "quaternion" in spec:
        return Rotation.from_quat(spec["quaternion"])
    return Rotation.from_euler(spec.get("seq", "xyz"), spec["euler"],
                               degrees=spec.get("degrees", True))


def _rotation_spec(rot: Rotation) -> dict:
    return {"quaternion": [float(v) for v in rot.as_quat()]}


MIRROR = np.diag([1.0, -1.0, 1.0])


def _mirror_point(p):
    return [float(p[0]), -float(p[1]), *[float(v) for v in p[2:]]] if len(p) == 3 else list(p)


def _mirror_shape(shape: dict) -> dict:
    """A shape mirrored in the x-z plane: placement conjugated, local shape mirrored."""
    out = copy.deepcopy(shape)
    kind = out.get("kind")
    if kind == "arc":
        out["angle"] = -out["angle"]
    elif kind == "sine":
        out["amplitude"] = -out["amplitude"]
    elif kind == "points":
        out["points"] = [_mirror_point(p) for p in out["points"]]
    if "placement" in out:
        place = out["placement"]
        if "position" in place:
            place["position"] = _mirror_point(place["position"])
        rot = _rotation(place.get("rotation"))
        place["rotation"] = _rotation_spec(
            Rotation.from_matrix(MIRROR @ rot.as_matrix() @ MIRROR))
    return out


def _mirror_obstacle(obs: dict) -> dict:
    out = copy.deepcopy(obs)
    for key in ("center", "base"):
        if key in out:
            out[key] = _mirror_point(out[key])
    if "yaw" in out:
        out["yaw"] = -out["yaw"]
    if "min" in out and "max" in out:
        lo, hi = out["min"], out["max"]
        out["min"] = [lo[0], -hi[1], lo[2]]
        out["max"] = [hi[0], -lo[1], hi[2]]
    return out


def mirror(job: dict) -> dict:
    """The job mirrored in the robot's x-z plane (y -> -y): the arms swap sides."""
    out = copy.deepcopy(job)
    for key in ("start", "target"):
        if key in out:
            out[key] = _mirror_shape(out[key])
    cable = out.get("cable", {})
    if "rest_shape" in cable:
        cable["rest_shape"] = _mirror_shape(cable["rest_shape"])
    out["obstacles"] = [_mirror_obstacle(o) for o in out.get("obstacles", [])]
    harness = out.get("harness")
    if harness:
        for fixture in harness.get("fixtures", []):
            fixture["position"] = _mirror_point(fixture["position"])
            fixture["axis"] = _mirror_point(fixture["axis"])
        for peg in harness.get("pegs", []):
            peg["base"] = _mirror_point(peg["base"])
            if "side" in peg:
                peg["side"] = _mirror_point(peg["side"])
    return out


def _job_centre(job: dict) -> np.ndarray:
    points = [job[k]["placement"]["position"] for k in ("start", "target")
              if k in job and "placement" in job[k] and "position" in job[k]["placement"]]
    return np.mean(points, axis=0) if points else np.zeros(3)


def rigid(job: dict, yaw_deg: float = 8.0, shift=(0.01, 0.02, 0.0)) -> dict:
    """The job turned by ``yaw_deg`` about the vertical through its centre and shifted [m].

    Gravity and the table stay: the internal forces must not change.
    """
    out = copy.deepcopy(job)
    scale = 1000.0 if out.get("units") == "mm" else 1.0
    centre = _job_centre(out)
    turn = Rotation.from_euler("z", yaw_deg, degrees=True)
    move = np.asarray(shift) * scale

    def point(p):
        return [float(v) for v in turn.apply(np.asarray(p, float) - centre) + centre + move]

    for key in ("start", "target"):
        shape = out.get(key)
        if not shape:
            continue
        if shape.get("kind") == "points":
            shape["points"] = [point(p) for p in shape["points"]]
        place = shape.setdefault("placement", {})
        if shape.get("kind") != "points":
            place["position"] = point(place.get("position", [0, 0, 0]))
            place["rotation"] = _rotation_spec(turn * _rotation(place.get("rotation")))
    obstacles = []
    for obs in out.get("obstacles", []):
        obs = copy.deepcopy(obs)
        if "min" in obs:
            lo, hi = np.asarray(obs.pop("min"), float), np.asarray(obs.pop("max"), float)
            obs["center"], obs["size"] = list((lo + hi) / 2), list(hi - lo)
        for key in ("center", "base"):
            if key in obs:
                obs[key] = point(obs[key])
        if obs.get("type") == "box":
            obs["yaw"] = obs.get("yaw", 0.0) + yaw_deg
        obstacles.append(obs)
    out["obstacles"] = obstacles
    return out


def with_cable(job: dict, name: str) -> dict:
    """The job with the catalogue cable ``name`` (its n and rest shape kept)."""
    out = copy.deepcopy(job)
    old = out.get("cable", {})
    cable = {"name": name, "n_links": old.get("n_links", 10)}
    if "rest_shape" in old:
        cable["rest_shape"] = old["rest_shape"]
    out["cable"] = cable
    return out


def with_modulus(job: dict, factor: float) -> dict:
    """The job with the cable's Young's modulus times ``factor`` (the catalogue's by name)."""
    from dloplan.cable import catalogue_cable

    out = copy.deepcopy(job)
    cable = out.setdefault("cable", {})
    modulus = cable.get("youngs_modulus") or catalogue_cable(cable["name"]).youngs_modulus
    cable["youngs_modulus"] = float(modulus) * factor
    return out


def with_links(job: dict, n: int) -> dict:
    out = copy.deepcopy(job)
    out.setdefault("cable", {})["n_links"] = n
    return out


def with_grip(job: dict, method: str) -> dict:
    out = copy.deepcopy(job)
    out["grippers"] = {**out.get("grippers", {}), "method": method}
    return out


def with_cell(job: dict, cell_file: Path) -> dict:
    """The job run on the robot cell of ``cell_file`` (its relative URDF paths made absolute)."""
    out = copy.deepcopy(job)
    robot = copy.deepcopy(yaml.safe_load(cell_file.read_text())["robot"])
    for arm in robot.get("cell", {}).get("arms", {}).values():
        if "urdf" in arm:
            arm["urdf"] = str((cell_file.parent / arm["urdf"]).resolve())
    out["robot"] = robot
    out["repair"] = {"placement": True}
    return out


# ---------------------------------------------------------------------------------------------
# checks of a run's outputs


def _load_plan(folder: Path) -> dict | None:
    path = folder / "plan.json"
    if not path.is_file():
        return None
    return json.loads(path.read_text())


def nan_files(folder: Path) -> list[str]:
    """Written text files holding NaN or inf."""
    bad = []
    if not folder.exists():
        return bad
    paths = [folder] if folder.is_file() else [p for p in folder.rglob("*") if p.is_file()]
    for path in paths:
        if path.suffix not in {".json", ".csv", ".mod", ".script", ".yaml", ".py", ".txt"}:
            continue
        text = path.read_text(errors="replace")
        if re.search(r"(?<![A-Za-z_])(nan|NaN|-?inf|-?Infinity)(?![A-Za-z_])", text):
            bad.append(str(path.relative_to(folder.parent)))
    return bad


def _arr(doc: dict, *keys):
    node = doc
    for key in keys:
        if node is None:
            return None
        node = node.get(key) if isinstance(node, dict) else None
    return None if node is None else np.asarray(node, dtype=float)


def _placed(doc: dict) -> bool:
    return bool(doc.get("placement")) or any(
        "placement" in json.dumps(r) for r in doc.get("repairs", []))


def invariance(base: dict, variant: dict, transform: str, tol: float,
               measured: dict | None = None) -> list[str]:
    """Where ``variant``'s physics differs from ``base``'s under ``transform``.

    mirror: shapes and stabilized shapes mirrored (y -> -y), axial and bending forces equal;
    mm: everything equal (both documents are SI); rigid: axial and bending forces equal.
    Returns the differences above ``tol`` (metres, and relative for forces); every difference
    measured goes into ``measured`` (name -> value).
    """
    notes = []
    measured = {} if measured is None else measured
    if transform != "mm" and (_placed(base) or _placed(variant)):
        return ["skipped: a placement moved one of the jobs"]
    if [r.get("kind") for r in base.get("repairs", [])] != \
            [r.get("kind") for r in variant.get("repairs", [])]:
        notes.append("repairs differ: " + json.dumps([r.get("kind") for r in
                                                      variant.get("repairs", [])])[:80])
    if transform in {"mirror", "mm"}:
        for key in ("shapes", "stabilized"):
            a, b = _arr(base, key), _arr(variant, key)
            if a is None or b is None or a.shape != b.shape:
                notes.append(f"{key}: shapes differ in size")
                continue
            if transform == "mirror":
                a = a * np.array([1.0, -1.0, 1.0])
            err = float(np.max(np.abs(a - b)))
            measured[key] = err
            if not err <= tol:
                notes.append(f"{key} differ by {err:.2e} m")
    for key in ("axial_mean", "bending_mean"):
        a, b = _arr(base, "forces", "physical", key), _arr(variant, "forces", "physical", key)
        if a is None or b is None:
            continue
        scale = max(float(np.max(np.abs(a))), 1e-9)
        err = float(np.max(np.abs(a - b))) / scale
        measured[key] = err
        if not err <= max(tol * 100, 1e-4):
            notes.append(f"forces.{key} differ by {err:.1e} (relative)")
    return notes


def verdict_line(stdout: str, stderr: str, summary: dict | None) -> str:
    """The run's one-line verdict: the JSON summary's message, else the last stderr line."""
    if summary and "n_shapes" in summary and "ok" in summary:   # plan
        warnings = summary.get("warnings") or []
        return (("ok" if summary["ok"] else "FAILED") + f", {len(warnings)} warning(s)"
                + (f": {warnings[-1]}" if warnings else ""))[:160]
    if summary:
        for key in ("message", "verdict", "result", "error"):
            if isinstance(summary.get(key), str):
                return summary[key].splitlines()[0][:160]
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    if lines:
        return re.sub(r"^\[\s*[\d.]+ s\] ", "", lines[-1])[:160]
    lines = [ln for ln in stdout.splitlines() if ln.strip()]
    return lines[-1][:160] if lines else ""


def parse_summary(stdout: str) -> dict | None:
    try:
        data = json.loads(stdout)
    except ValueError:
        start = stdout.find("{")
        try:
            data = json.loads(stdout[start:]) if start >= 0 else None
        except ValueError:
            return None
    return data if isinstance(data, dict) else None


def _refusal(stderr: str, summary: dict | None) -> str:
    """The line that says why a run exited 2: the ``--json`` answer's ``reason`` (a failed
    identification), else the last line on stderr."""
    if summary and isinstance(summary.get("reason"), str) and summary["reason"]:
        return summary["reason"]
    line = next((ln for ln in reversed(stderr.splitlines()) if ln.strip()), "")
    return re.sub(r"^\[\s*[\d.]+ s\] ", "", line)


def strict_json(stdout: str) -> bool:
    """Whether the JSON on ``stdout`` holds no NaN or infinity (RFC 8259 has neither)."""
    def refuse(constant):
        raise ValueError(f"constant {constant}")

    try:
        json.loads(stdout[stdout.find("{"):], parse_constant=refuse)
    except ValueError as exc:
        return not str(exc).startswith("constant ")
    return True


def flags_of(case: Case, code: int | None, stdout: str, stderr: str,
             summary: dict | None) -> list[str]:
    flags = []
    if code is None:
        return ["hang"]
    if "Traceback (most recent call last)" in stdout + stderr:
        flags.append("traceback")
    if summary is not None and "ok" in summary and code in (0, 1, 3):
        ok = summary.get("ok")
        warnings = summary.get("warnings") or []
        if (code == 3) == bool(ok) or (code == 0 and warnings and case.kind == "plan"):
            flags.append(f"exit: {code} with ok={ok}, {len(warnings)} warning(s)")
        bad = [w for w in warnings if FAILED_WORDS.search(str(w))
               and not HARMLESS_WARNINGS.search(str(w))]
        if ok and bad:
            flags.append("warning: ok but " + str(bad[0])[:100])
    if summary is not None and not strict_json(stdout):
        flags.append("json: --json printed NaN or Infinity (not JSON, RFC 8259)")
    if case.expect and code != 2:
        flags.append(f"refusal: exit {code}, expected 2")
    if code == 2:  # the whole error line (the verdict is cut at 160 characters)
        line = _refusal(stderr, summary)
        if case.output is not None and case.output.exists() and any(case.output.iterdir()
                                                                     if case.output.is_dir()
                                                                     else [1]):
            flags.append("half: exit 2 left " + str(case.output))
        missing = [f for f in case.expect if f.lower() not in line.lower()]
        if missing:
            flags.append(f"message: no {missing} in: " + line[:100])
        elif not re.search(r"expected|need|must|got|at least|at most|within|should|"
                           r"transform it|reverse|look like|not where|only|no |cannot|outside|"
                           r"takes|not allowed|see dloplan", line, re.I):
            flags.append("message: " + line[:100])
    if code == 3 and case.output is not None and case.output.is_dir():
        programs = [p.name for p in case.output.iterdir()
                    if p.name in {"rapid", "urscript", "ur_rtde", "ros_joints",
                                  "trajectory.csv"}]
        if programs:
            flags.append("half: exit 3 wrote " + ", ".join(programs))
    if case.output is not None and code in (0, 1, 3):
        bad = nan_files(case.output)
        if bad:
            flags.append("nan: " + ", ".join(bad[:3]))
    return flags


# ---------------------------------------------------------------------------------------------
# the cases


def write_yaml(path: Path, data: dict) -> Path:
    """Write ``data`` as YAML to ``path`` (its folder made); returns ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def job_cases(out: Path, quick: bool) -> list[Case]:
    """plan (and plan --verify) of every variant of the example jobs."""
    cases = []
    jobs = QUICK_JOBS if quick else PLAN_JOBS
    cells = sorted((EXAMPLES / "cells").glob("*.yaml"))
    for stem in jobs:
        job = yaml.safe_load((EXAMPLES / f"{stem}.yaml").read_text())
        variants = {"base": job, "mirror": mirror(job), "mm": to_millimetres(job),
                    "rigid": rigid(job)}
        links = (6, 30) if quick else (6, 8, 30, 40)
        for n in links:
            variants[f"n{n}"] = with_links(job, n)
        cables = CABLES if not quick else [c for c in CABLES
                                           if c != job.get("cable", {}).get("name")][:1]
        for name in cables:
            variants[f"cable_{name}"] = with_cable(job, name)
        for method in (("rigid", "auxiliary") if quick else ("minimal", "rigid", "auxiliary")):
            variants[f"grip_{method}"] = with_grip(job, method)
        for cell in cells[:1] if quick else cells:
            variants[f"cell_{cell.stem.split('_')[0]}"] = with_cell(job, cell)
        if not quick:
            variants["mirror_mm"] = to_millimetres(variants["mirror"])
        if stem == MEASURED_JOB:  # the "real" cable of the correction cases: E halved
            variants["E_half"] = with_modulus(job, 0.5)
        for tag, data in variants.items():
            name = f"{stem}/{tag}"
            path = write_yaml(out / "jobs" / stem / f"{tag}.yaml", data)
            target = out / "runs" / stem / tag
            compare = {"mirror": ("mirror", "base"), "mm": ("mm", "base"),
                       "rigid": ("rigid", "base")}.get(tag)
            cases.append(Case(name, ["plan", str(path), "-o", str(target)], target,
                              compare_with=(f"{stem}/base", compare[0]) if compare else None))
        # the verified plan of the mirrored job (the replay and snap checks on the other side)
        vtarget = out / "runs" / stem / "mirror_verify"
        cases.append(Case(f"{stem}/mirror --verify",
                          ["plan", str(out / "jobs" / stem / "mirror.yaml"), "--verify", "-o",
                           str(vtarget)], vtarget))
    for cell in cells:
        job = yaml.safe_load(cell.read_text())
        for arm in job["robot"].get("cell", {}).get("arms", {}).values():
            arm["urdf"] = str((cell.parent / arm["urdf"]).resolve())
        variants = {"base": job, "mirror": mirror(job), "mm": to_millimetres(job)}
        if quick:
            variants.pop("mm")
        for tag, data in variants.items():
            path = write_yaml(out / "jobs" / cell.stem / f"{tag}.yaml", data)
            target = out / "runs" / cell.stem / tag
            cases.append(Case(f"{cell.stem}/{tag}", ["plan", str(path), "--verify", "-o",
                                                     str(target)], target))
    if not quick:
        for stem in HARNESS_JOBS:
            job = yaml.safe_load((EXAMPLES / f"{stem}.yaml").read_text())
            for tag, data in {"mirror": mirror(job), "mm": to_millimetres(job)}.items():
                path = write_yaml(out / "jobs" / stem / f"{tag}.yaml", data)
                target = out / "runs" / stem / tag
                cases.append(Case(f"{stem}/{tag}", ["plan", str(path), "-o", str(target)],
                                  target))
    return cases


def document_cases(out: Path, quick: bool) -> list[Case]:
    """verify and export of a planned YuMi job and a planned UR job."""
    cases = []
    docs = [("m2_uniform_curvature_pa12/mirror", "yumi"), ("ur5e_pair_usb/mirror", "ur")]
    formats = ("json", "csv", "ros", "ros_joints", "urscript", "ur_rtde", "rapid", "report")
    for plan_case, cell in docs:
        plan = out / "runs" / plan_case / "plan.json"
        tag = plan_case.replace("/", "_")
        cases.append(Case(f"verify {plan_case}", ["verify", str(plan)], None, "verify",
                          needs=plan_case))
        for fmt in formats if not quick or cell == "yumi" else ("ur_rtde", "rapid"):
            suffix = {"json": ".json", "csv": ".csv", "ros": ".yaml", "report": ".html"}
            target = out / "exports" / tag / (fmt + suffix.get(fmt, ""))
            cases.append(Case(f"export {fmt} {plan_case}",
                              ["export", str(plan), "--format", fmt, "-o", str(target)],
                              target, "export", needs=plan_case))
        target = out / "exports" / tag / "slow.csv"
        cases.append(Case(f"export csv --speed 0.02 --rate 20 {plan_case}",
                          ["export", str(plan), "--format", "csv", "--speed", "0.02",
                           "--rate", "20", "-o", str(target)], target, "export",
                          needs=plan_case))
    return cases


def identify_cases(out: Path, quick: bool) -> list[Case]:
    """identify on the example with more noise, fewer markers, and in metres."""
    data = yaml.safe_load((EXAMPLES / "identify_ethernet.yaml").read_text())
    rng = np.random.default_rng(7)
    measured = np.asarray(data["identify"]["measured_shape"], float)
    variants = {}
    noisy = copy.deepcopy(data)
    noisy["identify"]["measured_shape"] = (measured + rng.normal(0, 3.0, measured.shape)).tolist()
    noisy["identify"]["measurement_noise"] = 3.0
    variants["noise3mm"] = noisy
    sparse = copy.deepcopy(data)
    sparse["identify"]["measured_shape"] = measured[::6].tolist()
    variants["markers9"] = sparse
    few = copy.deepcopy(data)
    few["identify"]["measured_shape"] = measured[::16].tolist()
    variants["markers4"] = few
    if not quick:
        metres = copy.deepcopy(data)
        metres["units"] = "m"
        ident = metres["identify"]
        ident["measured_shape"] = (measured / 1000).tolist()
        ident["initial_shape"] = (np.asarray(ident["initial_shape"]) / 1000).tolist()
        for step in ident["trajectory"]:
            for end in step.values():
                end["position"] = [v / 1000 for v in end["position"]]
        ident["measurement_noise"] = ident["measurement_noise"] / 1000  # file units
        variants["metres_noise_kept"] = copy.deepcopy(metres)        # 1.0: mm left in a m file
        variants["metres_noise_kept"]["identify"]["measurement_noise"] = 1.0
        variants["metres"] = metres
        variants["cable_pu"] = {**copy.deepcopy(data),
                                "cable": {"name": "pu", "n_links": 16,
                                          "youngs_modulus": "identify"}}
    cases = []
    for tag, job in variants.items():
        path = write_yaml(out / "jobs" / "identify" / f"{tag}.yaml", job)
        target = out / "runs" / "identify" / tag
        cases.append(Case(f"identify/{tag}", ["identify", str(path), "-o", str(target)],
                          target, "identify"))
    return cases


def _write_shapes_csv(path: Path, shapes: list[np.ndarray], frame: str, scale=1.0) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["label", "frame_id", "x", "y", "z"])
        for k, shape in enumerate(shapes):
            for p in shape:
                writer.writerow([f"xi_{k}", frame, *(f"{v * scale:.9f}" for v in p)])
    return path


def _write_shapes_json_mm(path: Path, points: np.ndarray, frame: str) -> Path:
    """One measured shape (labelled xi_3) as a dloplan-shapes JSON file in millimetres."""
    path = path.with_suffix(".json")
    path.write_text(json.dumps({"format": "dloplan-shapes", "version": 1, "units": "mm",
                                "frame_id": frame,
                                "shapes": [{"label": "xi_3",
                                            "points": (points * 1000).tolist()}]}))
    return path


class Deferred(Case):
    """A case whose input files are made from another case's plan just before it runs."""

    def __init__(self, name, make, kind, needs, output=None):
        super().__init__(name, [], output, kind, needs=needs)
        self.make = make


def measurement_cases(out: Path, quick: bool) -> list[Case]:
    """correct and compare with measured shapes made from the plans."""
    cases = []
    own, other = f"{MEASURED_JOB}/base", "m2_uniform_curvature_pa12/base"
    softer = f"{MEASURED_JOB}/E_half"
    def plan_of(case):
        return out / "runs" / case / "plan.json"

    def measured(case, at):
        doc = json.loads(plan_of(case).read_text())
        shape = np.asarray(doc["stabilized"][at], float)
        dense = np.concatenate([np.linspace(a, b, 5, endpoint=False)
                                for a, b in zip(shape[:-1], shape[1:], strict=True)]
                               + [shape[-1:]])
        noise = np.random.default_rng(3).normal(0, 0.0005, dense.shape)  # the same each time
        return dense + noise, doc.get("frame_id", "world")

    def correct_case(tag, make_csv, extra=(), needs=own):
        folder = out / "measured"
        target = out / "runs" / "correct" / tag

        def make():
            path = make_csv(folder / f"{tag}.csv")
            return ["correct", str(plan_of(own)), "--at", "3", "--measured", str(path),
                    "-o", str(target), *extra]
        return Deferred(f"correct/{tag}", make, "correct", needs, target)

    def soft(path):
        points, frame = measured(softer, 3)
        return _write_shapes_csv(path, [points], frame)

    def soft_mm(path):
        return _write_shapes_json_mm(path, *measured(softer, 3))

    # the plan measured on a cable of half its E: a correction is made, the same in m and mm
    cases.append(correct_case("E_half", soft, needs=softer))
    cases.append(correct_case("E_half_json_mm", soft_mm, needs=softer))
    cases[-1].compare_with = ("correct/E_half", "correction")

    def plain(path):
        points, frame = measured(own, 3)
        return _write_shapes_csv(path, [points], frame)

    def robot_base(path):
        points, _ = measured(own, 3)
        return _write_shapes_csv(path, [points], "robot_base")

    def camera(path):
        points, _ = measured(own, 3)
        return _write_shapes_csv(path, [points], "camera")

    def in_mm(path):
        points, frame = measured(own, 3)
        return _write_shapes_csv(path, [points], frame, scale=1000.0)

    def json_mm(path):
        return _write_shapes_json_mm(path, *measured(own, 3))

    def from_other(path):
        points, frame = measured(other, 3)
        return _write_shapes_csv(path, [points], frame)

    def reversed_(path):
        points, frame = measured(own, 3)
        return _write_shapes_csv(path, [points[::-1]], frame)

    for tag, maker in [("own", plain), ("json_mm", json_mm), ("csv_in_mm", in_mm),
                       ("frame_camera", camera), ("frame_robot_base", robot_base),
                       ("other_plan", from_other), ("reversed", reversed_)]:
        if quick and tag in {"reversed", "frame_robot_base"}:
            continue
        cases.append(correct_case(tag, maker, ("--no-verify",) if tag != "own" else ()))
        if tag == "other_plan":
            cases[-1].reads = (other,)

    def compare_case(tag, transform, needs=(own,)):
        target = out / "runs" / "compare" / tag

        def make():
            doc = json.loads(plan_of(own).read_text())
            shapes = [transform(np.asarray(s, float)) for s in doc["stabilized"]]
            path = _write_shapes_csv(out / "measured" / f"compare_{tag}.csv", shapes,
                                     doc.get("frame_id", "world"))
            return ["compare", str(plan_of(own)), str(path), "--stabilized", "-o", str(target)]
        return Deferred(f"compare/{tag}", make, "compare", own, target)

    cases.append(compare_case("own", lambda s: s))
    cases.append(compare_case("reversed", lambda s: s[::-1]))
    cases.append(compare_case("mirrored", lambda s: s * np.array([1, -1, 1])))
    return cases


def study_cases(out: Path, quick: bool) -> list[Case]:
    job = yaml.safe_load((EXAMPLES / "study_m2_ethernet.yaml").read_text())
    variants = {"base": job, "mirror": mirror(job)}
    if not quick:
        variants["mm"] = to_millimetres(job)
        variants["cable_pa12"] = with_cable(job, "pa12")
    cases = []
    for tag, data in variants.items():
        path = write_yaml(out / "jobs" / "study" / f"{tag}.yaml", data)
        target = out / "runs" / "study" / tag
        cases.append(Case(f"study/{tag}", ["study", str(path), "--samples", "3", "--workers",
                                           "1", "--csv", "-o", str(target)], target, "study"))
    return cases


# ---------------------------------------------------------------------------------------------
# round 2: the robot controller's reading, hostile files, harness variants, discretization

RAPID_JOBS = ("m2_uniform_curvature_pa12", "qualitative2_ethernet_3d", "m1_sine_pu_hose")
"""YuMi jobs whose RAPID modules are read back (mirrored, turned, in mm)."""
REFINED_JOBS = ("m2_uniform_curvature_pa12", "qualitative2_ethernet_3d")
"""Jobs planned at n, 2n and 4n links, and with another grip."""
REFINED_LINKS = (10, 20, 40)
AGREEMENT = 0.5
"""The end shapes of plans at n and 2n links agree within ``AGREEMENT * L / n`` [m] (the
model's discretization error falls at least as 1/n)."""


def _base(job: dict) -> list[float]:
    """Where a job puts the YuMi's base frame [m]: its ``robot.base_position``; without one, 0.1
    m above its table (the foot on it: docs/robot.md), or the origin."""
    scale = 1e-3 if job.get("units") == "mm" else 1.0
    if "base_position" in job.get("robot", {}):
        return [v * scale for v in job["robot"]["base_position"]]
    if "table" in job:
        return [0.0, 0.0, job["table"].get("height", 0.0) * scale + 0.1]
    return [0.0, 0.0, 0.0]


def _rapid_check(base):
    def check(case: Case, done: dict) -> list[str]:
        from sweep_checks import rapid_problems

        if not (case.output / "rapid").is_dir():
            return [] if case.result.get("code") not in (0, 1) else ["rapid: none written"]
        return [f"rapid: {p}" for p in rapid_problems(case.output, base)[:4]]
    return check


def _same_as(folder: Path):
    def check(case: Case, done: dict) -> list[str]:
        from sweep_checks import same_files

        return [f"round trip: {p}" for p in same_files(folder, case.output)[:4]]
    return check


def _verdict_kept(plan: Path):
    """``verify`` of a plan exits 0 or 1 where the plan's verification passed, 3 where it
    failed (the plan's own warnings, e.g. a sagging target, are the plan's: not verify's)."""
    def check(case: Case, done: dict) -> list[str]:
        passed = json.loads(plan.read_text())["verification"]["ok"]
        code = case.result.get("code")
        return [] if (code in (0, 1)) == passed else [
            f"round trip: verify exits {code}, the plan's verification ok={passed}"]
    return check


def rapid_cases(out: Path, quick: bool) -> list[Case]:
    """YuMi jobs mirrored, turned and in mm planned with --verify, their RAPID modules read back
    against the plan; the mirrored plans exported again (the same modules) and verified again
    (the same verdict)."""
    cases = []
    for stem in RAPID_JOBS[:1] if quick else RAPID_JOBS:
        job = yaml.safe_load((EXAMPLES / f"{stem}.yaml").read_text())
        variants = {"base": job, "mirror": mirror(job),
                    "turn25": rigid(job, 25.0, (0.02, -0.03, 0)),
                    "mirror_turn-20": rigid(mirror(job), -20.0, (-0.02, 0.03, 0))}
        if not quick:
            variants["mirror_mm"] = to_millimetres(mirror(job))
        for tag, data in variants.items():
            name = f"r2/rapid/{stem}/{tag}"
            path = write_yaml(out / "jobs" / "r2" / stem / f"{tag}.yaml", data)
            target = out / "runs" / "r2" / stem / tag
            cases.append(Case(name, ["plan", str(path), "--verify", "-o", str(target)], target,
                              check=_rapid_check(_base(data))))
        plan_case = f"r2/rapid/{stem}/mirror"
        plan = out / "runs" / "r2" / stem / "mirror"
        target = out / "exports" / "r2" / stem / "rapid"
        cases.append(Case(f"r2/roundtrip/{stem}/export rapid", [
            "export", str(plan / "plan.json"), "--format", "rapid", "-o", str(target)], target,
            "export", needs=plan_case, check=_same_as(plan / "rapid")))
        cases.append(Case(f"r2/roundtrip/{stem}/verify", ["verify", str(plan / "plan.json")],
                          None, "verify", needs=plan_case,
                          check=_verdict_kept(plan / "plan.json")))
    return cases


SMALL_JOB = {"cable": {"name": "pa12", "n_links": 8},
             "start": {"kind": "straight", "placement": {"position": [0.4, -0.25, 0.2],
                                                         "rotation": {"euler": [0, 0, 90]}}},
             "target": {"kind": "arc", "angle": 60,
                        "placement": {"position": [0.35, -0.22, 0.25],
                                      "rotation": {"euler": [0, 0, 90]}}},
             "planner": {"n_shapes": 2}, "outputs": ["json"]}
"""A job that plans in seconds: the hostile cases' good file."""


def _small_yaml(**changes) -> str:
    data = copy.deepcopy(SMALL_JOB)
    data.update(changes)
    return yaml.safe_dump(data, sort_keys=False)


def _harness_job(change) -> str:
    data = yaml.safe_load((EXAMPLES / "harness_usb.yaml").read_text())
    change(data["harness"])
    return yaml.safe_dump(data, sort_keys=False)


def _shapes_json(**fields) -> str:
    doc = {"format": "dloplan-shapes", "version": 1, "units": "m",
           "shapes": [{"label": "xi_1", "frame_id": "world",
                       "points": [[0.35, -0.22 + 0.05 * k, 0.25] for k in range(9)]}]}
    doc.update(fields)
    return json.dumps(doc)


def _untouched(path: Path, text: str):
    def check(case: Case, done: dict) -> list[str]:
        return [] if path.read_text() == text else [f"half: {path.name} was changed"]
    return check


def hostile_cases(out: Path, quick: bool) -> list[Case]:
    """Files no example holds: duplicate keys, wrong types, NaN, negative or huge values, empty
    lists, non-UTF-8 bytes, in job, harness, measured-shape and identification files, and outputs
    that cannot be written. Each must exit 2 naming (``expect``) the field and value."""
    folder = out / "jobs" / "r2" / "hostile"
    folder.mkdir(parents=True, exist_ok=True)
    good = folder / "good.yaml"
    good.write_text(_small_yaml())
    jobs = {
        "dup-key-yaml": ("job.yaml", _small_yaml().replace(
            "cable:\n", "cable:\n  n_links: 9\n", 1), ("n_links", "twice")),
        "dup-key-yaml-top": ("job.yaml", _small_yaml() + "planner: {n_shapes: 3}\n",
                             ("planner", "twice")),
        "dup-key-json": ("job.json", json.dumps(SMALL_JOB).replace(
            '"n_links": 8', '"n_links": 8, "n_links": 9'), ("n_links", "twice")),
        "non-utf8": ("job.yaml", _small_yaml().replace("pa12", "pa12\udcff"), ("UTF-8",)),
        "n-links-million": ("job.yaml", _small_yaml(cable={"name": "pa12", "n_links": 10**6}),
                            ("cable.n_links", "1000000")),
        "length-negative": ("job.yaml", _small_yaml(cable={"name": "pa12", "length": -0.5}),
                            ("cable.length", "-0.5")),
        "diameter-inf": ("job.yaml", _small_yaml(cable={"name": "pa12", "diameter": ".inf"})
                         .replace("'.inf'", ".inf"), ("cable.diameter", "inf")),
        "points-empty": ("job.yaml", _small_yaml(target={"kind": "points", "points": []}),
                         ("target", "points")),
        "position-string": ("job.yaml", _small_yaml(
            start={"kind": "straight", "placement": {"position": "0.4, -0.25, 0.2"}}),
            ("start.placement.position", "0.4, -0.25, 0.2")),
        "obstacle-unknown-key": ("job.yaml", _small_yaml(obstacles=[
            {"type": "box", "center": [0.4, 0, 0.05], "size": [0.1, 0.1, 0.1], "colour": 1}]),
            ("colour",)),
        "harness-slot-negative": ("harness.yaml", _harness_job(
            lambda h: h["fixtures"][0].__setitem__("slot_width", -0.008)),
            ("slot_width", "-0.008")),
        "harness-fixtures-empty": ("harness.yaml", _harness_job(
            lambda h: h.__setitem__("fixtures", [])), ("fixtures",)),
        "harness-axis-zero": ("harness.yaml", _harness_job(
            lambda h: h["fixtures"][0].__setitem__("axis", [0, 0, 0])), ("axis",)),
        "harness-position-nan": ("harness.yaml", _harness_job(
            lambda h: h["fixtures"][1].__setitem__("position", [0.5, float("nan"), 0.03])),
            ("position", "nan")),
        "harness-n-shapes-zero": ("harness.yaml", _harness_job(
            lambda h: h.__setitem__("n_shapes", [0, 4])), ("n_shapes",)),
        "harness-unknown-key": ("harness.yaml", _harness_job(
            lambda h: h["pegs"][0].__setitem__("colour", "red")), ("colour",)),
        "harness-dup-fixture-name": ("harness.yaml", _harness_job(
            lambda h: h["fixtures"][1].__setitem__("name", "fixture_right")),
            ("fixture_right",)),
    }
    cases = []
    for tag, (name, text, expect) in jobs.items():
        path = folder / tag / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if "\udcff" in text:
            path.write_bytes(text.encode("utf-8", "surrogateescape"))
        else:
            path.write_text(text)
        target = out / "runs" / "r2" / "hostile" / tag
        cases.append(Case(f"r2/hostile/{tag}", ["plan", str(path), "-o", str(target)], target,
                          expect=expect))
    # measured shapes (correct, compare) of the small job's plan
    plan_case = "r2/hostile/good"
    plan = out / "runs" / "r2" / "hostile" / "good" / "plan.json"
    cases.append(Case(plan_case, ["plan", str(good), "-o", str(plan.parent)], plan.parent))
    shapes = {
        "shapes-points-text": (_shapes_json(shapes=[{"label": "xi_1", "frame_id": "world",
                                                     "points": "many"}]), ("points", "many")),
        "shapes-empty-list": (_shapes_json(shapes=[]), ("shapes",)),
        "shapes-units-number": (_shapes_json(units=5), ("units", "5")),
        "shapes-nan": (_shapes_json().replace("0.25]", "NaN]", 1), ("NaN",)),
        "shapes-dup-key": (_shapes_json().replace('"units": "m"', '"units": "m", "units": "mm"'),
                           ("units", "twice")),
        "shapes-unknown-key": (_shapes_json(colour="red"), ("colour",)),
        "shapes-non-utf8": (_shapes_json().replace("xi_1", "xi_\udcff1"), ("UTF-8",)),
    }
    for tag, (text, expect) in shapes.items():
        path = folder / tag / "measured.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(text.encode("utf-8", "surrogateescape"))
        target = out / "runs" / "r2" / "hostile" / tag
        cases.append(Case(f"r2/hostile/correct {tag}", [
            "correct", str(plan), "--at", "1", "--measured", str(path), "-o", str(target)],
            target, "correct", needs=plan_case, expect=expect))
    ident = yaml.safe_load((EXAMPLES / "identify_ethernet.yaml").read_text())
    for tag, change, expect in [
            ("identify-measured-empty", lambda d: d.__setitem__("measured_shape", []),
             ("measured_shape",)),
            ("identify-trajectory-text", lambda d: d.__setitem__("trajectory", "along"),
             ("trajectory", "along")),
            ("identify-noise-negative", lambda d: d.__setitem__("measurement_noise", -1.0),
             ("measurement_noise", "-1"))]:
        data = copy.deepcopy(ident)
        change(data["identify"])
        path = write_yaml(folder / tag / "ident.yaml", data)
        target = out / "runs" / "r2" / "hostile" / tag
        cases.append(Case(f"r2/hostile/{tag}", ["identify", str(path), "-o", str(target)],
                          target, "identify", expect=expect))
    # outputs that cannot be written, or exist
    blocker = folder / "a-file"
    blocker.write_text("not a folder\n")
    foreign = folder / "foreign"
    foreign.mkdir(exist_ok=True)
    (foreign / "notes.txt").write_text("mine\n")
    outputs = {
        "output-under-a-file": (["plan", str(good), "-o", str(blocker / "out")],
                                (str(blocker / "out"), "is a file, not a folder")),
        "output-in-proc": (["plan", str(good), "-o", "/proc/dloplan-out"],
                           ("/proc/dloplan-out", "expected a path in a folder")),
        "export-under-a-file": (["export", str(plan), "--format", "csv", "-o",
                                 str(blocker / "t.csv")], (str(blocker / "t.csv"),
                                                            "is a file, not a folder")),
        "output-is-a-file": (["plan", str(good), "-o", str(blocker)], (str(blocker),)),
        "output-foreign-folder": (["plan", str(good), "-o", str(foreign)], (str(foreign),)),
        "export-csv-onto-folder": (["export", str(plan), "--format", "csv", "-o", str(foreign)],
                                   (str(foreign),)),
    }
    for tag, (argv, expect) in outputs.items():
        checks = _untouched(blocker, "not a folder\n") if "file" in tag else _untouched(
            foreign / "notes.txt", "mine\n")
        cases.append(Case(f"r2/hostile/{tag}", argv, None, "plan",
                          needs=plan_case if argv[0] == "export" else None,
                          expect=expect, check=checks))
    return cases


def _harness_variants(stem: str, job: dict) -> dict[str, dict]:
    """A harness job with other cables, a fixture moved, one removed, and mirrored."""
    cable = job["cable"]["name"]
    variants = {f"cable_{c}": with_cable(job, c) for c in CABLES if c != cable}
    moved = copy.deepcopy(job)
    moved["harness"]["fixtures"][1]["position"][0] += 0.03
    moved["harness"]["fixtures"][1]["position"][1] -= 0.02
    variants["fixture_moved"] = moved
    closer = copy.deepcopy(job)
    for fixture in closer["harness"]["fixtures"]:
        fixture["position"][1] *= 0.8
    variants["fixtures_closer"] = closer
    single = copy.deepcopy(job)
    single["harness"]["fixtures"] = single["harness"]["fixtures"][:1]
    variants["one_fixture"] = single
    variants["mirror"] = mirror(job)
    return variants


def harness_cases(out: Path, quick: bool) -> list[Case]:
    """The harness jobs varied (other cables, a fixture moved, fixtures closer, one removed,
    mirrored) through ``plan --verify`` (their RAPID read back)."""
    cases = []
    for stem in HARNESS_JOBS[:1] if quick else HARNESS_JOBS:
        job = yaml.safe_load((EXAMPLES / f"{stem}.yaml").read_text())
        for tag, data in _harness_variants(stem, job).items():
            path = write_yaml(out / "jobs" / "r2" / stem / f"{tag}.yaml", data)
            target = out / "runs" / "r2" / stem / tag
            cases.append(Case(f"r2/harness/{stem}/{tag}", ["plan", str(path), "--verify", "-o",
                                                            str(target)], target,
                              check=_rapid_check(_base(data))))
    return cases


def _agreement(stem: str, coarse: int, fine: int, length: float):
    """Flags of the plan at ``fine`` links whose end shape is farther from the one at
    ``coarse`` than :data:`AGREEMENT` ``* length / coarse``."""
    def check(case: Case, done: dict) -> list[str]:
        from sweep_checks import end_shape_gap

        gap = end_shape_gap(done[f"r2/refine/{stem}/n{coarse}"].output / "plan.json",
                            case.output / "plan.json")
        bound = AGREEMENT * length / coarse
        case.result["note"] = (f"end shape vs n={coarse}: {gap * 1e3:.2f} mm "
                               f"(bound {bound * 1e3:.1f})")
        return [] if gap <= bound else [f"discretization: end shapes at n={coarse} and {fine} "
                                        f"differ by {gap * 1e3:.2f} mm > {bound * 1e3:.1f} mm"]
    return check


def _grip_agreement(stem: str, n: int):
    def check(case: Case, done: dict) -> list[str]:
        from sweep_checks import end_shape_gap

        base = done[f"r2/refine/{stem}/n{n}"].output / "plan.json"
        gap = max(end_shape_gap(base, case.output / "plan.json", key)
                  for key in ("shapes", "stabilized"))
        case.result["note"] = f"end shape vs the job's grip: {gap:.1e} m"
        return [] if gap <= TOLERANCE else [f"grip: another grip moved the end shape by "
                                            f"{gap * 1e3:.3f} mm"]
    return check


def refine_cases(out: Path, quick: bool) -> list[Case]:
    """One job at n, 2n, 4n links and with another grip: the end shapes agree within a bound
    that halves with n; the grip changes no shape."""
    from dloplan.cable import catalogue_cable

    cases = []
    for stem in REFINED_JOBS[:1] if quick else REFINED_JOBS:
        job = yaml.safe_load((EXAMPLES / f"{stem}.yaml").read_text())
        length = job["cable"].get("length") or catalogue_cable(job["cable"]["name"]).length
        for k, n in enumerate(REFINED_LINKS):
            path = write_yaml(out / "jobs" / "r2" / "refine" / stem / f"n{n}.yaml",
                          with_links(job, n))
            target = out / "runs" / "r2" / "refine" / stem / f"n{n}"
            check = _agreement(stem, REFINED_LINKS[k - 1], n, length) if k else None
            cases.append(Case(f"r2/refine/{stem}/n{n}", ["plan", str(path), "-o", str(target)],
                              target, check=check,
                              reads=(f"r2/refine/{stem}/n{REFINED_LINKS[k - 1]}",) if k else ()))
        n = REFINED_LINKS[1]
        for method in ("minimal", "rigid"):
            path = write_yaml(out / "jobs" / "r2" / "refine" / stem / f"n{n}_{method}.yaml",
                          with_grip(with_links(job, n), method))
            target = out / "runs" / "r2" / "refine" / stem / f"n{n}_{method}"
            cases.append(Case(f"r2/refine/{stem}/n{n} grip {method}",
                              ["plan", str(path), "-o", str(target)], target,
                              reads=(f"r2/refine/{stem}/n{n}",),
                              check=_grip_agreement(stem, n)))
    return cases


# ---------------------------------------------------------------------------------------------
# running


def _children_cpu() -> float:
    """CPU seconds [s] of the finished child processes (a run's figure workers included)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _default_sigint() -> None:
    """SIGINT's default action in the child: a sweep started in the background of a
    non-interactive shell ignores SIGINT, and a command keeps an ignored signal ignored (as
    ``nohup`` asks), so the Ctrl-C cases would interrupt nothing."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _run(argv: list[str], env: dict, timeout: float,
         interrupt: float | None) -> tuple[int | None, str, str]:
    """(exit code or None on a timeout, stdout, stderr) of one CLI run; with ``interrupt``,
    SIGINT to its process group after that many seconds, as a terminal's Ctrl-C sends it."""
    process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env=env, cwd=ROOT, start_new_session=True,
                               preexec_fn=_default_sigint if interrupt is not None else None)
    try:
        if interrupt is not None:
            try:
                process.wait(interrupt)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGINT)
        stdout, stderr = process.communicate(timeout=timeout)
        return process.returncode, stdout, stderr
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        stdout, stderr = process.communicate()
        return None, stdout or "", stderr or ""


def run_case(case: Case, timeout: float, done: dict[str, Case]) -> None:
    for name in filter(None, (case.needs, *case.reads)):
        if done.get(name, Case("", [])).result.get("code") not in (0, 1, 3):
            case.result = {"code": None, "seconds": 0.0, "verdict": f"skipped: {name} failed",
                           "flags": []}
            return
    if isinstance(case, Deferred):
        try:
            case.argv = case.make()
        except Exception as exc:  # noqa: BLE001 - the sweep reports, never stops
            case.result = {"code": None, "seconds": 0.0, "verdict": f"not made: {exc}",
                           "flags": []}
            return
    if case.output is not None and case.output.exists() and not case.keep:
        shutil.rmtree(case.output) if case.output.is_dir() else case.output.unlink()
    argv = [sys.executable, "-m", "dloplan", *case.argv, "--json"]
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    t0 = time.perf_counter()
    cpu0 = _children_cpu()
    code, stdout, stderr = _run(argv, env, timeout, case.interrupt)
    seconds = time.perf_counter() - t0
    cpu = _children_cpu() - cpu0
    summary = parse_summary(stdout)
    flags = flags_of(case, code, stdout, stderr, summary)
    if case.compare_with and case.compare_with[1] == "correction" and code in (0, 1, 3):
        base = done.get(case.compare_with[0])
        files = [c.output / "correction.json" for c in (base, case) if c and c.output]
        if len(files) == 2 and all(f.is_file() for f in files):
            a, b = (json.loads(f.read_text()) for f in files)
            de = abs(a["youngs_modulus"] / b["youngs_modulus"] - 1)
            dc = float(np.max(np.abs(np.subtract(a["clip_corrections"],
                                                 b["clip_corrections"]))))
            case.result["note"] = f"vs m: E {de:.0e} (relative), clips {dc:.0e}"
            if not (de <= 1e-6 and dc <= TOLERANCE):
                flags.append(f"invariance: correction in mm differs (E {de:.1e}, clips {dc:.1e})")
    elif case.compare_with and code in (0, 1, 3):
        base = done.get(case.compare_with[0])
        doc_a = _load_plan(base.output) if base and base.output else None
        doc_b = _load_plan(case.output)
        if doc_a is not None and doc_b is not None:
            measured: dict = {}
            notes = invariance(doc_a, doc_b, case.compare_with[1], TOLERANCE, measured)
            flags += [f"invariance: {n}" for n in notes if not n.startswith("skipped")]
            if any(n.startswith("skipped") for n in notes):
                case.result["note"] = notes[0]
            elif measured:
                case.result["note"] = "vs base: " + ", ".join(
                    f"{k} {v:.0e}" for k, v in measured.items())
        if base and base.result.get("code") != code:
            case.result["note"] = (case.result.get("note", "") +
                                   f"; exit {code}, base exit {base.result.get('code')}")
    if case.check is not None and code is not None:
        case.result.update({"code": code, "summary": summary})
        try:
            flags += case.check(case, done)
        except Exception as exc:  # noqa: BLE001 - the sweep reports, never stops
            flags.append(f"check: {type(exc).__name__}: {exc}"[:160])
    verdict = verdict_line(stdout, stderr, summary)
    if code == 2 or not verdict:
        verdict = _refusal(stderr, summary)[:160] or verdict
    case.result.update({"code": code, "seconds": round(seconds, 1), "cpu": round(cpu, 1),
                        "summary": summary,
                        "verdict": verdict,
                        "flags": flags, "stderr_tail": stderr[-2000:]})


TOLERANCE = 1e-6


def table(cases: list[Case]) -> str:
    rows = ["| case | exit | wall s | CPU s | verdict | flags |", "|---|---|---|---|---|---|"]
    for case in cases:
        r = case.result
        verdict = (r.get("verdict", "") + (f" ({r['note']})" if r.get("note") else ""))
        rows.append(f"| {case.name} | {r.get('code')} | {r.get('seconds', 0):.0f} | "
                    f"{r.get('cpu', 0):.0f} | "
                    f"{verdict.replace('|', '/')[:140]} | "
                    f"{'; '.join(r.get('flags', [])).replace('|', '/')} |")
    return "\n".join(rows)


def main(argv=None) -> int:
    global TOLERANCE
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="a small subset (64 runs, ~10 min on 2 shared cores)")
    parser.add_argument("--only", help="run only the cases whose name contains one of these "
                        "(comma-separated)")
    parser.add_argument("--out", type=Path, default=Path("/tmp/unseen_sweep"))
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds: a hang")
    parser.add_argument("--tolerance", type=float, default=1e-6,
                        help="invariance tolerance [m] (forces: x100, relative)")
    parser.add_argument("--list", action="store_true", help="list the cases, run nothing")
    args = parser.parse_args(argv)
    TOLERANCE = args.tolerance
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    from sweep_round3 import round3_cases

    cases = (job_cases(out, args.quick) + document_cases(out, args.quick)
             + identify_cases(out, args.quick) + measurement_cases(out, args.quick)
             + study_cases(out, args.quick) + rapid_cases(out, args.quick)
             + hostile_cases(out, args.quick) + harness_cases(out, args.quick)
             + refine_cases(out, args.quick) + round3_cases(out, args.quick))
    if args.only:
        patterns = args.only.split(",")
        wanted = [c for c in cases if any(p in c.name for p in patterns)]
        # the plans a wanted case reads, and the bases it is compared with, run first
        needed = {c.needs for c in wanted} | {c.compare_with[0] for c in wanted
                                               if c.compare_with} | {
            name for c in wanted for name in c.reads}
        cases = [c for c in cases if c in wanted or c.name in needed]
    if args.list:
        print("\n".join(" ".join(c.argv) if c.argv else c.name for c in cases))
        return 0
    done: dict[str, Case] = {}
    for case in cases:
        with case.setup() if hasattr(case, "setup") else contextlib.nullcontext():
            run_case(case, args.timeout, done)
        done[case.name] = case
        r = case.result
        print(f"{case.name:55s} exit {r.get('code')!s:4s} {r.get('seconds', 0):5.1f} s "
              f"(CPU {r.get('cpu', 0):5.1f} s)  "
              f"{r.get('verdict', '')[:70]}" + ("  FLAGS: " + "; ".join(r["flags"])
                                                 if r.get("flags") else ""), flush=True)
    text = table(cases)
    (out / "sweep.md").write_text(text + "\n")
    (out / "sweep.json").write_text(json.dumps(
        [{"name": c.name, "argv": c.argv, **c.result} for c in cases], indent=1))
    flagged = [c for c in cases if c.result.get("flags")]
    print(f"\n{len(cases)} runs, {len(flagged)} flagged; table: {out / 'sweep.md'}")
    return 1 if flagged else 0


if __name__ == "__main__":
    sys.modules.setdefault("unseen_sweep", sys.modules["__main__"])  # one module for round 3
    sys.exit(main())
