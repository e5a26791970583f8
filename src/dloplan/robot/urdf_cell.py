"""A dual-arm cell built from robot descriptions, and its verification along a plan.

A :class:`DescribedCell` is two :class:`~dloplan.robot.chain.CellArm` s (any serial arms read
from URDF, each with its base pose, tool and joint limits) and the table they stand on.
:func:`check_cell_path` verifies a dual-arm TCP path on it as :mod:`dloplan.robot.reachability`
does for the YuMi: IK at every planned pose, tracked continuously through sub-steps between
poses (each solve seeded from the previous one), joint margins, arm-arm and arm-table capsule
clearance at every sub-step, and one verdict row per check, target and arm (the robot
program's :class:`~dloplan.robot.program.CheckRow`).
:func:`search_cell_placement` shifts the job on the table to where the cell executes it best.

Presets (:data:`PRESETS`): ``ur5e_pair`` (two UR5e side by side), ``panda_pair`` (two Franka
arms with the Franka Hand), ``yumi`` (the ABB YuMi from one description with two chains).
"""

from __future__ import annotations

import inspect
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from .assignment import assign_arms
from .chain import DEFAULT_TCP_IN_CLIP, CellArm, capsules, in_base_frame
from .collision import arm_clearance
from .description import load_arm, vendored
from .kinematics import inverse, joint_margin
from .program import CheckRow
from .reachability import ReachOptions
from .yumi import ARMS, yumi

START_RESTARTS = 16
"""Random restarts of the IK at the first pose (at least; more if ``options.ik`` asks): the one
solve without a previous solution to follow, where a margin from the limits is wanted."""

COMFORT_CLEARANCE = 0.05
"""[m] Arm-arm clearance beyond which the placement search no longer prefers more."""

COMFORT_MARGIN = float(np.radians(30.0))
"""[rad] Joint margin beyond which the placement search prefers a smaller shift of the job."""

PLACEMENT_TRIES = 3
"""Best-ranked placements verified in full by :func:`search_cell_placement`."""

CHECKS = ("reach", "joint limits", "continuity", "clearance", "table clearance", "joint speed",
          "joint acceleration")
"""The checks of a cell program, in the order of its rows (the last two along the time law,
:func:`dloplan.robot.cell_program.cell_program`)."""

MIN_MARGIN = float(np.radians(5.0))
"""[rad] Default smallest joint margin of a cell's program (:attr:`DescribedCell.min_margin`)."""


