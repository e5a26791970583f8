"""Which plug-in a cell takes: the one entry to a plan's robot program on any cell.

Two kinds of cell run a plan: the YuMi's :class:`~dloplan.robot.cell.RobotCell` (its
description, :func:`dloplan.robot.yumi.yumi`, with the arm angle's plug-in data, and its RAPID
settings) and a :class:`~dloplan.robot.described.DescribedCell` (any two arms from URDF). Both
programs are the one :class:`~dloplan.robot.program.RobotProgram`; what differs is made by the
cell's plug-in, chosen here and nowhere else:

- the YuMi's (:mod:`dloplan.robot.yumi_program`): targets solved with the arm angle held,
  confdata, the controller's round trip, the replayed MoveL; written as RAPID and ROS 2;
- a described cell's (:mod:`dloplan.robot.tracked_program`): IK tracked along the trajectory
  where the placement search puts the job; written as URScript, ur_rtde and ROS 2.

:func:`robot_program` makes the program; :func:`program_formats`, :func:`cell_name`,
:func:`placement_message` and :func:`reach_rows` answer the same per kind of cell for the CLI,
the plan document and the pipeline.
"""

from __future__ import annotations

import numpy as np

from .cell import RobotCell
from .described import DescribedCell
from .program import RobotProgram
from .tracked_program import tracked_formats, tracked_program
from .urdf_cell import verify_on_cell
from .yumi_program import YumiTargets, yumi_program


def program_formats(cell) -> tuple[str, ...]:
    """The program formats a cell takes: ``rapid`` and ``ros_joints`` for the YuMi
    (:attr:`~dloplan.robot.yumi_program.YumiTargets.formats`); a described cell's
    :func:`~dloplan.robot.tracked_program.tracked_formats`."""
    return YumiTargets.formats if isinstance(cell, RobotCell) else tracked_formats(cell)


def cell_name(cell) -> str:
    """A cell's name for messages (``yumi`` for the YuMi's RobotCell)."""
    return "yumi" if isinstance(cell, RobotCell) else cell.name


def robot_program(grippers, trajectory, cell=None, *, verdict_only: bool = False,
                  round_trips_on_demand: bool = False, held=None) -> RobotProgram:
    """The verified robot program of a plan on ``cell`` (either kind), made by its plug-in.

    Parameters
    ----------
    grippers : GripperPath
        Clip poses at every shape (S + 2) [m], the work frame.
    trajectory : Trajectory
        The timed motion of the same path (one knot per shape).
    cell : RobotCell or DescribedCell, optional
        Default :class:`~dloplan.robot.cell.RobotCell` (the YuMi at the work frame's origin,
        SmartGripper tools).
    verdict_only : bool
        Only the verdict and the first failure are wanted: the YuMi's program may stop at its
        first failing target (:func:`~dloplan.robot.yumi_program.yumi_program`); a described
        cell's is complete.
    round_trips_on_demand : bool
        A program that fails is wanted complete only when it is written or printed: the
        YuMi's may judge its passing round trips at less cost and leave them to
        :meth:`~dloplan.robot.program.RobotProgram.completed`
        (:func:`~dloplan.robot.yumi_program.yumi_program`); a described cell's is complete.
    held : HeldArms, optional
        The arms already hold the cable at the first target
        (:class:`~dloplan.robot.program.HeldArms`: the remaining motion of a corrected plan):
        the program starts from their joints, with the plan's assignment (and on a described
        cell its placement).

    Raises
    ------
    ValueError
        A cell of neither kind; inputs that do not belong together (the YuMi's plug-in:
        :func:`~dloplan.robot.yumi_program.yumi_program`).
    """
    if cell is None or isinstance(cell, RobotCell):
        return yumi_program(grippers, trajectory, cell, verdict_only=verdict_only,
                            round_trips_on_demand=round_trips_on_demand, held=held)
    if not isinstance(cell, DescribedCell):
        raise ValueError(f"cell: expected a RobotCell or a DescribedCell, got "
                         f"{type(cell).__name__}")
    return tracked_program(cell, trajectory, held)


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
