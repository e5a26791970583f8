"""The physical planning stage (thesis 4.5): each shape moved to a low-force, minimal-energy shape.

Every shape is processed on its own (decoupled, thesis Fig. 4.15): the target first (the
pre-processing of 4.5.1, with a warning when it moves too much), then the S intermediate shapes
of the geometric path. The results do not depend on the order, so any ``map`` (a process pool's,
a Dask client's) may run them in parallel.

**Held points.** In both modes the four points held by the clips -- points 0, 1 (first clip)
and n-1, n (last clip), :data:`dloplan.sim.clips.HELD_INDICES` -- stay where the geometric stage
put the clips; only points 2 .. n-2 move. Before the stage each held link is set to its rest
length l about its clip point along its own direction (the clip pose is kept exactly). Why:

* the clip poses are the robot's path. The geometric stages made them short and smooth over the
  whole path; minimizing each shape on its own with free ends would move every gripper
  independently of its neighbours and lose that smoothness;
* a shape is the cable's response to its grippers: with the clips held the physical stage
  answers the question the robot asks, and the "equilibrium" mode is exactly the static solve
  the later stabilization stage runs (there with gravity);
* with free ends |F_b|^2 + |F_s|^2 has the trivial minimum "straight and unstretched" anywhere.

**The two modes.**

``"equilibrium"`` (the default): the exact minimal-energy shape of the weightless cable for the
shape's own clip poses, :func:`dloplan.sim.statics.equilibrium` with gravity (0, 0, 0), started
from the geometric shape (which selects the equilibrium branch). At the result the net force on
every free point is zero to the solver tolerance, so the axial forces are only what the clips
impose and the link lengths are uniform. It has no weights to tune (no stiffness family), does
not depend on units, and is what the thesis' cost approximates ("minimal energy curves").

``"thesis"``: eq. 4.19, min w_sigma |sigma|^2 + w_b |F_b|^2 + w_s |F_s|^2 with sigma = xi_geom -
xi_min (eq. 4.20) and the bending and axial forces of eqs. 3.17/3.18 on **all n + 1 points**
(eqs. 4.21/4.22 list F_1 .. F_n+1; the forces at the held points are the loads the cable puts
on the clips, which a lower-stress path should also reduce). Made dimensionless the same way as
the geometric costs: sigma over the rest link length l, forces over the cable's weight
F_ref = m |g| (an E-independent force, so that the stiffness families of Table 6.2 compensate
the modulus as the thesis intends), each sum divided by (n + 1) / (n0 + 1) so that at n0 = 10
the sums are the thesis' own. It is a nonlinear least-squares problem whose Jacobian is exact
and sparse (dF/dx = -H, the per-term Hessians of :func:`dloplan.physics.hessian`); it is solved
by Levenberg-Marquardt steps on the banded normal equations (cost linear in n). With stiff
axial springs (:attr:`dloplan.cable.Cable.stiff_axial`: the composite cables' copper) a trial
step's link lengths are restored to what its linearization promised
(:func:`dloplan.sim.compiled.restore_link_lengths`, as in the static solver): the stiff axial
term's curved valley otherwise holds the steps to a fraction of a millimetre (more than 200
iterations instead of 16-42 on the folding case's Ethernet).

Its result is a compromise, not an equilibrium: the cable, released, would still move. That is
why "equilibrium" is the default; "thesis" reproduces the thesis' numbers and keeps shapes
closest to the geometric path (w_sigma).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..cable import GRAVITY, Cable
from ..least_squares import Damping, damped_minimize
from ..physics.chain import SpringChain, hessian, sparse_to_band
from ..physics.chain import forces as chain_forces
from ..sim.clips import held_links_conformed
from ..sim.compiled import restore_link_lengths
from ..sim.newton import factor_band, solve_band
from .geometric import REFERENCE_LINKS
from .tuning import PhysicalWeights

PHYSICAL_MODES: tuple[str, ...] = ("equilibrium", "thesis")
WEIGHTLESS = np.zeros(3)


def reference_force(cable: Cable, gravity=GRAVITY) -> float:
    """F_ref = m |g| [N]: the cable's weight, the force unit of the thesis-mode cost."""
    g = float(np.linalg.norm(np.asarray(gravity, dtype=float)))
    if not math.isfinite(g) or g <= 0.0:
        raise ValueError(f"gravity: got {gravity!r}, expected a non-zero acceleration [m/s^2]")
    return cable.mass * g


@dataclass(frozen=True, eq=False)
class ShapeResult:
    """One physically minimized shape.

    Attributes
    ----------
    shape : numpy.ndarray
        (n + 1, 3) result [m].
    success : bool
        The solver converged (and, in "equilibrium" mode, the equilibrium is stable).
    message : str
        The solver's message.
    iterations : int
        Iterations.
    displacement : float
        Largest distance of a point from the given shape, over L [-].
    """

    shape: np.ndarray
    success: bool
    message: str
    iterations: int
    displacement: float


