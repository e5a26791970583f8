"""The unseen-case sweep's third round (``tools/unseen_sweep.py --only r3/``).

* ``r3/cells``: the described cells' jobs (two UR5e, two Panda) and two YuMi jobs run on them,
  mirrored, turned, in mm, with a blend and in ``movel``, through ``plan --verify``; every program
  (URScript, the ur_rtde streamer's samples, the ROS 2 trajectories) read back with the vendor's
  kinematics and limits (``tools/cell_checks.py``);
* ``r3/obstacle``: the obstacle job mirrored, turned and in mm through ``plan --verify``: the
  cable's clearance from the box in every verified shape computed from the document (capsules
  against the box), the same in every variant, and the avoidance and verification verdicts the
  same;
* ``r3/identify``: the identification turned about the vertical (E must not move), at a coarser
  and a finer n, with noise and markers missing, another cable, and a cable simulated by MuJoCo
  (``tests/plants.py``) with another E than the catalogue's: its interval must hold the plant's
  E unless the run says why not;
* ``r3/study``: studies on a Dask scheduler (the same results as local workers), scheduler
  addresses that cannot work and bad study sections (each exit 2 naming what it expects);
* ``r3/interrupt``: Ctrl-C (SIGINT to the process group, as a terminal sends it) during a study,
  an identification and a verified plan: exit 130, nothing half-written beside the output (no
  staging folder, no lock), an interrupted study resumed to the uninterrupted study's results.
"""

from __future__ import annotations

import contextlib
import copy
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation
from unseen_sweep import (
    EXAMPLES,
    Case,
    mirror,
    rigid,
    to_millimetres,
    with_cable,
    with_cell,
    write_yaml,
)

CELL_JOBS = ("ur5e_pair_usb", "panda_pair_ethernet")
YUMI_ON_CELLS = ("qualitative2_ethernet_3d", "m1_sine_pu_hose")
OBSTACLE_JOB = "harness_phase1_obstacle"
CLEARANCE_TOLERANCE = 1e-6
"""[m] The obstacle clearance of a mirrored, turned or mm job equals the original's."""


def _cell_check():
    def check(case: Case, done: dict) -> list[str]:
        from cell_checks import cell_problems

        if case.result.get("code") not in (0, 1):
            return []
        problems = cell_problems(case.output)
        return [f"cell: {p}" for p in problems[:4]] + (
            [f"cell: ... {len(problems) - 4} more"] if len(problems) > 4 else [])
    return check


def _cell_job(stem: str) -> dict:
    path = EXAMPLES / "cells" / f"{stem}.yaml"
    job = yaml.safe_load(path.read_text())
    for arm in job["robot"].get("cell", {}).get("arms", {}).values():
        arm["urdf"] = str((path.parent / arm["urdf"]).resolve())
    return job


def _with_urscript(job: dict, **settings) -> dict:
    out = copy.deepcopy(job)
    urscript = out["robot"].setdefault("urscript", {})
    urscript.update(settings)
    return out


def facing_ur5e(job: dict) -> dict:
    """The UR5e job on two UR5e given by path, across the table from each other (bases at
    y = +-0.55 m, each turned to face the other), the programs in their own base frames."""
    out = copy.deepcopy(job)
    urdf = str(Path(__file__).resolve().parents[1] / "src" / "dloplan" / "robot" / "data"
                / "ur5e.urdf")
    arm = {"urdf": urdf, "tip_link": "tool0", "tcp_offset": [0.0, 0.0, 0.15],
           "tool_radius": 0.045, "home_deg": [0, -90, 90, -90, -90, 0]}
    out["robot"]["cell"] = {"name": "facing_ur5e", "arms": {
        "left": {**arm, "base_position": [0.5, 0.55, 0.0], "base_rpy": [0, 0, 90]},
        "right": {**arm, "base_position": [0.5, -0.55, 0.0], "base_rpy": [0, 0, -90]}}}
    return out


