"""Two-phase planning of a harness job (thesis 7.3.1, Fig. 7.27).

* **Insertion pose** (the end of phase 2): both clips at their fixture's approach point (the
  slot's position plus the insertion depth along its opening), each clip's u-axis along its
  fixture's axis (thesis 7.3.1: "the gripper holding that portion must be aligned with the
  fixture"). The shape between the clips is computed, not drawn: the weightless minimal-energy
  shape (:func:`dloplan.sim.statics.equilibrium` with gravity 0, the planner's own notion of a
  target, thesis 4.5.1) started from a route guess that passes each peg on its ``side``, with
  the pegs as one-sided contacts whose radius is grown by ``clearance``. So the shape carries
  the curvature the pegs impose and keeps that gap to them; where the free elastica would cross
  a peg, the peg bends it.
* **Phase 1** (:func:`approach_shape`): from the start shape to a shape ``approach_height``
  above the board that already carries that curvature: a planar circular arc of the cable's
  length whose tangent turns by the same total angle as the insertion pose's (in the horizontal
  plane), its middle point above the insertion pose's middle point, its middle tangent along
  the insertion pose's middle tangent. The planner (:func:`dloplan.planning.plan`) plans it;
  obstacle avoidance (:func:`dloplan.obstacles.avoid_obstacles`, thesis 5.4) stabilizes every
  shape under gravity, checks it against the obstacles, pegs, plates and table, and re-plans
  around collisions with the same planner.
* **Phase 2**: the planner again, from phase 1's last shape (the same array: the transition is
  continuous) to the insertion pose. The insertion pose is already a minimal-energy shape, so
  the target pre-processing is off (it would ignore the pegs). Its planned shapes are checked
  against the board and collisions are reported as warnings.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..frames import frame_from_axis
from ..geometry import arc_length, as_shape, resample_by_arc_length
from ..obstacles import Avoidance, Cylinder, avoid_obstacles, check_path
from ..planning import Plan, plan
from ..shapes import arc_shape
from ..sim.clips import ClipPoses, clip_poses_from_shape
from ..sim.statics import Equilibrium, check_target, equilibrium, interpolate_clips
from .board import Board, check_board
from .section import follow_path, section_cable, section_shape, whole_shape

WEIGHTLESS = np.zeros(3)


def fixture_clips(board: Board, inserted: bool = False) -> ClipPoses:
    """Clip poses at the fixtures: u-axes along the fixture axes, z-axes toward the openings.

    ``inserted=False``: at the approach points (before the downward insertion motion);
    ``inserted=True``: in the slots.
    """
    positions = np.stack([np.asarray(f.position) if inserted else f.approach
                          for f in board.fixtures])
    rotations = Rotation.concatenate([
        frame_from_axis(f.axis, up=f.opening) for f in board.fixtures
    ])
    return ClipPoses(positions, rotations)


def route_guess(board: Board, cable: Cable, clips: ClipPoses, clearance: float) -> np.ndarray:
    """A starting shape (n + 1, 3) for the insertion pose: the held points and, between them,
    one point beside each peg on its side, ``2 (clearance + cable radius)`` off its surface."""
    held = clips.held_points(cable.rest_link_length)
    z = float(np.mean(clips.positions[:, 2]))
    via = []
    for peg in board.route_pegs():
        offset = peg.radius + 2.0 * (clearance + cable.diameter / 2)
        point = np.asarray(peg.base) + offset * np.asarray(peg.side)
        via.append([point[0], point[1], z])
    polyline = np.vstack([held[:2], np.reshape(via, (-1, 3)), held[2:]])
    return resample_by_arc_length(polyline, cable.n_points)


def insertion_pose(
    cable: Cable, board: Board, clearance: float = 0.005, *, guess=None
) -> Equilibrium:
    """The shape at the end of phase 2, just above the fixtures (module docstring).

    Parameters
    ----------
    cable : Cable
        The cable.
    board : Board
        The board (:func:`check_board` is run first).
    clearance : float
        Gap kept between the cable's surface and the pegs [m].
    guess : array_like, optional
        (n + 1, 3) starting shape [m]; default :func:`route_guess`.

    Returns
    -------
    Equilibrium
        The weightless equilibrium with the clips at the fixtures' approach poses; its
        ``penetration`` is measured against the grown pegs.
    """
    check_board(board, cable)
    if not (math.isfinite(clearance) and clearance >= 0):
        raise ValueError(f"clearance: got {clearance!r}, expected a gap >= 0 [m]")
    clips = fixture_clips(board)
    x0 = route_guess(board, cable, clips, clearance) if guess is None else as_shape(
        guess, cable.n_points, "guess")
    # pegs grown by the clearance and tall enough to be met at the approach height
    tall = cable.length + float(np.max(clips.positions[:, 2]))
    routing = [Cylinder(p.base, p.radius + clearance, max(p.height, tall - p.base[2]), p.name)
               for p in board.pegs]
    return equilibrium(cable, x0, clips, gravity=WEIGHTLESS, contacts=routing)


def _heading_turn(x: np.ndarray) -> float:
    """Total signed turning [rad] of the horizontal projection of a polyline's links."""
    d = np.diff(x, axis=0)
    headings = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    return float(headings[-1] - headings[0])


