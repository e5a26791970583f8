"""What a static solve of a held cable returns: the equilibrium, its forces and clip reactions.

Shared by the solvers of :mod:`dloplan.sim.statics` (positions), :mod:`dloplan.sim.torsion`
(positions and material frames) and :func:`dloplan.sim.dynamics.settle` (the thesis' time
stepping run to rest), so that their results can be swapped.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np

from ..cable import GRAVITY, Cable
from ..jit import njit
from ..physics.chain import Forces, shape_forces
from ..physics.contact import penetrations
from .clips import ClipPoses


@dataclass(frozen=True, eq=False)
class Equilibrium:
    """A static equilibrium found by :func:`dloplan.sim.statics.equilibrium` (or a sibling solver).

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


def force_scale(cable: Cable, gravity=GRAVITY, weight: float | None = None) -> float:
    """Characteristic force of a cable's statics [N]: a point's weight plus k_b / l.

    ``weight`` [N], when given, stands for :func:`point_weight` (the same for every E of a
    cable: computed once for many)."""
    if weight is None:
        weight = point_weight(cable, gravity)
    return weight + cable.k_bending / cable.rest_link_length


def point_weight(cable: Cable, gravity=GRAVITY) -> float:
    """The largest weight of a point of the cable [N]."""
    return float(np.max(cable.point_masses)) * math.hypot(*np.asarray(gravity, dtype=float))


ROUNDOFF = 16.0
"""The round-off floor of a force residual is ``ROUNDOFF * eps * X * k_max``
(:func:`residual_tolerance`): a few terms per point, each a stiffness times a difference of
coordinates of size X."""


def stiffest(cable: Cable, contact_stiffness: float = 0.0) -> float:
    """The largest stiffness [N/m] of the discretized cable: k_s, k_b / l^2, k_t / l^2 (a
    torque per angle as a force per displacement of a point a link away) or a contact penalty.
    """
    l2 = cable.rest_link_length**2
    return max(cable.k_axial, cable.k_bending / l2, cable.k_twist / l2, contact_stiffness)


DEFAULT_RTOL = 1e-10
"""The static solvers' relative force tolerance when the caller gives none."""


def residual_tolerance(cable: Cable, gravity=GRAVITY, rtol: float | None = None, x=None,
                       contact_stiffness: float = 0.0) -> float:
    """The force residual [N] under which an equilibrium counts as converged.

    Without ``rtol``: :data:`DEFAULT_RTOL` times :func:`force_scale`, or the round-off floor of
    the residual, whichever is larger; a force k (x_j - x_i) computed from coordinates of size X
    carries an error of about
    eps k X, so with a stiff spring (a composite cable's axial modulus, 1000 times its bending
    one; a contact penalty) no iterate gets below ``ROUNDOFF * eps * X * k_max``
    (:func:`stiffest`, X = max |x| + L). Moving the same shape 0.3 m away raises the floor with
    X, as it raises the residual. Every static solver (:func:`dloplan.sim.equilibrium`,
    :func:`dloplan.sim.equilibrium_with_twist`, the identification's and the correction's
    equilibria) takes its tolerance from here. An explicit ``rtol`` is taken as asked (``rtol``
    times :func:`force_scale`): a caller who wants a tighter solve where round-off allows it
    (finite differences of equilibria) gets it.

    Parameters
    ----------
    cable : Cable
    gravity : array_like
        Gravity [m/s^2].
    rtol : float, optional
        Relative tolerance against :func:`force_scale` (default: :data:`DEFAULT_RTOL` or the
        round-off floor).
    x : array_like, optional
        (n + 1, 3) the shape [m] (its coordinates' size; default the cable's length from the
        origin).
    contact_stiffness : float
        The contact penalty [N/m] when obstacles are present.
    """
    scale, stiffness = _scales(cable, gravity, contact_stiffness)
    if rtol is not None:
        return rtol * scale
    size = cable.length + (0.0 if x is None else float(np.max(np.abs(x))))
    floor = ROUNDOFF * EPS * size * stiffness
    return max(DEFAULT_RTOL * scale, floor)


EPS = float(np.finfo(float).eps)

_SCALES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""Per cable object, while it lives: (:func:`force_scale`, :func:`stiffest`) per gravity and
contact stiffness (every solve asks for its tolerance; a cable is frozen)."""


def _scales(cable: Cable, gravity, contact_stiffness: float) -> tuple[float, float]:
    """(:func:`force_scale`, :func:`stiffest`) of ``cable``, computed once per cable object,
    gravity and contact stiffness."""
    key = (*np.asarray(gravity, dtype=float).ravel().tolist(), float(contact_stiffness))
    cached = _SCALES.get(cable)
    if cached is None:
        cached = _SCALES[cable] = {}
    if key not in cached:
        cached[key] = (force_scale(cable, gravity), stiffest(cable, contact_stiffness))
    return cached[key]


def clip_reactions(x: np.ndarray, grad: np.ndarray, clips: ClipPoses, held: str = "both"
                   ) -> np.ndarray:
    """Force [N] and moment [N m] the cable puts on each clip, (2, 6): minus the held reactions.

    Parameters
    ----------
    x : numpy.ndarray
        (n + 1, 3) equilibrium shape [m].
    grad : numpy.ndarray
        (n + 1, 3) energy gradient at ``x`` [N] (the clips balance it on their points).
    clips : ClipPoses
        The clips; moments are taken about their points.
    held : {"both", "first"}
        Which clips hold the cable (the second row stays zero for ``"first"``).
    """
    wrenches = np.zeros((2, 6))
    _add_reactions(x, grad, clips.positions, 2 if held == "both" else 1, wrenches)
    return wrenches


@njit(cache=True)
def _add_reactions(x, grad, positions, n_clips, wrenches):
    """Sum -grad and (x - clip) x (-grad) over each clip's two points into ``wrenches``."""
    n = x.shape[0]
    for k in range(n_clips):
        for point in ((0, 1) if k == 0 else (n - 2, n - 1)):
            f = -grad[point]
            r = x[point] - positions[k]
            wrenches[k, 0] += f[0]
            wrenches[k, 1] += f[1]
            wrenches[k, 2] += f[2]
            wrenches[k, 3] += r[1] * f[2] - r[2] * f[1]
            wrenches[k, 4] += r[2] * f[0] - r[0] * f[2]
            wrenches[k, 5] += r[0] * f[1] - r[1] * f[0]


def equilibrium_result(cable, chain, x, g, clips, iterations, converged, residual, tolerance,
                       stable, history, message, held="both") -> Equilibrium:
    """The :class:`Equilibrium` of a solved shape ``x`` with energy gradient ``g`` [N].

    Adds the forces, clip reactions and the deepest contact penetration to what the solver
    found; ``converged`` without ``stable`` appends a warning to ``message``.
    """
    if not stable and converged:
        message += "; the equilibrium is not stable (Hessian not positive definite)"
    depth = 0.0
    if chain.contacts:
        depth = max(0.0, *(float(d.max()) for d, _ in
                           penetrations(x, chain.contacts, chain.contact_radius)))
    return Equilibrium(
        shape=x,
        forces=shape_forces(chain, x),
        energy=float(history[-1]),
        clip_wrenches=clip_reactions(x, g, clips, held),
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
