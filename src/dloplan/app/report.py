"""The plan's figures and its HTML report, made from the plan document alone.

Everything shown is read from the :class:`~dloplan.pipeline.document.PlanDocument`, so the report of
a plan written by ``dloplan plan`` and of the same plan read back from ``plan.json`` are the
same page.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..obstacles.shapes import Table
from ..pipeline.document import PlanDocument

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


def figure_drawings(doc: PlanDocument) -> list:
    """The plan's figures still to draw (:class:`dloplan.plots.figures.Drawing`, named by
    :func:`figure_names`): path with frames, stabilized, forces, lengths, motion profile."""
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
    return [Drawing(name, draw, arguments, options) for name, (draw, arguments, options)
            in zip(figure_names(doc), figures, strict=True)]


def write_figures(doc: PlanDocument, folder) -> list[Path]:
    """The plan's figures as PNG and SVG, drawn here: path with frames, stabilized, forces,
    lengths, motion profile."""
    return [path for drawing in figure_drawings(doc) for path in drawing.save(folder)]


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


def verification_table(doc: PlanDocument):
    """The verification rows with titled columns, or None."""
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


def write_plan_report(doc: PlanDocument, path, images=(), arms=None) -> Path:
    """The self-contained HTML report of a plan document (``arms``: the robot program's
    ``report_arms()``, to draw both arms of its cell: the YuMi's
    :meth:`~dloplan.robot.RobotProgram.report_arms` or a described cell's
    :meth:`~dloplan.robot.cell_program.CellProgram.report_arms`)."""
    from ..plots.report import write_report

    tables = [shape_table(doc)]
    for table in (verification_table(doc), robot_table(doc)):
        if table is not None:
            tables.append(table)
    kind = "harness job" if doc.harness is not None else "plan"
    return write_report(
        path, title=f"dloplan {kind}: {doc.source}", shapes=doc.shapes,
        stabilized=doc.stabilized,
        clip_positions=None if doc.grippers is None else doc.grippers.positions,
        clip_rotations=None if doc.grippers is None else doc.grippers.matrices,
        obstacles=doc.obstacles, summary=summary_lines(doc), warnings=list(doc.warnings),
        tables=tables, images=images, labels=shape_labels(doc), **(arms or {}))
