"""Robot side of a plan: dual-arm cells from descriptions (:class:`DescribedCell`: the UR5e and
Panda pairs from URDF, the ABB YuMi, :func:`yumi`), forward and inverse kinematics of their arms
(plain numpy on the chain, the IK's solve compiled), joint limits, TCPs, arm-arm clearance as
capsules, the path checks and the placement searches; the YuMi's plug-in (its RAPID cell with
SmartGripper tools and work object, arm angle, confdata) and the one verified robot program of every
cell that the writers write (:class:`RobotProgram`, :func:`robot_program`).

See ``docs/robot.md`` for the frames, the TCP mapping, the checks and how to run a program.
"""

from ..geometry import segment_distance
from .armangle import arm_angle
from .assignment import ArmAssignment, assign_arms
from .cell import SMARTGRIPPER_SOURCE, RobotCell, Tool
from .chain import CellArm, capsules
from .checks import CheckRow
from .collision import arm_clearance
from .confdata import confdata
from .described import DescribedCell
from .kinematics import (
    IKOptions,
    IKResult,
    forward,
    inverse,
    jacobian,
    joint_margin,
    link_frames,
    manipulability,
    solve_from,
    solve_many,
    wrist_flip,
)
from .path import PathCheck, ReachOptions, check_path
from .placement import Placement, search_placement
from .plugins import robot_program
from .program import RobotProgram
from .reachability import Reachability, check_reachability, tcp_poses_from_clips
from .yumi import ARMS, Gripper, yumi, yumi_arm
from .yumi_program import CHECKS

__all__ = [
    "ARMS",
    "CellArm",
    "ArmAssignment",
    "CHECKS",
    "CheckRow",
    "DescribedCell",
    "Gripper",
    "IKOptions",
    "IKResult",
    "PathCheck",
    "Placement",
    "ReachOptions",
    "Reachability",
    "RobotCell",
    "RobotProgram",
    "SMARTGRIPPER_SOURCE",
    "Tool",
    "arm_angle",
    "capsules",
    "arm_clearance",
    "assign_arms",
    "check_path",
    "check_reachability",
    "confdata",
    "forward",
    "inverse",
    "jacobian",
    "joint_margin",
    "link_frames",
    "manipulability",
    "robot_program",
    "search_placement",
    "segment_distance",
    "solve_from",
    "solve_many",
    "tcp_poses_from_clips",
    "wrist_flip",
    "yumi",
    "yumi_arm",
]
