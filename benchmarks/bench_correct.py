"""Closed-loop shape correction (issue 22): its time, and what one correction buys.

Part 1: the time of one correction (`correct_plan`, target mode, until the corrected trajectory is
ready; the predictions that follow are timed apart) for a model of n = 20, 50, 100 links, on the
sagging demo plan (8 shapes) measured at mid-path (shape 3) on a plant of n = 200 links and twice
the modulus, 1 mm noise, 200 points, timed as the plan was (its trajectory's limits). Best of 5.
"correction" ends when the remaining trajectory is ready (what the robot waits for); the whole
trajectory and the predictions follow. Wall times, and the correction's CPU time
(`Correction.cpu_seconds`, this thread): the difference is waiting for a shared core.

Part 2: the plant (n = 100; E x0.5 and x2, 1 mm noise) running the n = 20 plans of the sagging
demo (tests/data/sagging_demo.yaml, the issue's demo), of the embedded demo (a U hanging in a
vertical plane) and of the 3D Ethernet example, open loop and corrected once at mid-path (the
tests' scenarios), plus corrected twice (mid-path and before the target). Mean error of the final
shape against the plan's stabilized target (curves at equal arc length), in mm; "floor" is the
least error any correction of the target's clips leaves this plant (`reachable_error`).

Numbers before this session (2026-11-30 morning, E-only model update; best of two runs):

    correction [ms]: n = 20: 34, n = 50: 45, n = 100: 46 (+ ~30 ms of predictions)
    sagging demo x0.5: 6.06 -> 4.06 mm (1.5x); x2: 18.20 -> 2.87 mm (6.3x)
    3D x0.5: 1.73 -> 1.12 mm (1.5x);          x2: 4.84 -> 1.15 mm (4.2x)

Numbers after (E and the discretization bias; 2 cores shared with 4 other agents, best of 3):

    correction, n = 20, 50, 100: CPU 25, 34, 33 ms (Correction.cpu_seconds); wall 33, 42, 73 ms
                     at load ~5, 150-240 ms at load ~8 (the 2n solves add to the E-only work)
    sagging demo x0.5: 6.06 -> 3.31 mm (1.8x, floor 3.26); x2: 18.20 -> 2.95 mm (6.2x, floor 2.98)
    3D x0.5: 1.73 -> 0.87 mm (2.0x, floor 0.86);          x2: 4.84 -> 0.89 mm (5.4x, floor 0.85)
    U demo: open loop 0.2-0.5 mm, below the 1 mm noise: nothing to correct
"""

from __future__ import annotations

import contextlib
import io
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

from dloplan.app import read_plan
from dloplan.cli import main as dloplan_main
from dloplan.correct import Plant, correct_plan, reachable_error, run_closed_loop
from dloplan.geometry import as_path, resample_by_arc_length
from dloplan.grippers import gripper_path
from dloplan.sim import equilibrium

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = {"sagging demo": ROOT / "tests" / "data" / "sagging_demo.yaml",
             "U demo": ROOT / "src" / "dloplan" / "data" / "demo.yaml",
             "3D ethernet": ROOT / "examples" / "qualitative2_ethernet_3d.yaml"}


def plan_with_links(source: Path, n_links: int, folder: Path):
    data = yaml.safe_load(source.read_text(encoding="utf-8"))
    data["cable"]["n_links"] = n_links
    data["outputs"] = ["json"]
    scenario = folder / f"{source.stem}_{n_links}.yaml"
    scenario.write_text(yaml.safe_dump(data), encoding="utf-8")
    out = folder / scenario.stem
    with contextlib.redirect_stdout(io.StringIO()):
        dloplan_main(["plan", str(scenario), "-o", str(out), "-q"])
    return read_plan(out / "plan.json")


def refined(doc, n_links: int):
    """The plan's shapes on n links, their clip poses and stabilized shapes."""
    cable = doc.cable.with_links(n_links)
    shapes = as_path(np.stack([resample_by_arc_length(s, n_links + 1) for s in doc.shapes]))
    grippers = gripper_path(shapes, method=doc.grippers.method, cable=cable)
    stable = np.stack([equilibrium(cable, s, grippers.clip_poses(j)).shape
                       for j, s in enumerate(shapes)])
    return cable, shapes, grippers, stable


