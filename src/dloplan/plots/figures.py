"""Matplotlib figures of a plan (thesis Figs. 4.21/4.25, 5.13/5.17, 6.8, 7.10, Table 4.2).

Each function takes plain arrays and returns a ``matplotlib.figure.Figure``; :func:`save_figure`
writes it as PNG (and SVG when asked: :data:`WITH_SVG`), a :class:`Drawing` is one such figure
still to draw (what :mod:`dloplan.app.figure_workers` sends to its worker processes). Many lines
of one style are one collection, not one artist each (drawing time grows with the number of
artists).
matplotlib is imported here only (with the non-interactive Agg backend), so ``import dloplan``
stays light.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..output_files import atomic_file

AXIS_COLOURS = ("#d32f2f", "#388e3c", "#1976d2")  # u, v, w

PNG = ("png",)
"""The figures' formats by default: PNG only (what the reports embed)."""

WITH_SVG = ("png", "svg")
"""The formats with a vector copy for print (``--svg``, a job's ``outputs: [..., svg]``)."""


def figure_formats(svg: bool) -> tuple[str, ...]:
    """The formats a figure is written in: :data:`WITH_SVG` when ``svg``, else :data:`PNG`."""
    return WITH_SVG if svg else PNG


def _checked_formats(formats: Sequence[str]) -> tuple[str, ...]:
    formats = tuple(formats)
    if not formats or any(f not in WITH_SVG for f in formats) or len(set(formats)) < len(formats):
        raise ValueError(f"formats: got {formats!r}, expected some of {', '.join(WITH_SVG)}, "
                         "each once")
    return formats


