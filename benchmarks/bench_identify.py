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

Today's numbers (2-core machine shared with other jobs, loaded; issue 19):

Part 1 (target <= 12 simulations with the global scan included; the thesis needed 42-46). The
counts include the 2n discretization check (2-3) and the path check (1); the scan and the
Gauss-Newton steps alone take 6 to 10::

    cable    design         n  sims  time s    error interval  verdict
    usb      two-clip     203    11   13.87  -0.03%     0.5%  ok (1 warnings)
    usb      cantilever   150    13    5.18  -0.39%     5.6%  ok
    ethernet two-clip      42    13    3.93  +0.59%    15.3%  ok (3 warnings)
    ethernet cantilever    51    11    2.78  -0.01%     3.8%  ok (1 warnings)
    pu       two-clip      31     8    0.95      --       --  refused: not informative (1.28)
    pu       cantilever    16     9    1.53  +0.00%    18.3%  ok
    pa12     two-clip      31     6    0.86      --       --  refused: not informative (100)
    pa12     cantilever    16     9    1.51  -0.00%    21.3%  ok

(The hose cantilevers' intervals are the discretization's: E at 16 and 32 links differ by
about 4 %. The Ethernet on the thesis' bend: its manipulation ends on another branch at 42
links than at the 39 the data were made with, which the path check reports.)

Part 2 (41 points, 1 mm noise)::

    case                n  sims  time s    error interval  covers
    pa12 gamma 1       16    12    1.53  -8.94%    23.6%   yes
    pa12 gamma 1       40    12    1.84  -4.13%     9.5%   yes
    pu gamma 5         16    11    1.94  -8.00%    19.9%   yes
    pu gamma 5         40    11    2.20  -3.25%     7.4%   yes
    ethernet gamma 10  16    11    2.18  -7.44%    19.2%   yes
    ethernet gamma 10  40    11    2.91  -2.88%     7.0%   yes

Part 3 (10 to 24 s per cable): recommended USB: dual-arm bend 90 deg (sd 0.002, n = 200);
Ethernet: cantilever tilted 45 deg (0.002; the thesis' bend, 0.0005, snaps to another branch
within a factor 2 of E); PU: cantilever tilted 45 deg (0.0008); PA12: cantilever (0.011);
every two-clip design of a hose is flat (sd 0.07 to 21).

Before issue 19 (grid + bracketed Gauss-Newton on the whole manipulation, point-to-point cost
after arc-length resampling, n as given): 7 to 10 simulations, 0.1 to 0.6 s per cable at
n = 16, but the thesis-model USB on the thesis' two-clip design came out at 9.5e5 Pa and PA12
at 2.9e7 Pa, both "successes", and the elastica USB at n = 16 92 % low.
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
        by_name = {s.name: s for s in report.scores}
        values = [min(by_name[n].log_sd, 100.0) for n in names]
        bars = ax.bar(np.arange(len(names)) + (k - 1.5) * width, values, width, label=cable)
        for bar, n in zip(bars, names, strict=True):
            if not by_name[n].robust:
                bar.set_hatch("xx")
                bar.set_edgecolor("black")
    ax.bar([0], [0], color="white", edgecolor="black", hatch="xx",
           label="snaps to another branch within E/2..2E")
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
