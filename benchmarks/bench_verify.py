"""Verification timings: the eigen-solve against n, a small path split by check, and the
embedded demo's plan split by check (issue 20's target: the demo's replay <= 0.2 s).

The demo's plan is made once (``run_job``, no verification), then verified five times in this
process (numba's kernels loaded by the first); the best time per check is printed.
Before (main 11d9c62, 2026-11-30, quiet): demo replay 0.25-0.26 s, of which 0.14 s composing
scipy ``Rotation`` objects for the clips' slerp; with ``frames.slerp_quaternions`` 0.18 s,
with the held points from the quaternions' x-axes (``frames.quaternion_x_axes``) 0.17 s (load 1.2).

Run: PYTHONPATH=src python benchmarks/bench_verify.py
"""

from __future__ import annotations

import math
import time

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


if __name__ == "__main__":
    eigen_scaling()
    path_timing()
    demo_timing()
