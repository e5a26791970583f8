"""Closed-loop shape correction (issues 22, 35): its time, and what one correction buys on plants
that are not the model.

Part 1, time: a warm correction (:class:`dloplan.app.correct.CorrectionService`, the plan kept
in memory: the first call loads the compiled kernels, the next ones are what a robot cell's loop
pays), at the sagging demo's own n and at n = 20, 50, 100, measured at shape 3 on a chain plant
of 200 links at E x1.5, 1 mm noise, 200 points; best and median of 10 warm calls
(``--calls``), CPU and wall; and the one-shot ``dloplan correct`` command's own report of its
CPU and wall time.

Part 2, plants: every example plan (sagging demo, 3D Ethernet, embedded U demo) planned by
``dloplan plan`` at its own n and at n = 20, run open loop and corrected once on

* ``chain``: dloplan's own chain on about 100 links (the same physics, finer; the multiple of
  the plan's n nearest to 100, ``fine_links``, so it clamps exactly L / n);
* ``dismech``: dismech-newton's discrete elastic rod (``tests/plants.py``: as many edges,
  ``fine_links``; clamped edges prescribed with their twist; a static solve per
  rest state, 0.1-0.5 s CPU; optional, skipped when ``dismech-newton`` is missing);
* ``mujoco``: MuJoCo 3.x's elastic cable (``tests/plants.py``: capsules on ball joints, Cosserat
  bending and twist, welded grippers; 5 segments per model link, ``MUJOCO_SEGMENTS``;
  optional; not run by default: a rest state is a simulation to rest, minutes per row at the
  examples' n = 12 and about an hour at n = 20, ``tests/plants.py`` says why),

one factor at a time around the base case (n = 20, E x2, each gripper clamping one model link L / n,
correction at mid-path): the plan's own n; E x0.5 and x10; a grip of 0.8 L / n; the correction early
(shape 1) and late (T - 1); early and again at mid-path ("early again", K "1+3") (``--cases``).
Columns: final mean error against the plan's stabilized
target (curves at equal arc length) open loop and closed loop [mm], their ratio, the floor (the
least error any correction of the target's clips leaves that plant, ``reachable_error``;
``--no-floor`` skips it; on every plant, with forward differences of a step 100 times the plant's
resolution, ``Plant.resolution``, and fewer evaluations on the slow plants, ``FLOOR_EVALUATIONS``:
there it is what the fit reached, an upper bound of the floor), "E told" (the closed loop
with the correction told the plant's E, ``modulus="known"``: what it reaches when E is not
limited by what the measurement at K tells; ``--no-told`` skips it), "E/E sd" (the corrected
model's E over the plant's, and sd(ln E) as the measurement tells it), the correction's
prediction interval of the final error [mm] and whether it covers the plant's, the clamp length the
correction estimated [mm] ("model": not told by the measurement, the model's L / n kept), whether
the correction as ``dloplan correct`` writes it passes ``dloplan verify`` (``written``: checked,
written, read back and verified) or what refused it, and the correction's CPU time [ms]. 1 mm noise,
200 points.

Part 3, the early correction over noise draws (``--part 3 --seeds 40``): the 3D job corrected
at shape 1 (and at 1 and again at mid-path) on the chain plant at E x2, grip known, its ratio to
the floor for each seed and their distribution: one noisy, nearly straight shape tells ln E to
sd 0.18, so the ratio is a draw.

Part 4, what one correction can do where the measurement does not tell E (``--part 4``,
``--factors``): the plan (the U demo by default, ``--plans``) at n = 20 on chain plants of
about 100 links at E x0.5, x2, x10 (no noise; grip L / n), each plant's floor, and, for every
pair of them and all together, the largest ratio to its floor that any single correction of
the target's clips leaves them: between a lower bound (weak duality, the largest B(w) =
min_p sum_k w_k e_k(p) / f_k over weights w on a grid of the simplex,
``dloplan.correct.plant.shared_floor``) and the ratios of the best correction found (an upper
bound). A correction that cannot tell these plants apart from its measurement (the U demo's
shapes before the target tell ln E to sd 5-9) gives them one correction, up to noise, so one
of them ends at least the lower bound above its floor. "alone": each plant's own least mean
distance over its floor (the floor is a least-squares fit's mean distance, not the least mean
distance). About 6 minutes of wall time at load 6-9.

The correction fits the clips on a refined chain by default (``correct_plan``'s ``fit_links``,
60 links at n = 12 and 20); ``--fit-links N`` sets it for parts 2 and 3 (the plan's n: its own
chain, as before).

Run: ``PYTHONPATH=tests python benchmarks/bench_correct.py [--part 2]
[--plants chain,dismech,mujoco] [--cases base,own n,...] [--plans ...] [--no-floor]
[--fit-links N]``.
Part 2 with the default plants (chain and dismech, 24 rows each) took about 8 minutes of wall
time per plant on the shared host (load 13; run them as two processes, ``--plants chain`` and
``--plants dismech``), most of it planning the six plans and the floors; a dismech row is 1-5 s of
plant CPU plus its floor (12 evaluations of 13 rest states).
Timings on this machine are shared with other sessions (2 cores); read the CPU column.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import itertools
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import yaml

from dloplan.app import read_plan, verify_plan, write_plan
from dloplan.app.correct import CorrectionService, check_correction
from dloplan.cable import COMPOSITE_AXIAL_MODULI
from dloplan.cli import main as dloplan_main
from dloplan.correct import (
    CorrectionRefused,
    Plant,
    reachable_error,
    run_closed_loop,
    shared_floor,
)
from dloplan.geometry import resample_by_arc_length
from dloplan.pipeline.stages import program_of
from dloplan.vision.shapes_io import RegisteredShape, write_shapes

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = {"sagging demo": ROOT / "tests" / "data" / "sagging_demo.yaml",
             "3D ethernet": ROOT / "examples" / "qualitative2_ethernet_3d.yaml",
             "U demo": ROOT / "src" / "dloplan" / "data" / "demo.yaml"}
NOISE, POINTS = 1e-3, 200


def plan_with_links(source: Path, n_links: int | None, folder: Path):
    """The plan of ``dloplan plan`` for the scenario, on ``n_links`` (None: its own)."""
    data = yaml.safe_load(source.read_text(encoding="utf-8"))
    if n_links is not None:
        data["cable"]["n_links"] = n_links
    data["outputs"] = ["json"]
    n = data["cable"]["n_links"]
    scenario = folder / f"{source.stem}_{n}.yaml"
    scenario.write_text(yaml.safe_dump(data), encoding="utf-8")
    out = folder / scenario.stem
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        dloplan_main(["plan", str(scenario), "-o", str(out), "-q"])
    return read_plan(out / "plan.json"), out / "plan.json"


def measurement(doc, at: int, factor: float, seed: int = 0) -> np.ndarray:
    plant = Plant(doc.cable.with_links(200).with_modulus(factor * doc.cable.youngs_modulus),
                  clamp=doc.cable.rest_link_length)
    run = run_closed_loop(plant, doc.cable, doc.shapes, doc.grippers, [],
                          stabilized=doc.stabilized)
    rng = np.random.default_rng(seed)
    return resample_by_arc_length(run.open_loop[at], POINTS) + rng.normal(scale=NOISE,
                                                                         size=(POINTS, 3))


def part1(folder: Path, calls: int = 10) -> None:
    print("Part 1: a warm correction (CorrectionService; sagging demo at shape 3, plant n = 200 "
          f"at E x1.5, 1 mm noise, 200 points; {calls} calls after the first, CPU ms, median "
          "(best))")
    print(f"{'n':>4} {'first wall':>10} {'to the motion':>14} {'fast answer':>12} "
          f"{'+ predictions':>14} {'+ program check':>16}  verdict")
    source = SCENARIOS["sagging demo"]
    for n in (None, 20, 50, 100):
        doc, path = plan_with_links(source, n, folder)
        points = measurement(doc, 3, 1.5)
        service = CorrectionService(doc)
        first = service.correct(3, points)
        columns = []
        for flags in (dict(predict=False, check_program=False),
                      dict(predict=True, check_program=False),
                      dict(predict=True, check_program=True)):
            warm = [service.correct(3, points, **flags) for _ in range(calls)]
            cpu = [1e3 * a["cpu_seconds"] for a in warm]
            columns.append(f"{statistics.median(cpu):.1f} ({min(cpu):.1f})")
            if not flags["predict"]:
                motion = [1e3 * a["correction"]["cpu_seconds"] for a in warm if a["ok"]]
        verdict = "ok" if warm[-1]["ok"] else warm[-1]["error"][:60]
        print(f"{doc.cable.n_links:>4} {1e3 * first['seconds']:>8.0f} ms "
              f"{statistics.median(motion):>8.1f} ({min(motion):.1f}) {columns[0]:>12} "
              f"{columns[1]:>14} {columns[2]:>16}  {verdict}")
        if n is None:  # the one-shot command, its own timing line
            shapes = folder / "measured.csv"
            write_shapes(shapes, [RegisteredShape(points, frame_id=doc.frame_id,
                                                  label="xi_3")])
            started = time.perf_counter()
            done = subprocess.run([sys.executable, "-m", "dloplan.cli", "correct", str(path),
                                   "--at", "3", "--measured", str(shapes), "-o",
                                   str(folder / "one-shot"), "--mode", "all", "-q"],
                                  capture_output=True, text=True, check=False)
            outside = time.perf_counter() - started
            lines = [line for line in (done.stdout + done.stderr).splitlines()
                     if "ms CPU" in line or "error" in line]
            print(f"     one-shot dloplan correct (exit {done.returncode}, {outside:.2f} s as "
                  f"timed from outside): {lines[-1] if lines else done.stderr.strip()}")


MUJOCO_SEGMENTS = 5
"""MuJoCo segments per model link: a grip of 0.8 L / n is 4 whole segments, and the cable comes
to rest at the examples' n = 12 (2 per link did not)."""


