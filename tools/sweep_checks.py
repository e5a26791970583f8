"""Checks of the unseen-case sweep's second round (``tools/unseen_sweep.py``) on what a run wrote.

They read the files as their consumer reads them, not as dloplan wrote them:

* :func:`rapid_problems`: the RAPID modules of a YuMi plan parsed back (as a controller does)
  and held against the plan document: every robtarget's pose, in the work object and the
  robot's base frame, where the plan puts the TCP; its ``eax_a`` the verified joints' arm
  angle, not joint 7 (the controller's IK with that arm angle and confdata gives the verified
  joints back); the start ``jointtarget`` the first target's joints in ABB axis order; the base
  frame ``yumi_base_link`` where the job puts it (0.1 m above the table the robot stands on,
  without a ``robot.base_position``), the work object the plan's origin in it; both tasks'
  synchronization (the same sync points with the same identifiers, the same move IDs, in the
  same order); and the joint speeds of each ``MoveL`` timed ``\\T`` between two targets,
  tracked by IK along the TCP's line with the arm angle moving linearly, against the
  joint-speed limits and the plan's reported peak (a peak is at least the move's average
  rate);
* :func:`same_files`: two exports of one plan hold the same text;
* :func:`end_shape_gap`: the largest distance [m] between two plans' final (stabilized)
  shapes, both resampled by arc length (plans of one job at two n, or with two grips).
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from robot_plans import read_module  # noqa: E402 - the tests' RAPID reader, one reader only

from dloplan.app.document_file import read_plan  # noqa: E402
from dloplan.pipeline.document import document_cell  # noqa: E402
from dloplan.robot import IKOptions, inverse  # noqa: E402
from dloplan.robot.robtarget import ROUND_TRIP_TOLERANCE, solve_robtarget  # noqa: E402

POSITION_TOLERANCE = 1e-4
"""A robtarget read back within 0.1 mm of the plan's TCP position [m]."""
ANGLE_TOLERANCE = 1e-4
"""``eax_a`` and the start jointtarget within 1e-4 deg of the plan's (6 decimals written)."""
SAMPLES = 24
"""IK samples along each MoveL for its joint speeds."""
SYNC_WORDS = re.compile(r"^(SyncMoveOn|SyncMoveOff|WaitSyncTask) (\w+)|\\ID:=(\d+)")


def _abb_to_urdf(values) -> np.ndarray:
    """A jointtarget's axes (ABB 1, 2, 3, 4, 5, 6 and eax_a = axis 7) in the URDF's order
    (1, 2, 7, 3, 4, 5, 6) [deg]."""
    robax, extax = values
    return np.r_[robax[:2], extax[0], robax[2:]]


def _sync_sequence(body: list[str]) -> list[str]:
    """The synchronization words of a motion procedure, in order: sync points with their
    identifiers and the move IDs."""
    out = []
    for line in body:
        for match in SYNC_WORDS.finditer(line):
            out.append(f"{match.group(1)} {match.group(2)}" if match.group(1)
                       else f"ID {match.group(3)}")
    return out


def _moves(body: list[str]) -> list[tuple[str, float]]:
    """(robtarget, duration ``\\T`` [s]) of every MoveL, in order."""
    return [(m.group(1), float(m.group(2))) for line in body
            for m in [re.match(r"MoveL (\w+) .*\\T:=([\d.eE+-]+)", line)] if m]


