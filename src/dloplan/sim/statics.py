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
  cable (the weight of a point plus k_b / l), and the final Hessian positive definite (a stable
  equilibrium) -- both reported, never hidden.

The result is the nearest stable equilibrium downhill from the guess: a clamped-clamped cable has
several (sagging, arching, S-shaped), and the guess chooses the branch. :func:`continuation`
follows a sequence of clip poses with warm starts, as a real cable would go.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.linalg import lapack
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation, Slerp

from ..cable import GRAVITY, Cable
from ..physics.chain import (
    Forces,
    SpringChain,
    band_to_sparse,
    energy,
    forces,
    gradient,
    gradient_and_hessian_band,
    hessian_band,
)
from ..physics.contact import penetrations
from ..physics.geometry import (
    arc_length,
    as_shape,
    norms,
    resample_by_arc_length,
    shape_length,
)
from ..physics.gravity import gravity_force
from .clips import ClipPoses, clip_poses_from_shape, place_held_points

MAX_STRAIN = 0.02
"""Largest mean strain of the free part accepted before clips are declared out of reach."""


@dataclass(frozen=True, eq=False)
class Equilibrium:
    """A static equilibrium found by :func:`equilibrium`.

    Attributes
    ----------
    shape : numpy.ndarray
        (n + 1, 3) point positions [m].
    forces : Forces
        Per-point axial, bending and gravity forces [N] at the equilibrium.
    energy : float
        Potential energy U [J].
    clip_wrenches : numpy.ndarray
        (2, 6): force [N] and moment [N m] the cable exerts on each clip, in the world frame,
        the moment taken about the clip point (first clip, last clip).
    iterations : int
        Newton iterations.
    converged : bool
        True when the force residual is below the tolerance.
    residual : float
        Largest norm of the net force on a free point [N].
    tolerance : float
        The residual tolerance used [N].
    stable : bool
        True when the Hessian over the free points is positive definite at the solution.
    clips : ClipPoses
        The clip poses held.
    message : str
        What happened, in words.
    energy_history : numpy.ndarray
        Energy after each accepted iteration [J] (monotonically decreasing).
    penetration : float
        Deepest penetration of a point into a contact obstacle [m] (0 without contacts).
    """

    shape: np.ndarray
    forces: Forces
    energy: float
    clip_wrenches: np.ndarray
    iterations: int
    converged: bool
    residual: float
    tolerance: float
    stable: bool
    clips: ClipPoses
    message: str
    energy_history: np.ndarray
    penetration: float = 0.0

    @property
    def success(self) -> bool:
        """Converged to a stable equilibrium."""
        return self.converged and self.stable


def force_scale(cable: Cable, gravity=GRAVITY) -> float:
    """Characteristic force of a cable's statics [N]: a point's weight plus k_b / l."""
    weight = float(np.max(cable.point_masses)) * float(np.linalg.norm(gravity))
    return weight + cable.k_bending / cable.rest_link_length


def check_clip_reach(cable: Cable, clips: ClipPoses) -> None:
    """Raise ValueError when the clips are coincident or farther apart than the cable reaches."""
    distance = clips.distance
    if distance < 1e-6 * cable.length:
        raise ValueError(f"clips: the two clip points coincide (distance {distance:.3g} m)")
    held = clips.held_points(cable.rest_link_length)
    gap = float(np.linalg.norm(held[2] - held[1]))
    reach = (cable.n_links - 2) * cable.rest_link_length
    if gap > reach * (1.0 + MAX_STRAIN):
        raise ValueError(
            f"clips: the inner held points are {gap:.4g} m apart but the free part of the cable "
            f"is {reach:.4g} m long (clip distance {distance:.4g} m for a {cable.length:.4g} m "
            f"cable): out of reach"
        )


def _clip_wrenches(x: np.ndarray, grad: np.ndarray, clips: ClipPoses, held: str) -> np.ndarray:
    """Force and moment the cable puts on each clip: minus the reactions on the held points."""
    wrenches = np.zeros((2, 6))
    for k, idx in enumerate(([0, 1], [-2, -1])[: 2 if held == "both" else 1]):
        on_clip = -grad[idx]  # the clip balances the net force on its points: reaction = grad
        wrenches[k, :3] = on_clip.sum(axis=0)
        wrenches[k, 3:] = np.cross(x[idx] - clips.positions[k], on_clip).sum(axis=0)
    return wrenches


