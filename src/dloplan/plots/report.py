"""The interactive 3D report: one self-contained HTML file, no network needed.

The page opens with the verdict (the failed checks first), then a 3D viewer (three.js, vendored
in ``plots/vendor``, the viewer itself in ``report_viewer.js``): the cable as a tube in its
planned and stabilized shape, both clip frames (u, v, w), the table and the obstacles as
surfaces, and, when given a robot, both arms with their visual meshes (the decimated meshes
of the robots' public descriptions, :mod:`dloplan.plots.robot_meshes`; capsules for an arm
without meshes) and grippers, moved by the joint values of the verified program. A timeline
plays the timed motion of both arms in sync with the cable (interpolated linearly between its
samples); the camera orbits, pans and zooms, with front, side, top and iso views. Summary
lines, tables and the PNG figures follow (images as base64), so the file can be mailed or
archived alone. ``report.html#t=1.5&view=top`` opens at that time and view.
"""

from __future__ import annotations

import base64
import html
import json
import re
from collections.abc import Sequence
from importlib import resources
from pathlib import Path

import numpy as np

from ..obstacles.shapes import Box, Cylinder, Table
from ..output_files import atomic_write_text
from .robot_meshes import credits, encoded_meshes, match_model, model_parts

DEFAULT_CABLE_RADIUS = 0.0025
"""[m] Radius of the cable's tube when the page is not told the cable's diameter."""

THREE_CREDIT = "3D view: three.js 0.187.0 (threejs.org), MIT licence."


def _obstacle_dict(obstacle) -> dict | None:
    if isinstance(obstacle, Box):
        return {"type": "box", "center": list(obstacle.center), "size": list(obstacle.size),
                "yaw": obstacle.yaw, "name": obstacle.name}
    if isinstance(obstacle, Cylinder):
        return {"type": "cylinder", "base": list(obstacle.base), "radius": obstacle.radius,
                "height": obstacle.height, "name": obstacle.name}
    return None


def _table_html(title: str, header: Sequence[str], rows: Sequence[Sequence]) -> str:
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = "".join(
        "<tr>" + "".join(f"<td{' class=fail' if c == 'FAILED' else ''}>{html.escape(str(c))}"
                         "</td>" for c in row) + "</tr>" for row in rows
    )
    return f"<h2>{html.escape(title)}</h2><table><tr>{head}</tr>{body}</table>"


def _rounded(values, digits: int = 6) -> list:
    """Values to 1e-``digits`` (1 micrometre for lengths), without negative zeros: the same
    plan, the same page."""
    return (np.asarray(values, dtype=float).round(digits) + 0.0).tolist()


def verdict_html(checks: Sequence[dict], warnings: Sequence[str] = ()) -> str:
    """The verdict banner: a headline (FAILED / OK with warnings / OK) and one chip per check,
    the failed ones first, then the warnings.

    Parameters
    ----------
    checks : sequence of dict
        ``name``, ``ok`` (bool) and ``detail`` (str: the worst value, where it fails).
    warnings : sequence of str
    """
    checks = sorted(checks, key=lambda c: bool(c["ok"]))  # stable: failed first, in order
    failed = sum(not c["ok"] for c in checks)
    passed = (f"all {len(checks)} checks passed" if checks else "no checks were run")
    if failed:
        kind, headline = "failed", f"verdict: FAILED ({failed} of {len(checks)} checks failed)"
    elif warnings:
        plural = "s" if len(warnings) > 1 else ""
        kind, headline = "warn", f"verdict: ok, with {len(warnings)} warning{plural} ({passed})"
    else:
        kind, headline = "ok", f"verdict: ok ({passed})"
    chips = "".join(
        f"<li class='{'pass' if c['ok'] else 'fail'}'>{'&#10003;' if c['ok'] else '&#10007;'} "
        f"{html.escape(c['name'])}"
        + (f" <span>{html.escape(c['detail'])}</span>" if c.get("detail") else "") + "</li>"
        for c in checks)
    notes = "".join(f"<li>{html.escape(w)}</li>" for w in warnings)
    return (f"<section class='verdict {kind}' id='verdict' data-verdict='{kind}'>"
            f"<p>{headline}</p><ul class='checks'>{chips}</ul>"
            + (f"<ul class='warnings'>{notes}</ul>" if notes else "") + "</section>")


