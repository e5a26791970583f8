"""The plan's figures and its HTML report, made from the plan document alone.

Everything shown is read from the :class:`~dloplan.pipeline.document.PlanDocument`, so the report of
a plan written by ``dloplan plan`` and of the same plan read back from ``plan.json`` are the
same page.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..obstacles.shapes import Table
from ..pipeline.document import PlanDocument
from ..plots.figures import PNG

VERIFY_TITLES = {
    "index": "shape", "smallest_eigenvalue": "lambda_1 [N/m]",
    "relative_eigenvalue": "lambda_1 / ref", "snap": "snap", "straying": "stray [mm]",
    "reachable_left": "left arm reaches", "reachable_right": "right arm reaches",
    "joint_margin": "joint margin [rad]", "replay_deviation": "replay deviation [mm]",
}
"""Column titles (with units) of the verification table: lengths in mm, as on the console."""

MILLIMETRE_COLUMNS = {"straying", "replay_deviation"}


def figure_names(doc: PlanDocument) -> list[str]:
    """Stems of the figures :func:`write_figures` writes for this document."""
    names = ["planned_path"]
    if doc.stabilized is not None:
        names.append("stabilized_path")
    names += ["forces" if list(doc.forces) == ["physical"] else f"forces_{phase}"
              for phase in doc.forces]
    if doc.stages is not None:
        names.append("lengths")
    if doc.trajectory is not None:
        names.append("motion_profile")
    return names


def figure_drawings(doc: PlanDocument, formats: tuple[str, ...] = PNG) -> list:
    """The plan's figures still to draw (:class:`dloplan.plots.figures.Drawing`, named by
    :func:`figure_names`): path with frames, stabilized, forces, lengths, motion profile; each
    to be written in ``formats`` (:data:`~dloplan.plots.figures.PNG` by default,
    :data:`~dloplan.plots.figures.WITH_SVG` for the SVG copies too)."""
    from ..plots.figures import (
        Drawing,
        forces_figure,
        lengths_figure,
        motion_profile_figure,
        path_figure,
        stabilized_figure,
    )

    positions = None if doc.grippers is None else doc.grippers.positions
    matrices = None if doc.grippers is None else doc.grippers.matrices
    edges = [edge for obstacle in doc.obstacles for edge in obstacle.edges()]
    figures = [(path_figure, (doc.shapes, positions, matrices, edges), {})]
    if doc.stabilized is not None:
        colliding = [] if doc.avoidance is None else doc.avoidance.colliding_after
        tables = [o.height for o in doc.obstacles if isinstance(o, Table)]
        figures.append((stabilized_figure, (doc.shapes, doc.stabilized, edges, tables,
                                            colliding), {}))
    for phase, stats in doc.forces.items():
        title = "Forces per mass point" + ("" if phase == "physical" else f", {phase}")
        figures.append((forces_figure, (stats.axial_mean, stats.axial_variance,
                                        stats.bending_mean, stats.bending_variance, title), {}))
    if doc.stages is not None:
        lengths = dict(zip(("basic", "advanced", "physical"), doc.stages.lengths, strict=True))
        figures.append((lengths_figure, (lengths, doc.cable.length), {}))
    if doc.trajectory is not None:
        figures.append((motion_profile_figure, motion_arguments(doc.trajectory), {}))
    return [Drawing(name, draw, arguments, options, tuple(formats))
            for name, (draw, arguments, options) in zip(figure_names(doc), figures, strict=True)]


def lasting_drawings(doc: PlanDocument, formats: tuple[str, ...] = PNG) -> list:
    """The figures of :func:`figure_drawings` that neither the robot program nor a repair
    changes: the planner's forces and lengths (a repair keeps the planner's sections; the
    path, the stabilized shapes and the motion profile move with a placement, new frames, a
    slower motion or new shapes, and the program may slow the motion down); in ``formats``."""
    return [d for d in figure_drawings(doc, formats)
            if d.name == "lengths" or d.name.startswith("forces")]


def write_figures(doc: PlanDocument, folder, formats: tuple[str, ...] = PNG) -> list[Path]:
    """The plan's figures in ``formats`` (PNG by default; :data:`~dloplan.plots.figures.WITH_SVG`
    the SVG copies too), drawn here: path with frames, stabilized, forces, lengths, motion
    profile."""
    return [path for drawing in figure_drawings(doc, formats) for path in drawing.save(folder)]


def motion_arguments(trajectory) -> tuple:
    """The arguments of :func:`dloplan.plots.figures.motion_profile_figure`: TCP speed and
    acceleration of both arms against time, with the limits (1 ms samples)."""
    times = np.linspace(0.0, trajectory.duration, max(2, int(trajectory.duration * 1000) + 1))
    k = trajectory.kinematics(times)
    limits = trajectory.law.limits if trajectory.law is not None else None
    return (times, k.speed, k.acceleration, trajectory.times,
            limits.speed if limits else trajectory.max_speed,
            limits.acceleration if limits else None)


def summary_lines(doc: PlanDocument) -> list[str]:
    """The report's opening lines: verdict, cable, plan, motion, checks."""
    cable = doc.cable
    verdict = "verdict: " + ("FAILED" if not doc.ok else "ok, with warnings" if doc.warnings
                             else "ok")
    lines = [verdict,
             f"{cable.name or 'cable'}: L {cable.length:.4g} m, d {1e3 * cable.diameter:.1f} mm, "
             f"E {cable.youngs_modulus:.3g} Pa"
             + ("" if doc.stages is None else f" ({doc.stages.family})")
             + f", n = {cable.n_links}, S = {doc.n_shapes}"]
    if doc.cycle is not None:
        parts = ", ".join(f"{name} {t:.2f} s" for name, t in doc.cycle["breakdown"].items())
        lines.append(f"cycle {doc.cycle['cycle_time']:.2f} s = motion "
                     f"{doc.cycle['motion_time']:.2f} s + gripper actions "
                     f"{doc.cycle['action_time']:.2f} s ({parts})")
    if doc.trajectory is not None and doc.grippers is not None:
        twist = np.degrees(np.abs(doc.grippers.twist).max())
        roll = np.degrees(np.abs(doc.grippers.roll).max(axis=0))
        lines.append(f"trajectory {doc.trajectory.duration:.2f} s; gripper method "
                     f"{doc.grippers.method}; largest relative twist {twist:.1f} deg; clips roll "
                     f"up to {roll[0]:.1f} / {roll[1]:.1f} deg about the cable")
    if doc.target_check is not None:
        lines.append(doc.target_check.message)
    if doc.avoidance is not None:
        lines.append(f"obstacles: {doc.avoidance.message}")
    if doc.harness is not None:
        lines.append(doc.harness.get("message", ""))
        lines += [f"{name}: {t0:.2f} s to {t1:.2f} s"
                  for name, (t0, t1) in doc.harness.get("phase_times", {}).items()]
    if doc.correction is not None:  # a corrected plan read as the plan it corrects
        lines.append(doc.correction.get("message", "corrected"))
    lines += [f"repair: {r.get('kind', '')}: {r.get('change', '')}" for r in doc.repairs]
    if doc.placement is not None:
        made = "moved" if doc.placement.applied else "proposed, not made"
        lines.append(f"placement ({made}): {doc.placement.message}")
    if doc.robot is not None:
        lines.append(doc.robot.message)
    if doc.verification is not None:
        lines.append(f"verification: {doc.verification.messages[-1]}"
                     if doc.verification.ok else "verification: FAILED")
    return lines