def conform_guess(cable: Cable, guess: np.ndarray, clips: ClipPoses, gravity=GRAVITY) -> np.ndarray:
    """A starting shape with the held points placed and the free part at its rest length.

    A guess whose free part is shorter or longer than the cable (a geometric path's shape,
    or a warm start whose clips moved) starts Newton's method with large axial forces: the
    Hessian is then strongly indefinite and steps crawl. This keeps the guess's shape and
    branch but scales its deviation from the chord between the inner held points until the
    length is right, and spaces the points evenly along it. A straight guess that is too long
    for the clips is bowed along gravity (or any perpendicular) first.

    Parameters
    ----------
    cable : Cable
        The cable.
    guess : numpy.ndarray
        (n + 1, 3) shape [m].
    clips : ClipPoses
        The clips holding points 0, 1 and n-1, n.
    gravity : array_like
        Gravity [m/s^2], the direction a straight compressed guess is bowed toward.
    """
    l = cable.rest_link_length
    held = clips.held_points(l)
    x = place_held_points(guess, clips, l)
    inner = np.array(guess[1:-1], dtype=float)
    need = (cable.n_links - 2) * l
    s = arc_length(inner)
    s = s / s[-1] if s[-1] > 0 else np.linspace(0.0, 1.0, len(inner))
    inner += (1 - s)[:, None] * (held[1] - inner[0]) + s[:, None] * (held[2] - inner[-1])
    chord = held[1] + s[:, None] * (held[2] - held[1])
    deviation = inner - chord
    if abs(shape_length(inner) / need - 1.0) < 1e-6:
        x[1:-1] = inner
        return x
    if float(np.linalg.norm(held[2] - held[1])) >= need:
        x[1:-1] = resample_by_arc_length(chord, len(inner))
        return x
    if float(np.max(np.linalg.norm(deviation, axis=1))) < 1e-9 * cable.length:
        deviation = 0.5 * (1.0 - np.cos(2.0 * np.pi * s))[:, None] * _bow_direction(
            held[2] - held[1], gravity
        ) * cable.length

    def excess(a: float) -> float:
        return float(shape_length(chord + a * deviation)) - need

    high = 1.0
    while excess(high) < 0.0:
        high *= 2.0
    amplitude = brentq(excess, 0.0, high, xtol=1e-12)
    x[1:-1] = resample_by_arc_length(chord + amplitude * deviation, len(inner))
    return x


def _bow_direction(chord: np.ndarray, gravity) -> np.ndarray:
    axis = chord / np.linalg.norm(chord)
    for candidate in (np.asarray(gravity, dtype=float), np.array([0, 0, -1.0]),
                      np.array([0, 1.0, 0])):
        perp = candidate - np.dot(candidate, axis) * axis
        if np.linalg.norm(perp) > 1e-6 * max(np.linalg.norm(candidate), 1e-300):
            return perp / np.linalg.norm(perp)
    return np.array([1.0, 0, 0])


def _free_band(band: np.ndarray, free: slice) -> np.ndarray:
    # the free points are contiguous, so their coordinates are a column range of the band
    return band[:, 3 * free.start : 3 * free.stop]


def _factor(band: np.ndarray, shift: float) -> np.ndarray | None:
    """Banded Cholesky factor of band + shift I (LAPACK dpbtrf), or None if not positive."""
    shifted = band.copy()
    shifted[0] += shift
    # LAPACK directly: scipy.linalg.cholesky_banded's checks and dispatch cost more than the
    # factorization itself at these sizes, and this runs in every Newton iteration
    factor, info = lapack.dpbtrf(shifted, lower=1)
    return factor if info == 0 else None


