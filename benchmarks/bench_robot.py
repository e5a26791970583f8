"""Timing of the YuMi IK (per pose, seeded near and from home), a 50-pose cable path, the
placement search, and the verified robot program (`robot_program`) of a 7- and a 50-shape job.

Run: PYTHONPATH=src python benchmarks/bench_robot.py

Times are wall clock and CPU (process time, the better figure on the shared 2-core machine).
Numbers of 2026-11-30, load average ~10, OMP/OPENBLAS_NUM_THREADS=1 (best of 3 CPU):
IK seeded 0.1 rad away 1.8-2.5 ms CPU per pose (12-18 ms wall), from home 30-36 ms CPU;
50-pose reachability 4.6 s wall; robot program of the 7-shape job (9 targets per arm: 2 grips x
~12 arm angles per arm tracked in sub-steps, replay, clearance) 0.44 s CPU (3.3 s wall), of the
50-shape job 1.03 s CPU (12.7 s wall); the M2 USB example's program 0.22 s CPU. Before (main at
9be97c7, the same load, wall only): IK seeded 23-51 ms wall per pose, 50-pose reachability
8.1 s wall (the IK's per-iteration scipy Rotation and pinv, now a closed-form log map, Rodrigues
joint rotations and a 6x6 solve); no robot program existed.

With the IK's solve compiled (robot/ik_compiled.py; 2026-12-01 00:20 UTC, load 2.4, one helper
running), per pose after the first call: seeded 0.16 ms (was 1.8-2.5 ms CPU, about 13x), from
home without restarts 0.6-0.7 ms (was 30-36 ms CPU, about 50x); the 50-pose path 0.032 s (was
4.6 s wall at load 10); the placement search 0.045 s; the robot programs 0.39 s and 0.93 s
with the vectorized numpy ``solve_many``, 0.080 s and 0.294 s with it compiled too
(``solve_batch``: the same solve per problem; 4.9x and 3.2x). ``dloplan plan`` of the q1 example
(qualitative1_curved_pa12.yaml: its repair searches 61 placements) 173 s -> 17.6 s (repair
167 s -> 11.7 s), with the same repair chosen.

One kinematics API for every cell (issue 32: the YuMi's arms are CellArms, one compiled solve
for every arm, seeds given up when their error stalls) and the controller's semantics (issue
31: the arm angle held as a 7th task row, every written robtarget solved back from 96 seeds,
peak joint speeds along the time law). Shared host (another helper's jobs running), best of 3
CPU, OMP/OPENBLAS_NUM_THREADS=1, before (ed58a84) -> after: IK seeded 0.20 -> 0.21 ms CPU per
pose, from home without restarts 0.74 -> 0.64 ms (success 84 % -> 81 %: a stalled seed is
given up); the 50-pose path 0.149 -> 0.136 s; the placement search 0.249 -> 0.181 s; the robot
program of the 7-shape job 0.094 -> 0.208 s CPU and of the 50-shape job 0.388 -> 1.21 s CPU:
the round trip (a new check, 96 seeds per target and arm) and the peaks along the law.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.spatial.transform import Rotation

from dloplan.frames import frame_from_axis
from dloplan.grippers import GripperPath
from dloplan.robot import (
    IKOptions,
    check_reachability,
    forward,
    inverse,
    robot_program,
    search_placement,
    yumi,
)
from dloplan.trajectory import trajectory_from_grippers


def _per_pose(arm, n=100):
    rng = np.random.default_rng(0)
    q = rng.uniform(arm.lower, arm.upper, (n, 7))
    pos, rot = forward(arm, q)
    for label, seeds, opts in (
        ("seeded 0.1 rad away", q + rng.normal(0, 0.1, q.shape), IKOptions()),
        ("from home (no restarts)", [None] * n, IKOptions(restarts=0)),
    ):
        t0, c0 = time.perf_counter(), time.process_time()
        results = [inverse(arm, pos[i], rot[i], seed=seeds[i], options=opts) for i in range(n)]
        dt = (time.perf_counter() - t0) / n
        cpu = (time.process_time() - c0) / n
        rate = np.mean([r.success for r in results])
        its = np.mean([r.iterations for r in results])
        print(f"  {arm.name:5s} {label:24s} {dt * 1e3:7.2f} ms/pose (cpu {cpu * 1e3:6.2f})  "
              f"success {rate:4.0%}  {its:5.1f} iterations")


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
    print("verified robot program (robot_program), cable path in front of the robot:")
    for n_shapes in (7, 50):
        _program(n_shapes)


def _program(n_shapes: int) -> None:
    pos, rot = _cable_path(n_shapes)
    mats = rot.as_matrix()
    grippers = GripperPath(pos, (Rotation.from_matrix(mats[:, 0]), Rotation.from_matrix(
        mats[:, 1])), "minimal", np.zeros(n_shapes))
    trajectory = trajectory_from_grippers(grippers)
    best = (np.inf, np.inf)
    for _ in range(3):
        t0, c0 = time.perf_counter(), time.process_time()
        program = robot_program(grippers, trajectory)
        best = min(best, (time.process_time() - c0, time.perf_counter() - t0))
    print(f"  {n_shapes:3d} shapes: {best[1]:.3f} s wall, {best[0]:.3f} s cpu (best of 3); "
          f"{program.message}")


if __name__ == "__main__":
    main()
