"""Timed dual-arm TCP trajectories through the planned gripper poses (thesis 4.6, 7.3).

The S + 2 pairs of TCP poses are joined by synchronized segments: in each segment both TCPs
move **linearly in position** and by **spherical-linear interpolation** (scipy's
:class:`~scipy.spatial.transform.Slerp`) in orientation, at constant speed, starting and ending
together. A segment lasts

    T_k = max over arms of max(|p_{k+1} - p_k| / v_max, angle(R_k^-1 R_{k+1}) / omega_max)

so the slower arm (or the larger rotation) sets it and neither arm exceeds the TCP speed limit
v_max [m/s] nor the angular speed limit omega_max [rad/s]. This is how ABB's synchronized
``MoveL ... \\ID`` behaves (the controller stretches the faster arm's move), without the
controller's acceleration ramps: the trajectory is the velocity-limited timing of the plan;
the robot controller adds its own acceleration limits (RAPID ``fine`` zones stop at every
planned shape, matching the quasi-static plan).

Defaults: v_max = 0.1 m/s (the thesis' 100 mm/s, section 7.3) and omega_max = 1 rad/s
(about 57 deg/s), the rate at which a point 0.1 m from the TCP, about a clip's lever on a
0.5 m cable, moves no faster than the TCP itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

DEFAULT_MAX_SPEED = 0.1
"""TCP speed limit [m/s] (thesis 7.3: 100 mm/s)."""

DEFAULT_MAX_ANGULAR_SPEED = 1.0
"""TCP angular speed limit [rad/s] (module docstring)."""

ARMS = ("left", "right")

ArmRotations = tuple[Rotation, Rotation]
"""``tcp_to_world`` rotations of the left and the right arm, one per knot each."""


def _positive(name: str, value) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: got {value!r}, expected a finite number > 0") from exc
    if not np.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name}: got {value!r}, expected a finite number > 0")
    return value


def _check_rotations(rotations, n: int, name: str) -> ArmRotations:
    rots = tuple(rotations) if isinstance(rotations, tuple | list) else None
    if (
        rots is None
        or len(rots) != 2
        or not all(isinstance(r, Rotation) and not r.single and len(r) == n for r in rots)
    ):
        raise ValueError(
            f"{name}: expected two scipy Rotations of {n} rotations each (one per arm)"
        )
    for arm, r in zip(ARMS, rots, strict=True):
        if not np.all(np.isfinite(r.as_quat())):
            raise ValueError(f"{name}: the {arm} arm has a non-finite quaternion (NaN or inf)")
    return rots  # type: ignore[return-value]


def _check_positions(positions, name: str) -> np.ndarray:
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 3 or pos.shape[1:] != (2, 3) or len(pos) < 1:
        raise ValueError(f"{name}: expected shape (n_knots, 2, 3), got {pos.shape}")
    if not np.all(np.isfinite(pos)):
        raise ValueError(f"{name}: non-finite coordinate (NaN or inf)")
    return pos


@dataclass(frozen=True, eq=False)
class TrajectorySamples:
    """A trajectory sampled in time.

    Parameters
    ----------
    times : numpy.ndarray
        (N,) sample times [s] from 0 to the duration, both included.
    positions : numpy.ndarray
        (N, 2, 3) TCP positions [m] of the left and right arm.
    rotations : tuple of Rotation
        ``tcp_to_world`` of the left and the right arm, N each.
    """

    times: np.ndarray
    positions: np.ndarray
    rotations: ArmRotations


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A timed, synchronized dual-arm TCP trajectory through knot poses.

    Parameters
    ----------
    times : numpy.ndarray
        (K,) knot times [s], t_0 = 0, non-decreasing (equal only across a segment where
        neither arm moves).
    positions : numpy.ndarray
        (K, 2, 3) TCP positions [m] at the knots, arms in the order left, right.
    rotations : tuple of Rotation
        ``tcp_to_world`` of the left and the right arm at the knots, K each.
    max_speed, max_angular_speed : float
        The limits the timing was made with [m/s], [rad/s].
    arm_clips : tuple of int
        Which clip each arm holds (0 first, 1 last), left then right.
    """

    times: np.ndarray
    positions: np.ndarray
    rotations: ArmRotations
    max_speed: float = DEFAULT_MAX_SPEED
    max_angular_speed: float = DEFAULT_MAX_ANGULAR_SPEED
    arm_clips: tuple[int, int] = (0, 1)

    def __post_init__(self) -> None:
        pos = _check_positions(self.positions, "positions")
        times = np.asarray(self.times, dtype=float)
        if times.shape != (len(pos),):
            raise ValueError(f"times: expected shape ({len(pos)},), got {times.shape}")
        if not np.all(np.isfinite(times)) or times[0] != 0.0 or np.any(np.diff(times) < 0):
            raise ValueError("times: expected finite, non-decreasing knot times starting at 0 [s]")
        rots = _check_rotations(self.rotations, len(pos), "rotations")
        if tuple(sorted(self.arm_clips)) != (0, 1):
            raise ValueError(f"arm_clips: got {self.arm_clips!r}, expected (0, 1) or (1, 0)")
        set_ = object.__setattr__
        set_(self, "times", times)
        set_(self, "positions", pos)
        set_(self, "rotations", rots)
        set_(self, "max_speed", _positive("max_speed", self.max_speed))
        set_(self, "max_angular_speed", _positive("max_angular_speed", self.max_angular_speed))
        set_(self, "arm_clips", tuple(int(c) for c in self.arm_clips))

    @property
    def duration(self) -> float:
        """Total duration [s]."""
        return float(self.times[-1])

    @property
    def n_knots(self) -> int:
        """Number of knots K (S + 2 for a planned path)."""
        return len(self.times)

    @property
    def segment_durations(self) -> np.ndarray:
        """(K - 1,) segment durations [s]."""
        return np.diff(self.times)

    def segment_distances(self) -> tuple[np.ndarray, np.ndarray]:
        """Per segment and arm: TCP travel [m] and rotation angle [rad], (K - 1, 2) each."""
        return _segment_motion(self.positions, self.rotations)

    def segment_speeds(self) -> tuple[np.ndarray, np.ndarray]:
        """Per segment and arm: constant TCP speed [m/s] and angular speed [rad/s], (K - 1, 2).

        Zero in a segment of zero duration (nothing moves there).
        """
        dist, angle = self.segment_distances()
        dt = self.segment_durations[:, None]
        safe = np.where(dt > 0, dt, 1.0)
        return np.where(dt > 0, dist / safe, 0.0), np.where(dt > 0, angle / safe, 0.0)

    def at(self, times) -> TrajectorySamples:
        """Poses of both TCPs at given times [s] (clipped to [0, duration])."""
        t = np.clip(np.atleast_1d(np.asarray(times, dtype=float)), 0.0, self.duration)
        if not np.all(np.isfinite(t)):
            raise ValueError("times: non-finite time (NaN or inf)")
        keep = np.r_[True, np.diff(self.times) > 0]
        knots = self.times[keep]
        positions = np.stack(
            [
                np.stack([np.interp(t, knots, self.positions[keep, arm, k]) for k in range(3)], -1)
                for arm in (0, 1)
            ],
            axis=1,
        )
        if len(knots) == 1:
            rotations = tuple(r[np.zeros(len(t), dtype=int)] for r in self.rotations)
        else:
            rotations = tuple(Slerp(knots, r[keep])(t) for r in self.rotations)
        return TrajectorySamples(t, positions, rotations)  # type: ignore[arg-type]

    def sample(self, rate: float) -> TrajectorySamples:
        """Sample at ``rate`` [Hz]: times 0, 1/rate, ... and the final time."""
        rate = _positive("rate", rate)
        steps = int(np.floor(self.duration * rate + 1e-9))
        times = np.arange(steps + 1) / rate
        if self.duration - times[-1] > 1e-12:
            times = np.r_[times, self.duration]
        return self.at(times)