@dataclass(frozen=True, eq=False)
class ThesisCost:
    """The dimensionless thesis-mode cost (eq. 4.19) of one shape, as least-squares residuals.

    Parameters
    ----------
    chain : SpringChain
        The weightless chain of the cable.
    geometric : numpy.ndarray
        (n + 1, 3) the geometric shape xi_geom [m] (held points already placed).
    weights : PhysicalWeights
        w_sigma, w_b, w_s.
    link_length : float
        l [m], the unit of sigma.
    force : float
        F_ref [N], the unit of the forces.
    """

    chain: SpringChain
    geometric: np.ndarray
    weights: PhysicalWeights
    link_length: float
    force: float

    @property
    def _scales(self) -> tuple[float, float, float]:
        share = (REFERENCE_LINKS + 1) / self.chain.n_points
        w = self.weights
        return (math.sqrt(w.sigma * share) / self.link_length,
                math.sqrt(w.bending * share) / self.force,
                math.sqrt(w.axial * share) / self.force)

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """r(x), (3, n + 1, 3): scaled sigma, F_b and F_s; the cost is sum r^2."""
        a_sigma, a_b, a_s = self._scales
        f = chain_forces(self.chain, x)
        return np.stack([a_sigma * (x - self.geometric), a_b * f.bending, a_s * f.axial])

    def value(self, x: np.ndarray) -> float:
        """The cost w_sigma |sigma/l|^2 + w_b |F_b/F_ref|^2 + w_s |F_s/F_ref|^2 (n-normalized)."""
        return float(np.sum(self.residuals(x) ** 2))

    def jacobian(self, x: np.ndarray) -> sp.csr_matrix:
        """dr/dx, (9(n + 1), 3(n + 1)), exact: d sigma/dx = I, dF/dx = -H (per term)."""
        a_sigma, a_b, a_s = self._scales
        n_dof = x.size
        return sp.vstack([
            a_sigma * sp.identity(n_dof, format="csr"),
            -a_b * hessian(self.chain, x, terms=("bending",)),
            -a_s * hessian(self.chain, x, terms=("axial",)),
        ]).tocsr()

    def gradient(self, x: np.ndarray) -> np.ndarray:
        """d cost / dx = 2 J^T r (so 2 H F for each force term), (n + 1, 3)."""
        return (2.0 * (self.jacobian(x).T @ self.residuals(x).ravel())).reshape(x.shape)


THESIS_DAMPING = Damping(initial=1e-3, start=1e-12, increase=8.0, decrease=5.0,
                         minimum=1e-12, good=0.0, poor=0.0, maximum=1e12)
"""The thesis-mode least squares' damping (:class:`dloplan.least_squares.Damping`): mu diag(J^T J)
from 1e-3, five times smaller after an accepted step (down to 1e-12), eight times larger after
a rejected one; beyond 1e12 the fit has stalled."""


@dataclass(frozen=True, eq=False)
class _NormalBand:
    """One iteration's banded normal equations J^T J p = -J^T r over the free points."""

    band: np.ndarray
    scale: np.ndarray
    grad: np.ndarray

    def solve(self, shift: float):
        shifted = self.band.copy()
        shifted[0] += shift * self.scale
        factor = factor_band(shifted)  # None: not positive definite, damp more
        return None if factor is None else solve_band(factor, -self.grad)

    def predicted(self, step, shift: float) -> None:
        return None


def _minimize_thesis(cost: ThesisCost, x: np.ndarray, free: slice, *, gtol: float = 1e-9,
                     max_iterations: int = 200) -> tuple[np.ndarray, bool, str, int]:
    """Levenberg-Marquardt on the banded normal equations over the free points (the shared
    loop :func:`dloplan.least_squares.damped_minimize`)."""
    cols = np.arange(3 * free.start, 3 * free.stop)

    def linearize(state):
        x, r = state
        jac = cost.jacobian(x)[:, cols]
        grad = jac.T @ r
        normal = (jac.T @ jac).tocsr()
        # gradient with respect to x / l: the test does not depend on the length unit
        if float(np.max(np.abs(grad))) * cost.link_length <= gtol * max(1.0, float(r @ r)):
            return None
        return _NormalBand(sparse_to_band(normal, 17), normal.diagonal(), grad)

    def evaluate(state, step, system):
        trial = state[0].copy()
        trial[free] += step.reshape(-1, 3)
        if cost.chain.stiff_axial:  # the links' lengths the step's linearization promised
            restore_link_lengths(state[0], trial, free.start, free.stop)
        r_trial = cost.residuals(trial).ravel()
        return (trial, r_trial), float(r_trial @ r_trial)

    r = cost.residuals(x).ravel()
    run = damped_minimize((x, r), float(r @ r), linearize, evaluate, THESIS_DAMPING,
                          max_iterations=max_iterations, stop_gain=1e-13)
    return run.state[0], run.success, run.message, run.iterations


def held_conformed(shape: np.ndarray, cable: Cable) -> np.ndarray:
    """The shape with each held link set to its rest length l about its clip point
    (:func:`dloplan.sim.clips.held_links_conformed`)."""
    return held_links_conformed(shape, cable.rest_link_length)


