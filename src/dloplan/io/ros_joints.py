"""ROS 2 joint trajectories: one ``trajectory_msgs/msg/JointTrajectory`` per arm, as YAML, and
the gripper actions beside them.

Each arm gets ``<stem>_<arm>_joint_trajectory.yaml``, the message in the YAML form that
``ros2 topic pub`` and ``ros2 action send_goal`` read::

    header: {frame_id: ''}
    joint_names: [shoulder_pan_joint, ...]
    points:
    - positions: [...]          # [rad]
      velocities: [...]         # [rad/s]
      accelerations: [...]      # [rad/s^2]
      time_from_start: {sec: 0, nanosec: 0}

The points sample the verified program along the plan's time law
(:class:`dloplan.robot.actions.ProgramTimeline`) at ``rate`` [Hz] and at every target's arrival
and leave instant: positions, velocities and accelerations are those of one twice
differentiable joint motion (:mod:`dloplan.robot.motion`), so a ``joint_trajectory_controller``
(quintic interpolation between points that carry all three) follows the planned time law and
passes every verified target at its time. The arms stand still while the planned gripper
actions run: the trajectory holds the target for the action's duration.

The gripper actions are ``<stem>_gripper_actions.yaml``, one row per command and arm in the
order they run, on the trajectories' clock::

    actions:
    - {time: 0.0, arm: left, action: grasp, command: close, duration: 0.5, knot: 0}
    - {time: 0.0, arm: right, action: grasp, command: close, duration: 0.5, knot: 0}
    - ...

(``command`` what the gripper does, ``duration`` [s] the arms stand after it, ``knot`` the
plan's knot). Both trajectories start at time 0: send both goals together (one
``FollowJointTrajectory`` goal per arm controller, the file's content under the goal's
``trajectory:`` key) and give each gripper command at its time (a gripper action server, e.g.
``control_msgs/action/GripperCommand``). The user sets up: the controller names, joint name
prefixes (``joint_prefix``) matching the robot's description, the gripper's driver, and the
start (each arm must stand at the first point, within the controller's goal tolerance).
Numbers are written with full float precision (``repr``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import yaml

from ..output_files import atomic_write_texts

DEFAULT_RATE = 100.0
"""[Hz] Points per second of the written trajectories (besides the targets' instants)."""



def _float(value: float) -> str:
    """A YAML float with full precision (``repr``; an exponent without a dot gets one, as
    PyYAML writes it, so YAML 1.1 readers take it for a float)."""
    text = repr(float(value))
    return text.replace("e", ".0e") if "e" in text and "." not in text else text


def _floats(values) -> str:
    return "[" + ", ".join(_float(v) for v in values) + "]"


def _message(names, times, fields) -> str:
    """The JointTrajectory message as YAML text (what ``yaml.safe_dump`` writes, in flow
    style per list; written directly: PyYAML's representer took seconds for a few hundred
    points)."""
    lines = ["header:", "  frame_id: ''", "joint_names:",
             *(f"- {json.dumps(name)}" for name in names), "points:"]
    for k, t in enumerate(times):
        stamp = _stamp(t)
        first = True
        for key, values in fields.items():
            lines.append(f"{'- ' if first else '  '}{key}: {_floats(values[k])}")
            first = False
        lines.append(f"  time_from_start: {{sec: {stamp['sec']}, nanosec: {stamp['nanosec']}}}")
    return "\n".join(lines) + "\n"


def _stamp(seconds: float) -> dict:
    nanoseconds = int(round(seconds * 1e9))
    return {"sec": nanoseconds // 1_000_000_000, "nanosec": nanoseconds % 1_000_000_000}


def write_joint_trajectories(folder, timeline, joint_names, *, arms=("left", "right"),
                             joint_prefix=None, velocities: bool = True,
                             rate: float = DEFAULT_RATE, stem: str = "dloplan",
                             notes=()) -> list[Path]:
    """Write one JointTrajectory YAML file per arm and the gripper action list (module
    docstring).

    Parameters
    ----------
    folder : str or pathlib.Path
        Output folder (created).
    timeline : ProgramTimeline
        The verified program's motion with the plan's gripper actions
        (:func:`dloplan.robot.actions.program_timeline`).
    joint_names : sequence of sequence of str
        Per arm the joint names of the description.
    arms : sequence of str
        Arm names (file names).
    joint_prefix : sequence of str, optional
        Per arm a prefix put before every joint name (e.g. ``"left_"``); default none.
    velocities : bool
        Write the velocities and accelerations (else positions only).
    rate : float
        [Hz] Points per second.
    stem : str
        File name stem.
    notes : sequence of str
        Lines of text written as comments into each file's header (where the job must be
        placed on the table when a repair moved it, docs/repair.md).

    Returns
    -------
    list of pathlib.Path
        The trajectories in the order of ``arms``, then the action list.
    """
    if len(joint_names) != len(arms):
        raise ValueError(f"joint_names: expected one list per arm of {tuple(arms)}, got "
                         f"{len(joint_names)}")
    prefixes = [""] * len(arms) if joint_prefix is None else list(joint_prefix)
    if len(prefixes) != len(arms):
        raise ValueError(f"joint_prefix: expected one per arm, got {joint_prefix!r}")
    times, values = timeline.samples(rate, order=2)
    for a, value in enumerate(values):
        if value.shape[2] != len(joint_names[a]) or not np.all(np.isfinite(value)):
            raise ValueError(f"joint_names[{a}]: {len(joint_names[a])} names for an arm of "
                             f"{value.shape[2]} joints (or joints not finite)")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    comments = "".join(f"# {note}\n" for note in notes)
    texts = {}
    for a, arm in enumerate(arms):
        names = [f"{prefixes[a]}{name}" for name in joint_names[a]]
        q, qd, qdd = values[a]
        fields = {"positions": q, "velocities": qd, "accelerations": qdd} if velocities \
            else {"positions": q}
        path = folder / f"{stem}_{arm}_joint_trajectory.yaml"
        header = (f"# trajectory_msgs/msg/JointTrajectory of the {arm} arm: {len(times)} points "
                  f"at {rate:g} Hz along the planned time law [rad, rad/s, rad/s^2]; gripper "
                  f"actions in {stem}_gripper_actions.yaml. Setup: docs/cells.md.\n" + comments)
        texts[path] = header + _message(names, times, fields)
    rows = [{"time": float(c.time), "arm": arm, "action": c.action, "command": c.command,
             "duration": float(c.wait), "knot": int(c.knot)}
            for c in timeline.commands for arm in arms]
    path = folder / f"{stem}_gripper_actions.yaml"
    header = ("# The plan's gripper actions beside the joint trajectories: each command given "
              "at `time` [s] on their clock,\n# the arms standing for `duration` [s] after "
              "it. Setup: docs/cells.md.\n" + comments)
    texts[path] = header + yaml.safe_dump({"actions": rows}, sort_keys=False)
    return atomic_write_texts(texts)
