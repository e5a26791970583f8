"""The described cells' plug-in of the robot program: targets solved by IK tracked along the
plan's trajectory, written as URScript, ur_rtde and ROS 2 joint trajectories.

:func:`tracked_program` verifies a plan's trajectory on a
:class:`~dloplan.robot.described.DescribedCell` (:func:`~dloplan.robot.urdf_cell.
verify_on_cell`: arm assignment by side, placement search, IK tracked through sub-steps, joint
limits, continuity, arm-arm and arm-table clearance), one target per kept trajectory knot (a
knot per shape), as the one :class:`~dloplan.robot.program.RobotProgram` whose ``targets`` are
a :class:`TrackedTargets`: the verified joints the URScript and ROS 2 writers write, and the
peak joint speeds and accelerations along the trajectory's time law
(:mod:`dloplan.robot.peaks`) against the arms' published limits; a segment over a joint speed
limit is slowed first, as on the YuMi (:func:`~dloplan.robot.program.slowed`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .chain import capsules
from .described import DescribedCell
from .path import CHECKS
from .program import HeldArms, RobotProgram, slowed
from .urdf_cell import CellPlan, verify_on_cell

URSCRIPT_JOINTS = 6
"""Joints per arm of the arms a Universal Robots controller runs (URScript's ``movej``)."""


def tracked_formats(cell: DescribedCell) -> tuple[str, ...]:
    """The program formats a described cell takes: ``ros_joints``, and ``ur_rtde`` (both arms
    streamed in lockstep, the program for a held cable) and ``urscript`` when both arms have
    :data:`URSCRIPT_JOINTS` joints (a Universal Robots controller runs no other arm)."""
    six = all(arm.n_joints == URSCRIPT_JOINTS for arm in cell.arms)
    return ("ur_rtde", "urscript", "ros_joints") if six else ("ros_joints",)


@dataclass(frozen=True, eq=False)
class TrackedTargets:
    """A described cell's plug-in of a :class:`~dloplan.robot.program.RobotProgram`: one
    target per kept trajectory knot.

    Attributes
    ----------
    plan : CellPlan
        Placement offset, arm assignment, knot times, TCP poses and the verdict (its rows
        labelled ``"shape k"``).
    left_clip : int
        The clip the left arm holds (0: the cable's first end).
    """

    plan: CellPlan
    left_clip: int

    CHECKS = CHECKS

    @property
    def formats(self) -> tuple[str, ...]:
        """:func:`tracked_formats` of the cell."""
        return tracked_formats(self.plan.cell)

    @property
    def labels(self) -> tuple[str, ...]:
        """(K,) ``"shape k"`` of each target."""
        return tuple(f"shape {s}" for s in self.plan.shapes)

    @property
    def shapes(self) -> np.ndarray:
        """(K,) int: the plan's shape (trajectory knot) of each target."""
        return self.plan.shapes

    @property
    def times(self) -> np.ndarray:
        """(K,) time [s] of each target (a trajectory knot)."""
        return self.plan.times

    @property
    def move_segments(self) -> np.ndarray:
        """(K - 1,) int: the trajectory segment each move is, the one that ends at its target
        (the segments before it, between knots at the same instant, do not move)."""
        return self.plan.shapes[1:] - 1

    @staticmethod
    def axis_name(joint: int) -> str:
        """A joint by its number along the chain (1 at the base)."""
        return f"joint {joint + 1}"

    def knot_targets(self) -> np.ndarray:
        """(K,) int: the target of each trajectory knot (a dropped knot, reached at the same
        instant as the one before it, is that knot's target)."""
        knots = np.arange(int(self.plan.shapes[-1]) + 1)
        return np.searchsorted(self.plan.shapes, knots, side="right") - 1

    def move_timing(self, cell, trajectory) -> tuple:
        """The profiles, starts [s] and arrivals [s] of the moves
        (:class:`~dloplan.robot.motion.JointMotion`): each move timed by ``trajectory``'s law
        of the segment that ends at its target."""
        law, segments = trajectory.law, self.move_segments
        return (tuple(law.profiles[k] for k in segments), law.starts[segments],
                law.knot_times[self.plan.shapes])

    def timed(self, cell, trajectory) -> TrackedTargets:
        """The same targets at ``trajectory``'s knot times."""
        return replace(self, plan=replace(self.plan, times=trajectory.times[self.plan.shapes]))

    @property
    def assignment_message(self) -> str:
        clips = ("first", "last")
        return (f"left arm holds the {clips[self.left_clip]} clip, right arm the "
                f"{clips[1 - self.left_clip]} (side rule in the cell's frame)")

    def message(self, program) -> str:
        """One line: the cell, the placement, and the verdict (the path's key numbers, or the
        first failure of every failing check, those along the time law included)."""
        shift = np.round(1e3 * self.plan.offset, 1).tolist()
        verdict = (self.plan.verdict.message if program.ok else
                   "cell FAILS: " + program.failure_text(lambda arm: f"{arm}: "))
        return f"{self.plan.cell.name}: job shifted by {shift} mm; {verdict}"

    def record(self, program) -> dict:
        """The cell, the placement, the assignment, the formats and the targets with their
        verified joints."""
        plan = self.plan
        rotvecs = plan.rotations.as_rotvec().reshape(-1, 2, 3)
        return {
            "cell": plan.cell.name,
            "offset": plan.offset.tolist(),
            "assignment": {"left_clip": self.left_clip, "swapped": plan.swapped,
                           "message": self.assignment_message},
            "formats": list(self.formats),
            "targets": [{"label": f"shape {s}", "shape": int(s), "time": float(plan.times[k]),
                         "arms": {arm.name: {"position": plan.positions[k, a].tolist(),
                                             "rotvec": rotvecs[k, a].tolist(),
                                             "joints_deg": np.degrees(
                                                 program.joints[a][k]).tolist()}
                                  for a, arm in enumerate(plan.cell.arms)}}
                        for k, s in enumerate(plan.shapes)],
        }

    def writer_arguments(self, program, name: str) -> dict:
        """``ros_joints``: the URDF joint names and the cell's ``ros_joints`` settings;
        ``urscript``: the verified joints and times, the TCP poses in each arm's base frame,
        each arm's ``set_tcp`` and the cell's ``urscript`` settings; ``ur_rtde``: the cell's
        ``ur_rtde`` settings."""
        cell = self.plan.cell
        if name not in self.formats:
            raise ValueError(f"{name}: the cell {cell.name!r} takes {', '.join(self.formats)}")
        if name == "ros_joints":
            return {"joint_names": [arm.joint_names for arm in cell.arms],
                    **cell.writers.get("ros_joints", {})}
        if name == "urscript":
            positions, rotvecs = self.plan.base_poses()
            tcp = [np.concatenate([arm.tcp_offset, arm.tcp_rotation.as_rotvec()])
                   for arm in cell.arms]
            return {"times": self.times, "joints": list(program.joints),
                    "tcp_positions": positions, "tcp_rotvecs": rotvecs, "tcp_offsets": tcp,
                    **cell.writers.get("urscript", {})}
        return dict(cell.writers.get("ur_rtde", {}))

    def report_arms(self, program) -> dict:
        """Both arms (their capsules at the verified joints) at every shape and along the
        tracked motion, in the plan's frame (moved back by the placement offset)."""
        plan, verdict = self.plan, self.plan.verdict
        n_shapes = int(plan.shapes[-1]) + 1
        knot = np.searchsorted(plan.shapes, np.arange(n_shapes), side="right") - 1
        motion_times = np.interp(verdict.motion_times, np.arange(len(plan.times)), plan.times)
        return {"arm_capsules": {
            "shapes": self._capsules([q[knot] for q in program.joints]),
            "radii": [capsules(arm, arm.home)[1].round(4).tolist() for arm in plan.cell.arms],
            "motion": {"times": motion_times.round(4).tolist(),
                       "capsules": self._capsules(verdict.motion_joints),
                       "shape_times": plan.times[knot].round(4).tolist()}}}

    def _capsules(self, joints) -> list:
        """Per sample the list (left, right) of capsule end points [m] in the plan's frame."""
        ends = [(capsules(arm, q)[0] - self.plan.offset).round(5).tolist()
                for arm, q in zip(self.plan.cell.arms, joints, strict=True)]
        return [list(pair) for pair in zip(*ends, strict=True)]


def tracked_moves(plan: CellPlan) -> tuple:
    """Per arm, per move the joints (n + 1, n_arm) [rad] from one target's verified joints
    through the tracked sub-steps (uniform in the move's parameter) to the next's."""
    verdict = plan.verdict
    moves = []
    for q, targets in zip(verdict.motion_joints, verdict.joints, strict=True):
        arm = []
        for j in range(len(plan.shapes) - 1):
            first = np.searchsorted(verdict.motion_times, j, side="right") - 1
            last = np.searchsorted(verdict.motion_times, j + 1, side="right")
            arm.append(np.concatenate([targets[j][None], q[first + 1:last - 1],
                                       targets[j + 1][None]]))
        moves.append(tuple(arm))
    return tuple(moves)


def tracked_program(cell: DescribedCell, trajectory, held: HeldArms | None = None) -> RobotProgram:
    """Verify a plan's timed trajectory on a described cell (:func:`verify_on_cell` with the
    cell's placement setting) as a :class:`~dloplan.robot.program.RobotProgram`: the
    verdict's rows, then per moving segment and arm the peak joint speed and (where the arm
    has published limits) joint acceleration along the time law. Segments over a joint speed
    limit are slowed (:func:`~dloplan.robot.program.slowed`); the joints' path does not
    change. ``held``: the arms hold the cable at the first knot (``verify_on_cell``'s)."""
    plan = verify_on_cell(cell, trajectory, held=held)
    arm_clips = tuple(trajectory.arm_clips)
    left_clip = arm_clips[1] if plan.swapped else arm_clips[0]
    program = RobotProgram(cell, TrackedTargets(plan, int(left_clip)), plan.verdict.joints,
                           tracked_moves(plan), plan.verdict.rows)
    return slowed(program.retimed(trajectory))