@dataclass(frozen=True, eq=False)
class DescribedCell:
    """Two arms from descriptions on a table.

    Parameters
    ----------
    name : str
    left, right : CellArm
        The arms (``name`` ``"left"`` and ``"right"``): the world frame is the plan's frame.
    table_height : float
        z of the table top in the world [m]; every moving capsule must stay above it.
    shared_base : bool
        Both arms hang on one body (one description with two chains, e.g. the YuMi): the base
        link's capsules are not checked against each other.
    place : bool
        A plan is verified where the placement search puts it (:func:`search_cell_placement`);
        False: where it was planned.
    writers : dict
        Per program format (``urscript``, ``ros_joints``) the writer's keyword settings (the
        scenario's ``robot.urscript`` / ``robot.ros_joints``: the cell's wiring and controller
        names).
    source : dict, optional
        The mapping that builds the cell again (:func:`cell_from_mapping`, lengths in m, URDF
        paths absolute); the presets record theirs.
    min_margin : float
        Smallest distance [rad] of every joint from its limits at every pose: a program closer
        fails its ``joint limits`` check (default :data:`MIN_MARGIN`, 5 deg).
    """

    name: str
    left: CellArm
    right: CellArm
    table_height: float = 0.0
    shared_base: bool = False
    place: bool = True
    writers: dict = field(default_factory=dict)
    source: dict | None = None
    min_margin: float = MIN_MARGIN

    def __post_init__(self) -> None:
        if (self.left.name, self.right.name) != ARMS:
            raise ValueError(f"arms: expected names {ARMS}, got ({self.left.name!r}, "
                             f"{self.right.name!r})")
        if not np.isfinite(self.table_height):
            raise ValueError(f"table_height: expected a finite number [m], got "
                             f"{self.table_height!r}")
        if not (np.isfinite(self.min_margin) and self.min_margin >= 0):
            raise ValueError(f"min_margin: expected a joint margin >= 0 [rad], got "
                             f"{self.min_margin!r}")

    @property
    def arms(self) -> tuple[CellArm, CellArm]:
        """``(left, right)``."""
        return (self.left, self.right)

    def to_base(self, positions) -> np.ndarray:
        """World points [m], (..., 3), in the cell's frame: origin between the two bases, y
        from the right base to the left one (horizontal), z up; the arms' base frame when both
        share a base (one body, e.g. the YuMi, however it is turned). The clip with the larger
        y goes to the left arm (:func:`~dloplan.robot.assignment.assign_arms`)."""
        pos = np.asarray(positions, dtype=float)
        across = self.left.base_position - self.right.base_position
        across[2] = 0.0
        if np.linalg.norm(across) < 1e-9:
            return self.left.base_rotation.inv().apply(
                pos.reshape(-1, 3) - self.left.base_position).reshape(pos.shape)
        y = across / np.linalg.norm(across)
        axes = np.stack([np.cross(y, [0.0, 0.0, 1.0]), y, [0.0, 0.0, 1.0]], 1)
        middle = 0.5 * (self.left.base_position + self.right.base_position)
        return (pos - middle) @ axes

    def to_dict(self) -> dict:
        """JSON-ready data that builds the cell again (:func:`cell_from_dict`)."""
        if self.source is None:
            raise ValueError(f"cell {self.name!r}: built without a mapping, cannot be recorded "
                             "(build it with cell_from_mapping or a preset)")
        return {"kind": "described", **self.source, "place": self.place,
                "writers": self.writers, "min_margin": self.min_margin}


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


def pair_clearance(cell: DescribedCell, q_left, q_right) -> np.ndarray:
    """Smallest arm-arm capsule clearance [m], (...,), negative when they overlap
    (:func:`~dloplan.robot.collision.arm_clearance`; the base links of arms on one body not
    against each other).

    Parameters
    ----------
    q_left, q_right : array_like
        (..., n_arm) joint values [rad] of each arm, same batch shape.
    """
    return arm_clearance(cell.left, q_left, cell.right, q_right,
                         shared_base=cell.shared_base)[0]


def _table_clearance(cell: DescribedCell, arm: CellArm, q) -> np.ndarray:
    """(...,) lowest surface of the arm's moving capsules above the table [m]."""
    seg, rad, link = capsules(arm, q)
    low = seg[..., 2].min(axis=-1) - rad - cell.table_height
    return np.where(link >= 0, low, np.inf).min(axis=-1)


def _substeps(positions, matrices, k: int, options: ReachOptions) -> int:
    """Sub-steps of the motion from pose k-1 to k (the larger of both arms' needs)."""
    dist = np.linalg.norm(positions[k] - positions[k - 1], axis=-1).max()
    turn = np.einsum("aij,akj->aik", matrices[k], matrices[k - 1])
    angle = Rotation.from_matrix(turn).magnitude().max()
    return max(1, int(np.ceil(dist / options.step_length)),
               int(np.ceil(angle / options.step_angle)))


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
    for k in range(1, n_poses):
        n_sub = _substeps(pos, mats, k, opts)
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
        np.minimum.at(table[:, a], owner, _table_clearance(cell, arm, motion_q[a]))
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