def cell_cases(out: Path, quick: bool) -> list[Case]:
    cases = []
    variants: dict[str, dict] = {}
    for stem in CELL_JOBS[:1] if quick else CELL_JOBS:
        job = _cell_job(stem)
        variants[f"{stem}/base"] = job
        variants[f"{stem}/mirror"] = mirror(job)
        variants[f"{stem}/turn25"] = rigid(job, 25.0, (0.02, -0.03, 0.0))
        variants[f"{stem}/mirror_turn-20"] = rigid(mirror(job), -20.0, (-0.02, 0.03, 0.0))
        if not quick:
            variants[f"{stem}/mm"] = to_millimetres(job)
            variants[f"{stem}/mirror_mm"] = to_millimetres(mirror(job))
        if stem.startswith("ur5e"):
            variants[f"{stem}/movel"] = _with_urscript(job, mode="movel")
            variants[f"{stem}/blend20mm"] = _with_urscript(job, blend=0.02)
            variants[f"{stem}/mm_movel_blend"] = _with_urscript(to_millimetres(job),
                                                                mode="movel", blend=5.0)
            variants[f"{stem}/facing"] = _with_urscript(facing_ur5e(job), mode="movel")
            variants[f"{stem}/facing_mirror_mm"] = to_millimetres(mirror(facing_ur5e(job)))
    cells = sorted((EXAMPLES / "cells").glob("*.yaml"))
    for stem in () if quick else YUMI_ON_CELLS:
        job = yaml.safe_load((EXAMPLES / f"{stem}.yaml").read_text())
        for cell in cells:
            variants[f"{stem}/{cell.stem.split('_')[0]}_mirror"] = with_cell(mirror(job), cell)
    for tag, data in variants.items():
        path = write_yaml(out / "jobs" / "r3" / "cells" / f"{tag}.yaml", data)
        target = out / "runs" / "r3" / "cells" / tag
        cases.append(Case(f"r3/cells/{tag}", ["plan", str(path), "--verify", "-o", str(target)],
                          target, check=_cell_check()))
    return cases


# ---------------------------------------------------------------------------------------------
# obstacles


def _box_distance(points: np.ndarray, box: dict) -> np.ndarray:
    """Distance [m] of ``points`` (k, 3) from a box ``{center, size, yaw [rad]}`` of a plan
    document (negative inside: minus the depth to the nearest face)."""
    local = Rotation.from_euler("z", box.get("yaw", 0.0)).inv().apply(
        points - np.asarray(box["center"], float))
    q = np.abs(local) - np.asarray(box["size"], float) / 2
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    return outside + np.minimum(q.max(axis=1), 0.0)


def clearance(plan: Path) -> float:
    """The smallest distance [m] between the cable's surface (its links as capsules of its
    radius, each sampled at 50 points) and any box obstacle, over every stabilized shape."""
    doc = json.loads(plan.read_text())
    radius = doc["cable"]["diameter"] / 2
    boxes = [o for o in doc.get("obstacles") or [] if o.get("type") == "box"]
    if not boxes:
        return float("inf")
    s = np.linspace(0.0, 1.0, 50)[:, None]
    best = np.inf
    for shape in doc["stabilized"]:
        x = np.asarray(shape, float)
        dense = (x[:-1, None] * (1 - s) + x[1:, None] * s).reshape(-1, 3)
        for box in boxes:
            best = min(best, float(_box_distance(dense, box).min()) - radius)
    return best


