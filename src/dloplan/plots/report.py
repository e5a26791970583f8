"""The interactive 3D report: one self-contained HTML file, no network needed.

The page animates the planned cable shape by shape with both gripper frames (u, v, w triads),
the stabilized shapes, obstacles and the table, and, when given their joint values, both robot
arms (each link the capsule of the collision check, drawn exactly: an orthographic view of a
capsule is a stroke of its width with round caps, depth-sorted); a slider scrubs the shapes, a
second one the arms' motion along the trajectory, the mouse rotates and zooms. Summary lines,
tables (verification, errors) and the PNG figures are embedded too (images as base64), so the
file can be mailed or archived alone.
"""

from __future__ import annotations

import base64
import html
import json
from collections.abc import Sequence
from importlib import resources
from pathlib import Path

import numpy as np

from ..io.files import atomic_write_text
from ..obstacles.shapes import Box, Cylinder, Table


def _obstacle_dict(obstacle) -> dict | None:
    if isinstance(obstacle, Box):
        return {"type": "box", "center": list(obstacle.center), "size": list(obstacle.size),
                "yaw": obstacle.yaw, "name": obstacle.name}
    if isinstance(obstacle, Cylinder):
        return {"type": "cylinder", "base": list(obstacle.base), "radius": obstacle.radius,
                "height": obstacle.height, "name": obstacle.name}
    return None


def _arm_data(arm_joints, robot, arm_motion, n_shapes: int) -> dict:
    """Capsules (end points [m], radii [m]) of both arms per shape and per motion sample."""
    from ..robot import capsules as arm_capsules
    from ..robot import yumi

    robot = robot if robot is not None else yumi()
    joints = np.asarray(arm_joints, dtype=float)
    if joints.shape != (n_shapes, 2, 7) or not np.all(np.isfinite(joints)):
        raise ValueError(f"arm_joints: expected finite ({n_shapes}, 2, 7) joint values [rad], "
                         f"got shape {joints.shape}")

    def capsules(q):
        return np.stack([arm_capsules(arm, q[:, a])[0] for a, arm in enumerate(robot.arms)],
                        axis=1).round(5).tolist()

    data = {"shapes": capsules(joints),
            "radii": [arm_capsules(arm, arm.home)[1].round(4).tolist() for arm in robot.arms],
            "motion": None}
    if arm_motion is not None:
        times, motion, shape_times = (np.asarray(v, dtype=float) for v in arm_motion)
        if (motion.ndim != 3 or motion.shape[1:] != (2, 7) or times.shape != (len(motion),)
                or shape_times.shape != (n_shapes,)):
            raise ValueError("arm_motion: expected (times (N,), joints (N, 2, 7), shape_times "
                             f"({n_shapes},)), got shapes {times.shape}, {motion.shape}, "
                             f"{shape_times.shape}")
        data["motion"] = {"times": times.round(4).tolist(), "capsules": capsules(motion),
                          "shape_times": shape_times.round(4).tolist()}
    return data


def _table_html(title: str, header: Sequence[str], rows: Sequence[Sequence]) -> str:
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in rows
    )
    return f"<h2>{html.escape(title)}</h2><table><tr>{head}</tr>{body}</table>"


def _rounded(values) -> list:
    """Values to 1 micrometre (or 1e-6), without negative zeros: the same plan, the same page."""
    return (np.asarray(values, dtype=float).round(6) + 0.0).tolist()


