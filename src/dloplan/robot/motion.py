"""A robot program's joints at any instant: positions, velocities and accelerations along its
time law, with the arms held still while the planned gripper actions run.

**The motion.** A program's arms move from target to target; in move m the joints of an arm
follow q_m(s), s in [0, 1], known at the sub-steps of the program's verified motion (uniform in
s: the replayed MoveL of the YuMi, the tracked sub-steps of a described cell), and
s = u_m(t - t0_m) is the move's time law (:class:`~dloplan.trajectory.timelaw.Profile`,
jerk-limited). With q_m(s) the not-a-knot cubic spline through the sub-steps (twice
continuously differentiable, exact at every verified sub-step),

    q(t)      = q_0 + sum_m [q_m(u_m) - q_m(0)]
    dq/dt     = sum_m q_m'(u_m) u_m'
    d2q/dt2   = sum_m [q_m''(u_m) u_m'^2 + q_m'(u_m) u_m'']

Outside its move u_m is 0 (before) or 1 (after) with zero derivatives, so the sum holds the
moves that ran; two moves overlapping at a fly-by target add, as the time law blends the TCP
motions there (:mod:`dloplan.trajectory.timelaw`). Between sub-steps the spline departs from
the straight TCP line by the interpolation error of the sub-step spacing (2 cm / 0.1 rad;
measured in tests/test_program_motion.py).

**The clock with gripper actions** (:class:`ActionClock`). The planned actions run at fine
targets (the arms at rest): the program's clock t runs on while the motion's clock stands,

    tau(t) = t - sum_m clip(t - arrive_m, 0, hold_m)

with ``arrive_m`` the instant the arms reach target m on the program's clock and ``hold_m`` the
total duration of the actions there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .joint_spline import NotAKnotSpline


def move_spline(path) -> NotAKnotSpline:
    """q_m(s): the not-a-knot cubic spline through one move's joints (n + 1, J) [rad] at the
    sub-steps s = 0, 1/n, ..., 1 (module docstring; linear for n = 1)."""
    return NotAKnotSpline(np.linspace(0.0, 1.0, len(path)), path)


@dataclass(frozen=True, eq=False)
class JointMotion:
    """The joints of every arm of a program along the time law (module docstring).

    Attributes
    ----------
    paths : tuple of tuple of numpy.ndarray
        Per arm, per move m (M - 1 moves) the joints (n_m + 1, J) [rad] at s = 0, 1/n_m, ..., 1.
    profiles : tuple of Profile
        (M - 1) the time law u_m of each move.
    starts : numpy.ndarray
        (M - 1,) the instant [s] each move starts, on the motion's clock.
    arrivals : numpy.ndarray
        (M,) the instant [s] the arms reach each target, on the motion's clock (the middle of
        the overlap at a fly-by target).
    """

    paths: tuple
    profiles: tuple
    starts: np.ndarray
    arrivals: np.ndarray

    def __post_init__(self) -> None:
        moves = len(self.profiles)
        if len(self.starts) != moves or len(self.arrivals) != moves + 1:
            raise ValueError(f"motion: {moves} moves need {moves} starts and {moves + 1} "
                             f"arrivals, got {len(self.starts)} and {len(self.arrivals)}")
        for a, arm in enumerate(self.paths):
            if len(arm) != moves or any(np.ndim(p) != 2 or len(p) < 2 for p in arm):
                raise ValueError(f"paths[{a}]: expected {moves} arrays (n + 1 >= 2, J) [rad]")
        splines = tuple(tuple(move_spline(p) for p in arm) for arm in self.paths)
        object.__setattr__(self, "_splines", splines)

    @property
    def duration(self) -> float:
        """[s] on the motion's clock, to the last target."""
        return float(self.arrivals[-1])

    def sample(self, times, order: int = 2) -> list[np.ndarray]:
        """Joints and their time derivatives at ``times`` [s] on the motion's clock.

        Parameters
        ----------
        times : array_like
            (N,) [s].
        order : int
            Highest derivative (0, 1 or 2).

        Returns
        -------
        list of numpy.ndarray
            Per arm (order + 1, N, J): q [rad], dq/dt [rad/s], d2q/dt2 [rad/s^2].
        """
        if order not in (0, 1, 2):
            raise ValueError(f"order: got {order!r}, expected 0, 1 or 2")
        t = np.atleast_1d(np.asarray(times, dtype=float))
        out = []
        for arm, splines in zip(self.paths, self._splines, strict=True):
            value = np.zeros((order + 1, len(t), arm[0].shape[1]))
            value[0] = arm[0][0]
            for m, (profile, spline) in enumerate(zip(self.profiles, splines, strict=True)):
                law = profile.evaluate(t - self.starts[m], order)
                u = np.clip(law[0], 0.0, 1.0)
                value[0] += spline(u) - spline(0.0)
                if order >= 1:
                    d1 = spline(u, 1)
                    value[1] += d1 * law[1][:, None]
                if order == 2:
                    value[2] += spline(u, 2) * law[1][:, None] ** 2 + d1 * law[2][:, None]
            out.append(value)
        return out


