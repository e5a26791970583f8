"""The robot program of a plan: one model for every cell, the cell's specifics a plug-in.

A :class:`RobotProgram` is a sequence of M targets, the verified joints of both arms at them,
the joints along each move between them (the controller's motion, sub-step by sub-step) timed
by the plan's time law, and the verdict rows checked on exactly that
(:mod:`dloplan.robot.checks`). What differs from cell to cell is its plug-in, the program's
``targets`` record (:class:`Targets`):

- how the targets are solved (the YuMi's arm-angle IK with its controller round trip,
  :mod:`dloplan.robot.yumi_program`; a described cell's IK tracked along the trajectory,
  :mod:`dloplan.robot.tracked_program`), which makes the record;
- what a target records (a robtarget with confdata and arm angle; a TCP pose with its
  placement offset) and its timing (the approach and retreat moves of the YuMi; the knots of
  the trajectory on a described cell);
- how the joint motion between targets is timed, and which writers it is given (RAPID;
  URScript, ur_rtde; ROS 2 for both).

What does not differ is here, once: the verdict (``ok``, ``failures``), its summary per check
and the one-line failure text (:class:`RobotProgram`); the joint motion along the time law
(:meth:`RobotProgram.joint_motion`) and the ``joint speed`` (and, where the arm publishes
acceleration limits, ``joint acceleration``) rows along it (:func:`speed_rows`); re-timing
(:meth:`RobotProgram.retimed`) and the slow-down of a program over a joint speed limit
(:func:`slowed`: its targets and joints never change, only its timing and the speed rows with
it). :func:`dloplan.robot.plugins.robot_program` makes the program of any cell.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from .checks import SLOW_ROUNDS, CheckRow, check_summary
from .motion import JointMotion
from .peaks import motion_peaks, slowed_scale

TIMED_CHECKS = ("joint speed", "joint acceleration")
"""The checks along the time law (:func:`speed_rows`): replaced when a program is re-timed."""


class Targets(Protocol):
    """A cell plug-in's record of a program's targets (:class:`RobotProgram.targets`): what is
    written of each target, its timing, and what the cell's writers are given. Implemented by
    :class:`~dloplan.robot.yumi_program.YumiTargets` (the YuMi: robtargets, RAPID) and
    :class:`~dloplan.robot.tracked_program.TrackedTargets` (a described cell: URScript,
    ur_rtde).

    Its methods: ``axis_name(j)`` a joint's name in the rows' notes; ``knot_targets()`` (K,)
    the target reaching each plan knot; ``timed(cell, trajectory)`` the record timed by another
    trajectory of the same path; ``move_timing(cell, trajectory)`` the moves' profiles, starts
    and arrivals (:class:`~dloplan.robot.motion.JointMotion`); ``message``, ``record``,
    ``writer_arguments`` and ``report_arms`` of a program (:class:`RobotProgram`'s)."""

    CHECKS: tuple[str, ...]  # the checks of the cell's programs, in the order of the rows
    formats: tuple[str, ...]  # the program formats written from it (dloplan.app.writers)
    labels: tuple[str, ...]  # (M,) the targets' labels
    shapes: np.ndarray  # (M,) int: the plan's shape (trajectory knot) of each target
    times: np.ndarray  # (M,) [s]: when each target is reached, on the motion's clock
    move_segments: np.ndarray  # (M - 1,) int: the trajectory segment each move is (-1: none)

    def axis_name(self, joint: int) -> str: ...

    def knot_targets(self) -> np.ndarray: ...

    def timed(self, cell, trajectory) -> Targets: ...

    def move_timing(self, cell, trajectory) -> tuple: ...

    def message(self, program: RobotProgram) -> str: ...

    def record(self, program: RobotProgram) -> dict: ...

    def writer_arguments(self, program: RobotProgram, name: str) -> dict: ...

    def report_arms(self, program: RobotProgram) -> dict: ...


@dataclass(frozen=True, eq=False)
class HeldArms:
    """Both arms holding the cable at a program's first target (the remaining motion of a
    corrected plan: the cable is held at the shape measured), as the plan's program holds it.

    Attributes
    ----------
    left_clip : int
        The clip the left arm holds (0 or 1): the assignment is kept.
    joints : sequence of numpy.ndarray
        The (left, right) arms' joints [rad], each (n_arm,), physical order (the YuMi's a
        (2, 7) array): the program starts from them (the YuMi's each arm angle kept).
    offset : numpy.ndarray
        (3,) [m] the job's placement on a described cell that the plan's program ran it with
        (:attr:`~dloplan.robot.urdf_cell.CellPlan.offset`), kept: no placement is searched for
        a held cable; zeros on the YuMi.
    """

    left_clip: int
    joints: Sequence[np.ndarray]
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))


