"""CPU time of drawing a plan's figures, figure by figure (matplotlib, PNG and SVG).

For each plan document given (``plan.json`` files written by ``dloplan plan``; read, not
planned, so two checkouts draw the same inputs) every figure of
:func:`dloplan.app.report.figure_drawings` is drawn and saved as a figure worker does
(:meth:`dloplan.plots.figures.Drawing.save`), after :func:`dloplan.plots.worker.warm_up`, in
this process: ``--runs`` times, the smallest CPU time (``time.process_time``) kept per figure.
``--study`` adds the figures of a small robustness study (``dloplan.plots.study.study_figures``
on a 16-sample study of the tests' hanging cable), ``--profile N`` prints the ``N`` functions
with the most cumulative time of one more drawing of every figure (cProfile).

To compare two checkouts on the same inputs run it with each one's ``src`` first on
``PYTHONPATH`` (``PYTHONPATH=../main/src:tests``), alternating; the load average is printed.

Run: PYTHONPATH=tests python benchmarks/bench_figures.py out/plan/plan.json ... [--runs 3]
     [--study] [--profile 30]
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import tempfile
import time
from pathlib import Path


def timed(function, runs: int) -> float:
    """[s] the smallest CPU time of ``runs`` calls of ``function``."""
    best = float("inf")
    for _ in range(runs):
        start = time.process_time()
        function()
        best = min(best, time.process_time() - start)
    return best


def study_drawing(folder: Path):
    """A function writing the figures of a 16-sample study of the tests' hanging cable."""
    from study_cases import hanging_problem

    from dloplan.plots.study import study_figures
    from dloplan.study import run_study

    result = run_study(hanging_problem(), {
        "samples": 16, "chunk_size": 8,
        "parameters": {"youngs_modulus": {"spread": 40}, "clip_position": {"spread": 1}}})
    return lambda: study_figures(result.table, result.summary, result.spec.criteria, folder)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("plans", nargs="*", help="plan.json files")
    parser.add_argument("--runs", type=int, default=3, help="drawings per figure (best kept)")
    parser.add_argument("--study", action="store_true", help="also a study's figures")
    parser.add_argument("--profile", type=int, default=0, help="cProfile's top N functions")
    args = parser.parse_args()

    import dloplan
    from dloplan.app import read_plan
    from dloplan.app.report import figure_drawings
    from dloplan.plots.worker import warm_up

    warm_up()
    print(f"dloplan from {Path(dloplan.__file__).parent}; load {os.getloadavg()[0]:.1f}")
    jobs = []
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        for path in args.plans:
            doc = read_plan(path)
            jobs += [(f"{Path(path).parent.name}/{d.name}", lambda d=d: d.save(folder))
                     for d in figure_drawings(doc)]
        if args.study:
            jobs.append(("study (3 figures)", study_drawing(folder)))
        total = 0.0
        for name, draw in jobs:
            cpu = timed(draw, args.runs)
            total += cpu
            print(f"  {name:<48} {1e3 * cpu:7.0f} ms CPU")
        print(f"  {'total':<48} {1e3 * total:7.0f} ms CPU (best of {args.runs} each)")
        if args.profile:
            profile = cProfile.Profile()
            profile.enable()
            for _, draw in jobs:
                draw()
            profile.disable()
            pstats.Stats(profile).sort_stats("cumulative").print_stats(args.profile)


if __name__ == "__main__":
    main()