def _robot_scene(robot: dict, n_shapes: int) -> tuple[dict, dict, list[str], list[str]]:
    """The page's arms (with their model's parts or capsules), the timeline, the mesh keys
    and the models drawn."""
    arms, joints = robot["arms"], robot["joints"]
    times = np.asarray(robot["times"], dtype=float)
    shape_index = np.asarray(robot["shapes"], dtype=float)
    if len(arms) != len(joints) or not arms:
        raise ValueError(f"robot: {len(arms)} arms and {len(joints)} joint series, expected the "
                         "same number (at least one)")
    if times.ndim != 1 or len(times) == 0 or not np.all(np.isfinite(times)) or np.any(
            np.diff(times) < 0):
        raise ValueError(f"robot.times: expected finite non-decreasing times [s], got "
                         f"{times.shape} values")
    if shape_index.shape != times.shape or np.any(shape_index < 0) or np.any(
            shape_index > n_shapes - 1):
        raise ValueError(f"robot.shapes: expected {len(times)} shape numbers in 0..{n_shapes - 1}")
    scene_arms, models, series = [], [], []
    bases = set()
    for arm, q in zip(arms, joints, strict=True):
        q = np.asarray(q, dtype=float)
        if q.shape != (len(times), len(arm["joints"])) or not np.all(np.isfinite(q)):
            raise ValueError(f"robot.joints of arm {arm['name']!r}: expected finite "
                             f"({len(times)}, {len(arm['joints'])}) joint values [rad], got "
                             f"{q.shape}")
        series.append(_rounded(q))
        model = match_model(arm["joints"])
        out = {key: arm[key] for key in ("name", "base", "joints", "tip", "tcp", "tool_radius",
                                         "finger_axis")}
        out["model"] = model
        if model is None:
            out.update(parts=[], capsules=arm["capsules"], generic_gripper=True)
        else:
            parts, gripper = model_parts(model, [j["name"] for j in arm["joints"]])
            # one body for arms on one base (the YuMi): its base parts are drawn once
            pose = json.dumps(_rounded(arm["base"]["xyz"]) + _rounded(arm["base"]["quaternion"]))
            parts = [p for p in parts if p["link"] >= 0 or (p["mesh"], pose) not in bases]
            bases |= {(p["mesh"], pose) for p in parts if p["link"] < 0}
            out.update(parts=parts, capsules=[], generic_gripper=not gripper)
            models.append(model)
        scene_arms.append(out)
    timeline = {"times": _rounded(times, 4), "shapes": _rounded(shape_index, 6), "unit": "s",
                "joints": series}
    keys = [p["mesh"] for arm in scene_arms for p in arm["parts"]]
    return {"arms": scene_arms}, timeline, keys, models


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
    cable_radius: float | None = None,
    checks: Sequence[dict] | None = None,
    shape_times: np.ndarray | None = None,
    robot: dict | None = None,
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
    summary : sequence of str
        Lines shown below the viewer.
    warnings : sequence of str
        Shown in the verdict banner (or, without ``checks``, in red above the summary).
    tables : sequence
        ``(title, header, rows)`` tables.
    images : sequence of path
        PNG figures to embed.
    labels : sequence of str, optional
        One label per shape for the timeline (default "shape k of S + 1").
    overlay_label : str
        What the second set of shapes is (default "stabilized"; "registered" when comparing
        with measured shapes).
    cable_radius : float, optional
        [m] the cable's radius (its tube); default :data:`DEFAULT_CABLE_RADIUS`.
    checks : sequence of dict, optional
        The verdict banner's checks (``name``, ``ok``, ``detail``; :func:`verdict_html`);
        None: no banner.
    shape_times : numpy.ndarray, optional
        (S + 2,) the time [s] each shape is reached, for the timeline without a robot (default:
        the timeline steps through the shapes).
    robot : dict, optional
        Both arms and their motion, plain data (made by
        :func:`dloplan.app.report.report_robot`):

        - ``arms``: per arm ``name``; ``base`` (``xyz`` [m], ``quaternion`` x-y-z-w: the base
          link in the plan's frame); ``joints``, the moving joints base to tip (``name``,
          ``xyz`` and ``quaternion`` of the joint origin in the parent link's frame, ``axis``);
          ``tip`` and ``tcp`` (``xyz``, ``quaternion``: flange and TCP in the last link's
          frame); ``tool_radius`` [m]; ``finger_axis`` (3,) the axis the fingers close along in
          the last link's frame; ``capsules`` (``link`` -1..n-1, ``ends`` (2, 3) [m] in that
          link's frame, ``radius`` [m]), drawn when the arm matches no model with meshes;
        - ``times`` (M,) [s], ``shapes`` (M,) the (fractional) shape number of the cable at
          each time, ``joints`` per arm (M, n_arm) joint values [rad].
    """
    shapes = np.asarray(shapes, dtype=float)
    if shapes.ndim != 3 or shapes.shape[-1] != 3 or len(shapes) == 0:
        raise ValueError(f"shapes: expected (S + 2, n + 1, 3) points, got {shapes.shape}")
    n = len(shapes)
    table_height = next((o.height for o in obstacles if isinstance(o, Table)), None)
    extent = np.ptp(shapes.reshape(-1, 3), axis=0).max()
    data = {
        "shapes": _rounded(shapes),
        "stabilized": None if stabilized is None else _rounded(stabilized),
        "clip_positions": None if clip_positions is None else _rounded(clip_positions),
        "clip_rotations": None if clip_rotations is None else _rounded(clip_rotations),
        "obstacles": [d for d in map(_obstacle_dict, obstacles) if d is not None],
        "table_height": table_height,
        "cable_radius": DEFAULT_CABLE_RADIUS if cable_radius is None else float(cable_radius),
        "triad": float(np.clip(0.15 * extent, 0.02, 0.06)),
        "labels": list(labels) if labels is not None
        else [f"shape {k} of {n - 1}" for k in range(n)],
        "robot": None, "meshes": {},
    }
    models: list[str] = []
    if robot is not None:
        data["robot"], data["timeline"], keys, models = _robot_scene(robot, n)
        data["meshes"] = encoded_meshes(keys)
    elif shape_times is not None:
        times = np.asarray(shape_times, dtype=float)
        if times.shape != (n,) or np.any(np.diff(times) < 0):
            raise ValueError(f"shape_times: expected ({n},) non-decreasing times [s], got "
                             f"{times.shape}")
        data["timeline"] = {"times": _rounded(times, 4), "shapes": list(range(n)), "unit": "s",
                            "joints": []}
    else:
        data["timeline"] = {"times": list(range(n)), "shapes": list(range(n)), "unit": "shape",
                            "joints": []}
    summary_html = "".join(f"<p>{html.escape(line)}</p>" for line in summary)
    if checks is None:
        summary_html = "".join(f"<p class='warn'>&#9888; {html.escape(w)}</p>"
                               for w in warnings) + summary_html
    tables_html = "".join(_table_html(*t) for t in tables)
    figures = []
    for image in images:
        encoded = base64.b64encode(Path(image).read_bytes()).decode("ascii")
        name = html.escape(Path(image).stem.replace("_", " "))
        figures.append(f"<figure><img alt='{name}' src='data:image/png;base64,{encoded}'>"
                       f"<figcaption>{name}</figcaption></figure>")
    plots = resources.files("dloplan.plots")
    parts = {
        "TITLE": html.escape(title),
        "VERDICT": "" if checks is None else verdict_html(checks, warnings),
        "SUMMARY": summary_html,
        "TABLES": tables_html,
        "FIGURES": "".join(figures),
        "CREDITS": "".join(f"<p>{html.escape(line)}</p>"
                           for line in [*credits(models), THREE_CREDIT]),
        "OVERLAY": html.escape(overlay_label),
        # never close the script element early
        "DATA": json.dumps(data, separators=(",", ":")).replace("</", "<\\/"),
        "THREE": plots.joinpath("vendor", "three.min.js").read_text(),
        "VIEWER": plots.joinpath("report_viewer.js").read_text(),
    }
    template = plots.joinpath("report_template.html").read_text()
    # one pass, so nothing inserted is searched again for a placeholder
    return re.sub(r"__([A-Z]+)__", lambda m: parts[m.group(1)], template)


def write_report(path: str | Path, **kwargs) -> Path:
    """Write :func:`report_html` to ``path`` atomically; returns the path."""
    return atomic_write_text(path, report_html(**kwargs))