def _obstacle_check(base: str | None):
    def check(case: Case, done: dict) -> list[str]:
        if case.result.get("code") not in (0, 1, 3):
            return []
        plan = case.output / "plan.json"
        gap = clearance(plan)
        doc = json.loads(plan.read_text())
        flags = []
        case.result["note"] = f"clearance {gap * 1e3:.3f} mm"
        if gap < 0:
            flags.append(f"obstacle: a stabilized shape is {-gap * 1e3:.2f} mm inside the box")
        if base is None:
            return flags
        other = done[base]
        if other.result.get("code") is None:
            return flags
        base_doc = json.loads((other.output / "plan.json").read_text())
        base_gap = clearance(other.output / "plan.json")
        if abs(gap - base_gap) > CLEARANCE_TOLERANCE:
            flags.append(f"invariance: clearance {gap * 1e3:.4f} mm, the original's "
                         f"{base_gap * 1e3:.4f} mm")
        for key in ("status", "rounds"):
            if (doc.get("avoidance") or {}).get(key) != (base_doc.get("avoidance") or {}).get(key):
                flags.append(f"invariance: avoidance {key} {doc['avoidance'].get(key)!r}, the "
                             f"original's {base_doc['avoidance'].get(key)!r}")
        verdicts = [(d.get("verification") or {}).get("ok") for d in (doc, base_doc)]
        if verdicts[0] != verdicts[1]:
            flags.append(f"invariance: verification ok={verdicts[0]}, the original's "
                         f"{verdicts[1]}")
        kinds = [[r.get("kind") for r in d.get("repairs", [])] for d in (doc, base_doc)]
        if kinds[0] != kinds[1]:
            flags.append(f"invariance: repairs {kinds[0]}, the original's {kinds[1]}")
        if case.result.get("code") != other.result.get("code"):
            flags.append(f"invariance: exit {case.result.get('code')}, the original's "
                         f"{other.result.get('code')}")
        return flags
    return check


def obstacle_cases(out: Path, quick: bool) -> list[Case]:
    job = yaml.safe_load((EXAMPLES / f"{OBSTACLE_JOB}.yaml").read_text())
    job.pop("robot", None)   # the YuMi on the table (its base 0.1 m above it), not at z = 0
    variants = {"base": job, "mirror": mirror(job), "turn30": rigid(job, 30.0, (0.0, 0.0, 0.0)),
                "mm": to_millimetres(job)}
    if not quick:
        variants["mirror_turn-15_mm"] = to_millimetres(rigid(mirror(job), -15.0, (0, 0, 0)))
        for cable in ("pu", "ethernet"):
            variants[f"cable_{cable}"] = with_cable(job, cable)
    cases = []
    for tag, data in variants.items():
        path = write_yaml(out / "jobs" / "r3" / "obstacle" / f"{tag}.yaml", data)
        target = out / "runs" / "r3" / "obstacle" / tag
        base = None if tag == "base" or tag.startswith("cable") else "r3/obstacle/base"
        cases.append(Case(f"r3/obstacle/{tag}", ["plan", str(path), "--verify", "--allow-"
                                                 "placement", "-o", str(target)], target,
                          reads=(base,) if base else (), check=_obstacle_check(base)))
    return cases


# ---------------------------------------------------------------------------------------------
# identification


def _turned_identification(data: dict, degrees: float) -> dict:
    """The identification turned about the vertical through the origin by ``degrees``."""
    out = copy.deepcopy(data)
    turn = Rotation.from_euler("z", degrees, degrees=True)
    ident = out["identify"]
    for key in ("initial_shape", "measured_shape"):
        ident[key] = turn.apply(np.asarray(ident[key], float)).tolist()
    for step in ident["trajectory"]:
        for end in step.values():
            end["position"] = turn.apply(np.asarray(end["position"], float)).tolist()
            end["rotation"] = {"quaternion": (turn * Rotation.from_quat(
                end["rotation"]["quaternion"])).as_quat().tolist()}
    return out


def _same_modulus(base: str, relative: float, interval: bool = False):
    """E within ``relative`` of the base run's (or within its 95 % interval widened by the
    other's, ``interval``)."""
    def check(case: Case, done: dict) -> list[str]:
        other = done[base].result.get("summary") or {}
        mine = case.result.get("summary") or {}
        if "youngs_modulus" not in other or "youngs_modulus" not in mine:
            return []
        e0, e1 = other["youngs_modulus"], mine["youngs_modulus"]
        case.result["note"] = f"E {e1:.4e} Pa against {e0:.4e} ({e1 / e0 - 1:+.1e})"
        if interval:
            lo = min(other["confidence_interval"][0], mine["confidence_interval"][0])
            hi = max(other["confidence_interval"][1], mine["confidence_interval"][1])
            ok = lo <= e0 <= hi and lo <= e1 <= hi and (
                mine["confidence_interval"][0] <= other["confidence_interval"][1]
                and other["confidence_interval"][0] <= mine["confidence_interval"][1])
            return [] if ok else [f"identify: E {e1:.4e} Pa, interval "
                                  f"{mine['confidence_interval']}, does not overlap the "
                                  f"original's {other['confidence_interval']}"]
        return [] if abs(e1 / e0 - 1) <= relative else [
            f"invariance: E {e1:.6e} Pa, the original's {e0:.6e} ({e1 / e0 - 1:+.1e})"]
    return check


