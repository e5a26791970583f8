"""Harness jobs (thesis 7.3): wall time per phase for the three thesis cables, and the cycle time.

Run: PYTHONPATH=src python benchmarks/bench_harness.py
Prints, per example file (examples/harness_*.yaml, n = 10, S = 4 + 4): the time of phase 1
(planning + obstacle avoidance), phase 2, insertion + tensioning search, the total, the
number of equilibria of the search, the offset, what produces the peg force (tension or
bending) with the peg force, and the cycle time (jerk-limited motion at the YuMi defaults plus
grasp, regrasp and release), broken down per phase. Not compared with the thesis' 9 s, whose
ingredients are not given (docs/harness.md).

One run (2 shared cores; PU: taut only at 15.66 mm, 3.06 N on the peg; it was 8.66 mm and
0.2 N by bending with every link compressed before the tension criterion):

    cable        phase1   phase2   insert    total solves    offset mechanism     peg   cycle
    usb           1.163    0.450    3.833    5.471     15   25.09mm   tension   0.20N   8.90s
    ethernet      0.842    0.389    1.644    2.913     16   19.50mm   tension   0.20N   8.77s
    pu            0.438    0.228    3.315    4.010     13   15.66mm   tension   3.06N   8.67s
"""

from __future__ import annotations

import time
from pathlib import Path

from dloplan.app import load_job
from dloplan.harness import run_harness

EXAMPLES = Path(__file__).parent.parent / "examples"


def main() -> None:
    print(f"{'cable':10s} {'phase1':>8s} {'phase2':>8s} {'insert':>8s} {'total':>8s} "
          f"{'solves':>6s} {'offset':>9s} {'mechanism':>9s} {'peg':>7s} {'cycle':>7s}")
    for name in ("usb", "ethernet", "pu"):
        job = load_job(EXAMPLES / f"harness_{name}.yaml")
        run_harness(job.cable, job.start, job.board, job.settings)  # warm-up (imports, caches)
        t = time.perf_counter()
        result = run_harness(job.cable, job.start, job.board, job.settings)
        wall = time.perf_counter() - t
        tm = result.timings
        print(f"{name:10s} {tm['phase1']:8.3f} {tm['phase2']:8.3f} {tm['insertion']:8.3f} "
              f"{wall:8.3f} {result.insertion.evaluations:6d} "
              f"{1e3 * result.offset:7.2f}mm {result.insertion.tensioned.mechanism:>9s} "
              f"{result.insertion.tensioned.contact_force:6.2f}N {result.cycle_time:6.2f}s"
              + ("" if result.success else f"  FAILED: {result.message}"))
        print(f"           {result.cycle.describe()}")


if __name__ == "__main__":
    main()
