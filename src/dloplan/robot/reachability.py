"""Can a dual-arm cell hold a plan's clips? The reach verdict of a path, with both grips of a
symmetric gripper, for grips and placements.

:func:`check_reachability` maps a plan's clip poses to TCP poses with the arm assignment and
follows them with the one path check (:func:`dloplan.robot.path.check_path`, the reach check's
settings of :class:`~dloplan.robot.path.ReachOptions`, the grip turned by pi as the
alternative); :func:`reach_verdict` turns a path check into the verdict (success, warnings,
collisions naming the closest links); :func:`reach_at_targets` is its cheap version (IK at the
targets only). The placement searches (:mod:`dloplan.robot.placement`) use them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from .assignment import assign_arms
from .described import ARMS, DescribedCell
from .kinematics import IKOptions, inverse, manipulability
from .path import TURN_Z, PathCheck, ReachOptions, check_path, validate_path
from .yumi import ABB_AXIS_NUMBERS, yumi


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
    return np.array(clip_positions, dtype=float), tcp_rotations(robot, clip_rotations)


def tcp_rotations(robot: DescribedCell, clip_rotations: Rotation) -> Rotation:
    """(K, 2) ``tcp_to_world`` of the TCPs holding clips turned by ``clip_rotations`` (K, 2),
    ordered by arm: the orientations of :func:`tcp_poses_from_clips`."""
    mats = clip_rotations.as_matrix()
    return Rotation.from_matrix(np.stack([mats[:, a] @ arm.tcp_in_clip.as_matrix()
                                          for a, arm in enumerate(robot.arms)], axis=1))


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
    check = check_path(robot, tcp_pos, tcp_rot, options=opts)
    return reach_verdict(robot, check, opts, clip_of_arm=tuple(order))


def reach_verdict(robot: DescribedCell, check: PathCheck, options: ReachOptions,
                  clip_of_arm: tuple[int, int] = (0, 1)) -> Reachability:
    """The reach verdict of a path check (:func:`~dloplan.robot.path.check_path`): manipulability,
    joint-margin warnings and arm collisions (naming the closest links) added to its messages;
    success when every pose is reachable, every motion continuous and the arms never closer than
    ``options.min_clearance`` where both reach.

    Parameters
    ----------
    robot : DescribedCell
    check : PathCheck
    options : ReachOptions
        Those of the check.
    clip_of_arm : tuple of int
        Which clip each arm holds (``(0, 1)`` when the poses were given per arm).
    """
    q, reachable, margin = check.q, check.reachable, check.joint_margin
    manip = np.stack([manipulability(arm, q[:, a]) for a, arm in enumerate(robot.arms)], axis=1)
    fields = (reachable, q, margin, manip, check.position_error, check.angle_error,
              check.continuous, check.clearance, clip_of_arm, check.grip_turned)
    if check.stopped:
        first = check.messages[0] if check.messages else "an arm failed"
        return Reachability(*fields, False, f"{first} (verdict only: the check stopped there)",
                            check.messages)
    messages = list(check.messages)
    clearance, gaps, planned = check.clearance, check.motion_clearance, check.poses
    for k in range(len(q)):
        if reachable[k].all() and options.min_margin > 0:
            for a, name in enumerate(ARMS):
                if margin[k, a] < options.min_margin:
                    j = int(np.argmin(np.minimum(q[k, a] - robot.arms[a].lower,
                                                 robot.arms[a].upper - q[k, a])))
                    messages.append(f"warning: {name} arm, pose {k}: ABB axis "
                                    f"{ABB_AXIS_NUMBERS[j]} {np.degrees(margin[k, a]):.1f} deg "
                                    f"from its limit")
        if reachable[k].all() and clearance[k] < options.min_clearance:
            lo = 0 if k == 0 else planned[k - 1] + 1
            i = lo + int(np.argmin(gaps[lo:planned[k] + 1]))
            where = f"pose {k}" if i == planned[k] else f"between pose {k - 1} and {k}"
            messages.append(f"arms collide, {where}: clearance {clearance[k] * 1e3:.1f} mm "
                            f"(left link {_link_name(check.closest[i, 0])}, right link "
                            f"{_link_name(check.closest[i, 1])})")
    collide = reachable.all(axis=1) & (clearance < options.min_clearance)
    continuous = check.continuous
    success = bool(reachable.all() and continuous.all() and not collide.any())
    if success:
        message = (f"all {len(q)} poses reachable by both arms; min joint margin "
                   f"{np.degrees(margin.min()):.1f} deg, min clearance "
                   f"{clearance.min() * 1e3:.1f} mm")
    else:
        message = (f"{int((~reachable).sum())} unreachable pose(s), "
                   f"{int((~continuous).sum())} discontinuous motion(s), "
                   f"{int(collide.sum())} arm collision(s) over {len(q)} poses")
    return Reachability(*fields, success, message, tuple(messages))


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
    return TargetGrips(robot, clip_rotations, opts).reached(pos, stop=stop)


class TargetGrips:
    """The TCP orientations of a path's targets, each arm's grips (the TCP turned by pi about z
    too when ``options.symmetric_grip``, as the full check and the robot program do), made once
    for every translation of the path that :meth:`reached` is asked about: a placement search
    moves the targets, never turns them (:func:`~dloplan.robot.placement.search_placement`).

    Parameters
    ----------
    robot : DescribedCell
    clip_rotations : scipy.spatial.transform.Rotation
        (K, 2) ``clip_to_world``, ordered by arm.
    options : ReachOptions
    """

    def __init__(self, robot: DescribedCell, clip_rotations: Rotation,
                 options: ReachOptions) -> None:
        tcp = tcp_rotations(robot, clip_rotations).as_matrix()
        self.robot, self.quick = robot, replace(options.ik, restarts=0)
        self._grips = [tcp, tcp @ TURN_Z] if options.symmetric_grip else [tcp]
        self._targets: dict[tuple[int, int], np.ndarray] = {}

    def targets(self, arm: int, grip: int) -> np.ndarray:
        """(K, 3, 3) the targets of ``arm`` with ``grip`` as :func:`ik_at_targets` solves them
        (:func:`normalized`), made when first asked for."""
        if (arm, grip) not in self._targets:
            self._targets[arm, grip] = normalized(self._grips[grip][:, arm])
        return self._targets[arm, grip]

    def reached(self, clip_positions: np.ndarray, *, stop: bool = False) -> np.ndarray:
        """(K, 2) IK success at each target of the clip points ``clip_positions`` (K, 2, 3) [m]
        (the TCP sits on the clip point, :func:`tcp_poses_from_clips`), seeded along the path,
        per arm with the better of its grips; ``stop`` at an arm's first miss with every grip:
        :func:`reach_at_targets`."""
        reached = np.zeros(clip_positions.shape[:2], dtype=bool)
        for a, arm in enumerate(self.robot.arms):
            for grip in range(len(self._grips)):
                _, hits = solved_at_targets(arm, clip_positions[:, a], self.targets(a, grip),
                                            self.quick, stop=stop)
                if hits.sum() > reached[:, a].sum():
                    reached[:, a] = hits
                if hits.all():
                    break
            if stop and not reached[:, a].all():
                return reached
        return reached


def ik_at_targets(arm, positions, matrices, options: IKOptions, *, stop: bool = False,
                  seed_from_miss: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """IK of one arm at its targets only (no sub-steps), target k seeded from the solution at
    target k - 1 (the first from the arm's home pose): the one loop of the YuMi's reach
    pre-check (:func:`reach_at_targets`) and of a described cell's placement score
    (:func:`~dloplan.robot.placement.target_score`).

    Parameters
    ----------
    arm : CellArm
    positions : numpy.ndarray
        (K, 3) TCP targets [m] in the world.
    matrices : numpy.ndarray
        (K, 3, 3) ``tcp_to_world``.
    options : IKOptions
    stop : bool
        Stop at the first target missed (the targets after it read False, their joints the
        miss's).
    seed_from_miss : bool
        After a miss, seed the next target from the miss's closest try (True) or from the last
        target reached (False).

    Returns
    -------
    q : numpy.ndarray
        (K, n) joint values [rad] (a miss: the IK's closest try).
    hits : numpy.ndarray
        (K,) bool: target k reached.
    """
    return solved_at_targets(arm, positions, normalized(matrices), options, stop=stop,
                             seed_from_miss=seed_from_miss)


def normalized(matrices: np.ndarray) -> np.ndarray:
    """(K, 3, 3) rotation matrices as scipy makes them (``Rotation.from_matrix(...)
    .as_matrix()``, in one batch: row for row each single one's): the targets
    :func:`ik_at_targets` solves."""
    return Rotation.from_matrix(matrices).as_matrix()


def solved_at_targets(arm, positions, targets, options: IKOptions, *, stop: bool = False,
                      seed_from_miss: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """:func:`ik_at_targets` of targets already :func:`normalized` (``targets`` (K, 3, 3))."""
    q, qs = arm.home, np.empty((len(positions), len(arm.home)))
    hits = np.zeros(len(positions), dtype=bool)
    for k in range(len(positions)):
        res = inverse(arm, positions[k], targets[k], q, options)
        hits[k], qs[k] = res.success, res.q
        if not res.success and stop:
            qs[k + 1:] = res.q
            break
        q = res.q if res.success or seed_from_miss else q
    return qs, hits


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