def search_cell_placement(cell: DescribedCell, positions, rotations: Rotation, *,
                          offsets=None, options: ReachOptions | None = None):
    """Shift the job on the table to where the cell executes it best.

    Each candidate offset (a translation of every TCP pose) is scored by IK at the planned
    poses only (each seeded from the previous pose, no sub-steps): first the number of poses
    both arms reach, then the smallest arm-arm clearance (up to :data:`COMFORT_CLEARANCE`),
    then the smallest joint margin (up to :data:`COMFORT_MARGIN`), then the smallest shift.
    The :data:`PLACEMENT_TRIES` best candidates are then verified in full with
    :func:`check_cell_path` (whose IK may choose other solutions, e.g. another elbow of a
    7-joint arm) in that order: the first that passes is returned, else the best ranked.

    Parameters
    ----------
    cell : DescribedCell
    positions, rotations
        As for :func:`check_cell_path`.
    offsets : array_like, optional
        (C, 3) candidate translations [m]; default a grid of +-0.2 m in x and +-0.1 m in y in
        0.1 m steps (15 candidates).

    Returns
    -------
    offset : numpy.ndarray
        (3,) the best translation [m].
    verdict : CellVerdict
        Of the shifted path.
    """
    opts = options if options is not None else ReachOptions()
    pos = np.asarray(positions, dtype=float)
    if offsets is None:
        gx, gy = np.meshgrid(np.arange(-0.2, 0.201, 0.1), np.arange(-0.1, 0.101, 0.1))
        offsets = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], 1)
    offsets = np.asarray(offsets, dtype=float).reshape(-1, 3)
    mats = rotations.as_matrix().reshape(len(pos), 2, 3, 3)
    quick = replace(opts.ik, restarts=1, min_margin=0.0)
    scores = []
    for offset in offsets:
        qs = [[], []]
        reached = np.ones(len(pos), bool)
        for a, arm in enumerate(cell.arms):
            q = arm.home
            for k in range(len(pos)):
                result = inverse(arm, pos[k, a] + offset, Rotation.from_matrix(mats[k, a]),
                                 seed=q, options=quick)
                reached[k] &= result.success
                q = result.q
                qs[a].append(q)
        q_l, q_r = np.array(qs[0]), np.array(qs[1])
        clear = float(pair_clearance(cell, q_l, q_r)[reached].min()) if reached.any() else -1.0
        margin = min(float(joint_margin(cell.left, q_l).min()),
                     float(joint_margin(cell.right, q_r).min()))
        scores.append((int(reached.sum()), min(clear, COMFORT_CLEARANCE),
                       min(margin, COMFORT_MARGIN), -float(np.linalg.norm(offset))))
    ranked = sorted(range(len(offsets)), key=lambda i: scores[i], reverse=True)
    first = None
    for i in ranked[:PLACEMENT_TRIES]:
        verdict = check_cell_path(cell, pos + offsets[i], rotations, options=opts)
        if verdict.ok:
            return offsets[i], verdict
        first = first or (offsets[i], verdict)
    return first


def _check_separation(separation) -> None:
    if not (np.isfinite(separation) and separation > 0):
        raise ValueError(f"robot.cell.separation: got {separation!r}, expected a distance > 0 "
                         "[m] between the two bases")


def ur5e_pair(*, separation: float = 0.8, tcp_offset: float = 0.15, tool_radius: float = 0.045,
              table_height: float = 0.0) -> DescribedCell:
    """Two UR5e side by side on a table, facing +x.

    The bases stand at ``(0, +-separation/2, table_height)``, each turned by pi about z so its
    zero pose points along +x; the tool is a gripper ``tcp_offset`` [m] along the flange z
    (e.g. a Robotiq 2F-85 with coupling, 0.15 m) drawn as a capsule of ``tool_radius``. Home:
    ``[0, -90, 90, -90, -90, 0]`` deg (elbow up, tool pointing down).
    """
    _check_separation(separation)
    description = load_arm(vendored("ur5e.urdf"), "tool0")
    home = np.radians([0.0, -90.0, 90.0, -90.0, -90.0, 0.0])
    turn = Rotation.from_rotvec([0.0, 0.0, np.pi])
    arms = [CellArm(side, replace(description, name=f"ur5e_{side}"),
                    base_position=(0.0, sign * separation / 2, table_height), base_rotation=turn,
                    tcp_offset=(0.0, 0.0, tcp_offset), tool_radius=tool_radius, home=home)
            for side, sign in zip(ARMS, (1.0, -1.0), strict=True)]
    return DescribedCell("ur5e_pair", *arms, table_height=table_height, source={
        "preset": "ur5e_pair", "separation": separation, "tcp_offset": tcp_offset,
        "tool_radius": tool_radius, "table_height": table_height})


