"""Verification timings: the eigen-solve against n, and a small path split by check.

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


if __name__ == "__main__":
    eigen_scaling()
    path_timing()
