"""Timed dual-arm TCP trajectories through the planned gripper poses (thesis 4.6, 7.3).

The S + 2 pairs of TCP poses (knots) are joined by synchronized segments: in each segment both
TCPs move **linearly in position** and by **spherical-linear interpolation** in orientation,
driven by one parameter shared by the two arms, so they start, pass every planned shape and
stop together. How that parameter runs in time is the **time law**
(:mod:`dloplan.trajectory.timelaw`):

* ``"jerk-limited"`` (default): time-optimal under per-arm limits on TCP speed, acceleration
  and jerk and on angular speed, acceleration and jerk (:class:`MotionLimits`, YuMi defaults),
  computed with ruckig; stops (fine points) at every knot, or fly-by zones at the interior
  knots when a ``zone`` radius is given (``stops`` keeps chosen knots fine).
* ``"constant-speed"``: the velocity-only timing, each segment at constant speed with

      T_k = max over arms of max(|p_{k+1} - p_k| / v_max, angle(R_k^-1 R_{k+1}) / omega_max),

  which ignores acceleration (infinite at every knot): a lower bound on the motion time, kept
  for comparison and for plan documents that carry only knot times.

For a robot program the trajectory exposes, per segment, the TCP speed to program
(:meth:`Trajectory.segment_peak_speeds`), the zone of its end knot (:attr:`Trajectory.zones`,
0 = ``fine``) and the knot-to-knot duration (:attr:`Trajectory.segment_durations`, for
``\\T``), all gathered by :meth:`Trajectory.segment_table`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from ..bounds import MAX_TRAJECTORY_SAMPLES
from ..frames import compose
from .limits import DEFAULT_MAX_ANGULAR_SPEED, DEFAULT_MAX_SPEED, MotionLimits, positive
from .timelaw import TimeLaw, jerk_limited_law

ARMS = ("left", "right")

LAWS = ("jerk-limited", "constant-speed")
"""The time laws of :func:`dual_arm_trajectory`."""

ArmRotations = tuple[Rotation, Rotation]
"""``tcp_to_world`` rotations of the left and the right arm, one per knot each."""


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


def segment_motion(positions: np.ndarray, rotations: ArmRotations):
    """Per segment and arm: displacement (K - 1, 2, 3) [m] and rotation vector in the TCP
    frame (K - 1, 2, 3) [rad]."""
    steps = np.diff(positions, axis=0)
    rotvecs = np.stack([(r[:-1].inv() * r[1:]).as_rotvec() for r in rotations], axis=1)
    return steps, rotvecs.reshape(steps.shape)


def interpolate_poses(law: TimeLaw, positions, rotations, times):
    """Poses of two frames at ``times`` [s] moving through knot poses under a time law.

    Parameters
    ----------
    law : TimeLaw
        The time law of the K knots.
    positions : array_like
        (K, 2, 3) positions [m] of the two frames at the knots (TCPs, or the clips they hold).
    rotations : tuple of Rotation
        The two frames' rotations, K each.
    times : array_like
        (N,) times [s] within [0, law.duration].

    Returns
    -------
    positions : numpy.ndarray
        (N, 2, 3) [m].
    rotations : tuple of Rotation
        N each.
    """
    pos = np.asarray(positions, dtype=float)
    rotvecs = np.concatenate([segment_motion(pos, rotations)[1], np.zeros((2, 2, 3))])
    b, u = law.parameters(times, 0)
    out = law.blend(pos, times)[0]
    rots = tuple(  # rotations[a][b] * (each segment's part) * (the next's), batched
        compose(compose(rotations[a][b], Rotation.from_rotvec(u[0, :, 0, None] * rotvecs[b, a])),
                Rotation.from_rotvec(u[0, :, 1, None] * rotvecs[b + 1, a]))
        for a in (0, 1)
    )
    return out, rots


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
class Kinematics:
    """Norms of each TCP's time derivatives, (N, 2) each (arms left, right).

    Attributes
    ----------
    times : numpy.ndarray
        (N,) [s].
    speed, acceleration, jerk : numpy.ndarray
        [m/s], [m/s^2], [m/s^3].
    angular_speed : numpy.ndarray
        [rad/s].
    """

    times: np.ndarray
    speed: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    angular_speed: np.ndarray


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A timed, synchronized dual-arm TCP trajectory through knot poses.

    Parameters
    ----------
    times : numpy.ndarray
        (K,) knot times [s], t_0 = 0, non-decreasing (equal only across a segment where
        neither arm moves): the instants both arms pass the planned shapes.
    positions : numpy.ndarray
        (K, 2, 3) TCP positions [m] at the knots, arms in the order left, right.
    rotations : tuple of Rotation
        ``tcp_to_world`` of the left and the right arm at the knots, K each.
    max_speed, max_angular_speed : float
        The speed limits the timing was made with [m/s], [rad/s].
    arm_clips : tuple of int
        Which clip each arm holds (0 first, 1 last), left then right.
    law : TimeLaw, optional
        The time law; default the constant-speed law through ``times`` (what a plan document
        holding only knot times describes).
    """

    times: np.ndarray
    positions: np.ndarray
    rotations: ArmRotations
    max_speed: float = DEFAULT_MAX_SPEED
    max_angular_speed: float = DEFAULT_MAX_ANGULAR_SPEED
    arm_clips: tuple[int, int] = (0, 1)
    law: TimeLaw | None = None

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
        law = self.law if self.law is not None else TimeLaw.constant_speed(times)
        if not isinstance(law, TimeLaw):
            raise ValueError(f"law: got {type(law).__name__}, expected a TimeLaw")
        if len(law.knot_times) != len(times):
            raise ValueError(f"law: {len(law.knot_times)} knot times, expected the trajectory's "
                             f"{len(times)} times")
        off = np.flatnonzero(np.abs(np.asarray(law.knot_times) - times) > 1e-9)
        if off.size:
            k = int(off[0])
            raise ValueError(f"law: knot {k} at {law.knot_times[k]:.9g} s, the trajectory's time "
                             f"{times[k]:.9g} s ({off.size} knots differ); expected the law's "
                             "knot times to be the trajectory's times")
        set_ = object.__setattr__
        set_(self, "times", times)
        set_(self, "positions", pos)
        set_(self, "rotations", rots)
        set_(self, "max_speed", positive("max_speed", self.max_speed))
        set_(self, "max_angular_speed", positive("max_angular_speed", self.max_angular_speed))
        set_(self, "arm_clips", tuple(int(c) for c in self.arm_clips))
        set_(self, "law", law)

    @property
    def duration(self) -> float:
        """Total motion time [s]."""
        return float(self.times[-1])

    @property
    def n_knots(self) -> int:
        """Number of knots K (S + 2 for a planned path)."""
        return len(self.times)

    @property
    def limits(self) -> MotionLimits | None:
        """The acceleration and jerk limits of a jerk-limited law (None: velocity only)."""
        return self.law.limits

    @property
    def segment_durations(self) -> np.ndarray:
        """(K - 1,) knot-to-knot durations [s] (RAPID's ``\\T`` of the move to knot k + 1)."""
        return np.diff(self.times)

    @property
    def zones(self) -> np.ndarray:
        """(K,) fly-by zone radius at each knot [m]; 0 at a fine point (the arms stop)."""
        return self.law.zones

    def segment_distances(self) -> tuple[np.ndarray, np.ndarray]:
        """Per segment and arm: TCP travel [m] and rotation angle [rad], (K - 1, 2) each."""
        steps, rotvecs = segment_motion(self.positions, self.rotations)
        return np.linalg.norm(steps, axis=-1), np.linalg.norm(rotvecs, axis=-1)

    def segment_speeds(self) -> tuple[np.ndarray, np.ndarray]:
        """Per segment and arm: mean TCP speed [m/s] and angular speed [rad/s], (K - 1, 2):
        distance over the knot-to-knot duration (zero where that duration is zero)."""
        dist, angle = self.segment_distances()
        dt = self.segment_durations[:, None]
        safe = np.where(dt > 0, dt, 1.0)
        return np.where(dt > 0, dist / safe, 0.0), np.where(dt > 0, angle / safe, 0.0)

    def segment_peak_speeds(self) -> tuple[np.ndarray, np.ndarray]:
        """Per segment and arm: the largest TCP speed [m/s] and angular speed [rad/s] of the
        segment's own motion, (K - 1, 2): the speed to program (RAPID ``speeddata``)."""
        dist, angle = self.segment_distances()
        rate = np.array([p.peak_rate() for p in self.law.profiles]).reshape(-1, 1)
        return dist * rate, angle * rate

    def segment_table(self) -> list[dict]:
        """One row per segment, what a robot program needs for the move to knot k + 1.

        Keys: ``start``, ``end`` (knot indices), ``duration`` (knot to knot [s]),
        ``speed`` and ``angular_speed`` (peak per arm, left and right [m/s], [rad/s]),
        ``zone`` (fly-by radius at the end knot [m], 0 = fine), ``fine`` (bool).
        """
        speed, angular = self.segment_peak_speeds()
        return [{"start": k, "end": k + 1, "duration": float(d),
                 "speed": speed[k].tolist(), "angular_speed": angular[k].tolist(),
                 "zone": float(self.zones[k + 1]), "fine": bool(self.zones[k + 1] == 0.0)}
                for k, d in enumerate(self.segment_durations)]

    def segment_speed_use(self) -> np.ndarray:
        """(K - 1,) the fraction of its speed limit (times its speed scale) each segment's law
        reaches: 1 when it cruises at the limit, less when the acceleration or jerk limit
        keeps it from getting there (a short segment), 0 where nothing moves. A speed scale
        below this fraction is what slows such a segment down."""
        dist, angle = self.segment_distances()
        rate = np.array([p.peak_rate() for p in self.law.profiles])
        with np.errstate(divide="ignore", invalid="ignore"):
            allowed = np.minimum(np.where(dist > 0, self.max_speed / dist, np.inf),
                                 np.where(angle > 0, self.max_angular_speed / angle,
                                          np.inf)).min(axis=1)
        scale = self.law.speed_scale if self.law.speed_scale is not None else 1.0
        allowed = allowed * scale
        return np.where(np.isfinite(allowed) & (allowed > 0),
                        np.minimum(rate / np.where(np.isfinite(allowed), allowed, 1.0), 1.0),
                        0.0)

    def with_speed_scale(self, speed_scale) -> Trajectory:
        """The same path timed again with per-segment factors (K - 1,) in (0, 1] on the speed
        limits (the hook for joint-speed limits): the law's other limits, its fly-by zones and
        fine points stay; a constant-speed law's segments last 1 / factor as long as at
        factor 1."""
        old = self.law.speed_scale if self.law.speed_scale is not None else \
            np.ones(self.n_knots - 1)
        scale = _speed_scale(speed_scale, self.positions, self.rotations, self.n_knots - 1)
        steps, rotvecs = segment_motion(self.positions, self.rotations)
        if self.law.kind == "constant-speed":
            durations = np.diff(self.times) * old / scale
            law = TimeLaw.constant_speed(np.r_[0.0, np.cumsum(durations)])
            law = replace(law, speed_scale=scale)
        else:
            zone = float(np.max(self.zones))
            stops = [k for k in range(1, self.n_knots - 1) if self.zones[k] == 0.0]
            law = jerk_limited_law(steps, rotvecs, self.law.limits, zone=zone,
                                   stops=stops if zone > 0 else (), speed_scale=scale)
        return replace(self, times=law.knot_times, law=law)

    def _clipped(self, times) -> np.ndarray:
        t = np.atleast_1d(np.asarray(times, dtype=float))
        if not np.all(np.isfinite(t)):
            raise ValueError("times: non-finite time (NaN or inf)")
        return np.clip(t, 0.0, self.duration)

    def at(self, times) -> TrajectorySamples:
        """Poses of both TCPs at given times [s] (clipped to [0, duration]) under the law."""
        t = self._clipped(times)
        positions, rotations = interpolate_poses(self.law, self.positions, self.rotations, t)
        return TrajectorySamples(t, positions, rotations)

    def kinematics(self, times) -> Kinematics:
        """Speed, acceleration, jerk and angular speed of both TCPs at ``times`` [s]."""
        t = self._clipped(times)
        rotvecs = np.concatenate([segment_motion(self.positions, self.rotations)[1],
                                  np.zeros((2, 2, 3))])
        b, u = self.law.parameters(t, 1)
        norms = np.linalg.norm(self.law.blend(self.positions, t, 3)[1:], axis=-1)
        # body angular velocity of R_b exp(u_b r_b) exp(u_b+1 r_b+1)
        omega = np.stack([np.linalg.norm(
            Rotation.from_rotvec(u[0, :, 1, None] * rotvecs[b + 1, a]).inv().apply(
                u[1, :, 0, None] * rotvecs[b, a]) + u[1, :, 1, None] * rotvecs[b + 1, a],
            axis=-1) for a in (0, 1)], axis=1)
        return Kinematics(t, *norms, omega)

    def sample(self, rate: float) -> TrajectorySamples:
        """Sample at ``rate`` [Hz]: times 0, 1/rate, ... and the final time."""
        return self.at(sample_times(self.duration, rate))


