"""Timed dual-arm TCP trajectories (:mod:`.core`), their time law (:mod:`.timelaw`), motion
limits with YuMi defaults (:mod:`.limits`) and the cycle with gripper actions (:mod:`.cycle`)."""

from .core import (
    ARMS,
    LAWS,
    ArmRotations,
    Kinematics,
    Trajectory,
    TrajectorySamples,
    dual_arm_trajectory,
    interpolate_poses,
    sample_times,
    segment_motion,
    trajectory_from_grippers,
)
from .cycle import (
    DEFAULT_GRASP_TIME,
    DEFAULT_RELEASE_TIME,
    Cycle,
    GripperAction,
    Phase,
    plan_cycle,
)
from .limits import (
    DEFAULT_MAX_ACCELERATION,
    DEFAULT_MAX_ANGULAR_ACCELERATION,
    DEFAULT_MAX_ANGULAR_JERK,
    DEFAULT_MAX_ANGULAR_SPEED,
    DEFAULT_MAX_JERK,
    DEFAULT_MAX_SPEED,
    MotionLimits,
)
from .timelaw import ZONE_LEVER, Profile, TimeLaw, jerk_limited_law

__all__ = [
    "ARMS",
    "DEFAULT_GRASP_TIME",
    "DEFAULT_MAX_ACCELERATION",
    "DEFAULT_MAX_ANGULAR_ACCELERATION",
    "DEFAULT_MAX_ANGULAR_JERK",
    "DEFAULT_MAX_ANGULAR_SPEED",
    "DEFAULT_MAX_JERK",
    "DEFAULT_MAX_SPEED",
    "DEFAULT_RELEASE_TIME",
    "LAWS",
    "ZONE_LEVER",
    "ArmRotations",
    "Cycle",
    "GripperAction",
    "Kinematics",
    "MotionLimits",
    "Phase",
    "Profile",
    "TimeLaw",
    "Trajectory",
    "TrajectorySamples",
    "dual_arm_trajectory",
    "interpolate_poses",
    "jerk_limited_law",
    "plan_cycle",
    "sample_times",
    "segment_motion",
    "trajectory_from_grippers",
]