@dataclass(frozen=True)
class ActionClock:
    """The program's clock: the motion's, standing while gripper actions hold the arms.

    Attributes
    ----------
    arrive : numpy.ndarray
        (M,) the instant [s] the arms reach each target on the program's clock.
    hold : numpy.ndarray
        (M,) how long [s] they stand there for the gripper actions (0: none).
    """

    arrive: np.ndarray
    hold: np.ndarray

    @classmethod
    def of(cls, arrivals, holds) -> ActionClock:
        """From the targets' instants on the motion's clock (M,) [s] and the holds (M,) [s]."""
        arrivals = np.asarray(arrivals, dtype=float)
        holds = np.asarray(holds, dtype=float)
        before = np.concatenate([[0.0], np.cumsum(holds)[:-1]])
        return cls(arrivals + before, holds)

    @property
    def leave(self) -> np.ndarray:
        """(M,) the instant [s] the arms leave each target on the program's clock."""
        return self.arrive + self.hold

    @property
    def end(self) -> float:
        """[s] the program's duration: the last target reached and its actions done."""
        return float(self.leave[-1])

    def motion_time(self, times) -> np.ndarray:
        """tau(t) (module docstring): the motion's clock at program times ``times`` [s]."""
        t = np.atleast_1d(np.asarray(times, dtype=float))
        return t - np.clip(t[:, None] - self.arrive[None], 0.0, self.hold[None]).sum(axis=1)

    def holding(self, times) -> np.ndarray:
        """(N,) bool: the arms stand for an action at program times ``times`` [s]."""
        t = np.atleast_1d(np.asarray(times, dtype=float))
        return np.any((t[:, None] > self.arrive[None]) & (t[:, None] < self.leave[None]),
                      axis=1)


SAMPLE_GAP = 1e-6
"""[s] A grid instant closer than this to a target's instant is left out (time stamps written
to the nanosecond must increase strictly)."""


def sample_times(clock: ActionClock, rate: float) -> np.ndarray:
    """(N,) instants [s] on the program's clock: a grid at ``rate`` [Hz] from 0 to the end,
    with every target's arrival and leave instants added (grid instants within
    :data:`SAMPLE_GAP` of them left out)."""
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"rate: got {rate!r}, expected a sampling rate > 0 [Hz]")
    events = np.unique(np.concatenate([clock.arrive, clock.leave, [clock.end]]))
    grid = np.arange(0.0, clock.end, 1.0 / rate)
    near = np.abs(grid[:, None] - events[None]).min(axis=1) < SAMPLE_GAP
    return np.union1d(grid[~near], events)


def program_samples(motion: JointMotion, clock: ActionClock, times,
                    order: int = 2) -> list[np.ndarray]:
    """The joints and their derivatives at ``times`` [s] on the program's clock (module
    docstring): :meth:`JointMotion.sample` at tau(t), the derivatives zero while the arms hold
    for a gripper action (d tau / dt = 0 there).

    Returns
    -------
    list of numpy.ndarray
        Per arm (order + 1, N, J) [rad], [rad/s], [rad/s^2].
    """
    t = np.atleast_1d(np.asarray(times, dtype=float))
    values = motion.sample(clock.motion_time(t), order)
    held = clock.holding(t)
    for value in values:
        value[1:, held] = 0.0
    return values


__all__ = ["SAMPLE_GAP", "ActionClock", "JointMotion", "program_samples", "sample_times"]
