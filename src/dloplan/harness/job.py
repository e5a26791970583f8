"""One harness job end to end: phases, insertion, tensioning, one timed dual-arm program.

``run_harness(cable, start, board)`` plans phase 1 and phase 2 (:mod:`.phases`), simulates the
insertion and finds the tensioning offset (:mod:`.insertion`), computes the clip (TCP) frames of
both phases with the gripper methods of thesis 4.6 (phase 2 starting from phase 1's last
frames), appends the insertion and tensioning motions (pure translations), and times the whole
motion as **one** synchronized, jerk-limited dual-arm trajectory
(:func:`dloplan.trajectory.dual_arm_trajectory` through every knot; the arms stop at the end of
phase 1, at the fixtures' approach poses and in the slots, fly-by elsewhere when a zone is
given). The **cycle** (:func:`dloplan.trajectory.plan_cycle`) adds the gripper actions: a grasp
before phase 1, a regrasp in the slots (the fingers let go of the cable lying in the slots and
close on it again outside the fixtures before pulling) and a release after tensioning; the
cycle time is motion plus actions, broken down per phase. It is not compared with the thesis'
9 s (Table 7.3), a time measured on the robot whose ingredients (the robot's ramps, the
gripper actions, how the cable was picked up) are not given.
The plan document of the job (:func:`dloplan.pipeline.run_harness_job`) carries the cycle, and
every robot program written from it (the writers of :mod:`dloplan.app.writers`) carries its
gripper actions, the regrasp included.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..geometry import resample_by_arc_length
from ..grippers import GripperPath, gripper_path, relative_twist
from ..planning.result import ForceStatistics, stage_forces
from ..sim.clips import clip_poses_from_shape
from ..trajectory import (
    DEFAULT_GRASP_TIME,
    DEFAULT_MAX_ANGULAR_SPEED,
    DEFAULT_MAX_SPEED,
    DEFAULT_RELEASE_TIME,
    Cycle,
    GripperAction,
    MotionLimits,
    Trajectory,
    plan_cycle,
    trajectory_from_grippers,
)
from .board import Board, board_to_dict, check_board
from .insertion import Insertion, insert_and_tension
from .phases import Phases, fixture_clips, plan_phases

PHASES: tuple[str, ...] = ("phase1", "phase2", "insertion", "tensioning")


@dataclass(frozen=True)
class HarnessSettings:
    """Settings of a harness job (SI units).

    Parameters
    ----------
    n_shapes : tuple of int
        Intermediate shapes of phase 1 and phase 2.
    approach_height : float
        Phase 1 ends this far above the insertion pose [m].
    clearance : float
        Gap between the planned insertion pose and the pegs [m].
    contact_force : float
        Force of the pegs on the tensioned cable [N].
    min_tension : float
        Tension every inner link of the tensioned section carries at least [N] (> 0).
    max_axial_force : float
        Largest link tension allowed while tensioning [N].
    max_offset : float
        Largest pull-apart offset per arm [m].
    section_links : int or None
        Links of the insertion simulation; None: enough that a link is no longer than the
        smallest peg radius plus the cable radius (so a link cuts a peg by at most 13 % of
        that radius), at least 20.
    substeps : int
        Equilibria solved while lowering into the slots.
    max_speed, max_angular_speed : float
        TCP limits of the trajectory [m/s], [rad/s].
    limits : MotionLimits or None
        Acceleration and jerk limits (None: the YuMi defaults); its speeds are replaced by
        ``max_speed`` and ``max_angular_speed``.
    zone : float
        Fly-by zone radius [m] at the knots where the cable need not settle; 0: stop at all.
    grasp_time, release_time : float
        Durations of a grasp and a release [s]; the regrasp in the slots takes both.
    gripper_method : str
        Method of :func:`dloplan.grippers.gripper_path`.
    physical_mode : str
        Planner's physical stage mode.
    z_safety : float
        Obstacle avoidance lift margin [m].
    max_rounds : int
        Obstacle avoidance rounds.
    weights : dict or None
        Planner weight overrides.
    rated_load : float or None
        Largest tension the cable may carry [N]: the checks of the plan fail above it
        (:mod:`dloplan.harness.verification`); None: not checked.
    tensioning_speed : float
        Factor (0, 1] on the speeds of the tensioning motion (the repair's slower tensioning).
    """

    n_shapes: tuple[int, int] = (4, 4)
    approach_height: float = 0.08
    clearance: float = 0.005
    contact_force: float = 0.2
    min_tension: float = 0.01
    max_axial_force: float = 5.0
    max_offset: float = 0.05
    section_links: int | None = None
    substeps: int = 8
    max_speed: float = DEFAULT_MAX_SPEED
    max_angular_speed: float = DEFAULT_MAX_ANGULAR_SPEED
    limits: MotionLimits | None = None
    zone: float = 0.0
    grasp_time: float = DEFAULT_GRASP_TIME
    release_time: float = DEFAULT_RELEASE_TIME
    gripper_method: str = "auto"
    physical_mode: str = "equilibrium"
    z_safety: float = 0.02
    max_rounds: int = 5
    weights: dict | None = field(default=None, hash=False)
    rated_load: float | None = None
    tensioning_speed: float = 1.0


def section_links(cable: Cable, board: Board) -> int:
    """Default links of the insertion simulation (see :class:`HarnessSettings`)."""
    if not board.pegs:
        return max(20, cable.n_links)
    rho = min(p.radius for p in board.pegs) + cable.diameter / 2
    return max(20, cable.n_links, math.ceil(cable.length / rho))


@dataclass(frozen=True, eq=False)
class HarnessResult:
    """Everything a harness job computed.

    Attributes
    ----------
    cable : Cable
    board : Board
    phases : Phases
        The two planned phases (plans, avoidance, insertion pose).
    insertion : Insertion
        Insertion and tensioning (section equilibria, offset, forces).
    shapes : numpy.ndarray
        (K, n + 1, 3) the cable at every knot of the job [m]: phase 1's path, phase 2's path
        without its first shape (phase 1's last), the cable in the slots and tensioned (the
        last two rebuilt on n links from the section solution: the straight parts between
        the grippers and the fixtures plus the section).
    grippers : GripperPath
        Clip poses at the K knots (one path for the whole job).
    knots : dict
        Phase name -> (first, last) knot index, both included, in :data:`PHASES` order;
        consecutive phases share their boundary knot.
    trajectory : Trajectory
        The single timed dual-arm trajectory through the K knots.
    cycle : Cycle
        The motion with the gripper actions (grasp, regrasp in the slots, release).
    fixture_alignment : numpy.ndarray
        (2,) angle between each clip's u-axis and its fixture's axis at insertion [rad].
    forces : dict
        "phase1", "phase2" -> :class:`ForceStatistics` of the planned (weightless) shapes
        (thesis Figs. 7.29/7.31: mean and variance of |F_s| and |F_b| per mass point).
    timings : dict
        Wall time [s] per computation: "phase1", "phase2", "insertion", "total".
    warnings : tuple of str
    success : bool
        Phases planned, insertion and tensioning succeeded, gripper path without excess twist.
    message : str
        One line with the cycle time and the tensioning's forces and mechanism.
    rated_load : float or None
        The cable's rated load the checks use [N] (:class:`HarnessSettings`).
    """

    cable: Cable
    board: Board
    phases: Phases
    insertion: Insertion
    shapes: np.ndarray
    grippers: GripperPath
    knots: dict
    trajectory: Trajectory
    cycle: Cycle
    fixture_alignment: np.ndarray
    forces: dict
    timings: dict
    warnings: tuple[str, ...]
    success: bool
    message: str
    rated_load: float | None = None

    @property
    def cycle_time(self) -> float:
        """Duration of the whole job [s]: motion and gripper actions."""
        return self.cycle.cycle_time

    @property
    def motion_time(self) -> float:
        """Time the arms move [s]."""
        return self.trajectory.duration

    @property
    def offset(self) -> float:
        """Tensioning offset per arm [m]."""
        return self.insertion.offset

    def phase_times(self) -> dict:
        """Phase name -> (start, end) time on the trajectory's (motion) clock [s]."""
        t = self.trajectory.times
        return {name: (float(t[a]), float(t[b])) for name, (a, b) in self.knots.items()}


def force_statistics(cable: Cable, path) -> ForceStatistics:
    """Mean and variance across a path's shapes of |F_s| and |F_b| at each point (Fig. 7.29)."""
    axial, bending = stage_forces(cable, np.asarray(path, dtype=float))
    a, b = np.linalg.norm(axial, axis=-1), np.linalg.norm(bending, axis=-1)
    return ForceStatistics(a.mean(axis=0), a.var(axis=0), b.mean(axis=0), b.var(axis=0))


def _whole_cable(cable: Cable, section_shape: np.ndarray, tcp: np.ndarray,
                 axes: np.ndarray) -> np.ndarray:
    """The whole cable (n + 1, 3) from a section solution and the gripper clip points."""
    ends = tcp - 0.5 * cable.rest_link_length * axes
    polyline = np.vstack([ends[0], section_shape[1:-1], ends[1]])
    return resample_by_arc_length(polyline, cable.n_points)


def _joined_grippers(cable: Cable, phases: Phases, insertion: Insertion,
                     method: str) -> tuple[GripperPath, list[str]]:
    first = gripper_path(phases.path1, method=method, cable=cable)
    initial = Rotation.concatenate([r[-1:] for r in first.rotations])
    second = gripper_path(phases.path2, method=method, cable=cable, initial=initial)
    last = second.positions[-1]
    positions = np.concatenate([first.positions, second.positions[1:],
                                (last + insertion.gripper_moves[0])[None],
                                (last + insertion.gripper_moves.sum(axis=0))[None]])
    rotations = tuple(
        Rotation.concatenate([first.rotations[c], second.rotations[c][1:],
                              second.rotations[c][-1:], second.rotations[c][-1:]])
        for c in (0, 1)
    )
    twist = relative_twist(*rotations)
    worst = float(np.max(np.abs(twist)))
    success = first.success and second.success
    warnings = [f"phase 1 grippers: {w}" for w in first.warnings]
    warnings += [f"phase 2 grippers: {w}" for w in second.warnings]
    message = (f"{first.method} frames; largest relative twist {math.degrees(worst):.1f} "
               "degrees over the job")
    joined = GripperPath(positions, rotations, first.method, twist, tuple(warnings), success,
                         message, first.max_twist)
    return joined, warnings


def held_before_planning(start: np.ndarray, board: Board) -> list[tuple[str, np.ndarray, str]]:
    """The clip points a harness job holds that are known before it is planned: the start,
    the fixtures' approach points (where phase 2 ends) and their slots (where the insertion
    ends); phase 1's end and the tensioned poses follow from planning.

    Returns
    -------
    list of (str, numpy.ndarray, str)
        Where (the job's field and the phase), the (2, 3) clip points [m], and what would hold
        them farther apart: the arguments of ``check_held`` (:func:`run_harness`).
    """
    return [("start (where phase 1 starts)", clip_poses_from_shape(start).positions,
             "a longer cable, or a start whose ends lie farther apart"),
            ("harness.fixtures (where phase 2 ends: their approach points, position + "
             "depth * opening)", fixture_clips(board).positions, "fixtures farther apart"),
            ("harness.fixtures (where the insertion ends: their slots, position)",
             fixture_clips(board, inserted=True).positions, "fixtures farther apart")]


def run_harness(
    cable: Cable,
    start,
    board: Board,
    settings: HarnessSettings | None = None,
    *,
    gravity=GRAVITY,
    check_held: Callable[[str, np.ndarray, str], None] | None = None,
) -> HarnessResult:
    """Run a whole harness job (module docstring; thesis 7.3).

    Parameters
    ----------
    cable : Cable
        The cable (its ``n_links`` is the planning discretization).
    start : array_like
        (k, 3) start shape [m].
    board : Board
        The harness board.
    settings : HarnessSettings, optional
    gravity : array_like
        Gravity [m/s^2].
    check_held : callable, optional
        ``check_held(where, clips, remedy)``, called with every phase's held clip points (2, 3)
        [m] as soon as they are known, ``where`` naming the phase and the job's fields that
        put them there, ``remedy`` what would hold them farther apart; it raises ValueError for
        clips the robot cannot hold (the grippers' distance,
        :func:`dloplan.pipeline.stages.check_held_clips`). Called for the start and the
        fixtures' approach points and slots before any planning, for phase 1's end before it is
        planned (:func:`~.phases.plan_phases`), and for the tensioned poses once the tensioning
        found its offset.

    Raises
    ------
    ValueError
        Before any planning, for a board the cable cannot be used on (:func:`check_board`) or
        bad settings; from ``check_held``.
    """
    t0 = time.perf_counter()
    s = settings or HarnessSettings()
    if not isinstance(s, HarnessSettings):
        raise ValueError(f"settings: got {type(s).__name__}, expected HarnessSettings")
    check_board(board, cable)
    if not board.pegs:
        raise ValueError("board: no pegs; a harness job tensions the cable against pegs")
    if check_held is not None:
        for where, clips, remedy in held_before_planning(start, board):
            check_held(where, clips, remedy)
    links = s.section_links if s.section_links is not None else section_links(cable, board)
    phases = plan_phases(cable, start, board, s.n_shapes, approach_height=s.approach_height,
                         clearance=s.clearance, weights=s.weights, physical_mode=s.physical_mode,
                         z_safety=s.z_safety, max_rounds=s.max_rounds, gravity=gravity,
                         section_links=links, check_held=check_held)
    t1 = time.perf_counter()
    insertion = insert_and_tension(
        cable, phases.path2[-1], board, contact_force=s.contact_force,
        min_tension=s.min_tension, max_axial_force=s.max_axial_force, max_offset=s.max_offset,
        n_links=links, substeps=s.substeps, gravity=gravity, section=phases.section)
    t2 = time.perf_counter()
    grippers, gripper_warnings = _joined_grippers(cable, phases, insertion, s.gripper_method)
    if check_held is not None and insertion.success:
        check_held(f"harness.tension (where the tensioning ends: the clips pulled "
                   f"{1e3 * insertion.offset:.1f} mm per arm out of the slots, along minus "
                   "harness.fixtures' axis)", grippers.positions[-1],
                   "fixtures whose axes do not point away from each other")
    axes = fixture_clips(board, inserted=True).u_axes
    inserted_shape = _whole_cable(cable, insertion.inserted.shape, grippers.positions[-2], axes)
    tensioned_shape = _whole_cable(cable, insertion.tensioned.equilibrium.shape,
                                   grippers.positions[-1], axes)
    shapes = np.concatenate([phases.path1, phases.path2[1:], inserted_shape[None],
                             tensioned_shape[None]])
    k1 = len(phases.path1) - 1
    k2 = k1 + len(phases.path2) - 1
    knots = {"phase1": (0, k1), "phase2": (k1, k2), "insertion": (k2, k2 + 1),
             "tensioning": (k2 + 1, k2 + 2)}
    left_clip = 0 if grippers.positions[0, 0, 1] >= grippers.positions[0, 1, 1] else 1
    last = len(shapes) - 1
    settle = [k for k in (k1, k2, k2 + 1) if 0 < k < last]
    if not (math.isfinite(s.tensioning_speed) and 0 < s.tensioning_speed <= 1):
        raise ValueError(f"settings.tensioning_speed: got {s.tensioning_speed!r}, expected a "
                         "factor in (0, 1]")
    scale = np.ones(last)
    scale[k2 + 1] = s.tensioning_speed  # the segment from the slots to the pulled poses
    trajectory = trajectory_from_grippers(grippers, max_speed=s.max_speed,
                                          max_angular_speed=s.max_angular_speed,
                                          limits=s.limits, zone=s.zone, stops=settle,
                                          left_clip=left_clip,
                                          speed_scale=None if s.tensioning_speed == 1 else scale)
    actions = [GripperAction("grasp", 0, s.grasp_time),
               GripperAction.regrasp_at(k2 + 1, s.release_time, s.grasp_time),
               GripperAction("release", last, s.release_time)]
    cycle = plan_cycle(trajectory, actions, knots)
    u_at_insertion = grippers.u_axes[k2]
    alignment = np.arccos(np.clip(np.einsum("kj,kj->k", u_at_insertion, axes), -1.0, 1.0))
    forces = {"phase1": force_statistics(cable, phases.path1),
              "phase2": force_statistics(cable, phases.path2)}
    warnings = list(phases.warnings) + gripper_warnings
    if not insertion.success:
        warnings.append(f"tensioning: {insertion.message}")
    success = phases.success and insertion.success and grippers.success
    message = f"{cycle.describe()} at {1e3 * s.max_speed:g} mm/s; {insertion.message}"
    if not success:
        message = f"{warnings[0] if warnings else 'a step failed'}; {message}"
    timings = {"phase1": phases.timings["phase1"], "phase2": phases.timings["phase2"],
               "insertion": t2 - t1, "total": time.perf_counter() - t0}
    return HarnessResult(cable, board, phases, insertion, shapes, grippers, knots, trajectory,
                         cycle, alignment, forces, timings, tuple(warnings), success, message,
                         s.rated_load)


def harness_summary(result: HarnessResult) -> dict:
    """The job's numbers as a JSON-ready dict (for ``dloplan plan``'s output and reports)."""
    ins = result.insertion
    stats = {
        name: {key: getattr(f, key).tolist() for key in
               ("axial_mean", "axial_variance", "bending_mean", "bending_variance")}
        for name, f in result.forces.items()
    }
    return {
        "success": result.success,
        "message": result.message,
        "cycle_time": result.cycle_time,
        "motion_time": result.motion_time,
        "action_time": result.cycle.action_time,
        "cycle": result.cycle.breakdown(),
        "phase_times": result.phase_times(),
        "knots": result.knots,
        "offset": None if math.isnan(ins.offset) else ins.offset,
        "peg_forces": ins.tensioned.peg_forces.tolist(),
        "max_tension": ins.tensioned.max_tension,
        "min_tension": ins.tensioned.min_tension,
        "peg_force_mechanism": ins.tensioned.mechanism,
        "pull_forces": ins.tensioned.pull_forces.tolist(),
        "penetration": ins.penetration,
        "link_penetration": ins.link_penetration,
        "fixture_alignment_deg": np.degrees(result.fixture_alignment).tolist(),
        "approach": result.phases.approach_kind,
        "phase2": result.phases.phase2_kind,
        "avoidance": {"status": result.phases.avoidance.status,
                      "rounds": result.phases.avoidance.rounds},
        "forces": stats,
        "timings": result.timings,
        "warnings": list(result.warnings),
        "board": board_to_dict(result.board),
        "section_links": ins.tensioned.section.n_links,
        "sections": {"approach": ins.lowering[0].shape.tolist(),
                     "inserted": ins.inserted.shape.tolist(),
                     "tensioned": ins.tensioned.equilibrium.shape.tolist()},
        "regrasp_time": result.cycle.breakdown().get("regrasp", 0.0),
        "rated_load": result.rated_load,
    }
