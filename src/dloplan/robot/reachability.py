"""Can a dual-arm cell hold a plan's clips? The reach check of every TCP pose along a path, with
both grips of a symmetric gripper, for grips and placements.

The motion between poses is that of :mod:`dloplan.robot.path` (straight TCP lines with slerped
orientation, the sub-steps of :func:`~dloplan.robot.path.substeps`, each IK seeded from the
previous sub-step). :func:`check_path` follows it per arm with the null-space motion keeping a
redundant elbow from its limits and keeps the better grip of each arm;
:func:`check_reachability` does so for a plan's clip poses with the arm assignment;
:func:`reach_at_targets` is its cheap version (IK at the targets only). The placement searches
(:mod:`dloplan.robot.placement`) and the free-elbow candidate of the YuMi's program
(:mod:`dloplan.robot.solutions`) use them; a described cell's program is verified by
:func:`dloplan.robot.path.check_cell_path`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from .assignment import assign_arms
from .chain import CellArm
from .collision import arm_clearance
from .described import ARMS, DescribedCell
from .kinematics import inverse, joint_margin, manipulability, solve_from
from .path import ReachOptions, substeps
from .yumi import ABB_AXIS_NUMBERS, yumi

_TURN_Z = Rotation.from_rotvec([0.0, 0.0, np.pi]).as_matrix()
"""The TCP turned by pi about its own z-axis (the other grip of a symmetric gripper)."""


@dataclass(frozen=True, eq=False)
class Reachability:
    """Per planned pose and arm: can the robot get there, and how comfortably.

    Arrays are indexed ``[pose, arm]`` with the arms in the order of :data:`ARMS`
    (``("left", "right")``).

    Attributes
    ----------
    reachable : numpy.ndarray
        (K, 2) bool: the IK reached the TCP pose within the tolerances and the joint limits.
    q : numpy.ndarray
        (K, 2, 7) joint values [rad] in physical joint order (ABB axes 1, 2, 7, 3, 4, 5, 6),
        always within the limits (the closest found where not reachable).
    joint_margin : numpy.ndarray
        (K, 2) distance of the nearest joint to its nearest limit [rad].
    manipulability : numpy.ndarray
        (K, 2) Yoshikawa manipulability of the 6x7 Jacobian [m^3] (0 at a singularity).
    position_error, angle_error : numpy.ndarray
        (K, 2) remaining TCP error [m] and [rad].
    continuous : numpy.ndarray
        (K, 2) bool: from the reachable pose k-1 the arm followed the straight TCP motion to
        pose k without losing it or jumping configuration (True at k = 0 and after an
        unreachable pose, which ``reachable`` already reports).
    clearance : numpy.ndarray
        (K,) smallest capsule distance between the arms [m] at each pose, and over the
        sub-steps leading to it (negative: overlap); a collision is only reported where both
        arms reach the pose.
    clip_of_arm : tuple of int
        Which clip (0 first, 1 last) each arm holds, or ``(0, 1)`` when the poses were given
        per arm.
    grip_turned : tuple of bool
        Per arm: the TCP holds its clip turned by pi about the TCP z-axis (see
        ``ReachOptions.symmetric_grip``).
    success : bool
        Every pose reachable, every motion continuous, clearance never below the minimum.
    message : str
        One-line summary.
    messages : tuple of str
        One line per problem, naming the arm and the pose index.
    """

    reachable: np.ndarray
    q: np.ndarray
    joint_margin: np.ndarray
    manipulability: np.ndarray
    position_error: np.ndarray
    angle_error: np.ndarray
    continuous: np.ndarray
    clearance: np.ndarray
    clip_of_arm: tuple[int, int]
    grip_turned: tuple[bool, bool]
    success: bool
    message: str
    messages: tuple[str, ...]

    @property
    def n_poses(self) -> int:
        """Number of planned poses K."""
        return int(self.reachable.shape[0])

    @property
    def min_joint_margin(self) -> float:
        """Smallest joint margin over the reachable poses [rad] (-inf if none is)."""
        m = self.joint_margin[self.reachable]
        return float(m.min()) if m.size else -np.inf

    @property
    def min_clearance(self) -> float:
        """Smallest arm-arm clearance over the path [m]."""
        return float(self.clearance.min())


def tcp_poses_from_clips(robot: DescribedCell, clip_positions, clip_rotations: Rotation):
    """TCP targets that hold clips at the given poses: the TCP sits on the clip point and its
    orientation is ``clip_to_world * gripper.tcp_in_clip`` (per arm's gripper).

    Parameters
    ----------
    robot : DescribedCell
    clip_positions : array_like
        (K, 2, 3) clip points [m], already ordered by arm (left, right).
    clip_rotations : scipy.spatial.transform.Rotation
        (K, 2) ``clip_to_world``, ordered by arm.

    Returns
    -------
    positions : numpy.ndarray
        (K, 2, 3) TCP positions [m].
    rotations : scipy.spatial.transform.Rotation
        (K, 2) ``tcp_to_world``.
    """
    mats = clip_rotations.as_matrix()
    tcp = np.stack([mats[:, a] @ arm.tcp_in_clip.as_matrix()
                    for a, arm in enumerate(robot.arms)], axis=1)
    return np.array(clip_positions, dtype=float), Rotation.from_matrix(tcp)


def check_path(robot: DescribedCell, positions, rotations: Rotation, *, seeds=None,
               options: ReachOptions | None = None,
               alternatives: Rotation | None = None) -> Reachability:
    """Reachability of a dual-arm TCP path, tracked continuously from pose to pose.

    Pose 0 is solved from ``seeds`` (default the home poses), trying seeds until a solution at
    least ``min_margin`` from the limits is found. Between poses k-1 and k both arms move in
    the same number of sub-steps (at most ``step_length`` and ``step_angle`` each); every
    sub-step's IK is seeded from the previous one (continuous joint motion, the null-space term
    of :func:`~dloplan.robot.kinematics.inverse` keeping the elbow from its limits). A pose
    that the tracking loses is solved afresh from all seeds; the motion to it is then marked
    not continuous. Never raises for an unreachable pose: it is reported.

    Parameters
    ----------
    robot : DescribedCell
    positions : array_like
        (K, 2, 3) TCP positions [m] in the world frame, arms in the order of :data:`ARMS`.
    rotations : scipy.spatial.transform.Rotation
        (K, 2) ``tcp_to_world`` rotations.
    seeds : array_like, optional
        (2, 7) joint values [rad] to start pose 0 from.
    options : ReachOptions, optional
    alternatives : scipy.spatial.transform.Rotation, optional
        (K, 2) other TCP rotations an arm may use instead, for the whole path (e.g. the grip
        turned by pi of a symmetric gripper); each arm keeps the better of the two (more poses
        reachable, then continuous, then the larger joint margin) and
        ``Reachability.grip_turned`` says which arm uses its alternative.

    Returns
    -------
    Reachability
    """
    pos, mats = validate_path(positions, rotations)
    grips = [mats]
    if alternatives is not None:
        grips.append(validate_path(positions, alternatives, "positions", "alternatives")[1])
    opts = options if options is not None else ReachOptions()
    if seeds is None:
        seeds = np.stack([arm.home for arm in robot.arms])
    seeds = np.asarray(seeds, dtype=float)
    if seeds.shape != (2, 7) or not np.all(np.isfinite(seeds)):
        raise ValueError(f"seeds: expected (2, 7) finite joint values [rad], got {seeds.shape}")
    return _check(robot, pos, grips, seeds, opts, clip_of_arm=(0, 1))


def check_reachability(gripper_positions, gripper_rotations: Rotation,
                       robot: DescribedCell | None = None, *, offset=(0.0, 0.0, 0.0),
                       assignment: str = "auto",
                       options: ReachOptions | None = None) -> Reachability:
    """Reachability of a plan's clip poses by a dual-arm robot (default: a YuMi at the world
    origin, see :func:`~dloplan.robot.yumi.yumi`).

    Parameters
    ----------
    gripper_positions : array_like
        (S+2, 2, 3) clip points [m] per planned shape: clip 0 holds the cable's first link,
        clip 1 its last (:class:`~dloplan.sim.clips.ClipPoses`).
    gripper_rotations : scipy.spatial.transform.Rotation
        (S+2, 2) ``clip_to_world`` rotations (x-axis = u, the held link direction).
    robot : DescribedCell, optional
    offset : array_like
        (3,) translation [m] applied to the whole job (e.g. from :func:`search_placement`).
    assignment : str
        Which arm holds which clip: ``"auto"`` (the clip further to +y, the robot's left, on
        average goes to the left arm), ``"first-left"`` or ``"first-right"``.
    options : ReachOptions, optional
    """
    robot = robot if robot is not None else yumi()
    pos, mats = validate_path(gripper_positions, gripper_rotations, "gripper_positions",
                               "gripper_rotations")
    offset = _as_offset(offset)
    order = arm_order(pos, assignment, robot)
    clip_pos = pos[:, order] + offset
    clip_rot = Rotation.from_matrix(mats[:, order])
    tcp_pos, tcp_rot = tcp_poses_from_clips(robot, clip_pos, clip_rot)
    opts = options if options is not None else ReachOptions()
    seeds = np.stack([arm.home for arm in robot.arms])
    grips = [tcp_rot.as_matrix()]
    if opts.symmetric_grip:
        grips.append(grips[0] @ _TURN_Z)
    return _check(robot, tcp_pos, grips, seeds, opts, clip_of_arm=tuple(order))


# --------------------------------------------------------------------------------------------


def _check(robot: DescribedCell, pos: np.ndarray, grips: list[np.ndarray], seeds: np.ndarray,
           opts: ReachOptions, clip_of_arm: tuple[int, int]) -> Reachability:
    """Track both arms through the sub-steps (each arm with the best of the ``grips``, each a
    (K, 2, 3, 3) set of TCP rotations), then margins, manipulability and clearance; with
    ``opts.verdict_only`` the first arm without a flawless grip ends the check
    (:func:`_stopped`)."""
    n_sub = substeps(pos, grips[0], opts)
    times = np.concatenate([[0.0]] + [k - 1 + np.arange(1, n + 1) / n
                                      for k, n in enumerate(n_sub, start=1)])
    planned = np.concatenate([[0], np.cumsum(n_sub)]).astype(int)
    tracks = []
    turned = []
    for a, arm in enumerate(robot.arms):
        options = [_track(arm, a, pos[:, a], g[:, a], times, planned, seeds[a], opts)
                   for g in grips]
        scores = [(t[1].sum(), t[4].sum(), joint_margin(arm, t[0][planned]).min())
                  for t in options]
        best = max(range(len(options)), key=lambda i: scores[i])
        if opts.verdict_only and not (options[best][1].all() and options[best][4].all()):
            return _stopped(robot, options[best], a, len(times), planned, clip_of_arm)
        tracks.append(options[best])
        turned.append(best == 1)
    q_all = np.stack([t[0] for t in tracks], axis=1)  # (M, 2, 7)
    q = q_all[planned]
    reachable = np.stack([t[1] for t in tracks], axis=1)
    perr = np.stack([t[2] for t in tracks], axis=1)
    aerr = np.stack([t[3] for t in tracks], axis=1)
    continuous = np.stack([t[4] for t in tracks], axis=1)
    messages = [m for t in tracks for m in t[5]]
    margin = np.stack([joint_margin(arm, q[:, a]) for a, arm in enumerate(robot.arms)], axis=1)
    manip = np.stack([manipulability(arm, q[:, a]) for a, arm in enumerate(robot.arms)], axis=1)
    gaps, pairs = arm_clearance(robot.left, q_all[:, 0], robot.right, q_all[:, 1])
    # clearance at pose k: min over the sub-steps leading to it and the pose itself
    clearance = np.minimum.reduceat(gaps, np.concatenate([[0], planned[:-1] + 1]))
    for k in range(len(q)):
        if reachable[k].all() and opts.min_margin > 0:
            for a, name in enumerate(ARMS):
                if margin[k, a] < opts.min_margin:
                    j = int(np.argmin(np.minimum(q[k, a] - robot.arms[a].lower,
                                                 robot.arms[a].upper - q[k, a])))
                    messages.append(f"warning: {name} arm, pose {k}: ABB axis "
                                    f"{ABB_AXIS_NUMBERS[j]} {np.degrees(margin[k, a]):.1f} deg "
                                    f"from its limit")
        if reachable[k].all() and clearance[k] < opts.min_clearance:
            lo = 0 if k == 0 else planned[k - 1] + 1
            i = lo + int(np.argmin(gaps[lo:planned[k] + 1]))
            where = f"pose {k}" if i == planned[k] else f"between pose {k - 1} and {k}"
            messages.append(f"arms collide, {where}: clearance {clearance[k] * 1e3:.1f} mm "
                            f"(left link {_link_name(pairs[i, 0])}, right link "
                            f"{_link_name(pairs[i, 1])})")
    collide = reachable.all(axis=1) & (clearance < opts.min_clearance)
    success = bool(reachable.all() and continuous.all() and not collide.any())
    if success:
        message = (f"all {len(q)} poses reachable by both arms; min joint margin "
                   f"{np.degrees(margin.min()):.1f} deg, min clearance "
                   f"{clearance.min() * 1e3:.1f} mm")
    else:
        message = (f"{int((~reachable).sum())} unreachable pose(s), "
                   f"{int((~continuous).sum())} discontinuous motion(s), "
                   f"{int(collide.sum())} arm collision(s) over {len(q)} poses")
    return Reachability(reachable, q, margin, manip, perr, aerr, continuous, clearance,
                        clip_of_arm, tuple(turned), success, message, tuple(messages))


def _stopped(robot: DescribedCell, track, index: int, n_times: int, planned,
             clip_of_arm: tuple[int, int]) -> Reachability:
    """The failed verdict of a ``verdict_only`` check: arm ``index``'s best ``track`` up to its
    first failure; the other arm and the clearance not computed (unreachable rows, NaN)."""
    n_poses = len(planned)
    other = robot.arms[1 - index]
    unknown = (np.repeat(other.home[None], n_times, axis=0), np.zeros(n_poses, dtype=bool),
               np.full(n_poses, np.nan), np.full(n_poses, np.nan), np.ones(n_poses, dtype=bool))
    pair = [track[:5], unknown][::1 if index == 0 else -1]
    q = np.stack([t[0][planned] for t in pair], axis=1)
    reachable, perr, aerr, continuous = (np.stack([t[i] for t in pair], axis=1)
                                         for i in range(1, 5))
    margin = np.stack([joint_margin(arm, q[:, a]) for a, arm in enumerate(robot.arms)], axis=1)
    manip = np.stack([manipulability(arm, q[:, a]) for a, arm in enumerate(robot.arms)], axis=1)
    messages = tuple(track[5])
    first = messages[0] if messages else f"{ARMS[index]} arm failed"
    return Reachability(reachable, q, margin, manip, perr, aerr, continuous,
                        np.full(n_poses, np.nan), clip_of_arm, (False, False), False,
                        f"{first} (verdict only: the check stopped there)", messages)


def _track(arm: CellArm, index: int, pos, mats, times, planned, seed, opts: ReachOptions):
    """Follow one arm's path through the sub-steps; returns per sub-step q and per pose flags
    (with ``opts.verdict_only``, up to the first pose not reached or motion lost: the poses
    after it read unreachable)."""
    name = ARMS[index]
    n_poses = len(pos)
    if n_poses > 1:
        slerp = Slerp(np.arange(n_poses), Rotation.from_matrix(mats))
        sub_rot = slerp(times).as_matrix()
    else:
        sub_rot = mats.copy()
    base = np.minimum(np.floor(times).astype(int), n_poses - 1)
    frac = times - base
    nxt = np.minimum(base + 1, n_poses - 1)
    sub_pos = (1.0 - frac)[:, None] * pos[base] + frac[:, None] * pos[nxt]
    first_opts = replace(opts.ik, min_margin=opts.min_margin)
    track_opts = replace(opts.ik, min_margin=opts.min_margin, restarts=0)
    q_all = np.empty((len(times), 7))
    reachable = np.zeros(n_poses, dtype=bool)
    continuous = np.ones(n_poses, dtype=bool)
    perr = np.full(n_poses, np.nan)
    aerr = np.full(n_poses, np.nan)
    messages = []
    res = inverse(arm, sub_pos[0], Rotation.from_matrix(sub_rot[0]), seed, first_opts)
    q_all[0] = res.q
    reachable[0], perr[0], aerr[0] = res.success, res.position_error, res.angle_error
    if not res.success:
        messages.append(f"{name} arm, pose 0: not reachable ({res.message})")
        if opts.verdict_only:
            q_all[1:] = res.q
            return q_all, reachable, perr, aerr, continuous, messages
    k = 1
    lost = False
    for i in range(1, len(times)):
        if (lost or not reachable[k - 1]) and i != planned[k]:
            q_all[i] = q_all[i - 1]  # motion already reported broken: only the pose matters
            continue
        step = solve_from(arm, sub_pos[i], sub_rot[i], q_all[i - 1], track_opts)
        q, pe, ae, ok = step.q, step.position_error, step.angle_error, step.success
        jump = np.max(np.abs(q - q_all[i - 1]))
        if ok and jump > opts.max_joint_step and not lost and reachable[k - 1]:
            j = int(np.argmax(np.abs(q - q_all[i - 1])))
            messages.append(f"{name} arm, between pose {k - 1} and {k}: configuration jump, "
                            f"ABB axis {ABB_AXIS_NUMBERS[j]} moves {np.degrees(jump):.0f} deg "
                            f"in one sub-step")
            lost = True
        if not ok and not lost and reachable[k - 1]:
            messages.append(f"{name} arm, between pose {k - 1} and {k}: lost the straight TCP "
                            f"motion at {times[i] - (k - 1):.2f} of the way (error "
                            f"{pe * 1e3:.2f} mm, {np.degrees(ae):.2f} deg)")
            lost = True
        if lost and opts.verdict_only:
            q_all[i:] = q_all[i - 1]
            continuous[k] = False
            return q_all, reachable, perr, aerr, continuous, messages
        if i == planned[k]:
            if not ok:  # solve the planned pose afresh
                res = inverse(arm, sub_pos[i], Rotation.from_matrix(sub_rot[i]), q, first_opts)
                q, pe, ae, ok = res.q, res.position_error, res.angle_error, res.success
                if not ok:
                    messages.append(f"{name} arm, pose {k}: not reachable ({res.message})")
            reachable[k], perr[k], aerr[k] = ok, pe, ae
            if not ok and opts.verdict_only:
                q_all[i:] = q
                return q_all, reachable, perr, aerr, continuous, messages
            continuous[k] = not lost
            lost = False
            k += 1
        q_all[i] = q
    return q_all, reachable, perr, aerr, continuous, messages


def reach_at_targets(robot: DescribedCell, clip_positions, clip_rotations: Rotation,
                     options: ReachOptions | None = None, *, stop: bool = False) -> np.ndarray:
    """Which planned poses each arm reaches, by IK at the targets only (no sub-steps, no
    continuity, no clearance): the cheap pre-check of
    :func:`~dloplan.robot.placement.search_placement` (with ``stop``), counted.

    Parameters
    ----------
    robot : DescribedCell
    clip_positions : array_like
        (K, 2, 3) clip points [m], ordered by arm (left, right).
    clip_rotations : scipy.spatial.transform.Rotation
        (K, 2) ``clip_to_world``, ordered by arm.
    options : ReachOptions, optional
    stop : bool
        Stop at an arm's first pose that no grip reaches (the poses after it read False): a
        yes-or-no pre-check.

    Returns
    -------
    numpy.ndarray
        (K, 2) bool: pose k solved for the arm (each pose seeded from the arm's previous one).
    """
    pos, _ = validate_path(clip_positions, clip_rotations, "clip_positions", "clip_rotations")
    opts = options if options is not None else ReachOptions()
    return _at_targets(robot, pos, clip_rotations, opts, stop=stop)


def _at_targets(robot: DescribedCell, clip_pos, clip_rot: Rotation, opts: ReachOptions,
                stop: bool) -> np.ndarray:
    """(K, 2) IK success at each target, seeded along the path, per arm with the better of its
    grips (the TCP turned by pi about z too when ``opts.symmetric_grip``, as the full check
    and the robot program do); ``stop`` at an arm's first miss with every grip."""
    tcp_pos, tcp_rot = tcp_poses_from_clips(robot, clip_pos, clip_rot)
    grips = [tcp_rot.as_matrix()]
    if opts.symmetric_grip:
        grips.append(grips[0] @ _TURN_Z)
    quick = replace(opts.ik, restarts=0)
    reached = np.zeros(tcp_pos.shape[:2], dtype=bool)
    for a, arm in enumerate(robot.arms):
        for mats in grips:
            q, hits = arm.home, np.zeros(len(tcp_pos), dtype=bool)
            for k in range(len(tcp_pos)):
                res = inverse(arm, tcp_pos[k, a], Rotation.from_matrix(mats[k, a]), q, quick)
                hits[k] = res.success
                if not res.success and stop:
                    break
                q = res.q if res.success else q
            if hits.sum() > reached[:, a].sum():
                reached[:, a] = hits
            if hits.all():
                break
        if stop and not reached[:, a].all():
            return reached
    return reached


def arm_order(pos: np.ndarray, assignment: str, robot: DescribedCell) -> list[int]:
    """The clip (0 first, 1 last) held by the left and by the right arm: ``auto`` the side rule
    in the robot's base frame (:func:`~dloplan.robot.assignment.assign_arms`), ``first-left``
    or ``first-right``.

    Parameters
    ----------
    pos : numpy.ndarray
        (K, 2, 3) clip points [m], clip 0 then clip 1.
    assignment : str
    robot : DescribedCell
    """
    if assignment == "first-left":
        return [0, 1]
    if assignment == "first-right":
        return [1, 0]
    if assignment == "auto":
        return list(assign_arms(pos, robot).clips)
    raise ValueError(
        f"assignment: expected 'auto', 'first-left' or 'first-right', got {assignment!r}")


def _link_name(i: int) -> str:
    return "gripper" if i == 7 else str(i + 1)


def _as_offset(offset) -> np.ndarray:
    arr = np.asarray(offset, dtype=float)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"offset: expected 3 finite numbers [m], got {offset!r}")
    return arr


def validate_path(positions, rotations, pos_name: str = "positions",
                  rot_name: str = "rotations") -> tuple[np.ndarray, np.ndarray]:
    """A dual-arm path's positions (K, 2, 3) [m] and rotation matrices (K, 2, 3, 3), checked:
    a ValueError naming ``pos_name`` or ``rot_name`` otherwise."""
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 3 or pos.shape[1:] != (2, 3) or pos.shape[0] < 1:
        raise ValueError(f"{pos_name}: expected shape (K, 2, 3) [m], got {pos.shape}")
    if not np.all(np.isfinite(pos)):
        raise ValueError(f"{pos_name}: non-finite coordinate (NaN or inf)")
    if not isinstance(rotations, Rotation) or rotations.shape != (pos.shape[0], 2):
        shape = getattr(rotations, "shape", None) if isinstance(rotations, Rotation) else None
        raise ValueError(f"{rot_name}: expected a scipy Rotation of shape ({pos.shape[0]}, 2), "
                         f"got {type(rotations).__name__} of shape {shape}")
    mats = rotations.as_matrix()
    if not np.all(np.isfinite(mats)):
        raise ValueError(f"{rot_name}: non-finite rotation")
    return pos, mats
