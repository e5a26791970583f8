"""Writing the robot programs of a plan with its gripper actions: time per format, size, and how
closely the time-law samples follow the planned TCP path.

For the UR5e example (examples/cells/ur5e_pair_usb.yaml) and the M2 USB YuMi example: the plan
and its verified program are made once; then each program format the cell takes is written
(its timeline sampled: the RTDE streamer at 500 Hz, ROS 2 at 100 Hz) and timed; for the UR5e,
the largest distance between the TCP of the streamed joints (FK) and the planned TCP at the
same instant.

Run: PYTHONPATH=src:tests python benchmarks/bench_programs.py

Numbers of 2026-12-02 on the 2 cores shared with six other sessions (load average ~15, so
times are several times an idle machine's):
  ur5e_pair_usb   ur_rtde 407 ms (2 files, 276 kB: 1621 rows at 500 Hz), urscript 120 ms,
                  ros_joints 391 ms (276 kB); streamed TCP vs planned TCP: largest 0.295 mm
  m2 USB (YuMi)   rapid 104 ms, ros_joints 1.8 s (526 kB; in a profile 0.86 s of it the
                  timeline: the joint motion and its action clock)
Before the ROS 2 YAML was written as text, PyYAML's representer took 1.8 s (UR5e) and 4.2 s
(M2 USB) of the ros_joints times.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
from robot_plans import example_plan

from dloplan.app.writers import program_files
from dloplan.pipeline.stages import default_cycle, plan_program


def main() -> None:
    for name in ("cells/ur5e_pair_usb.yaml", "m2_uniform_curvature_usb.yaml"):
        t0 = time.perf_counter()
        _, grippers, trajectory, job = example_plan(name)
        program = plan_program(job.robot, grippers, trajectory)
        made = time.perf_counter() - t0
        actions = default_cycle(trajectory, {"grasp": job.motion.grasp_time,
                                             "release": job.motion.release_time}).actions
        print(f"{name}: plan and program {made:.1f} s, {program.message[:60]}")
        with tempfile.TemporaryDirectory() as folder:
            for fmt in program.formats:
                t0 = time.perf_counter()
                files = program_files(program, Path(folder) / fmt, fmt, trajectory, actions)
                size = sum(f.stat().st_size for f in files)
                print(f"  {fmt:10s} {1e3 * (time.perf_counter() - t0):7.1f} ms, "
                      f"{len(files)} files, {size / 1e3:7.1f} kB")
        if name.startswith("cells"):
            from dloplan.robot.kinematics import forward

            motion = program.joint_motion(trajectory)
            t = np.arange(0.0, motion.duration, 1 / 500)
            joints = motion.sample(t, 0)
            planned = trajectory.law.blend(trajectory.positions, t)[0]
            columns = [1, 0] if program.targets.plan.swapped else [0, 1]
            worst = max(float(np.linalg.norm(forward(arm, joints[a][0])[0]
                                             - planned[:, columns[a]] - program.targets.plan.offset,
                                             axis=1).max())
                        for a, arm in enumerate(program.cell.arms))
            print(f"  streamed TCP vs planned TCP (500 Hz): largest {1e3 * worst:.3f} mm")


if __name__ == "__main__":
    main()
