"""Timing of cells from robot descriptions: IK per pose and verification per plan, per cell.

For each preset (two UR5e, two Franka Panda, the YuMi from its description): the IK of one
arm at random reachable poses, seeded 0.1 rad away (what tracking along a path does) and from
the home pose with restarts (a first pose); then the verification of an 8-pose cable path
(path.check_path with ReachOptions.cell_program(): IK tracked through sub-steps, clearance,
table, rows) and the placement search with full checks (search_cell_placement); last, the
program stage of the cell examples.

Run: PYTHONPATH=src python benchmarks/bench_cells.py

Today's numbers (2 shared cores, after merging main; the first run under load average ~15 in
parentheses):
  ur5e_pair   IK seeded 2.2 ms/pose (6.0), from home 25 ms (54), 98 %; 8-pose path 0.05 s;
              placement 0.50 s
  panda_pair  IK seeded 6.7 ms/pose (17.0; 12.5 iterations), from home 42 ms (99), 95 %;
              8-pose path 0.03 s; placement 0.76 s
  yumi        IK seeded 1.8 ms/pose (4.4), from home 28 ms (67), 100 %; 8-pose path 0.33 s
              (fails honestly: continuity at pose 7 with main's 114.2 mm SmartGripper TCP);
              placement 1.1 s (passes)
Before the stall stop of the IK (same session, loaded): from home 222 / 262 / 283 ms per pose.

The pipeline's program stage on the examples of ``examples/cells`` (plan_program: placement
search and verification; then plan.json read back, the cell rebuilt from its record and the
program verified again and compared), first measured 2026-11-30 on the 2 cores shared with
the other agents (the IK numbers of that run were ~3x those above: a loaded machine):
  ur5e_pair_usb        program stage 2.1 s (7 targets), read back and re-verified 2.0 s
  panda_pair_ethernet  program stage 5.5 s (8 targets), read back and re-verified 6.5 s
No cell other than the YuMi existed before (bench_robot.py times the YuMi-specific solver).

With the solve from one seed compiled (robot/ik_compiled.chain_solve; 2026-12-01 00:45 UTC,
load about 2.5, one helper running), the same iterations and success rates:
  ur5e_pair   IK from home with restarts 0.33 ms/pose (was 25 ms: 75x); placement 0.09 s (0.50)
  panda_pair  IK seeded 0.34 ms/pose (6.7 ms: 20x), from home 1.12 ms (42 ms: 37x); placement
              0.11 s (0.76)
  yumi        IK seeded 0.21 ms/pose (1.8 ms), from home 1.05 ms (28 ms); 8-pose path 0.02 s
              (fails as before: continuity at pose 7); placement 0.11 s (1.1)
  panda_pair_ethernet  program stage 0.15 s (5.5 s), read back and re-verified 0.15 s (6.5 s)
  ur5e_pair_usb        program stage 0.08 s (2.1 s), read back and re-verified 0.08 s (2.0 s)

With one solve for every arm (issue 32; ``chain_solve`` merged into ``ik_compiled.solve``,
wrist flips as seeds for every arm), shared host, before (ed58a84) -> after: IK from home with
8 restarts, UR5e 1.56 -> 1.54 ms, Panda 4.59 -> 2.20 ms, YuMi 5.46 -> 2.55 ms per pose; seeded
Panda 1.28 -> 0.96 ms, YuMi 0.70 -> 0.36 ms; placement search 0.38 -> 0.28 s (UR5e), 0.45 ->
0.40 s (Panda).
"""

from __future__ import annotations

import time

import numpy as np
from scipy.spatial.transform import Rotation

from dloplan.robot.kinematics import IKOptions, forward, inverse
from dloplan.robot.path import ReachOptions, check_path
from dloplan.robot.placement import search_cell_placement
from dloplan.robot.urdf_cell import PRESETS


