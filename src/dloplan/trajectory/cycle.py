"""The cycle of a job: the timed motion with the gripper actions in its timeline.

The motion (:class:`~dloplan.trajectory.Trajectory`) waits at a knot while a gripper action
runs there: grasp at the start, release at the end, regrasp (release and grasp again) where a
job needs one (the harness insertion: the fingers let go of the cable lying in the slots and
close again outside the fixtures before pulling). The **cycle time** is the motion time plus
the action time, broken down into phases (:class:`Cycle`).

Every robot program carries the cycle's actions as gripper commands (:meth:`GripperAction.
commands`): a grasp closes the fingers and waits its duration, a release opens them, a regrasp
opens them for its ``opening`` part and closes them for the rest (docs/cells.md, docs/robot.md).

Default durations, for a YuMi smart gripper (fingers at up to 25 mm/s): closing the fingers
10 mm onto the cable and building up the grip force takes about 0.5 s, opening them 10 mm
0.4 s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .limits import positive

DEFAULT_GRASP_TIME = 0.5
"""Duration of a grasp [s] (module docstring)."""

DEFAULT_RELEASE_TIME = 0.4
"""Duration of a release [s] (module docstring)."""

ACTIONS = ("grasp", "release", "regrasp")

COMMANDS = ("open", "close")
"""What a gripper is told to do: open or close its fingers."""


@dataclass(frozen=True)
class GripperAction:
    """A gripper action at a knot, during which the arms do not move.

    Parameters
    ----------
    name : {"grasp", "release", "regrasp"}
    knot : int
        The knot of the motion where it happens (0: before the motion; the last knot: after).
    duration : float
        [s] (> 0).
    opening : float
        [s] A regrasp's first part, while the fingers open (0 < opening < duration; the rest
        they close); 0 for a grasp or a release.
    """

    name: str
    knot: int
    duration: float
    opening: float = 0.0

    def __post_init__(self) -> None:
        if self.name not in ACTIONS:
            raise ValueError(f"action: got {self.name!r}, expected one of {ACTIONS}")
        if isinstance(self.knot, bool) or int(self.knot) != self.knot or self.knot < 0:
            raise ValueError(f"{self.name}.knot: got {self.knot!r}, expected a knot index >= 0")
        object.__setattr__(self, "knot", int(self.knot))
        object.__setattr__(self, "duration", positive(f"{self.name}.duration", self.duration))
        opening = float(self.opening)
        if self.name == "regrasp" and not 0.0 < opening < self.duration:
            raise ValueError(f"regrasp.opening: got {self.opening!r}, expected the opening part "
                             f"of the regrasp, in (0, {self.duration}) s")
        if self.name != "regrasp" and opening != 0.0:
            raise ValueError(f"{self.name}.opening: got {self.opening!r}, expected 0 (only a "
                             "regrasp opens and closes)")
        object.__setattr__(self, "opening", opening)

    @classmethod
    def regrasp_at(cls, knot: int, release: float = DEFAULT_RELEASE_TIME,
                   grasp: float = DEFAULT_GRASP_TIME) -> GripperAction:
        """A release followed by a grasp at ``knot``."""
        return cls("regrasp", knot, positive("release", release) + positive("grasp", grasp),
                   release)

    def commands(self) -> tuple[tuple[str, float], ...]:
        """The gripper commands of the action in order: (``"open"`` or ``"close"``, the wait
        after it [s]); their waits add up to the duration."""
        if self.name == "grasp":
            return (("close", self.duration),)
        if self.name == "release":
            return (("open", self.duration),)
        return (("open", self.opening), ("close", self.duration - self.opening))


@dataclass(frozen=True)
class Phase:
    """One interval of the cycle.

    Attributes
    ----------
    name : str
        A motion phase's name (``"motion"`` or the job's, e.g. ``"phase1"``) or an action's.
    kind : {"motion", "action"}
    start, duration : float
        [s] on the cycle's clock.
    knots : tuple of int
        (first, last) knot of a motion interval; (k, k) for an action at knot k.
    """

    name: str
    kind: str
    start: float
    duration: float
    knots: tuple[int, int]

    @property
    def end(self) -> float:
        """[s]."""
        return self.start + self.duration


@dataclass(frozen=True, eq=False)
class Cycle:
    """A job's timeline: motion intervals and gripper actions in order.

    Attributes
    ----------
    phases : tuple of Phase
    actions : tuple of GripperAction
        The gripper actions in the order they run (what every robot program carries).
    """

    phases: tuple[Phase, ...]
    actions: tuple[GripperAction, ...] = ()

    @property
    def motion_time(self) -> float:
        """Time the arms move [s]."""
        return sum(p.duration for p in self.phases if p.kind == "motion")

    @property
    def action_time(self) -> float:
        """Time spent in gripper actions [s]."""
        return sum(p.duration for p in self.phases if p.kind == "action")

    @property
    def cycle_time(self) -> float:
        """Motion plus actions [s]."""
        return self.motion_time + self.action_time

    def breakdown(self) -> dict[str, float]:
        """Phase name -> total duration [s], in the order the phases first occur."""
        out: dict[str, float] = {}
        for p in self.phases:
            out[p.name] = out.get(p.name, 0.0) + p.duration
        return out

    def knot_times(self, trajectory) -> np.ndarray:
        """(K,) when the arms pass each knot on the cycle's clock [s] (actions included)."""
        shift = np.zeros(trajectory.n_knots)
        for p in self.phases:
            if p.kind == "action":
                shift[p.knots[0] + (0 if p.knots[0] == 0 else 1):] += p.duration
        return trajectory.times + shift

    def describe(self) -> str:
        """One line: cycle time = motion + actions, and the breakdown."""
        parts = ", ".join(f"{name} {t:.2f} s" for name, t in self.breakdown().items())
        return (f"cycle {self.cycle_time:.2f} s = motion {self.motion_time:.2f} s + gripper "
                f"actions {self.action_time:.2f} s ({parts})")