def _joint_rates(arm, start: np.ndarray, poses, duration: float) -> tuple[np.ndarray, bool]:
    """(n,) average and peak-bound joint rates [rad/s] of a MoveL from ``start`` joints along the
    line between two poses ``(position, Rotation, arm angle)`` taking ``duration`` [s]: the
    average is the joints' total variation over the duration (a peak is at least that), the
    bound the largest dq/ds times twice 1/duration (a law cruising at up to twice its average
    rate). Second value: whether the IK followed the line."""
    (p0, r0, a0), (p1, r1, a1) = poses
    slerp = Slerp([0.0, 1.0], Rotation.concatenate([r0, r1]))
    s = np.linspace(0.0, 1.0, SAMPLES + 1)
    q, path = start, [start]
    for t in s[1:]:
        res = inverse(arm, (1 - t) * p0 + t * p1, slerp(t), seed=q,
                      options=IKOptions(restarts=0), arm_angle=(1 - t) * a0 + t * a1)
        if not res.success:
            return np.zeros_like(start), False
        q = res.q
        path.append(q)
    dq = np.abs(np.diff(np.asarray(path), axis=0))
    average = dq.sum(axis=0) / duration
    bound = 2.0 * dq.max(axis=0) / np.diff(s)[0] / duration
    return np.vstack([average, bound]), True


def rapid_problems(folder: Path, base=(0.0, 0.0, 0.0)) -> list[str]:
    """What in ``folder/rapid/*.mod`` disagrees with ``folder/plan.json`` (see the module).

    Parameters
    ----------
    folder : Path
        A plan's output folder holding ``plan.json`` and ``rapid/``.
    base : array_like
        (3,) where the job puts the robot's base frame in the plan's frame [m] (its
        ``robot.base_position``; without one, 0.1 m above the table, or the origin).

    Returns
    -------
    list of str
        One line per problem; empty when the modules are the plan.
    """
    doc = read_plan(folder / "plan.json")
    data = json.loads((folder / "plan.json").read_text())
    modules = sorted((folder / "rapid").glob("*.mod"))
    if len(modules) != 2:
        return [f"rapid: {len(modules)} modules, expected 2"]
    cell = document_cell(doc)
    program = data["robot"]["program"]
    targets = program["targets"]
    problems = []
    written = np.asarray(data["robot"]["cell"]["base_position"], float)
    if np.abs(written - np.asarray(base, float)).max() > 1e-9:
        problems.append(f"base frame at {written.tolist()} m, the job puts it at {list(base)}")
    read = [read_module(path.read_text()) for path in modules]
    sync = [_sync_sequence(m["procs"]["dloplan_move"]) for m in read]
    if sync[0] != sync[1]:
        first = next(i for i, (a, b) in enumerate(zip(*sync, strict=False)) if a != b) \
            if any(a != b for a, b in zip(*sync, strict=False)) else min(map(len, sync))
        problems.append(f"sync: the tasks differ at step {first} ({sync[0][first:first + 1]} "
                        f"against {sync[1][first:first + 1]}; {len(sync[0])} and "
                        f"{len(sync[1])} steps)")
    limits_ratio = []
    for a, (side, module) in enumerate(zip(("left", "right"), read, strict=True)):
        decl = module["declarations"]
        arm = cell.robot.arms[a]
        uframe = decl[cell.wobj][2][3]
        wobj_pos = np.asarray(uframe[0], float) / 1e3
        wobj_rot = Rotation.from_quat(uframe[1], scalar_first=True)
        origin = -cell.base_rotation.inv().apply(np.asarray(base, float))
        if np.linalg.norm(wobj_pos - origin) > POSITION_TOLERANCE:
            problems.append(f"{side}: work object at {(wobj_pos * 1e3).round(3).tolist()} mm in "
                            f"the base frame, the plan's origin is at "
                            f"{(origin * 1e3).round(3).tolist()} mm")
        names = sorted(n for n, d in decl.items() if d[1] == "robtarget")
        if len(names) != len(targets):
            problems.append(f"{side}: {len(names)} robtargets, the plan has {len(targets)}")
            continue
        start = np.radians(_abb_to_urdf(decl["dlo_start"][2]))
        want0 = np.radians(targets[0]["arms"][side]["joints_deg"])
        if np.degrees(np.abs(start - want0)).max() > ANGLE_TOLERANCE:
            problems.append(f"{side}: jointtarget dlo_start is {np.degrees(start).round(4)} "
                            f"deg, the plan's first target {np.degrees(want0).round(4)}")
        poses = {}
        for name, target in zip(names, targets, strict=True):
            trans, quat, conf, extax = decl[name][2]
            plan = target["arms"][side]
            p = cell.base_rotation.apply(wobj_pos + wobj_rot.apply(np.asarray(trans) / 1e3)) \
                + cell.base_position
            r = cell.base_rotation * wobj_rot * Rotation.from_quat(quat, scalar_first=True)
            poses[name] = (p, r, np.radians(extax[0]))
            where = f"{side} {name} ({target['label']})"
            if np.linalg.norm(p - plan["position"]) > POSITION_TOLERANCE:
                problems.append(f"{where}: at {np.round(p, 5).tolist()} m, the plan's TCP at "
                                f"{plan['position']}")
            if abs(extax[0] - plan["arm_angle_deg"]) > ANGLE_TOLERANCE:
                problems.append(f"{where}: eax_a {extax[0]} deg, the arm angle is "
                                f"{plan['arm_angle_deg']} deg (joint 7: "
                                f"{plan['joints_deg'][2]:.4f})")
            found = solve_robtarget(arm, p, r.as_matrix(), np.radians(extax[0]), conf)
            miss = found.deviation(np.radians(plan["joints_deg"]))
            if miss > ROUND_TRIP_TOLERANCE:
                problems.append(f"{where}: the controller's IK of the robtarget misses the "
                                f"verified joints by {miss:.3g} rad")
        joints = {n: np.radians(t["arms"][side]["joints_deg"])
                  for n, t in zip(names, targets, strict=True)}
        moves = _moves(module["procs"]["dloplan_move"])
        for (before, _), (name, duration) in zip(moves[:-1], moves[1:], strict=True):
            rates, followed = _joint_rates(arm, joints[before], (poses[before], poses[name]),
                                           duration)
            if not followed:
                problems.append(f"{side} MoveL {name}: the IK does not follow its line")
                continue
            ratio = rates / np.asarray(arm.max_velocity)
            limits_ratio.append((ratio[0].max(), ratio[1].max(), f"{side} {name}"))
    if limits_ratio:
        average, bound, where = max(limits_ratio)
        reported = next((c["worst"] for c in program["summary"] if c["check"] == "joint speed"),
                        None)
        if average > 1.0:
            problems.append(f"joint speed: {where} averages {average:.0%} of a joint's limit")
        if reported is not None and reported < average * 0.99:
            problems.append(f"joint speed: the plan reports a peak of {reported:.0%} of the "
                            f"limit, below the average {average:.0%} of {where}")
        if reported is not None and bound <= 1.0 and reported > 1.0:
            problems.append(f"joint speed: the plan reports {reported:.0%}, the bound is "
                            f"{bound:.0%}")
    return problems