def _at_half_length(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The point at half the arc length of a polyline and the unit tangent there."""
    s = arc_length(x)
    half = 0.5 * s[-1]
    k = int(np.clip(np.searchsorted(s, half) - 1, 0, len(x) - 2))
    t = (half - s[k]) / (s[k + 1] - s[k])
    tangent = x[k + 1] - x[k]
    return x[k] + t * tangent, tangent / np.linalg.norm(tangent)


def _insertion_shape(cable: Cable, insertion, height: float) -> np.ndarray:
    """The insertion pose as an (n + 1, 3) shape [m], with the approach height checked."""
    x = as_shape(insertion, cable.n_points, "insertion")
    if not (math.isfinite(height) and height > 0):
        raise ValueError(f"approach_height: got {height!r}, expected a height > 0 [m]")
    return x


def taut_approach(cable: Cable, insertion: np.ndarray, height: float) -> np.ndarray:
    """Phase 1's target for a cable that cannot carry the arc: the cable straight and level,
    ``height`` above the insertion pose's middle point, across the route's front, (n + 1, 3)
    [m] (module docstring).

    Its middle point is above the insertion pose's; it runs horizontally perpendicular to the
    direction from the fixtures' chord middle (the pose's two clip points) to that point, its
    first point on the side of the pose's first clip. Held taut, a soft cable sags by
    (3 w L^3 / (64 E A))^(1/3) at most (its weight w per length stretching it) and keeps its
    place; pulled back to the fixtures in phase 2 it is bent around the pegs' sides.

    Parameters
    ----------
    cable : Cable
        The cable (length and n).
    insertion : array_like
        (n + 1, 3) the insertion pose [m].
    height : float
        How far above the insertion pose's middle point the line lies [m].
    """
    x = _insertion_shape(cable, insertion, height)
    mid, _ = _at_half_length(x)
    clips = clip_poses_from_shape(x).positions
    front = mid - 0.5 * (clips[0] + clips[1])
    front[2] = 0.0
    if np.linalg.norm(front) < 1e-9 * cable.length:  # a straight route: along its chord
        along = clips[1] - clips[0]
    else:
        along = np.cross([0.0, 0.0, 1.0], front)
        if along @ (clips[1] - clips[0]) < 0:
            along = -along
    along[2] = 0.0
    along /= np.linalg.norm(along)
    s = np.linspace(-0.5, 0.5, cable.n_points)[:, None] * cable.length
    return mid + s * along + np.array([0.0, 0.0, height])


def approach_shape(cable: Cable, insertion: np.ndarray, height: float) -> np.ndarray:
    """Phase 1's target: a horizontal arc carrying the insertion pose's curvature, ``height``
    above it (module docstring), (n + 1, 3) [m].

    Parameters
    ----------
    cable : Cable
        The cable (length and n).
    insertion : array_like
        (n + 1, 3) the insertion pose [m].
    height : float
        How far above the insertion pose's middle point the arc's middle point lies [m].
    """
    x = _insertion_shape(cable, insertion, height)
    arc = arc_shape(cable.length, cable.n_links, _heading_turn(x))
    arc_mid, arc_tangent = _at_half_length(arc)
    mid, tangent = _at_half_length(x)
    yaw = math.atan2(tangent[1], tangent[0]) - math.atan2(arc_tangent[1], arc_tangent[0])
    turned = Rotation.from_euler("z", yaw).apply(arc - arc_mid)
    return turned + mid + np.array([0.0, 0.0, height])


@dataclass(frozen=True, eq=False)
class Phases:
    """The two planned phases of a harness job.

    Attributes
    ----------
    insertion : Equilibrium
        The insertion pose (phase 2's target) as solved.
    approach : numpy.ndarray
        (n + 1, 3) phase 1's proposed target [m] (the arc or the taut line, before
        pre-processing).
    plan1, plan2 : Plan
        The planner's results of phase 1 and phase 2 (a settled phase 2 may take its clip
        poses, :func:`settled_phase2`).
    avoidance : Avoidance
        Obstacle avoidance of phase 1 (its ``path`` is phase 1's path).
    path1, path2 : numpy.ndarray
        (S1 + 2, n + 1, 3) and (S2 + 2, n + 1, 3) the paths of the phases [m] (the avoidance's
        and the planner's; both settled after a taut approach, :func:`settled_phase2`);
        ``path2[0]`` is ``path1[-1]``.
    timings : dict
        Wall time [s] of "phase1" (planning and avoidance) and "phase2".
    warnings : tuple of str
        Planner warnings, avoidance failures, phase-2 collisions.
    success : bool
        Both plans succeeded, avoidance succeeded and the insertion pose converged.
    message : str
        One line.
    approach_kind : str
        ``"arc"`` or ``"taut"`` (:func:`approach_target`).
    phase2_kind : str
        ``"planned"`` (the planner's shapes) or ``"settled (... clip route)"``
        (:func:`settled_phase2`, after a taut approach).
    section : numpy.ndarray or None
        (n_s + 1, 3) a settled phase 2's section at the approach poses [m] (what the insertion
        starts from), else None.
    """

    insertion: Equilibrium
    approach: np.ndarray
    plan1: Plan
    plan2: Plan
    avoidance: Avoidance
    path1: np.ndarray
    path2: np.ndarray
    timings: dict
    warnings: tuple[str, ...]
    success: bool
    message: str
    approach_kind: str = "arc"
    phase2_kind: str = "planned"
    section: np.ndarray | None = None


CARRY_TOLERANCE = 0.01
"""Largest sag [m] of the arc (settled under gravity, its clips held) for which the cable
carries it to the board: the thesis' T_cf of a stable target (5.3)."""


def approach_target(cable: Cable, insertion: np.ndarray, height: float,
                    gravity=GRAVITY) -> tuple[np.ndarray, str]:
    """Phase 1's target and its kind: the arc (:func:`approach_shape`, ``"arc"``) when the
    cable carries it, i.e. settled under gravity with its clips held no point moves more than
    :data:`CARRY_TOLERANCE` (the thesis' target stability, 5.3); else the cable laid taut across
    the route (:func:`taut_approach`, ``"taut"``): a soft cable cannot hold the curvature in the
    air, and the pegs give it."""
    arc = approach_shape(cable, insertion, height)
    if check_target(arc, cable, threshold=CARRY_TOLERANCE, gravity=gravity).stable:
        return arc, "arc"
    return taut_approach(cable, insertion, height), "taut"


@dataclass(frozen=True, eq=False)
class SettledPhase2:
    """Result of :func:`settled_phase2`.

    Attributes
    ----------
    path1 : numpy.ndarray
        (S1 + 2, n + 1, 3) phase 1's shapes as the cable rests at its clip poses [m].
    path : numpy.ndarray
        (S + 2, n + 1, 3) phase 2's shapes on the planning's links, the first phase 1's last
        [m].
    section : numpy.ndarray
        (n_s + 1, 3) the section at the fixtures' approach poses as reached [m].
    route : str
        The clip route taken: ``"planned"`` (the planner's clip poses) or ``"straight"``.
    distance : float
        Largest point distance between the section reached and the insertion pose as it rests
        [m].
    """

    path1: np.ndarray
    path: np.ndarray
    section: np.ndarray
    route: str
    distance: float


def settled_phase2(cable: Cable, path1, planned, insertion, board: Board, section_links: int,
                   gravity=GRAVITY) -> SettledPhase2:
    """Phase 2 with gravity and the board (module docstring): the cable's shapes its equilibria
    with gravity and the board's contacts as the clips move, on the first clip route that
    brings it to the insertion pose as it rests.

    The cable is followed as the section of ``section_links`` links
    (:func:`dloplan.harness.section.follow_path`): settled at phase 1's first clip poses, through
    phase 1's knots (phase 1's shapes become these equilibria: the avoidance's are stabilized
    on the planning's coarser links), then phase 2's. Two clip routes are tried, in this
    order: the planner's (the clip poses of ``planned``, its last the fixtures' approach poses)
    and straight lines (linear positions, slerped frames) in as many steps. A route is taken
    when the section it reaches at the approach poses is within :data:`CARRY_TOLERANCE` of the
    insertion pose as it rests there (the weightless pose settled with gravity and the
    contacts); else the closer one. Each equilibrium is brought back to the planning's links
    with its end links on the clips (:func:`~dloplan.harness.section.whole_shape`).

    Parameters
    ----------
    cable : Cable
    path1 : array_like
        (S1 + 2, n + 1, 3) phase 1's shapes [m].
    planned : array_like
        (S + 2, n + 1, 3) the planner's phase 2 [m].
    insertion : array_like
        (n + 1, 3) the insertion pose [m].
    board : Board
    section_links : int
    gravity : array_like
        Gravity [m/s^2].
    """
    path1 = np.asarray(path1, dtype=float)
    section = section_cable(cable, section_links)
    contacts = board.contacts()
    approach = fixture_clips(board)
    rest = follow_path(section, section_shape(insertion, cable, section), [approach], contacts,
                       gravity).shapes[-1]
    clips1 = [clip_poses_from_shape(x) for x in path1]
    first = follow_path(section, section_shape(path1[0], cable, section), clips1, contacts,
                        gravity).shapes
    x = first[-1]
    count = len(planned)
    routes = {"planned": [clip_poses_from_shape(y) for y in planned[:-1]] + [approach],
              "straight": interpolate_clips(clips1[-1], approach, np.linspace(0.0, 1.0, count))}
    best = None
    for route, poses in routes.items():
        settled = follow_path(section, x, poses, contacts, gravity).shapes
        distance = float(np.max(np.linalg.norm(settled[-1] - rest, axis=1)))
        if best is None or distance < best[2]:
            best = (route, poses, distance, settled)
        if distance <= CARRY_TOLERANCE:
            break
    route, poses, distance, settled = best
    path1 = np.stack([whole_shape(cable, shape, pose)
                      for shape, pose in zip(first, clips1, strict=True)])
    path = np.stack([path1[-1]] + [whole_shape(cable, shape, pose)
                                   for shape, pose in zip(settled[1:], poses[1:], strict=True)])
    return SettledPhase2(path1, path, settled[-1], route, distance)


def plan_phases(
    cable: Cable,
    start,
    board: Board,
    n_shapes: tuple[int, int] = (4, 4),
    *,
    approach_height: float = 0.08,
    clearance: float = 0.005,
    weights=None,
    physical_mode: str = "equilibrium",
    z_safety: float = 0.02,
    max_rounds: int = 5,
    gravity=GRAVITY,
    section_links: int = 40,
    map: Callable = map,
    check_held: Callable[[str, np.ndarray, str], None] | None = None,
) -> Phases:
    """Plan phase 1 (to above the board, avoiding obstacles) and phase 2 (to the fixtures).

    Parameters
    ----------
    cable : Cable
        The cable.
    start : array_like
        (k, 3) start shape [m] (resampled to n + 1 points by the planner).
    board : Board
        The harness board (checked by :func:`check_board` before anything is planned).
    n_shapes : tuple of int
        Intermediate shapes S of phase 1 and of phase 2.
    approach_height : float
        Height of phase 1's end above the insertion pose [m].
    clearance : float
        Gap between the planned insertion pose and the pegs [m].
    weights, physical_mode
        Passed to :func:`dloplan.planning.plan`.
    z_safety, max_rounds
        Obstacle avoidance settings (thesis 5.4.3: 2 cm).
    gravity : array_like
        Gravity [m/s^2] for the stabilization of the avoidance and a settled phase 2.
    section_links : int
        Links of the section a settled phase 2 is followed with (:func:`settled_phase2`).
    map : callable
        Passed to the planner.
    check_held : callable, optional
        ``check_held(where, clips, remedy)``, called with phase 1's end's clip points (2, 3)
        [m] before phase 1 is planned (:func:`dloplan.harness.run_harness`).
    """
    check_board(board, cable)
    counts = tuple(n_shapes)
    if len(counts) != 2 or any(isinstance(s, bool) or int(s) != s or s < 1 for s in counts):
        raise ValueError(f"n_shapes: got {n_shapes!r}, expected two integers >= 1")
    warnings: list[str] = []
    t0 = time.perf_counter()
    insertion = insertion_pose(cable, board, clearance)
    if not insertion.success:
        warnings.append(f"insertion pose: {insertion.message}")
    approach, approach_kind = approach_target(cable, insertion.shape, approach_height, gravity)
    if check_held is not None:
        check_held(f"harness.approach_height (where phase 1 ends: the {approach_kind} approach "
                   "above the board, turning as the insertion pose between harness.fixtures "
                   "around harness.pegs)", clip_poses_from_shape(approach).positions,
                   "fixtures farther apart, or pegs that turn the cable less")
    options = dict(weights=weights, physical_mode=physical_mode, map=map)
    plan1 = plan(cable, start, approach, int(counts[0]), **options)
    warnings += [f"phase 1: {w}" for w in plan1.warnings]

    def replan(a, b, k):
        return plan(cable, a, b, k, preprocess=False, **options).path

    avoidance = avoid_obstacles(cable, plan1.path, board.collision_volumes(), replan,
                                z_safety=z_safety, max_rounds=max_rounds, gravity=gravity)
    if not avoidance.success:
        warnings.append(f"phase 1 obstacle avoidance: {avoidance.message}")
    t1 = time.perf_counter()
    path1 = avoidance.path
    plan2 = plan(cable, path1[-1], insertion.shape, int(counts[1]), preprocess=False, **options)
    warnings += [f"phase 2: {w}" for w in plan2.warnings]
    path2, section, phase2_kind = plan2.path, None, "planned"
    if approach_kind == "taut":
        settled = settled_phase2(cable, path1, plan2.path, insertion.shape, board,
                                 section_links, gravity)
        path1, path2, section = settled.path1, settled.path, settled.section
        phase2_kind = f"settled ({settled.route} clip route)"
        if settled.distance > CARRY_TOLERANCE:
            warnings.append(f"phase 2: the cable comes to rest {1e3 * settled.distance:.1f} mm "
                            "from the insertion pose as it rests (tolerance "
                            f"{1e3 * CARRY_TOLERANCE:.0f} mm) on either clip route")
        for report in check_path(path1[1:-1], board.collision_volumes(), cable.diameter / 2):
            if report.colliding:  # the avoidance checked the coarser stabilized shapes
                warnings.append(f"phase 1, shape {report.shape_index + 1} (settled): "
                                f"{report.describe().split(': ', 1)[1]}")
    else:
        for report in check_path(path2[1:-1], board.collision_volumes(), cable.diameter / 2):
            if report.colliding:
                warnings.append(f"phase 2, shape {report.shape_index + 1} (planned): "
                                f"{report.describe().split(': ', 1)[1]}")
    t2 = time.perf_counter()
    success = plan1.success and plan2.success and avoidance.success and insertion.success
    message = ("planned both phases" if success else warnings[0] if warnings
               else "a planning stage did not succeed")
    return Phases(insertion, approach, plan1, plan2, avoidance, path1, path2,
                  {"phase1": t1 - t0, "phase2": t2 - t1}, tuple(warnings), success, message,
                  approach_kind, phase2_kind, section)
