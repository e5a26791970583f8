"""Where on the table a cell runs a job: the placement searches, and the cheap tests that reject
a candidate placement before any IK.

A placement is a translation of the whole job (every TCP pose) on the table. Two searches, for
two uses:

- :func:`search_placement`: the repair's search (:mod:`dloplan.pipeline.repair.placement`) and
  ``dloplan verify --place`` on the YuMi: a grid of offsets checked nearest first, each by IK
  at the targets (:func:`~dloplan.robot.reachability.reach_at_targets`), then along the path
  with both grips (:func:`~dloplan.robot.reachability.check_reachability`); the first that
  passes wins, so the job moves as little as possible.
- :func:`search_cell_placement`: a described cell's program, which places the job itself
  (``DescribedCell.place``): candidates ranked by IK at the targets (poses reached, clearance,
  margin, shift), the best verified along the path (:func:`~dloplan.robot.path.check_cell_path`).

Both first reject the candidates that cannot pass without solving anything
(:func:`within_reach`: a target beyond an arm's reach sphere, the bound the IK itself applies)
and take the others in order of cost: the nearest first, or the best bound first with the
candidates whose bound cannot reach the best ranked never solved (:func:`search_cell_placement`).
The result is that of checking every candidate.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from .described import DescribedCell, pair_clearance
from .kinematics import inverse, joint_margin
from .path import COMFORT_CLEARANCE, COMFORT_MARGIN, ReachOptions, check_path, validate_path
from .reachability import Reachability, arm_order, check_reachability, reach_at_targets
from .yumi import yumi

PLACEMENT_TRIES = 3
"""Best-ranked placements verified in full by :func:`search_cell_placement`."""

REACH_SLACK = 1e-9
"""[m] A target counts as beyond an arm's reach (:func:`within_reach`) only this far beyond
the IK's own bound, so that rounding never rejects what the IK would try."""


def within_reach(cell: DescribedCell, positions, offsets) -> np.ndarray:
    """Which targets each arm can reach at all after each offset, without IK: the TCP target
    within the arm's reach sphere (:attr:`~dloplan.robot.chain.CellArm.reach` about its
    :attr:`~dloplan.robot.chain.CellArm.shoulder`, the sum of the description's link offsets),
    the bound at which the IK gives up (:func:`~dloplan.robot.kinematics.inverse`).

    Parameters
    ----------
    cell : DescribedCell
    positions : array_like
        (K, 2, 3) TCP targets [m], ordered by arm (left, right).
    offsets : array_like
        (C, 3) candidate translations [m].

    Returns
    -------
    numpy.ndarray
        (C, K, 2) bool: target k of the arm within its reach after offset c.
    """
    pos = np.asarray(positions, dtype=float)
    offsets = np.asarray(offsets, dtype=float).reshape(-1, 3)
    inside = np.empty((len(offsets), len(pos), 2), dtype=bool)
    for a, arm in enumerate(cell.arms):
        moved = pos[None, :, a] + offsets[:, None] - arm.shoulder
        inside[..., a] = np.linalg.norm(moved, axis=-1) <= arm.reach + REACH_SLACK
    return inside


@dataclass(frozen=True, eq=False)
class Placement:
    """Outcome of :func:`search_placement`.

    Attributes
    ----------
    offset : numpy.ndarray
        (3,) translation of the job [m] (the best found when none works).
    reachability : Reachability or None
        The check at that offset.
    candidates : int
        Offsets fully checked.
    success : bool
        Every pose reachable, continuous and collision-free at ``offset``.
    message : str
    """

    offset: np.ndarray
    reachability: Reachability
    candidates: int
    success: bool
    message: str


