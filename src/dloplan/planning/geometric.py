"""The two geometric planning stages (thesis 4.3 and 4.4).

A path is an array (S + 2, n + 1, 3): the start shape xi_o, S intermediate shapes (the decision
variables, eq. 4.11) and the target xi_f.

**Basic stage** (eqs. 4.12-4.15): the cost sum_k w_k |gamma_k|^2 over the S + 1 steps
gamma_k = xi_k - xi_{k-1} (the last one is gamma_f, weight w_f) is a quadratic whose Hessian is
block-tridiagonal in the shape index and the same for every coordinate. Its stationarity
condition (w_i + w_{i+1}) xi_i - w_i xi_{i-1} - w_{i+1} xi_{i+1} = 0 is one S x S tridiagonal
system with 3(n + 1) right-hand sides, solved exactly by :func:`scipy.linalg.solve_banded`. With
equal weights every point moves in S + 1 equal steps on the straight line to its target.

**Advanced stage** (eq. 4.17): five terms (transversal steps, the final step, the link-length
change delta against the start's links, 1/Delta_clip between the clip points, the bending angles
against those of the basic path), minimized from the basic path with the exact gradient and
Hessian (damped Newton, its systems solved on the shape x point grid by
:mod:`dloplan.planning.grid_newton`; scipy's L-BFGS-B on request), vectorized over all shapes
and points.

**Dimensionless scaling.** The thesis writes eq. 4.17 in metres, which makes its weights depend
on the unit: the quadratic terms scale with the unit squared, 1/Delta_clip with its inverse and
the angles not at all, so the same weights give other paths in millimetres. Here every quantity
is measured in the unit it naturally has -- positions over the cable length L, link-length
changes over the rest link length l (strains), the clip distance as L / Delta_clip, angles in
radians -- and each term is normalized so that it does not depend on n and S either
(Y = x / L, l = L / n):

====================  ==============================================  =====================
term                  dimensionless measure (-> continuum limit)      factor c
====================  ==============================================  =====================
transversal steps     T = (S+1)/(n+1) sum_k w_k |Delta Y_k|^2          c_T = (n0+1)/(S0+1)
                      (-> mean over points of int |dY/dtau|^2)
link-length change    D = 1/(n S) sum_i sum_j (delta_ij / l)^2         c_D = n0 S0
                      (mean squared strain)
clip distance         C = 1/S sum_i L / Delta_clip,i                  c_C = S0
bending angles        B = n/S sum_i sum_j (beta_ij - beta_o,ij)^2      c_B = S0 / n0
                      (-> mean over shapes of L int (kappa - kappa_o)^2 ds)
====================  ==============================================  =====================

and J = c_T T + w_delta c_D D + w_clip c_C C + w_beta c_B B. The factors c make J equal, term by
term, to the thesis' sums of eq. 4.17 on the problem it tuned its weights on (n0 = 10 links,
S0 = 5 shapes) with the quantities in the units above. So the Table 6.1 weights keep their
meaning, for any unit, cable length, n and S, and they reproduce the thesis' behaviour (Table
4.2: shapes kept near L on a folding path). Measured in metres instead (the thesis' literal
form) the angle term outweighs the length terms about 400 to 1 for a 0.5 m cable and the
advanced stage keeps folding paths at about 0.7 L; in millimetres the angle and clip terms
vanish: neither is what the thesis' tuning describes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.linalg import solve_banded
from scipy.sparse.linalg import splu

from ..geometry import bending_angles, link_lengths
from ..least_squares import Damping
from ..physics.axial import axial_energy, axial_gradient
from ..physics.bending import bending_energy, bending_gradient
from .grid_newton import (
    GridNewton,
    grid_layout,
    hessian_entries,
    plane_of,
    shape_bands,
    shape_costs,
)
from .tuning import AdvancedWeights, BasicWeights

REFERENCE_LINKS = 10
"""n0: the number of links of the thesis' tuning problem (Figs. 4.8, 4.14)."""
REFERENCE_SHAPES = 5
"""S0: the number of intermediate shapes of the thesis' tuning problem."""

