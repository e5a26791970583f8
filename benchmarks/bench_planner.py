"""Time of ``plan`` per stage for growing (n, S), and the growth exponent in n * S.

Case: the Ethernet cable (0.5 m) from a straight shape to a half-circle fold beside it (the
folding case of the tests, thesis Table 4.2), default settings (physical mode "equilibrium").
Targets (docs/planner.md): (10, 5) whole pipeline under 0.3 s; growth close to linear in n S.
Run: PYTHONPATH=src python benchmarks/bench_planner.py [--thesis]

Before the compiled static core (issue 20, quiet machine): (50, 50) 1.7 s, (100, 100) 21 s;
targets 0.3 s and 2 s. Side by side under load (load average 13, same code before and after):
(50, 50) physical stage 1.58 -> 0.54 s, stabilization 2.50 -> 0.45 s, plans equal to 2e-14 m;
the advanced stage (sparse LU of a 2-D grid-structured Newton system, unchanged) takes about
10 s of the 11-14 s there and is what stays above the targets.
"""

from __future__ import annotations

import sys
import time

import numpy as np

import dloplan
from dloplan.planning import plan

SIZES = ((10, 5), (20, 20), (50, 50), (100, 100))
BEFORE_S = {(50, 50): 1.7, (100, 100): 21.0}  # whole plan before issue 20 (docstring)
TARGET_S = {(50, 50): 0.3, (100, 100): 2.0}


def arc(length, angle, n_links, origin=(0.0, 0.0, 0.0)):
    s = np.linspace(0.0, length, n_links + 1)
    if angle == 0.0:
        return np.stack([s, 0 * s, 0 * s], axis=1) + origin
    k = angle / length
    return np.stack([np.sin(k * s) / k, 0 * s, (1 - np.cos(k * s)) / k], axis=1) + origin


def main(mode: str = "equilibrium") -> None:
    print(f"plan() per stage [s], physical mode {mode!r}")
    print(f"{'n':>4} {'S':>4} {'variables':>9} {'target':>7} {'basic':>7} {'advanced':>9} "
          f"{'(iter)':>6} {'physical':>9} {'total':>7}  min L_adv/L  success")
    work, totals = [], []
    for n, s in SIZES:
        cable = dloplan.catalogue_cable("ethernet", n_links=n)
        start = arc(cable.length, 0.0, n)
        target = arc(cable.length, np.pi, n, origin=np.array([0.1, 0.0, 0.05]))
        plan(cable, start, target, s, physical_mode=mode)  # warm-up (imports, caches)
        t0 = time.perf_counter()
        p = plan(cable, start, target, s, physical_mode=mode)
        total = time.perf_counter() - t0
        t = p.timings
        print(f"{n:>4} {s:>4} {p.statuses['advanced'].n_variables:>9} {t['target']:>7.3f} "
              f"{t['basic']:>7.4f} {t['advanced']:>9.3f} {p.statuses['advanced'].iterations:>6} "
              f"{t['physical']:>9.3f} {total:>7.3f}  {p.lengths[1].min() / cable.length:>10.3f}"
              f"  {p.success}")
        if (n, s) in BEFORE_S:
            print(f"           before {BEFORE_S[n, s]} s: {BEFORE_S[n, s] / total:.2f}x; target "
                  f"{TARGET_S[n, s]} s")
        for w in p.warnings:
            print(f"           warning: {w}")
        work.append(n * s)
        totals.append(total)
    slope = np.polyfit(np.log(work), np.log(totals), 1)[0]
    print(f"log-log fit of total time against n*S: exponent {slope:.2f} (1 = linear)")
    print(f"(10, 5) whole pipeline: {totals[0]:.3f} s (target < 0.3 s)")


if __name__ == "__main__":
    main("thesis" if "--thesis" in sys.argv else "equilibrium")