def shape_table(doc: PlanDocument):
    """Per-shape rows: length, largest forces, stabilization moves, clip force and moment."""
    from ..geometry import shape_length
    from ..physics.chain import SpringChain, forces

    chain = SpringChain.from_cable(doc.cable)
    header = ["shape", "length [mm]", "max |F_axial| [N]", "max |F_bending| [N]"]
    if doc.stabilized is not None:
        header.append("stabilization moves [mm]")
    if doc.clip_wrenches is not None:
        header += ["force on clips [N]", "moment on clips [N m]"]
    rows = []
    for k, shape in enumerate(doc.shapes):
        f = forces(chain, shape)
        row = [k, f"{1e3 * shape_length(shape):.1f}",
               f"{np.linalg.norm(f.axial, axis=-1).max():.3g}",
               f"{np.linalg.norm(f.bending, axis=-1).max():.3g}"]
        if doc.stabilized is not None:
            moved = np.linalg.norm(doc.stabilized[k] - shape, axis=1).max()
            row.append(f"{1e3 * moved:.1f}")
        if doc.clip_wrenches is not None:
            wrench = doc.clip_wrenches[k]
            row += [" / ".join(f"{np.linalg.norm(w[:3]):.3g}" for w in wrench),
                    " / ".join(f"{np.linalg.norm(w[3:]):.3g}" for w in wrench)]
        rows.append(row)
    return "Shapes", header, rows


PHASE_TITLES = {
    "phase": "phase", "holders": "held by", "configurations": "configurations",
    "stable": "stable", "smallest_eigenvalue": "lambda_1 [N/m]",
    "relative_eigenvalue": "lambda_1 / ref", "contacts": "contacts", "snap": "snap",
    "replay_deviation": "replay deviation [mm]", "peak_tension": "peak tension [N]",
    "rated_load": "rated load [N]", "robot": "robot", "verdict": "verdict", "notes": "notes",
}
"""Column titles of a wire-harness plan's verification table, one row per phase."""