C_TRANSVERSAL = (REFERENCE_LINKS + 1) / (REFERENCE_SHAPES + 1)
C_DELTA = REFERENCE_LINKS * REFERENCE_SHAPES
C_CLIP = REFERENCE_SHAPES
C_BETA = REFERENCE_SHAPES / REFERENCE_LINKS


def step_weights(weights: BasicWeights | AdvancedWeights, n_shapes: int) -> np.ndarray:
    """The S + 1 step weights (w_1 .. w_S, w_f) of the transversal terms."""
    steps = np.atleast_1d(np.asarray(weights.steps, dtype=float))
    if steps.size == 1:
        steps = np.full(n_shapes, steps[0])
    if steps.size != n_shapes:
        raise ValueError(
            f"weights.steps: {steps.size} values given, expected 1 or n_shapes = {n_shapes}"
        )
    return np.append(steps, weights.final)


def transversal_cost(path: np.ndarray, weights: np.ndarray) -> tuple[float, np.ndarray]:
    """sum_k w_k |xi_k - xi_{k-1}|^2 (eq. 4.15) and its gradient over the intermediate shapes.

    Parameters
    ----------
    path : numpy.ndarray
        (S + 2, n + 1, 3) shapes, start and target included.
    weights : numpy.ndarray
        (S + 1,) step weights w_1 .. w_S, w_f.

    Returns
    -------
    tuple
        The cost [length^2] and its gradient (S, n + 1, 3) [length].
    """
    steps = np.diff(path, axis=0)
    weighted = weights[:, None, None] * steps
    value = float(np.sum(weighted * steps))
    return value, 2.0 * (weighted[:-1] - weighted[1:])


def basic_path(start: np.ndarray, target: np.ndarray, n_shapes: int,
               weights: BasicWeights | None = None) -> np.ndarray:
    """The basic geometric path: the exact minimizer of eq. 4.15 (thesis 4.3).

    Parameters
    ----------
    start, target : numpy.ndarray
        (n + 1, 3) shapes xi_o and xi_f [m].
    n_shapes : int
        S >= 1 intermediate shapes.
    weights : BasicWeights, optional
        w_i (one or S values) and w_f; default all 1 (Table 6.1).

    Returns
    -------
    numpy.ndarray
        (S + 2, n + 1, 3) path [m].
    """
    w = step_weights(weights or BasicWeights(), n_shapes)
    # rows i = 1..S: -w_i xi_{i-1} + (w_i + w_{i+1}) xi_i - w_{i+1} xi_{i+1} = 0
    banded = np.zeros((3, n_shapes))
    banded[0, 1:] = -w[1:-1]  # super-diagonal: -w_{i+1}
    banded[1] = w[:-1] + w[1:]
    banded[2, :-1] = -w[1:-1]  # sub-diagonal: -w_i
    rhs = np.zeros((n_shapes, start.size))
    rhs[0] += w[0] * start.ravel()
    rhs[-1] += w[-1] * target.ravel()
    inner = solve_banded((1, 1), banded, rhs, check_finite=False)
    return np.concatenate([start[None], inner.reshape(n_shapes, *start.shape), target[None]])


@dataclass(frozen=True, eq=False)
class AdvancedProblem:
    """The data of the advanced cost (eq. 4.17), in dimensionless positions Y = x / L.

    Parameters
    ----------
    start, target : numpy.ndarray
        (n + 1, 3) fixed end shapes / L.
    start_links : numpy.ndarray
        (n,) link lengths of the start shape / L (the "length_o" of the thesis).
    basic_angles : numpy.ndarray
        (S, n - 1) bending angles beta_o of the basic path's intermediate shapes [rad].
    step_weights : numpy.ndarray
        (S + 1,) w_i,a .. w_f,a.
    weights : AdvancedWeights
        The other weights.
    """

    start: np.ndarray
    target: np.ndarray
    start_links: np.ndarray
    basic_angles: np.ndarray
    step_weights: np.ndarray
    weights: AdvancedWeights

    @property
    def n_links(self) -> int:
        return self.start.shape[0] - 1

    @property
    def n_shapes(self) -> int:
        return self.basic_angles.shape[0]