def search_placement(gripper_positions, gripper_rotations: Rotation,
                     robot: DescribedCell | None = None, *, extent=(0.2, 0.2, 0.0),
                     step: float = 0.05, objective: str = "nearest",
                     assignment: str = "auto", options: ReachOptions | None = None,
                     explain: bool = True) -> Placement:
    """Search a translation of the whole job on the table that makes every pose reachable.

    The candidate offsets form a grid of spacing ``step`` within ``+-extent`` per axis (z
    extent 0 keeps the job at its height). With ``objective="nearest"`` they are checked in
    order of distance from the original placement and the first that succeeds is returned;
    with ``"margin"`` every candidate is checked and the successful one with the largest
    smallest joint margin wins. Offsets with a target beyond an arm's reach sphere
    (:func:`within_reach`) are never solved; a quick pre-check (IK at the planned poses only, no
    sub-steps, first failure stops it,
    :func:`~dloplan.robot.reachability.reach_at_targets`) discards hopeless offsets before the
    full :func:`~dloplan.robot.reachability.check_reachability` (with ``options.verdict_only``
    the grid's checks stop at their first failure; ``explain`` checks in full).

    Parameters
    ----------
    gripper_positions, gripper_rotations, robot, assignment, options
        As for :func:`~dloplan.robot.reachability.check_reachability` (default robot: a YuMi
        at the origin).
    extent : array_like
        (3,) half-widths [m] of the searched box.
    step : float
        Grid spacing [m].
    objective : str
        ``"nearest"`` or ``"margin"``.
    explain : bool
        When no offset passes the pre-check, check the original placement in full to say why
        (its ``reachability``); False skips that (``reachability`` None: a caller that tries
        many searches, like the repair loop, only needs to know that none passed).
    """
    robot = robot if robot is not None else yumi()
    extent = np.asarray(extent, dtype=float)
    if extent.shape != (3,) or not np.all(np.isfinite(extent)) or np.any(extent < 0):
        raise ValueError(f"extent: expected 3 half-widths >= 0 [m], got {extent!r}")
    if not (np.isfinite(step) and step > 0):
        raise ValueError(f"step: expected a positive grid spacing [m], got {step!r}")
    if objective not in ("nearest", "margin"):
        raise ValueError(f"objective: expected 'nearest' or 'margin', got {objective!r}")
    pos, mats = validate_path(gripper_positions, gripper_rotations, "gripper_positions",
                              "gripper_rotations")
    rot = Rotation.from_matrix(mats)
    opts = options if options is not None else ReachOptions()
    axes = [np.arange(-np.floor(e / step), np.floor(e / step) + 1) * step for e in extent]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    grid = grid[np.argsort(np.linalg.norm(grid, axis=1), kind="stable")]
    order = arm_order(pos, assignment, robot)
    by_arm = Rotation.from_matrix(mats[:, order])
    best = None
    checked = 0
    for offset in grid[within_reach(robot, pos[:, order], grid).all(axis=(1, 2))]:
        if not reach_at_targets(robot, pos[:, order] + offset, by_arm, opts, stop=True).all():
            continue
        result = check_reachability(pos, rot, robot, offset=offset, assignment=assignment,
                                    options=opts)
        checked += 1
        key = (result.success, result.min_joint_margin if objective == "margin" else 0.0)
        if best is None or key > best[0]:
            best = (key, offset, result)
        if result.success and objective == "nearest":
            break
    if best is None:
        result = check_reachability(pos, rot, robot, assignment=assignment,
                                    options=replace(opts, verdict_only=False)) \
            if explain else None
        return Placement(np.zeros(3), result, int(explain), False,
                         f"no offset within +-{format_offset(extent)} m (step {step} m) passed "
                         "the pre-check")
    (ok, _), offset, result = best
    text = format_offset(offset)
    if ok:
        return Placement(offset, result, checked, True,
                         f"offset {text} m: every pose reachable (min joint margin "
                         f"{np.degrees(result.min_joint_margin):.1f} deg)")
    return Placement(offset, result, checked, False,
                     f"no offset within +-{format_offset(extent)} m works; best {text} m: "
                     f"{result.message}")