PANDA_MAX_ACCELERATION = (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0)
"""[rad/s^2] The Panda's joint acceleration limits (Franka Emika, "Robot and interface
specifications", Franka Control Interface documentation: ddq_max); its joint speed limits
(2.175 rad/s for joints 1-4, 2.61 for 5-7) are the description's."""

PANDA_TCP_IN_CLIP = Rotation.from_matrix(np.diag([1.0, -1.0, -1.0]))
"""TCP axes in the clip frame for the Franka Hand: TCP x = u (the cable), y = -v, z = -w."""

CABLE_ALONG = {"y": DEFAULT_TCP_IN_CLIP, "x": PANDA_TCP_IN_CLIP}
"""A scenario's ``cable_along`` (the TCP axis the held cable runs along; the gripper approaches
from above) -> ``tcp_in_clip``: ``y`` for fingers closing along TCP x (YuMi, default), ``x``
for fingers closing along TCP y (Franka Hand)."""


def panda_pair(*, separation: float = 0.8, table_height: float = 0.0) -> DescribedCell:
    """Two Franka Emika Panda arms with the Franka Hand side by side, facing +x.

    Bases at ``(0, +-separation/2, table_height)``; the TCP is the Franka Hand's (0.1034 m
    along the hand's z, between the fingertips), the fingers drawn as a 3 cm capsule from the
    hand to the TCP. Home: Franka's ready pose ``[0, -45, 0, -135, 0, 90, 45]`` deg. The
    hand's fingers close along its y-axis, so it holds a clip with the cable along TCP x and
    approaches from above (:data:`PANDA_TCP_IN_CLIP`).
    """
    _check_separation(separation)
    description = load_arm(vendored("panda.urdf"), "panda_hand", base_link="panda_link0")
    home = np.radians([0.0, -45.0, 0.0, -135.0, 0.0, 90.0, 45.0])
    arms = [CellArm(side, replace(description, name=f"panda_{side}"),
                    base_position=(0.0, sign * separation / 2, table_height),
                    tcp_offset=(0.0, 0.0, 0.1034), tool_radius=0.03, home=home,
                    tcp_in_clip=PANDA_TCP_IN_CLIP, max_acceleration=PANDA_MAX_ACCELERATION)
            for side, sign in zip(ARMS, (1.0, -1.0), strict=True)]
    return DescribedCell("panda_pair", *arms, table_height=table_height, source={
        "preset": "panda_pair", "separation": separation, "table_height": table_height})


def yumi_cell(*, table_height: float = 0.0) -> DescribedCell:
    """The ABB YuMi as a described cell: both arms of :func:`dloplan.robot.yumi.yumi` (body
    ``yumi_body`` at the world origin, the SmartGripper's TCP on tool0, ABB's home pose, the
    arm angle's plug-in); the vendored ``yumi.urdf`` loads to the same chains (tested)."""
    robot = yumi()
    return DescribedCell("yumi", robot.left, robot.right, table_height=table_height,
                         shared_base=True, source={"preset": "yumi",
                                                   "table_height": table_height})


