"""Where the job lies on the table: the placement search of ``dloplan verify --place`` as a repair.

A placement is a horizontal rigid motion of the job (start and target: the operator puts the
cable there; the obstacles stay where they are in the world, and a placement whose shapes
collide with them is not kept, :func:`obstacle_collisions`): a turn by ``yaw`` about the
vertical axis through the job's centre, then a translation ``offset``, :class:`TableMove`. The
cable model is invariant under both (uniform gravity along -z, the table a horizontal plane,
thesis eq. 3.1-3.8 involve only differences of points and the height), so the plan of the moved
job is the moved plan: :func:`moved_document` moves the document instead of planning again (the
shapes, the planner's stages, the gripper frames, the clip wrenches) and makes its robot program
again in the job's robot cell (the arm assignment, IK, limits, clearance and continuity of the
moved targets, :func:`dloplan.robot.robot_program`). :func:`placements` turns the job by each of
:data:`YAWS` and, at each turn, searches a translation with the reachability check of the YuMi
at the work frame's origin (:func:`dloplan.robot.search_placement`, both arm assignments); the
program confirms it.

Turning helps where shifting cannot: a job laid along the robot's x-axis (both clips on the
centre line, thesis Fig. 4.8) puts one arm's clip in front of the other's, and a target turned
about the vertical (thesis qualitative test 1) can leave a wrist at its limit at every shift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial.transform import Rotation

from ...grippers.path import GripperPath
from ...obstacles.collisions import check_path
from ...robot.path import ReachOptions
from ...robot.placement import format_offset
from ..document import PlacementSection
from ..stages import collision_rows
from .rebuild import left_clip, timed, timed_with_robot, without_robot

SEARCHES = ((0.2, 0.05, "nearest"),)
"""The placement searches tried in turn: half-width [m] of the square searched on the table
(at the job's height), grid spacing [m], and which working offset wins (the nearest to the job's
own placement, or the one with the largest joint margin). A search that repeats an earlier
search's placement yields nothing."""

YAWS = tuple(math.radians(a) for a in (0.0, 30.0, -30.0, 60.0, -60.0, 90.0, -90.0))
"""Turns of the job about the vertical [rad] tried by :func:`placements`, smallest first."""