def minimize_shape(cable: Cable, shape: np.ndarray, *, mode: str = "equilibrium",
                   weights: PhysicalWeights | None = None, force: float | None = None,
                   chain: SpringChain | None = None) -> ShapeResult:
    """Physically minimize one shape with its clips held (thesis 4.5.2-4.5.3).

    Parameters
    ----------
    cable : Cable
        The cable (n links).
    shape : numpy.ndarray
        (n + 1, 3) geometric shape [m].
    mode : {"equilibrium", "thesis"}
        See the module docstring.
    weights : PhysicalWeights, optional
        Thesis-mode weights (Table 6.2); default: the medium family.
    force : float, optional
        F_ref [N] of the thesis-mode cost; default :func:`reference_force` of the cable.
    chain : SpringChain, optional
        The cable's weightless chain (built if not given).
    """
    from ..sim.statics import equilibrium

    if mode not in PHYSICAL_MODES:
        raise ValueError(f"mode: got {mode!r}, expected one of {', '.join(PHYSICAL_MODES)}")
    chain = chain or SpringChain.from_cable(cable, WEIGHTLESS)
    if mode == "equilibrium":
        try:
            eq = equilibrium(cable, shape, gravity=WEIGHTLESS, chain=chain)
        except ValueError as exc:  # clips out of reach: the geometric shape is over-stretched
            return ShapeResult(shape.copy(), False, str(exc), 0, 0.0)
        x, ok, message, iterations = eq.shape, eq.success, eq.message, eq.iterations
    else:
        geometric = held_conformed(shape, cable)
        cost = ThesisCost(chain, geometric, weights or PhysicalWeights(),
                          cable.rest_link_length, force or reference_force(cable))
        x, ok, message, iterations = _minimize_thesis(cost, geometric.copy(),
                                                      slice(2, cable.n_points - 2))
    moved = float(np.max(np.linalg.norm(x - shape, axis=1))) / cable.length
    return ShapeResult(x, bool(ok), message, int(iterations), moved)


def physical_stage(cable: Cable, shapes: Sequence[np.ndarray] | np.ndarray, *,
                   mode: str = "equilibrium", weights: PhysicalWeights | None = None,
                   force: float | None = None, map: Callable = map) -> list[ShapeResult]:
    """Minimize every shape on its own (decoupled, thesis Fig. 4.15).

    Parameters
    ----------
    cable : Cable
        The cable.
    shapes : array_like
        (k, n + 1, 3) shapes [m], e.g. the intermediate shapes of the advanced path.
    mode, weights, force
        As in :func:`minimize_shape`.
    map : callable
        ``map(function, iterable)`` returning results in input order: the builtin (serial),
        ``ProcessPoolExecutor().map`` or a Dask client's map to run shapes in parallel.

    Returns
    -------
    list of ShapeResult
        One per shape, in input order.
    """
    chain = SpringChain.from_cable(cable, WEIGHTLESS)

    def one(shape):
        return minimize_shape(cable, shape, mode=mode, weights=weights, force=force, chain=chain)

    return list(map(one, list(np.asarray(shapes, dtype=float))))


@dataclass(frozen=True, eq=False)
class TargetResult:
    """The pre-processed target (thesis 4.5.1).

    Attributes
    ----------
    shape : numpy.ndarray
        (n + 1, 3) minimized target [m].
    result : ShapeResult
        The minimization.
    displacement : float
        Largest point displacement over L [-].
    tolerance : float
        The threshold over L [-].
    warning : str or None
        Set when the displacement exceeds the tolerance or the minimization failed.
    """

    shape: np.ndarray
    result: ShapeResult
    displacement: float
    tolerance: float
    warning: str | None


def preprocess_target(cable: Cable, target: np.ndarray, *, mode: str = "equilibrium",
                      weights: PhysicalWeights | None = None, force: float | None = None,
                      tolerance: float = 0.02) -> TargetResult:
    """Minimize the proposed target and warn if it moves more than ``tolerance`` L (4.5.1).

    Parameters
    ----------
    cable : Cable
        The cable.
    target : numpy.ndarray
        (n + 1, 3) proposed target [m].
    mode, weights, force
        As in :func:`minimize_shape`.
    tolerance : float
        Largest accepted point displacement, as a fraction of L (default 0.02: 1 cm on a
        0.5 m cable).
    """
    if not (math.isfinite(tolerance) and tolerance > 0.0):
        raise ValueError(f"target_tolerance: got {tolerance!r}, expected a fraction of L > 0")
    res = minimize_shape(cable, target, mode=mode, weights=weights, force=force)
    warning = None
    moved = np.linalg.norm(res.shape - target, axis=1) / cable.length
    worst = float(moved.max())
    if not res.success:
        warning = f"target: the physical minimization failed ({res.message})"
    elif worst > tolerance:
        warning = (
            f"target: far from a minimal-energy shape, point {int(moved.argmax())} moves "
            f"{100 * worst:.1f} % of L ({worst * cable.length:.4g} m) when minimized "
            f"(tolerance {100 * tolerance:g} % of L); the minimized target is planned instead"
        )
    return TargetResult(res.shape, res, worst, float(tolerance), warning)