def phase_verification_table(doc: PlanDocument):
    """A harness plan's verification, one row per phase with titled columns, or None."""
    phases = doc.verification.phases if doc.verification is not None else ()
    if not phases:
        return None

    def cell(key, value):
        if value is None:
            return "-"
        if isinstance(value, bool):
            return "yes" if value else "NO"
        if isinstance(value, float):
            return f"{1e3 * value:.2f}" if key == "replay_deviation" else f"{value:.4g}"
        if isinstance(value, list):
            return "; ".join(value) or "-"
        return value

    return ("Verification per phase", list(PHASE_TITLES.values()),
            [[cell(key, row.get(key)) for key in PHASE_TITLES] for row in phases])


def verification_table(doc: PlanDocument):
    """The verification rows with titled columns (per phase for a harness plan), or None."""
    if doc.verification is not None and doc.verification.phases:
        return phase_verification_table(doc)
    rows = doc.verification.rows if doc.verification is not None else ()
    if not rows:
        return None
    header = list(rows[0])

    def cell(key, value):
        if value is None:
            return "-"
        if isinstance(value, float):
            return f"{1e3 * value:.2f}" if key in MILLIMETRE_COLUMNS else f"{value:.4g}"
        return value

    return ("Verification", [VERIFY_TITLES.get(h, h) for h in header],
            [[cell(h, row[h]) for h in header] for row in rows])


def shape_labels(doc: PlanDocument) -> list[str]:
    """One slider label per shape, numbered as in the tables: start, target, harness phase."""
    count = len(doc.shapes)
    names = {0: "start", count - 1: "target"}
    for phase, (first, last) in (doc.harness or {}).get("knots", {}).items():
        for k in range(first, min(last, count - 1) + 1):
            names.setdefault(k, phase)
    return [f"shape {k}" + (f" ({names[k]})" if k in names else "") for k in range(count)]


def robot_table(doc: PlanDocument):
    """The robot program's checks, one row per check (worst value and where), or None."""
    if doc.robot is None:
        return None
    rows = [[line["check"], "ok" if line["ok"] else "FAILED", f"{line['worst']:.4g} {line['unit']}",
             line["where"], line["failures"], line["first_failure"] or "-"]
            for line in doc.robot.program["summary"]]
    cell = doc.robot.program.get("cell", "YuMi")
    return (f"Robot program ({cell}, exactly the exported targets)",
            ["check", "verdict", "worst", "where", "failing rows", "first failure"], rows)


def verdict_checks(doc: PlanDocument) -> list[dict]:
    """The checks of the verdict banner, in the pipeline's order: target stability, obstacles,
    harness, verification, and each check of the robot program; per check ``name``, ``ok``
    and ``detail`` (the worst value and where, or what failed first)."""
    checks = []
    if doc.target_check is not None:
        t = doc.target_check
        checks.append({"name": "target stable", "ok": bool(t.stable),
                       "detail": f"moves {1e3 * t.max_displacement:.1f} mm under gravity "
                                 f"(limit {1e3 * t.threshold:.1f} mm)"})
    if doc.avoidance is not None:
        a = doc.avoidance
        checks.append({"name": "obstacles", "ok": a.status in ("clear", "replanned"),
                       "detail": a.status + (f" after {a.rounds} rounds" if a.rounds else "")})
    if doc.harness is not None:
        checks.append({"name": "harness", "ok": bool(doc.harness.get("success", True)),
                       "detail": doc.harness.get("message", "")})
    if doc.verification is not None:
        v = doc.verification
        checks.append({"name": "verification", "ok": bool(v.ok),
                       "detail": v.messages[-1] if v.ok else v.messages[0]})
    if doc.robot is not None:
        for line in doc.robot.program["summary"]:
            detail = (f"worst {line['worst']:.4g} {line['unit']} at {line['where']}"
                      if line["ok"] else f"{line['failures']} rows fail, first at "
                      f"{line['first_failure']}; worst {line['worst']:.4g} {line['unit']}")
            checks.append({"name": f"robot: {line['check']}", "ok": bool(line["ok"]),
                           "detail": detail})
    return checks


def _pose(position, rotation: Rotation) -> dict:
    return {"xyz": np.asarray(position, float).round(9).tolist(),
            "quaternion": rotation.as_quat().round(12).tolist()}