def part1(doc) -> None:
    print("Part 1: time of one correction (target mode; sagging demo at shape 3, plant n = 200 at "
          "E x2, 1 mm noise; best of 5)")
    print(f"{'n':>4} {'correction [ms]':>16} {'its CPU [ms]':>13} {'predictions [ms]':>17} "
          f"{'LM its':>7} {'E steps':>8} {'alpha':>6}")
    rng = np.random.default_rng(0)
    for n in (20, 50, 100):
        cable, shapes, grippers, stable = refined(doc, n)
        plant = Plant(doc.cable.with_links(200).with_modulus(2 * cable.youngs_modulus),
                      clamp=cable.rest_link_length)
        truth, ok, message = plant.hold(resample_by_arc_length(stable[3], 201),
                                        grippers.clip_poses(3))
        assert ok, message
        measured = resample_by_arc_length(truth, 200) + rng.normal(scale=1e-3, size=(200, 3))
        runs = [correct_plan(cable, shapes, grippers, 3, measured, stabilized=stable,
                             trajectory=doc.trajectory) for _ in range(5)]
        result = min(runs, key=lambda r: r.seconds)
        cpu = min(r.cpu_seconds for r in runs)
        print(f"{n:>4} {1e3 * result.seconds:>16.0f} {1e3 * cpu:>13.0f} "
              f"{1e3 * result.prediction_seconds:>17.0f} {result.iterations:>7} "
              f"{result.model.steps:>8} "
              f"{result.model.discretization:>6.2f}")


def part2(docs) -> None:
    print("\nPart 2: the plant (n = 100, 1 mm noise, 200 points) on the n = 20 plans; final mean "
          "error [mm]")
    print(f"{'plan':>12} {'plant':>22} {'checkpoints':>12} {'open loop':>10} {'closed':>8} "
          f"{'ratio':>6} {'floor':>6} {'E model -> updated [Pa]':>25}")
    for name, doc in docs.items():
        cable = doc.cable
        last = len(doc.shapes) - 1
        stable = doc.stabilized
        cases = [
            ("E x0.5", cable.with_links(100).with_modulus(0.5 * cable.youngs_modulus),
             [last // 2]),
            ("E x2", cable.with_links(100).with_modulus(2 * cable.youngs_modulus), [last // 2]),
            ("E x0.5", cable.with_links(100).with_modulus(0.5 * cable.youngs_modulus),
             [last // 2, last - 1]),
            ("E x2", cable.with_links(100).with_modulus(2 * cable.youngs_modulus),
             [last // 2, last - 1]),
        ]
        floors = {}
        for label, plant_cable, checks in cases:
            plant = Plant(plant_cable, noise=1e-3, n_measured=200, seed=1,
                          clamp=cable.rest_link_length)
            run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, checks,
                                  stabilized=stable, trajectory=doc.trajectory)
            if label not in floors:
                floors[label] = reachable_error(plant, doc.grippers.clip_poses(last),
                                                run.reference, run.open_loop[-1])
            e = (f"{cable.youngs_modulus:.3g} -> {run.corrections[-1].model.youngs_modulus:.3g}"
                 if run.corrections else "refused: " + "; ".join(run.refusals)[:60])
            print(f"{name:>12} {label:>22} {','.join(map(str, checks)):>12} "
                  f"{1e3 * run.open_loop_error:>10.2f} {1e3 * run.closed_loop_error:>8.2f} "
                  f"{run.improvement:>6.1f} {1e3 * floors[label]:>6.2f} {e:>25}")


def main() -> None:
    with tempfile.TemporaryDirectory() as folder:
        docs = {name: plan_with_links(path, 20, Path(folder)) for name, path in SCENARIOS.items()}
    part1(docs["sagging demo"])
    part2(docs)


if __name__ == "__main__":
    sys.exit(main())