def _ik(arm, n=40):
    rng = np.random.default_rng(0)
    q = rng.uniform(arm.lower, arm.upper, (n, arm.n_joints))
    pos, rot = forward(arm, q)
    for label, seeds, opts in (("seeded 0.1 rad away", q + rng.normal(0, 0.1, q.shape),
                                IKOptions()),
                               ("from home, 8 restarts", [None] * n, IKOptions(restarts=8))):
        t0 = time.perf_counter()
        results = [inverse(arm, pos[i], rot[i], seed=seeds[i], options=opts) for i in range(n)]
        dt = (time.perf_counter() - t0) / n
        rate = np.mean([r.success for r in results])
        its = np.mean([r.iterations for r in results])
        print(f"  {arm.name:5s} IK {label:22s} {dt * 1e3:7.2f} ms/pose  success {rate:4.0%}  "
              f"{its:5.1f} iterations")


def _path(x0, z0, n=8):
    pos = np.zeros((n, 2, 3))
    rots = []
    down = Rotation.from_rotvec([np.pi, 0, 0])
    for k, t in enumerate(np.linspace(0.0, 1.0, n)):
        half = 0.2 - 0.05 * t
        pos[k, 0] = [x0 + 0.05 * t, half, z0 + 0.1 * t]
        pos[k, 1] = [x0 + 0.05 * t, -half, z0 + 0.1 * t]
        rots += [Rotation.from_rotvec([0, 0, 0.3 * t]) * down,
                 Rotation.from_rotvec([0, 0, -0.3 * t]) * down]
    return pos, Rotation.from_quat([r.as_quat() for r in rots])


def main() -> None:
    where = {"ur5e_pair": (0.45, 0.1), "panda_pair": (0.45, 0.1), "yumi": (0.38, 0.05)}
    for name, make in PRESETS.items():
        t0 = time.perf_counter()
        cell = make()
        print(f"{name}: built in {time.perf_counter() - t0:.2f} s "
              f"({cell.left.n_joints} joints per arm)")
        _ik(cell.left)
        pos, rot = _path(*where[name])
        t0 = time.perf_counter()
        verdict = check_path(cell, pos, rot, options=ReachOptions.cell_program())
        t1 = time.perf_counter()
        offset, placed = search_cell_placement(cell, pos, rot)
        t2 = time.perf_counter()
        print(f"  verification of an 8-pose path  {t1 - t0:6.2f} s  "
              f"({len(verdict.motion_times)} sub-steps): {verdict.message[:90]}")
        print(f"  placement search (15 candidates) {t2 - t1:6.2f} s  offset "
              f"{np.round(offset, 2).tolist()}: {placed.message[:70]}")
    _program_stage()


def _program_stage() -> None:
    """The pipeline's program stage on each example of ``examples/cells``: the plan made once,
    then the program (placement search, verification) and reading it back from plan.json
    (the cell rebuilt from its record, verified again and compared)."""
    import tempfile
    from pathlib import Path

    from dloplan.app import load_scenario, read_plan, run_job, write_outputs
    from dloplan.pipeline.stages import plan_program, program_of

    for example in sorted((Path(__file__).parents[1] / "examples" / "cells").glob("*.yaml")):
        job = load_scenario(example)
        doc = run_job(job, check_robot=False)
        t0 = time.perf_counter()
        program = plan_program(job.robot, doc.grippers, doc.trajectory)
        t1 = time.perf_counter()
        with tempfile.TemporaryDirectory() as folder:
            from dloplan.pipeline.stages import with_program

            write_outputs(with_program(doc, program), folder, ("json",))
            back = read_plan(Path(folder) / "plan.json")
            t2 = time.perf_counter()
            program_of(back)
            t3 = time.perf_counter()
        print(f"{example.stem}: program stage {t1 - t0:5.2f} s ({len(program.times)} targets, "
              f"ok {program.ok}); read back and re-verified {t3 - t2:5.2f} s")


if __name__ == "__main__":
    main()