def _segment_motion(positions: np.ndarray, rotations: ArmRotations):
    dist = np.linalg.norm(np.diff(positions, axis=0), axis=-1)
    angle = np.stack([(r[:-1].inv() * r[1:]).magnitude() for r in rotations], axis=1)
    return dist, angle


def dual_arm_trajectory(
    positions,
    rotations,
    *,
    max_speed: float = DEFAULT_MAX_SPEED,
    max_angular_speed: float = DEFAULT_MAX_ANGULAR_SPEED,
    arm_clips: tuple[int, int] = (0, 1),
) -> Trajectory:
    """Time a synchronized dual-arm motion through knot poses (module docstring).

    Parameters
    ----------
    positions : array_like
        (K, 2, 3) TCP positions [m], arms in the order left, right.
    rotations : tuple of Rotation
        ``tcp_to_world`` of the left and of the right arm, K each.
    max_speed : float
        TCP speed limit [m/s] (> 0).
    max_angular_speed : float
        TCP angular speed limit [rad/s] (> 0).
    arm_clips : tuple of int
        Recorded in the result: which clip each arm holds.

    Returns
    -------
    Trajectory
    """
    pos = _check_positions(positions, "positions")
    rots = _check_rotations(rotations, len(pos), "rotations")
    v = _positive("max_speed", max_speed)
    w = _positive("max_angular_speed", max_angular_speed)
    dist, angle = _segment_motion(pos, rots)
    durations = np.maximum(dist / v, angle / w).max(axis=1)
    times = np.r_[0.0, np.cumsum(durations)]
    return Trajectory(times, pos, rots, v, w, arm_clips)


def trajectory_from_grippers(
    grippers,
    *,
    max_speed: float = DEFAULT_MAX_SPEED,
    max_angular_speed: float = DEFAULT_MAX_ANGULAR_SPEED,
    left_clip: int = 0,
    tcp_in_clip: Rotation | None = None,
) -> Trajectory:
    """The dual-arm trajectory of a :class:`~dloplan.grippers.GripperPath`.

    Parameters
    ----------
    grippers : GripperPath
        Clip poses at every shape.
    max_speed, max_angular_speed : float
        Limits [m/s], [rad/s].
    left_clip : int
        The clip the left arm holds: 0 (first clip, default) or 1 (last clip); the right arm
        holds the other.
    tcp_in_clip : Rotation, optional
        A single constant rotation ``tcp_to_clip`` (the robot's TCP frame expressed in the clip
        frame), for tools whose frame is not the thesis' u, v, w frame: tcp_to_world =
        clip_to_world * tcp_to_clip. Default identity.
    """
    if left_clip not in (0, 1) or isinstance(left_clip, bool):
        raise ValueError(f"left_clip: got {left_clip!r}, expected 0 (first clip) or 1 (last clip)")
    order = (left_clip, 1 - left_clip)
    offset = Rotation.identity() if tcp_in_clip is None else tcp_in_clip
    if not isinstance(offset, Rotation) or not offset.single:
        raise ValueError("tcp_in_clip: expected a single scipy Rotation (tcp_to_clip)")
    rotations = tuple(grippers.rotations[c] * offset for c in order)
    return dual_arm_trajectory(
        grippers.positions[:, list(order)],
        rotations,
        max_speed=max_speed,
        max_angular_speed=max_angular_speed,
        arm_clips=order,
    )
