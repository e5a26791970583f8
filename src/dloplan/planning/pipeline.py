"""``plan``: start and target shapes to a path of S + 2 shapes, through the three stages.

target pre-processing (4.5.1) -> basic geometric (4.3) -> advanced geometric (4.4) ->
physical, shape by shape (4.5); see :mod:`dloplan.planning` and ``docs/planner.md``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from ..cable import GRAVITY, Cable
from ..geometry import shape_length
from ..shapes import discretize
from .geometric import StageStatus, advanced_path, basic_path
from .physical import PHYSICAL_MODES, physical_stage, preprocess_target, reference_force
from .result import STAGES, Plan, stage_forces
from .tuning import FamilyBoundaries, PlannerWeights, planner_weights, stiffness_family


def _resolve_weights(weights, cable: Cable, boundaries) -> PlannerWeights:
    if weights is None:
        return planner_weights(cable, boundaries=boundaries)
    if isinstance(weights, PlannerWeights):
        return weights
    if isinstance(weights, dict):
        return planner_weights(cable, boundaries=boundaries, overrides=weights)
    raise ValueError(
        f"weights: got {type(weights).__name__}, expected None, a PlannerWeights or a dict of "
        f"overrides like {{'advanced': {{'clip': 0.02}}}}"
    )


def plan(
    cable: Cable,
    start,
    target,
    n_shapes: int = 5,
    *,
    weights: PlannerWeights | dict | None = None,
    physical_mode: str = "equilibrium",
    preprocess: bool = True,
    target_tolerance: float = 0.02,
    length_tolerance: float = 0.05,
    family_boundaries: FamilyBoundaries | None = None,
    gravity=GRAVITY,
    map: Callable = map,
    max_iterations: int = 200,
    obstacles=None,
    z_safety: float = 0.02,
    max_rounds: int = 5,
    stabilize: bool = True,
) -> Plan:
    """Plan S intermediate cable shapes from ``start`` to ``target`` (thesis chapter 4).

    Parameters
    ----------
    cable : Cable
        The cable; its ``n_links`` sets the discretization n.
    start, target : array_like
        Shapes (k, 3) [m], or (k, 2) in the x-z plane. Any k >= 2: a shape with k != n + 1
        points is resampled by arc length. Their length must be the cable's within
        ``length_tolerance``.
    n_shapes : int
        S >= 1, the number of intermediate shapes.
    weights : PlannerWeights or dict, optional
        Default: Table 6.1 and the Table 6.2 row of the cable's stiffness family; a dict
        overrides single weights (``{"physical": {"sigma": 1.0}}``).
    physical_mode : {"equilibrium", "thesis"}
        How the physical stage minimizes a shape (see :mod:`dloplan.planning.physical`).
    preprocess : bool
        Minimize the target first (thesis 4.5.1) and plan to the minimized target.
    target_tolerance : float
        The pre-processing warns when a target point moves more than this fraction of L.
    length_tolerance : float
        Accepted relative difference between the given shapes' lengths and the cable's.
    family_boundaries : FamilyBoundaries, optional
        Young's modulus boundaries of the stiffness families.
    gravity : array_like
        Gravity [m/s^2]. The planned shapes are weightless (gravity enters when they are
        stabilized, thesis 5.2); here only |g| is used, for the reference force m |g| of the
        thesis-mode cost.
    map : callable
        ``map(function, iterable)`` for the decoupled physical stage (builtin: serial).
    max_iterations : int
        Iteration limit of the advanced stage.
    obstacles : sequence, optional
        Obstacle volumes (:mod:`dloplan.obstacles`): the stabilized path is checked against
        them and the colliding shapes lifted and the path re-planned around them (thesis 5.4,
        :func:`dloplan.obstacles.avoid_obstacles`), keeping S.
    z_safety : float
        Safety offset of the lift [m].
    max_rounds : int
        Re-planning rounds at most.
    stabilize : bool
        Settle every planned shape under gravity with its clips held (thesis 5.2): the plan's
        ``stabilized`` path. Always done when there are obstacles.

    Returns
    -------
    Plan
        The paths of the three stages, lengths, forces, statuses, timings and warnings.

    Raises
    ------
    ValueError
        Naming the argument for every malformed input.
    """
    t_start = time.perf_counter()
    if not isinstance(cable, Cable):
        raise ValueError(f"cable: got {type(cable).__name__}, expected a dloplan.Cable")
    if isinstance(n_shapes, bool) or int(n_shapes) != n_shapes or n_shapes < 1:
        raise ValueError(f"n_shapes: got {n_shapes!r}, expected an integer >= 1")
    n_shapes = int(n_shapes)
    if physical_mode not in PHYSICAL_MODES:
        raise ValueError(
            f"physical_mode: got {physical_mode!r}, expected one of {', '.join(PHYSICAL_MODES)}"
        )
    if not (math.isfinite(length_tolerance) and length_tolerance > 0):
        raise ValueError(f"length_tolerance: got {length_tolerance!r}, expected a fraction > 0")
    if not (isinstance(max_iterations, int) and max_iterations >= 1):
        raise ValueError(f"max_iterations: got {max_iterations!r}, expected an integer >= 1")
    family = stiffness_family(cable.youngs_modulus, family_boundaries)
    weights = _resolve_weights(weights, cable, family_boundaries)
    force = reference_force(cable, gravity)
    x_start = discretize(start, cable, "start", length_tolerance)
    proposed = discretize(target, cable, "target", length_tolerance)
    warnings: list[str] = []
    timings: dict[str, float] = {}

    t = time.perf_counter()
    target_status = None
    x_target = proposed
    if preprocess:
        pre = preprocess_target(cable, proposed, mode=physical_mode, weights=weights.physical,
                                force=force, tolerance=target_tolerance)
        target_status, x_target = pre.result, pre.shape
        if pre.warning:
            warnings.append(pre.warning)
    timings["target"] = time.perf_counter() - t

    t = time.perf_counter()
    basic = basic_path(x_start, x_target, n_shapes, weights.basic)
    timings["basic"] = time.perf_counter() - t
    basic_status = StageStatus(True, "exact tridiagonal solve", 0, basic[1:-1].size, float("nan"),
                               timings["basic"])

    advanced, advanced_status = advanced_path(basic, cable.length, weights.advanced,
                                              max_iterations=max_iterations)
    timings["advanced"] = advanced_status.seconds
    if not advanced_status.success:
        warnings.append(f"advanced stage: {advanced_status.message}")

    t = time.perf_counter()
    shapes = physical_stage(cable, advanced[1:-1], mode=physical_mode, weights=weights.physical,
                            force=force, map=map)
    physical = np.concatenate([x_start[None], np.stack([s.shape for s in shapes]),
                               x_target[None]])
    timings["physical"] = time.perf_counter() - t
    for i, s in enumerate(shapes, start=1):
        if not s.success:
            warnings.append(f"physical stage, shape {i}: {s.message}")

    avoidance = None
    stabilized = None
    if obstacles or stabilize:
        from ..obstacles.avoidance import avoid_obstacles

        def replan(a: np.ndarray, b: np.ndarray, count: int) -> np.ndarray:
            return plan(cable, a, b, count, weights=weights, physical_mode=physical_mode,
                        preprocess=False, length_tolerance=length_tolerance,
                        family_boundaries=family_boundaries, gravity=gravity, map=map,
                        max_iterations=max_iterations, stabilize=False).path

        t = time.perf_counter()
        checked = avoid_obstacles(cable, physical, list(obstacles or ()), replan,
                                  z_safety=z_safety, max_rounds=max_rounds, gravity=gravity)
        timings["stabilize"] = time.perf_counter() - t
        physical, stabilized = checked.path, checked.stabilized
        if obstacles:
            avoidance = checked
            if not checked.success:
                warnings.append(f"obstacles: {checked.message}")
        elif checked.status == "not_converged":
            warnings.append(f"stabilization: {checked.message}")

    paths = np.stack([basic, advanced, physical])
    lengths = shape_length(paths)
    worst = float(np.max(np.abs(lengths[2] / cable.length - 1.0)))
    if worst > length_tolerance:
        warnings.append(f"physical stage: a shape's length differs from L by {100 * worst:.1f} %")
    axial, bending = stage_forces(cable, paths)
    timings["total"] = time.perf_counter() - t_start
    return Plan(
        cable=cable,
        basic=basic,
        advanced=advanced,
        physical=physical,
        proposed_target=proposed,
        lengths=lengths,
        axial_forces=axial,
        bending_forces=bending,
        statuses={"basic": basic_status, "advanced": advanced_status,
                  "physical": tuple(shapes), "target": target_status},
        timings=timings,
        warnings=tuple(warnings),
        weights=weights,
        family=family,
        physical_mode=physical_mode,
        stabilized=stabilized,
        avoidance=avoidance,
    )


__all__ = ["STAGES", "plan"]
