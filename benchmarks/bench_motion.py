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

Numbers of the first run (2 shared cores; the best of two runs):

    job        timing      motion  actions   cycle   knot dev  segment dev  peak T    time law
    demo       before       ...
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from dloplan.harness import load_harness, run_harness_job
from dloplan.jobs import load_job, plan_job
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
        outcome = plan_job(load_job(DEMO)[0])
        traj = outcome.trajectory
        poses = [outcome.grippers.clip_poses(k) for k in range(traj.n_knots)]
        for label, timed, wall in _timings(traj, ()):
            _row("demo", label, timed, None, outcome.job.cable, outcome.plan.stabilized, poses,
                 wall)
    for name in [j for j in jobs if j != "demo"]:
        result = run_harness_job(load_harness(EXAMPLES / f"harness_{name}.yaml"))
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
