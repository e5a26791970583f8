"""Static equilibrium of a cable held by two clips (thesis 5.2-5.3, done without time stepping).

The thesis stabilizes a shape by running its explicit dynamics (eq. 3.24) until the cable stops
moving: 10^4 to 10^6 steps. Here the same equilibrium is found directly, as the minimum of the
potential energy U(x) = U^s + U^b + U^g over the free points with the four held points fixed,
by Newton's method on the exact banded Hessian:

* each iteration solves (H + lambda I) p = -g with a banded Cholesky factorization (cost linear
  in n); lambda = 0 (a pure Newton step) whenever H is positive definite and the quadratic model
  is trusted, otherwise lambda grows until the factorization succeeds (indefinite H: compressed
  or buckling shapes) and shrinks again as steps succeed, the Levenberg-Marquardt form of a
  trust region;
* a step is accepted only if the energy decreases (so U decreases monotonically) and no point
  moves farther than the trust radius; the ratio of actual to predicted decrease adapts lambda
  and the radius;
* convergence: the largest free-point force residual below ``rtol`` times a force scale of the
  cable (the weight of a point plus k_b / l) or the round-off floor of its stiffest spring
  (axial, bending, twist, contact: :func:`dloplan.sim.result.residual_tolerance`), and the
  final Hessian positive definite (a stable equilibrium) -- both reported, never hidden.

The result is the nearest stable equilibrium downhill from the guess: a clamped-clamped cable has
several (sagging, arching, S-shaped), and the guess chooses the branch. :func:`continuation`
follows a sequence of clip poses with warm starts, as a real cable would go.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..frames import slerp_quaternions
from ..geometry import as_shape, norms
from ..physics.chain import (
    HALF_BANDWIDTH,
    SpringChain,
    band_to_sparse,
    energy,
    gradient,
    hessian_band,
    shape_derivatives,
    shape_energy,
)
from ..physics.contact import contact_rows, entry_fraction
from .clips import ClipPoses, check_clip_reach, clip_poses_from_shape, conform_guess
from .compiled import (
    CONVERGED,
    MAX_ITERATIONS,
    SADDLE,
    STALLED,
    newton_positions,
    restore_link_lengths,
)
from .contact_newton import newton_contacts
from .dynamics import settle
from .newton import (
    MAX_ESCAPES,
    NewtonRun,
    escape_saddle,
    free_band,
    newton_message,
    trust_region_newton,
)
from .result import (
    Equilibrium,
    clip_reactions,
    equilibrium_result,
    force_scale,
    residual_tolerance,
)

__all__ = [  # the static solvers, and the shared names callers have always imported from here
    "Equilibrium", "TargetCheck", "check_clip_reach", "check_target", "clip_wrenches",
    "conform_guess", "continuation", "equilibrium", "force_scale", "free_hessian",
    "interpolate_clips", "minimize_energy", "stabilize",
]


def equilibrium(
    cable: Cable,
    guess,
    clips: ClipPoses | None = None,
    *,
    gravity=GRAVITY,
    rtol: float | None = None,
    max_iterations: int = 500,
    chain: SpringChain | None = None,
    held: str = "both",
    contacts=(),
) -> Equilibrium:
    """The nearest stable static equilibrium of a cable held by two clips.

    Minimizes the potential energy (eqs. 3.8, 3.20, 3.28) over the free points 2 .. n-2 with
    points 0, 1 and n-1, n held by the clips, by a trust-region Newton method on the exact banded
    Hessian (see the module docstring). No tuning by the caller is needed across E = 1e5 to
    1e11 Pa and n = 5 to 1000.

    Parameters
    ----------
    cable : Cable
        The cable and its discretization (n links).
    guess : array_like
        (n + 1, 3) starting shape [m]; it selects the equilibrium branch.
    clips : ClipPoses, optional
        Clip poses; default: those of the guess (its own end links).
    gravity : array_like
        Gravity acceleration [m/s^2]; ``(0, 0, 0)`` for a weightless cable.
    rtol : float, optional
        Convergence when the largest free-point force is below ``rtol`` times
        :func:`force_scale`; by default 1e-10, or the round-off floor of the stiffest spring
        when that is larger (:func:`dloplan.sim.result.residual_tolerance`).
    max_iterations : int
        Iteration limit; reaching it gives ``converged=False``.
    chain : SpringChain, optional
        Precomputed chain of ``cable`` under ``gravity`` (saves its construction in loops), or
        a chain with other loads (its ``point_masses`` times ``gravity`` are the point loads).
    held : {"both", "first"}
        ``"first"``: only the first clip holds the cable (points 0, 1), the rest hangs free
        (a cantilever); ``clips.positions[1]`` is then ignored.
    contacts : sequence
        Obstacles the cable cannot enter (pegs, plates, the table): one-sided contact by a
        stiff penalty (:mod:`dloplan.physics.contact`); the deepest penetration is reported.

    Returns
    -------
    Equilibrium
        Shape, forces, energy, clip wrenches, iteration count, convergence and stability.

    Raises
    ------
    ValueError
        For a guess with the wrong number of points or non-finite values, or clips that
        coincide or are out of the cable's reach.
    """
    x = as_shape(guess, cable.n_points, "guess")
    if held not in ("both", "first"):
        raise ValueError(f"held: got {held!r}, expected 'both' or 'first'")
    if clips is None:
        clips = clip_poses_from_shape(x)
    if chain is None:
        chain = SpringChain.from_cable(cable, gravity, contacts)
    if held == "both":
        check_clip_reach(cable, clips)
        x = conform_guess(cable, x, clips, gravity)
        free = slice(2, cable.n_points - 2)
    else:
        x = x.copy()
        x[:2] = clips.held_points(cable.rest_link_length)[:2]
        free = slice(2, cable.n_points)
    # with contacts, no point may jump farther than the cable's diameter in one step, or it
    # could tunnel through a thin obstacle into a region where the penalty no longer sees it
    max_step = max(cable.diameter, 1e-3) if chain.contacts else cable.length
    limit = residual_tolerance(cable, gravity, rtol, x,
                               chain.contact_stiffness if chain.contacts else 0.0)
    x, g, iterations, residual, stable, history, message = minimize_energy(
        chain, x, free, max_step, limit, max_iterations
    )
    return equilibrium_result(cable, chain, x, g, clips, iterations, residual <= limit,
                              residual, limit, stable, history, message, held)


def minimize_energy(
    chain: SpringChain,
    x: np.ndarray,
    free: slice,
    length_scale: float,
    tolerance: float,
    max_iterations: int = 500,
):
    """Trust-region Newton minimization of the chain's energy over a range of free points.

    The engine of :func:`equilibrium` (see the module docstring), for callers that hold other
    points than the two clips.

    Parameters
    ----------
    chain : SpringChain
        Energy constants and loads.
    x : numpy.ndarray
        (n + 1, 3) start [m]; points outside ``free`` stay where they are.
    free : slice
        Contiguous range of free points (step 1, explicit start and stop).
    length_scale : float
        Largest step of a point [m] at the start (a quarter of it) and ever (all of it).
    tolerance : float
        Force residual for convergence [N].
    max_iterations : int
        Iteration limit.

    Returns
    -------
    tuple
        ``(x, gradient, iterations, residual, stable, energy_history, message)``.
    """
    x = np.array(x, dtype=float)
    if free.stop <= free.start:  # every point is held
        return x, gradient(chain, x), 0, 0.0, True, np.array([float(energy(chain, x))]), \
            "no free point"

    def energy_of(x):
        return shape_energy(chain, x)

    def derivatives(x):
        _, g, band = shape_derivatives(chain, x)
        residual = float(np.max(norms(g[free])))
        return g[free].ravel(), free_band(band, free), residual, g

    def moved(x, p):
        trial = x.copy()
        trial[free] += p.reshape(-1, 3)
        return trial

    def corrected(x, p):  # the step, then the link lengths its linearization promised
        trial = moved(x, p)
        return trial if restore_link_lengths(x, trial, free.start, free.stop) else None

    def displacement(p):
        return float(np.max(norms(p.reshape(-1, 3))))

    rows = contact_rows(chain.contacts)
    if rows is None:  # an obstacle without a compiled row: the generic loop
        def limit(x, p):  # land a point entering an obstacle just inside it
            return entry_fraction(x, moved(x, p), chain.contacts, chain.contact_radius)

        stiff = chain.stiff_axial  # the stiff links' measures; E_a = E takes the plain steps
        run = trust_region_newton(x, energy_of, derivatives, moved, displacement, length_scale,
                                  tolerance, max_iterations, corrected=corrected if stiff else None,
                                  limit=limit if stiff else None)
    else:
        run = _compiled_newton(chain, x, free, length_scale, tolerance, max_iterations,
                               energy_of, moved, displacement, rows)
    return run.state, run.extra, run.iterations, run.residual, run.stable, run.history, \
        run.message


def _compiled_newton(chain, x, free, length_scale, tolerance, max_iterations, energy_of, moved,
                     displacement, rows) -> NewtonRun:
    """:func:`trust_region_newton` for the chain, in :func:`newton_positions` (no contacts) or
    :func:`~dloplan.sim.contact_newton.newton_contacts` (``rows``: the contacts' compiled rows).

    The compiled loop returns at a saddle; the escape along the lowest mode is done here, as
    in the generic loop, and the compiled loop resumes.
    """
    history = np.empty(max_iterations + 1)
    history[0] = energy_of(x)
    n_history, iterations, radius, escapes = 1, 0, 0.25 * length_scale, 0
    grad, band = np.empty(x.shape), np.empty((HALF_BANDWIDTH + 1, x.size))
    while True:
        if len(rows):
            status, iterations, residual, radius, n_history = newton_contacts(
                x, free.start, free.stop, chain.constants, rows, chain.contact_radius,
                chain.contact_stiffness, length_scale, tolerance, max_iterations, iterations,
                radius, history, n_history, grad, band, escapes < MAX_ESCAPES, chain.stiff_axial)
        else:  # restart passed, as the plants' call passes it: one compiled overload
            status, iterations, residual, radius, n_history = newton_positions(
                x, free.start, free.stop, *chain.constants, length_scale, tolerance,
                max_iterations, iterations, radius, history, n_history, grad, band,
                escapes < MAX_ESCAPES, chain.stiff_axial, False)
        if status != SADDLE:
            break
        escaped = escape_saddle(x, history[n_history - 1], free_band(band, free), energy_of,
                                moved, displacement, radius)
        iterations += 1
        escapes += 1
        if escaped is None:
            break
        x, history[n_history] = escaped
        n_history += 1
    outcome = {CONVERGED: "converged", MAX_ITERATIONS: "max_iterations", STALLED: "stalled",
               SADDLE: "stuck"}[status]
    return NewtonRun(x, grad, iterations, residual, status == CONVERGED,
                     history[:n_history].copy(), newton_message(outcome, iterations, residual))


def clip_wrenches(cable: Cable, shape, gravity=GRAVITY) -> np.ndarray:
    """Force [N] and moment [N m] a held shape puts on each clip, (2, 6), world frame.

    The reactions of the held points, as in :attr:`Equilibrium.clip_wrenches`, for a shape
    that is an equilibrium (e.g. a stabilized one); the moment is about each clip point.
    """
    x = as_shape(shape, cable.n_points, "shape")
    chain = SpringChain.from_cable(cable, gravity)
    return clip_reactions(x, gradient(chain, x), clip_poses_from_shape(x), "both")


def free_hessian(cable: Cable, shape, gravity=GRAVITY) -> sp.csr_matrix:
    """Sparse Hessian of the energy over the free coordinates (points 2 .. n-2) [N/m].

    The tangent stiffness of a held cable: its smallest eigenvalue decides elastic stability.
    """
    x = as_shape(shape, cable.n_points, "shape")
    chain = SpringChain.from_cable(cable, gravity)
    return band_to_sparse(free_band(hessian_band(chain, x), slice(2, cable.n_points - 2)))


def stabilize(
    shape, cable: Cable, *, gravity=GRAVITY, method: str = "static", **options
) -> Equilibrium:
    """Let a planned shape settle under gravity with its own clip poses held (thesis 5.2).

    Parameters
    ----------
    shape : array_like
        (n + 1, 3) planned shape [m].
    cable : Cable
        The cable.
    gravity : array_like
        Gravity [m/s^2].
    method : {"static", "dynamic"}
        ``"static"``: :func:`equilibrium` (default, exact and fast); ``"dynamic"``: the thesis'
        explicit time stepping run to rest (:func:`dloplan.sim.dynamics.settle`).
    **options
        Passed to the chosen solver.
    """
    x = as_shape(shape, cable.n_points, "shape")
    if method == "static":
        return equilibrium(cable, x, gravity=gravity, **options)
    if method == "dynamic":
        return settle(cable, x, gravity=gravity, **options)
    raise ValueError(f"method: got {method!r}, expected 'static' or 'dynamic'")


@dataclass(frozen=True, eq=False)
class TargetCheck:
    """Result of :func:`check_target` (thesis 5.3, Fig. 5.4).

    Attributes
    ----------
    displacements : numpy.ndarray
        (n + 1,) distance of each point between the target and its stabilized shape [m].
    max_displacement : float
        Largest of them [m].
    threshold : float
        T_cf [m].
    stable : bool
        ``max_displacement <= threshold`` and the stabilization converged.
    stabilized : Equilibrium
        The stabilized target.
    message : str
        A warning when the target is not stable, else a short confirmation.
    """

    displacements: np.ndarray
    max_displacement: float
    threshold: float
    stable: bool
    stabilized: Equilibrium
    message: str


def check_target(
    target, cable: Cable, *, threshold: float = 0.01, gravity=GRAVITY
) -> TargetCheck:
    """Stabilize a proposed target and warn if it moves more than ``threshold`` (thesis 5.3).

    Parameters
    ----------
    target : array_like
        (n + 1, 3) proposed target shape [m].
    cable : Cable
        The cable.
    threshold : float
        T_cf [m], the largest per-point displacement accepted (default 1 cm).
    gravity : array_like
        Gravity [m/s^2].
    """
    if not (math.isfinite(threshold) and threshold > 0):
        raise ValueError(f"threshold: got {threshold!r}, expected a distance > 0 [m]")
    x = as_shape(target, cable.n_points, "target")
    settled = stabilize(x, cable, gravity=gravity)
    moved = np.linalg.norm(settled.shape - x, axis=1)
    worst = float(moved.max())
    ok = worst <= threshold and settled.converged
    if not settled.converged:
        message = f"target: stabilization failed ({settled.message})"
    elif ok:
        message = f"target is stable: largest displacement {1e3 * worst:.2f} mm"
    else:
        message = (
            f"target is not stable under gravity: point {int(moved.argmax())} moves "
            f"{1e3 * worst:.1f} mm when stabilized (threshold T_cf = {1e3 * threshold:.1f} mm)"
        )
    return TargetCheck(moved, worst, float(threshold), bool(ok), settled, message)


def interpolate_clips(a: ClipPoses, b: ClipPoses, fractions) -> list[ClipPoses]:
    """Clip poses between ``a`` and ``b``: linear in position, slerp in rotation.

    Both clips at all fractions in one array slerp (:func:`dloplan.frames.slerp_quaternions`:
    scipy's ``Slerp`` to round-off, without building a ``Slerp`` and ``Rotation`` objects per
    clip, which cost more than the arithmetic in the continuations of the snap check and the
    closed-loop plant).
    """
    w = np.asarray(fractions, dtype=float).reshape(-1)
    positions = (1.0 - w)[:, None, None] * a.positions + w[:, None, None] * b.positions
    keys = np.stack([a.rotations.as_quat(), b.rotations.as_quat()])  # (2 keys, 2 clips, 4)
    quats = slerp_quaternions(np.array([0.0, 1.0]), keys, w)  # (len(w), 2, 4)
    return [ClipPoses(pos, Rotation(q, normalize=False))
            for pos, q in zip(positions, quats, strict=True)]


def continuation(
    cable: Cable,
    start_shape,
    clip_sequence: Sequence[ClipPoses],
    *,
    substeps: int = 1,
    gravity=GRAVITY,
    contacts=(),
    every_substep: bool = False,
    **options,
) -> list[Equilibrium] | list[list[Equilibrium]]:
    """Quasi-static continuation: equilibria along a sequence of clip poses, warm-started.

    Each equilibrium starts from the previous one, so path-dependent outcomes (which way a
    compressed cable buckles) follow the motion, as a slowly moved real cable does.

    Parameters
    ----------
    cable : Cable
        The cable.
    start_shape : array_like
        (n + 1, 3) shape at the first clip poses [m] (settled first).
    clip_sequence : sequence of ClipPoses
        The clip poses to visit, in order.
    substeps : int
        Equilibria solved between consecutive clip poses (clips interpolated linearly and by
        slerp at the fractions j / substeps, j = 1 .. substeps); only the equilibria at the
        given poses are returned unless ``every_substep``.
    gravity : array_like
        Gravity [m/s^2].
    contacts : sequence
        Obstacles the cable cannot enter (see :func:`equilibrium`).
    every_substep : bool
        Return every equilibrium solved, grouped by the clip pose it leads to.
    **options
        Passed to :func:`equilibrium`.

    Returns
    -------
    list of Equilibrium, or list of list of Equilibrium
        One per element of ``clip_sequence``. With ``every_substep``, per element the
        equilibria solved on the way to it, the last at its clip poses: the first element's
        settling alone, then each next element's ``substeps`` sub-steps.
    """
    if substeps < 1:
        raise ValueError(f"substeps: got {substeps}, expected an integer >= 1")
    if len(clip_sequence) == 0:
        raise ValueError("clip_sequence: empty, expected at least one ClipPoses")
    chain = SpringChain.from_cable(cable, gravity, contacts)
    x = as_shape(start_shape, cable.n_points, "start_shape")
    results = []
    previous = None
    for clips in clip_sequence:
        stops = [clips] if previous is None else interpolate_clips(
            previous, clips, np.arange(1, substeps + 1) / substeps
        )
        solved = []
        for stop in stops:
            solved.append(equilibrium(cable, x, stop, gravity=gravity, chain=chain, **options))
            x = solved[-1].shape
        results.append(solved if every_substep else solved[-1])
        previous = clips
    return results
