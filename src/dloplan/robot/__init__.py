"""Robot feasibility of a plan for an ABB YuMi (IRB 14000): forward and inverse kinematics of
both 7-DoF arms (plain numpy on the URDF chain), joint limits, the gripper's TCP, arm-arm
clearance as capsules, per-pose reachability along a path and a search for the job's placement.

See ``docs/robot.md`` for the frames, the TCP mapping and what "reachable" means.
"""

from .collision import arm_capsules, arm_clearance, segment_distance
from .kinematics import (
    IKOptions,
    IKResult,
    forward,
    inverse,
    jacobian,
    joint_margin,
    link_frames,
    manipulability,
    reach,
    wrist_flip,
)
from .reachability import (
    Placement,
    Reachability,
    ReachOptions,
    check_path,
    check_reachability,
    search_placement,
    tcp_poses_from_clips,
)
from .yumi import ARMS, Arm, Gripper, Robot, yumi, yumi_arm

__all__ = [
    "ARMS",
    "Arm",
    "Gripper",
    "IKOptions",
    "IKResult",
    "Placement",
    "ReachOptions",
    "Reachability",
    "Robot",
    "arm_capsules",
    "arm_clearance",
    "check_path",
    "check_reachability",
    "forward",
    "inverse",
    "jacobian",
    "joint_margin",
    "link_frames",
    "manipulability",
    "reach",
    "search_placement",
    "segment_distance",
    "tcp_poses_from_clips",
    "wrist_flip",
    "yumi",
    "yumi_arm",
]