@dataclass(frozen=True, eq=False)
class CellPlan:
    """A plan's trajectory verified on a cell: what the vendor writers are given.

    Attributes
    ----------
    cell : DescribedCell
    offset : numpy.ndarray
        (3,) translation [m] of the job found by the placement search (zeros without it).
    swapped : bool
        The trajectory's left clip went to the right arm (it lies on the robot's right).
    times : numpy.ndarray
        (K,) knot times [s], strictly increasing (knots where no arm moves dropped).
    positions : numpy.ndarray
        (K, 2, 3) TCP positions [m] in the world, offset applied.
    rotations : scipy.spatial.transform.Rotation
        (K * 2,) ``tcp_to_world``, pose-major (k, arm).
    verdict : CellVerdict
        Its rows labelled by the plan's shapes.
    shapes : numpy.ndarray
        (K,) int, the plan's shape (trajectory knot) of each kept knot.
    """

    cell: DescribedCell
    offset: np.ndarray
    swapped: bool
    times: np.ndarray
    positions: np.ndarray
    rotations: Rotation
    verdict: CellVerdict
    shapes: np.ndarray

    def base_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """(K, 2, 3) TCP positions [m] and (K, 2, 3) rotation vectors [rad] in each arm's base
        frame (URScript's ``p[...]`` poses)."""
        mats = self.rotations.as_matrix().reshape(-1, 2, 3, 3)
        pairs = [in_base_frame(arm, self.positions[:, a], Rotation.from_matrix(mats[:, a]))
                 for a, arm in enumerate(self.cell.arms)]
        return (np.stack([p for p, _ in pairs], 1), np.stack([r for _, r in pairs], 1))


def verify_on_cell(cell: DescribedCell, trajectory, *, tcp_in_clip: Rotation | None = None,
                   place: bool | None = None, options: ReachOptions | None = None) -> CellPlan:
    """Verify a plan's timed clip trajectory on a cell.

    The TCP holds each clip at the clip point with ``clip_to_world * tcp_in_clip`` (default
    each arm's :attr:`~dloplan.robot.chain.CellArm.tcp_in_clip`); the clip on the robot's
    left (larger y in :meth:`DescribedCell.to_base`) goes to the left arm; knots where no arm
    moves are dropped; with ``place`` (default ``cell.place``) the job is shifted by
    :func:`search_cell_placement`, else verified where it is. The verdict's rows are labelled
    by the plan's shapes (``"shape k"``, one knot per shape).

    Parameters
    ----------
    cell : DescribedCell
    trajectory : dloplan.trajectory.Trajectory
        Knot times [s], clip positions (K, 2, 3) [m] and rotations per arm.
    tcp_in_clip : scipy.spatial.transform.Rotation, optional
        The same mapping for both arms instead of the arms' own.
    place : bool, optional
    options : ReachOptions, optional
    """
    options = options if options is not None else ReachOptions(min_margin=cell.min_margin)
    times = np.asarray(trajectory.times, dtype=float)
    keep = np.concatenate([[True], np.diff(times) > 0])
    pos = np.asarray(trajectory.positions, dtype=float)[keep]
    mats = np.stack([r.as_matrix() for r in trajectory.rotations], 1)[keep]
    swapped = assign_arms(pos, cell).left_clip == 1
    if swapped:
        pos, mats = pos[:, ::-1], mats[:, ::-1]
    mats = np.stack([mats[:, a] @ (tcp_in_clip or arm.tcp_in_clip).as_matrix()
                     for a, arm in enumerate(cell.arms)], 1)
    rot = Rotation.from_matrix(mats.reshape(-1, 3, 3))
    if cell.place if place is None else place:
        offset, verdict = search_cell_placement(cell, pos, rot, options=options)
    else:
        offset, verdict = np.zeros(3), check_cell_path(cell, pos, rot, options=options)
    shapes = np.flatnonzero(keep)
    rows = tuple(replace(row, label=f"shape {shapes[row.shape]}", shape=int(shapes[row.shape]))
                 for row in verdict.rows)
    return CellPlan(cell, np.asarray(offset, float), swapped, times[keep], pos + offset, rot,
                    replace(verdict, rows=rows), shapes)


