"""The plan's gripper actions placed in a robot program.

A plan's cycle (:func:`dloplan.trajectory.plan_cycle`) puts each gripper action at a knot of
the motion: a grasp at the first, a release at the last, a harness job's regrasp in the slots.
A program reaches every knot at one of its targets (:meth:`knot_targets` of the program: the
YuMi's program has an approach target before the first knot; a described cell's drops knots
where no arm moves), and every writer (RAPID, URScript, the UR pair's RTDE streamer, ROS 2)
writes each action there as its gripper commands (:meth:`dloplan.trajectory.GripperAction.
commands`) with the planned waits, both grippers together, the arms standing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..trajectory import DEFAULT_GRASP_TIME, DEFAULT_RELEASE_TIME, GripperAction
from .motion import ActionClock, JointMotion, program_samples, sample_times


@dataclass(frozen=True)
class ProgramAction:
    """A planned gripper action at a program target.

    Attributes
    ----------
    action : GripperAction
    target : int
        The program target where the arms stand while it runs.
    """

    action: GripperAction
    target: int


@dataclass(frozen=True)
class GripperCommand:
    """One gripper command on the program's clock: both arms' grippers at once.

    Attributes
    ----------
    time : float
        [s] when it is given, on the program's clock (:class:`~dloplan.robot.motion.
        ActionClock`).
    target : int
    knot : int
        The plan's knot.
    action : str
        The planned action it belongs to (grasp, release, regrasp).
    command : str
        ``"open"`` or ``"close"``.
    wait : float
        [s] the arms stand after it.
    """

    time: float
    target: int
    knot: int
    action: str
    command: str
    wait: float


def default_actions(n_knots: int) -> tuple[GripperAction, ...]:
    """The cycle of a plan without a recorded one: grasp before the motion, release after it,
    with the default durations (:func:`dloplan.trajectory.plan_cycle`)."""
    return (GripperAction("grasp", 0, DEFAULT_GRASP_TIME),
            GripperAction("release", n_knots - 1, DEFAULT_RELEASE_TIME))


def place_actions(actions, knot_targets, zones=None) -> tuple[ProgramAction, ...]:
    """The actions at their program targets, in the order they run.

    Parameters
    ----------
    actions : sequence of GripperAction
        In the order they run at a knot (a cycle's ``actions``).
    knot_targets : array_like
        (K,) int: the program target of each plan knot.
    zones : array_like, optional
        (M,) the program's fly-by zone radius at each target [m]: an action needs a stop (0).

    Raises
    ------
    ValueError
        An action at a knot the program does not have, or at a target it flies by.
    """
    targets = np.asarray(knot_targets, dtype=int)
    placed = []
    for action in actions:
        if not isinstance(action, GripperAction):
            raise ValueError(f"actions: got {type(action).__name__}, expected GripperAction")
        if not 0 <= action.knot < len(targets):
            raise ValueError(f"{action.name}.knot: got {action.knot}, the program has knots "
                             f"0..{len(targets) - 1}")
        target = int(targets[action.knot])
        if zones is not None and zones[target] > 0:
            raise ValueError(f"{action.name}: the program flies by target {target} (knot "
                             f"{action.knot}); a gripper action needs a stop")
        placed.append(ProgramAction(action, target))
    order = sorted(range(len(placed)), key=lambda i: (placed[i].target, i))
    return tuple(placed[i] for i in order)


def picks_up(placed) -> bool:
    """The first of the placed actions is a grasp (:attr:`ProgramTimeline.picks_up`)."""
    return bool(placed) and placed[0].action.name == "grasp"


def action_clock(arrivals, placed) -> ActionClock:
    """The program's clock (:class:`~dloplan.robot.motion.ActionClock`) of targets reached at
    ``arrivals`` (M,) [s] on the motion's clock, held for the ``placed`` actions."""
    holds = np.zeros(len(arrivals))
    for p in placed:
        holds[p.target] += p.action.duration
    return ActionClock.of(arrivals, holds)


def gripper_commands(placed, clock: ActionClock) -> tuple[GripperCommand, ...]:
    """Every gripper command of the placed actions with its instant on ``clock``."""
    out = []
    start = {}
    for p in placed:
        time = start.get(p.target, float(clock.arrive[p.target]))
        for command, wait in p.action.commands():
            out.append(GripperCommand(time, p.target, p.action.knot, p.action.name, command,
                                      wait))
            time += wait
        start[p.target] = time
    return tuple(out)


@dataclass(frozen=True, eq=False)
class ProgramTimeline:
    """A program's motion with the plan's gripper actions: what the time-based writers (the
    UR pair's RTDE streamer, ROS 2) sample.

    Attributes
    ----------
    motion : JointMotion
        The joints along the time law, on the motion's clock.
    clock : ActionClock
        The program's clock: the motion's, standing while the actions run.
    actions : tuple of ProgramAction
        In the order they run.
    """

    motion: JointMotion
    clock: ActionClock
    actions: tuple[ProgramAction, ...]

    @property
    def picks_up(self) -> bool:
        """The program's first action is a grasp: the grippers open before the arms go to the
        start (else the arms already hold the cable there, e.g. a corrected remaining motion,
        and nothing opens them)."""
        return picks_up(self.actions)

    @property
    def commands(self) -> tuple[GripperCommand, ...]:
        """Every gripper command at its instant on the program's clock."""
        return gripper_commands(self.actions, self.clock)

    def samples(self, rate: float, order: int = 2) -> tuple[np.ndarray, list[np.ndarray]]:
        """The joints at ``rate`` [Hz] (and at every arrival and leave instant) on the
        program's clock: times (N,) [s] and per arm (order + 1, N, J) [rad, rad/s, rad/s^2]
        (:func:`~dloplan.robot.motion.program_samples`)."""
        times = sample_times(self.clock, rate)
        return times, program_samples(self.motion, self.clock, times, order)


def program_timeline(program, trajectory, actions=None) -> ProgramTimeline:
    """The :class:`ProgramTimeline` of a verified program (its ``joint_motion`` along
    ``trajectory``, the plan's timing) with the plan's gripper ``actions`` (default
    :func:`default_actions`) at its targets (:meth:`knot_targets`)."""
    knots = program.knot_targets()
    placed = place_actions(default_actions(len(knots)) if actions is None else actions, knots)
    motion = program.joint_motion(trajectory)
    return ProgramTimeline(motion, action_clock(motion.arrivals, placed), placed)


__all__ = ["GripperCommand", "ProgramAction", "ProgramTimeline", "action_clock",
           "default_actions", "gripper_commands", "picks_up", "place_actions", "program_timeline"]
