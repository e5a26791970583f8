"""Verification timings: the eigen-solve against n, a small path split by check, and the
embedded demo's plan split by check (issue 20's target: the demo's replay <= 0.2 s).

The demo's plan is made once (``run_job``, no verification), then verified five times in this
process (numba's kernels loaded by the first); the best time per check is printed.
Before (main 11d9c62, 2026-11-30, quiet): demo replay 0.25-0.26 s, of which 0.14 s composing
scipy ``Rotation`` objects for the clips' slerp; with ``frames.slerp_quaternions`` 0.18 s,
with the held points from the quaternions' x-axes (``frames.quaternion_x_axes``) 0.17 s (load 1.2).

Fast against reference paths (issue 34, docs/performance.md section 1): for shipped examples
(planned once, without the robot), the snap-through check and the replay timed in this process,
CPU seconds (best of ``--repeats``, the two alternating), the reference being the Python loop
of the continuation (``compiled=False``) and the thesis' explicit replay (``scheme="explicit"``),
with the largest difference of their knot deviations and whether the verdicts agree.

Run: PYTHONPATH=src python benchmarks/bench_verify.py [--examples NAME ...] [--repeats 2]
"""

from __future__ import annotations

import argparse
import math
import os
import time
from functools import partial
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from dloplan.cable import catalogue_cable
from dloplan.sim.clips import ClipPoses
from dloplan.sim.statics import continuation, equilibrium
from dloplan.verify.report import verify_path
from dloplan.verify.stability import elastic_stability

FACING = Rotation.from_rotvec([[0, 0, 0], [0, 0, math.pi]])


def best_of(fn, repeats: int = 5) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def hanging(n: int):
    cable = catalogue_cable("ethernet", n)
    clips = ClipPoses(np.array([[0, 0, 0.3], [0.4, 0, 0.3]]), FACING)
    guess = np.zeros((n + 1, 3))
    guess[:, 0] = np.linspace(-0.05, 0.45, n + 1)
    return cable, equilibrium(cable, guess, clips).shape


def eigen_scaling() -> None:
    print("smallest 3 eigenpairs of the free Hessian (ethernet, hanging, sparse shift-invert)")
    print(f"{'n':>6} {'time [ms]':>10} {'per link [us]':>14} {'lambda_1 [N/m]':>15}")
    for n in (10, 100, 1000):
        cable, x = hanging(n)
        t = best_of(lambda c=cable, s=x: elastic_stability(c, s, method="sparse"))
        lam = elastic_stability(cable, x).smallest
        print(f"{n:>6} {1e3 * t:>10.2f} {1e6 * t / n:>14.1f} {lam:>15.4g}")


def path_timing() -> None:
    cable = catalogue_cable("usb", 10)
    poses = [ClipPoses(np.array([[0, 0, 0.3], [0.4 - d, d, 0.3 + 0.5 * d]]), FACING)
             for d in np.linspace(0.0, 0.12, 5)]
    guess = np.zeros((11, 3))
    guess[:, 0] = np.linspace(-0.05, 0.45, 11)
    shapes = np.stack([e.shape for e in continuation(cable, guess, poses, substeps=5)])
    start = time.perf_counter()
    result = verify_path(cable, shapes, poses, times=np.linspace(0.0, 4.0, len(poses)))
    total = time.perf_counter() - start
    print(f"\nverification of a 5-shape path (usb, n = 10, 4 s replay): {total:.2f} s")
    for check, seconds in result.timings.items():
        print(f"  {check:<10} {seconds:8.3f} s  ({100 * seconds / total:4.1f} %)")
    print(result.table())


DEMO_BEFORE_S = {"replay": 0.25}  # main 11d9c62, quiet (docstring)
DEMO_TARGET_S = {"replay": 0.2}


