"""Harness plans verified phase by phase: wall time of each check and the verdict table.

Run: PYTHONPATH=src python benchmarks/bench_harness_verify.py [usb ethernet pu]
Prints, per example file (examples/harness_*.yaml): the wall time of the planning, of the held
model (the configurations followed through the job), of the stability, snap-through and
replay checks, then the verdict table per phase (docs/harness.md, "Verification"). The host is
shared (2 cores, several sessions): the times say what costs what, not how fast it is.

One run of ``dloplan plan examples/harness_*.yaml --verify`` (host load ~17 on its 2 cores):
USB 90 s, Ethernet 58 s, PU 97 s wall for planning, robot program, verification, figures and
files; on a quieter host the verification alone took 46 s for the USB job (held model 10 s,
stability 0.4 s, snap-through 16 s, replay 29 s). The USB job's table (the contacts column cut):

  phase      held by  conf stable lambda_1 [N/m]  snap replay [mm]  peak [N] rated [N] robot verdict
  phase1     grippers    6    yes        0.03648    no        6.82     0.179         -   yes warning
  phase2     grippers    6    yes        0.01075  SNAP       75.25    0.0591         -   yes  FAILED
  insertion  grippers    2    yes        0.04158    no        2.39   0.00159         -   yes warning
  regrasp    fixtures    1    yes        0.04158     -        2.02 -2.02e-14         -   yes warning
  tensioning fixtures    2    yes      0.0008941    no        8.73    0.0139         -   yes  FAILED

(the peak tension of the tensioning is the replay's: 0.014 N, where the cable lies under the
plate on the table; the plan's tensioned section, resting on the plate, carries 0.147 N).
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