PRESETS = {"ur5e_pair": ur5e_pair, "panda_pair": panda_pair, "yumi": yumi_cell}
"""Cell presets by name: a function of keyword settings returning a :class:`DescribedCell`."""


@dataclass(frozen=True)
class ArmSpec:
    """One arm of a cell given by paths (the scenario's ``robot.cell.arms`` entries).

    Parameters
    ----------
    urdf : str
        Path of the URDF.
    tip_link : str
    base_link : str, optional
    base_position : tuple
        (3,) [m].
    base_rpy : tuple
        (3,) URDF roll-pitch-yaw [rad] of ``base_to_world``.
    tcp_offset : tuple
        (3,) [m] in the tip frame.
    tool_radius : float
        [m].
    home : tuple, optional
        (n,) [rad].
    cable_along : str
        Key of :data:`CABLE_ALONG`.
    max_acceleration : tuple, optional
        (n,) published joint acceleration limits [rad/s^2].
    package_dirs : dict
        For :func:`~dloplan.robot.description.load_arm`.
    """

    urdf: str
    tip_link: str
    base_link: str | None = None
    base_position: tuple = (0.0, 0.0, 0.0)
    base_rpy: tuple = (0.0, 0.0, 0.0)
    tcp_offset: tuple = (0.0, 0.0, 0.0)
    tool_radius: float = 0.0
    home: tuple | None = None
    cable_along: str = "y"
    max_acceleration: tuple | None = None
    package_dirs: dict = field(default_factory=dict)


def _cable_along(value, side: str) -> Rotation:
    if value not in CABLE_ALONG:
        raise ValueError(f"robot.cell.arms.{side}.cable_along: got {value!r}, expected one of "
                         f"{sorted(CABLE_ALONG)}")
    return CABLE_ALONG[value]


def cell_from_specs(name: str, left: ArmSpec, right: ArmSpec, *,
                    table_height: float = 0.0) -> DescribedCell:
    """A cell from one URDF per arm (or the same URDF with two tip links)."""
    arms = []
    for side, spec in zip(ARMS, (left, right), strict=True):
        try:
            description = load_arm(spec.urdf, spec.tip_link, base_link=spec.base_link,
                                   name=f"{name}_{side}", package_dirs=spec.package_dirs)
        except ValueError as exc:  # about tip_link / base_link, or about the URDF file
            field_name = str(exc).split(":", 1)[0]
            where = f"robot.cell.arms.{side}" + ("" if field_name in ("tip_link", "base_link")
                                                 else ".urdf")
            raise ValueError(f"{where}: {exc}") from None
        if spec.home is not None and len(spec.home) != description.n_joints:
            raise ValueError(f"robot.cell.arms.{side}.home_deg: got {len(spec.home)} values, "
                             f"expected {description.n_joints} (one per joint of "
                             f"{spec.tip_link!r})")
        if spec.max_acceleration is not None and \
                len(spec.max_acceleration) != description.n_joints:
            raise ValueError(f"robot.cell.arms.{side}.max_acceleration: got "
                             f"{len(spec.max_acceleration)} values, expected "
                             f"{description.n_joints} (one per joint of {spec.tip_link!r})")
        arms.append(CellArm(side, description, base_position=spec.base_position,
                            base_rotation=Rotation.from_euler("xyz", spec.base_rpy),
                            tcp_offset=spec.tcp_offset, tool_radius=spec.tool_radius,
                            home=spec.home, tcp_in_clip=_cable_along(spec.cable_along, side),
                            max_acceleration=spec.max_acceleration))
    shared = (left.urdf == right.urdf and left.base_link == right.base_link
              and tuple(left.base_position) == tuple(right.base_position)
              and tuple(left.base_rpy) == tuple(right.base_rpy))
    return DescribedCell(name, *arms, table_height=table_height, shared_base=shared)



