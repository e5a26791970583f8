"""A correction's report as plain text (``correction.txt`` of ``dloplan correct``)."""

from __future__ import annotations

import math

import numpy as np


def correction_table(report: dict) -> str:
    """A correction's report (:meth:`dloplan.correct.Correction.report`) as plain text: the
    modulus update, the predicted final error and its interval, open-loop against corrected
    predictions shape by shape with the clip corrections (mm, degrees)."""
    low, high = report["prediction_interval"]
    lines = [
        f"# dloplan correction at shape {report['at']} ({report['mode']} mode, reference: "
        f"{report['reference']} shapes)",
        f"E: {report['youngs_modulus_before']:.4g} -> {report['youngs_modulus']:.4g} Pa "
        f"({report['modulus_steps']} Gauss-Newton steps); measured vs model at shape "
        f"{report['at']}: {1e3 * report['measured_vs_model_before']:.2f} -> "
        f"{1e3 * report['measured_vs_model_after']:.2f} mm",
        f"predicted final error {1e3 * report['predicted_error']:.2f} mm, interval "
        f"{1e3 * low:.2f} - {1e3 * high:.2f} mm (unexplained at shape {report['at']} "
        f"{1e3 * report['uncertainty']['unexplained']:.2f}, grip "
        f"{1e3 * report['uncertainty']['grip']:.2f}, modulus "
        f"{1e3 * report['uncertainty']['modulus']:.2f} mm)",
        f"clips fitted on the cable as a chain of {report.get('fit_links') or '?'} links",
        f"computed in {1e3 * report['seconds']:.0f} ms wall, {1e3 * report['cpu_seconds']:.0f}"
        f" ms CPU (+ {1e3 * report['prediction_seconds']:.0f} ms predictions); remaining "
        f"motion {report['duration_remaining']:.2f} s",
        "",
        "shape  open-loop [mm]  corrected [mm]  first clip [mm, deg]  last clip [mm, deg]",
    ]
    for k, (o, c, p) in enumerate(zip(report["open_loop_error"], report["corrected_error"],
                                      report["clip_corrections"], strict=True)):
        p = np.asarray(p)
        moves = [f"{1e3 * np.linalg.norm(p[i : i + 3]):6.2f}, "
                 f"{math.degrees(np.linalg.norm(p[i + 3 : i + 6])):5.2f}" for i in (0, 6)]
        lines.append(f"{report['shapes'][k]:5d}  {1e3 * o:14.2f}  {1e3 * c:14.2f}  "
                     f"{moves[0]:>20}  {moves[1]:>19}")
    lines += [f"warning: {w}" for w in report["warnings"]]
    return "\n".join(lines) + "\n"