def demo_timing(repeats: int = 5) -> None:
    from importlib import resources

    from dloplan.app.load import resolve_mapping
    from dloplan.io.scenario import read_mapping
    from dloplan.pipeline.stages import run_job, verify_plan

    with resources.as_file(resources.files("dloplan.data").joinpath("demo.yaml")) as path:
        job = resolve_mapping(read_mapping(path), "demo (embedded)")
    doc = run_job(job, check_robot=False)
    best: dict[str, float] = {}
    for _ in range(repeats):
        for check, seconds in verify_plan(doc, robot=False).timings.items():
            best[check] = min(seconds, best.get(check, math.inf))
    print(f"\nthe demo's plan ({len(doc.shapes)} shapes, n = {doc.cable.n_links}), best of "
          f"{repeats} per check:")
    for check, seconds in best.items():
        versus = "" if check not in DEMO_BEFORE_S else \
            f"  (before {DEMO_BEFORE_S[check]:.2f} s: {DEMO_BEFORE_S[check] / seconds:.2f}x; " \
            f"target {DEMO_TARGET_S[check]:.1f} s)"
        print(f"  {check:<10} {seconds:8.3f} s{versus}")


EXAMPLES = ("qualitative1_curved_pa12", "m1_sine_pu_hose", "m2_uniform_curvature_pa12",
            "fig4_8_straight_to_bent", "qualitative2_ethernet_3d", "m2_uniform_curvature_usb")


def cpu_of(fn, repeats: int):
    """(best CPU seconds, last result) of ``repeats`` calls."""
    best, out = math.inf, None
    for _ in range(repeats):
        start = time.process_time()
        out = fn()
        best = min(best, time.process_time() - start)
    return best, out


def fast_against_reference(names, repeats: int) -> None:
    from dloplan.app import load_job
    from dloplan.pipeline.stages import replay_modulus_cap, run_job, settled_shapes
    from dloplan.verify.replay import replay
    from dloplan.verify.snap import check_snap_through

    root = Path(__file__).resolve().parent.parent / "examples"
    print(f"\nfast against reference paths, CPU s, best of {repeats} (load average "
          f"{os.getloadavg()[0]:.1f}; a shared host)")
    print(f"{'example':<27} {'snap ref':>8} {'fast':>6} {'x':>5}  {'replay ref':>10} {'fast':>6} "
          f"{'x':>5}  {'steps ref/fast':>15} {'max dDev um':>11} {'verdicts':>8}")
    for name in names:
        doc = run_job(load_job(root / f"{name}.yaml"), check_robot=False)
        args = (doc.cable, settled_shapes(doc), doc.clip_poses())
        options = dict(knot_times=doc.trajectory.times, law=doc.trajectory.law,
                       youngs_modulus_cap=replay_modulus_cap(doc.cable))
        snaps, replays = {}, {}
        for fast in (False, True) * repeats:  # alternating
            snaps.setdefault(fast, []).append(cpu_of(partial(
                check_snap_through, *args, compiled=fast), 1))
            replays.setdefault(fast, []).append(cpu_of(partial(
                replay, *args, scheme="implicit" if fast else "explicit", **options), 1))
        (s_ref, snap_ref), (s_fast, snap_fast) = (min(snaps[f], key=lambda t: t[0])
                                                  for f in (False, True))
        (r_ref, run_ref), (r_fast, run_fast) = (min(replays[f], key=lambda t: t[0])
                                                for f in (False, True))
        same = (snap_ref.message == snap_fast.message and run_ref.ok == run_fast.ok
                and run_ref.settled == run_fast.settled)
        worst = 1e6 * float(np.max(np.abs(run_ref.deviations - run_fast.deviations)))
        steps = f"{run_ref.simulation.steps}/{run_fast.simulation.steps}"
        print(f"{name:<27} {s_ref:8.3f} {s_fast:6.3f} {s_ref / s_fast:5.1f}  {r_ref:10.3f} "
              f"{r_fast:6.3f} {r_ref / r_fast:5.1f}  {steps:>15} {worst:11.2f} "
              f"{'same' if same else 'DIFFER':>8}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", nargs="*", default=list(EXAMPLES),
                        help="example file stems for the fast/reference comparison")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--only-examples", action="store_true",
                        help="skip the eigen-solve, path and demo timings")
    cli = parser.parse_args()
    if not cli.only_examples:
        eigen_scaling()
        path_timing()
        demo_timing()
    fast_against_reference(cli.examples, cli.repeats)