def identify_cases(out: Path, quick: bool) -> list[Case]:
    data = yaml.safe_load((EXAMPLES / "identify_ethernet.yaml").read_text())
    measured = np.asarray(data["identify"]["measured_shape"], float)
    rng = np.random.default_rng(11)
    variants: dict[str, tuple[dict, object]] = {"base": (data, None)}
    variants["turn30"] = (_turned_identification(data, 30.0), _same_modulus("r3/identify/base",
                                                                           1e-4))
    variants["mirror_turn-120"] = (_turned_identification(mirror_identification(data), -120.0),
                                   _same_modulus("r3/identify/base", 1e-4))
    for n in (8, 32):
        changed = copy.deepcopy(data)
        changed["cable"]["n_links"] = n
        variants[f"n{n}"] = (changed, _same_modulus("r3/identify/base", 0.0, interval=True))
    holes = copy.deepcopy(data)
    keep = np.ones(len(measured), bool)
    keep[rng.choice(np.arange(3, len(measured) - 3), 8, replace=False)] = False
    holes["identify"]["measured_shape"] = (measured[keep] + rng.normal(0, 2.0, (keep.sum(), 3))
                                           ).tolist()
    holes["identify"]["measurement_noise"] = 2.0
    variants["noise2mm_8missing"] = (holes, _same_modulus("r3/identify/base", 0.0,
                                                          interval=True))
    if not quick:
        variants["cable_usb"] = ({**copy.deepcopy(data), "cable": {
            "name": "usb", "n_links": 16, "youngs_modulus": "identify"}}, None)
        gap = copy.deepcopy(data)
        cut = np.r_[measured[:20], measured[30:]]
        gap["identify"]["measured_shape"] = cut.tolist()
        variants["gap_10_markers"] = (gap, _same_modulus("r3/identify/base", 0.0,
                                                         interval=True))
    cases = []
    for tag, (job, check) in variants.items():
        path = write_yaml(out / "jobs" / "r3" / "identify" / f"{tag}.yaml", job)
        target = out / "runs" / "r3" / "identify" / tag
        cases.append(Case(f"r3/identify/{tag}", ["identify", str(path), "-o", str(target)],
                          target, "identify", check=check,
                          reads=("r3/identify/base",) if check else ()))
    return cases


def mirror_identification(data: dict) -> dict:
    """The identification mirrored in the x-z plane (y -> -y; rotations conjugated)."""
    out = copy.deepcopy(data)
    flip = np.diag([1.0, -1.0, 1.0])
    ident = out["identify"]
    for key in ("initial_shape", "measured_shape"):
        ident[key] = (np.asarray(ident[key], float) * [1, -1, 1]).tolist()
    for step in ident["trajectory"]:
        for end in step.values():
            end["position"] = [end["position"][0], -end["position"][1], end["position"][2]]
            matrix = Rotation.from_quat(end["rotation"]["quaternion"]).as_matrix()
            end["rotation"] = {"quaternion": Rotation.from_matrix(
                flip @ matrix @ flip).as_quat().tolist()}
    return out


# ---------------------------------------------------------------------------------------------
# studies: Dask, bad specs


