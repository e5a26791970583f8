"""Timing of the YuMi IK: per pose (seeded near, from home) and for a 50-pose cable path.

Run: PYTHONPATH=src python benchmarks/bench_robot.py
"""

from __future__ import annotations

import time

import numpy as np
from scipy.spatial.transform import Rotation

from dloplan.frames import frame_from_axis
from dloplan.robot import IKOptions, check_reachability, forward, inverse, search_placement, yumi


def _per_pose(arm, n=100):
    rng = np.random.default_rng(0)
    q = rng.uniform(arm.lower, arm.upper, (n, 7))
    pos, rot = forward(arm, q)
    for label, seeds, opts in (
        ("seeded 0.1 rad away", q + rng.normal(0, 0.1, q.shape), IKOptions()),
        ("from home (no restarts)", [None] * n, IKOptions(restarts=0)),
    ):
        t0 = time.perf_counter()
        results = [inverse(arm, pos[i], rot[i], seed=seeds[i], options=opts) for i in range(n)]
        dt = (time.perf_counter() - t0) / n
        rate = np.mean([r.success for r in results])
        its = np.mean([r.iterations for r in results])
        print(f"  {arm.name:5s} {label:24s} {dt * 1e3:7.2f} ms/pose  success {rate:4.0%}  "
              f"{its:5.1f} iterations")


def _cable_path(n_shapes):
    pos = np.zeros((n_shapes, 2, 3))
    u = np.zeros((n_shapes, 2, 3))
    for k, t in enumerate(np.linspace(0.0, 1.0, n_shapes)):
        half = 0.2 - 0.05 * t
        pos[k, 0] = [0.38 + 0.05 * t, -half, 0.05 + 0.1 * t]
        pos[k, 1] = [0.38 + 0.05 * t, half, 0.05 + 0.1 * t]
        u[k, 0] = [np.sin(0.6 * t), np.cos(0.6 * t), 0.0]
        u[k, 1] = [np.sin(0.6 * t), -np.cos(0.6 * t), 0.0]
    rot = frame_from_axis(u.reshape(-1, 3))
    return pos, Rotation.from_quat(rot.as_quat().reshape(n_shapes, 2, 4))


def main() -> None:
    robot = yumi()
    print("IK per pose (100 random reachable poses):")
    for arm in robot.arms:
        _per_pose(arm)
    print("50-pose cable path, both arms (sub-steps, both grips, clearance):")
    pos, rot = _cable_path(50)
    t0 = time.perf_counter()
    result = check_reachability(pos, rot)
    dt = time.perf_counter() - t0
    print(f"  {dt:.3f} s total, {dt / 50 * 1e3:.2f} ms per pose; {result.message}")
    print("placement search, job misplaced by (0.3, 0.15, 0) m, 12-pose path:")
    pos, rot = _cable_path(12)
    t0 = time.perf_counter()
    placement = search_placement(pos + [0.3, 0.15, 0.0], rot, extent=(0.35, 0.35, 0.0))
    print(f"  {time.perf_counter() - t0:.3f} s, {placement.candidates} full check(s); "
          f"{placement.message}")


if __name__ == "__main__":
    main()
