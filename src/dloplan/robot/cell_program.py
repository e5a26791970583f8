"""The robot program of a plan on any cell, behind one interface.

Two kinds of cell run a plan: the YuMi's :class:`~dloplan.robot.cell.RobotCell` (its own
kinematics, arm angles, RAPID) and a :class:`~dloplan.robot.described.DescribedCell` (any two
arms from URDF). Both satisfy :class:`Cell`; :func:`make_program` makes the verified program
of either, and both programs satisfy :class:`Program`: the pipeline, the plan document, the
writers and the report use only that interface. This module is the one place that tells the
two kinds apart.

A :class:`CellProgram` is the verification of the plan's trajectory on a described cell
(:func:`~dloplan.robot.urdf_cell.verify_on_cell`: arm assignment by side, placement search,
IK tracked through sub-steps, joint limits, continuity, arm-arm and arm-table clearance), one
target per kept trajectory knot (a knot per shape), with the verified joints the URScript and
ROS 2 writers write, and the peak joint speeds and accelerations along the trajectory's time
law (:mod:`dloplan.robot.peaks`) against the arms' published limits; a segment over a joint
speed limit is slowed first, as on the YuMi. Both programs are a
:class:`~dloplan.robot.program_core.ProgramCore`: the verdict, its summary and failure text,
the dict they are written to, the speed rows and the slow-down are the same code for every
cell; what each program adds is how its targets are solved and what its writers are given.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np

from .cell import RobotCell
from .chain import capsules
from .checks import CheckRow
from .described import DescribedCell
from .motion import JointMotion
from .path import CHECKS
from .peaks import motion_peaks
from .program import robot_program
from .program_core import ProgramCore, slowed, speed_rows
from .urdf_cell import CellPlan, verify_on_cell

URSCRIPT_JOINTS = 6
"""Joints per arm of the arms a Universal Robots controller runs (URScript's ``movej``)."""


class Cell(Protocol):
    """What the pipeline needs of a cell: a name for messages, the table, and the frame in which
    the clip on the robot's left (larger y) goes to the left arm."""

    table_height: float

    def to_base(self, positions) -> np.ndarray: ...


class Program(Protocol):
    """What the pipeline, the plan document, the writers and the report need of a verified
    program (:class:`~dloplan.robot.program.RobotProgram`, :class:`CellProgram`, both on
    :class:`~dloplan.robot.program_core.ProgramCore`). A program whose ``formats`` has
    ``urscript`` also has ``urscript_arguments()`` and ``ur_rtde_arguments()``."""

    cell: Cell
    checks: tuple[CheckRow, ...]
    trajectory: object  # the Trajectory the program was verified with (maybe slowed)

    @property
    def ok(self) -> bool: ...

    @property
    def message(self) -> str: ...

    @property
    def failures(self) -> tuple[CheckRow, ...]: ...

    @property
    def formats(self) -> tuple[str, ...]: ...

    def summary(self) -> list[dict]: ...

    def knot_targets(self) -> np.ndarray: ...

    def to_dict(self) -> dict: ...

    def ros_joints_arguments(self) -> dict: ...

    def report_arms(self) -> dict: ...


def program_formats(cell) -> tuple[str, ...]:
    """The program formats a cell takes: ``rapid`` and ``ros_joints`` for the YuMi;
    ``ros_joints`` for any described cell, and ``ur_rtde`` (both arms streamed in lockstep,
    the program for a held cable) and ``urscript`` when both arms have
    :data:`URSCRIPT_JOINTS` joints (a Universal Robots controller runs no other arm)."""
    if isinstance(cell, RobotCell):
        return ("rapid", "ros_joints")
    six = all(arm.n_joints == URSCRIPT_JOINTS for arm in cell.arms)
    return ("ur_rtde", "urscript", "ros_joints") if six else ("ros_joints",)


def cell_name(cell) -> str:
    """A cell's name for messages (``yumi`` for the YuMi's RobotCell)."""
    return "yumi" if isinstance(cell, RobotCell) else cell.name


def make_program(cell, grippers, trajectory) -> Program:
    """The verified robot program of a plan on ``cell`` (either kind).

    Parameters
    ----------
    cell : RobotCell or DescribedCell
    grippers : GripperPath
        Clip poses at every shape (S + 2) [m].
    trajectory : Trajectory
        The timed motion of the same path (one knot per shape).
    """
    if isinstance(cell, RobotCell):
        return robot_program(grippers, trajectory, cell)
    if not isinstance(cell, DescribedCell):
        raise ValueError(f"cell: expected a RobotCell or a DescribedCell, got "
                         f"{type(cell).__name__}")
    return cell_program(cell, trajectory)


@dataclass(frozen=True, eq=False)
class CellProgram(ProgramCore):
    """A plan verified on a described cell: what the URScript and ROS 2 writers write.

    Attributes
    ----------
    plan : CellPlan
        Placement offset, arm assignment, knot times, TCP poses and the verdict.
    left_clip : int
        The clip the left arm holds (0: the cable's first end).
    checks : tuple of CheckRow
        The verdict's rows, labelled ``"shape k"``, then the joint speed and acceleration
        rows along the time law.
    trajectory : Trajectory or None
        The timing the program was verified with: the plan's, or slowed where a joint was
        over its speed limit.
    joint_speed : numpy.ndarray or None
        (K - 1, 2) per move and arm the peak joint speed along the time law as a fraction of
        the limit.
    """

    plan: CellPlan
    left_clip: int
    checks: tuple[CheckRow, ...]
    trajectory: object = None
    joint_speed: np.ndarray | None = None

    CHECKS = CHECKS

    @property
    def cell(self) -> DescribedCell:
        return self.plan.cell

    @property
    def times(self) -> np.ndarray:
        """(K,) time [s] of each target (a trajectory knot)."""
        return self.plan.times

    @property
    def joints(self) -> tuple[np.ndarray, np.ndarray]:
        """Per arm (K, n_arm) the verified joints [rad] at the targets."""
        return self.plan.verdict.joints

    @property
    def formats(self) -> tuple[str, ...]:
        """:func:`program_formats` of the cell."""
        return program_formats(self.cell)

    def joint_motion(self, trajectory) -> JointMotion:
        """Both arms' joints along the time law (:class:`~dloplan.robot.motion.JointMotion`):
        the move between two kept knots timed by ``trajectory``'s law (the plan's, which this
        program was verified on) of the segment that ends at the later one (the segments
        before it, between knots at the same instant, do not move); its path the tracked
        sub-steps (uniform in the move's parameter) from one target's verified joints to the
        next's."""
        law, plan = trajectory.law, self.plan
        verdict = plan.verdict
        segments = plan.shapes[1:] - 1
        paths = []
        for q, targets in zip(verdict.motion_joints, self.joints, strict=True):
            arm = []
            for j in range(len(segments)):
                first = np.searchsorted(verdict.motion_times, j, side="right") - 1
                last = np.searchsorted(verdict.motion_times, j + 1, side="right")
                arm.append(np.concatenate([targets[j][None], q[first + 1:last - 1],
                                           targets[j + 1][None]]))
            paths.append(tuple(arm))
        return JointMotion(tuple(paths), tuple(law.profiles[k] for k in segments),
                           law.starts[segments], law.knot_times[plan.shapes])

    def knot_targets(self) -> np.ndarray:
        """(K,) int: the target of each trajectory knot (a dropped knot, reached at the same
        instant as the one before it, is that knot's target)."""
        knots = np.arange(int(self.plan.shapes[-1]) + 1)
        return np.searchsorted(self.plan.shapes, knots, side="right") - 1

    @property
    def assignment_message(self) -> str:
        clips = ("first", "last")
        return (f"left arm holds the {clips[self.left_clip]} clip, right arm the "
                f"{clips[1 - self.left_clip]} (side rule in the cell's frame)")

    @property
    def message(self) -> str:
        """One line: the cell, the placement, and the verdict (the path's key numbers, or the
        first failure of every failing check, those along the time law included)."""
        shift = np.round(1e3 * self.plan.offset, 1).tolist()
        verdict = (self.plan.verdict.message if self.ok else
                   "cell FAILS: " + self.failure_text(lambda arm: f"{arm}: "))
        return f"{self.cell.name}: job shifted by {shift} mm; {verdict}"

    def segment_speed_ratios(self) -> np.ndarray:
        """(K - 1,) per segment of the trajectory the larger arm's peak joint speed as a
        fraction of the limit (0 for a dropped knot's segment: no arm moves)."""
        ratios = np.zeros(self.trajectory.n_knots - 1)
        ratios[self.plan.shapes[1:] - 1] = self.joint_speed.max(axis=1)
        return ratios

    def retimed(self, trajectory) -> CellProgram:
        """The same targets and joints timed by ``trajectory`` (the plan's trajectory, maybe
        slowed): the knot times, and the verdict's rows followed by the joint speed and
        acceleration rows along its time law (:func:`~dloplan.robot.program_core.
        speed_rows`)."""
        plan = replace(self.plan, times=trajectory.times[self.plan.shapes])
        cell = plan.cell
        timed = CellProgram(plan, self.left_clip, plan.verdict.rows, trajectory)
        peaks = motion_peaks(timed.joint_motion(trajectory),
                             [arm.max_velocity for arm in cell.arms],
                             [arm.max_acceleration for arm in cell.arms])
        labels = [f"shape {s}" for s in plan.shapes]
        rows = speed_rows(labels, plan.shapes, cell.arms, peaks, lambda j: f"joint {j + 1}")
        return replace(timed, checks=plan.verdict.rows + rows,
                       joint_speed=np.stack([p.speed for p in peaks], axis=1))

    def record(self) -> dict:
        """The cell, the placement, the assignment, the formats and the targets with their
        verified joints (:meth:`to_dict`)."""
        plan = self.plan
        rotvecs = plan.rotations.as_rotvec().reshape(-1, 2, 3)
        return {
            "cell": self.cell.name,
            "offset": plan.offset.tolist(),
            "assignment": {"left_clip": self.left_clip, "swapped": plan.swapped,
                           "message": self.assignment_message},
            "formats": list(self.formats),
            "targets": [{"label": f"shape {s}", "shape": int(s), "time": float(plan.times[k]),
                         "arms": {arm.name: {"position": plan.positions[k, a].tolist(),
                                             "rotvec": rotvecs[k, a].tolist(),
                                             "joints_deg": np.degrees(
                                                 self.joints[a][k]).tolist()}
                                  for a, arm in enumerate(self.cell.arms)}}
                        for k, s in enumerate(plan.shapes)],
        }

    def ros_joints_arguments(self) -> dict:
        """Keyword arguments of :func:`dloplan.io.ros_joints.write_joint_trajectories` after
        the folder and the timeline: the URDF joint names and the cell's ``ros_joints``
        settings."""
        return {"joint_names": [arm.joint_names for arm in self.cell.arms],
                **self.cell.writers.get("ros_joints", {})}

    def urscript_arguments(self) -> dict:
        """Keyword arguments of :func:`dloplan.io.urscript.write_urscript` after the folder:
        the verified joints and times, the TCP poses in each arm's base frame, each arm's
        ``set_tcp`` and the cell's ``urscript`` settings."""
        positions, rotvecs = self.plan.base_poses()
        tcp = [np.concatenate([arm.tcp_offset, arm.tcp_rotation.as_rotvec()])
               for arm in self.cell.arms]
        return {"times": self.times, "joints": list(self.joints), "tcp_positions": positions,
                "tcp_rotvecs": rotvecs, "tcp_offsets": tcp,
                **self.cell.writers.get("urscript", {})}

    def ur_rtde_arguments(self) -> dict:
        """Keyword arguments of :func:`dloplan.io.ur_rtde.write_ur_rtde` after the folder and
        the timeline: the cell's ``ur_rtde`` settings."""
        return dict(self.cell.writers.get("ur_rtde", {}))

    def report_arms(self) -> dict:
        """Keyword arguments of :func:`dloplan.plots.report.write_report` that draw both arms
        (their capsules at the verified joints) at every shape and along the tracked motion,
        in the plan's frame (moved back by the placement offset)."""
        plan, verdict = self.plan, self.plan.verdict
        n_shapes = int(plan.shapes[-1]) + 1
        knot = np.searchsorted(plan.shapes, np.arange(n_shapes), side="right") - 1
        motion_times = np.interp(verdict.motion_times, np.arange(len(plan.times)), plan.times)
        return {"arm_capsules": {
            "shapes": self._capsules([q[knot] for q in self.joints]),
            "radii": [capsules(arm, arm.home)[1].round(4).tolist() for arm in self.cell.arms],
            "motion": {"times": motion_times.round(4).tolist(),
                       "capsules": self._capsules(verdict.motion_joints),
                       "shape_times": plan.times[knot].round(4).tolist()}}}

    def _capsules(self, joints) -> list:
        """Per sample the list (left, right) of capsule end points [m] in the plan's frame."""
        ends = [(capsules(arm, q)[0] - self.plan.offset).round(5).tolist()
                for arm, q in zip(self.cell.arms, joints, strict=True)]
        return [list(pair) for pair in zip(*ends, strict=True)]


def cell_program(cell: DescribedCell, trajectory) -> CellProgram:
    """Verify a plan's timed trajectory on a described cell (:func:`verify_on_cell` with the
    cell's placement setting) as a :class:`CellProgram`: the verdict's rows, then per moving
    segment and arm the peak joint speed and (where the arm has published limits) joint
    acceleration along the time law. Segments over a joint speed limit are slowed
    (:func:`~dloplan.robot.program_core.slowed`); the joints' path does not change."""
    plan = verify_on_cell(cell, trajectory)
    arm_clips = tuple(trajectory.arm_clips)
    left_clip = arm_clips[1] if plan.swapped else arm_clips[0]
    return slowed(CellProgram(plan, int(left_clip), plan.verdict.rows).retimed(trajectory))


def placement_message(cell, grippers, trajectory) -> str:
    """Where on the table the cell runs a plan best (``dloplan verify --place``): the YuMi's
    grid search over shifts of the whole job (:func:`dloplan.robot.placement.search_placement`, the
    robot where the cell places it), or the
    described cell's (:func:`~dloplan.robot.placement.search_cell_placement`, verified along
    the timed trajectory); one line."""
    from scipy.spatial.transform import Rotation

    from .placement import search_placement

    if isinstance(cell, RobotCell):
        return search_placement(grippers.positions, Rotation.from_matrix(grippers.matrices),
                                cell.robot, options=cell.reach).message
    plan = verify_on_cell(cell, trajectory, place=True)
    shift = np.round(1e3 * plan.offset, 1).tolist()
    return f"{cell.name}: job shifted by {shift} mm; {plan.verdict.message}"


def reach_rows(cell, grippers) -> list[dict]:
    """Can the cell's arms hold the clips of a gripper path (before planning the motion)?
    Per pose ``reachable_left``, ``reachable_right``, ``joint_margin`` [rad] and ``error_left``,
    ``error_right`` (the IK's position error [m]: how far the arm's best try stays from the
    clip; ~0 when reached): for the YuMi where the cell places it, either arm at each pose
    (:func:`dloplan.robot.check_reachability`), for a described cell
    the arm assigned by side, tracked from pose to pose where the placement search puts
    the path."""
    from scipy.spatial.transform import Rotation

    from ..trajectory import dual_arm_trajectory
    from .reachability import check_reachability

    if isinstance(cell, RobotCell):
        reach = check_reachability(grippers.positions, Rotation.from_matrix(grippers.matrices),
                                   cell.robot, options=cell.reach)
        return [{"reachable_left": bool(reach.reachable[k, 0]),
                 "reachable_right": bool(reach.reachable[k, 1]),
                 "joint_margin": float(np.min(reach.joint_margin[k])),
                 "error_left": float(reach.position_error[k, 0]),
                 "error_right": float(reach.position_error[k, 1])}
                for k in range(len(grippers.positions))]
    plan = verify_on_cell(cell, dual_arm_trajectory(grippers.positions,
                                                    tuple(grippers.rotations)))
    verdict = plan.verdict
    knots = np.searchsorted(plan.shapes, np.arange(len(grippers.positions)), side="right") - 1
    return [{"reachable_left": bool(verdict.reachable[k, 0]),
             "reachable_right": bool(verdict.reachable[k, 1]),
             "joint_margin": float(np.min(verdict.joint_margin[k])),
             "error_left": float(verdict.position_error[k, 0]),
             "error_right": float(verdict.position_error[k, 1])} for k in knots]
