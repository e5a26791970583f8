"""Figures of a planned-versus-registered comparison (thesis Figs. 7.9 and 7.10).

Figure 7.9: one panel per shape, the planned shape (bold) and the registered ones (dashed),
seen from above (the camera's view) or from the side. Figure 7.10: the mean error of each
shape by axis, with the thesis' error_tot. matplotlib is imported lazily (Agg backend).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .figures import PNG, errors_figure, pyplot, save_figure

PLANES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}


def registered_shapes_figure(comparison, plane: str = "xy",
                             title: str = "Planned and registered shapes (thesis Fig. 7.9)"):
    """One panel per shape: planned (bold, with its mass points) and registered (dashed).

    Parameters
    ----------
    comparison : dloplan.vision.compare.ShapeComparison
    plane : {"xy", "xz", "yz"}
        The robot-frame plane drawn (``"xy"``: top view, as the camera sees the table).
    """
    if plane not in PLANES:
        raise ValueError(f"plane: got {plane!r}, expected one of {sorted(PLANES)}")
    a, b = PLANES[plane]
    plt = pyplot()
    n_shapes = len(comparison.labels)
    cols = min(4, n_shapes)
    rows = math.ceil(n_shapes / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.4 * cols, 3.0 * rows), squeeze=False)
    everything = np.concatenate([comparison.planned.reshape(-1, 3),
                                 comparison.registered.reshape(-1, 3)])
    lo, hi = everything.min(axis=0), everything.max(axis=0)
    pad = 0.05 * max(hi[a] - lo[a], hi[b] - lo[b], 1e-3)
    for j, ax in enumerate(axes.ravel()):
        if j >= n_shapes:
            ax.set_visible(False)
            continue
        plan = comparison.planned[j]
        ax.plot(plan[:, a], plan[:, b], "-o", color="#1565c0", lw=2.4, ms=3, label="planned")
        for t, reg in enumerate(comparison.registered[:, j]):
            ax.plot(reg[:, a], reg[:, b], "--", color="#e65100", lw=1.4,
                    label="registered" if t == 0 else None)
        ax.set_title(f"{comparison.labels[j]}: {1e3 * comparison.euclidean_errors[j]:.1f} mm")
        ax.set_xlim(lo[a] - pad, hi[a] + pad)
        ax.set_ylim(lo[b] - pad, hi[b] + pad)
        ax.set_aspect("equal")
        ax.set_xlabel(f"{'xyz'[a]} [m]")
        ax.set_ylabel(f"{'xyz'[b]} [m]")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def comparison_errors_figure(comparison,
                             title: str = "Mean error per shape (thesis Fig. 7.10)"):
    """Bars per shape: mean absolute error along x, y, z and the thesis' error_tot [mm]."""
    errors = np.column_stack([comparison.axis_errors, comparison.total_errors])
    fig = errors_figure(errors, title)
    ax = fig.axes[0]
    ax.set_xticks(np.arange(len(comparison.labels)), comparison.labels)
    ax.set_xlabel("shape")
    return fig


def write_comparison_figures(comparison, folder: str | Path, plane: str = "xy",
                             formats: tuple[str, ...] = PNG) -> list[Path]:
    """Write ``registered_shapes`` (Fig. 7.9) and ``shape_errors`` (Fig. 7.10) in ``formats``
    (PNG by default; :data:`~dloplan.plots.figures.WITH_SVG` the SVG copies too)."""
    return (save_figure(registered_shapes_figure(comparison, plane), folder,
                        "registered_shapes", formats)
            + save_figure(comparison_errors_figure(comparison), folder, "shape_errors", formats))
