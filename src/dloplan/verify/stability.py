"""Elastic stability of a held cable: the smallest eigenvalues of its tangent stiffness.

A static equilibrium x* of the potential energy U (eqs. 3.8, 3.20, 3.28) with both clips held
is *stable* when every small motion of the free points 2 .. n-2 raises the energy, i.e. when the
Hessian H = d^2U/dx^2 restricted to the free coordinates (:func:`dloplan.sim.statics.free_hessian`)
is positive definite. Its smallest eigenvalue lambda_1 [N/m] measures how far the shape is from
losing stability, and the matching eigenvector (the *mode*) shows how it would go: a shape near a
fold or a buckling load has lambda_1 close to zero and snaps along its mode.

Scale and tolerance
-------------------
Eigenvalues are compared with :func:`stiffness_scale`, the lowest eigenvalue of the same cable
straight, unloaded and weightless between simple supports,

    lambda_ref = (k_b / l^2) (pi l / L)^4 = B l pi^4 / L^4,    B = k_b l (the bending stiffness),

which is the smallest stiffness an intact cable owes to bending alone (the Hessian's largest
eigenvalues, about 4 k_s, are axial and irrelevant here). A shape is stable when

    lambda_1 > max(rtol * lambda_ref, 100 eps ||H||_inf)

with ``rtol = 1e-6`` by default: the second term is the round-off floor of an eigenvalue of H
(entries of size k_s computed in double precision), which only matters for very fine chains of
axially stiff cables (n = 1000: about 1e-4 lambda_ref). A smaller lambda_1 is zero to the
accuracy of the model: the shape is neutral (a rigid rotation the torsion-free model does not
resist, e.g. a weightless cable whose clips both point along the chord) or unstable.

Contacts
--------
A cable resting on a plate or wrapped around a peg is held there by one-sided contacts
(:mod:`dloplan.physics.contact`). With ``contacts`` the energy includes the penalty of the
obstacles, and the Hessian its exact blocks k_c (n n^T - d grad^2 phi)
(:func:`dloplan.physics.contact.contact_hessian_blocks`): an active contact resists motion into
the obstacle (with the stiffness k_c of the penalty, the hard constraint's limit) and, along a
curved surface, softens the cable by the pressing force over the curvature radius; an inactive
contact adds nothing. So lambda_1 is the smallest eigenvalue of the *constrained* Hessian: the
held points removed, the active contacts acting. Each obstacle's state (active with its force,
or clear by a gap) is reported (:mod:`dloplan.verify.contacts`), and an active contact along
which the lowest mode slides is marked as sliding: frictionless, it does not resist that mode.

The statics are frictionless, a real board is not: a slack cable resting on a plate or touching
a peg may be neutral or unstable along the surface in the frictionless model (lambda_1 <= 0 with
the mode sliding along the contact) and held there by friction. So with contacts a second
eigenvalue is computed, ``sticking`` [N/m]: the smallest of the same Hessian with the pressing
points held as well (sticking friction pins them, as long as they press: a perturbation asks an
infinitesimal tangential force of them). ``stable_with_friction`` asks it to exceed the
threshold; a configuration stable with friction but not without is *held by friction*, its
sliding contacts named. By Cauchy's interlacing theorem ``sticking >= lambda_1``.

The stability verdict is only meaningful at an equilibrium, so the net force on the free points
is checked as well: a shape whose largest free-point force exceeds ``equilibrium_rtol`` times
:func:`dloplan.sim.statics.force_scale` is reported as not an equilibrium (and not stable).

The eigen-solve is linear in n: H - sigma I is factorized by a banded Cholesky decomposition at a
shift sigma below the spectrum (whose success *proves* that every eigenvalue exceeds sigma, by
Sylvester's law of inertia) and ARPACK's shift-invert Lanczos (``scipy.sparse.linalg.eigsh``) runs
on the banded solves; small problems (fewer than :data:`DENSE_BELOW` free coordinates) use a
dense ``scipy.linalg.eigh``. ``method="band"`` skips the sparse matrix altogether: LAPACK's
banded eigen-solver (``scipy.linalg.eig_banded``, tridiagonal reduction of the band, then the
k smallest eigenpairs by bisection) runs on the Hessian's band as assembled, about six times
faster per shape at the sizes the snap-through continuation solves at every sub-step (the same
eigenvalues to round-off); its eigenvectors cost O(N^2) though, so :func:`quickest_method` picks
it only below :data:`BAND_BELOW` free coordinates. Along a continuation (``method="follow"`` of
:func:`elastic_stabilities`) each sub-step's smallest eigenpair is the previous one's refined by
inverse iteration on a banded Cholesky factor and certified by another
(:mod:`dloplan.verify.lowest`), about 10 times cheaper than LAPACK's banded solve, which it
falls back on near the stability threshold.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..cable import GRAVITY, Cable
from ..geometry import as_path, as_shape
from ..physics.chain import (
    HALF_BANDWIDTH,
    SpringChain,
    band_to_sparse,
    shape_derivatives,
    sparse_to_band,
)
from ..physics.compiled import add_point_blocks
from ..sim.newton import factor_band, free_band, lowest_eigenpair, solve_band
from ..sim.statics import force_scale
from .contacts import BoardContacts, ContactState, contact_stiffness
from .lowest import eigenvalue_tolerance, follow_lowest

STABILITY_RTOL = 1e-6
"""Default relative tolerance on the smallest eigenvalue, against :func:`stiffness_scale`."""

EQUILIBRIUM_RTOL = 1e-3
"""Default tolerance on the free-point force residual, against ``force_scale``: loose enough for
shapes settled by the thesis' time stepping (rest speed 1e-5 m/s), tight enough to reject a shape
that is not an equilibrium at all."""

ROUNDOFF_FACTOR = 100.0
"""The round-off floor of an eigenvalue is ``ROUNDOFF_FACTOR * eps * ||H||_inf``."""

DENSE_BELOW = 60
"""Free-coordinate count below which a dense eigen-solve is used (ARPACK overhead dominates)."""

BAND_BELOW = 150
"""Free-coordinate count below which ``method="band"`` is the quickest (measured, k = 1: n = 12
1.4 ms against 3.3 ms; n = 50 3.2 ms against 5.6 ms; n = 200 61 ms against 21 ms)."""

LANCZOS_SEED = 0
"""Seed of the start vector of ARPACK's Lanczos iteration (:func:`smallest_eigenpairs`): ARPACK's
own random start advances with every call, so the same matrix gave eigenvalues differing in the
15th digit from run to run and plan.json was not repeatable bit for bit; a seeded start vector,
uniform in [-1, 1) as ARPACK draws its own, keeps the same convergence and makes it so."""


def quickest_method(n_points: int) -> str:
    """The quickest eigen-solver of :func:`elastic_stability` for a chain of ``n_points``
    points: ``"band"`` for fewer than :data:`BAND_BELOW` free coordinates, else ``"auto"``."""
    return "band" if 3 * (n_points - 4) < BAND_BELOW else "auto"


@dataclass(frozen=True, eq=False)
class Stability:
    """Result of :func:`elastic_stability` for one shape.

    Attributes
    ----------
    eigenvalues : numpy.ndarray
        (k,) smallest eigenvalues of the free-DOF Hessian, ascending [N/m].
    modes : numpy.ndarray
        (k, n + 1, 3) matching unit eigenvectors as point displacements (zero at the held
        points); the sign makes the largest component positive.
    scale : float
        lambda_ref of :func:`stiffness_scale` [N/m].
    threshold : float
        The eigenvalue a stable shape must exceed [N/m].
    residual : float
        Largest net force on a free point [N].
    is_equilibrium : bool
        ``residual`` within the equilibrium tolerance.
    stable : bool
        An equilibrium whose smallest eigenvalue exceeds ``threshold``.
    message : str
        The verdict in words.
    contacts : tuple of ContactState
        The state of each contact obstacle (empty without contacts).
    sticking : float
        Smallest eigenvalue with the pressing points held too [N/m] (module docstring; equal
        to the smallest eigenvalue when no point presses).
    """

    eigenvalues: np.ndarray
    modes: np.ndarray
    scale: float
    threshold: float
    residual: float
    is_equilibrium: bool
    stable: bool
    message: str
    contacts: tuple[ContactState, ...] = ()
    sticking: float = math.inf

    @property
    def stable_with_friction(self) -> bool:
        """An equilibrium that is stable with its pressing contacts sticking (module
        docstring); the same as ``stable`` without contacts."""
        return self.is_equilibrium and self.sticking > self.threshold

    @property
    def held_by_friction(self) -> bool:
        """Stable only with friction at the pressing contacts."""
        return self.stable_with_friction and not self.stable

    @property
    def smallest(self) -> float:
        """The smallest eigenvalue lambda_1 [N/m] (+inf when no point is free)."""
        return float(self.eigenvalues[0]) if len(self.eigenvalues) else math.inf

    @property
    def relative(self) -> float:
        """lambda_1 / lambda_ref (dimensionless)."""
        return self.smallest / self.scale

    @property
    def success(self) -> bool:
        """Same as ``stable``."""
        return self.stable


def stiffness_scale(cable: Cable) -> float:
    """Lowest eigenvalue of the straight, unloaded, simply supported chain [N/m].

    lambda_ref = (k_b / l^2) (pi l / L)^4: the stiffness of the softest bending mode of the
    cable by bending alone, used to judge whether a smallest eigenvalue is zero.
    """
    l = cable.rest_link_length
    return cable.k_bending / l**2 * (math.pi * l / cable.length) ** 4


def _shift_below_spectrum(band: np.ndarray, matrix: sp.spmatrix, start: float):
    """A shift sigma < lambda_1 and the Cholesky factor of H - sigma I.

    Tries sigma = -start, -4 start, -16 start, ... and finally the Gershgorin lower bound
    (certainly below the spectrum).
    """
    row_sums = np.asarray(abs(matrix).sum(axis=1)).ravel()
    diagonal = band[0]
    gershgorin = float(np.min(2.0 * diagonal - row_sums))  # min_i (H_ii - sum_{j!=i} |H_ij|)
    sigma = -start
    while sigma > gershgorin:
        factor = factor_band(band, -sigma)
        if factor is not None:
            return sigma, factor
        sigma *= 4.0
    sigma = gershgorin - start
    factor = factor_band(band, -sigma)
    if factor is None:  # pragma: no cover - Gershgorin guarantees definiteness
        raise FloatingPointError("stability: no shift below the spectrum found")
    return sigma, factor


def smallest_eigenpairs(matrix, k: int = 3, *, scale: float = 1.0, method: str = "auto"):
    """The k smallest eigenvalues and eigenvectors of a symmetric banded sparse matrix.

    Parameters
    ----------
    matrix : scipy.sparse matrix
        (N, N) symmetric, with half bandwidth at most ``HALF_BANDWIDTH`` (a free Hessian).
    k : int
        Number of eigenpairs (fewer when N < k).
    scale : float
        Magnitude of the eigenvalues of interest; sets the first shift tried.
    method : {"auto", "sparse", "dense"}
        ``"sparse"``: shift-invert Lanczos on banded Cholesky solves (linear in N);
        ``"dense"``: ``scipy.linalg.eigh``; ``"auto"``: dense below :data:`DENSE_BELOW`.

    Returns
    -------
    eigenvalues : numpy.ndarray
        (k,) ascending.
    vectors : numpy.ndarray
        (N, k) orthonormal columns.
    """
    n_dof = matrix.shape[0]
    k = min(k, n_dof)
    if method not in ("auto", "sparse", "dense"):
        raise ValueError(f"method: got {method!r}, expected 'auto', 'sparse' or 'dense'")
    if method == "dense" or (method == "auto" and n_dof < DENSE_BELOW) or k >= n_dof - 1:
        values, vectors = sla.eigh(matrix.toarray(), subset_by_index=[0, k - 1])
        return values, vectors
    band = sparse_to_band(matrix, HALF_BANDWIDTH)
    sigma, factor = _shift_below_spectrum(band, matrix, scale)
    inverse = spla.LinearOperator(
        (n_dof, n_dof),
        matvec=lambda b: solve_band(factor, b),
        dtype=float,
    )
    # the eigenvalues of (H - sigma I)^-1 are 1 / (lambda - sigma) > 0; the largest belong to the
    # smallest lambda because sigma lies below all of them.
    start = np.random.default_rng(LANCZOS_SEED).uniform(-1.0, 1.0, n_dof)
    values, vectors = spla.eigsh(matrix, k=k, sigma=sigma, which="LM", OPinv=inverse, tol=0.0,
                                 v0=start)
    order = np.argsort(values)
    return values[order], vectors[:, order]


def band_eigenpairs(band: np.ndarray, k: int = 3) -> tuple[np.ndarray, np.ndarray, float]:
    """The k smallest eigenpairs of a symmetric matrix given by its lower band, and its norm.

    Parameters
    ----------
    band : numpy.ndarray
        (w + 1, N) lower band, ``band[i, j] = H[j + i, j]`` (entries with j + i >= N unused), as
        :func:`dloplan.physics.chain.hessian_band` and :func:`dloplan.sim.newton.free_band`
        give it [N/m].
    k : int
        Number of eigenpairs (fewer when N < k).

    Returns
    -------
    eigenvalues : numpy.ndarray
        (k,) ascending [N/m].
    vectors : numpy.ndarray
        (N, k) orthonormal columns.
    norm : float
        ||H||_inf, the largest absolute row sum [N/m] (:func:`band_norm`).
    """
    n_dof = band.shape[1]
    k = min(k, n_dof)
    values, vectors = sla.eig_banded(band, lower=True, select="i", select_range=(0, k - 1),
                                     check_finite=False)
    return values, vectors, band_norm(band)


def band_norm(band: np.ndarray) -> float:
    """||H||_inf [N/m], the largest absolute row sum of a symmetric matrix given by its lower
    band (w + 1, N) (:func:`band_eigenpairs`' layout)."""
    n_dof = band.shape[1]
    used = np.abs(band)
    used[np.arange(band.shape[0])[:, None] + np.arange(n_dof) >= n_dof] = 0.0
    rows = used.sum(axis=0)  # row j: H[j, j] and H[j + i, j] = H[j, j + i] right of it
    for i in range(1, min(band.shape[0], n_dof)):  # a short chain has fewer dof than rows
        rows[i:] += used[i, : n_dof - i]  # and H[j, j - i] left of the diagonal
    return float(rows.max())


def constrained_hessian(cable: Cable, shape, *, gravity=GRAVITY, contacts=(),
                        stiffness: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The energy gradient and the lower Hessian band of a held cable over its free points.

    Parameters
    ----------
    cable : Cable
        The cable.
    shape : array_like
        (n + 1, 3) shape [m]; points 0, 1, n-1, n are held by the clips.
    gravity : array_like
        Gravity [m/s^2].
    contacts : sequence
        Obstacles in one-sided contact (module docstring), with their exact Hessian blocks.
    stiffness : float, optional
        Penalty stiffness k_c [N/m]; default the statics' (100 k_s).

    Returns
    -------
    gradient : numpy.ndarray
        (n + 1, 3) dU/dx at every point [N] (gravity and contacts included).
    band : numpy.ndarray
        (HALF_BANDWIDTH + 1, 3 (n - 3)) lower band of d^2U/dx^2 over the free points 2 .. n-2
        [N/m]: the held points' coordinates removed.
    """
    x = as_shape(shape, cable.n_points, "shape")
    k_c = contact_stiffness(cable) if stiffness is None else float(stiffness)
    board = BoardContacts.at(x[None], tuple(contacts), cable.diameter / 2, k_c)
    return _free_derivatives(SpringChain.from_cable(cable, gravity), x, board, 0)


def _free_derivatives(chain: SpringChain, x: np.ndarray, board: BoardContacts,
                      b: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`constrained_hessian` of shape ``x``, shape b of ``board``."""
    _, grad, band = shape_derivatives(chain, x)
    if board.names:
        grad = grad + board.gradient[b]
        add_point_blocks(band, board.blocks[b])
    return grad, free_band(band, slice(2, len(x) - 2))


def elastic_stability(
    cable: Cable,
    shape,
    *,
    gravity=GRAVITY,
    k: int = 3,
    rtol: float = STABILITY_RTOL,
    equilibrium_rtol: float = EQUILIBRIUM_RTOL,
    method: str = "auto",
    contacts=(),
) -> Stability:
    """Smallest eigenvalues and modes of the held cable's stiffness, and the stability verdict.

    Parameters
    ----------
    cable : Cable
        The cable.
    shape : array_like
        (n + 1, 3) equilibrium shape [m]; points 0, 1, n-1, n are held by the clips.
    gravity : array_like
        Gravity [m/s^2] (enters the equilibrium check only: gravity has no Hessian).
    k : int
        Number of eigenpairs returned (>= 1).
    rtol : float
        Relative tolerance: stable when lambda_1 > max(rtol lambda_ref, round-off floor).
    equilibrium_rtol : float
        The largest free-point force accepted, relative to ``force_scale(cable, gravity)``.
    method : {"auto", "sparse", "dense", "band", "follow"}
        Eigen-solver, see :func:`smallest_eigenpairs`; ``"band"``: :func:`band_eigenpairs` on
        the Hessian's band, without a sparse matrix (the continuation's choice); ``"follow"``
        (k = 1): as ``"band"`` for one shape (:func:`elastic_stabilities`).
    contacts : sequence
        Obstacles in one-sided contact with the cable (pegs, plates, the table): their penalty
        enters the equilibrium and the constrained Hessian (module docstring), and their
        states are reported.

    Returns
    -------
    Stability
        Eigenvalues [N/m], modes, threshold, equilibrium residual, verdict and contact states.
    """
    x = as_shape(shape, cable.n_points, "shape")
    return elastic_stabilities([cable], x[None], gravity=gravity, k=k, rtol=rtol,
                               equilibrium_rtol=equilibrium_rtol, method=method,
                               contacts=contacts)[0]


def elastic_stabilities(
    cables,
    shapes,
    *,
    gravity=GRAVITY,
    k: int = 3,
    rtol: float = STABILITY_RTOL,
    equilibrium_rtol: float = EQUILIBRIUM_RTOL,
    method: str = "auto",
    contacts=(),
) -> tuple[Stability, ...]:
    """:func:`elastic_stability` of M shapes, the contacts' penalty evaluated once for all.

    Shape b is judged as ``elastic_stability(cables[b], shapes[b], ...)`` (the same numbers):
    the obstacles' distances, normals and curvatures at every point of every shape come from
    one call each (:class:`~dloplan.verify.contacts.BoardContacts`), the chain of each distinct
    cable is built once, and the sticking eigenvalue is LAPACK's banded solve of the Hessian
    with the pressing points' coordinates cleared (:func:`_sticking_eigenvalue`). The snap-through
    continuation with contacts judges its sub-steps this way.

    Parameters
    ----------
    cables : sequence of Cable
        (M,) the cable of each shape (the same number of links; a cable may repeat).
    shapes : array_like
        (M, n + 1, 3) equilibrium shapes [m].
    gravity, k, rtol, equilibrium_rtol, method, contacts
        As for :func:`elastic_stability`; ``method="follow"`` (k = 1) for shapes that are
        consecutive sub-steps of a continuation: each shape's smallest eigenpairs (without and
        with the pressing points sticking) found from the shape before's by inverse iteration,
        certified (:func:`dloplan.verify.lowest.follow_lowest`: the eigenvalue to
        :func:`~dloplan.verify.lowest.eigenvalue_tolerance`, the round-off floor of an
        eigenvalue of H), LAPACK's banded solve where that fails, at the first shape, and where
        the eigenvalue is within twice that tolerance of the stability threshold or below it:
        the verdicts are ``"band"``'s, the eigenvalues and modes the same to round-off.

    Returns
    -------
    tuple of Stability
        One per shape.
    """
    cables = list(cables)
    if not cables:
        raise ValueError("cables: none given, expected one per shape")
    x = as_path(shapes, cables[0].n_points, "shapes")
    if len(cables) != len(x) or len({c.n_points for c in cables}) != 1:
        raise ValueError(f"cables: {len(cables)} given for {len(x)} shapes, expected one per "
                         "shape, all with the same number of links")
    if isinstance(k, bool) or int(k) != k or k < 1:
        raise ValueError(f"k: got {k!r}, expected an integer >= 1")
    for name, value in (("rtol", rtol), ("equilibrium_rtol", equilibrium_rtol)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}: got {value!r}, expected a number > 0")
    if method == "follow" and k != 1:
        raise ValueError(f"k: got {k!r}, method 'follow' finds the smallest eigenpair only (k=1)")
    contacts = tuple(contacts)
    chains: dict[int, SpringChain] = {}
    forces: dict[int, float] = {}  # force_scale per cable
    for cable in cables:
        if id(cable) not in chains:
            chains[id(cable)] = SpringChain.from_cable(cable, gravity)
            forces[id(cable)] = force_scale(cable, gravity)
    board = BoardContacts.at(x, contacts, cables[0].diameter / 2,
                             [chains[id(c)].contact_stiffness for c in cables])
    followed = _Followed() if method == "follow" else None
    return tuple(_judged(cable, chains[id(cable)], shape, board, b, forces[id(cable)], int(k),
                         rtol, equilibrium_rtol, method, followed)
                 for b, (cable, shape) in enumerate(zip(cables, x, strict=True)))


class _Followed:
    """The previous shape's smallest eigenpairs along a continuation (``method="follow"``):
    ``free`` and ``sticking``, each (value [N/m], unit vector (N,)) or None."""

    def __init__(self):
        self.free = self.sticking = None

    def lowest(self, band: np.ndarray, which: str, scale: float, norm: float,
               threshold: float) -> tuple[float, np.ndarray]:
        """The smallest eigenpair of ``band``, followed from the previous shape's ``which``
        pair (:func:`~.lowest.follow_lowest`) where that is certified and above ``threshold``
        [N/m] by more than twice its tolerance (so the stability verdict is certain);
        LAPACK's banded solve (:func:`band_eigenpairs`) otherwise: at the first shape, where the
        eigenvalue jumped or crossed another, near or below the threshold. Kept as the next
        shape's start."""
        previous = getattr(self, which)
        found = None
        if previous is not None:
            tolerance = eigenvalue_tolerance(previous[0], scale, norm, ROUNDOFF_FACTOR)
            found = follow_lowest(band, previous[1], previous[0], scale, tolerance)
            if found is not None and not found[0] - 2.0 * tolerance > threshold:
                found = None
        if found is None:
            found = lowest_eigenpair(band)
        setattr(self, which, found)
        return found


def _judged(cable: Cable, chain: SpringChain, x: np.ndarray, board: BoardContacts, b: int,
            force: float, k: int, rtol: float, equilibrium_rtol: float, method: str,
            followed: _Followed | None = None) -> Stability:
    """The :class:`Stability` of shape ``x``, shape b of ``board`` (:func:`elastic_stability`;
    ``force`` [N] the cable's :func:`~dloplan.sim.statics.force_scale` under the gravity);
    ``followed``: the previous shape's eigenpairs (``method="follow"``)."""
    grad, band = _free_derivatives(chain, x, board, b)
    residual = 0.0
    if cable.n_points > 4:
        residual = float(np.max(np.linalg.norm(grad[2:-2], axis=1)))
    is_equilibrium = residual <= equilibrium_rtol * force
    scale = stiffness_scale(cable)
    states = board.states(b) if board.names else ()
    n_dof = 3 * max(cable.n_points - 4, 0)
    if n_dof == 0:
        return Stability(np.zeros(0), np.zeros((0, cable.n_points, 3)), scale, 0.0, residual,
                         True, True, "no free point: the clips fix the whole cable", states,
                         math.inf)
    lowest = None
    if method == "band":
        values, vectors, norm = band_eigenpairs(band, k)
    elif method == "follow":
        norm = band_norm(band)
        limit = _threshold(rtol, scale, norm)
        value, vector = followed.lowest(band, "free", scale, norm, limit)
        values, vectors = np.array([value]), vector[:, None]

        def lowest(held):
            return followed.lowest(held, "sticking", scale, norm, limit)[0]
    else:
        matrix = band_to_sparse(band)
        values, vectors = smallest_eigenpairs(matrix, k, scale=scale, method=method)
        norm = float(abs(matrix).sum(axis=1).max())
    threshold = _threshold(rtol, scale, norm)
    modes = np.zeros((len(values), cable.n_points, 3))
    for j in range(len(values)):
        v = vectors[:, j]
        modes[j, 2:-2] = (v if v[np.argmax(np.abs(v))] > 0 else -v).reshape(-1, 3)
    sticking = float(values[0])
    pressing = board.pressing(b) if states else np.zeros(cable.n_points, dtype=bool)
    if states:
        states = board.sliding(b, states, modes[0])
        sticking = _sticking_eigenvalue(band, pressing, float(values[0]), norm, lowest)
    if followed is not None and not pressing[2:-2].any():  # sticking is the free pair's
        followed.sticking = followed.free
    positive = bool(values[0] > threshold)
    stable = positive and is_equilibrium
    summary = f"lambda_1 = {values[0]:.4g} N/m ({values[0] / scale:.4g} lambda_ref)"
    if not is_equilibrium:
        message = (f"not an equilibrium: a free point carries a net force of {residual:.3g} N "
                   f"(tolerance {equilibrium_rtol * force:.3g} N); {summary}")
    elif positive:
        message = f"stable: {summary}"
    elif sticking > threshold:
        message = (f"held by friction: {summary} is not above {threshold:.3g} N/m without "
                   f"friction, {sticking:.4g} N/m with the pressing points sticking")
    else:
        message = f"not stable: {summary} is not above {threshold:.3g} N/m"
    if states:
        message += "; contacts: " + ", ".join(state.describe() for state in states)
    return Stability(values, modes, scale, float(threshold), residual, bool(is_equilibrium),
                     stable, message, states, sticking)


def _threshold(rtol: float, scale: float, norm: float) -> float:
    """The eigenvalue a stable shape must exceed [N/m] (module docstring), for the stiffness
    scale ``scale`` and ||H||_inf ``norm`` [N/m]."""
    return max(rtol * scale, ROUNDOFF_FACTOR * np.finfo(float).eps * norm)


def _sticking_eigenvalue(band: np.ndarray, pressing: np.ndarray, smallest: float,
                         norm: float, lowest=None) -> float:
    """Smallest eigenvalue of the free Hessian ``band`` (its norm ``norm`` [N/m]) with the
    coordinates of the points ``pressing`` (n + 1,) removed too (module docstring); ``smallest``
    when no free point presses. ``lowest``: the smallest eigenvalue of a band (default:
    LAPACK's banded solve).

    The removed coordinates' rows and columns are cleared and their diagonal set to 2 ||H||,
    above every eigenvalue of the rest (a principal submatrix of H: its eigenvalues lie within
    H's, at most ||H||): the band's smallest eigenvalue is then the reduced matrix's, by
    LAPACK's banded solver (:func:`band_eigenpairs`'s), without leaving the band.
    """
    keep = ~pressing[2:-2]
    if keep.all():
        return smallest
    if not keep.any():
        return math.inf
    removed = np.flatnonzero(np.repeat(~keep, 3))
    held = band.copy()
    for d in range(held.shape[0]):  # band[d, j] = H[j + d, j]
        held[d, removed] = 0.0  # column j removed
        rows = removed - d
        held[d, rows[rows >= 0]] = 0.0  # row j + d removed
    held[0, removed] = 2.0 * norm
    if lowest is not None:
        return lowest(held)
    return float(sla.eig_banded(held, lower=True, select="i", select_range=(0, 0),
                                eigvals_only=True, check_finite=False)[0])


def path_stability(
    cable: Cable, shapes, *, gravity=GRAVITY, **options
) -> tuple[Stability, ...]:
    """:func:`elastic_stability` of every shape of a path.

    Parameters
    ----------
    cable : Cable
        The cable.
    shapes : array_like
        (S + 2, n + 1, 3) stabilized shapes [m].
    gravity : array_like
        Gravity [m/s^2].
    **options
        Passed to :func:`elastic_stability`.
    """
    path = as_path(shapes, cable.n_points, "shapes")
    return tuple(elastic_stability(cable, x, gravity=gravity, **options) for x in path)


__all__ = [
    "Stability",
    "band_eigenpairs",
    "band_norm",
    "constrained_hessian",
    "quickest_method",
    "elastic_stabilities",
    "elastic_stability",
    "path_stability",
    "smallest_eigenpairs",
    "stiffness_scale",
]
