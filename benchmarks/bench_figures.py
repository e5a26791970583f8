"""CPU time of drawing a plan's figures, figure by figure (matplotlib, PNG; ``--svg`` PNG and SVG).

For each plan document given (``plan.json`` files written by ``dloplan plan``; read, not
planned, so two checkouts draw the same inputs) every figure of
:func:`dloplan.app.report.figure_drawings` is drawn and saved as a figure worker does
(:meth:`dloplan.plots.figures.Drawing.save`), after :func:`dloplan.plots.worker.warm_up`, in
this process: ``--runs`` times, the smallest CPU time (``time.process_time``) kept per figure.
The figures are PNG only, as ``dloplan plan`` draws them; ``--svg`` draws the SVG copies too, as
``dloplan plan --svg`` does (a checkout before branch svg draws both always, and has no
``--svg``).
``--study`` adds the figures of a small robustness study (``dloplan.plots.study.study_figures``
on a 16-sample study of the tests' hanging cable), ``--profile N`` prints the ``N`` functions
with the most cumulative time of one more drawing of every figure (cProfile).

To compare two checkouts on the same inputs run it with each one's ``src`` first on
``PYTHONPATH`` (``PYTHONPATH=../main/src:tests``), alternating; the load average is printed.

Run: PYTHONPATH=tests python benchmarks/bench_figures.py out/plan/plan.json ... [--runs 3]
     [--study] [--svg] [--profile 30]
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


def study_drawing(folder: Path, svg: bool):
    """A function writing the figures of a 16-sample study of the tests' hanging cable (with
    their SVG copies when ``svg``)."""
    from study_cases import hanging_problem

    from dloplan.plots.study import study_figures
    from dloplan.study import run_study

    result = run_study(hanging_problem(), {
        "samples": 16, "chunk_size": 8,
        "parameters": {"youngs_modulus": {"spread": 40}, "clip_position": {"spread": 1}}})
    if not svg:
        return lambda: study_figures(result.table, result.summary, result.spec.criteria, folder)
    from dloplan.plots.figures import WITH_SVG

    return lambda: study_figures(result.table, result.summary, result.spec.criteria, folder,
                                 formats=WITH_SVG)


def drawings(doc, svg: bool) -> list:
    """The plan's figures to draw (:func:`dloplan.app.report.figure_drawings`), with their SVG
    copies when ``svg``."""
    from dloplan.app.report import figure_drawings

    if not svg:
        return figure_drawings(doc)
    from dloplan.plots.figures import WITH_SVG

    return figure_drawings(doc, WITH_SVG)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("plans", nargs="*", help="plan.json files")
    parser.add_argument("--runs", type=int, default=3, help="drawings per figure (best kept)")
    parser.add_argument("--study", action="store_true", help="also a study's figures")
    parser.add_argument("--profile", type=int, default=0, help="cProfile's top N functions")
    parser.add_argument("--svg", action="store_true", help="the SVG copies too (as plan --svg)")
    args = parser.parse_args()

    import dloplan
    from dloplan.app import read_plan
    from dloplan.plots.worker import warm_up

    warm_up()
    from dloplan.plots.figures import Drawing

    before = "formats" not in Drawing.__dataclass_fields__  # a checkout before branch svg
    formats = "PNG and SVG" if args.svg or before else "PNG"
    print(f"dloplan from {Path(dloplan.__file__).parent} ({formats}); "
          f"load {os.getloadavg()[0]:.1f}")
    jobs = []
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        for path in args.plans:
            doc = read_plan(path)
            jobs += [(f"{Path(path).parent.name}/{d.name}", lambda d=d: d.save(folder))
                     for d in drawings(doc, args.svg)]
        if args.study:
            jobs.append(("study (3 figures)", study_drawing(folder, args.svg)))
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