def format_offset(offset) -> str:
    """An offset (3,) [m] as ``[x, y, z]`` with millimetre digits (no ``-0.``)."""
    return "[" + ", ".join(f"{v:.3f}" for v in np.round(np.asarray(offset, float), 4) + 0.0) + "]"


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

    Candidates are scored best bound first (:func:`within_reach`: a pose with a target beyond
    an arm's reach sphere is not reached; clearance and margin at most their comfort values),
    and scoring stops once the :data:`PLACEMENT_TRIES` best scores exceed every bound left: the
    candidates left could not rank among them. The ranking is that of scoring every candidate.

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
    opts = options if options is not None else ReachOptions.cell_program()
    pos = np.asarray(positions, dtype=float)
    if offsets is None:
        gx, gy = np.meshgrid(np.arange(-0.2, 0.201, 0.1), np.arange(-0.1, 0.101, 0.1))
        offsets = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], 1)
    offsets = np.asarray(offsets, dtype=float).reshape(-1, 3)
    mats = rotations.as_matrix().reshape(len(pos), 2, 3, 3)
    quick = replace(opts.ik, restarts=1, min_margin=0.0)
    shifts = [-float(np.linalg.norm(offset)) for offset in offsets]
    # the best score a candidate can have: its poses within both arms' reach, comfort, its shift
    bounds = [(int(n), COMFORT_CLEARANCE, COMFORT_MARGIN, float(shift)) for n, shift in
              zip(within_reach(cell, pos, offsets).all(axis=2).sum(axis=1), shifts, strict=True)]
    scores = {}
    for i in sorted(range(len(offsets)), key=lambda i: bounds[i], reverse=True):
        kept = sorted(scores.values(), reverse=True)[:PLACEMENT_TRIES]
        if len(kept) == PLACEMENT_TRIES and kept[-1] > bounds[i]:
            break  # no candidate left can rank among the best: none is solved
        scores[i] = target_score(cell, pos + offsets[i], mats, quick, shifts[i])
    ranked = sorted(sorted(scores), key=lambda i: scores[i], reverse=True)
    first = None
    for i in ranked[:PLACEMENT_TRIES]:
        verdict = check_path(cell, pos + offsets[i], rotations, options=opts)
        if verdict.ok:
            return offsets[i], verdict
        first = first or (offsets[i], verdict)
    return first


def target_score(cell: DescribedCell, pos, mats, options, shift: float) -> tuple:
    """A placement's rank by IK at the targets (each seeded from the arm's previous one): poses
    both arms reach, smallest arm-arm clearance (up to :data:`COMFORT_CLEARANCE`, -1 when no
    pose is reached), smallest joint margin (up to :data:`COMFORT_MARGIN`), ``shift``.

    Parameters
    ----------
    cell : DescribedCell
    pos : numpy.ndarray
        (K, 2, 3) TCP targets [m] of the placement, arms (left, right).
    mats : numpy.ndarray
        (K, 2, 3, 3) ``tcp_to_world``.
    options : IKOptions
    shift : float
        Minus the placement's translation length [m] (a smaller shift ranks higher).
    """
    qs = [[], []]
    reached = np.ones(len(pos), bool)
    for a, arm in enumerate(cell.arms):
        q = arm.home
        for k in range(len(pos)):
            result = inverse(arm, pos[k, a], Rotation.from_matrix(mats[k, a]), seed=q,
                             options=options)
            reached[k] &= result.success
            q = result.q
            qs[a].append(q)
    q_l, q_r = np.array(qs[0]), np.array(qs[1])
    clear = float(pair_clearance(cell, q_l, q_r)[reached].min()) if reached.any() else -1.0
    margin = min(float(joint_margin(cell.left, q_l).min()),
                 float(joint_margin(cell.right, q_r).min()))
    return (int(reached.sum()), min(clear, COMFORT_CLEARANCE), min(margin, COMFORT_MARGIN),
            shift)