def report_html(
    *,
    title: str,
    shapes: np.ndarray,
    stabilized: np.ndarray | None = None,
    clip_positions: np.ndarray | None = None,
    clip_rotations: np.ndarray | None = None,
    obstacles: Sequence = (),
    summary: Sequence[str] = (),
    warnings: Sequence[str] = (),
    tables: Sequence[tuple[str, Sequence[str], Sequence[Sequence]]] = (),
    images: Sequence[str | Path] = (),
    labels: Sequence[str] | None = None,
    overlay_label: str = "stabilized",
    arm_joints: np.ndarray | None = None,
    robot=None,
    arm_motion: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    arm_capsules: dict | None = None,
) -> str:
    """The report page as a string.

    Parameters
    ----------
    title : str
        Page title.
    shapes : numpy.ndarray
        (S + 2, n + 1, 3) planned shapes [m].
    stabilized : numpy.ndarray, optional
        Same shape: the shapes settled under gravity [m].
    clip_positions : numpy.ndarray, optional
        (S + 2, 2, 3) clip points [m].
    clip_rotations : numpy.ndarray, optional
        (S + 2, 2, 3, 3) clip frames (columns u, v, w).
    obstacles : sequence
        Boxes, cylinders and tables of :mod:`dloplan.obstacles`.
    summary, warnings : sequence of str
        Lines shown at the top (warnings in red).
    tables : sequence
        ``(title, header, rows)`` tables.
    images : sequence of path
        PNG figures to embed.
    labels : sequence of str, optional
        One label per shape for the slider (default "shape k").
    overlay_label : str
        What the dashed second set of shapes is (default "stabilized"; "registered" when
        comparing with measured shapes).
    arm_joints : numpy.ndarray, optional
        (S + 2, 2, 7) joint values [rad] of the left and right arm at every shape (e.g.
        ``RobotProgram.shape_joints``): both arms are drawn, each link as the capsule of the
        collision check (:func:`dloplan.robot.capsules`).
    robot : dloplan.robot.Robot, optional
        The robot placed in the plan's frame (default: a YuMi at the origin).
    arm_motion : tuple, optional
        ``(times (N,), joints (N, 2, 7), shape_times (S + 2,))`` [s], [rad]: the arms' motion
        along the trajectory (``RobotProgram.motion_times``, ``.motion_joints`` and the shapes'
        times ``.times[grasp:release + 1]``), shown on a time slider with the cable of the
        last shape reached.
    arm_capsules : dict, optional
        Instead of ``arm_joints``, both arms of any cell as capsules already placed:
        ``shapes`` (per shape, per arm a list of (2, 3) end points [m]), ``radii`` (per arm
        [m]) and ``motion`` (None or ``times``, ``capsules`` per sample, ``shape_times``)
        (:meth:`dloplan.robot.cell_program.CellProgram.report_arms`).
    """
    shapes = np.asarray(shapes, dtype=float)
    if shapes.ndim != 3 or shapes.shape[-1] != 3 or len(shapes) == 0:
        raise ValueError(f"shapes: expected (S + 2, n + 1, 3) points, got {shapes.shape}")
    table_height = next((o.height for o in obstacles if isinstance(o, Table)), None)
    data = {
        "shapes": _rounded(shapes),
        "stabilized": None if stabilized is None else _rounded(stabilized),
        "clip_positions": None if clip_positions is None
        else _rounded(clip_positions),
        "clip_rotations": None if clip_rotations is None
        else _rounded(clip_rotations),
        "obstacles": [d for d in map(_obstacle_dict, obstacles) if d is not None],
        "table_height": table_height,
        "labels": list(labels) if labels is not None
        else [f"shape {k} of {len(shapes) - 1}" for k in range(len(shapes))],
    }
    if arm_joints is not None:
        data["arms"] = _arm_data(arm_joints, robot, arm_motion, len(shapes))
    elif arm_capsules is not None:
        data["arms"] = arm_capsules
    summary_html = "".join(f"<p>{html.escape(line)}</p>" for line in summary)
    summary_html += "".join(f"<p class='warn'>&#9888; {html.escape(w)}</p>" for w in warnings)
    tables_html = "".join(_table_html(*t) for t in tables)
    figures = []
    for image in images:
        encoded = base64.b64encode(Path(image).read_bytes()).decode("ascii")
        name = html.escape(Path(image).stem.replace("_", " "))
        figures.append(f"<figure><img alt='{name}' src='data:image/png;base64,{encoded}'>"
                       f"<figcaption>{name}</figcaption></figure>")
    template = resources.files("dloplan.plots").joinpath("report_template.html").read_text()
    payload = json.dumps(data).replace("</", "<\\/")  # never close the script element early
    return (template.replace("__TITLE__", html.escape(title))
            .replace("__SUMMARY__", summary_html)
            .replace("__TABLES__", tables_html)
            .replace("__FIGURES__", "".join(figures))
            .replace("__OVERLAY__", html.escape(overlay_label))
            .replace("__DATA__", payload))


def write_report(path: str | Path, **kwargs) -> Path:
    """Write :func:`report_html` to ``path`` atomically; returns the path."""
    return atomic_write_text(path, report_html(**kwargs))