@dataclass(frozen=True, eq=False)
class RobotProgram:
    """A verified dual-arm program on any cell: what its writers write, and its checks.

    Attributes
    ----------
    cell : RobotCell or DescribedCell
        The YuMi's RAPID cell or a cell of two arms from descriptions; ``cell.arms`` are its
        two arms (left, right).
    targets : Targets
        The cell plug-in's record of the M targets (:class:`Targets`): labels, plan shapes,
        times, and what is written of them.
    joints : tuple of numpy.ndarray
        Per arm (left, right) the (M, n_arm) verified joint values [rad] at the targets, in
        the order of the arm's chain (the YuMi: physical order, ABB axes 1, 2, 7, 3, 4, 5, 6;
        a URDF arm: its joints from base to tip).
    moves : tuple of tuple of numpy.ndarray
        Per arm, per move m = 0..M-2 the joints (n_m + 1, n_arm) [rad] along the move from
        target m to target m + 1, uniform in the move's parameter: the controller's motion
        (the YuMi's replayed MoveL, a described cell's tracked sub-steps), starting on
        ``joints[a][m]`` and ending on ``joints[a][m + 1]``.
    checks : tuple of CheckRow
        The verdict rows, their checks in the order of ``targets.CHECKS``, those along the
        time law last.
    trajectory : Trajectory or None
        The timing the program was verified with: the plan's, or slowed where a joint was
        over its speed limit.
    joint_speed : numpy.ndarray or None
        (M - 1, 2) per move and arm the peak joint speed along the time law as a fraction of
        the limit.
    completion : callable or None
        None: every row is the complete program's. Else some passing rows were judged at less
        cost, with the complete program's verdicts but not its values and notes (the YuMi's
        passing round trips from the verified joints' own solutions,
        :func:`~dloplan.robot.yumi_program.yumi_program`), and ``completion(program)`` gives
        the program with those rows made as the complete program makes them:
        :meth:`completed`.
    """

    cell: object
    targets: Targets
    joints: tuple[np.ndarray, np.ndarray]
    moves: tuple
    checks: tuple[CheckRow, ...]
    trajectory: object = None
    joint_speed: np.ndarray | None = None
    completion: Callable[[RobotProgram], RobotProgram] | None = None

    @property
    def ok(self) -> bool:
        """Every check passes: the program may be written and run."""
        return all(row.ok for row in self.checks)

    @property
    def failures(self) -> tuple[CheckRow, ...]:
        """The rows that fail."""
        return tuple(row for row in self.checks if not row.ok)

    @property
    def n_targets(self) -> int:
        """Number of targets M."""
        return len(self.targets.labels)

    @property
    def labels(self) -> tuple[str, ...]:
        """(M,) the targets' labels (``"shape k"``; the YuMi's ``"approach"``, ``"retreat"``)."""
        return self.targets.labels

    @property
    def times(self) -> np.ndarray:
        """(M,) time [s] each target is reached, on the motion's clock."""
        return self.targets.times

    @property
    def formats(self) -> tuple[str, ...]:
        """The program formats written from it (:mod:`dloplan.app.writers`)."""
        return self.targets.formats

    @property
    def message(self) -> str:
        """One line: passed with the key numbers, or the first failure of every failing
        check."""
        return self.targets.message(self)

    def completed(self) -> RobotProgram:
        """The program with every row as the complete program makes it (its
        :attr:`completion` run once; itself when there is none): what is written, printed
        and recorded. The verdicts, the failing rows, the targets, joints and timing are the
        same either way."""
        return self if self.completion is None else replace(self.completion(self),
                                                            completion=None)

    def knot_targets(self) -> np.ndarray:
        """(K,) int: the target at which the program reaches each plan knot (shape)."""
        return self.targets.knot_targets()

    def joint_motion(self, trajectory) -> JointMotion:
        """Both arms' joints along the time law (:class:`~dloplan.robot.motion.JointMotion`):
        each move's path ``moves``, timed by ``trajectory``'s law (the plan's, which this
        program was made from) as the cell's plug-in times its moves."""
        return JointMotion(self.moves, *self.targets.move_timing(self.cell, trajectory))

    def segment_speed_ratios(self) -> np.ndarray:
        """(K - 1,) per segment of the trajectory the larger arm's peak joint speed as a
        fraction of the limit (0 for a segment no move is: a dropped knot's; moves that are
        no segment, the YuMi's approach and retreat, are not the trajectory's)."""
        segments = np.asarray(self.targets.move_segments)
        inner = segments >= 0
        ratios = np.zeros(self.trajectory.n_knots - 1)
        ratios[segments[inner]] = self.joint_speed[inner].max(axis=1)
        return ratios

    def retimed(self, trajectory) -> RobotProgram:
        """The same targets and joints timed by ``trajectory`` (the plan's trajectory, maybe
        slowed): the plug-in's target times (and what is written of them), and the rows along
        the time law (:func:`speed_rows`) replacing any it had. Re-timing never changes a
        target or a joint."""
        targets = self.targets.timed(self.cell, trajectory)
        checks = tuple(row for row in self.checks if row.check not in TIMED_CHECKS)
        timed = replace(self, targets=targets, checks=checks, trajectory=trajectory)
        arms = self.cell.arms
        peaks = motion_peaks(timed.joint_motion(trajectory), [arm.max_velocity for arm in arms],
                             [arm.max_acceleration for arm in arms])
        rows = speed_rows(targets.labels, targets.shapes, arms, peaks, targets.axis_name)
        return replace(timed, checks=checks + rows,
                       joint_speed=np.stack([p.speed for p in peaks], axis=1))

    def writer_arguments(self, name: str) -> dict:
        """Keyword arguments of the writer of program format ``name`` (one of ``formats``
        but ``rapid``, which is given the program): ``ros_joints``
        (:func:`dloplan.io.ros_joints.write_joint_trajectories` after the folder and the
        timeline), ``urscript`` (:func:`dloplan.io.urscript.write_urscript` after the folder),
        ``ur_rtde`` (:func:`dloplan.io.ur_rtde.write_ur_rtde` after the folder and the
        timeline)."""
        return self.targets.writer_arguments(self, name)

    def report_arms(self) -> dict:
        """Keyword arguments of :func:`dloplan.plots.report.write_report` that draw both arms
        at every shape and along the program's motion."""
        return self.targets.report_arms(self)

    def summary(self) -> list[dict]:
        """Per check: passed, the worst value and where, how many rows fail and the first."""
        return check_summary(self.checks, self.targets.CHECKS)

    def failure_text(self, who=lambda arm: "" if arm == "both" else f"{arm} arm: ") -> str:
        """The first failing row of every failing check, in the order of ``CHECKS``:
        ``check at label (who value unit; note)`` joined by ``; `` (empty when none fails);
        ``who`` names a row's arm (``left``, ``right`` or ``both``)."""
        parts = []
        for name in self.targets.CHECKS:
            first = next((r for r in self.checks if r.check == name and not r.ok), None)
            if first is not None:
                note = f"; {first.note}" if first.note else ""
                parts.append(f"{name} at {first.label} ({who(first.arm)}{first.value:.4g} "
                             f"{first.unit}{note})")
        return "; ".join(parts)

    def to_dict(self) -> dict:
        """JSON-ready: the verdict and its message, what the cell's plug-in records of the
        targets (the assignment, the targets as written, their joints [deg]), the summary and
        every check row."""
        return {"ok": self.ok, "message": self.message, **self.targets.record(self),
                "summary": self.summary(), "checks": [row.to_dict() for row in self.checks]}


