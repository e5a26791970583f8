"""The harness jobs' replay: the default schemes against the thesis' explicit scheme throughout.

Run: PYTHONPATH=src python benchmarks/bench_harness_replay.py [ethernet pu usb]
Per example file (examples/harness_NAME.yaml): the job is planned once, then verified in one
process (snap-through off) with the replay's default schemes (run A, phases 1-2 with the board's
contacts: linearly implicit Euler at 1 ms; run B, the changing section: explicit) and with
``scheme="explicit"`` for both runs (main's replay before the implicit step took contacts),
each twice; the second, warm, pass is printed: the CPU seconds and steps of each run, then per
phase both verdicts, the replay's deviation and peak tension, and the notes and contact events
where they differ (docs/performance.md, "The harness jobs' verification"; docs/decisions.md,
"the replay's time step"). The host is shared: compare the CPU seconds side by side.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import dloplan.harness.verification as verification
from dloplan.app import load_job
from dloplan.harness import run_harness
from dloplan.verify.replay import replay

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def verified(result, scheme: str):
    """The harness verification with the replay's ``scheme`` ("auto" is the default), and the
    (CPU seconds, steps) of each replay run."""
    spent = []

    def timed(*args, **options):
        start = time.process_time()
        run = replay(*args, scheme=scheme, **options)
        spent.append((time.process_time() - start, run.simulation.steps))
        return run

    verification.replay = timed
    try:
        return verification.verify_harness_result(result, snap=False), spent
    finally:
        verification.replay = replay


def main(names: list[str]) -> None:
    for name in names:
        job = load_job(EXAMPLES / f"harness_{name}.yaml")
        result = run_harness(job.cable, job.start, job.board, job.settings)
        out = {}
        for scheme in ("auto", "explicit", "auto", "explicit"):  # the second pass is warm
            out[scheme] = verified(result, scheme)
        for scheme, (_, spent) in out.items():
            runs = ", ".join(f"{s:.2f} s {n} steps" for s, n in spent)
            print(f"{name} {scheme:8s}: replay CPU {sum(s for s, _ in spent):.2f} s ({runs})")
        for mine, theirs in zip(out["auto"][0].rows, out["explicit"][0].rows, strict=True):
            print(f"  {mine.phase:10s} {mine.verdict:8s} {theirs.verdict:8s} deviation "
                  f"{1e3 * mine.replay_deviation:.3f} / {1e3 * theirs.replay_deviation:.3f} mm, "
                  f"peak {mine.peak_tension:.3g} / {theirs.peak_tension:.3g} N")
            if (mine.notes, mine.contacts) != (theirs.notes, theirs.contacts):
                print(f"    {mine.notes} {mine.contacts!r}\n    vs {theirs.notes} "
                      f"{theirs.contacts!r}")
        sys.stdout.flush()


if __name__ == "__main__":
    main(sys.argv[1:] or ["ethernet", "pu", "usb"])