class Scheduler:
    """A Dask scheduler and one worker on this machine, started for the sweep's Dask cases and
    ended by their process ids."""

    def __init__(self, port: int = 8797):
        self.address = f"tcp://127.0.0.1:{port}"
        self.processes: list[subprocess.Popen] = []
        self.port = port

    def start(self) -> None:
        bindir = Path(sys.executable).parent
        self.processes.append(subprocess.Popen(
            [str(bindir / "dask"), "scheduler", "--port", str(self.port), "--no-dashboard"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        self.processes.append(subprocess.Popen(
            [str(bindir / "dask"), "worker", self.address, "--nworkers", "1", "--nthreads", "1",
             "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))

    def stop(self) -> None:
        for process in reversed(self.processes):
            process.terminate()
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
        self.processes.clear()


SCHEDULER = Scheduler()


def _same_study(base: str):
    def check(case: Case, done: dict) -> list[str]:
        if case.result.get("code") not in (0, 1):
            return []
        a = json.loads((done[base].output / "summary.json").read_text())
        b = json.loads((case.output / "summary.json").read_text())
        keys = ("n_samples", "n_success", "failures", "deviation_m")
        diff = [k for k in keys if a.get(k) != b.get(k)]
        rows = [(c.output / "results.csv").read_text() for c in (done[base], case)]
        if rows[0] != rows[1]:
            diff.append("results.csv")
        return [f"study: {', '.join(diff)} differ from {base}"] if diff else []
    return check


def study_cases(out: Path, quick: bool) -> list[Case]:
    job = yaml.safe_load((EXAMPLES / "study_m2_ethernet.yaml").read_text())
    folder = out / "jobs" / "r3" / "study"
    good = write_yaml(folder / "good.yaml", job)
    cases = []
    local = out / "runs" / "r3" / "study" / "local"
    cases.append(Case("r3/study/local", ["study", str(good), "--samples", "24", "--workers",
                                         "2", "--csv", "--seed", "5", "-o", str(local)],
                      local, "study"))
    dask = out / "runs" / "r3" / "study" / "dask"
    cases.append(DaskCase("r3/study/dask", ["study", str(good), "--samples", "24",
                                            "--scheduler", SCHEDULER.address, "--csv",
                                            "--seed", "5", "-o", str(dask)], dask, "study",
                          reads=("r3/study/local",), check=_same_study("r3/study/local")))
    bad_address = {
        "scheduler-closed-port": ("tcp://127.0.0.1:9", ("tcp://127.0.0.1:9",)),
        "scheduler-no-scheme": ("127.0.0.1:8786", ("scheduler", "tcp://")),
        "scheduler-empty": ("", ("scheduler",)),
    }
    for tag, (address, expect) in bad_address.items():
        target = out / "runs" / "r3" / "study" / tag
        cases.append(Case(f"r3/study/{tag}", ["study", str(good), "--samples", "4",
                                              "--scheduler", address, "-o", str(target)],
                          target, "study", expect=expect))
    target = out / "runs" / "r3" / "study" / "scheduler-and-workers"
    cases.append(Case("r3/study/scheduler-and-workers", [
        "study", str(good), "--samples", "4", "--scheduler", SCHEDULER.address, "--workers",
        "2", "-o", str(target)], target, "study", expect=("--workers", "--scheduler")))
    specs = {
        "samples-zero": (lambda s: s.__setitem__("samples", 0), ("samples", "0")),
        "spread-negative": (lambda s: s["parameters"]["youngs_modulus"].__setitem__(
            "spread", -30), ("spread", "-30")),
        "parameter-unknown": (lambda s: s["parameters"].__setitem__("colour", {"spread": 1}),
                              ("colour",)),
        "criterion-text": (lambda s: s["criteria"].__setitem__("max_deviation", "ten"),
                           ("max_deviation", "ten")),
        "spread-nan": (lambda s: s["parameters"]["clip_position"].__setitem__(
            "spread", float("nan")), ("spread", "nan")),
        "parameters-empty": (lambda s: s.__setitem__("parameters", {}), ("parameters",)),
        "seed-float": (lambda s: s.__setitem__("seed", 1.5), ("seed", "integer")),
        "samples-huge": (lambda s: s.__setitem__("samples", 10**9), ("samples",)),
    }
    for tag, (change, expect) in specs.items():
        data = copy.deepcopy(job)
        change(data["study"])
        path = write_yaml(folder / f"{tag}.yaml", data)
        target = out / "runs" / "r3" / "study" / tag
        cases.append(Case(f"r3/study/{tag}", ["study", str(path), "-o", str(target)], target,
                          "study", expect=expect))
    return cases


class DaskCase(Case):
    """A case that runs with the sweep's Dask scheduler up (started before, ended after)."""

    @contextlib.contextmanager
    def setup(self):
        SCHEDULER.start()
        try:
            time.sleep(3.0)   # the scheduler listening, its worker registered
            yield
        finally:
            SCHEDULER.stop()


# ---------------------------------------------------------------------------------------------
# Ctrl-C


def _nothing_half(case: Case, done: dict) -> list[str]:
    """Exit 130 and nothing half-written: no staging folder or lock beside the output; an
    output folder, if any, is a complete earlier one (none here) or a study's resumable one."""
    flags = []
    code = case.result.get("code")
    if code in (0, 1, 3):
        case.result["note"] = "finished before the signal"
        return flags
    if code != 130:
        flags.append(f"interrupt: exit {code}, expected 130")
    parent = case.output.parent
    left = [p.name for p in parent.iterdir() if p.name.startswith(f".{case.output.name}.")] \
        if parent.is_dir() else []
    if left:
        flags.append(f"half: {', '.join(sorted(left))} left beside the output")
    if case.kind != "study" and case.output.exists():
        flags.append(f"half: {case.output.name} written by an interrupted run")
    return flags


def interrupt_cases(out: Path, quick: bool) -> list[Case]:
    study = out / "jobs" / "r3" / "study" / "good.yaml"
    cases = []
    for seconds in (3.0, 12.0):
        target = out / "runs" / "r3" / "interrupt" / f"study_{seconds:g}s"
        cases.append(Case(f"r3/interrupt/study at {seconds:g} s", [
            "study", str(study), "--samples", "24", "--workers", "2", "--csv", "--seed", "5",
            "-o", str(target)], target, "study", interrupt=seconds, check=_nothing_half,
            reads=("r3/study/local",)))
        cases.append(Case(f"r3/interrupt/study at {seconds:g} s resumed", [
            "study", str(study), "--samples", "24", "--workers", "2", "--csv", "--seed", "5",
            "-o", str(target)], target, "study", keep=True,
            reads=("r3/study/local",),
            check=_same_study("r3/study/local")))
    ident = EXAMPLES / "identify_ethernet.yaml"
    for seconds in (1.5, 8.0):
        target = out / "runs" / "r3" / "interrupt" / f"identify_{seconds:g}s"
        cases.append(Case(f"r3/interrupt/identify at {seconds:g} s", [
            "identify", str(ident), "-o", str(target)], target, "identify", interrupt=seconds,
            check=_nothing_half))
    plan = EXAMPLES / "qualitative2_ethernet_3d.yaml"
    for seconds in (2.0, 12.0):
        target = out / "runs" / "r3" / "interrupt" / f"plan_{seconds:g}s"
        cases.append(Case(f"r3/interrupt/plan --verify at {seconds:g} s", [
            "plan", str(plan), "--verify", "-o", str(target)], target, interrupt=seconds,
            check=_nothing_half))
    return cases


def round3_cases(out: Path, quick: bool) -> list[Case]:
    """Every case of round 3 (see the module)."""
    return (cell_cases(out, quick) + obstacle_cases(out, quick) + identify_cases(out, quick)
            + plant_cases(out, quick) + study_cases(out, quick) + interrupt_cases(out, quick))


# ---------------------------------------------------------------------------------------------
# identification of a cable simulated by another simulator

PLANT_FACTOR = 1.4
"""The plant's E is the catalogue Ethernet's times this: the model's starting cable is not the
real one."""


def plant_identification(path: Path, steps: int = 5) -> Path:
    """An identification file (mm) whose measured shape is MuJoCo's cable (``tests/plants.py``:
    32 segments, E = :data:`PLANT_FACTOR` x the catalogue's, clamped over one model link) held
    by both ends, brought 15 cm closer and each tilted 20 deg down from a straight cable at
    z = 0.3 m, measured at 45 points with 0.5 mm noise."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from dataclasses import replace

    from plants import MujocoPlant

    from dloplan.cable import catalogue_cable
    from dloplan.sim.clips import ClipPoses

    model = catalogue_cable("ethernet", n_links=16)
    real = replace(catalogue_cable("ethernet", n_links=32),
                   youngs_modulus=model.youngs_modulus * PLANT_FACTOR)
    plant = MujocoPlant(real, noise=5e-4, n_measured=45, seed=3, clamp=model.rest_link_length)
    half = model.rest_link_length / 2
    length = model.length
    start = np.column_stack([np.linspace(0.0, length, 33), np.zeros(33), np.full(33, 0.3)])
    first0 = Rotation.identity()
    last0 = Rotation.from_euler("z", 180, degrees=True)
    poses = []
    for t in np.linspace(0.0, 1.0, steps + 1):
        positions = np.array([[half + 0.075 * t, 0.0, 0.3], [length - half - 0.075 * t, 0.0, 0.3]])
        tilt = 20.0 * t
        rotations = Rotation.concatenate([
            Rotation.from_euler("y", tilt, degrees=True) * first0,
            Rotation.from_euler("y", -tilt, degrees=True) * last0])
        poses.append(ClipPoses(positions, rotations))
    shape = start
    for clips in poses[1:]:
        shape, ok, message = plant.hold(shape, clips)
        if not ok:
            raise RuntimeError(f"the MuJoCo plant did not come to rest: {message}")
    measured = plant.measure(shape, np.random.default_rng(3))

    def pose(clips, k):
        return {"position": (clips.positions[k] * 1e3).tolist(),
                "rotation": {"quaternion": clips.rotations[k].as_quat().tolist()}}

    data = {"version": 1, "units": "mm",
            "cable": {"name": "ethernet", "n_links": 16, "youngs_modulus": "identify"},
            "identify": {
                "held": "both", "measurement_noise": 0.5, "bounds": [1e5, 1e10],
                "simulator": "branch",
                "initial_shape": (np.column_stack([np.linspace(0.0, length, 17), np.zeros(17),
                                                   np.full(17, 0.3)]) * 1e3).tolist(),
                "trajectory": [{"first": pose(c, 0), "last": pose(c, 1)} for c in poses],
                "measured_shape": (measured * 1e3).tolist()}}
    return write_yaml(path, data)


def _plant_modulus(case: Case, done: dict) -> list[str]:
    """The identified interval holds the plant's E, or the run says the model does not explain
    the measurement (a warning, or not informative)."""
    from dloplan.cable import catalogue_cable

    summary = case.result.get("summary") or {}
    if summary.get("youngs_modulus") is None:  # not identified: its reason is the verdict
        case.result["note"] = str(summary.get("reason", ""))[:100]
        return []
    true = catalogue_cable("ethernet").youngs_modulus * PLANT_FACTOR
    low, high = summary["confidence_interval"]
    case.result["note"] = (f"E {summary['youngs_modulus']:.4e} Pa, the plant's {true:.4e} "
                           f"({summary['youngs_modulus'] / true - 1:+.1%}), interval "
                           f"{low:.3e}..{high:.3e}, noise ratio {summary.get('noise_ratio')}")
    if low <= true <= high or summary.get("warnings") or not summary.get("informative", True):
        return []
    return [f"identify: the plant's E {true:.4e} Pa outside the 95 % interval "
            f"{low:.4e}..{high:.4e} of a run that warns of nothing"]


def plant_cases(out: Path, quick: bool) -> list[Case]:
    from unseen_sweep import Deferred

    path = out / "jobs" / "r3" / "identify" / "mujoco_plant.yaml"
    target = out / "runs" / "r3" / "identify" / "mujoco_plant"

    def make():
        plant_identification(path)
        return ["identify", str(path), "-o", str(target)]

    case = Deferred("r3/identify/mujoco_plant", make, "identify", None, target)
    case.check = _plant_modulus
    return [case]