def arm_scene(arm, offset=(0.0, 0.0, 0.0)) -> dict:
    """One arm of a cell as the report draws it (:func:`dloplan.plots.report.report_html`'s
    ``robot["arms"]`` entry): base pose in the plan's frame (the cell's placement ``offset``
    [m] taken off), the moving joints (origin and axis in the parent link's frame), flange and
    TCP in the last link's frame, the tool radius [m], the axis the fingers close along
    (across the held cable and the approach) and the link capsules in their link frames.

    ``arm``: a :class:`~dloplan.robot.chain.CellArm` (every cell's arms, the YuMi's included:
    the chain of its ``description``).
    """
    d = arm.description
    origins, xyz, axes = Rotation.from_matrix(d.origin_rot), d.origin_xyz, d.axes
    tip_xyz, tip_rot = d.tip_xyz, Rotation.from_matrix(d.tip_rot)
    tcp_xyz, tcp_rot = tip_xyz + tip_rot.apply(arm.tcp_offset), tip_rot * arm.tcp_rotation
    capsules, capsule_links, radii = d.capsules, d.capsule_link, d.radii
    tool_radius, tcp_in_clip = arm.tool_radius, arm.tcp_in_clip
    if tool_radius > 0:  # the tool's capsule from the flange to the TCP
        capsules = np.concatenate([capsules, [[tip_xyz, tcp_xyz]]])
        capsule_links = np.r_[capsule_links, len(xyz) - 1]
        radii = np.r_[radii, tool_radius]
    cable = tcp_in_clip.as_matrix()[0]  # the clip's u (the cable) in the TCP frame
    fingers = np.cross([0.0, 0.0, 1.0], cable)
    fingers = fingers / np.linalg.norm(fingers) if np.linalg.norm(fingers) > 1e-9 else np.eye(3)[0]
    return {
        "name": arm.name,
        "base": _pose(np.asarray(arm.base_position) - offset, arm.base_rotation),
        "joints": [{"name": name, **_pose(xyz[i], origins[i]),
                    "axis": np.asarray(axes[i], float).round(12).tolist()}
                   for i, name in enumerate(arm.joint_names)],
        "tip": _pose(tip_xyz, tip_rot),
        "tcp": _pose(tcp_xyz, tcp_rot),
        "tool_radius": float(tool_radius),
        "finger_axis": tcp_rot.apply(fingers).round(9).tolist(),
        "capsules": [{"link": int(link), "ends": np.asarray(ends, float).round(6).tolist(),
                      "radius": float(r)}
                     for ends, link, r in zip(capsules, capsule_links, radii, strict=True)],
    }


def report_robot(program) -> dict:
    """Both arms of a verified robot program and their timed motion as the report's plain data
    (``robot`` of :func:`dloplan.plots.report.report_html`).

    Relies on the program's cell (``program.cell.arms``, each arm drawn by :func:`arm_scene`)
    and on
    ``program.to_dict()``: its ``targets`` (per target ``time`` [s], ``shape`` and per arm
    ``joints_deg``, exactly the verified joints the program files hold) and, on a described
    cell, the placement ``offset`` [m]. The timeline's samples are the targets; the page
    interpolates the joints linearly between them.
    """
    record = program.to_dict()
    offset = np.asarray(record.get("offset", (0.0, 0.0, 0.0)), dtype=float)
    arms = program.cell.arms
    targets = record["targets"]
    return {"arms": [arm_scene(arm, offset) for arm in arms],
            "times": [float(t["time"]) for t in targets],
            "shapes": [int(t["shape"]) for t in targets],
            "joints": [np.radians([t["arms"][arm.name]["joints_deg"] for t in targets])
                       for arm in arms]}


def write_plan_report(doc: PlanDocument, path, images=(), program=None) -> Path:
    """The self-contained HTML report of a plan document: the verdict banner
    (:func:`verdict_checks`), the 3D view with both arms of the verified robot ``program``
    (:func:`report_robot`; without one the timeline plays the shapes at the trajectory's
    times), the summary, the tables and the PNG ``images``."""
    from ..plots.report import write_report

    tables = [shape_table(doc)]
    for table in (verification_table(doc), robot_table(doc)):
        if table is not None:
            tables.append(table)
    kind = ("harness job" if doc.harness is not None else "corrected plan"
            if doc.correction is not None else "plan")
    return write_report(
        path, title=f"dloplan {kind}: {doc.source}", shapes=doc.shapes,
        stabilized=doc.stabilized,
        clip_positions=None if doc.grippers is None else doc.grippers.positions,
        clip_rotations=None if doc.grippers is None else doc.grippers.matrices,
        obstacles=doc.obstacles, summary=summary_lines(doc)[1:], warnings=list(doc.warnings),
        tables=tables, images=images, labels=shape_labels(doc),
        cable_radius=doc.cable.diameter / 2, checks=verdict_checks(doc),
        shape_times=None if doc.trajectory is None else doc.trajectory.times,
        robot=None if program is None else report_robot(program))
