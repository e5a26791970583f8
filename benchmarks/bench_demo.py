"""Wall time of ``dloplan demo`` and the command line's cold start, after a first run.

Runs ``dloplan demo`` (the embedded default job, all outputs) as a fresh process three times and
quotes the best wall time with the stage lines of that run; then ``dloplan --help`` and the
import of ``dloplan.cli`` in fresh processes. The first run of a fresh install compiles the
numba kernels (cached on disk) and is not counted.

Before issue 20 (quiet machine): demo about 9 s wall (verification 4.3 s, of which the replay
2.6 s; figures 2.7 s); CLI cold start over 2 s. Targets: demo <= 3 s, CLI < 2 s.
Measured under heavy load (load average 7-8 on 2 cores), same machine, before -> after the
changes of this issue: demo 46 s -> 30 s wall (verification 17 s -> 3.8 s: the replay rebuilt
90 000 Rotation objects to interpolate its clip frames; figures 26 s -> 12 s: one tight-bbox
draw per figure instead of one per format), ``import dloplan.cli`` 7.2 s -> 0.7 s (dloplan's
public names load on first use). Run it on a quiet machine for the figures against the targets.
Run: python benchmarks/bench_demo.py
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time

BEFORE_S = {"demo": 9.0}
TARGET_S = {"demo": 3.0, "help": 2.0, "import": 2.0}


def wall(command: list[str]) -> tuple[float, str]:
    """Wall time [s] of a fresh process and its standard error."""
    t0 = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=True)
    return time.perf_counter() - t0, done.stderr


def best_of(command: list[str], runs: int = 3) -> tuple[float, str]:
    return min((wall(command) for _ in range(runs)), key=lambda pair: pair[0])


def main() -> None:
    python = sys.executable
    with tempfile.TemporaryDirectory() as folder:
        demo = [python, "-m", "dloplan.cli", "demo", "-o", folder]
        wall(demo)  # the first run: compilation caches, file system caches
        seconds, stages = best_of(demo)
    print(stages.rstrip())
    print(f"dloplan demo: {seconds:.2f} s wall (best of 3; before {BEFORE_S['demo']:.0f} s: "
          f"{BEFORE_S['demo'] / seconds:.1f}x; target {TARGET_S['demo']:.0f} s)")
    seconds, _ = best_of([python, "-m", "dloplan.cli", "--help"])
    print(f"dloplan --help: {seconds:.2f} s wall (target < {TARGET_S['help']:.0f} s)")
    seconds, _ = best_of([python, "-c", "import dloplan.cli"])
    print(f"import dloplan.cli: {seconds:.2f} s wall (target < {TARGET_S['import']:.0f} s)")


if __name__ == "__main__":
    main()