STIFF_AXIAL_TOLERANCE = 1e-4
"""[m] the rod's Newton tolerance with the copper axial modulus (267 E): in float32 the stretch
energy's rounding hides the bending energy's last changes, and the line search stalls with
Newton steps of 10-40 micrometres (a tenth of the measurement's noise; 1e-5 m otherwise)."""

FINE = 100
"""About this many links of the chain plant and edges of the dismech-newton rod: the multiple of
the plan's n nearest to it (:func:`fine_links`: 100 at n = 20, 96 at n = 12), so that the plant
clamps exactly the model's L / n (a clamp of 0.8 L / n is then 4 links at n = 20, 6 at n = 12:
0.75 L / n)."""


def fine_links(n_links: int) -> int:
    """The plant's links for a plan of ``n_links``: the multiple nearest to :data:`FINE`."""
    return n_links * max(1, round(FINE / n_links))


FLOOR_EVALUATIONS = {"chain": 200, "dismech": 12, "mujoco": 4}
"""Evaluations of the floor's cost per plant (``reachable_error``; each Jacobian is 12 plant
solves more): another simulator's rest state costs 10-1000 times the chain's."""


def plants(names):
    out = {"chain": lambda cable, clamp, links: Plant(cable.with_links(fine_links(links)),
                                                      noise=NOISE,
                                                      n_measured=POINTS, seed=1, clamp=clamp)}
    if "mujoco" in names:
        try:
            import mujoco  # noqa: F401
            from plants import MujocoPlant
        except ImportError as exc:
            print(f"mujoco plant skipped: {exc} (pip install dloplan[plants])")
        else:
            out["mujoco"] = lambda cable, clamp, links: MujocoPlant(
                cable.with_links(MUJOCO_SEGMENTS * links), noise=NOISE, n_measured=POINTS,
                seed=1, clamp=clamp)
    if "dismech" in names:
        try:
            from plants import DismechPlant, import_dismech

            import_dismech()
        except ImportError as exc:
            print(f"dismech plant skipped: {exc} (pip install dloplan[plants])")
        else:
            out["dismech"] = lambda cable, clamp, links: DismechPlant(
                cable.with_links(fine_links(links)), noise=NOISE, n_measured=POINTS, seed=1,
                clamp=clamp)
    return {k: v for k, v in out.items() if k in names}


