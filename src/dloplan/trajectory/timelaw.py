"""The time law of a synchronized dual-arm motion: when each arm is where on its path.

**Path.** Between knots k and k + 1 (planned shapes) each TCP moves on a straight line in
position and by slerp in orientation, both driven by one **segment parameter** u_k in [0, 1]
shared by the two arms:

    p_a(u_k) = p_a,k + u_k dp_a,k,        R_a(u_k) = R_a,k exp(u_k [r_a,k])

(dp_a,k the arm's displacement, r_a,k its rotation vector in the TCP frame). Sharing u_k keeps
the two arms on the interpolated pair of poses at every instant, so both pass each planned
shape at the same time.

**Time law of a segment** (:class:`Profile`). The arm's speed is |dp_a,k| du/dt, its
acceleration |dp_a,k| d2u/dt2 and its jerk |dp_a,k| d3u/dt3 (straight line); the angular
quantities are the same with the angle |r_a,k|. So the limits of both arms (:class:`MotionLimits`)
become limits on the derivatives of u_k,

    du/dt <= s_k min_a(v / |dp_a,k|, w / |r_a,k|),  d2u/dt2 <= min_a(a / |dp_a,k|, alpha / |r_a,k|),
    d3u/dt3 <= min_a(j / |dp_a,k|, zeta / |r_a,k|),

(s_k in (0, 1] a per-segment speed scale, the hook for joint-speed limits) and the time-optimal
jerk-limited motion of u_k from rest at 0 to rest at 1 under them is computed by **ruckig**
(Berscheid and Kroeger 2021): a piecewise-cubic u_k(t) of up to seven phases (jerk +J, 0, -J,
cruise, -J, 0, +J). It is exact: every limit holds everywhere, with one of them active.

**Fine points and fly-by** (:func:`jerk_limited_law`). At a *fine* knot the segments join at
rest: the cable settles there as in the quasi-static plan. At a *fly-by* knot with zone radius
r the next segment starts before the previous one ends, by an overlap o, and the motions
superpose (the way a robot controller blends a corner zone):

    p_a(t) = p_a,0 + sum_k u_k(t - t_k) dp_a,k

The overlap starts when both TCPs are within r of the knot (an angle counts as the distance
it moves a point :data:`ZONE_LEVER` from the TCP) and ends when they are r past it, so the
corner is cut by less than r. During an overlap two segments add their accelerations and
jerks: segments next to a fly-by knot are timed with half the acceleration and jerk limits,
so the sum stays within the limits (triangle inequality); the speeds are checked on the
overlap (grid of 0.25 ms at most) and the overlap is the largest that keeps them, found by
bisection. Halving costs time; the law with fly-by is kept only when it is shorter than the
one that stops at every knot.

**Knot times.** The instant of knot k is the end of segment k - 1 at a fine point, the middle
of the overlap at a fly-by point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from ruckig import InputParameter, Result, Ruckig, RuckigError
from ruckig import Trajectory as RuckigTrajectory

from .limits import MotionLimits

ZONE_LEVER = 0.1
"""Lever [m] turning a TCP rotation into a distance for the fly-by zone (1 rad -> 0.1 m)."""

STILL = 1e-12
"""Displacement [m] and rotation [rad] below which an arm does not move in a segment."""

SPEED_GRID = 2.5e-4
"""Largest spacing [s] of the grid on which the speeds in an overlap are checked."""


@dataclass(frozen=True, eq=False)
class Profile:
    """A segment parameter u(tau) rising from 0 to 1 over [0, duration], piecewise cubic.

    Parameters
    ----------
    bounds : numpy.ndarray
        (m + 1,) phase boundaries [s], from 0 to the duration.
    p, v, a, j : numpy.ndarray
        (m,) u, du/dt [1/s], d2u/dt2 [1/s^2] at each phase's start and the phase's constant
        jerk d3u/dt3 [1/s^3].
    """

    bounds: np.ndarray
    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    j: np.ndarray

    @property
    def duration(self) -> float:
        """[s]."""
        return float(self.bounds[-1])

    @classmethod
    def still(cls) -> Profile:
        """A segment where nothing moves: zero duration."""
        zero = np.zeros(1)
        return cls(np.zeros(2), zero, zero, zero, zero)

    @classmethod
    def linear(cls, duration: float) -> Profile:
        """Constant rate 1 / duration (the velocity-only timing: infinite acceleration at the
        ends)."""
        if duration <= 0:
            return cls.still()
        return cls(np.array([0.0, duration]), np.zeros(1), np.array([1.0 / duration]),
                   np.zeros(1), np.zeros(1))

    @classmethod
    def jerk_limited(cls, velocity: float, acceleration: float, jerk: float) -> Profile:
        """Time-optimal rest-to-rest motion from 0 to 1 under the limits (ruckig)."""
        request = InputParameter(1)
        request.current_position = [0.0]
        request.target_position = [1.0]
        request.max_velocity = [velocity]
        request.max_acceleration = [acceleration]
        request.max_jerk = [jerk]
        result = RuckigTrajectory(1)
        try:
            status = Ruckig(1).calculate(request, result)
        except RuckigError as exc:  # limits far outside any robot's (MotionLimits bounds them)
            raise ValueError(f"trajectory: no jerk-limited motion under the limits (path "
                             f"parameter) v {velocity:g}, a {acceleration:g}, j {jerk:g} "
                             f"({str(exc).strip().splitlines()[0]})") from None
        if status != Result.Working:
            raise ValueError(f"trajectory: ruckig: {status} for the limits (path parameter) "
                             f"v {velocity:g}, a {acceleration:g}, j {jerk:g}")
        phases = result.profiles[0][0]
        return cls(np.r_[0.0, np.cumsum(phases.t)], np.array(phases.p[:-1]),
                   np.array(phases.v[:-1]), np.array(phases.a[:-1]), np.array(phases.j))

    def peak_rate(self) -> float:
        """Largest du/dt [1/s]: at a phase boundary or where d2u/dt2 = 0 inside a phase."""
        if self.duration == 0.0:
            return 0.0
        lengths = np.diff(self.bounds)
        with np.errstate(divide="ignore", invalid="ignore"):
            turn = np.where(self.j != 0, -self.a / self.j, -1.0)
        candidates = np.concatenate([np.zeros_like(lengths), lengths,
                                     np.where((turn > 0) & (turn < lengths), turn, 0.0)])
        phase = np.tile(np.arange(len(lengths)), 3)
        dt = candidates
        rate = self.v[phase] + dt * (self.a[phase] + dt * self.j[phase] / 2)
        return float(rate.max())

    def evaluate(self, tau, order: int = 0) -> np.ndarray:
        """u and its time derivatives at times ``tau`` [s] from the segment's start.

        Returns
        -------
        numpy.ndarray
            (order + 1, N): u, du/dt, ... up to ``order`` (<= 3); u = 0 before the start and
            1 after the end, the derivatives 0 outside the segment.
        """
        tau = np.asarray(tau, dtype=float)
        out = np.zeros((order + 1, *tau.shape))
        out[0] = tau >= self.duration
        inside = (tau >= 0.0) & (tau < self.duration)
        if not np.any(inside):
            return out
        t = tau[inside]
        k = np.clip(np.searchsorted(self.bounds, t, side="right") - 1, 0, len(self.p) - 1)
        dt = t - self.bounds[k]
        p, v, a, j = self.p[k], self.v[k], self.a[k], self.j[k]
        series = (p + dt * (v + dt * (a / 2 + dt * j / 6)), v + dt * (a + dt * j / 2),
                  a + dt * j, j)
        for n in range(order + 1):
            out[n][inside] = series[n]
        return out


@dataclass(frozen=True, eq=False)
class TimeLaw:
    """When each segment of a knot sequence runs (module docstring).

    Attributes
    ----------
    starts : numpy.ndarray
        (K - 1,) start time of each segment [s].
    profiles : tuple of Profile
        K - 1 segment parameters u_k(t - starts[k]).
    knot_times : numpy.ndarray
        (K,) the instant of each knot [s].
    zones : numpy.ndarray
        (K,) fly-by zone radius at each knot [m]; 0 at a fine point (a stop).
    kind : str
        ``"jerk-limited"`` or ``"constant-speed"`` (velocity only: each segment at constant
        rate, infinite acceleration at the knots).
    limits : MotionLimits or None
        The limits of a jerk-limited law.
    speed_scale : numpy.ndarray
        (K - 1,) the factor on the speed limits of each segment.
    """

    starts: np.ndarray
    profiles: tuple[Profile, ...]
    knot_times: np.ndarray
    zones: np.ndarray
    kind: str
    limits: MotionLimits | None = None
    speed_scale: np.ndarray | None = None

    @property
    def duration(self) -> float:
        """[s]."""
        return float(self.knot_times[-1])

    @property
    def durations(self) -> np.ndarray:
        """(K - 1,) duration of each segment's own motion [s] (overlaps included)."""
        return np.array([p.duration for p in self.profiles])

    @classmethod
    def constant_speed(cls, knot_times) -> TimeLaw:
        """Each segment at constant rate between given knot times (the velocity-only law)."""
        times = np.asarray(knot_times, dtype=float)
        profiles = tuple(Profile.linear(d) for d in np.diff(times))
        return cls(times[:-1].copy(), profiles, times, np.zeros(len(times)), "constant-speed",
                   None, np.ones(len(times) - 1))

    def parameters(self, t, order: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """The segments running at times ``t`` [s] and their parameters.

        At any instant at most two segments run (an overlap joins two): b, the first not yet
        finished, and b + 1.

        Returns
        -------
        b : numpy.ndarray
            (N,) int in [0, K - 1]: every segment before b has finished (b = K - 1 at the end).
        u : numpy.ndarray
            (order + 1, N, 2): u and its derivatives for segments b and b + 1 (0 where those
            do not exist).
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        segments = len(self.profiles)
        u = np.zeros((order + 1, len(t), 2))
        if segments == 0:
            return np.zeros(len(t), dtype=int), u
        ends = self.starts + self.durations
        b = np.searchsorted(ends, t, side="right")
        for column in (0, 1):
            index = b + column
            for k in np.unique(index[index < segments]):
                rows = index == k
                u[:, rows, column] = self.profiles[k].evaluate(t[rows] - self.starts[k], order)
        return np.minimum(b, segments), u


    def blend(self, values, t, order: int = 0) -> np.ndarray:
        """Knot values moved linearly by the running segments, and their time derivatives.

        ``values[b] + u_b (values[b+1] - values[b]) + u_b+1 (values[b+2] - values[b+1])``:
        positions of a TCP, or whole cable shapes, between their knot values.

        Parameters
        ----------
        values : array_like
            (K, ...) one value per knot.
        t : array_like
            (N,) times [s].
        order : int
            Highest time derivative (<= 3).

        Returns
        -------
        numpy.ndarray
            (order + 1, N, ...): the value and its derivatives [unit/s^n].
        """
        values = np.asarray(values, dtype=float)
        steps = np.concatenate([np.diff(values, axis=0), np.zeros((2, *values.shape[1:]))])
        b, u = self.parameters(t, order)
        extra = (None,) * (values.ndim - 1)
        out = (u[:, :, 0][(..., *extra)] * steps[b] + u[:, :, 1][(..., *extra)] * steps[b + 1])
        out[0] += values[b]
        return out


def _rates(distances: np.ndarray, angles: np.ndarray, linear: float, angular: float):
    """(K - 1,) limit on a derivative of u: min over arms of limit / distance and / angle."""
    with np.errstate(divide="ignore"):
        rate = np.minimum(np.where(distances > STILL, linear / distances, np.inf),
                          np.where(angles > STILL, angular / angles, np.inf))
    return rate.min(axis=1)


def _profiles(distances, angles, limits: MotionLimits, scale, halved) -> list[Profile]:
    v = _rates(distances, angles, limits.speed, limits.angular_speed) * scale
    out = []
    for k in range(len(distances)):
        if not np.isfinite(v[k]):
            out.append(Profile.still())
            continue
        lim = limits.scaled(0.5) if halved[k] else limits
        a = _rates(distances[k : k + 1], angles[k : k + 1], lim.acceleration,
                   lim.angular_acceleration)[0]
        j = _rates(distances[k : k + 1], angles[k : k + 1], lim.jerk, lim.angular_jerk)[0]
        out.append(Profile.jerk_limited(v[k], a, j))
    return out


def _bisect(ok, high: float, iterations: int = 20) -> float:
    """The largest x in [0, high] with ok(x) (to high / 2^iterations), assuming ok holds below
    some threshold."""
    if ok(high):
        return high
    low = 0.0
    for _ in range(iterations):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if ok(mid) else (low, mid)
    return low


def _overlap(first: Profile, second: Profile, steps: np.ndarray, angles: np.ndarray,
             reach: np.ndarray, zone: float, speed: float, angular_speed: float) -> float:
    """The largest overlap [s] of two segments at a fly-by knot (module docstring).

    ``steps`` (2, 2, 3): displacement of each arm in both segments; ``angles`` (2, 2);
    ``reach`` (2,): each segment's largest distance (an angle times :data:`ZONE_LEVER`).
    """
    t1, t2 = first.duration, second.duration
    longest = 0.5 * min(t1, t2)

    def in_zone(o: float) -> bool:
        before = (1.0 - first.evaluate(np.array([t1 - o]))[0, 0]) * reach[0]
        after = second.evaluate(np.array([o]))[0, 0] * reach[1]
        return before <= zone and after <= zone

    def within_speed(o: float) -> bool:
        tau = np.linspace(0.0, o, max(50, int(np.ceil(o / SPEED_GRID)) + 1))
        r1 = first.evaluate(t1 - o + tau, 1)[1]
        r2 = second.evaluate(tau, 1)[1]
        velocity = r1[:, None, None] * steps[0] + r2[:, None, None] * steps[1]  # (N, 2, 3)
        rotation = r1[:, None] * angles[0] + r2[:, None] * angles[1]
        return bool(np.all(np.linalg.norm(velocity, axis=-1) <= speed * (1 + 1e-12))
                    and np.all(rotation <= angular_speed * (1 + 1e-12)))

    o = _bisect(in_zone, longest)
    return _bisect(within_speed, o) if o > 0 else 0.0


def _assemble(profiles, overlaps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Segment starts and knot times from the profiles and the overlap at each knot."""
    durations = np.array([p.duration for p in profiles])
    starts = np.zeros(len(profiles))
    for k in range(1, len(profiles)):
        starts[k] = starts[k - 1] + durations[k - 1] - overlaps[k]
    knots = np.r_[0.0, starts[1:] + overlaps[1:-1] / 2, starts[-1] + durations[-1]]
    return starts, knots


def jerk_limited_law(
    steps: np.ndarray,
    rotvecs: np.ndarray,
    limits: MotionLimits,
    *,
    zone: float = 0.0,
    stops=(),
    speed_scale=None,
) -> TimeLaw:
    """The time-optimal jerk-limited law of a knot sequence (module docstring).

    Parameters
    ----------
    steps : numpy.ndarray
        (K - 1, 2, 3) displacement of each arm's TCP in each segment [m].
    rotvecs : numpy.ndarray
        (K - 1, 2, 3) rotation vector of each arm's TCP in each segment [rad].
    limits : MotionLimits
        Per-arm limits.
    zone : float
        Fly-by zone radius [m] at the interior knots; 0: stop at every knot.
    stops : iterable of int
        Interior knots that are fine points whatever ``zone`` (the cable must settle there).
    speed_scale : array_like, optional
        (K - 1,) factor in (0, 1] on the speed limits of each segment; default 1.
    """
    n = len(steps)
    if n == 0:
        return TimeLaw(np.zeros(0), (), np.zeros(1), np.zeros(1), "jerk-limited", limits,
                       np.ones(0))
    scale = np.ones(n) if speed_scale is None else np.asarray(speed_scale, dtype=float)
    distances = np.linalg.norm(steps, axis=-1)
    angles = np.linalg.norm(rotvecs, axis=-1)
    moving = (distances > STILL).any(axis=1) | (angles > STILL).any(axis=1)
    fine_profiles = _profiles(distances, angles, limits, scale, np.zeros(n, dtype=bool))
    no_overlap = np.zeros(n + 1)
    starts, knots = _assemble(fine_profiles, no_overlap)
    best = TimeLaw(starts, tuple(fine_profiles), knots, np.zeros(n + 1), "jerk-limited",
                   limits, scale)
    fixed = {int(k) for k in stops}
    flyby = np.array([0 < k < n and zone > 0 and k not in fixed and moving[k - 1] and moving[k]
                      for k in range(n + 1)])
    if not flyby.any():
        return best
    halved = flyby[:-1] | flyby[1:]
    profiles = _profiles(distances, angles, limits, scale, halved)
    reach = np.maximum(distances, ZONE_LEVER * angles).max(axis=1)
    overlaps = np.zeros(n + 1)
    for k in np.flatnonzero(flyby):
        slow = min(scale[k - 1], scale[k])
        overlaps[k] = _overlap(profiles[k - 1], profiles[k], steps[k - 1 : k + 1],
                               angles[k - 1 : k + 1], reach[k - 1 : k + 1], zone,
                               limits.speed * slow, limits.angular_speed * slow)
    starts, knots = _assemble(profiles, overlaps)
    if knots[-1] >= best.duration:
        return best
    zones = np.where(overlaps > 0, zone, 0.0)
    return TimeLaw(starts, tuple(profiles), knots, zones, "jerk-limited", limits, scale)


__all__ = ["STILL", "ZONE_LEVER", "Profile", "TimeLaw", "jerk_limited_law"]
