"""Trajectory exports: the ROS 2 ``MultiDOFJointTrajectory`` message and the sampled CSV.

* :func:`write_ros_trajectory`: the trajectory as a ``trajectory_msgs/MultiDOFJointTrajectory``
  message (YAML or JSON) with two "joints" ``left_tcp`` and ``right_tcp``.
* :func:`write_trajectory_csv`: the trajectory sampled at a rate, one row per sample.

Both are written atomically (:mod:`dloplan.output_files`). The plan document itself (its versioned
JSON schema) is owned by :mod:`dloplan.pipeline.document`, the RAPID program by
:mod:`dloplan.io.rapid`.
See ``docs/grippers-and-exports.md`` for the formats with examples.
"""

from __future__ import annotations

import io
import json
import os
from pathlib import Path

import numpy as np
import yaml

from ..output_files import atomic_write_text
from ..trajectory import ARMS, Trajectory
from .poses import (
    DEFAULT_FRAME_ID,
    canonical_quaternions,
    check_frame_id,
    duration_dict,
    transform_dict,
)

DEFAULT_CSV_RATE = 100.0
"""Default sampling rate [Hz] of the CSV export."""


def _trajectory_points(trajectory: Trajectory, rate: float | None):
    if rate is None:
        return trajectory.times, trajectory.positions, trajectory.rotations
    samples = trajectory.sample(rate)
    return samples.times, samples.positions, samples.rotations


def multi_dof_trajectory_msg(
    trajectory: Trajectory, *, rate: float | None = None, frame_id: str = DEFAULT_FRAME_ID
) -> dict:
    """The trajectory as a ``trajectory_msgs/MultiDOFJointTrajectory``-shaped dict.

    Parameters
    ----------
    trajectory : Trajectory
    rate : float, optional
        Sampling rate [Hz]; None writes the knots only (one point per planned shape), which a
        controller interpolating linearly between points reproduces exactly in position.
    frame_id : str
        ``header.frame_id``.

    Notes
    -----
    Joint names are ``left_tcp`` and ``right_tcp``; each point has one
    ``geometry_msgs/Transform`` per joint (translation [m], rotation x-y-z-w, w >= 0), empty
    velocities and accelerations (the segment velocities are piecewise constant and jump at
    the knots), and ``time_from_start`` as ``builtin_interfaces/Duration``. The points'
    times increase strictly, as a trajectory controller requires: a knot at the time of the one
    before it (a segment where nothing moves, two equal planned shapes) is written once.
    """
    frame_id = check_frame_id(frame_id)
    times, positions, rotations = _trajectory_points(trajectory, rate)
    quats = [canonical_quaternions(r) for r in rotations]
    stamps = np.round(np.asarray(times, dtype=float) * 1e9)   # [ns], as the Duration holds them
    kept = np.flatnonzero(np.r_[True, np.diff(stamps) > 0])
    points = [
        {
            "transforms": [transform_dict(positions[i, a], quats[a][i]) for a in (0, 1)],
            "velocities": [],
            "accelerations": [],
            "time_from_start": duration_dict(times[i]),
        }
        for i in kept
    ]
    return {
        "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": frame_id},
        "joint_names": [f"{arm}_tcp" for arm in ARMS],
        "points": points,
    }


def write_ros_trajectory(
    path: str | os.PathLike,
    trajectory: Trajectory,
    *,
    rate: float | None = None,
    frame_id: str = DEFAULT_FRAME_ID,
    fmt: str | None = None,
    note: str | None = None,
) -> Path:
    """Write :func:`multi_dof_trajectory_msg` as YAML or JSON, atomically.

    Parameters
    ----------
    fmt : {"yaml", "json"}, optional
        Default: from the suffix (``.json`` -> JSON, otherwise YAML).
    note : str, optional
        A comment line put before the YAML message (JSON has no comments: not written).
    """
    fmt = fmt or ("json" if Path(path).suffix.lower() == ".json" else "yaml")
    if fmt not in ("yaml", "json"):
        raise ValueError(f"fmt: got {fmt!r}, expected 'yaml' or 'json'")
    msg = multi_dof_trajectory_msg(trajectory, rate=rate, frame_id=frame_id)
    if fmt == "json":
        text = json.dumps(msg, indent=1) + "\n"
    else:
        text = yaml.safe_dump(msg, sort_keys=False, default_flow_style=None, width=100)
        text = (f"# {note}\n" if note else "") + text
    return atomic_write_text(path, text)


# -- CSV -----------------------------------------------------------------------------------------
CSV_COLUMNS = ["time [s]"] + [
    f"{arm} {c}" for arm in ARMS for c in ("x [m]", "y [m]", "z [m]", "qx", "qy", "qz", "qw")
]


def trajectory_csv(
    trajectory: Trajectory, *, rate: float = DEFAULT_CSV_RATE, frame_id: str = DEFAULT_FRAME_ID,
    note: str | None = None,
) -> str:
    """The sampled trajectory as CSV text (one comment line, one header line, one row per sample).

    Columns: time [s]; per arm (left, right) x, y, z [m] and the unit quaternion qx, qy, qz,
    qw (x-y-z-w order, scalar last, sign canonical w >= 0) of ``tcp_to_world``. ``note``: a
    sentence appended to the comment line (where the robot programs run the job, when not
    here: :func:`dloplan.app.writers.trajectory_note`).
    """
    frame_id = check_frame_id(frame_id)
    samples = trajectory.sample(rate)
    quats = [canonical_quaternions(r) for r in samples.rotations]
    table = np.column_stack(
        [samples.times] + [np.column_stack([samples.positions[:, a], quats[a]]) for a in (0, 1)]
    )
    out = io.StringIO()
    out.write(
        f"# dloplan dual-arm TCP trajectory; frame {frame_id}; positions in m; quaternions "
        f"x-y-z-w (scalar last, w >= 0); sampled at {rate:g} Hz; "
        f"duration {trajectory.duration:.6g} s{'; ' + note if note else ''}\n"
    )
    out.write(",".join(CSV_COLUMNS) + "\n")
    np.savetxt(out, table, delimiter=",", fmt="%.12g")
    return out.getvalue()


def write_trajectory_csv(
    path: str | os.PathLike,
    trajectory: Trajectory,
    *,
    rate: float = DEFAULT_CSV_RATE,
    frame_id: str = DEFAULT_FRAME_ID,
    note: str | None = None,
) -> Path:
    """Write :func:`trajectory_csv` atomically to ``path``."""
    return atomic_write_text(path, trajectory_csv(trajectory, rate=rate, frame_id=frame_id,
                                                  note=note))