def pyplot():
    """matplotlib.pyplot on the non-interactive Agg backend (imported on first use)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def save_figure(figure, folder: str | Path, name: str,
                formats: Sequence[str] = PNG) -> list[Path]:
    """Write the figure as ``name.<format>`` (110 dpi) into ``folder`` for each of ``formats``
    (``"png"``, ``"svg"``; :data:`PNG` by default); returns the paths in that order.

    The figure is written whole, as its function laid it out (fixed margins, or
    ``tight_layout``), not cropped to its tight bounding box: finding that box is one more
    draw of the figure (docs/decisions.md, "fixed figure margins"). Each format is one whole
    draw of the figure (the SVG copy was 30-45 % of a figure's CPU: docs/performance.md).

    Raises
    ------
    ValueError
        ``formats`` empty, repeated, or not among :data:`WITH_SVG` (nothing is written, the
        figure is closed).
    """
    try:
        formats = _checked_formats(formats)
    except ValueError:
        pyplot().close(figure)
        raise
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    figure.set_dpi(110)
    for suffix in formats:
        path = folder / f"{name}.{suffix}"
        with atomic_file(path) as tmp:
            figure.savefig(tmp, format=suffix, dpi=110)
        paths.append(path)
    pyplot().close(figure)
    return paths


@dataclass(frozen=True)
class Drawing:
    """One figure to draw and save: its file stem, a figure function of this module and its
    arguments (plain arrays: picklable, and drawn on another process without dloplan's solvers),
    and the formats to write (:data:`PNG` or :data:`WITH_SVG`: part of the drawing, so a draft
    drawn without SVG is not the drawing of a request with SVG).
    """

    name: str
    draw: Callable
    arguments: tuple = ()
    options: dict = field(default_factory=dict)
    formats: tuple[str, ...] = PNG

    def save(self, folder: str | Path) -> list[Path]:
        """Draw the figure and write ``name.<format>`` for each of its formats into
        ``folder`` (:func:`save_figure`)."""
        return save_figure(self.draw(*self.arguments, **self.options), folder, self.name,
                           self.formats)


def _equal_3d(ax, points: np.ndarray) -> None:
    """Equal scales on the three axes of a 3D plot, around ``points``."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, half = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 1e-3)
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre, strict=True):
        setter(c - half, c + half)
    ax.set_box_aspect((1, 1, 1))


def _side_axis(points: np.ndarray) -> int:
    """The horizontal axis (0 = x, 1 = y) along which the shapes spread most."""
    return int(np.ptp(points[:, 1]) > np.ptp(points[:, 0]))


def _lines(ax, segments, colours, width: float) -> None:
    """Polylines (each (m, 2) or (m, 3) [m]) as one collection on a 2D or 3D axes."""
    if ax.name == "3d":
        from mpl_toolkits.mplot3d.art3d import Line3DCollection

        ax.add_collection3d(Line3DCollection(list(segments), colors=colours, linewidths=width))
    else:
        from matplotlib.collections import LineCollection

        ax.add_collection(LineCollection(list(segments), colors=colours, linewidths=width))
        ax.autoscale_view()


def path_figure(
    shapes: np.ndarray,
    clip_positions: np.ndarray | None = None,
    clip_rotations: np.ndarray | None = None,
    obstacle_edges: Sequence[np.ndarray] = (),
    title: str = "Planned shapes and gripper frames",
):
    """Planned shapes with both gripper frames as u/v/w triads: 3D, top and side views.

    ``obstacle_edges``: the obstacles' outlines, polylines (m, 3) [m] (``edges()`` of
    :mod:`dloplan.obstacles.shapes`: plain arrays, so a figure worker needs no obstacle code).
    """
    plt = pyplot()
    shapes = np.asarray(shapes)
    points = shapes.reshape(-1, 3)
    fig = plt.figure(figsize=(15, 5))
    ax3 = fig.add_subplot(1, 3, 1, projection="3d")
    top = fig.add_subplot(1, 3, 2)
    side = fig.add_subplot(1, 3, 3)
    horizontal = _side_axis(points)
    colours = plt.cm.viridis(np.linspace(0, 1, len(shapes)))
    views = ((ax3, [0, 1, 2]), (top, [0, 1]), (side, [horizontal, 2]))
    # one collection per colour group instead of one artist per line: the same drawing, drawn
    # (and laid out) in a fraction of the time
    ends = {0: "start", len(shapes) - 1: "target"}
    middle = [k for k in range(len(shapes)) if k not in ends]
    for ax, columns in views:
        marker = {} if ax is ax3 else {"marker": ".", "ms": 3}
        for k, label in ends.items():
            ax.plot(*shapes[k][:, columns].T, color=colours[k], lw=2.5, label=label, **marker)
        if middle:
            _lines(ax, [shapes[k][:, columns] for k in middle], colours[middle], 1.2)
            if marker:
                dots = shapes[middle][:, :, columns].reshape(-1, 2)
                ax.scatter(*dots.T, s=9, marker=".", linewidths=1.0,
                           c=np.repeat(colours[middle], shapes.shape[1], axis=0))
    if clip_positions is not None and clip_rotations is not None:
        span = float(np.ptp(points, axis=0).max()) or 1.0
        bases = np.asarray(clip_positions).reshape(-1, 3)
        for axis, colour in enumerate(AXIS_COLOURS):
            tips = bases + 0.08 * span * np.asarray(clip_rotations)[..., axis].reshape(-1, 3)
            segments = np.stack([bases, tips], axis=1)
            _lines(ax3, segments, colour, 1.2)
            _lines(top, segments[:, :, :2], colour, 1.0)
    if len(obstacle_edges):
        for ax, columns in views:
            _lines(ax, [edge[:, columns] for edge in obstacle_edges], "#8d6e63", 1.0)
    ax3.set_xlabel("x [m]")
    ax3.set_ylabel("y [m]")
    ax3.set_zlabel("z [m]")
    _equal_3d(ax3, points)
    ax3.set_title("3D view (u red, v green, w blue)")
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.set_title("top view")
    side.set_xlabel(f"{'xy'[horizontal]} [m]")
    side.set_ylabel("z [m]")
    side.set_title("side view")
    for ax in (top, side):
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    side.legend(loc="best")
    fig.suptitle(title)
    fig.subplots_adjust(left=0.03, right=0.98, bottom=0.1, top=0.85, wspace=0.35)
    return fig


def stabilized_figure(shapes, stabilized, obstacle_edges: Sequence[np.ndarray] = (),
                      table_heights: Sequence[float] = (), colliding=(),
                      title: str = "Planned and stabilized shapes"):
    """Planned (solid) and gravity-stabilized (dashed) shapes with the obstacles, side view.

    ``obstacle_edges`` as in :func:`path_figure`; ``table_heights`` [m] drawn as lines.
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 5))
    colours = plt.cm.viridis(np.linspace(0, 1, len(shapes)))
    # look along the cable: the side view across the direction the shapes spread least
    h = 1 - _side_axis(np.asarray(shapes).reshape(-1, 3)[:, [1, 0, 2]])
    for k, (shape, settled) in enumerate(zip(shapes, stabilized, strict=True)):
        ax.plot(shape[:, h], shape[:, 2], color=colours[k], lw=1.2)
        style = dict(color="#b71c1c", lw=2) if k in set(colliding) else dict(color=colours[k])
        ax.plot(settled[:, h], settled[:, 2], ls="--", **style)
    for edge in obstacle_edges:
        ax.plot(edge[:, h], edge[:, 2], color="#8d6e63", lw=1)
    for height in table_heights:
        ax.axhline(height, color="#8d6e63", lw=1)
    ax.plot([], [], color="grey", label="planned")
    ax.plot([], [], color="grey", ls="--", label="stabilized")
    if colliding:
        ax.plot([], [], color="#b71c1c", ls="--", lw=2, label="colliding (stabilized)")
    ax.set_xlabel(f"{'xy'[h]} [m]")
    ax.set_ylabel("z [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(title)
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.1, top=0.93)
    return fig


def _bars(ax, positions, values, colour: str, width: float = 0.8, label: str | None = None
          ) -> None:
    """A bar chart as one collection of rectangles (``ax.bar`` makes one patch per bar);
    ``label`` its legend entry."""
    from matplotlib.collections import PolyCollection

    x, h = np.asarray(positions, dtype=float), np.asarray(values, dtype=float)
    left, right, base = x - width / 2, x + width / 2, np.zeros_like(h)
    corners = np.stack([np.stack([left, base], 1), np.stack([left, h], 1),
                        np.stack([right, h], 1), np.stack([right, base], 1)], axis=1)
    bars = PolyCollection(corners, facecolors=colour, edgecolors="none", label=label)
    bars.sticky_edges.y.append(0.0)  # as ax.bar: no margin below the bars' base
    ax.add_collection(bars)
    ax.autoscale_view()


def forces_figure(axial_mean, axial_variance, bending_mean, bending_variance,
                  title: str = "Forces per mass point across the path"):
    """Mean and variance of the axial and bending force magnitudes per point (Figs. 4.21, 7.29)."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(10, 6), sharex=True)
    points = np.arange(len(axial_mean))
    panels = ((axial_mean, "axial mean [N]"), (bending_mean, "bending mean [N]"),
              (axial_variance, "axial variance [N²]"),
              (bending_variance, "bending variance [N²]"))
    for ax, (values, label) in zip(axes.ravel(), panels, strict=True):
        _bars(ax, points, values, "#1565c0")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("mass point")
    fig.suptitle(title)
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.09, top=0.92, wspace=0.25)
    return fig