MAX_SAMPLES = MAX_TRAJECTORY_SAMPLES
"""Most samples of a trajectory (:data:`dloplan.bounds.MAX_TRAJECTORY_SAMPLES`)."""


def sample_times(duration: float, rate: float) -> np.ndarray:
    """Times 0, 1/rate, ... up to ``duration`` [s], which is always included.

    Raises
    ------
    ValueError
        When ``rate`` is not a number > 0, or gives more than :data:`MAX_SAMPLES` samples.
    """
    rate = positive("rate", rate)
    steps = int(np.floor(duration * rate + 1e-9))
    if steps >= MAX_SAMPLES:
        raise ValueError(f"rate: {rate:g} Hz over the trajectory's {duration:.4g} s gives "
                         f"{steps + 1:.3g} samples, more than {MAX_SAMPLES:.0e}: lower the rate "
                         "(or re-time the plan faster)")
    times = np.arange(steps + 1) / rate
    if duration - times[-1] > 1e-12:
        return np.r_[times, duration]
    times[-1] = duration
    return times


def _speed_scale(speed_scale, positions, rotations, segments: int):
    if speed_scale is None:
        return None
    values = speed_scale(positions, rotations) if callable(speed_scale) else speed_scale
    scale = np.asarray(values, dtype=float)
    if scale.shape != (segments,) or not np.all((scale > 0) & (scale <= 1)):
        raise ValueError(f"speed_scale: got {values!r}, expected {segments} factors in (0, 1] "
                         "(one per segment)")
    return scale