def advanced_terms(
    problem: AdvancedProblem, inner: np.ndarray
) -> dict[str, tuple[float, np.ndarray]]:
    """The four weighted, dimensionless terms of eq. 4.17 and their gradients.

    Parameters
    ----------
    problem : AdvancedProblem
        The fixed data.
    inner : numpy.ndarray
        (S, n + 1, 3) intermediate shapes / L.

    Returns
    -------
    dict
        ``{"transversal", "delta", "clip", "beta"}`` -> (value, gradient (S, n + 1, 3)); the
        transversal term holds both the step and the final-step terms.
    """
    n, s = problem.n_links, problem.n_shapes
    w = problem.weights
    path = np.concatenate([problem.start[None], inner, problem.target[None]])
    t_value, t_grad = transversal_cost(path, problem.step_weights)
    c_t = C_TRANSVERSAL * (s + 1) / (n + 1)

    c_d = w.delta * C_DELTA * n / s  # (delta / l)^2 = n^2 (delta / L)^2, averaged over n S
    d_value = axial_energy(inner, 2.0, problem.start_links)  # sum (l - l_o)^2
    d_grad = axial_gradient(inner, 2.0, problem.start_links)

    c_c = w.clip * C_CLIP / s
    chord = 0.5 * (inner[:, -1] + inner[:, -2] - inner[:, 0] - inner[:, 1])
    distance = np.linalg.norm(chord, axis=-1)
    pull = chord / distance[:, None] ** 3  # d(1/Delta)/d(first clip point)
    c_grad = np.zeros_like(inner)
    c_grad[:, :2] += 0.5 * pull[:, None]
    c_grad[:, -2:] -= 0.5 * pull[:, None]

    c_b = w.beta * C_BETA * n / s
    b_value = 2.0 * bending_energy(inner, 1.0, problem.basic_angles)  # sum (beta - beta_o)^2
    b_grad = 2.0 * bending_gradient(inner, 1.0, problem.basic_angles)
    return {
        "transversal": (c_t * t_value, c_t * t_grad),
        "delta": (c_d * float(np.sum(d_value)), c_d * d_grad),
        "clip": (c_c * float(np.sum(1.0 / distance)), c_c * c_grad),
        "beta": (c_b * float(np.sum(b_value)), c_b * b_grad),
    }


def advanced_cost(problem: AdvancedProblem, inner: np.ndarray) -> tuple[float, np.ndarray]:
    """The dimensionless advanced cost J (eq. 4.17, scaled) and its gradient (S, n + 1, 3).

    The sum of :func:`advanced_terms` (the readable reference, equal to round-off, tested),
    with the link-length and angle terms in one compiled pass per shape
    (:func:`dloplan.planning.grid_newton.shape_costs`, the static core's kernel as for the
    Hessian in :func:`hessian_values`).
    """
    n, s = problem.n_links, problem.n_shapes
    w = problem.weights
    path = np.concatenate([problem.start[None], inner, problem.target[None]])
    t_value, t_grad = transversal_cost(path, problem.step_weights)
    c_t = C_TRANSVERSAL * (s + 1) / (n + 1)
    c_d = w.delta * C_DELTA * n / s  # times sum (l - l_o)^2: k_s = 2 c_d
    c_b = 2.0 * w.beta * C_BETA * n / s  # times 1/2 sum (beta - beta_o)^2: k_b = c_b
    value, grad = shape_costs(np.ascontiguousarray(inner), 2.0 * c_d, problem.start_links, c_b,
                              problem.basic_angles)
    c_c = w.clip * C_CLIP / s
    chord = 0.5 * (inner[:, -1] + inner[:, -2] - inner[:, 0] - inner[:, 1])
    distance = np.sqrt(np.einsum("ij,ij->i", chord, chord))
    pull = (0.5 * c_c) * chord / distance[:, None] ** 3  # c_c d(1/Delta)/d(first clip point) / 2
    grad += c_t * t_grad
    grad[:, :2] += pull[:, None]
    grad[:, -2:] -= pull[:, None]
    return c_t * t_value + value + c_c * float(np.sum(1.0 / distance)), grad


