"""Clip routes that keep the cable on a stable equilibrium branch (snap-through repairs).

Between two planned shapes the robot moves both clips linearly (slerp in rotation), and the cable
follows its equilibrium branch quasi-statically (:mod:`dloplan.verify.snap`). When that branch
folds or loses stability the cable snaps; when the motion stays on another branch than the
planner's shape, the plan shows a shape the cable never takes. The repairs of one segment s
(shape A -> shape B):

**Follow the stable branch** (:func:`follow_branch`): continue quasi-statically from the planned
shape A along the planned clip poses of the rest of the path
(:func:`dloplan.sim.statics.continuation`, warm start after warm start) and take the equilibria
reached as the remaining shapes: the plan then shows what the cable does. The last one must lie
within T_cf of the planned target (thesis 5.3): the target is never moved beyond its tolerance.

**Re-route the clips** (:func:`routes`, :func:`route_segment`): other clip motions from A's clip
poses to B's, through waypoints whose shapes are stabilized equilibria reached by continuation,
checked with the verification's own snap-through continuation
(:func:`dloplan.verify.check_snap_through`):

* *rotate first*: the cable is carried rigidly into B's orientation (the best rigid motion of
  A's clip frames onto B's, turned about A's centre in steps of at most :data:`MAX_TURN`), then
  translated and bent into B: a curved hose turned while it keeps its shape does not buckle;
* *translate first*: the clips are carried rigidly to B's centre, turned there in steps, then
  bent;
* *rotate last*: the cable is bent into B's shape where A lies (B's clip frames moved rigidly
  back onto A's centre and orientation), then turned and carried into B.

A route is kept when its continuation has no event and ends within the tolerance of B.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ...cable import Cable
from ...sim.clips import ClipPoses
from ...sim.statics import continuation
from ...verify import check_snap_through, clip_motion
from ...verify.stability import elastic_stability

MAX_TURN = math.radians(30.0)
"""Largest rotation [rad] of one rigid step of a route (below the 45 deg frame-flip check)."""

CONTINUATION_STEP = 0.02
"""Largest clip motion of one continuation sub-step while building shapes, as a fraction of L."""


def substeps(cable: Cable, poses) -> int:
    """Continuation sub-steps per leg so that no sub-step moves a clip more than
    :data:`CONTINUATION_STEP` L (clip motion as in :func:`dloplan.verify.clip_motion`)."""
    legs = [clip_motion(a, b, cable.length) for a, b in zip(poses[:-1], poses[1:], strict=True)]
    return max(1, math.ceil(max(legs, default=0.0) / (CONTINUATION_STEP * cable.length)))


def equilibria_along(cable: Cable, shape: np.ndarray, poses) -> tuple[np.ndarray, bool]:
    """The equilibria reached from ``shape`` (at ``poses[0]``) at each later pose, warm-started.

    Returns the (len(poses) - 1, n + 1, 3) shapes [m] and whether every solve converged.
    """
    eqs = continuation(cable, shape, list(poses), substeps=substeps(cable, poses))[1:]
    return np.stack([e.shape for e in eqs]), all(e.converged for e in eqs)


def max_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Largest point-to-point distance between two shapes [m]."""
    return float(np.max(np.linalg.norm(a - b, axis=-1)))


@dataclass(frozen=True, eq=False)
class Branch:
    """Outcome of :func:`follow_branch`.

    Attributes
    ----------
    shapes : numpy.ndarray
        (k, n + 1, 3) the equilibria reached at the planned poses after shape s [m].
    success : bool
        Every one converged and stable, and the last within ``tolerance`` of the planned end.
    end_error : float
        Distance of the last from the planned end [m].
    message : str
    """

    shapes: np.ndarray
    success: bool
    end_error: float
    message: str


def follow_branch(cable: Cable, shape: np.ndarray, poses, end: np.ndarray,
                  tolerance: float) -> Branch:
    """Follow the equilibrium branch from ``shape`` along the planned ``poses`` (the first is
    the pose of ``shape``); the last equilibrium must be within ``tolerance`` [m] of ``end``."""
    shapes, converged = equilibria_along(cable, shape, poses)
    unstable = [k for k, x in enumerate(shapes) if not elastic_stability(cable, x, k=1).stable]
    error = max_distance(shapes[-1], end)
    if not converged or unstable:
        why = "a solve did not converge" if not converged else \
            f"the equilibrium at pose {unstable[0] + 1} is not stable"
        return Branch(shapes, False, error, f"the branch is lost: {why}")
    if error > tolerance:
        return Branch(shapes, False, error, f"the branch ends {1e3 * error:.1f} mm from the "
                      f"planned end (tolerance {1e3 * tolerance:.1f} mm)")
    return Branch(shapes, True, error, f"followed the stable branch over {len(shapes)} "
                  f"pose(s); it ends {1e3 * error:.1f} mm from the planned end")


