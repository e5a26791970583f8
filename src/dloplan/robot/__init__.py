"""Robot side of a plan for an ABB YuMi (IRB 14000): forward and inverse kinematics of both
7-DoF arms (plain numpy on the URDF chain), joint limits, the gripper's TCP, arm-arm clearance
as capsules, per-pose reachability along a path and a search for the job's placement; the
robot cell (placement, SmartGripper tools, work object), the arm assignment, and the verified
robot program that the RAPID writer writes (:func:`robot_program`).

See ``docs/robot.md`` for the frames, the TCP mapping, the checks and how to run a program.
"""

from .armangle import arm_angle
from .assignment import ArmAssignment, assign_arms
from .cell import SMARTGRIPPER_SOURCE, RobotCell, Tool
from .chain import CellArm, capsules
from .collision import arm_clearance, segment_distance
from .confdata import confdata
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
from .program import CHECKS, CheckRow, RobotProgram, robot_program
from .reachability import (
    Placement,
    Reachability,
    ReachOptions,
    check_path,
    check_reachability,
    search_placement,
    tcp_poses_from_clips,
)
from .yumi import ARMS, Gripper, Robot, yumi, yumi_arm

__all__ = [
    "ARMS",
    "CellArm",
    "ArmAssignment",
    "CHECKS",
    "CheckRow",
    "Gripper",
    "IKOptions",
    "IKResult",
    "Placement",
    "ReachOptions",
    "Reachability",
    "Robot",
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
