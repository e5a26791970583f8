"""Harness jobs (thesis 7.3): wall time per phase for the three thesis cables, and the cycle time.

Run: PYTHONPATH=src python benchmarks/bench_harness.py
Prints, per example file (examples/harness_*.yaml, n = 10, S = 4 + 4): the time of phase 1
(planning + obstacle avoidance), phase 2, insertion + tensioning search, the total, the
number of equilibria of the search, the offset, and the program's cycle time at 100 mm/s with
its ratio to the thesis' 9 s.
"""

from __future__ import annotations

import time
from pathlib import Path

from dloplan.harness import THESIS_CYCLE_TIME, load_harness, run_harness_job

EXAMPLES = Path(__file__).parent.parent / "examples"


def main() -> None:
    print(f"{'cable':10s} {'phase1':>8s} {'phase2':>8s} {'insert':>8s} {'total':>8s} "
          f"{'solves':>6s} {'offset':>9s} {'cycle':>7s} {'/9 s':>6s}")
    for name in ("usb", "ethernet", "pu"):
        job = load_harness(EXAMPLES / f"harness_{name}.yaml")
        run_harness_job(job)  # warm-up (imports, caches)
        t = time.perf_counter()
        result = run_harness_job(job)
        wall = time.perf_counter() - t
        tm = result.timings
        print(f"{name:10s} {tm['phase1']:8.3f} {tm['phase2']:8.3f} {tm['insertion']:8.3f} "
              f"{wall:8.3f} {result.insertion.evaluations:6d} "
              f"{1e3 * result.offset:7.2f}mm {result.cycle_time:6.2f}s "
              f"{result.cycle_time / THESIS_CYCLE_TIME:6.2f}"
              + ("" if result.success else f"  FAILED: {result.message}"))
        times = result.phase_times()
        print("           program: " + ", ".join(
            f"{k} {b - a:.2f} s" for k, (a, b) in times.items()))


if __name__ == "__main__":
    main()