ARM_KEYS = {"urdf", "tip_link", "base_link", "base_position", "base_rpy", "tcp_offset",
            "tool_radius", "home_deg", "cable_along", "max_acceleration"}
"""Keys of one arm in a scenario's ``robot.cell.arms`` (angles in degrees, lengths in m,
``max_acceleration`` the published joint acceleration limits in rad/s^2)."""

LENGTH_KEYS = {"separation", "tcp_offset", "tool_radius", "table_height", "base_position"}
"""Keys of a cell mapping (a preset's settings, the cell's, an arm's) that are lengths: given in
the scenario's units, multiplied by its scale."""


def _scaled(mapping: dict, scale: float) -> dict:
    """The mapping with its lengths (:data:`LENGTH_KEYS`) in m."""
    def scale_value(key, value):
        if key not in LENGTH_KEYS or isinstance(value, bool):
            return value
        try:
            return (np.asarray(value, dtype=float) * scale).tolist()
        except (TypeError, ValueError):
            raise ValueError(f"robot.cell.{key}: got {value!r}, expected a length (a number or "
                             "a list of numbers)") from None
    return {key: scale_value(key, value) for key, value in mapping.items()}


def _numbers(field_name: str, value, count: int | None, unit: str) -> tuple[float, ...]:
    """``value`` as ``count`` finite numbers (any count for None), else a ValueError naming the
    field, the value and what was expected."""
    expected = f"{count} finite numbers [{unit}]" if count else \
        f"finite numbers [{unit}], one per joint"
    if isinstance(value, str | bytes | bool) or not isinstance(value, list | tuple):
        raise ValueError(f"{field_name}: got {value!r}, expected a list of {expected}")
    try:
        numbers = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{field_name}: got {value!r}, expected {expected}") from None
    if numbers.ndim != 1 or (count is not None and len(numbers) != count) or \
            not np.all(np.isfinite(numbers)) or any(isinstance(v, bool) for v in value):
        raise ValueError(f"{field_name}: got {value!r}, expected {expected}")
    return tuple(float(v) for v in numbers)


def _arm_spec(side: str, arm, folder, scale: float) -> tuple[ArmSpec, dict]:
    """One arm of a scenario's ``robot.cell.arms`` checked field by field (before any file is
    read): its :class:`ArmSpec` and its record (lengths in m, the URDF path absolute)."""
    where = f"robot.cell.arms.{side}"
    if not isinstance(arm, dict):
        raise ValueError(f"{where}: expected a mapping, got {arm!r}")
    extra = set(arm) - ARM_KEYS
    if extra or not {"urdf", "tip_link"} <= set(arm):
        raise ValueError(f"{where}: got keys {sorted(arm)}, expected "
                         f"urdf, tip_link and some of {sorted(ARM_KEYS)}")
    for key in ("urdf", "tip_link", "base_link", "cable_along"):
        if key in arm and not (isinstance(arm[key], str) and arm[key]):
            raise ValueError(f"{where}.{key}: got {arm[key]!r}, expected a name (text)")
    urdf = Path(os.path.abspath(Path(folder) / arm["urdf"]))  # symlinks are the reader's
    for key, unit in (("base_position", "file units"), ("tcp_offset", "file units"),
                      ("base_rpy", "deg")):
        if key in arm:
            _numbers(f"{where}.{key}", arm[key], 3, unit)
    home = arm.get("home_deg")
    if home is not None:
        home = _numbers(f"{where}.home_deg", home, None, "deg")
    accel = arm.get("max_acceleration")
    if accel is not None:
        accel = _numbers(f"{where}.max_acceleration", accel, None, "rad/s^2")
        if min(accel) <= 0:
            raise ValueError(f"{where}.max_acceleration: got {arm['max_acceleration']!r}, "
                             "expected limits > 0 [rad/s^2], one per joint")
    radius = arm.get("tool_radius", 0.0)
    if isinstance(radius, bool) or not isinstance(radius, int | float) or \
            not (np.isfinite(radius) and radius >= 0):
        raise ValueError(f"{where}.tool_radius: got {radius!r}, expected a finite number >= 0 "
                         "[file units]")
    record = {**_scaled(arm, scale), "urdf": str(urdf)}
    spec = ArmSpec(str(urdf), arm["tip_link"], arm.get("base_link"),
                   tuple(record.get("base_position", (0.0, 0.0, 0.0))),
                   tuple(np.radians(arm.get("base_rpy", (0.0, 0.0, 0.0)))),
                   tuple(record.get("tcp_offset", (0.0, 0.0, 0.0))),
                   float(record.get("tool_radius", 0.0)),
                   None if home is None else tuple(np.radians(home)),
                   arm.get("cable_along", "y"), accel)
    return spec, record