def lengths_figure(lengths: Mapping[str, np.ndarray], cable_length: float,
                   title: str = "Shape lengths per stage (thesis Table 4.2)"):
    """Length of every shape of the path after each planner stage, against L."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    for stage, values in lengths.items():
        ax.plot(np.arange(len(values)), values, marker="o", label=stage)
    ax.axhline(cable_length, color="black", lw=1, ls=":", label="cable length L")
    ax.set_xlabel("shape index")
    ax.set_ylabel("length [m]")
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(title)
    fig.subplots_adjust(left=0.12, right=0.97, bottom=0.13, top=0.91)
    return fig


def identification_figure(moduli, costs, identified: float | None = None,
                          title: str = "Identification cost against E (thesis Fig. 6.8)"):
    """The identification cost |xi_data - xi_sim|^2 against the Young's modulus (log scale)."""
    plt = pyplot()
    order = np.argsort(moduli)
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.loglog(np.asarray(moduli)[order], np.asarray(costs)[order], marker="o")
    if identified is not None:
        ax.axvline(identified, color="#b71c1c", ls="--", label=f"identified {identified:.3g} Pa")
        ax.legend()
    ax.set_xlabel("Young's modulus E [Pa]")
    ax.set_ylabel("cost [m²]")
    ax.grid(alpha=0.3, which="both")
    ax.set_title(title)
    fig.subplots_adjust(left=0.12, right=0.97, bottom=0.13, top=0.91)
    return fig


def errors_figure(errors: np.ndarray, title: str = "Mean error per shape (thesis Fig. 7.10)"):
    """Per-shape mean errors: columns x, y, z and total [m], (S + 2, 4)."""
    plt = pyplot()
    errors = np.asarray(errors)
    fig, ax = plt.subplots(figsize=(8, 4))
    index = np.arange(len(errors))
    for k, (label, colour) in enumerate(zip(("x", "y", "z", "total"), (*AXIS_COLOURS, "black"),
                                            strict=True)):
        _bars(ax, index + (k - 1.5) * 0.2, 1e3 * errors[:, k], colour, width=0.2, label=label)
    ax.set_xlabel("shape index")
    ax.set_ylabel("mean error [mm]")
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(title)
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.13, top=0.91)
    return fig


def motion_profile_figure(times, speed, acceleration, knot_times=(), speed_limit=None,
                          acceleration_limit=None,
                          title: str = "TCP speed and acceleration of both arms"):
    """TCP speed [m/s] and acceleration [m/s^2] against time [s] for both arms.

    ``speed`` and ``acceleration`` are (N, 2) (left, right arm) at ``times`` (N,)
    (``Trajectory.kinematics``); ``knot_times`` mark the planned shapes; the limits, when
    given, are drawn as dashed lines.
    """
    plt = pyplot()
    times = np.asarray(times)
    fig, axes = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    for ax, values, limit, label in ((axes[0], speed, speed_limit, "speed [mm/s]"),
                                     (axes[1], acceleration, acceleration_limit,
                                      "acceleration [m/s²]")):
        scale = 1e3 if ax is axes[0] else 1.0
        values = np.asarray(values)
        for arm, colour in zip(("left", "right"), ("#1976d2", "#d32f2f"), strict=True):
            ax.plot(times, scale * values[:, 0 if arm == "left" else 1], color=colour,
                    label=f"{arm} arm", lw=1.2)
        if limit is not None:
            ax.axhline(scale * limit, color="black", ls="--", lw=0.8, label="limit")
        if len(knot_times):  # as axvline each: data x, the axes' height, not autoscaled
            from matplotlib.collections import LineCollection

            ax.add_collection(LineCollection(
                [[(t, 0.0), (t, 1.0)] for t in knot_times], colors="#9e9e9e", linewidths=0.5,
                alpha=0.6, transform=ax.get_xaxis_transform()), autolim=False)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[1].set_xlabel("time [s] (grey: planned shapes)")
    axes[0].set_title(title)
    fig.subplots_adjust(left=0.11, right=0.97, bottom=0.1, top=0.93)
    return fig
