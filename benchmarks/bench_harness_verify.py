"""Harness plans verified phase by phase: wall time of each check and the verdict table.

Run: PYTHONPATH=src python benchmarks/bench_harness_verify.py [usb ethernet pu]
Prints, per example file (examples/harness_*.yaml): the wall and CPU time of the planning and
of the verification, the wall time of the held model (the configurations followed through the
job), of the stability, snap-through and replay checks, then the verdict table per phase
(docs/harness.md, "Verification"). The host is shared (2 cores, several sessions): the times
say what costs what, not how fast it is.

Measured on a shared host (load 11-13 on its 2 cores: wall times are 4-7 times the CPU times,
so the CPU times are what compares). Verification CPU time before (main before the harness2
branch: the generic Python contact Newton loop, the soft cables' phases planned gravity-free) and
after (this branch: the compiled contact Newton loop, sim/contact_newton.py; the soft cables
carried taut, their phases settled):

  example    before: verified      after: verified
  usb        19.1 s CPU (102 s)    10.6 s CPU (53 s wall)
  ethernet   10.5 s CPU (82 s)      8.2 s CPU (33 s wall)
  pu         20.7 s CPU (183 s)    19.1 s CPU (79 s wall; the stiff hose's replay, 70 s wall)

``dloplan plan examples/harness_*.yaml --verify`` after (same host, load 9.6-11.3): USB exit 3
in 81 s wall, Ethernet exit 0 in 69 s, PU exit 0 in 131 s (before: exit 3 in 331 s, exit 1 in
59 s, exit 0 in 142 s). The USB job's table after (the contacts column cut):

  phase      held by  conf stable lambda_1 [N/m]  snap replay [mm]  peak [N] rated [N] robot verdict
  phase1     grippers    6    yes         0.1103    no        4.92      0.19         -   yes      ok
  phase2     grippers    6    yes       0.007556    no       13.67     0.192         -   yes  FAILED
  insertion  grippers    2    yes        0.00452    no        5.73    0.0125         -   yes warning
  regrasp    fixtures    1    yes        0.00452     -        5.64   0.00772         -   yes      ok
  tensioning fixtures    2    yes        0.00452    no        9.12     0.651         -   yes      ok

(phase 2: the replay ends 13.7 mm from the frictionless configuration and is not at rest after
10 s: the slack soft cable creeps on the plate, docs/harness.md "What the examples show"; the
tensioning's peak, 0.65 N, is the replay's, the pegs pushing with 0.2 N).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from dloplan.app import load_job
from dloplan.harness import run_harness
from dloplan.harness.verification import verify_harness_result

EXAMPLES = Path(__file__).parent.parent / "examples"


def main(names) -> None:
    for name in names:
        job = load_job(EXAMPLES / f"harness_{name}.yaml")
        t, c = time.perf_counter(), time.process_time()
        result = run_harness(job.cable, job.start, job.board, job.settings)
        planned, planned_cpu = time.perf_counter() - t, time.process_time() - c
        t, c = time.perf_counter(), time.process_time()
        check = verify_harness_result(result)
        total, total_cpu = time.perf_counter() - t, time.process_time() - c
        checks = ", ".join(f"{k} {v:.1f} s" for k, v in check.timings.items())
        print(f"{name}: planned in {planned:.1f} s wall ({planned_cpu:.1f} s CPU); verified in "
              f"{total:.1f} s wall ({total_cpu:.1f} s CPU; held model "
              f"{total - sum(check.timings.values()):.1f} s, {checks}); host load "
              f"{os.getloadavg()[0]:.1f}")
        print(check.table())
        print()


if __name__ == "__main__":
    main(sys.argv[1:] or ("usb", "ethernet", "pu"))