def dual_arm_trajectory(
    positions,
    rotations,
    *,
    max_speed: float | None = None,
    max_angular_speed: float | None = None,
    arm_clips: tuple[int, int] = (0, 1),
    limits: MotionLimits | None = None,
    law: str = "jerk-limited",
    zone: float = 0.0,
    stops=(),
    speed_scale=None,
) -> Trajectory:
    """Time a synchronized dual-arm motion through knot poses (module docstring).

    Parameters
    ----------
    positions : array_like
        (K, 2, 3) TCP positions [m], arms in the order left, right.
    rotations : tuple of Rotation
        ``tcp_to_world`` of the left and of the right arm, K each.
    max_speed, max_angular_speed : float, optional
        TCP speed [m/s] and angular speed [rad/s] limits; they replace ``limits``' own.
    arm_clips : tuple of int
        Recorded in the result: which clip each arm holds.
    limits : MotionLimits, optional
        Per-arm limits (default: the YuMi defaults of :mod:`dloplan.trajectory.limits`).
    law : {"jerk-limited", "constant-speed"}
        The time law (module docstring).
    zone : float
        Fly-by zone radius [m] at the interior knots (``"jerk-limited"`` only); 0: stop at
        every knot (fine points).
    stops : iterable of int
        Interior knots kept fine whatever ``zone``: where the cable must settle.
    speed_scale : array_like or callable, optional
        (K - 1,) factors in (0, 1] on the speed limits of each segment, or a callable
        ``speed_scale(positions, rotations)`` returning them: the hook for joint-speed limits
        from the robot's inverse kinematics along the path.

    Returns
    -------
    Trajectory

    Raises
    ------
    ValueError
        For malformed poses, a limit that is not a finite number > 0, a negative zone, a
        stop that is not an interior knot, or speed factors outside (0, 1].
    """
    pos = _check_positions(positions, "positions")
    rots = _check_rotations(rotations, len(pos), "rotations")
    base = limits if limits is not None else MotionLimits()
    if not isinstance(base, MotionLimits):
        raise ValueError(f"limits: got {type(base).__name__}, expected MotionLimits")
    v = base.speed if max_speed is None else positive("max_speed", max_speed)
    w = base.angular_speed if max_angular_speed is None else positive("max_angular_speed",
                                                                       max_angular_speed)
    base = MotionLimits(v, base.acceleration, base.jerk, w, base.angular_acceleration,
                        base.angular_jerk)
    if law not in LAWS:
        raise ValueError(f"law: got {law!r}, expected one of {LAWS}")
    try:
        zone = float(zone)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"zone: got {zone!r}, expected a radius >= 0 [m]") from exc
    if not (math.isfinite(zone) and zone >= 0):
        raise ValueError(f"zone: got {zone!r}, expected a radius >= 0 [m]")
    stops = tuple(stops)
    bad = [k for k in stops if isinstance(k, bool) or int(k) != k or not 0 < k < len(pos) - 1]
    if bad:
        raise ValueError(f"stops: got {bad!r}, expected interior knot indices 1..{len(pos) - 2}")
    scale = _speed_scale(speed_scale, pos, rots, len(pos) - 1)
    steps, rotvecs = segment_motion(pos, rots)
    if law == "constant-speed":
        if zone > 0:
            raise ValueError("zone: fly-by needs the jerk-limited law (the constant-speed law "
                             "stops at every knot)")
        s = np.ones(len(steps)) if scale is None else scale
        dist, angle = np.linalg.norm(steps, axis=-1), np.linalg.norm(rotvecs, axis=-1)
        durations = np.maximum(dist / v, angle / w).max(axis=1) / s if len(steps) else s
        timing = TimeLaw.constant_speed(np.r_[0.0, np.cumsum(durations)])
    else:
        timing = jerk_limited_law(steps, rotvecs, base, zone=zone, stops=stops,
                                  speed_scale=scale)
    return Trajectory(timing.knot_times, pos, rots, v, w, arm_clips, timing)


