"""Harness plans verified phase by phase: wall time of each check and the verdict table.

Run: PYTHONPATH=src python benchmarks/bench_harness_verify.py [usb ethernet pu]
Prints, per example file (examples/harness_*.yaml): the wall time of the planning, of the held
model (the configurations followed through the job), of the stability, snap-through and
replay checks, then the verdict table per phase (docs/harness.md, "Verification"). The host is
shared (2 cores, several sessions): the times say what costs what, not how fast it is.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from dloplan.harness import load_harness, run_harness_job
from dloplan.harness.verification import verify_harness_result

EXAMPLES = Path(__file__).parent.parent / "examples"


def main(names) -> None:
    for name in names:
        job = load_harness(EXAMPLES / f"harness_{name}.yaml")
        t = time.perf_counter()
        result = run_harness_job(job)
        planned = time.perf_counter() - t
        t = time.perf_counter()
        check = verify_harness_result(result)
        total = time.perf_counter() - t
        checks = ", ".join(f"{k} {v:.1f} s" for k, v in check.timings.items())
        print(f"{name}: planned in {planned:.1f} s; verified in {total:.1f} s (held model "
              f"{total - sum(check.timings.values()):.1f} s, {checks})")
        print(check.table())
        print()


if __name__ == "__main__":
    main(sys.argv[1:] or ("usb", "ethernet", "pu"))