def hessian_values(problem: AdvancedProblem, inner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The entries of the exact Hessian of :func:`advanced_cost`, by term.

    Returns
    -------
    tuple
        The within-shape entries, ``np.concatenate([bands.ravel(), clip.ravel()])`` (see
        :func:`dloplan.planning.grid_newton.hessian_entries`): each shape's lower band of the
        link-length and angle terms (S, 9, 3(n + 1)), by the static core's compiled kernel
        (the same formulas as the numpy reference of :mod:`dloplan.physics`), and the clip
        term's blocks (S, 12, 12); then the (S + 1,) factors a_k of the transversal term,
        whose Hessian is A (x) I with A tridiagonal: A_ii = a_i + a_{i+1}, A_i,i+1 = -a_{i+1}.
    """
    n, s = problem.n_links, problem.n_shapes
    w = problem.weights
    a = 2.0 * C_TRANSVERSAL * (s + 1) / (n + 1) * problem.step_weights
    c_d = w.delta * C_DELTA * n / s  # times sum (l - l_o)^2: k_s = 2 c_d
    c_b = 2.0 * w.beta * C_BETA * n / s  # times 1/2 sum (beta - beta_o)^2: k_b = c_b
    bands = shape_bands(np.ascontiguousarray(inner), 2.0 * c_d, problem.start_links, c_b,
                        problem.basic_angles)
    # clip: 1/|d|, d = (Y_{n-1} + Y_n - Y_0 - Y_1) / 2: d2/dd2 = 3 d d^T/|d|^5 - I/|d|^3
    chord = 0.5 * (inner[:, -1] + inner[:, -2] - inner[:, 0] - inner[:, 1])
    dist = np.linalg.norm(chord, axis=-1)[:, None, None]
    h_d = (3.0 * chord[:, :, None] * chord[:, None, :] / dist**5 - np.eye(3) / dist**3)
    h_d *= w.clip * C_CLIP / s
    signs = np.array([-0.5, -0.5, 0.5, 0.5])
    h_clip = np.einsum("p,q,sij->spiqj", signs, signs, h_d)
    return np.concatenate([bands.ravel(), h_clip.ravel()]), a


def _sparse_hessian(entries: tuple[np.ndarray, np.ndarray, np.ndarray], values: np.ndarray,
                    transversal: np.ndarray, shape: tuple[int, ...]) -> sp.csr_matrix:
    """The Hessian over the flattened ``shape`` (S, n + 1, 3) from :func:`hessian_values` and
    :func:`dloplan.planning.grid_newton.hessian_entries`."""
    rows, cols, pick = entries
    size = int(np.prod(shape))
    block = size // shape[0]
    diag = np.repeat(transversal[:-1] + transversal[1:], block)
    off = np.repeat(-transversal[1:-1], block)
    within = sp.csr_matrix((values[pick], (rows, cols)), shape=(size, size))
    return (sp.diags([diag, off, off], [0, block, -block], shape=(size, size)) + within).tocsr()


def advanced_hessian(problem: AdvancedProblem, inner: np.ndarray) -> sp.csr_matrix:
    """The exact sparse Hessian of :func:`advanced_cost` over the flattened (S, n + 1, 3)."""
    values, transversal = hessian_values(problem, inner)
    return _sparse_hessian(hessian_entries(problem.n_links, problem.n_shapes), values,
                           transversal, inner.shape)


@dataclass(frozen=True)
class StageStatus:
    """How one optimization stage ended.

    Attributes
    ----------
    success : bool
        The solver met its tolerance.
    message : str
        The solver's message.
    iterations : int
        Iterations (0 for the exact basic solve).
    n_variables : int
        Number of decision variables.
    cost : float
        Final (dimensionless) cost; NaN when the stage has none.
    seconds : float
        Wall time [s].
    """

    success: bool
    message: str
    iterations: int
    n_variables: int
    cost: float
    seconds: float


def advanced_problem(basic: np.ndarray, length: float,
                     weights: AdvancedWeights | None = None) -> AdvancedProblem:
    """The advanced problem of a basic path (S + 2, n + 1, 3) [m] for a cable of length L [m]."""
    weights = weights or AdvancedWeights()
    y = basic / length
    return AdvancedProblem(
        start=y[0],
        target=y[-1],
        start_links=link_lengths(y[0]),
        basic_angles=bending_angles(y[1:-1]),
        step_weights=step_weights(weights, basic.shape[0] - 2),
        weights=weights,
    )


LINEAR_SOLVERS: tuple[str, ...] = ("gmres", "lu")
"""Newton-system solvers of the advanced stage: two-level GMRES on the grid (default, with
sparse LU where it cannot vouch for a step) or sparse LU alone (the reference)."""
FORCING = 1e-8
"""GMRES solves a Newton system to the relative residual FORCING * max |g|, between 1e-12 and
FORCING (an inexact Newton method whose steps tighten as the gradient g vanishes); a step that
would end the iteration on its Newton decrement is solved again to 1e-12. At (n, S) = (50, 50)
1e-8 saves a third of the Krylov iterations of 1e-12 throughout (1e-4: two thirds), with the
same iterations, trials and optimum (to 2e-14 L). Looser forcing changes the path where the cost
is not convex: on a 3-D turn (76 iterations through indefinite Hessians) 1e-6 and 1e-4 stopped
at other points, 1e-3 m and 3e-4 m away from the exact steps' optimum; 1e-8 reproduces it."""


SHIFT_START = 1e-4
"""The first Levenberg-Marquardt shift, relative to mean |diag H|, once a Newton direction is no
descent direction or does not lower the cost; it then grows tenfold per retry. A start at 1e-8
(the previous policy) spent 6 of the 25 systems at (n, S) = (50, 50) on shifts that cannot make
the indefinite Hessian of an early iterate positive definite (there it needs about 1e-3)."""
SHIFT_FLOOR = 1e-4
"""After an accepted step the shift falls by :data:`SHIFT_DECREASE`, and to 0 (a pure Newton step
first) once it is at most this."""
SHIFT_DECREASE = 10.0
"""The factor by which the shift falls after an accepted step."""
RATIO_GOOD = 0.9
"""An accepted step whose actual decrease is at least this fraction of the decrease its
quadratic model predicted lets the shift fall (:data:`SHIFT_DECREASE`)."""
RATIO_POOR = 0.25
"""Below this ratio an accepted step raises the shift tenfold for the next iteration; between
the two it is kept."""


PLANNER_DAMPING = Damping(start=SHIFT_START, increase=10.0, decrease=SHIFT_DECREASE,
                          reset_below=SHIFT_FLOOR, good=RATIO_GOOD, poor=RATIO_POOR)
"""The advanced stage's damping policy, in the shared form (:class:`dloplan.least_squares.
Damping`)."""


def next_shift(shift: float, ratio: float) -> float:
    """The Levenberg-Marquardt shift after a trial whose actual / predicted decrease is ``ratio``.

    A rejected trial (``ratio`` = -inf: the cost did not fall) and a poor model (``ratio`` <
    :data:`RATIO_POOR`) raise the shift tenfold, at least to :data:`SHIFT_START`; a good one
    (``ratio`` >= :data:`RATIO_GOOD`) lowers it by :data:`SHIFT_DECREASE`, to 0 from
    :data:`SHIFT_FLOOR`; in between it stays (:data:`PLANNER_DAMPING`).
    """
    return PLANNER_DAMPING.after(shift, ratio)


def _damped_newton(problem: AdvancedProblem, y: np.ndarray, gtol: float, max_iterations: int,
                   linear_solver: str = "gmres", coords: tuple[int, ...] = (0, 1, 2)
                   ) -> tuple[np.ndarray, float, bool, str, int]:
    """Levenberg-Marquardt-damped Newton steps on the exact Hessian.

    Every trial solves (H + shift * scale I) p = -g, scale = mean |diag H|; while p is not a
    descent direction or does not lower the cost the shift grows tenfold from
    :data:`SHIFT_START`; after an accepted step it follows the ratio of the actual to the
    quadratic model's predicted decrease (:func:`next_shift`, a trust-region ratio test:
    fewer systems where the model is poor far from the optimum). ``coords``: the
    coordinates that move (see :func:`dloplan.planning.grid_newton.plane_of`); the others keep
    their values (their gradient is zero).
    """
    shape = y.shape
    n, s = problem.n_links, problem.n_shapes
    entries = hessian_entries(n, s)
    diagonal_rows = entries[0][entries[0] == entries[1]]
    diagonal_pick = entries[2][entries[0] == entries[1]]
    layout = grid_layout(n, s, coords, entries) if linear_solver == "gmres" else None
    identity = sp.identity(y.size, format="csc")
    f, g = advanced_cost(problem, y)
    shift = 0.0
    for iteration in range(max_iterations + 1):
        largest = float(np.max(np.abs(g)))
        if largest <= gtol:
            return y, f, True, f"converged in {iteration} iterations", iteration
        if iteration == max_iterations:
            break
        values, a = hessian_values(problem, y)
        diagonal = np.bincount(diagonal_rows, weights=values[diagonal_pick],
                               minlength=y.size) + np.repeat(a[:-1] + a[1:], y.size // s)
        scale = float(np.mean(np.abs(diagonal)))
        system = None
        if layout is not None:
            system = GridNewton(layout, layout.band(values, a[:-1] + a[1:]), -a[1:-1])
        matrix = None
        tolerance = min(FORCING, max(1e-12, FORCING * largest))
        for _ in range(41):
            step = None
            if system is not None:
                solved = system.solve(layout.gather(-g), shift * scale, tolerance)
                step = None if solved is None else layout.scatter(solved).ravel()
            if step is None:  # sparse LU: the reference, and where GMRES cannot vouch
                if matrix is None:
                    matrix = _sparse_hessian(entries, values, a, shape).tocsc()
                try:
                    step = splu(matrix + (shift * scale) * identity,
                                permc_spec="COLAMD").solve(-g.ravel())
                except RuntimeError:  # exactly singular: damp more
                    step = None
            # g^T p by einsum: a threaded BLAS dot costs 10-20 ms on a loaded machine
            slope = np.nan if step is None else float(np.einsum("i,i->", g.ravel(), step))
            if step is None or not (np.all(np.isfinite(step)) and slope < 0.0):
                shift = PLANNER_DAMPING.raised(shift)
                continue
            decrement = -slope  # twice the predicted decrease
            # a round-off decrement ends the iteration only with a small gradient: with
            # curvatures up to 1e7 g^T H^-1 g is below 1e-12 already at |g| ~ 1e-4
            if decrement <= 1e-13 * max(1.0, abs(f)) and shift == 0.0 and largest <= 1e3 * gtol:
                if system is not None and tolerance > 1e-12:  # only an exact step can tell
                    tolerance = 1e-12
                    continue
                return y, f, True, (f"converged in {iteration} iterations (Newton decrement "
                                    f"{decrement:.2g} at round-off)"), iteration
            step = step.reshape(shape)
            longest = float(np.max(np.linalg.norm(step, axis=-1)))
            t = min(1.0, 0.25 / longest)  # no point moves more than L / 4 per step
            step *= t
            # the quadratic model's decrease along t p, p^T H p = -g^T p - shift scale |p|^2
            squared = float(np.einsum("i,i->", step.ravel(), step.ravel())) / (t * t)
            predicted = t * decrement * (1.0 - 0.5 * t) + 0.5 * t * t * shift * scale * squared
            f_trial, g_trial = advanced_cost(problem, y + step)
            accepted = f_trial < f
            shift = next_shift(shift, (f - f_trial) / predicted if accepted else -np.inf)
            if accepted:
                y, f, g = y + step, f_trial, g_trial
                break
        else:
            return y, f, False, f"stalled after {iteration} iterations (gradient {largest:.3g})", \
                iteration
    return (y, f, False, f"no convergence in {max_iterations} iterations "
            f"(gradient {float(np.max(np.abs(g))):.3g})", max_iterations)


def advanced_path(basic: np.ndarray, length: float, weights: AdvancedWeights | None = None, *,
                  method: str = "newton", max_iterations: int = 200,
                  gtol: float = 1e-8, linear_solver: str = "gmres"
                  ) -> tuple[np.ndarray, StageStatus]:
    """The advanced geometric path (thesis 4.4): eq. 4.17 minimized from the basic path.

    Parameters
    ----------
    basic : numpy.ndarray
        (S + 2, n + 1, 3) basic path [m] (its start and target are kept).
    length : float
        Cable length L [m], the unit of the dimensionless positions.
    weights : AdvancedWeights, optional
        Default: Table 6.1.
    method : {"newton", "L-BFGS-B"}
        ``"newton"`` (default): Newton steps on the exact Hessian, damped toward gradient steps
        where the Hessian is indefinite; typically 10-30 iterations at any size.
        ``"L-BFGS-B"``: scipy's quasi-Newton method with the exact gradient; it needs
        hundreds to thousands of iterations on this ill-conditioned cost (curvature terms grow
        like n^2) and stalls short of the optimum beyond n S ~ 400.
    max_iterations : int
        Iteration limit.
    gtol : float
        Tolerance on the largest component of the dimensionless gradient.
    linear_solver : {"gmres", "lu"}
        How a Newton step is solved (:data:`LINEAR_SOLVERS`): ``"gmres"`` (default) on the
        grid (:mod:`dloplan.planning.grid_newton`), in the plane of a planar problem; ``"lu"``
        sparse LU of the full 3-D system (the reference; the same steps to round-off).

    Returns
    -------
    tuple
        The path (S + 2, n + 1, 3) [m] and its :class:`StageStatus`.
    """
    t0 = time.perf_counter()
    if linear_solver not in LINEAR_SOLVERS:
        raise ValueError(f"linear_solver: got {linear_solver!r}, expected one of "
                         f"{', '.join(LINEAR_SOLVERS)}")
    rotation, coords = None, (0, 1, 2)
    if method == "newton" and linear_solver == "gmres":
        rotation, coords = plane_of(np.concatenate([basic[0], basic[-1]]))
    frame = basic
    if rotation is not None:  # a plane that is no axis plane: make its normal the third axis
        frame = basic @ rotation.T
        frame[..., 2] = np.mean(frame[..., 2])
    problem = advanced_problem(frame, length, weights)
    y0 = frame[1:-1] / length
    if method == "newton":
        y, cost, ok, message, iterations = _damped_newton(problem, y0, gtol, max_iterations,
                                                          linear_solver, coords)
    elif method == "L-BFGS-B":
        from scipy.optimize import minimize  # here: scipy.optimize costs the CLI 0.13 s to import

        def fun(flat):
            value, grad = advanced_cost(problem, flat.reshape(y0.shape))
            return value, grad.ravel()

        res = minimize(fun, y0.ravel(), jac=True, method="L-BFGS-B",
                       options={"maxiter": max_iterations, "gtol": gtol, "ftol": 1e-14,
                                "maxcor": 20})
        y, cost, ok = res.x.reshape(y0.shape), float(res.fun), bool(res.success)
        message, iterations = str(res.message), int(res.nit)
    else:
        raise ValueError(f"method: got {method!r}, expected 'newton' or 'L-BFGS-B'")
    inner = y * length if rotation is None else (y * length) @ rotation
    path = np.concatenate([basic[:1], inner, basic[-1:]])
    status = StageStatus(ok, message, iterations, y0.size, cost, time.perf_counter() - t0)
    return path, status