def _frame_vectors(clips: ClipPoses, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Centre of the two clips and vectors that pin their frames (points along u, w axes)."""
    centre = clips.positions.mean(axis=0)
    m = clips.rotations.as_matrix()
    rel = clips.positions - centre
    return centre, np.concatenate([rel, rel + reach * m[:, :, 0], reach * m[:, :, 2]])


def rigid_motion(a: ClipPoses, b: ClipPoses, reach: float) -> tuple[Rotation, np.ndarray,
                                                                      np.ndarray]:
    """The rigid motion that best carries clips ``a`` onto clips ``b``: x -> R (x - c_a) + c_b.

    Least squares over the clip points, points ``reach`` [m] along their u-axes and their
    w-axes (scaled by ``reach``); returns (R, c_a, c_b).
    """
    ca, va = _frame_vectors(a, reach)
    cb, vb = _frame_vectors(b, reach)
    rotation, _ = Rotation.align_vectors(vb, va)
    return rotation, ca, cb


def moved(clips: ClipPoses, rotation: Rotation, centre: np.ndarray,
          to: np.ndarray) -> ClipPoses:
    """Clips turned by ``rotation`` about ``centre`` and carried to ``to``."""
    return ClipPoses(rotation.apply(clips.positions - centre) + to, rotation * clips.rotations)


def _turns(rotation: Rotation) -> list[Rotation]:
    count = max(1, math.ceil(rotation.magnitude() / MAX_TURN))
    vec = rotation.as_rotvec()
    return [Rotation.from_rotvec(vec * i / count) for i in range(1, count + 1)]


def routes(a: ClipPoses, b: ClipPoses, reach: float) -> list[tuple[str, list[ClipPoses]]]:
    """Waypoints of the alternative clip routes from ``a`` to ``b`` (module docstring)."""
    rotation, ca, cb = rigid_motion(a, b, reach)
    back = moved(b, rotation.inv(), cb, ca)
    return [
        ("rotate first", [moved(a, r, ca, ca) for r in _turns(rotation)]),
        ("translate first", [moved(a, r, ca, cb) for r in [Rotation.identity(),
                                                             *_turns(rotation)]]),
        ("rotate last", [back] + [moved(back, r, ca, ca) for r in _turns(rotation)]),
    ]


@dataclass(frozen=True, eq=False)
class Route:
    """A checked clip route of one segment.

    Attributes
    ----------
    name : str
    poses : list of ClipPoses
        The waypoints (without the segment's ends).
    shapes : numpy.ndarray
        (len(poses) + 1, n + 1, 3) the equilibria at the waypoints and at the segment's end [m].
    success : bool
        No snap-through event along the route, and the end within the tolerance.
    end_error : float
        Distance of the end from the planned shape B [m].
    message : str
    """

    name: str
    poses: list
    shapes: np.ndarray
    success: bool
    end_error: float
    message: str


def route_segment(cable: Cable, shape: np.ndarray, a: ClipPoses, waypoints, b: ClipPoses,
                  end: np.ndarray, tolerance: float, name: str = "route") -> Route:
    """Move the clips from ``a`` (holding ``shape``) through ``waypoints`` to ``b``; check it.

    The waypoint shapes are equilibria reached by continuation; the whole route is then checked
    by :func:`dloplan.verify.check_snap_through` (each leg from its waypoint shape), and its end
    must be within ``tolerance`` [m] of ``end`` (the planned shape B).
    """
    poses = [a, *waypoints, b]
    shapes, converged = equilibria_along(cable, shape, poses)
    check = check_snap_through(cable, np.concatenate([shape[None], shapes]), poses)
    error = max_distance(shapes[-1], end)
    if not converged:
        return Route(name, list(waypoints), shapes, False, error,
                     f"{name}: an equilibrium along the route did not converge")
    if not check.ok:
        return Route(name, list(waypoints), shapes, False, error,
                     f"{name}: {check.events[0].message}")
    ok = error <= tolerance
    return Route(name, list(waypoints), shapes, ok, error,
                 f"{name}: {len(waypoints)} waypoint(s), no snap-through, ends "
                 f"{1e3 * error:.1f} mm from the planned shape"
                 + ("" if ok else f" (tolerance {1e3 * tolerance:.1f} mm)"))
