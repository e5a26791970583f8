"""Statics (equilibrium, continuation, stabilization, target check) and the dynamic simulator."""

from .clips import HELD_INDICES, ClipPoses, clip_poses_from_shape, place_held_points
from .dynamics import ClipTrajectory, Simulation, settle, simulate
from .statics import (
    Equilibrium,
    TargetCheck,
    check_target,
    clip_wrenches,
    conform_guess,
    continuation,
    equilibrium,
    free_hessian,
    interpolate_clips,
    stabilize,
)

__all__ = [
    "HELD_INDICES",
    "ClipPoses",
    "ClipTrajectory",
    "Equilibrium",
    "Simulation",
    "TargetCheck",
    "check_target",
    "clip_wrenches",
    "clip_poses_from_shape",
    "conform_guess",
    "continuation",
    "equilibrium",
    "free_hessian",
    "interpolate_clips",
    "place_held_points",
    "settle",
    "simulate",
    "stabilize",
]
