"""Where on the table a cell runs a job: the one placement search, its two rankings, and the
cheap test that rejects a candidate placement before any IK.

A placement is a translation of the whole job (every TCP pose) on the table.
:func:`search_offsets` is the search: it rejects the candidates that cannot pass without solving
anything (:func:`within_reach`: a target beyond an arm's reach sphere, the bound the IK itself
applies), scores the others best bound first with the caller's score, and verifies them in the
order of their scores, never solving a candidate that cannot rank; the result is that of
scoring every candidate. Its two callers differ only in the score and the verification:

- :func:`search_placement`: the repair's search (:mod:`dloplan.pipeline.repair.placement`) and
  ``dloplan verify --place`` on the YuMi: a grid of offsets scored by their distance (the
  nearest first) if IK at the targets reaches them
  (:func:`~dloplan.robot.reachability.reach_at_targets`), verified along the path with both
  grips (:func:`~dloplan.robot.reachability.check_reachability`); the first that passes wins,
  so the job moves as little as possible.
- :func:`search_cell_placement`: a described cell's program, which places the job itself
  (``DescribedCell.place``): candidates scored by IK at the targets (:func:`target_score`:
  poses reached, clearance, margin, shift), the :data:`PLACEMENT_TRIES` best verified along the
  path (:func:`~dloplan.robot.path.check_path` with :meth:`~dloplan.robot.path.ReachOptions.
  cell_program`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from .described import DescribedCell, pair_clearance
from .kinematics import joint_margin
from .path import COMFORT_CLEARANCE, COMFORT_MARGIN, ReachOptions, check_path, validate_path
from .reachability import (
    Reachability,
    TargetGrips,
    arm_order,
    check_reachability,
    ik_at_targets,
)
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


def search_offsets(cell: DescribedCell, positions, offsets, *, bound, score, verify,
                   tries: int | None = None, first_pass: bool = True):
    """The placement search: candidates ranked by a caller's score, the best verified in full.

    Every candidate offset first gets the ``bound`` of its score from :func:`within_reach`
    alone (None: it cannot pass, and is never solved); candidates are then scored (``score``:
    cheap IK, None rejects) best bound first, and verified (``verify``) in the order of their
    scores (ties: the earlier candidate first) as soon as no candidate left unscored can rank
    before them. The first verified that passes ends the search (``first_pass``), else the best
    verified is kept, at most ``tries`` are verified; a candidate whose bound cannot rank among
    them is never solved. The result is that of scoring every candidate first.

    Parameters
    ----------
    cell : DescribedCell
    positions : array_like
        (K, 2, 3) TCP targets [m], ordered by arm (left, right), before any offset.
    offsets : array_like
        (C, 3) candidate translations [m].
    bound : callable
        ``bound(c, inside)`` with ``inside`` the (K, 2) bool of :func:`within_reach` for
        candidate c: the best score it can have (a tuple), or None.
    score : callable
        ``score(c)``: its score (a tuple, never above its bound), or None (rejected).
    verify : callable
        ``verify(c)``: ``(key, result)`` of the full check; ``key[0]`` True when it passes, the
        largest key (the first of equal ones) is kept.
    tries : int, optional
        Best-scored candidates verified at most (default all).
    first_pass : bool

    Returns
    -------
    tuple or None
        ``(c, result, verified)``: the candidate kept, its check and the number of candidates
        verified; None when none was verified.
    """
    offsets = np.asarray(offsets, dtype=float).reshape(-1, 3)
    inside = within_reach(cell, positions, offsets)
    bounds = [bound(c, inside[c]) for c in range(len(offsets))]
    todo = sorted((c for c in range(len(offsets)) if bounds[c] is not None),
                  key=lambda c: bounds[c], reverse=True)
    ranked, best, verified, i = [], None, 0, 0
    while tries is None or verified < tries:
        if ranked and (i == len(todo) or ranked[0][0] > bounds[todo[i]]):
            _, c = ranked.pop(0)
            key, result = verify(c)
            verified += 1
            if best is None or key > best[0]:
                best = (key, c, result)
            if first_pass and key[0]:
                break
            continue
        if i == len(todo):
            break
        c, i = todo[i], i + 1
        value = score(c)
        if value is not None:
            ranked.append((value, c))
            ranked.sort(key=lambda item: (item[0], -item[1]), reverse=True)
    return None if best is None else (best[1], best[2], verified)


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
    the grid's checks stop at their first failure; ``explain`` checks in full): the
    :func:`search_offsets` whose score is minus the offset's length.

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
    distance = np.linalg.norm(grid, axis=1)
    order = np.argsort(distance, kind="stable")
    grid, distance = grid[order], distance[order]
    order = arm_order(pos, assignment, robot)
    grips = TargetGrips(robot, Rotation.from_matrix(mats[:, order]), opts)  # every offset's

    def reached(c):
        """The nearest first, if IK at the targets reaches every one."""
        hits = grips.reached(pos[:, order] + grid[c], stop=True)
        return (-distance[c],) if hits.all() else None

    def verify(c):
        result = check_reachability(pos, rot, robot, offset=grid[c], assignment=assignment,
                                    options=opts)
        return (result.success, result.min_joint_margin if objective == "margin" else 0.0), result

    found = search_offsets(robot, pos[:, order], grid, score=reached, verify=verify,
                           bound=lambda c, inside: (-distance[c],) if inside.all() else None,
                           first_pass=objective == "nearest")
    if found is None:
        result = check_reachability(pos, rot, robot, assignment=assignment,
                                    options=replace(opts, verdict_only=False)) \
            if explain else None
        return Placement(np.zeros(3), result, int(explain), False,
                         f"no offset within +-{format_offset(extent)} m (step {step} m) passed "
                         "the pre-check")
    c, result, checked = found
    text = format_offset(grid[c])
    if result.success:
        return Placement(grid[c], result, checked, True,
                         f"offset {text} m: every pose reachable (min joint margin "
                         f"{np.degrees(result.min_joint_margin):.1f} deg)")
    return Placement(grid[c], result, checked, False,
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
    both arms reach, then the comfort (:func:`comfort`: the product of the smallest arm-arm
    clearance's share of :data:`COMFORT_CLEARANCE` and the smallest joint margin's share of
    :data:`COMFORT_MARGIN`, to :data:`COMFORT_RESOLUTION`), then the smallest shift, then the
    earlier candidate (docs/decisions.md, "Placement of a described cell: comfort as a
    product").
    The :data:`PLACEMENT_TRIES` best candidates are then verified in full with
    :func:`~dloplan.robot.path.check_path` (whose IK may choose other solutions, e.g. another
    elbow of a 7-joint arm) in that order: the first that passes is returned, else the best
    ranked (:func:`search_offsets`, the bound of a score: a pose with a target beyond an arm's
    reach sphere is not reached, a comfort of at most 1).

    Parameters
    ----------
    cell : DescribedCell
    positions, rotations
        As for :func:`~dloplan.robot.path.check_path`.
    offsets : array_like, optional
        (C, 3) candidate translations [m]; default a grid of +-0.2 m in x and +-0.1 m in y in
        0.1 m steps (15 candidates).

    Returns
    -------
    offset : numpy.ndarray
        (3,) the best translation [m].
    verdict : PathCheck
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

    def bound(c, inside):
        """The best score a candidate can have: its poses within both arms' reach, full
        comfort, its shift."""
        return (int(inside.all(axis=1).sum()), 1.0, shifts[c])

    def verify(c):
        verdict = check_path(cell, pos + offsets[c], rotations, options=opts)
        return (verdict.ok,), verdict

    c, verdict, _ = search_offsets(
        cell, pos, offsets, bound=bound, verify=verify, tries=PLACEMENT_TRIES,
        score=lambda c: target_score(cell, pos + offsets[c], mats, quick, shifts[c]))
    return offsets[c], verdict


COMFORT_RESOLUTION = 1e-3
"""Resolution of a placement's comfort (a share of 1): placements closer than this (0.05 mm of
clearance, 0.03 deg of margin) are equally comfortable, and the smaller shift ranks first, not
the IK's round-off."""