def written_and_verified(doc, correction, folder: Path) -> str:
    """What ``dloplan correct`` does with the correction: check it (refused: the reason), write
    the corrected plan, read it back and run dloplan verify's checks on it."""
    try:
        corrected, _ = check_correction(doc, correction, verify=True)
    except CorrectionRefused as exc:
        return "refused: " + str(exc)[:70]
    path = write_plan(folder / "corrected.json", corrected)
    back = read_plan(path)
    verification = verify_plan(back)
    program = program_of(back)
    return "written, verify ok" if verification.ok and program.ok else \
        f"written, verify FAILS: {'; '.join(verification.messages)[:50]}"


CASES = ("base", "own n", "E x0.5", "E x10", "grip 0.8", "early", "late", "stiff axial",
         "grip told", "early again")
"""The cases around the base (n = 20, E x2, grip L / n known to the correction, correction at
mid-path), one factor at a time. "grip 0.8": the plant clamps 0.8 L / n and the correction
estimates it (``grip="estimate"``); "grip told": the base with the correction's default, the
clamp length estimated when the measurement tells it (``grip="estimate"``, "est" in the grip
column); where the plant clamps L / n the correction is told so (``grip="known"``). "stiff
axial": the plant's cable nearly inextensible (the composite cables' copper axial modulus,
``COMPOSITE_AXIAL_MODULI``, 2 GPa), "Ea" in the E column; not run by default: the plans' cables
have it already (the catalogue's default), so it is the base case. "early again": corrected
early (shape 1) and again at mid-path, each correction from its own measurement (K "1+3")."""