def cell_from_mapping(data: dict, folder=".", scale: float = 1.0) -> DescribedCell:
    """The cell of a scenario's ``robot.cell`` section (``docs/cells.md``).

    Either ``{preset: name, <keyword settings of the preset>}`` or ``{arms: {left: {...},
    right: {...}}, table_height: h, name: n}`` with per arm the keys of :data:`ARM_KEYS`
    (``urdf`` relative to ``folder``; ``base_rpy`` and ``home_deg`` in degrees). Lengths
    (:data:`LENGTH_KEYS`) are in file units, ``scale`` [m per unit]. The cell records its
    ``source``: this mapping with lengths in m and URDF paths absolute.

    Raises
    ------
    ValueError
        Naming the field, the value and what was expected.
    """
    if not isinstance(data, dict):
        raise ValueError(f"robot.cell: expected a mapping, got {data!r}")
    if "preset" in data:
        settings = _scaled({k: v for k, v in data.items() if k != "preset"}, scale)
        if data["preset"] not in PRESETS:
            raise ValueError(f"robot.cell.preset: got {data['preset']!r}, expected one of "
                             f"{sorted(PRESETS)}")
        make = PRESETS[data["preset"]]
        allowed = set(inspect.signature(make).parameters)
        if set(settings) - allowed:
            raise ValueError(f"robot.cell: got {sorted(set(settings) - allowed)} for preset "
                             f"{data['preset']!r}, expected some of {sorted(allowed)}")
        try:
            return make(**settings)
        except TypeError as exc:
            raise ValueError(f"robot.cell: preset {data['preset']!r}: {exc}") from None
    arms = data.get("arms")
    if not isinstance(arms, dict) or set(arms) != set(ARMS):
        raise ValueError(f"robot.cell: expected `preset` or `arms` with keys {ARMS}, got "
                         f"{sorted(data)}")
    unknown = set(data) - {"arms", "table_height", "name"}
    if unknown:
        raise ValueError(f"robot.cell: unknown keys {sorted(unknown)}")
    specs, source = [], {"arms": {}, **_scaled({k: v for k, v in data.items() if k != "arms"},
                                               scale)}
    for side in ARMS:
        spec, source["arms"][side] = _arm_spec(side, arms[side], folder, scale)
        specs.append(spec)
    cell = cell_from_specs(str(data.get("name", "cell")), *specs,
                           table_height=float(source.get("table_height", 0.0)))
    return replace(cell, source=source)


def cell_from_record(data: dict) -> DescribedCell:
    """The cell of :meth:`DescribedCell.to_dict`'s data (a plan document's ``robot.cell``)."""
    if not isinstance(data, dict) or data.get("kind") != "described":
        raise ValueError(f"robot.cell: expected a described cell record, got {data!r}")
    mapping = {k: v for k, v in data.items()
               if k not in ("kind", "place", "writers", "min_margin")}
    return replace(cell_from_mapping(mapping), place=bool(data.get("place", True)),
                   writers=dict(data.get("writers") or {}),
                   min_margin=float(data.get("min_margin", MIN_MARGIN)))