def speed_rows(labels, shapes, arms, peaks, axis_name) -> tuple[CheckRow, ...]:
    """The rows along the time law: per move into target m = 1..M-1 and arm, ``joint speed``
    (the peak |dq/dt| over the joints as a fraction of the joint's limit) and, where the arm
    publishes acceleration limits, ``joint acceleration`` (the same for d2q/dt2).

    Parameters
    ----------
    labels : sequence of str
        (M,) the targets' labels.
    shapes : sequence of int
        (M,) the plan's shape each target belongs to.
    arms : sequence of CellArm
        The two arms (their ``name`` and ``max_acceleration``).
    peaks : sequence of JointPeaks
        Per arm the peaks of every move (:func:`~dloplan.robot.peaks.motion_peaks`).
    axis_name : callable
        Joint index (physical order) -> the axis' name in a note (``ABB axis 7``, ``joint 3``).
    """
    rows = []
    for m in range(1, len(labels)):
        j = m - 1
        for arm, p in zip(arms, peaks, strict=True):
            common = (m, labels[m], int(shapes[m]), arm.name)
            rows.append(CheckRow("joint speed", *common, float(p.speed[j]), "of the limit",
                                 bool(p.speed[j] <= 1.0),
                                 f"from {labels[m - 1]}; peak along the time law, "
                                 f"{axis_name(int(p.speed_joint[j]))}; peak joint acceleration "
                                 f"{p.largest_acceleration[j]:.3g} rad/s^2"))
            if np.isfinite(arm.max_acceleration).any():
                rows.append(CheckRow("joint acceleration", *common, float(p.acceleration[j]),
                                     "of the limit", bool(p.acceleration[j] <= 1.0),
                                     f"from {labels[m - 1]}; peak along the time law, "
                                     f"{axis_name(int(p.acceleration_joint[j]))}; "
                                     f"{p.largest_acceleration[j]:.3g} rad/s^2"))
    return tuple(rows)


def slowed(program: RobotProgram) -> RobotProgram:
    """``program`` re-timed while a move is over a joint speed limit: each such segment's speed
    scale of the time law (:func:`~dloplan.robot.peaks.slowed_scale`) brings it to
    :data:`~dloplan.robot.peaks.SLOW_MARGIN` of the limit, up to :data:`SLOW_ROUNDS` times
    (the last timing is kept whatever its verdict: its speed rows say what is left).

    A program that fails a check the timing does not change (any but :data:`TIMED_CHECKS`: a
    target out of reach, a joint limit, a collision) is returned as it is: no timing saves it,
    and the joints it would slow for are not a motion the arm can make (at a pose out of reach
    they are IK's closest guess). Slowed, such a program made the refused plan's trajectory and
    cycle time its own (an unreachable Ethernet job: 100.6 s against the plan's 2.3 s)."""
    if any(row.check not in TIMED_CHECKS for row in program.failures):
        return program
    for _ in range(SLOW_ROUNDS):
        ratios = program.segment_speed_ratios()
        if not np.any(ratios > 1.0):
            break
        timing = program.trajectory
        program = program.retimed(timing.with_speed_scale(slowed_scale(timing, ratios)))
    return program
