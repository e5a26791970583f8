"""Is this plan safe to run? Elastic stability, snap-through, dynamic replay, the table.

Reading order: :mod:`.stability` (eigenvalues of the held cable's stiffness; :mod:`.lowest`
follows the smallest along a continuation), :mod:`.snap`
(quasi-static continuation between planned clip poses), :mod:`.replay` (the timed plan simulated
at real speed), :mod:`.report` (one row per shape, with robot reachability when given).
"""

from .replay import Replay, as_clip_trajectory, replay
from .report import Reachability, ShapeRow, Verification, as_reachability, verify_path
from .snap import SegmentContinuation, SnapCheck, SnapEvent, check_snap_through, clip_motion
from .stability import (
    Stability,
    elastic_stability,
    path_stability,
    smallest_eigenpairs,
    stiffness_scale,
)

__all__ = [
    "Reachability",
    "Replay",
    "SegmentContinuation",
    "ShapeRow",
    "SnapCheck",
    "SnapEvent",
    "Stability",
    "Verification",
    "as_clip_trajectory",
    "as_reachability",
    "check_snap_through",
    "clip_motion",
    "elastic_stability",
    "path_stability",
    "replay",
    "smallest_eigenpairs",
    "stiffness_scale",
    "verify_path",
]
