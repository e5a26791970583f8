"""Following a dual-arm TCP path: the settings every path check shares, the one sub-step rule, and
the path check of a described cell.

A path gives, per planned pose k and arm, a TCP pose in the world. Both arms move from pose
k-1 to pose k together, the TCP on a straight line with spherical-linear orientation (the
motion of :mod:`dloplan.trajectory`), in the same number of sub-steps (:func:`substeps`: at
most ``step_length`` and ``step_angle`` each); a check follows that motion with every IK seeded
from the previous sub-step, so the joint motion it reports is the continuous one a controller
executes, not a fresh solution per pose.

:func:`check_cell_path` verifies a path on a :class:`~dloplan.robot.described.DescribedCell`
for its program: IK at every planned pose, tracked through the sub-steps, joint margins,
arm-arm and arm-table capsule clearance at every sub-step, one verdict row per check, target
and arm (:class:`~dloplan.robot.checks.CheckRow`). The reach check of a grip or a placement,
which tries both grips of a symmetric gripper and may stop at the first failure, is
:func:`dloplan.robot.reachability.check_path` (the YuMi's program is verified along the
controller's own semantics, :mod:`dloplan.robot.program`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from .checks import CheckRow
from .described import DescribedCell, pair_clearance, table_clearance
from .kinematics import IKOptions, inverse, joint_margin

COMFORT_CLEARANCE = 0.05
"""[m] Arm-arm clearance beyond which a ranking (a program's joint solutions, a placement) no
longer prefers more clearance."""

COMFORT_MARGIN = float(np.radians(30.0))
"""[rad] Joint margin beyond which a ranking no longer prefers more margin."""


START_RESTARTS = 16
"""Random restarts of the IK at the first pose (at least; more if ``options.ik`` asks): the one
solve without a previous solution to follow, where a margin from the limits is wanted."""

CHECKS = ("reach", "joint limits", "continuity", "clearance", "table clearance", "joint speed",
          "joint acceleration")
"""The checks of a cell program, in the order of its rows (the last two along the time law,
:func:`dloplan.robot.cell_program.cell_program`)."""


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
        its approach (z) axis grips the cable the same way. When True, :func:`check_reachability`
        tracks both grips for each arm (one grip for the whole path, so the wrist does not spin
        between poses) and keeps the better one (more poses reachable, then continuous, then
        the larger joint margin).
    verdict_only : bool
        Only the verdict is wanted (a search that tries many placements): the tracking of an
        arm's grip stops at its first pose it cannot reach or motion it loses, the other arm and
        the clearance are skipped once an arm has no grip without a failure, and the rows after
        the failure are not computed (they read unreachable, their errors and clearance NaN).
        ``success`` is that of the complete check: a grip without a failure is tracked to the
        end, and of two such grips the one with the larger joint margin is kept, as in the
        complete check (so the clearance is judged for the same joint motion). The user-facing
        checks keep the default False: every row.
    """

    ik: IKOptions = field(default_factory=IKOptions)
    step_length: float = 0.02
    step_angle: float = 0.1
    max_joint_step: float = 0.5
    min_margin: float = np.radians(5.0)
    min_clearance: float = 0.005
    symmetric_grip: bool = True
    verdict_only: bool = False

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
class CellVerdict:
    """Verification of a dual-arm TCP path on a :class:`DescribedCell`.

    Attributes
    ----------
    joints : tuple of numpy.ndarray
        Per arm (K, n_arm) the tracked joint solutions [rad] at the K poses (the closest found
        where not reachable), within the limits.
    reachable, continuous : numpy.ndarray
        (K, 2) bool. ``continuous[k]``: the arm followed the straight TCP motion from pose k-1
        through every sub-step without losing the IK or a joint step above ``max_joint_step``.
    position_error, angle_error, joint_margin, joint_step, table_clearance : numpy.ndarray
        (K, 2) [m], [rad], [rad], largest joint step of a sub-step into pose k [rad], lowest
        capsule surface above the table over the motion into pose k [m].
    clearance : numpy.ndarray
        (K,) smallest arm-arm capsule distance [m] over the motion into pose k.
    motion_times : numpy.ndarray
        (N,) sub-step parameter (k + fraction) of the tracked motion.
    motion_joints : tuple of numpy.ndarray
        Per arm (N, n_arm) the joints [rad] of every sub-step (for a joint trajectory).
    rows : tuple of CheckRow
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
    rows: tuple[CheckRow, ...]

    @property
    def ok(self) -> bool:
        """Every row passes."""
        return all(row.ok for row in self.rows)

    @property
    def message(self) -> str:
        """One line: ok with the key numbers, or the first failure of each failing check."""
        if self.ok:
            return (f"cell ok: {len(self.clearance)} poses; min clearance "
                    f"{1e3 * self.clearance.min():.1f} mm, min table clearance "
                    f"{1e3 * self.table_clearance.min():.1f} mm, min joint margin "
                    f"{np.degrees(self.joint_margin.min()):.1f} deg")
        parts = []
        for name in CHECKS:
            bad = [row for row in self.rows if row.check == name and not row.ok]
            if bad:
                parts.append(f"{name} at {bad[0].label} ({bad[0].arm}: {bad[0].value:.4g} "
                             f"{bad[0].unit}{'; ' + bad[0].note if bad[0].note else ''})")
        return "cell FAILS: " + "; ".join(parts)


def check_cell_path(cell: DescribedCell, positions, rotations: Rotation, *, seeds=None,
                    options: ReachOptions | None = None) -> CellVerdict:
    """Verify a dual-arm TCP path on a cell (module docstring).

    Pose 0 is solved from ``seeds`` (default the arms' home poses) with the random restarts of
    ``options.ik`` and the wanted ``min_margin``. Between poses both arms move in the same
    number of sub-steps (at most ``step_length`` [m] and ``step_angle`` [rad] each), the TCP on
    a straight line with slerped orientation, each IK seeded from the previous sub-step without
    restarts; a pose the tracking loses is solved afresh (restarts) and marked not continuous.

    Parameters
    ----------
    cell : DescribedCell
    positions : array_like
        (K, 2, 3) TCP positions [m] in the world, arms in the order (left, right).
    rotations : scipy.spatial.transform.Rotation
        (K, 2) ``tcp_to_world``.
    seeds : sequence of array_like, optional
        Per arm the (n_arm,) joints [rad] to start pose 0 from.
    options : ReachOptions, optional
        ``ik``, ``step_length``, ``step_angle``, ``max_joint_step``, ``min_margin``,
        ``min_clearance`` are used.
    """
    opts = options if options is not None else ReachOptions()
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 3 or pos.shape[1:] != (2, 3) or not np.all(np.isfinite(pos)):
        raise ValueError(f"positions: expected finite (K, 2, 3) TCP positions [m], got shape "
                         f"{pos.shape}")
    if not isinstance(rotations, Rotation) or rotations.single or len(rotations) != pos.size // 3:
        raise ValueError("rotations: expected a scipy Rotation of shape (K, 2) matching "
                         "positions")
    n_poses = len(pos)
    mats = rotations.as_matrix().reshape(n_poses, 2, 3, 3)
    seeds = [arm.home for arm in cell.arms] if seeds is None else list(seeds)
    start_opts = replace(opts.ik, min_margin=opts.min_margin,
                         restarts=max(opts.ik.restarts, START_RESTARTS))
    track_opts = replace(opts.ik, restarts=0, min_margin=0.0)
    shape = (n_poses, 2)
    reach_ok, cont = np.zeros(shape, bool), np.ones(shape, bool)
    perr, aerr, step = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    joints = [np.zeros((n_poses, arm.n_joints)) for arm in cell.arms]
    motion = [[] for _ in cell.arms]
    times = []
    clearance, table = np.full(n_poses, np.inf), np.full(shape, np.inf)
    for a, arm in enumerate(cell.arms):
        first = inverse(arm, pos[0, a], Rotation.from_matrix(mats[0, a]), seed=seeds[a],
                        options=start_opts)
        joints[a][0] = first.q
        reach_ok[0, a], perr[0, a], aerr[0, a] = (first.success, first.position_error,
                                                  first.angle_error)
        motion[a].append(first.q)
    times.append(0.0)
    counts = substeps(pos, mats, opts)
    for k in range(1, n_poses):
        n_sub = int(counts[k - 1])
        frac = np.arange(1, n_sub + 1) / n_sub
        for a, arm in enumerate(cell.arms):
            sub_rot = Slerp([0.0, 1.0], Rotation.from_matrix(mats[k - 1:k + 1, a]))(frac)
            q = joints[a][k - 1]
            lost = not reach_ok[k - 1, a]
            for s, f in enumerate(frac):
                target = (1.0 - f) * pos[k - 1, a] + f * pos[k, a]
                result = inverse(arm, target, sub_rot[s], seed=q, options=track_opts)
                step[k, a] = max(step[k, a], float(np.max(np.abs(result.q - q))))
                lost = lost or not result.success
                q = result.q
                motion[a].append(q)
            result_k = result
            if lost:
                result_k = inverse(arm, pos[k, a], Rotation.from_matrix(mats[k, a]), seed=q,
                                   options=start_opts)
                cont[k, a] = not reach_ok[k - 1, a]  # after an unreachable pose: not a jump
                motion[a][-1] = result_k.q
            cont[k, a] &= step[k, a] <= opts.max_joint_step
            joints[a][k] = result_k.q
            reach_ok[k, a], perr[k, a], aerr[k, a] = (result_k.success, result_k.position_error,
                                                      result_k.angle_error)
        times.extend(k - 1 + frac)
    motion_q = [np.array(m) for m in motion]
    times = np.array(times)
    owner = np.concatenate([[0], np.ceil(times[1:] - 1e-9).astype(int)])
    sub_clear = pair_clearance(cell, motion_q[0], motion_q[1])
    np.minimum.at(clearance, owner, sub_clear)
    for a, arm in enumerate(cell.arms):
        np.minimum.at(table[:, a], owner, table_clearance(cell, arm, motion_q[a]))
    margin = np.stack([joint_margin(arm, joints[a]) for a, arm in enumerate(cell.arms)], 1)
    rows = _rows(cell, reach_ok, cont, perr, margin, step, table, clearance, opts)
    return CellVerdict(tuple(joints), reach_ok, cont, perr, aerr, margin, step, table, clearance,
                       times, tuple(motion_q), tuple(rows))


def _rows(cell, reach_ok, cont, perr, margin, step, table, clearance, opts) -> list[CheckRow]:
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
            rows.append(CheckRow("continuity", k, label, k, arm.name,
                                   float(np.degrees(step[k, a])), "deg", bool(cont[k, a]),
                                   "" if cont[k, a] else "configuration change or IK lost"))
            rows.append(CheckRow("table clearance", k, label, k, arm.name,
                                   1e3 * table[k, a], "mm",
                                   bool(table[k, a] >= opts.min_clearance)))
        both = bool(reach_ok[k].all())
        rows.append(CheckRow("clearance", k, label, k, "both", 1e3 * clearance[k], "mm",
                               bool(clearance[k] >= opts.min_clearance or not both)))
    return rows