def comfort(clearance: float, margin: float) -> float:
    """How comfortably a pair of arms holds a placement, 0 .. 1: the share of
    :data:`COMFORT_CLEARANCE` its smallest arm-arm clearance ``clearance`` [m] has, times the
    share of :data:`COMFORT_MARGIN` its smallest joint margin ``margin`` [rad] has (each in
    0 .. 1), rounded to :data:`COMFORT_RESOLUTION`. Neither can make up for the other's lack:
    a 5 deg margin with 33 mm of clearance (0.11) ranks below 41 deg with 31 mm (0.61)."""
    share = (min(max(clearance / COMFORT_CLEARANCE, 0.0), 1.0)
             * min(max(margin / COMFORT_MARGIN, 0.0), 1.0))
    return round(share / COMFORT_RESOLUTION) * COMFORT_RESOLUTION


def target_score(cell: DescribedCell, pos, mats, options, shift: float) -> tuple:
    """A placement's rank by IK at the targets (each seeded from the arm's previous one): poses
    both arms reach, the :func:`comfort` of their smallest arm-arm clearance (0 when no pose is
    reached) and smallest joint margin, ``shift``.

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
    (q_l, hit_l), (q_r, hit_r) = (ik_at_targets(arm, pos[:, a], mats[:, a], options,
                                                seed_from_miss=True)
                                  for a, arm in enumerate(cell.arms))
    reached = hit_l & hit_r
    clear = float(pair_clearance(cell, q_l, q_r)[reached].min()) if reached.any() else 0.0
    margin = min(float(joint_margin(cell.left, q_l).min()),
                 float(joint_margin(cell.right, q_r).min()))
    return (int(reached.sum()), comfort(clear, margin), shift)