def _solve(factor: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve with a factor of :func:`_factor` (LAPACK dpbtrs)."""
    return lapack.dpbtrs(factor, rhs, lower=1)[0]


def equilibrium(
    cable: Cable,
    guess,
    clips: ClipPoses | None = None,
    *,
    gravity=GRAVITY,
    rtol: float = 1e-10,
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
    rtol : float
        Convergence when the largest free-point force is below ``rtol`` times
        :func:`force_scale`.
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
    tolerance = rtol * force_scale(cable, gravity)
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
    x, g, iterations, residual, stable, history, message = minimize_energy(
        chain, x, free, max_step, tolerance, max_iterations
    )
    return _result(cable, chain, x, g, clips, iterations, residual <= tolerance, residual,
                   tolerance, stable, history, message, held)


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

    def derivatives(x):
        g, band = gradient_and_hessian_band(chain, x)
        g -= gravity_force(chain.point_masses, chain.gravity)
        residual = float(np.max(norms(g[free])))
        return g[free].ravel(), _free_band(band, free), residual, g

    def moved(x, p):
        trial = x.copy()
        trial[free] += p.reshape(-1, 3)
        return trial

    run = trust_region_newton(
        x, lambda x: float(energy(chain, x)), derivatives, moved,
        lambda p: float(np.max(norms(p.reshape(-1, 3)))),
        length_scale, tolerance, max_iterations,
    )
    return run.state, run.extra, run.iterations, run.residual, run.stable, run.history, \
        run.message


@dataclass(frozen=True, eq=False)
class NewtonRun:
    """Outcome of :func:`trust_region_newton`.

    Attributes
    ----------
    state : object
        The final state (whatever the caller's ``moved`` builds).
    extra : object
        The fourth item of the last ``derivatives(state)`` call (e.g. the full gradient).
    iterations : int
        Newton iterations.
    residual : float
        The residual of the last evaluation (the caller's unit, e.g. [N]).
    stable : bool
        Residual below the tolerance and the free Hessian positive definite.
    history : numpy.ndarray
        Energy after each accepted iteration [J].
    message : str
        What happened.
    """

    state: object
    extra: object
    iterations: int
    residual: float
    stable: bool
    history: np.ndarray
    message: str


def trust_region_newton(
    state, energy_of, derivatives, moved, displacement, length_scale: float, tolerance: float,
    max_iterations: int = 500, unit: str = "N",
) -> NewtonRun:
    """The trust-region (Levenberg-Marquardt) Newton loop of the static solvers.

    Generic over the state so that positions only (:func:`minimize_energy`) and positions with
    twist angles (:mod:`dloplan.sim.torsion`) share it; see the module docstring for the method.

    Parameters
    ----------
    state : object
        The start.
    energy_of : callable
        ``energy_of(state) -> float`` [J].
    derivatives : callable
        ``derivatives(state) -> (g, band, residual, extra)``: the gradient over the free
        coordinates (1-D), the lower band of their Hessian (``cholesky_banded(lower=True)``
        layout), the residual compared with ``tolerance``, and anything to hand back.
    moved : callable
        ``moved(state, p) -> state``: the state after the step ``p`` of the free coordinates.
    displacement : callable
        ``displacement(p) -> float``: the size of a step [m], compared with the trust radius.
    length_scale : float
        Largest step [m] at the start (a quarter of it) and ever (all of it).
    tolerance : float
        Residual for convergence.
    max_iterations : int
        Iteration limit.
    unit : str
        Unit of the residual, for the messages.
    """
    radius = 0.25 * length_scale  # trust radius: the largest point displacement of one step
    shift = 0.0
    f = energy_of(state)
    history = [f]
    iterations = 0
    message = ""
    stable = False
    escapes = 0
    while True:
        gf, band, residual, extra = derivatives(state)
        scale = float(np.mean(band[0]))
        # stable: positive definite up to a relative 1e-9 (a zero-stiffness mode is neutral)
        stable = residual <= tolerance and _factor(band, _NEUTRAL * scale) is not None
        if stable:
            message = f"converged in {iterations} iterations"
            break
        if iterations >= max_iterations:
            message = (f"no convergence in {max_iterations} iterations "
                       f"(residual {residual:.3g} {unit})")
            break
        if residual <= tolerance and escapes < _MAX_ESCAPES:
            # a saddle (an unstable equilibrium): leave it downhill along the direction of
            # most negative curvature, then carry on with Newton toward a stable one
            escaped = _escape_saddle(state, f, band, energy_of, moved, displacement, radius)
            iterations += 1
            escapes += 1
            if escaped is None:
                message = f"stuck at an unstable equilibrium after {iterations} iterations"
                break
            state, f = escaped
            history.append(f)
            shift = 0.0
            continue
        accepted = False
        for _ in range(60):  # adapt the shift until a step is accepted
            factor = _factor(band, shift)
            if factor is None:
                shift = max(4.0 * shift, 1e-8 * scale)
                continue
            p = -_solve(factor, gf)
            longest = displacement(p)
            alpha = min(1.0, radius / longest) if longest > 0 else 1.0  # truncate to the radius
            # model decrease g.p + p.H.p/2 with (H + shift I) p_full = -g, p = alpha p_full
            g_p = float(gf @ p)
            predicted = alpha * g_p + 0.5 * alpha**2 * (-g_p - shift * float(p @ p))
            p *= alpha
            trial = moved(state, p)
            f_trial = energy_of(trial)
            actual = f_trial - f
            noise = 1e-13 * (abs(f) + abs(predicted)) + 1e-300
            if predicted < 0 and (actual < 0 or abs(actual) < noise):
                ratio = actual / predicted if abs(predicted) > noise else 1.0
                state, f = trial, f_trial
                accepted = True
                if ratio > 0.75:
                    shift = 0.0 if shift < 1e-6 * scale else shift / 8.0
                    radius = min(2.0 * radius, length_scale)
                elif ratio < 0.25:
                    shift = max(4.0 * shift, 1e-8 * scale)
                break
            shift = max(4.0 * shift, 1e-8 * scale)
            radius = max(0.5 * min(radius, longest), 1e-9 * length_scale)
        iterations += 1
        if not accepted:
            message = f"stalled after {iterations} iterations (residual {residual:.3g} {unit})"
            break
        history.append(f)
    return NewtonRun(state, extra, iterations, residual, stable, np.asarray(history), message)


_NEUTRAL = 1e-9  # relative shift under which a Hessian counts as positive (semi-)definite
_MAX_ESCAPES = 20


def _escape_saddle(state, f, band, energy_of, moved, displacement, radius):
    """A step from a saddle along the eigenvector of the most negative Hessian eigenvalue.

    Tries both signs with a backtracking length, starting at the trust radius; returns
    ``(state, energy)`` of the first step that lowers the energy, or None.
    """
    _, vectors = sla.eig_banded(band, lower=True, select="i", select_range=(0, 0),
                                check_finite=False)
    direction = vectors[:, 0] / displacement(vectors[:, 0])
    length = radius
    for _ in range(40):
        for sign in (1.0, -1.0):
            trial = moved(state, sign * length * direction)
            f_trial = energy_of(trial)
            if f_trial < f:
                return trial, f_trial
        length *= 0.5
    return None


def _result(cable, chain, x, g, clips, iterations, converged, residual, tolerance, stable,
            history, message, held="both") -> Equilibrium:
    if not stable and converged:
        message += "; the equilibrium is not stable (Hessian not positive definite)"
    depth = 0.0
    if chain.contacts:
        depth = max(0.0, *(float(d.max()) for d, _ in
                           penetrations(x, chain.contacts, chain.contact_radius)))
    return Equilibrium(
        shape=x,
        forces=forces(chain, x),
        energy=float(history[-1]),
        clip_wrenches=_clip_wrenches(x, g, clips, held),
        iterations=iterations,
        converged=bool(converged),
        residual=float(residual),
        tolerance=float(tolerance),
        stable=bool(stable),
        clips=clips,
        message=message,
        energy_history=np.asarray(history),
        penetration=depth,
    )


def clip_wrenches(cable: Cable, shape, gravity=GRAVITY) -> np.ndarray:
    """Force [N] and moment [N m] a held shape puts on each clip, (2, 6), world frame.

    The reactions of the held points, as in :attr:`Equilibrium.clip_wrenches`, for a shape
    that is an equilibrium (e.g. a stabilized one); the moment is about each clip point.
    """
    x = as_shape(shape, cable.n_points, "shape")
    chain = SpringChain.from_cable(cable, gravity)
    return _clip_wrenches(x, gradient(chain, x), clip_poses_from_shape(x), "both")


def free_hessian(cable: Cable, shape, gravity=GRAVITY) -> sp.csr_matrix:
    """Sparse Hessian of the energy over the free coordinates (points 2 .. n-2) [N/m].

    The tangent stiffness of a held cable: its smallest eigenvalue decides elastic stability.
    """
    x = as_shape(shape, cable.n_points, "shape")
    chain = SpringChain.from_cable(cable, gravity)
    return band_to_sparse(_free_band(hessian_band(chain, x), slice(2, cable.n_points - 2)))


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
        from .dynamics import settle

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
    """Clip poses between ``a`` and ``b``: linear in position, slerp in rotation."""
    fractions = np.asarray(fractions, dtype=float)
    out = []
    slerps = [
        Slerp([0.0, 1.0], Rotation.concatenate([a.rotations[k], b.rotations[k]]))
        for k in range(2)
    ]
    for t in fractions:
        pos = (1.0 - t) * a.positions + t * b.positions
        rot = Rotation.concatenate([slerps[k](t) for k in range(2)])
        out.append(ClipPoses(pos, rot))
    return out


def continuation(
    cable: Cable,
    start_shape,
    clip_sequence: Sequence[ClipPoses],
    *,
    substeps: int = 1,
    gravity=GRAVITY,
    contacts=(),
    **options,
) -> list[Equilibrium]:
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
        slerp); only the equilibria at the given poses are returned.
    gravity : array_like
        Gravity [m/s^2].
    contacts : sequence
        Obstacles the cable cannot enter (see :func:`equilibrium`).
    **options
        Passed to :func:`equilibrium`.

    Returns
    -------
    list of Equilibrium
        One per element of ``clip_sequence``.
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
        for stop in stops:
            eq = equilibrium(cable, x, stop, gravity=gravity, chain=chain, **options)
            x = eq.shape
        results.append(eq)
        previous = clips
    return results