def oracle(plant, doc, at: list, modulus: float, grip: str, fit_links: int | None = None) -> str:
    """The closed loop's final error [mm] with the correction told the plant's E
    (``modulus="known"`` on the plan's cable at the plant's E; the bias, clamp length and offset
    estimated as in the row): what the correction reaches when E is not limited by what the
    measurement tells ("-": refused)."""
    run = run_closed_loop(plant, doc.cable.with_modulus(modulus), doc.shapes, doc.grippers,
                          at, stabilized=doc.stabilized, trajectory=doc.trajectory, grip=grip,
                          modulus="known", fit_links=fit_links)
    return f"{1e3 * run.closed_loop_error:.2f}" if run.corrections else "-"


def part2(names, floor: bool, folder: Path, plans, chosen=CASES, axial_like_e=False,
          with_told: bool = True, fit_links: int | None = None) -> None:
    print("\nPart 2: plants; final mean error [mm] against the plan's stabilized target")
    print(f"{'plan':>12} {'n':>3} {'plant':>7} {'E':>5} {'grip':>6} {'K':>3} {'open':>7} "
          f"{'closed':>7} {'ratio':>6} {'floor':>6} {'E told':>6} {'E/E sd':>10} "
          f"{'interval':>13} {'cover':>5} "
          f"{'clamp':>7} {'CPU ms':>6}  written?")
    makers = plants(names)
    for name, source in SCENARIOS.items():
        if name not in plans:
            continue
        docs = {}
        for n in (None, 20):
            doc, _ = plan_with_links(source, n, folder)
            docs[doc.cable.n_links] = doc
        base_n = 20
        own_n = next(k for k in docs if k != 20) if len(docs) > 1 else 20
        for plant_name, make in makers.items():
            base = (base_n, 2.0, 1.0, "mid", False, "known")
            cases = dict(zip(CASES, [base, (own_n, *base[1:]), (base_n, 0.5, *base[2:]),
                                     (base_n, 10.0, *base[2:]),
                                     (*base[:2], 0.8, *base[3:5], "estimate"),
                                     (*base[:3], "early", *base[4:]),
                                     (*base[:3], "late", *base[4:]),
                                     (*base[:4], True, base[5]), (*base[:5], "estimate"),
                                     (*base[:3], "early again", *base[4:])],
                             strict=True))
            cases = [cases[case] for case in chosen]
            for n, factor, grip, when, stiff, told in dict.fromkeys(cases):
                doc = docs[n]
                cable = doc.cable
                last = len(doc.shapes) - 1
                at = {"early": [1], "mid": [last // 2], "late": [last - 1],
                      "early again": [1, last // 2]}[when]
                shown_at = "+".join(map(str, at))
                real = cable.with_modulus(factor * cable.youngs_modulus)
                modulus = f"x{factor:g}" + ("Ea" if stiff else "")
                if stiff:
                    real = replace(real, axial_modulus=COMPOSITE_AXIAL_MODULI[cable.name])
                elif axial_like_e:  # the plant's cable stretches with E_a = E (marked "a")
                    real, modulus = replace(real, axial_modulus=None), modulus + "a"
                plant = make(real, grip * cable.rest_link_length, cable.n_links)
                shown = f"{grip:>4.1f}" + ("est" if told == "estimate" else "L/n")
                if real.stiff_axial and plant_name == "dismech":
                    plant = replace(plant, tolerance=STIFF_AXIAL_TOLERANCE)
                started = time.process_time()
                try:
                    run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, at,
                                          stabilized=doc.stabilized, trajectory=doc.trajectory,
                                          grip=told, fit_links=fit_links)
                except RuntimeError as exc:
                    print(f"{name:>12} {n:>3} {plant_name:>7} {modulus:<5} {shown:>7} "
                          f"{shown_at:>3} plant failed: {exc}")
                    continue
                plant_seconds = time.process_time() - started
                told_mm = (oracle(plant, doc, at, real.youngs_modulus, told, fit_links)
                           if with_told else "-")
                floor_mm = "-"
                if floor:
                    best = reachable_error(plant, doc.grippers.clip_poses(last), run.reference,
                                           run.open_loop[-1],
                                           max_evaluations=FLOOR_EVALUATIONS[plant_name])
                    floor_mm = f"{1e3 * best:.2f}"
                if run.corrections:
                    c = run.corrections[-1]  # the last: its interval is of the final error
                    low, high = c.prediction_interval
                    interval = f"{1e3 * low:5.2f}-{1e3 * high:5.2f}"
                    cover = "yes" if low <= run.closed_loop_error <= high else "NO"
                    written = written_and_verified(replace(doc), c, folder)
                    cpu = f"{1e3 * c.cpu_seconds:.0f}"
                    clamp = (f"{1e3 * (1 + 0.5 * c.model.grip) * cable.rest_link_length:.1f}"
                             if c.model.grip_estimated else "model")
                    fitted = (f"{c.model.youngs_modulus / real.youngs_modulus:.2f} "
                              f"{c.model.log_sd:.2g}")
                else:
                    interval, cover, cpu, clamp, fitted = "-", "-", "-", "-", "-"
                    written = "refused: " + "; ".join(run.refusals)[:70]
                print(f"{name:>12} {n:>3} {plant_name:>7} {modulus:<5} {shown:>7} "
                      f"{shown_at:>3} {1e3 * run.open_loop_error:>7.2f} "
                      f"{1e3 * run.closed_loop_error:>7.2f} {run.improvement:>6.1f} "
                      f"{floor_mm:>6} {told_mm:>6} {fitted:>10} {interval:>13} {cover:>5} "
                      f"{clamp:>7} {cpu:>6}  {written}"
                      f"  [plant {plant_seconds:.0f} s CPU]", flush=True)


def part3(folder: Path, seeds: int, fit_links: int | None = None) -> None:
    """The early correction's ratio to the floor over noise draws: the 3D job (n = 20) on the
    100-link chain plant at E x2, grip known, corrected at shape 1 ("1") and at shape 1 and
    again at mid-path ("1+3"), seeds 1 .. ``seeds``; the floor does not depend on the noise."""
    print(f"\nPart 3: 3D Ethernet, n = 20, chain plant E x2, grip known, {seeds} noise draws: "
          "closed / floor")
    doc, _ = plan_with_links(SCENARIOS["3D ethernet"], 20, folder)
    cable, last = doc.cable, len(doc.shapes) - 1
    real = cable.with_modulus(2.0 * cable.youngs_modulus)
    ratios = {"1": [], "1+3": []}
    floor = None
    for seed in range(1, seeds + 1):
        plant = Plant(real.with_links(fine_links(20)), noise=NOISE, n_measured=POINTS, seed=seed,
                      clamp=cable.rest_link_length)
        for name, at in (("1", [1]), ("1+3", [1, last // 2])):
            run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, at,
                                  stabilized=doc.stabilized, trajectory=doc.trajectory,
                                  grip="known", fit_links=fit_links)
            if floor is None:
                floor = reachable_error(plant, doc.grippers.clip_poses(last), run.reference,
                                        run.open_loop[-1])
            ratios[name].append(run.closed_loop_error / floor)
            if name == "1":
                m = run.corrections[0].model if run.corrections else None
                z = 0.0 if m is None else np.log(m.youngs_modulus / real.youngs_modulus) / m.log_sd
                shown = ("refused" if m is None else f"ln E off by {z:+.2f} sd"
                         + (", offset taken out" if m.offset_estimated else ""))
            else:
                again = "" if len(run.corrections) == 2 else " (second refused)"
                print(f"  seed {seed:3d}: K 1 {ratios['1'][-1]:.3f} ({shown}); K 1+3 "
                      f"{ratios['1+3'][-1]:.3f}{again}", flush=True)
    print(f"  floor {1e3 * floor:.3f} mm")
    for name, values in ratios.items():
        v = np.array(values)
        print(f"  K {name:>3}: median {np.median(v):.3f}, mean {v.mean():.3f}, 90 % "
              f"{np.percentile(v, 90):.3f}, largest {v.max():.3f}; within 1.15 of the floor: "
              f"{np.sum(v <= 1.15)} of {len(v)}")


def simplex_grid(count: int, step: float) -> list[np.ndarray]:
    """The weights w_k >= 0 summing to 1 on a grid of ``step`` (``count`` of them)."""
    cells = round(1.0 / step)
    return [np.array([*c, cells - sum(c)]) / cells
            for c in itertools.product(range(cells + 1), repeat=count - 1) if sum(c) <= cells]


def part4(folder: Path, plans, factors) -> None:
    """The largest ratio to the floor any single correction leaves plants that differ only in
    E (module docstring, part 4)."""
    print("\nPart 4: one correction for plants the measurement cannot tell apart (n = 20, chain "
          f"plants of {fine_links(20)} links, no noise, grip L / n): the largest ratio to the "
          "floor")
    for name in plans:
        doc, _ = plan_with_links(SCENARIOS[name], 20, folder)
        cable, last = doc.cable, len(doc.shapes) - 1
        clips, reference = doc.grippers.clip_poses(last), doc.stabilized[-1]
        plants, guesses, floors = [], [], []
        for factor in factors:
            plant = Plant(cable.with_modulus(factor * cable.youngs_modulus).with_links(
                fine_links(20)), clamp=cable.rest_link_length)
            run = run_closed_loop(plant, cable, doc.shapes, doc.grippers, [],
                                  stabilized=doc.stabilized)
            plants.append(plant)
            guesses.append(run.open_loop[-1])
            floors.append(reachable_error(plant, clips, reference, run.open_loop[-1]))
            alone, _ = shared_floor(plants[-1:], clips, reference, guesses[-1:], floors[-1:])
            print(f"{name:>12} E x{factor:<4g} floor {1e3 * floors[-1]:.3f} mm, alone "
                  f"{alone:.3f}", flush=True)
        bounds = {}
        for size in range(2, len(factors) + 1):
            for chosen in itertools.combinations(range(len(factors)), size):
                # a subset's bound holds for the set (its largest ratio is among the set's)
                lower = max((bounds[c] for c in itertools.combinations(chosen, size - 1)
                             if c in bounds), default=0.0)
                weights, upper = None, (math.inf, None)
                for w in simplex_grid(size, 0.1 if size == 2 else 0.2):
                    try:
                        bound, ratios = shared_floor([plants[k] for k in chosen], clips,
                                                     reference, [guesses[k] for k in chosen],
                                                     [floors[k] for k in chosen], weights=w)
                    except RuntimeError as exc:  # no bound from these weights
                        print(f"  weights {np.round(w, 2).tolist()}: {exc}")
                        continue
                    if bound > lower:
                        lower, weights = bound, w
                    if max(ratios) < upper[0]:
                        upper = (float(max(ratios)), ratios)
                bounds[chosen] = lower
                shown = ", ".join(f"x{factors[k]:g}" for k in chosen)
                how = (f"w {np.round(weights, 2).tolist()}" if weights is not None else
                       "a subset's")
                print(f"{name:>12} E {shown}: one correction leaves one of them at least "
                      f"{lower:.3f} times its floor ({how}); the best found {upper[0]:.3f} "
                      f"({', '.join(f'{r:.3f}' for r in upper[1])})", flush=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plants", default="chain,dismech")
    parser.add_argument("--no-floor", action="store_true")
    parser.add_argument("--no-told", action="store_true",
                        help="skip the 'E told' column (a second closed loop per row)")
    parser.add_argument("--cases", default=",".join(c for c in CASES if c != "stiff axial"),
                        help="comma-separated, of: " + ", ".join(CASES))
    parser.add_argument("--plans", default=",".join(SCENARIOS),
                        help="comma-separated, of: " + ", ".join(SCENARIOS))
    parser.add_argument("--part", choices=["1", "2", "3", "4", "both"], default="both",
                        help="1: time, 2: plants (both: 1 and 2), 3: the early correction over "
                        "noise draws, 4: one correction for plants of unknown E")
    parser.add_argument("--factors", default="0.5,2,10",
                        help="part 4: the plants' E over the plan's, comma-separated")
    parser.add_argument("--seeds", type=int, default=40, help="part 3: noise draws")
    parser.add_argument("--calls", type=int, default=10,
                        help="part 1: warm calls per n and column (their median and best)")
    parser.add_argument("--fit-links", type=int, default=None,
                        help="the links the correction fits the clips on (correct_plan's "
                        "fit_links; default: its own choice, 60 at n = 12 and 20; the plan's n: "
                        "the plan's chain, as before issue 35's refined fit)")
    parser.add_argument("--plant-axial-like-e", action="store_true",
                        help="the plants' cables stretch with E_a = E (the rod's float32 solve "
                             "does not settle every rest state of the 3D job with the plans' "
                             "copper axial modulus)")
    args = parser.parse_args()
    print(json.dumps({"host": "2 cores shared with other sessions"}))
    with tempfile.TemporaryDirectory() as folder:
        if args.part in ("1", "both"):
            part1(Path(folder), args.calls)
        if args.part in ("2", "both"):
            part2(args.plants.split(","), not args.no_floor, Path(folder),
                  args.plans.split(","), args.cases.split(","), args.plant_axial_like_e,
                  not args.no_told, args.fit_links)
        if args.part == "3":
            part3(Path(folder), args.seeds, args.fit_links)
        if args.part == "4":
            part4(Path(folder), ["U demo"] if args.plans == parser.get_default("plans") else
                  args.plans.split(","), [float(f) for f in args.factors.split(",")])
    return 0


if __name__ == "__main__":
    sys.exit(main())
