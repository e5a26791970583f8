"""Following a dual-arm TCP path: the settings, the one sub-step rule and the one path check of
every cell.

A path gives, per planned pose k and arm, a TCP pose in the world. Both arms move from pose
k-1 to pose k together, the TCP on a straight line with spherical-linear orientation (the
motion of :mod:`dloplan.trajectory`), in the same number of sub-steps (:func:`substeps`: at
most ``step_length`` and ``step_angle`` each); :func:`check_path` follows that motion with every
IK seeded from the previous sub-step, so the joint motion it reports is the continuous one a
controller executes, not a fresh solution per pose. It reports per pose and arm the joints,
reach, continuity, errors, joint margin and step, the arm-arm (and optionally arm-table)
capsule clearance, one verdict row per check, pose and arm (:class:`~dloplan.robot.checks.
CheckRow`) and one message per problem (:class:`PathCheck`).

Its users differ only in named settings of :class:`ReachOptions`: the reach check of a grip or a
placement (:mod:`dloplan.robot.reachability`, the defaults: the elbow kept from its limits while
tracking, a lost motion skipped to the next pose, both grips of a symmetric gripper, optionally
stopped at the first failure) and a described cell's program (:meth:`ReachOptions.cell_program`:
restarts at the first pose, every sub-step tracked and recorded even after a loss, the arm-table
clearance).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial.transform import Rotation

from .checks import CheckRow
from .collision import arm_clearance
from .described import ARMS, DescribedCell, table_clearance
from .kinematics import IKOptions, IKResult, forward, inverse, joint_margin, solve_from
from .line_deviation import LINE_TOLERANCE, line_deviation
from .yumi import ABB_AXIS_NUMBERS

COMFORT_CLEARANCE = 0.05
"""[m] Arm-arm clearance beyond which a ranking (a program's joint solutions, a placement) no
longer prefers more clearance."""

COMFORT_MARGIN = float(np.radians(30.0))
"""[rad] Joint margin beyond which a ranking no longer prefers more margin."""


START_RESTARTS = 16
"""Random restarts of the IK at the first pose of a cell program's check (at least; more if
``options.ik`` asks; :meth:`ReachOptions.cell_program`): the one solve without a previous
solution to follow, where a margin from the limits is wanted."""

REFINEMENTS = 3
"""Times at most the path check tracks a path again with more sub-steps in the moves whose
joint motion leaves the straight TCP line by more than ``ReachOptions.line_tolerance``."""

TURN_Z = Rotation.from_rotvec([0.0, 0.0, np.pi]).as_matrix()
"""The TCP turned by pi about its own z-axis: the other grip of a symmetric gripper."""

CHECKS = ("reach", "joint limits", "continuity", "clearance", "table clearance", "joint speed",
          "joint acceleration")
"""The checks of a cell program, in the order of its rows (the last two along the time law,
:func:`dloplan.robot.tracked_program.tracked_program`)."""


HELD_TOLERANCE = 1e-4
"""[m + rad] How far the TCP at held joints may be from target 0 and still hold it there (the
held joints solved the same target, written to 1e-6 mm and 1e-9 in a quaternion, to the IK's
1e-5 tolerance)."""


@dataclass(frozen=True, eq=False)
class ReachOptions:
    """Settings of the path check.

    Parameters
    ----------
    ik : IKOptions
        Settings of each IK solve (tolerances: a pose counts as reached within them).
    step_length : float
        Largest TCP translation [m] of one tracking sub-step between planned poses.
    step_angle : float
        Largest TCP rotation [rad] of one sub-step.
    max_joint_step : float
        A joint moving more than this over one sub-step [rad] is a configuration jump: the
        motion between the two poses is flagged as not continuous.
    min_margin : float
        Wanted distance from every joint limit [rad]: the first pose is solved for it (seeds are
        tried until one gives it), and a reachable pose closer than this is reported in the
        messages (a warning, not a failure).
    min_clearance : float
        Smallest allowed distance between the two arms' capsules [m]; less is a collision.
    symmetric_grip : bool
        The gripper's two fingers are alike, so holding a clip with the TCP turned by pi about
        its approach (z) axis grips the cable the same way. When True, :func:`check_path`
        tracks both grips for each arm (unless given other ``alternatives``; one grip for the
        whole path, so the wrist does not spin between poses) and keeps the better one (more
        poses reachable, then continuous, then the larger joint margin).
    verdict_only : bool
        Only the verdict is wanted (a search that tries many placements): the tracking of an
        arm's grip stops at its first pose it cannot reach or motion it loses, the other arm and
        the clearance are skipped once an arm has no grip without a failure, and the rows after
        the failure are not computed (they read unreachable, their errors and clearance NaN).
        ``success`` is that of the complete check: a grip without a failure is tracked to the
        end, and of two such grips the one with the larger joint margin is kept, as in the
        complete check (so the clearance is judged for the same joint motion). The user-facing
        checks keep the default False: every row.
    start_restarts : int
        Random restarts (at least; more if ``ik.restarts`` asks) of the IK at the first pose and
        of a pose solved afresh after a lost motion.
    track_margin : bool
        Every tracking sub-step keeps ``min_margin`` from the limits (the null-space polish of a
        redundant elbow) and is one solve from the previous sub-step; False: the sub-steps
        ask no margin, and a sub-step that does not converge from the previous one is retried
        from its wrist flip and the home pose (:func:`~dloplan.robot.kinematics.inverse`
        without restarts).
    follow_lost : bool
        After the tracking of a move is lost (the IK, or a joint jumping more than
        ``max_joint_step``), keep tracking its sub-steps from the last solution (the recorded
        motion is the one a program would run) and solve the pose afresh at its planned
        rotation when a sub-step's IK failed; False: hold the joints to the pose and solve it
        afresh (at the end of the move's slerp, the same rotation to 1e-16) only when it is
        not reached from there.
    table_clearance : bool
        Check the arms' capsules against the table at every sub-step (a ``table clearance``
        verdict row per pose and arm); False: not computed (NaN, no rows).
    line_tolerance : float or None
        [m] How far the joint motion between sub-steps (the spline a time-based program runs,
        :mod:`dloplan.robot.line_deviation`) may leave the straight TCP line: a move that leaves
        it by more is tracked again with more sub-steps (up to :data:`REFINEMENTS` times), and
        one that still does is not continuous. None: not measured (a reach check's, whose
        joints between the poses are no program).
    """

    ik: IKOptions = field(default_factory=IKOptions)
    step_length: float = 0.02
    step_angle: float = 0.1
    max_joint_step: float = 0.5
    min_margin: float = np.radians(5.0)
    min_clearance: float = 0.005
    symmetric_grip: bool = True
    verdict_only: bool = False
    start_restarts: int = 0
    track_margin: bool = True
    follow_lost: bool = False
    table_clearance: bool = False
    line_tolerance: float | None = None

    @classmethod
    def cell_program(cls, **settings) -> ReachOptions:
        """The settings of a described cell's program check (:func:`~dloplan.robot.urdf_cell.
        verify_on_cell`): :data:`START_RESTARTS` at the first pose, sub-steps tracked without a
        margin, every sub-step tracked after a loss, the table clearance, the mapped grip only,
        the motion between sub-steps within :data:`~dloplan.robot.line_deviation.
        LINE_TOLERANCE` of the straight TCP line; ``settings`` as for the class."""
        return cls(**{"start_restarts": START_RESTARTS, "track_margin": False,
                      "follow_lost": True, "table_clearance": True, "symmetric_grip": False,
                      "line_tolerance": LINE_TOLERANCE, **settings})

    def __post_init__(self) -> None:
        for key in ("step_length", "step_angle", "max_joint_step"):
            value = getattr(self, key)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"ReachOptions.{key}: expected a positive number, got {value!r}")
        for key in ("min_margin", "min_clearance"):
            value = getattr(self, key)
            if not np.isfinite(value) or (key == "min_margin" and value < 0):
                raise ValueError(f"ReachOptions.{key}: expected a finite number >= 0, got "
                                 f"{value!r}")
        if self.line_tolerance is not None and not (np.isfinite(self.line_tolerance)
                                                    and self.line_tolerance > 0):
            raise ValueError(f"ReachOptions.line_tolerance: expected a positive number or "
                             f"None, got {self.line_tolerance!r}")
        if int(self.start_restarts) < 0:
            raise ValueError(f"ReachOptions.start_restarts: expected an integer >= 0, got "
                             f"{self.start_restarts!r}")
        if not isinstance(self.ik, IKOptions):
            raise ValueError(f"ReachOptions.ik: expected IKOptions, got {self.ik!r}")


def substeps(positions, matrices, options: ReachOptions) -> np.ndarray:
    """Number of sub-steps of each move between planned poses, the same for both arms: at most
    ``options.step_length`` of TCP translation and ``options.step_angle`` of TCP rotation per
    sub-step for either arm, at least one.

    Parameters
    ----------
    positions : numpy.ndarray
        (K, 2, 3) TCP positions [m], arms (left, right).
    matrices : numpy.ndarray
        (K, 2, 3, 3) ``tcp_to_world`` rotation matrices.
    options : ReachOptions

    Returns
    -------
    numpy.ndarray
        (K-1,) int: sub-steps of the move from pose k-1 to pose k.
    """
    if len(positions) < 2:
        return np.zeros(0, dtype=int)
    dist = np.linalg.norm(np.diff(positions, axis=0), axis=-1)  # (K-1, 2)
    rel = Rotation.from_matrix(np.einsum("kaji,kajl->kail", matrices[:-1], matrices[1:]))
    angle = rel.magnitude()
    n = np.maximum(np.ceil(dist / options.step_length), np.ceil(angle / options.step_angle))
    return np.maximum(n.max(axis=1), 1).astype(int)



@dataclass(frozen=True, eq=False)
class PathCheck:
    """A dual-arm TCP path followed on a :class:`DescribedCell` (:func:`check_path`).

    Attributes
    ----------
    joints : tuple of numpy.ndarray
        Per arm (K, n_arm) the joint solutions [rad] at the K poses (the closest found where not
        reachable), within the limits.
    reachable, continuous : numpy.ndarray
        (K, 2) bool. ``continuous[k]``: the arm followed the straight TCP motion from pose k-1
        through every sub-step without losing the IK or a joint step above ``max_joint_step``
        (True at k = 0 and after an unreachable pose, which ``reachable`` already reports).
    position_error, angle_error, joint_margin, joint_step, table_clearance : numpy.ndarray
        (K, 2) [m], [rad], [rad], largest joint step of a tracked sub-step into pose k [rad],
        lowest capsule surface above the table over the motion into pose k [m] (NaN unless
        ``ReachOptions.table_clearance``).
    clearance : numpy.ndarray
        (K,) smallest arm-arm capsule distance [m] over the motion into pose k (negative:
        overlap; NaN when a ``verdict_only`` check stopped before it).
    motion_times : numpy.ndarray
        (N,) sub-step parameter (k + fraction) of the tracked motion.
    motion_joints : tuple of numpy.ndarray
        Per arm (N, n_arm) the joints [rad] of every sub-step (for a joint trajectory).
    motion_clearance : numpy.ndarray
        (N,) arm-arm clearance [m] of every sub-step.
    closest : numpy.ndarray
        (N, 2) int: the capsules of the left and the right arm that come closest at each
        sub-step (:func:`~dloplan.robot.collision.arm_clearance`).
    poses : numpy.ndarray
        (K,) int: the sub-step of each planned pose.
    grip_turned : tuple of bool
        Per arm: the arm follows the ``alternatives`` rotations of :func:`check_path`.
    stopped : bool
        A ``verdict_only`` check stopped at an arm's first failure: the rows after it (and the
        other arm, and the clearance) were not computed.
    messages : tuple of str
        One line per tracking problem, naming the arm and the pose index.
    rows : tuple of CheckRow
        Per pose and arm ``reach``, ``joint limits``, ``continuity`` (and ``table clearance``),
        per pose ``clearance``.
    line_deviation : numpy.ndarray or None
        (K, 2) [m] the largest distance of the joint motion into pose k from the straight TCP
        line between the sub-steps (:mod:`dloplan.robot.line_deviation`); None without
        ``ReachOptions.line_tolerance`` or where an arm lost a move or missed a pose (the
        check fails already).
    """

    joints: tuple[np.ndarray, np.ndarray]
    reachable: np.ndarray
    continuous: np.ndarray
    position_error: np.ndarray
    angle_error: np.ndarray
    joint_margin: np.ndarray
    joint_step: np.ndarray
    table_clearance: np.ndarray
    clearance: np.ndarray
    motion_times: np.ndarray
    motion_joints: tuple[np.ndarray, np.ndarray]
    motion_clearance: np.ndarray
    closest: np.ndarray
    poses: np.ndarray
    grip_turned: tuple[bool, bool]
    stopped: bool
    messages: tuple[str, ...]
    rows: tuple[CheckRow, ...]
    line_deviation: np.ndarray | None = None

    @property
    def q(self) -> np.ndarray:
        """(K, 2, n) the joints of both arms (arms with the same number of joints)."""
        return np.stack(self.joints, axis=1)

    @property
    def ok(self) -> bool:
        """Every row passes."""
        return all(row.ok for row in self.rows)

    @property
    def message(self) -> str:
        """One line: ok with the key numbers, or the first failure of each failing check."""
        if self.ok:
            table = "" if not np.isfinite(self.table_clearance).all() else (
                f", min table clearance {1e3 * self.table_clearance.min():.1f} mm")
            return (f"cell ok: {len(self.clearance)} poses; min clearance "
                    f"{1e3 * self.clearance.min():.1f} mm{table}, min joint margin "
                    f"{np.degrees(self.joint_margin.min()):.1f} deg")
        parts = []
        for name in CHECKS:
            bad = [row for row in self.rows if row.check == name and not row.ok]
            if bad:
                parts.append(f"{name} at {bad[0].label} ({bad[0].arm}: {bad[0].value:.4g} "
                             f"{bad[0].unit}{'; ' + bad[0].note if bad[0].note else ''})")
        return "cell FAILS: " + "; ".join(parts)


def check_path(cell: DescribedCell, positions, rotations: Rotation, *, seeds=None,
               options: ReachOptions | None = None,
               alternatives: Rotation | None = None, held: bool = False) -> PathCheck:
    """Follow a dual-arm TCP path on a cell (module docstring): the one path check.

    Pose 0 is solved from ``seeds`` (default the arms' home poses) for the wanted
    ``min_margin`` (with at least ``start_restarts`` random restarts). Between poses both arms
    move in the same number of sub-steps (:func:`substeps`), the TCP on a straight line with
    slerped orientation, each IK seeded from the previous sub-step (``track_margin``); a move
    the tracking loses is reported not continuous and its pose solved afresh
    (``follow_lost``). Never raises for an unreachable pose: it is reported.

    Parameters
    ----------
    cell : DescribedCell
    positions : array_like
        (K, 2, 3) TCP positions [m] in the world, arms in the order (left, right).
    rotations : scipy.spatial.transform.Rotation
        (K, 2) or (K * 2,) pose-major ``tcp_to_world``.
    seeds : sequence of array_like, optional
        Per arm the (n_arm,) joints [rad] to start pose 0 from.
    held : bool
        The arms hold the cable at pose 0 with ``seeds`` (the remaining motion of a corrected
        plan): pose 0 is those joints, not solved, and reached where their TCP is within
        :data:`HELD_TOLERANCE` of it; of an arm's two grips the one it holds is kept (the
        other's pose 0 is not where the held joints are).
    options : ReachOptions, optional
        Default ``ReachOptions()``, the reach check's settings.
    alternatives : scipy.spatial.transform.Rotation, optional
        Other TCP rotations, shaped like ``rotations``, an arm may use instead for the whole
        path; default with ``options.symmetric_grip`` the grip turned by pi about the TCP
        z-axis (:data:`TURN_Z`). Each arm keeps the better of the two (more poses reachable,
        then continuous, then the larger joint margin), and ``PathCheck.grip_turned`` says
        which arm uses its alternative.

    Returns
    -------
    PathCheck
    """
    opts = options if options is not None else ReachOptions()
    pos, mats = validate_path(positions, rotations)
    grips = [mats]
    if alternatives is not None:
        grips.append(validate_path(positions, alternatives, "positions", "alternatives")[1])
    elif opts.symmetric_grip:
        grips.append(mats @ TURN_Z)
    seeds = [arm.home for arm in cell.arms] if seeds is None else list(seeds)
    for a, arm in enumerate(cell.arms):
        seed = np.asarray(seeds[a], dtype=float) if a < len(seeds) else None
        if len(seeds) != 2 or seed.shape != (arm.n_joints,) or not np.all(np.isfinite(seed)):
            raise ValueError(f"seeds: expected per arm ({arm.n_joints},) finite joint values "
                             f"[rad], got {seeds!r}")
    counts = substeps(pos, mats, opts)
    tracks = _track_arms(cell, pos, grips, seeds, counts, opts, held)
    deviation = None
    for refinement in range(REFINEMENTS + 1):
        if opts.line_tolerance is None or not all(
                t.reachable.all() and t.continuous.all() for t, _ in tracks):
            break  # (a lost or unreached motion fails already: its spline is no program)
        deviation = np.stack([line_deviation(arm, t.motion, pos[:, a], counts)
                              for a, ((t, _), arm) in enumerate(zip(tracks, cell.arms,
                                                                    strict=True))], 1)
        worst = deviation[1:].max(axis=1) / opts.line_tolerance  # per move
        if refinement == REFINEMENTS or not np.any(worst > 1.0):
            break
        # the spline's error falls at least as the square of the spacing: one more round is
        # rarely needed; at most 4 times the sub-steps a round
        factor = np.clip(1.2 * np.sqrt(worst), 2.0, 4.0)
        counts = np.where(worst > 1.0, np.ceil(counts * factor), counts).astype(int)
        tracks, deviation = _track_arms(cell, pos, grips, seeds, counts, opts, held), None
    times = np.concatenate([[0.0]] + [k - 1 + np.arange(1, n + 1) / n
                                      for k, n in enumerate(counts, start=1)])
    poses = np.concatenate([[0], np.cumsum(counts)]).astype(int)
    stopped = any(t.stopped for t, _ in tracks)
    motion = tuple(t.motion for t, _ in tracks)
    joints = tuple(m[poses] for m in motion)
    reachable, continuous, perr, aerr, step = (
        np.stack([getattr(t, key) for t, _ in tracks], axis=1)
        for key in ("reachable", "continuous", "position_error", "angle_error", "joint_step"))
    messages = tuple(m for t, _ in tracks for m in t.messages)
    off = np.zeros_like(continuous)
    if deviation is not None:
        off = (deviation > opts.line_tolerance) & continuous & reachable
        continuous = continuous & ~off
        messages += tuple(
            f"{ARMS[a]} arm, between pose {k - 1} and {k}: the joint motion leaves the straight "
            f"TCP line by {1e3 * deviation[k, a]:.2f} mm with {counts[k - 1]} sub-steps "
            f"(bound {1e3 * opts.line_tolerance:.2f} mm)" for k, a in zip(*np.nonzero(off),
                                                                          strict=True))
    margin = np.stack([joint_margin(arm, joints[a]) for a, arm in enumerate(cell.arms)], 1)
    starts = np.concatenate([[0], poses[:-1] + 1])
    if stopped:
        gaps, closest = np.full(len(times), np.nan), np.zeros((len(times), 2), dtype=int)
        clearance = np.full(len(pos), np.nan)
    else:
        gaps, closest = arm_clearance(cell.left, motion[0], cell.right, motion[1],
                                      shared_base=cell.shared_base)
        clearance = np.minimum.reduceat(gaps, starts)
    table = np.full((len(pos), 2), np.nan)
    if opts.table_clearance and not stopped:
        table = np.stack([np.minimum.reduceat(table_clearance(cell, arm, motion[a]), starts)
                          for a, arm in enumerate(cell.arms)], 1)
    rows = _rows(cell, reachable, continuous, perr, margin, step, table, clearance, opts,
                 np.where(off, deviation, np.nan) if off.any() else None)
    return PathCheck(joints, reachable, continuous, perr, aerr, margin, step, table, clearance,
                     times, motion, gaps, closest, poses,
                     (False, False) if stopped else tuple(turned for _, turned in tracks),
                     stopped, messages, tuple(rows), deviation)


def held_pose(arm, position, rotation_matrix, joints) -> IKResult:
    """Joints that hold the cable at a pose, as an IK result: ``joints`` (n,) [rad] themselves,
    a success where their TCP is within :data:`HELD_TOLERANCE` (position [m] + angle [rad]) of
    ``position`` (3,) and ``rotation_matrix`` (3, 3)."""
    p, r = forward(arm, joints)
    position_error = float(np.linalg.norm(p - position))
    angle_error = float((Rotation.from_matrix(rotation_matrix).inv() * r).magnitude())
    success = position_error + angle_error <= HELD_TOLERANCE
    return IKResult(np.asarray(joints, dtype=float), success, position_error, angle_error, 0, 1,
                    "held" if success else f"the joints holding the cable put the TCP "
                    f"{position_error * 1e3:.3g} mm, {np.degrees(angle_error):.3g} deg from it")


def _track_arms(cell, pos, grips, seeds, counts, opts: ReachOptions, held: bool) -> list:
    """Per arm ``(track, turned)``: each arm's better grip followed through ``counts``
    sub-steps (:func:`check_path`; ``held``: pose 0 is the seeds); a stopped ``verdict_only``
    track leaves the other arm untracked."""
    poses = np.concatenate([[0], np.cumsum(counts)]).astype(int)
    tracks = []
    for a, arm in enumerate(cell.arms):
        tried = [_follow(arm, ARMS[a], pos[:, a], g[:, a], counts, np.asarray(seeds[a], float),
                         opts, held) for g in grips]
        scores = [(t.reachable.sum(), t.continuous.sum(),
                   joint_margin(arm, t.motion[poses]).min()) for t in tried]
        best = max(range(len(tried)), key=lambda i: scores[i])
        tracks.append((tried[best], best == 1))
        if tried[best].stopped:  # verdict_only: the verdict is known, the rest not computed
            return [(tried[best], False) if i == a else (_unknown(other, poses[-1] + 1,
                                                                  len(pos)), False)
                    for i, other in enumerate(cell.arms)]
    return tracks


@dataclass(frozen=True, eq=False)
class _Track:
    """One arm's tracked motion: (N, n) joints of every sub-step; per pose reached,
    continuous, errors [m], [rad] and largest tracked joint step [rad]; messages; stopped
    (``verdict_only``: the poses after the first failure not tracked)."""

    motion: np.ndarray
    reachable: np.ndarray
    continuous: np.ndarray
    position_error: np.ndarray
    angle_error: np.ndarray
    joint_step: np.ndarray
    messages: tuple[str, ...]
    stopped: bool = False


def _unknown(arm, n_times: int, n_poses: int) -> _Track:
    """The arm a stopped check did not track: its home pose, nothing reached."""
    return _Track(np.repeat(arm.home[None], n_times, axis=0), np.zeros(n_poses, bool),
                  np.ones(n_poses, bool), np.full(n_poses, np.nan), np.full(n_poses, np.nan),
                  np.zeros(n_poses), (), True)


def substep_rotations(matrices, counts) -> list[np.ndarray]:
    """The TCP rotations of every move's sub-steps: scipy's
    ``Slerp([0, 1], Rotation.from_matrix(matrices[k - 1:k + 1]))(j / n)``, j = 1..n, n =
    ``counts[k - 1]``, bit for bit, for all moves in one batch (the same operations as the
    Slerp's, element by element: one batch instead of a Slerp per move, whose scipy calls
    cost more than their arithmetic).

    Parameters
    ----------
    matrices : numpy.ndarray
        (K, 3, 3) ``tcp_to_world`` at the planned poses.
    counts : numpy.ndarray
        (K-1,) int >= 1: sub-steps of each move (:func:`substeps`).

    Returns
    -------
    list of numpy.ndarray
        (K-1) arrays, the k-th (counts[k], 3, 3): the move into pose k + 1, its last the
        pose's own rotation as the Slerp gives it.
    """
    counts = np.asarray(counts, dtype=int)
    if len(counts) == 0:
        return []
    ends = Rotation.from_matrix(matrices)
    starts = ends[:-1]
    rotvecs = (starts.inv() * ends[1:]).as_rotvec()
    move = np.repeat(np.arange(len(counts)), counts)
    frac = np.concatenate([np.arange(1, n + 1) / n for n in counts])
    sub = (starts[move] * Rotation.from_rotvec(rotvecs[move] * frac[:, None])).as_matrix()
    return np.split(sub, np.cumsum(counts)[:-1])


def _follow(arm, name: str, pos, mats, counts, seed, opts: ReachOptions,
            held: bool = False) -> _Track:
    """Track one arm through the sub-steps of its (K, 3) positions and (K, 3, 3) rotations
    (:func:`check_path`; ``held``: pose 0 is ``seed``)."""
    n_poses = len(pos)
    start = replace(opts.ik, min_margin=opts.min_margin,
                    restarts=max(opts.ik.restarts, opts.start_restarts))
    track = replace(opts.ik, restarts=0, min_margin=opts.min_margin if opts.track_margin else 0.0)
    reach, cont = np.zeros(n_poses, dtype=bool), np.ones(n_poses, dtype=bool)
    perr, aerr, step = np.full(n_poses, np.nan), np.full(n_poses, np.nan), np.zeros(n_poses)
    messages = []
    total = 1 + int(np.sum(counts))

    def finish(motion, stopped=False):
        motion = motion + [motion[-1]] * (total - len(motion))
        return _Track(np.array(motion), reach, cont, perr, aerr, step, tuple(messages), stopped)

    res = (held_pose(arm, pos[0], mats[0], seed) if held else
           inverse(arm, pos[0], Rotation.from_matrix(mats[0]), seed=seed, options=start))
    motion = [res.q]
    reach[0], perr[0], aerr[0] = res.success, res.position_error, res.angle_error
    if not res.success:
        messages.append(f"{name} arm, pose 0: not reachable ({res.message})")
        if opts.verdict_only:
            return finish(motion, True)
    moves = substep_rotations(mats, counts)
    for k in range(1, n_poses):
        n_sub = int(counts[k - 1])
        frac = np.arange(1, n_sub + 1) / n_sub
        sub_mats = moves[k - 1]
        q = motion[-1]
        broken = not reach[k - 1]  # the motion into pose k starts from an unreached pose
        lost = failed = False
        for s, f in enumerate(frac):
            held = (broken or lost) and not opts.follow_lost
            if held and s < n_sub - 1:
                motion.append(q)  # the motion is reported broken: only the pose matters
                continue
            target = (1.0 - f) * pos[k - 1] + f * pos[k]
            if opts.track_margin:
                res = solve_from(arm, target, sub_mats[s], q, track)
            else:
                res = inverse(arm, target, sub_mats[s], seed=q, options=track)
            if not held:
                jump = np.abs(res.q - q)
                step[k] = max(step[k], float(np.max(jump)))
                failed = failed or not res.success
                if not (lost or broken) and not res.success:
                    messages.append(f"{name} arm, between pose {k - 1} and {k}: lost the "
                                    f"straight TCP motion at {f:.2f} of the way (error "
                                    f"{res.position_error * 1e3:.2f} mm, "
                                    f"{np.degrees(res.angle_error):.2f} deg)")
                    lost = True
                elif not (lost or broken) and jump.max() > opts.max_joint_step:
                    messages.append(f"{name} arm, between pose {k - 1} and {k}: configuration "
                                    f"jump, ABB axis {ABB_AXIS_NUMBERS[int(np.argmax(jump))]} "
                                    f"moves {np.degrees(jump.max()):.0f} deg in one sub-step")
                    lost = True
                if lost and opts.verdict_only:
                    cont[k] = False
                    return finish(motion, True)
            q = res.q
            motion.append(q)
        if not res.success or (opts.follow_lost and (broken or failed)):
            pose = mats[k] if opts.follow_lost else sub_mats[-1]
            res = inverse(arm, pos[k], Rotation.from_matrix(pose), seed=q, options=start)
            motion[-1] = res.q
            if not res.success:
                messages.append(f"{name} arm, pose {k}: not reachable ({res.message})")
        reach[k], perr[k], aerr[k] = res.success, res.position_error, res.angle_error
        cont[k] = not lost and step[k] <= opts.max_joint_step
        if not res.success and opts.verdict_only:
            return finish(motion, True)
    return finish(motion)


def _rows(cell, reach_ok, cont, perr, margin, step, table, clearance, opts,
          off_line=None) -> list[CheckRow]:
    """The verdict rows of :func:`check_path`; ``off_line`` (K, 2) [m]: where the motion into a
    pose left the straight TCP line by more than its bound, the distance (else NaN)."""
    rows = []
    for k in range(len(clearance)):
        label = f"pose {k}"
        for a, arm in enumerate(cell.arms):
            note = "" if reach_ok[k, a] else "IK did not converge"
            rows.append(CheckRow("reach", k, label, k, arm.name, 1e3 * perr[k, a], "mm",
                                 bool(reach_ok[k, a]), note))
            low = margin[k, a] < opts.min_margin
            rows.append(CheckRow("joint limits", k, label, k, arm.name,
                                 float(np.degrees(margin[k, a])), "deg",
                                 bool(reach_ok[k, a] and not low),
                                 f"below the {np.degrees(opts.min_margin):.0f} deg required"
                                 if low else ""))
            off = off_line is not None and np.isfinite(off_line[k, a])
            rows.append(CheckRow("continuity", k, label, k, arm.name,
                                 float(np.degrees(step[k, a])), "deg", bool(cont[k, a]),
                                 "" if cont[k, a] else
                                 f"the joint motion leaves the straight TCP line by "
                                 f"{1e3 * off_line[k, a]:.2f} mm" if off else
                                 "configuration change or IK lost"))
            if opts.table_clearance:
                rows.append(CheckRow("table clearance", k, label, k, arm.name,
                                     1e3 * table[k, a], "mm",
                                     bool(table[k, a] >= opts.min_clearance)))
        both = bool(reach_ok[k].all())
        rows.append(CheckRow("clearance", k, label, k, "both", 1e3 * clearance[k], "mm",
                             bool(clearance[k] >= opts.min_clearance or not both)))
    return rows


def validate_path(positions, rotations, pos_name: str = "positions",
                  rot_name: str = "rotations") -> tuple[np.ndarray, np.ndarray]:
    """A dual-arm path's positions (K, 2, 3) [m] and rotation matrices (K, 2, 3, 3), checked
    (rotations given (K, 2) or pose-major (K * 2,)): a ValueError naming ``pos_name`` or
    ``rot_name`` otherwise."""
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 3 or pos.shape[1:] != (2, 3) or pos.shape[0] < 1:
        raise ValueError(f"{pos_name}: expected shape (K, 2, 3) [m], got {pos.shape}")
    if not np.all(np.isfinite(pos)):
        raise ValueError(f"{pos_name}: non-finite coordinate (NaN or inf)")
    if not isinstance(rotations, Rotation) or rotations.shape not in ((pos.shape[0], 2),
                                                                      (2 * pos.shape[0],)):
        shape = getattr(rotations, "shape", None) if isinstance(rotations, Rotation) else None
        raise ValueError(f"{rot_name}: expected a scipy Rotation of shape ({pos.shape[0]}, 2), "
                         f"got {type(rotations).__name__} of shape {shape}")
    mats = rotations.as_matrix().reshape(pos.shape[0], 2, 3, 3)
    if not np.all(np.isfinite(mats)):
        raise ValueError(f"{rot_name}: non-finite rotation")
    return pos, mats