def plan_cycle(trajectory, actions=None, motion_phases=None) -> Cycle:
    """The timeline of a trajectory with gripper actions at its knots.

    Parameters
    ----------
    trajectory : Trajectory
        The timed motion.
    actions : sequence of GripperAction, optional
        Default: a grasp at knot 0 and a release at the last knot with the default durations.
    motion_phases : dict, optional
        Name -> (first, last) knot, consecutive and covering the whole motion (each phase
        starts where the previous ends); default ``{"motion": (0, K - 1)}``.

    Raises
    ------
    ValueError
        For an action outside the knots, at an interior knot the motion flies by (it must
        stop there: pass the knot in ``stops``), or phases that do not cover the motion.
    """
    last = trajectory.n_knots - 1
    if actions is None:
        actions = (GripperAction("grasp", 0, DEFAULT_GRASP_TIME),
                   GripperAction("release", last, DEFAULT_RELEASE_TIME))
    phases = dict(motion_phases) if motion_phases is not None else {"motion": (0, last)}
    bounds = list(phases.values())
    if (not bounds or bounds[0][0] != 0 or bounds[-1][1] != last
            or any(a[1] != b[0] for a, b in zip(bounds, bounds[1:], strict=False))
            or any(not 0 <= a <= b <= last for a, b in bounds)):
        raise ValueError(f"motion_phases: got {phases!r}, expected consecutive (first, last) "
                         f"knots covering 0..{last}")
    for action in actions:
        if not isinstance(action, GripperAction):
            raise ValueError(f"actions: got {type(action).__name__}, expected GripperAction")
        if action.knot > last:
            raise ValueError(f"{action.name}.knot: got {action.knot}, the motion has knots "
                             f"0..{last}")
        if 0 < action.knot < last and trajectory.zones[action.knot] > 0:
            raise ValueError(f"{action.name}.knot: the motion flies by knot {action.knot}; "
                             "it must stop there for a gripper action (pass it in stops)")
    waits: dict[int, list[GripperAction]] = {}
    for action in actions:
        waits.setdefault(action.knot, []).append(action)
    times = trajectory.times
    clock = 0.0
    out: list[Phase] = []
    done: list[GripperAction] = []

    def act(k: int) -> None:
        nonlocal clock
        for action in waits.pop(k, []):
            out.append(Phase(action.name, "action", clock, action.duration, (k, k)))
            done.append(action)
            clock += action.duration

    act(0)
    for name, (first, end) in phases.items():
        cuts = [first] + [k for k in sorted(waits) if first < k < end] + [end]
        for a, b in zip(cuts, cuts[1:], strict=False):
            out.append(Phase(name, "motion", clock, float(times[b] - times[a]), (a, b)))
            clock += float(times[b] - times[a])
            act(b)
    act(last)
    return Cycle(tuple(out), tuple(done))


__all__ = ["ACTIONS", "COMMANDS", "DEFAULT_GRASP_TIME", "DEFAULT_RELEASE_TIME", "Cycle",
           "GripperAction",
           "Phase", "plan_cycle"]
