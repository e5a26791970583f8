"""Real motion: cycle times and replay deviations, velocity-only against jerk-limited timing.

Run: PYTHONPATH=src python benchmarks/bench_motion.py [JOB ...]   (demo usb ethernet pu; default
all; a stiff hose's replay takes minutes: its explicit time step is short)

For the embedded demo (src/dloplan/data/demo.yaml) and the three harness jobs
(examples/harness_*.yaml), prints the motion time, the gripper action time and the cycle time,
and the dynamic replay's largest deviation from the planned shapes at the knots and along the
segments, with its peak tension during the motion, for

* **before**: the velocity-only timing (each segment at constant speed, the clips jumping to
  100 mm/s at every knot; no gripper actions, as the old cycle time);
* **after**: the jerk-limited time law (YuMi defaults: 0.1 m/s, 1 m/s^2, 10 m/s^3, 1 rad/s,
  10 rad/s^2, 100 rad/s^3; fine points), with grasp and release (and the harness' regrasp);
* **fly-by**: the same with 1 cm zones where the cable need not settle.

A harness job's replay covers phases 1 and 2 (free motion in the air: the simulator has no
pegs or plates, so insertion and tensioning are not replayed). Also the wall time of the time
parameterization (ruckig) per trajectory.

Numbers of the first run (2 cores shared with other jobs; the time law's wall time is noisy,
the first call includes imports):

    job        timing     motion  actions    cycle   knot dev segment dev   peak T   time law
    demo       before      2.02s    0.00s    2.02s     1.71mm      1.85mm   0.319N     41.4ms
    demo       after       3.42s    0.90s    4.32s     3.12mm      3.19mm   0.304N      1.5ms
    demo       fly-by      2.66s    0.90s    3.56s     2.35mm      2.61mm   0.304N    285.4ms
    usb        before      4.68s    0.00s    4.68s     0.52mm      2.82mm   0.185N      0.9ms
    usb        after       7.10s    1.80s    8.90s     3.95mm      4.65mm   0.170N      1.7ms
    usb        fly-by      6.11s    1.80s    7.91s     2.63mm      3.19mm   0.168N    353.5ms
    ethernet   before      4.55s    0.00s    4.55s     1.23mm      1.72mm   0.324N      1.2ms
    ethernet   after       6.97s    1.80s    8.77s     2.06mm      2.23mm   0.298N      7.6ms
    ethernet   fly-by      5.98s    1.80s    7.78s     1.88mm      1.91mm   0.297N    157.7ms
    pu         before      4.44s    0.00s    4.44s     0.37mm      5.41mm   0.331N      8.4ms
    pu         after       6.87s    1.80s    8.67s     0.20mm      5.39mm   0.316N      2.6ms
    pu         fly-by      5.88s    1.80s    7.68s     0.65mm      5.36mm   0.316N    372.7ms

The real time law adds 0.2 s per stop (v / a + a / j) and the gripper actions 0.9 s (plan) or
1.8 s (harness, with the regrasp). Stopping at every shape makes the soft cables swing: the
replay deviates more at the knots than with the velocity-only timing (demo 1.7 -> 3.1 mm, USB
0.5 -> 4.0 mm), and 1 cm fly-by zones recover part of it and of the time. The stiff PU hose
hardly swings; its segment deviation (5.4 mm either way) is the plan's own interpolation
between shapes (verify/replay.py). A PU replay takes minutes (its explicit time step is short).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from dloplan.app import load_job, run_job
from dloplan.harness import run_harness
from dloplan.trajectory import GripperAction, dual_arm_trajectory, plan_cycle
from dloplan.verify.replay import replay

ROOT = Path(__file__).parent.parent
EXAMPLES = ROOT / "examples"
DEMO = ROOT / "src" / "dloplan" / "data" / "demo.yaml"


def _timings(traj, stops):
    """(label, trajectory, wall time of the timing) for the three timings of the same knots."""
    out = []
    for label, options in (("before", {"law": "constant-speed"}), ("after", {}),
                           ("fly-by", {"zone": 0.01})):
        t0 = time.perf_counter()
        timed = dual_arm_trajectory(traj.positions, traj.rotations, arm_clips=traj.arm_clips,
                                    stops=stops if label == "fly-by" else (), **options)
        out.append((label, timed, time.perf_counter() - t0))
    return out


def _row(job: str, label: str, timed, actions, cable, shapes, poses, wall: float) -> None:
    if label == "before":
        motion, extra = timed.duration, 0.0
        run = replay(cable, shapes, (timed.times[: len(poses)], poses))
    else:
        cycle = plan_cycle(timed, actions)
        motion, extra = cycle.motion_time, cycle.action_time
        sub = dual_arm_trajectory(timed.positions[: len(poses)],
                                  tuple(r[: len(poses)] for r in timed.rotations),
                                  zone=float(timed.zones.max()),
                                  stops=np.flatnonzero(timed.zones[: len(poses)] == 0)[1:-1])
        run = replay(cable, shapes, poses, law=sub.law)
    print(f"{job:10s} {label:8s} {motion:7.2f}s {extra:7.2f}s {motion + extra:7.2f}s "
          f"{1e3 * run.max_deviation:8.2f}mm {1e3 * run.segment_deviations.max():9.2f}mm "
          f"{run.motion_peak_tension:7.3f}N {1e3 * wall:8.1f}ms")


def main(jobs=("demo", "usb", "ethernet", "pu")) -> None:
    print(f"{'job':10s} {'timing':8s} {'motion':>8s} {'actions':>8s} {'cycle':>8s} "
          f"{'knot dev':>10s} {'segment dev':>11s} {'peak T':>8s} {'time law':>10s}")
    if "demo" in jobs:
        job = load_job(DEMO)
        doc = run_job(job, check_robot=False)
        traj = doc.trajectory
        poses = [doc.grippers.clip_poses(k) for k in range(traj.n_knots)]
        for label, timed, wall in _timings(traj, ()):
            _row("demo", label, timed, None, job.cable, doc.stabilized, poses, wall)
    for name in [j for j in jobs if j != "demo"]:
        job = load_job(EXAMPLES / f"harness_{name}.yaml")
        result = run_harness(job.cable, job.start, job.board, job.settings)
        k1, k2 = result.knots["phase1"][1], result.knots["insertion"][0]
        shapes = np.concatenate([result.phases.avoidance.stabilized,
                                 result.phases.plan2.stabilized[1:]])
        poses = [result.grippers.clip_poses(k) for k in range(k2 + 1)]
        gripper = [GripperAction(p.name, p.knots[0], p.duration) for p in result.cycle.phases
                   if p.kind == "action"]
        for label, timed, wall in _timings(result.trajectory, (k1, k2, k2 + 1)):
            _row(name, label, timed, gripper, result.cable, shapes, poses, wall)


if __name__ == "__main__":
    main(tuple(sys.argv[1:]) or ("demo", "usb", "ethernet", "pu"))
