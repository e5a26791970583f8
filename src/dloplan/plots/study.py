"""Figures of a robustness study: success against a parameter, deviations, sensitivities.

Each function takes plain arrays (or the study's summary) and returns a matplotlib figure;
:func:`study_figures` writes the three of a finished study as PNG, and SVG when asked (four
with a closed-loop study).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..study.summary import sample_outcomes, success_interval
from .figures import PNG, pyplot, save_figure

SCALES = {"Pa": (1e-6, "MPa"), "m": (1e3, "mm"), "rad": (57.29577951308232, "deg"),
          "kg/m": (1e3, "g/m")}
"""Display unit of each SI unit (factor, label)."""


def success_by_parameter_figure(values, success, name: str = "youngs_modulus",
                                unit: str = "Pa", bins: int = 8, confidence: float = 0.95):
    """Success rate per quantile bin of one parameter, with binomial (Wilson) intervals.

    Parameters
    ----------
    values : array_like
        (N,) the parameter of each sample [unit].
    success : array_like
        (N,) bool, whether each sample succeeded.
    name, unit : str
        Parameter name and SI unit (shown in a readable unit: MPa, mm, deg).
    bins : int
        Number of bins, each holding about N / bins samples.
    confidence : float
        Level of the error bars.
    """
    plt = pyplot()
    x = np.asarray(values, dtype=float)
    ok = np.asarray(success, dtype=bool)
    factor, label = SCALES.get(unit, (1.0, unit))
    edges = np.unique(np.quantile(x, np.linspace(0, 1, min(bins, len(x)) + 1)))
    which = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, len(edges) - 2)
    centres, rates, lows, highs = [], [], [], []
    for b in range(len(edges) - 1):
        sel = which == b
        if not sel.any():
            continue
        k, n = int(ok[sel].sum()), int(sel.sum())
        lo, hi = success_interval(k, n, confidence)
        centres.append(factor * float(np.median(x[sel])))
        rates.append(k / n)
        lows.append(k / n - lo)
        highs.append(hi - k / n)
    fig, ax = plt.subplots(figsize=(6.0, 3.8))
    ax.errorbar(centres, rates, yerr=[lows, highs], fmt="o-", capsize=3, color="#1976d2")
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel(f"{name.replace('_', ' ')} [{label}]")
    ax.set_ylabel("success rate [-]")
    ax.set_title(f"Success against {name.replace('_', ' ')} ({100 * confidence:.0f} % intervals)")
    ax.grid(alpha=0.3)
    fig.subplots_adjust(left=0.13, right=0.97, bottom=0.14, top=0.91)
    return fig


def deviation_figure(deviations, threshold: float | None = None):
    """Distribution of the deviation from the nominal stabilized shapes.

    Parameters
    ----------
    deviations : array_like
        (N, S + 2) largest point deviation of each sample and shape [m] (NaN: not evaluated).
    threshold : float, optional
        The ``max_deviation`` criterion [m], drawn as a line.
    """
    plt = pyplot()
    d = 1e3 * np.asarray(deviations, dtype=float)
    fig, (left, right) = plt.subplots(1, 2, figsize=(9.0, 3.8))
    worst = np.nanmax(np.where(np.isnan(d), -np.inf, d), axis=1)
    worst = worst[np.isfinite(worst)]
    left.hist(worst, bins=max(5, min(40, len(worst) // 4)), color="#90caf9", edgecolor="#1976d2")
    left.set_xlabel("largest deviation of a sample [mm]")
    left.set_ylabel("samples [-]")
    right.boxplot([col[np.isfinite(col)] for col in d.T], showfliers=True)
    right.set_xticks(range(1, d.shape[1] + 1), [str(k) for k in range(d.shape[1])])
    right.set_xlabel("shape [-] (0 = start)")
    right.set_ylabel("deviation [mm]")
    if threshold is not None:
        for ax, vertical in ((left, True), (right, False)):
            line = ax.axvline if vertical else ax.axhline
            line(1e3 * threshold, color="#d32f2f", ls="--", label="criterion")
        left.legend()
    fig.suptitle("Deviation from the nominal stabilized shapes")
    fig.tight_layout()
    return fig


def tornado_figure(sensitivities: Sequence):
    """Spearman rank correlations of each parameter with deviation and with failure.

    ``sensitivities``: :class:`~dloplan.study.summary.Sensitivity` items, most influential
    first (drawn at the top).
    """
    plt = pyplot()
    items = list(sensitivities)
    fig, ax = plt.subplots(figsize=(6.5, 1.2 + 0.5 * max(len(items), 1)))
    y = np.arange(len(items))[::-1]
    dev = [s.rho_deviation for s in items]
    fail = [s.rho_failure for s in items]
    ax.barh(y + 0.18, np.nan_to_num(dev), height=0.36, color="#1976d2",
            label="with deviation")
    ax.barh(y - 0.18, np.nan_to_num(fail), height=0.36, color="#d32f2f", label="with failure")
    ax.set_yticks(y, [s.parameter.replace("_", " ") for s in items])
    ax.axvline(0.0, color="black", lw=0.8)
    ax.set_xlim(-1.0, 1.0)
    ax.set_xlabel("Spearman rank correlation rho [-]")
    ax.set_title("Which parameter drives failure")
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    return fig


def closed_loop_figure(closed_loop):
    """Open-loop and closed-loop success probability with their intervals (a bar each).

    ``closed_loop``: a :class:`~dloplan.correct.ClosedLoopSuccess` (tolerance [m], trials,
    ``open_loop`` and ``closed_loop`` as (probability, low, high)).
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(4.5, 3.5))
    for x, ((p, low, high), color) in enumerate(((closed_loop.open_loop, "#9e9e9e"),
                                                 (closed_loop.closed_loop, "#388e3c"))):
        ax.bar(x, 100 * p, color=color, width=0.6)
        ax.errorbar(x, 100 * p, yerr=[[100 * (p - low)], [100 * (high - p)]], color="black",
                    capsize=6)
        ax.text(x, 100 * high + 2, f"{100 * p:.0f} %", ha="center", fontsize=9)
    how = "\n(linearized)" if getattr(closed_loop, "method", "exact") == "linearized" else ""
    ax.set_xticks([0, 1], ["open loop", f"one correction{how}"])
    ax.set_ylim(0, 110)
    ax.set_ylabel("P(final mean error <= tolerance) [%]")
    ax.set_title(f"Final shape within {1e3 * closed_loop.tolerance:.1f} mm "
                 f"({closed_loop.trials} samples)")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig


def study_figures(table: dict, summary, criteria, folder: str | Path,
                  parameter: str = "youngs_modulus", formats: tuple[str, ...] = PNG
                  ) -> list[Path]:
    """Write the three figures of a study into ``folder``, each in ``formats``.

    Parameters
    ----------
    table : dict
        The study table.
    summary : StudySummary
        Its summary (for the sensitivities, and the closed-loop figure when it has one).
    criteria : CriteriaSpec
        The success criteria.
    folder : str or os.PathLike
        Output folder.
    parameter : str
        The parameter of the success figure (default E).
    formats : tuple of str
        The files of each figure: :data:`~dloplan.plots.figures.PNG` (default), or
        :data:`~dloplan.plots.figures.WITH_SVG` (``dloplan study --svg``).
    """
    from ..study.sampling import parameter_columns

    per = sample_outcomes(table, criteria)
    n_shapes = int(table["shape"].max()) + 1
    deviations = np.asarray(table["deviation"], dtype=float).reshape(-1, n_shapes)
    units = parameter_columns(0)
    paths = []
    paths += save_figure(success_by_parameter_figure(
        table[parameter][table["shape"] == 0], per["success"], parameter,
        units.get(parameter, "")), folder, f"study_success_{parameter}", formats)
    threshold = None if criteria.max_deviation is None else criteria.max_deviation * 1e-3
    paths += save_figure(deviation_figure(deviations, threshold), folder, "study_deviation",
                         formats)
    paths += save_figure(tornado_figure(summary.sensitivities), folder, "study_tornado",
                         formats)
    if summary.closed_loop is not None:
        paths += save_figure(closed_loop_figure(summary.closed_loop), folder,
                             "study_closed_loop", formats)
    return paths