def same_files(a: Path, b: Path) -> list[str]:
    """The files of ``a`` and ``b`` (two folders or two files) whose text differs."""
    if a.is_file() or b.is_file():
        return [] if a.read_text() == b.read_text() else [f"{a.name} differs"]
    names = sorted({p.relative_to(a) for p in a.rglob("*") if p.is_file()}
                   | {p.relative_to(b) for p in b.rglob("*") if p.is_file()})
    return [f"{n} differs" for n in names
            if not ((a / n).is_file() and (b / n).is_file()
                    and (a / n).read_text() == (b / n).read_text())]


def _resampled(points: np.ndarray, count: int = 101) -> np.ndarray:
    """``points`` (k, 3) resampled at ``count`` equally spaced arc lengths."""
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]
    u = np.linspace(0.0, s[-1], count)
    return np.column_stack([np.interp(u, s, points[:, k]) for k in range(3)])


def end_shape_gap(plan_a: Path, plan_b: Path, key: str = "stabilized") -> float:
    """Largest distance [m] between the last ``key`` shapes of two plan documents, each
    resampled by arc length."""
    shapes = [np.asarray(json.loads(p.read_text())[key][-1], float) for p in (plan_a, plan_b)]
    a, b = (_resampled(s) for s in shapes)
    return float(np.linalg.norm(a - b, axis=1).max())