def trajectory_from_grippers(
    grippers,
    *,
    left_clip: int = 0,
    tcp_in_clip: Rotation | None = None,
    **timing,
) -> Trajectory:
    """The dual-arm trajectory of a :class:`~dloplan.grippers.GripperPath`.

    Parameters
    ----------
    grippers : GripperPath
        Clip poses at every shape.
    left_clip : int
        The clip the left arm holds: 0 (first clip, default) or 1 (last clip); the right arm
        holds the other.
    tcp_in_clip : Rotation, optional
        A single constant rotation ``tcp_to_clip`` (the robot's TCP frame expressed in the clip
        frame), for tools whose frame is not the thesis' u, v, w frame: tcp_to_world =
        clip_to_world * tcp_to_clip. Default identity.
    **timing
        ``max_speed``, ``max_angular_speed``, ``limits``, ``law``, ``zone``, ``stops``,
        ``speed_scale`` of :func:`dual_arm_trajectory`.
    """
    if left_clip not in (0, 1) or isinstance(left_clip, bool):
        raise ValueError(f"left_clip: got {left_clip!r}, expected 0 (first clip) or 1 (last clip)")
    order = (left_clip, 1 - left_clip)
    offset = Rotation.identity() if tcp_in_clip is None else tcp_in_clip
    if not isinstance(offset, Rotation) or not offset.single:
        raise ValueError("tcp_in_clip: expected a single scipy Rotation (tcp_to_clip)")
    rotations = tuple(grippers.rotations[c] * offset for c in order)
    return dual_arm_trajectory(grippers.positions[:, list(order)], rotations, arm_clips=order,
                               **timing)
