"""Simulating the identification experiment at one Young's modulus (thesis 6.1, Fig. 6.2).

Three simulators give the final shape xi_sim,f that is compared with the measurement:

* ``"branch"`` (default): only the final equilibrium, held by the final clip poses and
  started from a guess close to the measured shape (:func:`final_equilibrium`). A
  clamped-clamped cable has several equilibria (sagging, arching, S-shaped); the guess keeps
  the simulated shape on the measured shape's branch at every E, so the cost is a smooth
  function of E. (Simulating the whole manipulation instead makes the outcome jump between
  branches as E changes: several basins, and a search that can settle in the wrong one.)
* ``"static"``: the quasi-static continuation of :mod:`dloplan.sim.statics` along the clip
  poses (:func:`run_manipulation`), each equilibrium warm-started from the previous one (the
  cable follows the robot's slow motion, so a path-dependent outcome follows the path).
  Optionally each step is warm-started instead from the same step of a previous run at a
  nearby modulus, which saves Newton iterations inside a search over E. It checks that the
  manipulation really ends on the measured branch.
* ``"dynamic"``: the thesis' explicit time stepping (:func:`dloplan.sim.dynamics.simulate`),
  the clips driven along the poses at a fixed pace and the cable then left to settle; its time
  step may come from a capped, fictitious modulus (thesis Fig. 6.5). Much slower; see
  ``docs/identification.md``.

All return the sensitivity d xi_sim,f / d ln E of the final shape, from the implicit function
theorem at the final equilibrium: with U = E Phi_b(x) + U_a(x) + U_g(x) (the bending energy
proportional to E; the axial energy U_a too when the cable has no axial modulus of its own;
gravity independent of E) and grad U = 0 at the free points,

    H  dx/d(ln E) = -E grad Phi_b = F_b   (+ F_a when E_a = E),

one sparse solve with the Hessian H of the free points and the bending (and axial) forces F:
the Jacobian of the fit costs no extra simulation. (The derivative of the quasi-static path's
end point equals that of the final equilibrium, since the final clip poses do not depend on E
and the branch does not change under a small change of E.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

from ..cable import GRAVITY, Cable
from ..physics.chain import SpringChain, forces, hessian
from ..sim.statics import continuation, equilibrium
from .experiment import Manipulation

SIMULATORS = ("branch", "static", "dynamic")


@dataclass(frozen=True)
class DynamicSettings:
    """How the dynamic simulator runs the manipulation (thesis chapter 6, Fig. 6.5).

    Parameters
    ----------
    step_duration : float
        Time to move between consecutive clip poses [s].
    max_settle : float
        Longest time the cable is left to settle after the last pose [s].
    rest_speed : float
        The cable is at rest when every point is slower than this [m/s].
    youngs_modulus_cap : float, optional
        The fictitious modulus E_discretization [Pa] of Fig. 6.5: the time step is computed
        from min(E, cap). It shortens stiff runs, but the explicit scheme is only stable while
        E / cap stays below roughly 1 / (l [m]) (about 30 for l = 3 cm): a larger ratio
        diverges, and is reported as a failed simulation. Axial springs with a modulus of their
        own (the composite cables' copper) keep their own step (:meth:`Cable.time_step`).
    """

    step_duration: float = 0.5
    max_settle: float = 60.0
    rest_speed: float = 1e-4
    youngs_modulus_cap: float | None = None

    def __post_init__(self) -> None:
        for name in ("step_duration", "max_settle", "rest_speed"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"dynamic.{name}: got {value!r}, expected a value > 0")
        cap = self.youngs_modulus_cap
        if cap is not None and not (math.isfinite(cap) and cap > 0):
            raise ValueError(f"dynamic.youngs_modulus_cap: got {cap!r}, expected a modulus > 0")


@dataclass(frozen=True, eq=False)
class ManipulationRun:
    """One simulated identification manipulation at one modulus.

    Attributes
    ----------
    youngs_modulus : float
        E [Pa].
    shapes : numpy.ndarray
        (K, n + 1, 3) equilibria at the K clip poses [m] (static), or (1, n + 1, 3) the settled
        final shape (dynamic).
    sensitivity : numpy.ndarray
        (n + 1, 3) d xi_sim,f / d ln E [m] (zero at the held points).
    success : bool
        Every equilibrium converged and is stable (static), or the cable came to rest
        (dynamic), and the sensitivity is finite.
    message : str
        What happened (the first failure, if any).
    solver_iterations : int
        Newton iterations (static) or time steps (dynamic) spent.
    """

    youngs_modulus: float
    shapes: np.ndarray
    sensitivity: np.ndarray
    success: bool
    message: str
    solver_iterations: int

    @property
    def final(self) -> np.ndarray:
        """The final shape xi_sim,f [m], (n + 1, 3)."""
        return self.shapes[-1]


RTOL = 1e-10
"""Relative force tolerance of the equilibria (as :func:`dloplan.sim.statics.equilibrium`)."""


def free_slice(cable: Cable, held: str) -> slice:
    """The points not held by the clips: 2 .. n-2 (both clips) or 2 .. n (first clip only)."""
    return slice(2, cable.n_points - 2 if held == "both" else cable.n_points)


def modulus_sensitivity(cable: Cable, shape: np.ndarray, held: str = "both",
                        gravity=GRAVITY) -> np.ndarray:
    """d x / d ln E of an equilibrium, H^-1 F_b (+ F_a) on the free points (module docstring).

    Parameters
    ----------
    cable : Cable
        The cable at the modulus of the equilibrium; with an ``axial_modulus`` of its own only
        the bending springs scale with E.
    shape : numpy.ndarray
        (n + 1, 3) equilibrium [m].
    held : {"both", "first"}
        Which clips hold the cable.
    gravity : array_like
        Gravity [m/s^2].

    Returns
    -------
    numpy.ndarray
        (n + 1, 3) [m]; NaN where the Hessian is singular.
    """
    chain = SpringChain.from_cable(cable, gravity)
    free = free_slice(cable, held)
    coords = np.arange(3 * free.start, 3 * free.stop)
    h = hessian(chain, shape).tocsc()[coords][:, coords]
    parts = forces(chain, shape)
    scaled = parts.bending if cable.axial_modulus is not None else parts.bending + parts.axial
    out = np.zeros_like(shape)
    with np.errstate(all="ignore"):
        out[free] = np.asarray(spla.spsolve(h, scaled[free].ravel())).reshape(-1, 3)
    return out


def final_equilibrium(cable: Cable, manipulation: Manipulation, guess: np.ndarray
                      ) -> ManipulationRun:
    """The equilibrium held by the final clip poses nearest downhill from ``guess``.

    The ``"branch"`` simulator (module docstring): with a guess on the measured shape's branch
    (the measurement itself, or the equilibrium at a nearby E) the result stays on it.

    Parameters
    ----------
    cable : Cable
        The cable, with the modulus to simulate.
    manipulation : Manipulation
        Its final clip poses, held mode and gravity are used.
    guess : numpy.ndarray
        (n + 1, 3) starting shape [m].
    """
    result = equilibrium(cable, guess, manipulation.final_clips, gravity=manipulation.gravity,
                         held=manipulation.held,
                         rtol=None)
    return _finish(cable, manipulation, result.shape[None], result.success,
                   "" if result.success else f"final equilibrium failed: {result.message}",
                   result.iterations)


def run_manipulation(
    cable: Cable,
    manipulation: Manipulation,
    initial: np.ndarray,
    *,
    simulator: str = "static",
    warm_start: np.ndarray | None = None,
    dynamic: DynamicSettings | None = None,
) -> ManipulationRun:
    """Simulate the experiment's manipulation with ``cable`` (at its modulus).

    Parameters
    ----------
    cable : Cable
        The cable, with the modulus to simulate.
    manipulation : Manipulation
        Clip trajectory, held mode and gravity.
    initial : numpy.ndarray
        (n + 1, 3) initial shape [m] (see :func:`~dloplan.identify.manipulation.prepare_shapes`).
    simulator : {"static", "dynamic"}
        Quasi-static continuation or the thesis' time stepping.
    warm_start : numpy.ndarray, optional
        (K, n + 1, 3) equilibria of a run at a nearby modulus: step k starts from its shape k
        (static only).
    dynamic : DynamicSettings, optional
        Settings of the dynamic simulator.
    """
    if simulator == "dynamic":
        return _run_dynamic(cable, manipulation, initial, dynamic or DynamicSettings())
    gravity = manipulation.gravity
    rtol = None  # the static solvers' default: RTOL, or the round-off floor
    if warm_start is None:
        results = continuation(cable, initial, manipulation.clips, gravity=gravity,
                               held=manipulation.held, rtol=rtol)
    else:
        chain = SpringChain.from_cable(cable, gravity)
        results = [equilibrium(cable, guess, clips, gravity=gravity, chain=chain,
                               held=manipulation.held, rtol=rtol)
                   for guess, clips in zip(warm_start, manipulation.clips, strict=True)]
    shapes = np.stack([r.shape for r in results])
    failed = [(k, r) for k, r in enumerate(results) if not r.success]
    message = "" if not failed else (
        f"equilibrium {failed[0][0] + 1} of {len(results)} failed: {failed[0][1].message}")
    return _finish(cable, manipulation, shapes, not failed, message,
                   sum(r.iterations for r in results))


def _run_dynamic(cable: Cable, manipulation: Manipulation, initial: np.ndarray,
                 settings: DynamicSettings) -> ManipulationRun:
    from ..sim.dynamics import ClipTrajectory, simulate

    if manipulation.held != "both":
        raise ValueError("simulator: 'dynamic' supports held='both' only (the thesis' setup)")
    times = settings.step_duration * np.arange(len(manipulation.clips))
    trajectory = ClipTrajectory(times, list(manipulation.clips))
    try:
        with np.errstate(over="ignore", invalid="ignore"):  # a divergence is reported below
            run = simulate(cable, initial, trajectory,
                           duration=times[-1] + settings.max_settle,
                           youngs_modulus_cap=settings.youngs_modulus_cap,
                           gravity=manipulation.gravity, rest_speed=settings.rest_speed,
                           max_steps=50_000_000)
    except FloatingPointError as exc:
        nan = np.full((1, cable.n_points, 3), np.nan)
        return ManipulationRun(cable.youngs_modulus, nan, nan[0], False, str(exc), 0)
    message = "" if run.settled else (
        f"the cable did not come to rest within {settings.max_settle} s ({run.message})")
    return _finish(cable, manipulation, run.shapes[-1:], run.settled, message, run.steps)


def _finish(cable, manipulation, shapes, success, message, iterations) -> ManipulationRun:
    sensitivity = modulus_sensitivity(cable, shapes[-1], manipulation.held, manipulation.gravity)
    if success and not np.all(np.isfinite(sensitivity)):
        success, message = False, "the final equilibrium's Hessian is singular"
    return ManipulationRun(cable.youngs_modulus, shapes, sensitivity, bool(success),
                           message or "ok", int(iterations))
