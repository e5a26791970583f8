"""Static equilibrium of a cable with torsion: points and material frames together (3.4.3, 3.9).

:func:`equilibrium_with_twist` minimizes U = U^s + U^b + U^g (+ contacts) + U^t + U^d
(:mod:`dloplan.physics.twist`) jointly over the free points 2 .. n-2 and the twist angles of the
free links 1 .. n-2, with the same trust-region Newton loop as :func:`dloplan.sim.statics.
equilibrium` (:func:`~dloplan.sim.newton.trust_region_newton`). The clips hold the four end
points and set the material frame of the two held links:

* first clip: m1 of link 0 is the clip's v-axis (its y-axis);
* last clip: m1 of link n-1 is minus the clip's v-axis. The last clip's u-axis points inward,
  against the cable's direction, so its frame is the material frame turned by 180 degrees about
  the w-axis: two clips with the same w-axis hold a straight cable untwisted.

The state is the points and one director per link, so no angle is ever wrapped: each Newton
iteration works in a chart centred on the current state (reference directors = the current
ones, angles 0) and the step's angles turn the parallel-transported directors. Angles enter the
linear algebra as l theta [m], so that one trust radius [m] and one residual [N] serve points and
angles (a torque residual tau [N m] counts as tau / l). Coordinates are interleaved point by point
(x_i, y_i, z_i, theta_i): the Hessian is a band of half-width 10 and each step costs O(n).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, fields, replace
from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..frames import frame_from_axis
from ..geometry import as_shape, tangents
from ..physics.chain import (
    HALF_BANDWIDTH,
    Forces,
    SpringChain,
    shape_derivatives,
    shape_energy,
)
from ..physics.rod_frames import (
    parallel_transport,
    rotate_about,
    transported_directors,
)
from ..physics.twist import (
    TwistChain,
    TwistDerivatives,
    centred_twist_derivatives,
)
from ..physics.twist_compiled import (
    interleaved_band,
    moved_directors,
    scratch,
    twist_angles,
    twist_energies,
)
from .clips import ClipPoses, check_clip_reach, clip_poses_from_shape, conform_guess
from .compiled import (
    CONVERGED,
    MAX_ITERATIONS,
    SADDLE,
    STALLED,
    newton_twist,
    twist_step_length,
    twist_trial,
)
from .newton import (
    MAX_ESCAPES,
    NewtonRun,
    escape_saddle,
    newton_message,
    trust_region_newton,
)
from .result import Equilibrium, equilibrium_result, residual_tolerance

TWIST_HALF_BANDWIDTH = 10
"""Half bandwidth of the joint Hessian over interleaved (x, y, z, theta) coordinates."""

DEFAULT_MAX_TWIST = math.radians(15.0)
"""Largest |twist| [rad] between the clips a path may carry and still count as a success."""


@dataclass(frozen=True, eq=False)
class TwistEquilibrium(Equilibrium):
    """An :class:`~dloplan.sim.statics.Equilibrium` with material frames.

    ``energy`` includes U^t and U^d; ``forces.twist`` is F^t (eq. 3.19) and ``forces.bending``
    includes the directional bending of a curved cable; ``clip_wrenches`` include the torque.

    Attributes
    ----------
    directors : numpy.ndarray
        (n, 3) material directors m1 of the links (unit, perpendicular to the links).
    twist : numpy.ndarray
        (n - 1,) discrete twist psi_i at the interior points [rad].
    rest_twist : numpy.ndarray
        (n - 1,) natural twist psibar_i [rad].
    twist_energy : float
        U^t [J] (eq. 3.14 summed).
    """

    directors: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    twist: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rest_twist: np.ndarray = field(default_factory=lambda: np.zeros(0))
    twist_energy: float = 0.0
    k_twist: float = 0.0

    @property
    def total_twist(self) -> float:
        """Twist carried between the two held links beyond the natural twist [rad]."""
        return float(np.sum(self.twist - self.rest_twist))

    @property
    def torques(self) -> np.ndarray:
        """Twisting moment k_t (psi_i - psibar_i) at each interior point [N m], (n - 1,)."""
        return self.k_twist * (self.twist - self.rest_twist)


def clip_directors(clips: ClipPoses) -> np.ndarray:
    """The material directors m1 the clips set on the held links, (2, 3) (module docstring)."""
    return held_directors(clips.rotations.as_matrix())


def rest_clip_poses(cable: Cable, natural_twist: float = 0.0) -> ClipPoses:
    """Clip poses holding the cable in its rest shape without stress (energy U^b = U^t = 0).

    The rest shape as placed in ``cable.rest_shape`` (a straight cable along world x from the
    origin if it has none); the first clip frame is :func:`dloplan.frames.frame_from_axis` of
    link 0, the last one carries the rest frame of link n-1 (see
    :meth:`dloplan.physics.twist.TwistChain.from_cable`). Move both rigidly
    (:meth:`ClipPoses.moved`) to hold the cable at rest anywhere.
    """
    tc = TwistChain.from_cable(cable, natural_twist)
    if tc.rest_directors is not None:
        shape, directors = cable.rest_shape, tc.rest_directors
    else:
        n, l = cable.n_links, cable.rest_link_length
        shape = np.zeros((n + 1, 3))
        shape[:, 0] = l * np.arange(n + 1)
        first = frame_from_axis(tangents(shape)[0]).apply([0.0, 1.0, 0.0])[0]
        turned = np.concatenate([[0.0], np.cumsum(tc.rest_twist)])
        directors = rotate_about(transported_directors(shape, first), tangents(shape), turned)
    t = tangents(shape)
    u_last = -t[-1]
    v_last = -directors[-1]
    last = Rotation.from_matrix(np.stack([u_last, v_last, np.cross(u_last, v_last)], axis=-1))
    first = frame_from_axis(t[0])
    return ClipPoses(clip_poses_from_shape(shape).positions, Rotation.concatenate([first, last]))


@lru_cache(maxsize=32)
def _layout(n_links: int):
    """Index tables of the interleaved coordinates of a chain of ``n_links`` links."""
    n_points = n_links + 1
    n_dof = 4 * n_links + 3
    point_dofs = 4 * np.arange(n_points)[:, None] + np.arange(3)[None, :]
    angle_dofs = 4 * np.arange(n_links) + 3
    free = slice(7, 4 * n_links - 4)  # theta_1, x_2, theta_2, ..., x_{n-2}, theta_{n-2}
    return n_dof, point_dofs, angle_dofs, free


def _joint_derivatives(chain: SpringChain, tc: TwistChain, x: np.ndarray, d1: np.ndarray,
                       link: float):
    """Gradient and lower band over the interleaved coordinates (angles as l theta [m])."""
    n_dof, point_dofs, angle_dofs, *_ = _layout(len(d1))
    _, g_pos, band_pos = shape_derivatives(chain, x)
    td = centred_twist_derivatives(tc, x, d1)
    g_pos = g_pos + td.twist_gradient + td.direction_gradient
    band = np.empty((TWIST_HALF_BANDWIDTH + 1, n_dof))
    interleaved_band(band_pos, td.blocks, link, band)
    g = np.empty(n_dof)
    g[point_dofs] = g_pos
    g[angle_dofs] = td.angle_gradient / link
    return g, band, g_pos, td


def _compiled_twist_newton(chain: SpringChain, tc: TwistChain, state, link: float,
                           length_scale: float, tolerance: float, max_iterations: int,
                           energy_of, moved) -> NewtonRun:
    """:func:`trust_region_newton` for points and angles without contacts, in
    :func:`~dloplan.sim.compiled.newton_twist`; saddles are escaped here as in the generic loop.
    ``extra`` of the run is ``(points' gradient [N], TwistDerivatives)`` at the last state."""
    x, d1 = (np.array(part, dtype=float) for part in state)
    n = len(d1)
    history = np.empty(max_iterations + 1)
    history[0] = energy_of((x, d1))
    n_history, iterations, radius, escapes = 1, 0, 0.25 * length_scale, 0
    arrays = dict(grad=np.empty_like(x), tgrad=np.empty_like(x), dgrad=np.empty_like(x),
                  agrad=np.empty(n), blocks=np.empty((n - 1, 11, 11)),
                  band_pos=np.empty((HALF_BANDWIDTH + 1, x.size)),
                  band=np.empty((TWIST_HALF_BANDWIDTH + 1, 4 * n + 3)))
    free = _layout(n)[3]
    while True:
        status, iterations, residual, radius, n_history = newton_twist(
            x, d1, chain.constants, tc.constants, link, length_scale, tolerance,
            max_iterations, iterations, radius, history, n_history, scratch(), *arrays.values(),
            escapes < MAX_ESCAPES, chain.stiff_axial)
        if status != SADDLE:
            break
        escaped = escape_saddle((x, d1), history[n_history - 1], arrays["band"][:, free],
                                energy_of, moved, twist_step_length, radius)
        iterations += 1
        escapes += 1
        if escaped is None:
            break
        (x, d1), history[n_history] = escaped
        n_history += 1
    outcome = {CONVERGED: "converged", MAX_ITERATIONS: "max_iterations", STALLED: "stalled",
               SADDLE: "stuck"}[status]
    u_t, u_d = twist_energies(x, d1, *tc.constants)
    td = TwistDerivatives(u_t, u_d, arrays["tgrad"], arrays["dgrad"], arrays["agrad"],
                          arrays["blocks"])
    return NewtonRun((x, d1), (arrays["grad"], td), iterations, residual, status == CONVERGED,
                     history[:n_history].copy(), newton_message(outcome, iterations, residual))


def _orthonormal(d1: np.ndarray, t: np.ndarray) -> np.ndarray:
    d1 = d1 - np.einsum("ij,ij->i", d1, t)[:, None] * t
    return d1 / np.linalg.norm(d1, axis=1, keepdims=True)


def initial_directors(shape: np.ndarray, held: np.ndarray, rest_twist: np.ndarray) -> np.ndarray:
    """Directors that meet the clips' with the twist spread evenly, (n, 3).

    The first clip's director is carried along ``shape`` by parallel transport; the angle it
    then misses the last clip's director by, taken within pi of the natural twist, is spread
    over the interior points on top of the natural twist.
    """
    carried = transported_directors(shape, held[0])
    t_last = shape[-1] - shape[-2]
    t_last = t_last / math.sqrt(float(t_last @ t_last))
    a, b = carried[-1], held[1]  # the angle turning a to b about t_last, in (-pi, pi]
    missing = math.atan2(float(np.cross(a, b) @ t_last), float(a @ b))
    total = np.sum(rest_twist)
    total += (missing - total + np.pi) % (2.0 * np.pi) - np.pi
    turned = total * np.arange(len(carried)) / (len(carried) - 1)
    d1 = np.empty_like(carried)
    moved_directors(shape, shape, carried, turned, d1)  # turned about the links, kept unit
    d1[[0, -1]] = held
    return d1


def _twist_angles(x: np.ndarray, d1: np.ndarray) -> np.ndarray:
    out = np.empty(len(d1) - 1)
    twist_angles(x, d1, out)
    return out


def equilibrium_with_twist(
    cable: Cable,
    guess,
    clips: ClipPoses | None = None,
    *,
    directors=None,
    natural_twist: float = 0.0,
    gravity=GRAVITY,
    rtol: float | None = None,
    max_iterations: int = 500,
    contacts=(),
    chain: SpringChain | None = None,
    twist_chain: TwistChain | None = None,
) -> TwistEquilibrium:
    """The nearest stable static equilibrium of a cable with torsion held by two clips.

    Minimizes the potential energy with twist (eqs. 3.8, 3.14, 3.20, 3.28; directional bending
    for a curved rest shape) over the free points and the free links' twist angles; the clips
    hold points 0, 1, n-1, n and set the material frames of links 0 and n-1 (module docstring).

    Parameters
    ----------
    cable : Cable
        The cable (k_t = G I_p / l from its E and Poisson ratio).
    guess : array_like
        (n + 1, 3) starting shape [m]; it selects the equilibrium branch.
    clips : ClipPoses, optional
        Clip poses; default: those of the guess (:func:`clip_poses_from_shape`).
    directors : array_like, optional
        (n, 3) material directors of a previous solution whose shape was ``guess`` (a warm
        start: they carry the twist already in the cable, more than half a turn included).
        Default: the first clip's director carried along the guess, with the angle it misses the
        last clip's by (within half a turn of the natural twist) spread evenly.
    natural_twist : float
        Natural twist theta of the cable end to end [rad] (3.4.3).
    gravity, rtol, max_iterations, contacts, chain
        As in :func:`dloplan.sim.statics.equilibrium`.
    twist_chain : TwistChain, optional
        Precomputed twist constants (``natural_twist`` is then ignored).

    Returns
    -------
    TwistEquilibrium
        Shape, directors, twist, energies, forces (with F^t), clip wrenches (with the torque).
    """
    x = as_shape(guess, cable.n_points, "guess")
    if clips is None:
        clips = clip_poses_from_shape(x)
    check_clip_reach(cable, clips)
    tc = twist_chain if twist_chain is not None else TwistChain.from_cable(cable, natural_twist)
    if chain is None:
        chain = SpringChain.from_cable(cable, gravity, contacts)
    if tc.directional:  # the directional term replaces the unsigned rest angles
        chain = replace(chain, rest_angles=np.zeros_like(chain.rest_angles))
    start = conform_guess(cable, x, clips, gravity)
    held = clip_directors(clips)
    if directors is None:
        d1 = initial_directors(start, held, tc.rest_twist)
    else:
        d1 = np.asarray(directors, dtype=float)
        if d1.shape != (cable.n_links, 3) or not np.all(np.isfinite(d1)):
            raise ValueError(
                f"directors: expected finite (n_links, 3) = ({cable.n_links}, 3) directors, "
                f"got shape {d1.shape}"
            )
        t_new = tangents(start)
        d1 = _orthonormal(parallel_transport(_orthonormal(d1, tangents(x)), tangents(x), t_new),
                          t_new)
        d1[[0, -1]] = held
    link = cable.rest_link_length
    n = cable.n_links
    free = _layout(n)[3]
    tolerance = residual_tolerance(cable, gravity, rtol, start)

    def energy_of(state):
        x, d1 = state
        return shape_energy(chain, x) + sum(twist_energies(x, d1, *tc.constants))

    def derivatives(state):
        x, d1 = state
        g, band, g_pos, td = _joint_derivatives(chain, tc, x, d1, link)
        residual = max(
            float(np.max(np.linalg.norm(g_pos[2:-2], axis=1), initial=0.0)),
            float(np.max(np.abs(td.angle_gradient[1:-1]), initial=0.0)) / link,
        )
        return g[free], band[:, free], residual, (g_pos, td)

    def moved(state, p, correct=False):
        x, d1 = state
        trial, trial_d1 = np.empty_like(x), np.empty_like(d1)
        done = twist_trial(x, d1, p, link, trial, trial_d1, np.empty(n), correct)
        return (trial, trial_d1) if done else None

    def corrected(state, p):
        return moved(state, p, True)

    if chain.contacts:  # obstacles are Python objects: the generic loop
        run = trust_region_newton((start, d1), energy_of, derivatives, moved,
                                  twist_step_length, cable.length, tolerance, max_iterations,
                                  corrected=corrected if chain.stiff_axial else None)
    else:
        run = _compiled_twist_newton(chain, tc, (start, d1), link, cable.length, tolerance,
                                     max_iterations, energy_of, moved)
    x, d1 = run.state
    g_pos, td = run.extra
    converged = run.residual <= tolerance
    base = equilibrium_result(cable, chain, x, g_pos, clips, run.iterations, converged,
                              run.residual, tolerance, run.stable, run.history, run.message)
    plain = base.forces
    wrenches = base.clip_wrenches.copy()
    t = tangents(x)
    wrenches[0, 3:] -= td.angle_gradient[0] * t[0]
    wrenches[1, 3:] -= td.angle_gradient[-1] * t[-1]
    values = {f.name: getattr(base, f.name) for f in fields(Equilibrium)}
    values.update(
        forces=Forces(plain.axial, plain.bending - td.direction_gradient, plain.gravity,
                      plain.contact, -td.twist_gradient),
        clip_wrenches=wrenches,
    )
    return TwistEquilibrium(
        **values,
        directors=d1,
        twist=_twist_angles(x, d1),
        rest_twist=tc.rest_twist,
        twist_energy=td.twist_energy,
        k_twist=tc.k_twist,
    )


class QuasiStaticTwist:
    """Twist in the dynamic simulator: massless twist angles carried along the moving cable.

    The material directors are transported with the links from step to step (parallel
    transport in time) and, at every step, the free links' angles take one Newton step toward
    the minimum of U^t + U^d for the current points (the angles have no inertia); the position
    gradient of that energy is the twisting force of eq. 3.19 on the points. The steps run
    compiled in :func:`dloplan.sim.stepping.twist_steps`; this holds the state between chunks.

    Parameters
    ----------
    cable : Cable
        The cable.
    x : numpy.ndarray
        (n + 1, 3) initial shape [m].
    clip_matrices : numpy.ndarray
        (2, 3, 3) initial ``clip_to_world`` matrices (their v-axes set the held directors).
    natural_twist : float
        Natural twist [rad].
    """

    def __init__(self, cable: Cable, x: np.ndarray, clip_matrices: np.ndarray,
                 natural_twist: float = 0.0) -> None:
        self.twist_chain = TwistChain.from_cable(cable, natural_twist)
        self.directors = initial_directors(x, held_directors(clip_matrices),
                                           self.twist_chain.rest_twist)

    def chain_for(self, chain: SpringChain) -> SpringChain:
        """The spring chain to use with it (the directional term replaces rest angles)."""
        if self.twist_chain.directional:
            return replace(chain, rest_angles=np.zeros_like(chain.rest_angles))
        return chain


def held_directors(clip_matrices: np.ndarray) -> np.ndarray:
    """The held links' directors from clip frames (..., 2, 3, 3): v of the first, -v of the
    last, (..., 2, 3)."""
    v = np.asarray(clip_matrices)[..., 1]
    return np.stack([v[..., 0, :], -v[..., 1, :]], axis=-2)


@dataclass(frozen=True, eq=False)
class TwistReport:
    """Twist along a planned path with gripper frames (:func:`twist_along_path`).

    Attributes
    ----------
    equilibria : tuple of TwistEquilibrium
        The stabilized shape with torsion at every clip pose.
    twist : numpy.ndarray
        (K,) twist the cable carries between the clips beyond its natural twist [rad]
        (:attr:`TwistEquilibrium.total_twist`).
    relative_twist : numpy.ndarray
        (K,) ``twist - twist[0]``: the twist the motion added [rad].
    twist_energy : numpy.ndarray
        (K,) U^t [J] at every shape.
    success : bool
        Every equilibrium converged and |twist| <= ``max_twist`` everywhere.
    message : str
        One line: the largest twist and twist energy, or what failed.
    max_twist : float
        The threshold [rad].
    """

    equilibria: tuple[TwistEquilibrium, ...]
    twist: np.ndarray
    relative_twist: np.ndarray
    twist_energy: np.ndarray
    success: bool
    message: str
    max_twist: float


def twist_along_path(
    cable: Cable,
    path,
    clip_sequence: Sequence[ClipPoses],
    *,
    natural_twist: float = 0.0,
    gravity=GRAVITY,
    max_twist: float = DEFAULT_MAX_TWIST,
    **options,
) -> TwistReport:
    """Stabilize every shape of a path with torsion, holding the planned gripper frames.

    Each shape is solved from the planned shape with the previous solution's directors carried
    over (a quasi-static continuation), so twist accumulated over several shapes -- half a turn
    and more -- is tracked, as the real cable would carry it.

    Parameters
    ----------
    cable : Cable
        The cable.
    path : array_like
        (K, n + 1, 3) planned shapes [m] (K = S + 2).
    clip_sequence : sequence of ClipPoses
        K clip poses (e.g. ``GripperPath.clip_poses(i)`` for every shape i).
    natural_twist : float
        Natural twist of the cable [rad].
    gravity : array_like
        Gravity [m/s^2].
    max_twist : float
        |twist| above which the report fails [rad].
    **options
        Passed to :func:`equilibrium_with_twist`.
    """
    shapes = np.asarray(path, dtype=float)
    if shapes.ndim != 3 or shapes.shape[1:] != (cable.n_points, 3):
        raise ValueError(
            f"path: expected shapes (K, n_links + 1, 3) = (K, {cable.n_points}, 3), "
            f"got {shapes.shape}"
        )
    if len(clip_sequence) != len(shapes):
        raise ValueError(
            f"clip_sequence: {len(clip_sequence)} clip poses for {len(shapes)} shapes, "
            "expected one per shape"
        )
    if not (math.isfinite(max_twist) and max_twist > 0):
        raise ValueError(f"max_twist: got {max_twist!r}, expected an angle > 0 [rad]")
    tc = TwistChain.from_cable(cable, natural_twist)
    chain = SpringChain.from_cable(cable, gravity)
    results: list[TwistEquilibrium] = []
    for k, (shape, clips) in enumerate(zip(shapes, clip_sequence, strict=True)):
        guess = as_shape(shape, cable.n_points, f"path[{k}]")
        directors = None
        if results:  # carry the previous directors over to this shape
            before = results[-1]
            directors = parallel_transport(before.directors, tangents(before.shape),
                                           tangents(guess))
        results.append(equilibrium_with_twist(
            cable, guess, clips, directors=directors, gravity=gravity, chain=chain,
            twist_chain=tc, **options,
        ))
    twist = np.array([r.total_twist for r in results])
    energies = np.array([r.twist_energy for r in results])
    failed = [k for k, r in enumerate(results) if not r.converged]
    worst = int(np.argmax(np.abs(twist)))
    summary = (f"largest twist {math.degrees(twist[worst]):.1f} degrees at shape {worst}, "
               f"largest twist energy {energies.max():.3g} J")
    if failed:
        message = f"stabilization failed at shapes {failed}; {summary}"
    elif abs(twist[worst]) > max_twist:
        message = (f"the path twists the cable: {summary} (more than "
                   f"{math.degrees(max_twist):.0f} degrees)")
    else:
        message = summary
    return TwistReport(
        equilibria=tuple(results),
        twist=twist,
        relative_twist=twist - twist[0],
        twist_energy=energies,
        success=not failed and abs(twist[worst]) <= max_twist,
        message=message,
        max_twist=float(max_twist),
    )
