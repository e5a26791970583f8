#!/usr/bin/env python3
"""Stream a dloplan plan to two Universal Robots arms over RTDE, both in lockstep.

This file is the program dloplan writes for a cell of two UR arms (``dloplan.io.ur_rtde``
copies it, with the settings block below filled in, beside the joint samples it streams). It
runs on a PC connected to both controllers and needs only Python 3.10 or later and the
``ur_rtde`` library (``pip install ur-rtde``); it imports nothing from dloplan.

Every control period (``RATE``) it sends both arms the joints of the same instant of the plan
(``servoJ``), so the arms cannot drift apart: both follow one clock, the PC's. Before each
period it reads both controllers' state; when either is not running as expected (protective
or emergency stop, safety mode not normal, robot not running, its control script stopped,
speed scaling below 100 %, or its joints farther than ``TRACKING_TOLERANCE`` from what was
commanded ``LAG`` earlier) it stops both arms at once (``servoStop``), leaves the grippers as
they are (the cable stays held) and exits with status 1 naming the arm and the reason. The
planned gripper actions (``ACTIONS``) are given at their instants through each arm's digital
output (``GRIPPER``) while the samples hold the arms still.

Usage::

    python3 <this file> --left HOST --right HOST     (hosts default to the settings)
    python3 <this file> --dry-run                    (check the samples, connect to nothing)

Exit status: 0 done, 1 stopped on a fault (both arms stopped), 2 not started (bad samples,
no hosts, an arm not at the start or not ready). Setup: dloplan's docs/cells.md.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

# --- settings (written by dloplan) ---
SAMPLES = "dloplan_ur_pair.csv"
RATE = 500.0
HOSTS = {"left": "", "right": ""}
LOOKAHEAD = 0.1
GAIN = 300.0
START_SPEED = 0.5
START_TOLERANCE = 0.01
TRACKING_TOLERANCE = 0.05
STOP_DECELERATION = 10.0
WATCHDOG = 10.0
GRIPPER = {"output": 1, "tool": False, "closed": True}
OPEN_FIRST = True
ACTIONS: list = []
# --- end of settings ---

ARMS = ("left", "right")
ROBOT_MODE_RUNNING = 7
SAFETY_MODE_NORMAL = 1
LAG = max(1, round(LOOKAHEAD * RATE))
"""Periods the servo lags the commanded joints (its lookahead)."""


class Fault(Exception):
    """An arm is not in the state the motion needs."""


def load_samples(path) -> list[tuple[float, list[float], list[float]]]:
    """The (time [s], left joints [rad], right joints [rad]) rows of the samples file, checked:
    a header ``t, left_q1..6, right_q1..6`` and one row per period from time 0."""
    with open(path, newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(line for line in handle if not line.startswith("#")))
    expected = ["t"] + [f"{arm}_q{j}" for arm in ARMS for j in range(1, 7)]
    if not rows or rows[0] != expected:
        raise ValueError(f"{path}: expected the header {','.join(expected)}")
    samples = []
    for k, row in enumerate(rows[1:]):
        values = [float(v) for v in row]
        if len(values) != 13 or abs(values[0] - k / RATE) > 1e-6:
            raise ValueError(f"{path}: row {k + 1}: expected time {k / RATE:.6f} s and 12 "
                             "joints")
        samples.append((values[0], values[1:7], values[7:]))
    if len(samples) < 2:
        raise ValueError(f"{path}: fewer than two samples")
    return samples


class Arm:
    """One arm's RTDE interfaces: ``control`` (RTDEControlInterface), ``receive``
    (RTDEReceiveInterface) and ``io`` (RTDEIOInterface)."""

    def __init__(self, name: str, control, receive, io):
        self.name, self.control, self.receive, self.io = name, control, receive, io

    def check(self, commanded=None) -> None:
        """Raise :class:`Fault` naming what is wrong with the arm, if anything; ``commanded``:
        the joints it should have reached by now."""
        r = self.receive
        if r.isEmergencyStopped():
            raise Fault(f"{self.name} arm: emergency stop")
        if r.isProtectiveStopped():
            raise Fault(f"{self.name} arm: protective stop")
        if r.getSafetyMode() != SAFETY_MODE_NORMAL:
            raise Fault(f"{self.name} arm: safety mode {r.getSafetyMode()}, not normal")
        if r.getRobotMode() != ROBOT_MODE_RUNNING:
            raise Fault(f"{self.name} arm: robot mode {r.getRobotMode()}, not running")
        if not self.control.isProgramRunning():
            raise Fault(f"{self.name} arm: its RTDE control script is not running")
        scaling = r.getSpeedScalingCombined()
        if scaling < 0.99:
            raise Fault(f"{self.name} arm: speed scaling {100 * scaling:.0f} % (the plan's "
                        "timing needs 100 %)")
        if commanded is not None:
            error = max(abs(a - b) for a, b in zip(r.getActualQ(), commanded, strict=True))
            if error > TRACKING_TOLERANCE:
                raise Fault(f"{self.name} arm: {error:.3f} rad from the commanded joints "
                            f"(tolerance {TRACKING_TOLERANCE} rad)")

    def grip(self, command: str) -> None:
        """Open or close the gripper through the digital output (``GRIPPER``)."""
        level = GRIPPER["closed"] if command == "close" else not GRIPPER["closed"]
        if GRIPPER["tool"]:
            self.io.setToolDigitalOut(GRIPPER["output"], level)
        else:
            self.io.setStandardDigitalOut(GRIPPER["output"], level)

    def stop(self) -> None:
        """Decelerate to standstill (servo mode ends); errors ignored: it is stopping."""
        try:
            self.control.servoStop(STOP_DECELERATION)
        except Exception:  # noqa: BLE001 - the arm may already be stopped or unreachable
            pass


def move_to_start(arms, samples) -> None:
    """When the program picks the cable up (``OPEN_FIRST``: its first action is a grasp), open
    both grippers and move each arm (one after the other: nothing is held yet) to the first
    sample; otherwise the arms hold the cable already and must stand there: nothing moves.
    Then check each arm is at the start and ready."""
    for arm in arms:
        arm.check()
    for a, arm in enumerate(arms):
        start = samples[0][1 + a]
        if OPEN_FIRST:
            arm.grip("open")
            arm.control.moveJ(start, START_SPEED, 1.0, False)
        error = max(abs(x - y) for x, y in zip(arm.receive.getActualQ(), start, strict=True))
        if error > START_TOLERANCE:
            raise Fault(f"{arm.name} arm: {error:.4f} rad from the start joints "
                        f"(tolerance {START_TOLERANCE} rad)")


def stream(arms, samples, actions=ACTIONS) -> None:
    """Send both arms every sample at ``RATE`` in lockstep, the gripper commands at their
    instants; on a fault of either arm stop both and raise it."""
    dt = 1.0 / RATE
    pending = sorted(actions)
    for arm in arms:
        arm.control.setWatchdog(WATCHDOG)
    try:
        for k, (t, *joints) in enumerate(samples):
            start = arms[0].control.initPeriod()
            for a, arm in enumerate(arms):
                arm.check(samples[k - LAG][1 + a] if k >= LAG else None)
            while pending and pending[0][0] <= t + 1e-9:
                _, command, _, _ = pending.pop(0)
                for arm in arms:
                    arm.grip(command)
            for arm, q in zip(arms, joints, strict=True):
                arm.control.servoJ(q, 0.0, 0.0, dt, LOOKAHEAD, GAIN)
                arm.control.kickWatchdog()
            arms[0].control.waitPeriod(start)
    except Fault:
        for arm in arms:
            arm.stop()
        raise
    for arm in arms:
        arm.stop()


def connect(hosts) -> list[Arm]:
    """Both arms' RTDE interfaces (the ``ur_rtde`` library, imported here)."""
    import rtde_control
    import rtde_io
    import rtde_receive

    return [Arm(name, rtde_control.RTDEControlInterface(hosts[name], RATE),
                rtde_receive.RTDEReceiveInterface(hosts[name], RATE),
                rtde_io.RTDEIOInterface(hosts[name])) for name in ARMS]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--left", default=HOSTS["left"], help="left arm's controller address")
    parser.add_argument("--right", default=HOSTS["right"],
                        help="right arm's controller address")
    parser.add_argument("--dry-run", action="store_true",
                        help="check the samples and connect to nothing")
    args = parser.parse_args(argv)
    try:
        samples = load_samples(Path(__file__).with_name(SAMPLES))
    except (OSError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    duration = samples[-1][0]
    print(f"{len(samples)} samples at {RATE:g} Hz ({duration:.3f} s), {len(ACTIONS)} gripper "
          "commands")
    if args.dry_run:
        return 0
    if not args.left or not args.right:
        print("error: --left and --right: the controllers' addresses are needed",
              file=sys.stderr)
        return 2
    arms = connect({"left": args.left, "right": args.right})
    try:
        move_to_start(arms, samples)
    except Fault as exc:
        print(f"error: not started: {exc}", file=sys.stderr)
        return 2
    try:
        stream(arms, samples)
    except Fault as exc:
        print(f"error: both arms stopped: {exc}", file=sys.stderr)
        return 1
    print("done")
    return 0


if __name__ == "__main__":
    sys.exit(main())
