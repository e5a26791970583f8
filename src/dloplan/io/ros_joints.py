"""ROS 2 joint trajectories: one ``trajectory_msgs/msg/JointTrajectory`` per arm, as YAML.

Each arm gets ``<stem>_<arm>_joint_trajectory.yaml``, the message in the YAML form that
``ros2 topic pub`` and ``ros2 action send_goal`` read::

    header: {frame_id: ''}
    joint_names: [shoulder_pan_joint, ...]
    points:
    - positions: [...]          # the verified IK solution [rad]
      velocities: [...]         # [rad/s], see below
      time_from_start: {sec: 0, nanosec: 0}

The positions are the verified joint values, written with full float precision (``repr``),
so they read back exactly. Velocities (optional) are those of the cubic Hermite spline through
the points with zero velocity at both ends and the Catmull-Rom (central difference) velocity at
every interior point; a ROS 2 ``joint_trajectory_controller`` interpolates positions and
velocities with that cubic spline, so the arm passes every verified point at its time. Both
files start at time 0: send both goals together (one ``FollowJointTrajectory`` goal per arm
controller, the file's content under the goal's ``trajectory:`` key) or use a controller for
both arms with the joint names concatenated. The user sets up: the controller names, joint
name prefixes (``joint_prefix``) matching the robot's description, and the start (each arm must
stand at the first point, within the controller's goal tolerance).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml


def hermite_velocities(times, positions) -> np.ndarray:
    """Catmull-Rom velocities: central differences inside, zero at both ends.

    Parameters
    ----------
    times : array_like
        (M,) increasing [s].
    positions : array_like
        (M, n) [rad].

    Returns
    -------
    numpy.ndarray
        (M, n) [rad/s].
    """
    t = np.asarray(times, dtype=float)
    q = np.asarray(positions, dtype=float)
    vel = np.zeros_like(q)
    if len(t) > 2:
        vel[1:-1] = (q[2:] - q[:-2]) / (t[2:] - t[:-2])[:, None]
    return vel


def _stamp(seconds: float) -> dict:
    nanoseconds = int(round(seconds * 1e9))
    return {"sec": nanoseconds // 1_000_000_000, "nanosec": nanoseconds % 1_000_000_000}


def write_joint_trajectories(folder, times, joints, joint_names, *, arms=("left", "right"),
                             joint_prefix=None, velocities: bool = True,
                             stem: str = "dloplan", notes=()) -> list[Path]:
    """Write one JointTrajectory YAML file per arm (module docstring).

    Parameters
    ----------
    folder : str or pathlib.Path
        Output folder (created).
    times : array_like
        (M,) time from start [s] of each point, increasing, from 0 or later.
    joints : sequence of array_like
        Per arm (M, n_arm) the verified joint values [rad].
    joint_names : sequence of sequence of str
        Per arm the n_arm joint names of the description.
    arms : sequence of str
        Arm names (file names).
    joint_prefix : sequence of str, optional
        Per arm a prefix put before every joint name (e.g. ``"left_"``); default none.
    velocities : bool
        Write the spline velocities (:func:`hermite_velocities`).
    stem : str
        File name stem.
    notes : sequence of str
        Lines of text written as comments into each file's header (where the job must be
        placed on the table when a repair moved it, docs/repair.md).

    Returns
    -------
    list of pathlib.Path
    """
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or len(t) < 1 or not np.all(np.isfinite(t)) or t[0] < 0 or np.any(
            np.diff(t) <= 0):
        raise ValueError(f"times: expected increasing finite times >= 0 [s], got {times!r}")
    if len(joints) != len(arms) or len(joint_names) != len(arms):
        raise ValueError(f"joints, joint_names: expected one per arm of {tuple(arms)}, got "
                         f"{len(joints)} and {len(joint_names)}")
    prefixes = [""] * len(arms) if joint_prefix is None else list(joint_prefix)
    if len(prefixes) != len(arms):
        raise ValueError(f"joint_prefix: expected one per arm, got {joint_prefix!r}")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for a, arm in enumerate(arms):
        names = [f"{prefixes[a]}{name}" for name in joint_names[a]]
        q = np.asarray(joints[a], dtype=float)
        if q.shape != (len(t), len(names)) or not np.all(np.isfinite(q)):
            raise ValueError(f"joints[{a}]: expected finite values of shape "
                             f"{(len(t), len(names))} [rad], got {q.shape}")
        vel = hermite_velocities(t, q)
        points = []
        for k in range(len(t)):
            point = {"positions": [float(v) for v in q[k]]}
            if velocities:
                point["velocities"] = [float(v) for v in vel[k]]
            point["time_from_start"] = _stamp(t[k])
            points.append(point)
        message = {"header": {"frame_id": ""}, "joint_names": names, "points": points}
        path = folder / f"{stem}_{arm}_joint_trajectory.yaml"
        header = (f"# trajectory_msgs/msg/JointTrajectory of the {arm} arm: {len(t)} points, "
                  f"verified joint values [rad]. Setup: docs/cells.md.\n"
                  + "".join(f"# {note}\n" for note in notes))
        path.write_text(header + yaml.safe_dump(message, sort_keys=False), encoding="utf-8")
        written.append(path)
    return written
