"""A plan with one obstacle that forces one re-planning round (issue 6).

The embedded demo's job (an Ethernet cable brought over a wall) at (n, S) = (10, 5) and
(20, 20): time of the whole plan, of its stabilization + collision + re-planning part, the
rounds, and the number of stabilizations (static equilibria under gravity; the re-planned
sub-paths also solve one weightless equilibrium per shape in their physical stage).
"""

from __future__ import annotations

import time
from importlib import resources

from dloplan.app import load_scenario
from dloplan.planning import plan
from dloplan.shapes import discretize


def main() -> None:
    with resources.as_file(resources.files("dloplan.data").joinpath("demo.yaml")) as path:
        job = load_scenario(path)
    print(f"{'n':>4} {'S':>4} {'plan [s]':>9} {'stabilize+avoid [s]':>20} {'rounds':>7} "
          f"{'stabilizations':>15} {'status':>10}")
    for n, s in ((10, 5), (20, 20)):
        cable = job.cable.with_links(n)
        start = discretize(job.start, cable, "start")
        target = discretize(job.target, cable, "target")
        best = None
        for _ in range(3):
            t0 = time.perf_counter()
            result = plan(cable, start, target, s, obstacles=job.obstacles)
            elapsed = time.perf_counter() - t0
            best = elapsed if best is None else min(best, elapsed)
        avoidance = result.avoidance
        print(f"{n:>4} {s:>4} {best:>9.3f} {result.timings['stabilize']:>20.3f} "
              f"{avoidance.rounds:>7} {avoidance.statics_solves:>15} {avoidance.status:>10}")


if __name__ == "__main__":
    main()
