"""Time of ``plan`` per stage for (n, S) = (10, 5), (50, 50), (100, 100), best of 3.

Case: the Ethernet cable (0.5 m) from a straight shape to a half-circle fold beside it (the
folding case of the tests, thesis Table 4.2), default settings (physical mode "equilibrium",
stabilization under gravity). Targets (issue 20, docs/planner.md): (50, 50) <= 0.3 s,
(100, 100) <= 2 s for the whole plan.
Run: PYTHONPATH=src python benchmarks/bench_planner.py [--thesis]

Today's numbers before the grid Newton solver (sparse LU of the advanced stage's 3-D Newton
system, COLAMD, on this 2-core machine): (50, 50) 4.4 s, (100, 100) 46 s for the whole plan,
the advanced stage 4.0 s of the 4.4 s (13 Newton iterations, 25 sparse LU factorizations).
Quiet-machine numbers from the issue (before the compiled static core): 1.7 s and 21 s.
With the grid Newton solver (two-level GMRES, planning/grid_newton.py), load 2.5-4.4: (50, 50)
0.60-0.80 s (advanced 0.43-0.57 s), 5.5-7.3x; (100, 100) 5.7-6.4 s (advanced 5.2-5.8 s),
7.2-8.1x; exponent 0.92-0.93.
With Levenberg-Marquardt shifts from 1e-4 (not 1e-8), the coarse blocks compiled and the held
points placed without scipy frames, side by side with main at the same load 2.5: (50, 50)
0.48 s against main's 0.59 s (advanced 0.38 s, 14 iterations, 18 systems; main 13 and 25);
(100, 100) 3.6 s against main's 8.6 s (advanced 3.2 s, 12 iterations, 18 systems; main 22 and
42); exponent 0.87. At load 6.4-7.2: 0.68-0.82 s and 5.3-5.4 s against main's 0.99 s and 12.8 s.
Third round (block-tridiagonal coarse solve, one band product per GMRES iteration, the band
half-width 5d - 1 instead of 7d - 1, compiled cost, no threaded BLAS dot in the Newton loop),
side by side with main at load 6.3-6.7: (50, 50) 0.66 s against main's 1.42 s (advanced 0.42
against 0.98 s), (100, 100) 2.12 s against 5.36 s (advanced 1.79 against 4.79 s), exponent
0.77; at load 7.8-8.6: 1.02-1.29 s against 1.30-1.76 s and 4.41-4.68 s against 6.71-8.06 s;
with the compiled restriction and prolongation, at load 11: 1.02-1.10 s against 1.20-1.77 s
(advanced 0.60-0.61 against 0.88-1.24 s) and 3.72-4.08 s against 6.65-8.72 s (advanced
2.8-3.2 against 5.9-7.7 s). Same iterations (14 and 12), systems (18) and optimum as main.
Fourth round (trust-region ratio test for the shift), load 2.7: (10, 5) 0.019 s, (50, 50)
0.325 s (advanced 0.227 s, 11 iterations, 15 systems instead of 14 and 18), (100, 100) 1.364 s
(advanced 1.195 s, 12 iterations, 18 systems as before), exponent 0.78; at load 2.0-2.1
(50, 50) 0.196 and 0.295 s, (100, 100) 1.420 and 1.310 s; the previous policy
in the same process at load 2.6-3.4: (50, 50) 0.319 s against 0.230-0.286 s, (100, 100)
1.29-1.58 s against 1.53-1.83 s (same systems there: noise). Same optimum as before.

Quiet machine after the third round's merge (main 7f40e43, load 1.2, 2026-11-30 22:28 UTC), two
runs: (50, 50) 0.310 and 0.330 s (advanced 0.22-0.24 s; target 0.3 s: at it, not under it),
(100, 100) 1.671 and 1.258 s (target 2 s: met); exponent 0.87.
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np

import dloplan
from dloplan.planning import plan

SIZES = ((10, 5), (50, 50), (100, 100))
TODAY_S = {(50, 50): 4.4, (100, 100): 46.0}  # whole plan with sparse LU (docstring)
MAIN_S = {(50, 50): 1.42, (100, 100): 5.36}  # main before the third round, load 6.3 (docstring)
TARGET_S = {(50, 50): 0.3, (100, 100): 2.0}
STAGES = ("target", "basic", "advanced", "physical", "stabilize")


def arc(length, angle, n_links, origin=(0.0, 0.0, 0.0)):
    s = np.linspace(0.0, length, n_links + 1)
    if angle == 0.0:
        return np.stack([s, 0 * s, 0 * s], axis=1) + origin
    k = angle / length
    return np.stack([np.sin(k * s) / k, 0 * s, (1 - np.cos(k * s)) / k], axis=1) + origin


def main(mode: str = "equilibrium", repeats: int = 3) -> None:
    print(f"plan() per stage [s], physical mode {mode!r}, best of {repeats}, load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"{'n':>4} {'S':>4} {'variables':>9} " + " ".join(f"{s:>9}" for s in STAGES)
          + f" {'(iter)':>6} {'total':>7}  min L_adv/L  success")
    work, totals = [], []
    for n, s in SIZES:
        cable = dloplan.catalogue_cable("ethernet", n_links=n)
        start = arc(cable.length, 0.0, n)
        target = arc(cable.length, np.pi, n, origin=np.array([0.1, 0.0, 0.05]))
        plan(cable, start, target, min(s, 5), physical_mode=mode)  # warm-up (imports, JIT)
        runs = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            p = plan(cable, start, target, s, physical_mode=mode)
            runs.append((time.perf_counter() - t0, p))
        total, p = min(runs, key=lambda r: r[0])
        t = p.timings
        print(f"{n:>4} {s:>4} {p.statuses['advanced'].n_variables:>9} "
              + " ".join(f"{t.get(stage, 0.0):>9.3f}" for stage in STAGES)
              + f" {p.statuses['advanced'].iterations:>6} {total:>7.3f}"
              f"  {p.lengths[1].min() / cable.length:>10.3f}  {p.success}")
        if (n, s) in TODAY_S:
            print(f"           today (sparse LU) {TODAY_S[n, s]} s: {TODAY_S[n, s] / total:.1f}x "
                  f"faster; before the third round {MAIN_S[n, s]} s (load 6.3): "
                  f"{MAIN_S[n, s] / total:.1f}x; target {TARGET_S[n, s]} s: "
                  f"{total / TARGET_S[n, s]:.1f}x the target")
        for w in p.warnings:
            print(f"           warning: {w}")
        work.append(n * s)
        totals.append(total)
    slope = np.polyfit(np.log(work), np.log(totals), 1)[0]
    print(f"log-log fit of total time against n*S: exponent {slope:.2f} (1 = linear)")


if __name__ == "__main__":
    main("thesis" if "--thesis" in sys.argv else "equilibrium")
