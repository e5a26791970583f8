"""Young's modulus identification: simulations, time, error, interval (issues 7 and 19).

Part 1: the four catalogue cables (rod model) on the thesis' two-clip design (Fig. 6.3) and a
horizontal cantilever; model-made data at the n the shape needs (the identification's own
curvature check), 300 points with 1 mm noise; default bounds 1e5..1e10 Pa. Per case: n,
simulations (global scan, Gauss-Newton steps, the 2n check and the path check), the wall time,
the error of E, the width of the 95 % interval (hi / lo - 1) and the verdict.

Part 2: independent shapes, the shared elastica references (cantilevers clamped at their end,
q L^3 / EI = 1, 5, 10 mapped onto PA12, PU and Ethernet), 41 points + 1 mm noise, at n = 16 and
40: the interval must cover the continuum E.

Part 3: experiment design (``dloplan identify --design``): the predicted sd(ln E) of each
candidate per cable, 100 points of 1 mm noise; ``--figure PATH`` draws it (docs figure).

    PYTHONPATH=src python benchmarks/bench_identify.py [--figure docs/figures/identify_design.png]

Today's numbers (2-core machine shared with other jobs; best of two runs; issue 19):

Part 1 (target <= 12 simulations with the global scan included; the thesis needed 42-46)::

    cable    design        n  sims  time s   error  interval  verdict
    usb      two-clip    203    12    4.67  +0.15%    3.4%    ok
    usb      cantilever  203    11    4.21  -1.46%    5.9%    ok
    ethernet two-clip     36    12    0.71  +0.03%    0.9%    ok
    ethernet cantilever   56    11    1.15  -0.08%    2.2%    ok
    pu       two-clip     33     7    0.30      --      --    refused: not informative
    pu       cantilever   16    11    0.50  -0.10%    17%     ok (discretization 8 %)
    pa12     two-clip     33     8    0.33      --      --    refused: not informative
    pa12     cantilever   16    11    0.42  +0.71%    22%     ok (discretization 8 %)

Part 2: every interval covers the continuum E (errors -2 to -8 % at n = 16, -1 to -3 % at
n = 40, the clip's half link).

Part 3: recommended USB: dual-arm bend 90 deg (sd 0.002, n 200); Ethernet: dual-arm bend 90
deg (0.0006); PU: cantilever tilted 45 deg (0.0008); PA12: cantilever (0.011); every
two-clip design of a hose is flat (sd 0.07 to 21).

Before issue 19 (grid + bracketed Gauss-Newton on the whole manipulation, point-to-point cost
after arc-length resampling): 7 to 10 simulations, 0.1 to 0.6 s per cable at n = 16, but on
the thesis' two-clip design the thesis-model USB came out at 9.5e5 Pa and PA12 at 2.9e7 Pa,
both "successes".
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from dloplan import catalogue_cable
from dloplan.frames import frame_from_axis
from dloplan.identify import (
    Experiment,
    Manipulation,
    bending_manipulation,
    cantilever_manipulation,
    identify_youngs_modulus,
    synthetic_experiment,
)
from dloplan.identify.experiment import initial_on
from dloplan.identify.fit import links_for_curvature
from dloplan.identify.measured import measured_curve
from dloplan.identify.recommend import recommend_design
from dloplan.identify.simulate import run_manipulation
from dloplan.sim.clips import ClipPoses

REFERENCE = Path(__file__).resolve().parents[1] / "tests" / "reference"
DESIGNS = {"two-clip": bending_manipulation, "cantilever": cantilever_manipulation}


def data_links(name: str, design: str) -> int:
    cable = catalogue_cable(name, n_links=64)
    manipulation = DESIGNS[design](cable)
    run = run_manipulation(cable, manipulation, initial_on(cable, manipulation))
    return max(16, links_for_curvature(cable, measured_curve(run.final, 1e-5)) + 2)


def row(label: str, truth: float, result, seconds: float) -> str:
    if result.success:
        lo, hi = result.confidence_interval
        numbers = (f"{100 * (result.youngs_modulus / truth - 1):+7.2f}%"
                   f"{100 * (hi / lo - 1):8.1f}%  ok")
        if result.warnings:
            numbers += f" ({len(result.warnings)} warnings)"
    else:
        numbers = f"{'--':>8}{'--':>9}  refused: {result.reason[:60]}"
    return (f"{label}{result.n_links:5d}{result.simulations:6d}{seconds:8.2f}" + numbers)


def timed(*args, **kwargs):
    start = time.perf_counter()
    result = identify_youngs_modulus(*args, **kwargs)
    return result, time.perf_counter() - start


def part1() -> None:
    print("Part 1: model-made data, 300 points, 1 mm noise, bounds 1e5..1e10 Pa")
    print(f"{'cable':9}{'design':11}{'n':>5}{'sims':>6}{'time s':>8}{'error':>9}"
          f"{'interval':>9}  verdict")
    for name in ("usb", "ethernet", "pu", "pa12"):
        for design in DESIGNS:
            cable = catalogue_cable(name, n_links=data_links(name, design))
            experiment = synthetic_experiment(cable, DESIGNS[design](cable), noise=1e-3,
                                              n_measured=300, seed=5)
            result, seconds = timed(cable.with_modulus(1e7), experiment)
            print(row(f"{name:9}{design:11}", cable.youngs_modulus, result, seconds))


def part2() -> None:
    print("\nPart 2: shared elastica references (cantilevers), 41 points + 1 mm noise")
    print(f"{'case':20}{'n':>5}{'sims':>6}{'time s':>8}{'error':>9}{'interval':>9}  verdict"
          "  covers")
    height = 0.3
    along = frame_from_axis([1.0, 0.0, 0.0])[0]
    for name, gamma in (("pa12", 1), ("pu", 5), ("ethernet", 10)):
        ref = json.loads((REFERENCE / f"cantilever_selfweight_gamma{gamma}.json").read_text())
        for n in (16, 40):
            base = catalogue_cable(name, n_links=n)
            truth = base.weight_per_length * base.length**3 / gamma / base.second_moment
            shape = np.stack([np.asarray(ref["x"]) * base.length, np.zeros(ref["K"]),
                              height + np.asarray(ref["z"]) * base.length], axis=1)
            noisy = shape + np.random.default_rng(gamma).normal(0.0, 1e-3, shape.shape)
            clips = ClipPoses(np.array([[0.0, 0.0, height], [0.5, 0.0, height]]),
                              Rotation.concatenate([along, along]))
            experiment = Experiment(Manipulation(shape[[0, -1]], [clips], held="first"), noisy)
            result, seconds = timed(base.with_modulus(truth), experiment)
            lo, hi = result.confidence_interval
            covers = "yes" if result.success and lo <= truth <= hi else (
                "refused" if not result.success else "NO")
            print(row(f"{name} gamma {gamma:<8}", truth, result, seconds) + f"  {covers}")


def part3(figure: str | None) -> None:
    print("\nPart 3: experiment design, predicted sd(ln E), 100 points of 1 mm noise")
    reports = {}
    for name in ("usb", "ethernet", "pu", "pa12"):
        start = time.perf_counter()
        reports[name] = recommend_design(catalogue_cable(name, n_links=16))
        print(f"-- {name} ({time.perf_counter() - start:.1f} s)")
        print("\n".join(reports[name].lines()))
    if figure:
        draw(reports, figure)
        print(f"figure: {figure}")


def draw(reports, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [s.name for s in reports["usb"].scores]
    names.sort()
    fig, ax = plt.subplots(figsize=(9, 4.5))
    width = 0.2
    for k, (cable, report) in enumerate(reports.items()):
        by_name = {s.name: s.log_sd for s in report.scores}
        values = [min(by_name[n], 100.0) for n in names]
        ax.bar(np.arange(len(names)) + (k - 1.5) * width, values, width, label=cable)
    ax.axhline(0.1, color="black", ls="--", lw=1, label="informative: sd(ln E) = 0.1")
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(names)), names, rotation=30, ha="right")
    ax.set_ylabel("predicted sd(ln E)  (1 mm noise, 100 points)")
    ax.set_title("Which experiment identifies E (dloplan identify --design)")
    ax.legend(ncols=2, fontsize=8)
    ax.grid(alpha=0.3, axis="y", which="both")
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figure", help="write the design figure here (png)")
    args = parser.parse_args()
    part1()
    part2()
    part3(args.figure)