@dataclass(frozen=True, eq=False)
class TableMove:
    """A horizontal rigid motion of the job: x -> R_z(yaw) (x - pivot) + pivot + offset.

    Attributes
    ----------
    offset : numpy.ndarray
        (3,) translation [m] (its z is kept 0 by the searches: the job stays at its height).
    yaw : float
        Turn about the vertical through ``pivot`` [rad].
    pivot : numpy.ndarray
        (3,) a point of the vertical axis [m] (the centre of the clip points).
    """

    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    yaw: float = 0.0
    pivot: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        for name in ("offset", "pivot"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (3,) or not np.all(np.isfinite(value)):
                raise ValueError(f"TableMove.{name}: expected 3 finite coordinates [m], got "
                                 f"{getattr(self, name)!r}")
            object.__setattr__(self, name, value)
        if not math.isfinite(self.yaw):
            raise ValueError(f"TableMove.yaw: expected a finite angle [rad], got {self.yaw!r}")

    @property
    def rotation(self) -> Rotation:
        """R_z(yaw)."""
        return Rotation.from_rotvec([0.0, 0.0, self.yaw])

    def points(self, x) -> np.ndarray:
        """Points (..., 3) [m] moved."""
        x = np.asarray(x, dtype=float)
        flat = self.rotation.apply(x.reshape(-1, 3) - self.pivot) + self.pivot + self.offset
        return flat.reshape(x.shape)

    def vectors(self, v) -> np.ndarray:
        """Free vectors (..., 3) turned (forces, moments, directions)."""
        v = np.asarray(v, dtype=float)
        return self.rotation.apply(v.reshape(-1, 3)).reshape(v.shape)

    @property
    def is_identity(self) -> bool:
        """No turn and no translation."""
        return self.yaw == 0.0 and not np.any(self.offset)

    def then(self, other: TableMove) -> TableMove:
        """This move followed by ``other``, as one move (about the origin when both move)."""
        if other.is_identity or self.is_identity:
            return self if other.is_identity else other
        turn = other.rotation
        offset = turn.apply(self.offset + self.pivot - self.rotation.apply(self.pivot)
                            - other.pivot) + other.pivot + other.offset
        return TableMove(offset, self.yaw + other.yaw)

    def describe(self) -> str:
        """One line: the offset and, when turned, the yaw."""
        if self.is_identity:
            return "at its own place"
        parts = []
        if self.yaw:
            parts.append(f"turned {math.degrees(self.yaw):.0f} deg about the vertical through "
                         f"{format_offset(self.pivot)} m")
        if np.any(self.offset):
            parts.append(f"offset {format_offset(self.offset)} m")
        return ", ".join(parts)


def placement_section(move: TableMove, applied: bool) -> PlacementSection:
    """The plan document's record of a placement: made (``applied``) or proposed."""
    where = (f"the job file's start and target {move.describe()}"
             + (" (turn first, then the offset)" if move.yaw and np.any(move.offset) else ""))
    return PlacementSection(applied, float(move.yaw), move.pivot.copy(), move.offset.copy(),
                            where)


def moved_job(job, move: TableMove):
    """The job moved by ``move``: start, target and the gripper settings' world directions
    (auxiliary vector, initial frames). The obstacles stay where they are in the world: a
    placement is checked against them (:func:`obstacle_collisions`)."""
    turn = move.rotation
    grippers = replace(job.grippers, auxiliary_vector=move.vectors(job.grippers.auxiliary_vector),
                       initial=None if job.grippers.initial is None
                       else turn * job.grippers.initial)
    return replace(job, start=move.points(job.start), target=move.points(job.target),
                   grippers=grippers)


def translated_job(job, offset):
    """The job translated by ``offset`` (3,) [m] (:func:`moved_job` without a turn)."""
    return moved_job(job, TableMove(offset))


def moved_grippers(grippers: GripperPath, move: TableMove) -> GripperPath:
    """Gripper frames moved by ``move`` (a turn about the vertical keeps their relative twist)."""
    turn = move.rotation
    return replace(grippers, positions=move.points(grippers.positions),
                   rotations=tuple(turn * r for r in grippers.rotations))


def moved_document(job, doc, move: TableMove, program: bool | None = None):
    """The plan document moved by ``move``: shapes, the planner's stages, frames, clip
    wrenches, trajectory, and its robot program made again in the cell of ``job`` (the job
    already moved) when ``program`` (default: when it had one; False drops it). The obstacles
    stay in the world: the obstacle section's collisions after re-planning are those of the
    moved shapes (:func:`obstacle_collisions`). The target check (a displacement) and the
    forces' magnitudes do not depend on the placement."""
    stages = doc.stages if doc.stages is None else replace(
        doc.stages, basic=move.points(doc.stages.basic),
        advanced=move.points(doc.stages.advanced))
    moved = replace(
        doc, shapes=move.points(doc.shapes), stages=stages,
        stabilized=None if doc.stabilized is None else move.points(doc.stabilized),
        grippers=None if doc.grippers is None else moved_grippers(doc.grippers, move),
        clip_wrenches=None if doc.clip_wrenches is None else move.vectors(
            doc.clip_wrenches.reshape(-1, 3)).reshape(doc.clip_wrenches.shape))
    if doc.avoidance is not None and not move.is_identity:
        after = collision_rows(_collisions(moved))
        moved = replace(moved, avoidance=replace(
            doc.avoidance, after=after, message=f"{doc.avoidance.message}; at the placement "
            f"({move.describe()}): " + _collision_text(after)))
    if program is None:
        program = doc.robot is not None or doc.program is not None
    if doc.trajectory is None:
        return moved
    if not program:
        return without_robot(timed(job, moved))
    return timed_with_robot(job, moved, always=True)


def _collisions(doc):
    """Collision reports of the document's stabilized shapes with its (world) obstacles."""
    shapes = doc.shapes if doc.stabilized is None else doc.stabilized
    return check_path(shapes, doc.obstacles, doc.cable.diameter / 2)


def _collision_text(rows) -> str:
    hits = [row["shape"] for row in rows if row["colliding"]]
    return f"shapes {hits} collide" if hits else "no collision"


def obstacle_collisions(doc) -> str | None:
    """Why a placed plan cannot be kept: its stabilized shapes collide with the obstacles,
    which stay where they are in the world when the job is moved (None when clear)."""
    if not doc.obstacles:
        return None
    reports = [r for r in _collisions(doc) if r.colliding]
    if not reports:
        return None
    return (f"shape {reports[0].shape_index} collides with {', '.join(reports[0].obstacles)} "
            f"({len(reports)} shape(s) collide at this placement)")


def translated_document(job, doc, offset):
    """The plan document translated by ``offset`` (3,) [m] (:func:`moved_document`)."""
    return moved_document(job, doc, TableMove(offset))


@dataclass(frozen=True, eq=False)
class PlacementRepair:
    """One placement search of :func:`placements`.

    Attributes
    ----------
    move : TableMove
        The turn and translation of the job (the turn alone when the search failed).
    left_clip : int
        The clip the left arm holds.
    success : bool
        Every pose reachable, continuous and collision-free after ``move``.
    message : str
        The search's one line (the best offset's problems when none works).
    failed : str or None
        The first check the best offset failed, in the robot program's order (``"reach"``,
        ``"continuity"``, ``"clearance"``: :func:`searched_failure`); None on success.
    """

    move: TableMove
    left_clip: int
    success: bool
    message: str
    failed: str | None = None


def searched_failure(reachability) -> str:
    """The first check a placement search's best offset failed (its
    :class:`~dloplan.robot.reachability.Reachability`; None: no offset passed the search's
    pre-check, IK at the targets): ``"reach"`` where a pose is not reached, else
    ``"continuity"`` where a motion is lost, else ``"clearance"`` (the arms come too close)."""
    if reachability is None or not np.all(reachability.reachable):
        return "reach"
    return "continuity" if not np.all(reachability.continuous) else "clearance"


def with_approach(positions: np.ndarray, matrices: np.ndarray, cell) -> tuple:
    """The clip poses (K, 2, 3) [m] and frames (K, 2, 3, 3) with the robot program's approach
    and retreat poses added (``cell.approach`` back along the TCP z-axis of the first and the
    last pose, :mod:`dloplan.robot.program`), so that the search checks what the program
    executes."""
    if cell is None or cell.approach <= 0:
        return positions, matrices
    back = cell.approach * (matrices @ cell.tools[0].tcp_in_clip.as_matrix()[:, 2])
    return (np.concatenate([positions[:1] - back[:1], positions, positions[-1:] - back[-1:]]),
            np.concatenate([matrices[:1], matrices, matrices[-1:]]))


def targets_reached(grippers: GripperPath, cell) -> int:
    """How many of the robot program's targets (the clip poses with the approach and the
    retreat, :func:`with_approach`) the arms reach by IK at the targets alone, the left arm
    holding the clip on its side (:func:`dloplan.robot.reachability.reach_at_targets`): a
    cheap score that ranks gripper frames before their robot program is made (2-10 s each).
    A described cell, which places the job itself, counts every target (no ranking)."""
    from ...robot.cell import RobotCell
    from ...robot.reachability import reach_at_targets

    if not isinstance(cell, RobotCell):
        return 2 * (grippers.n_shapes + 2)
    positions, matrices = with_approach(grippers.positions, grippers.matrices, cell)
    order = [0, 1] if left_clip(grippers, cell) == 0 else [1, 0]
    return int(reach_at_targets(cell.robot, positions[:, order],
                                Rotation.from_matrix(matrices[:, order]), cell.reach).sum())


def _pivot(grippers: GripperPath) -> np.ndarray:
    """(3,) [m] the vertical the job is turned about: through the clips' centre."""
    return grippers.positions.reshape(-1, 3).mean(axis=0) * [1.0, 1.0, 0.0]


def _turned_targets(grippers: GripperPath, yaw: float, pivot, cell) -> tuple:
    """The frames turned by ``yaw`` [rad] about the vertical through ``pivot`` and the targets
    a search checks on them (:func:`with_approach`): (frames, (K', 2, 3) positions [m],
    (K', 2, 3, 3) matrices)."""
    turned = moved_grippers(grippers, TableMove(yaw=yaw, pivot=pivot))
    return (turned, *with_approach(turned.positions, turned.matrices, cell))


def within_spheres(grippers: GripperPath, cell) -> bool:
    """Whether the job where it lies (turned by 0) may pass a placement search of zero extent
    (the reach repair's search where the job lies): every target of one of the two arm
    assignments, the approach and the retreat included, within its arm's reach sphere
    (:func:`dloplan.robot.placement.within_reach`, the first test of
    :func:`dloplan.robot.placement.search_placement`, on the same targets as
    :func:`placements`). When not, such a search finds nothing, and solves no IK to say so."""
    from ...robot.placement import within_reach
    from ...robot.yumi import yumi

    _, positions, _ = _turned_targets(grippers, 0.0, _pivot(grippers), cell)
    robot = yumi() if cell is None else cell.robot
    return any(bool(within_reach(robot, positions[:, order], np.zeros((1, 3))).all())
               for order in ([0, 1], [1, 0]))


def placements(grippers: GripperPath, *, searches=SEARCHES, yaws=YAWS, cell=None):
    """Placements of the job where the robot reaches every planned pose, smallest turn first.

    For each turn of ``yaws`` about the vertical through the clips' centre, each (half-width,
    step, objective) of ``searches`` and each arm assignment (the side rule's, then the swapped
    one, which the robot program also falls back to), the working offset the objective picks
    (:func:`dloplan.robot.search_placement`, on the poses with the approach and the retreat of
    ``cell``, a :class:`~dloplan.robot.RobotCell`, :func:`with_approach`; its checks for the
    verdict only, ``ReachOptions.verdict_only``: the robot program confirms). Yields a
    :class:`PlacementRepair` per successful search, and one per turn that no search of it
    passed (``success`` False).
    """
    from ...robot.placement import search_placement

    pivot = _pivot(grippers)
    options = replace(ReachOptions() if cell is None else cell.reach, verdict_only=True)
    seen = set()
    for yaw in yaws:
        turned, positions, matrices = _turned_targets(grippers, yaw, pivot, cell)
        side = left_clip(turned, cell)
        messages, failed = [], None
        for half, step, objective in searches:
            for clip in (side, 1 - side):
                found = search_placement(positions, Rotation.from_matrix(matrices),
                                         None if cell is None else cell.robot, options=options,
                                         extent=(half, half, 0.0), step=step, explain=False,
                                         objective=objective,
                                         assignment=("first-left", "first-right")[clip])
                move = TableMove(found.offset if found.success else np.zeros(3), yaw, pivot)
                key = (clip, *np.round(found.offset, 6))
                if found.success and key not in seen:
                    seen.add(key)
                    yield PlacementRepair(move, clip, True, found.message)
                else:
                    messages.append(found.message)
                    if not found.success:
                        failed = searched_failure(found.reachability)
        if messages:
            yield PlacementRepair(TableMove(yaw=yaw, pivot=pivot), side, False,
                                  f"turned {math.degrees(yaw):.0f} deg: {messages[-1]}",
                                  failed or "reach")
