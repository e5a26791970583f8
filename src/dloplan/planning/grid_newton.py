"""The advanced stage's Newton system on the (shape x point) grid, solved in O(n S) per iteration.

The unknowns of the advanced stage (thesis eq. 4.17) are S shapes of n + 1 points with d
coordinates each (d = 3, or d = 2 for a planar problem, see :func:`plane_of`). Their Hessian is

    H = A (x) I + blockdiag(H_1, ..., H_S),

with A the S x S tridiagonal matrix of the transversal term (the same for every point and
coordinate, constant) and H_i the within-shape part: axial (points j, j+1) and bending (j .. j+2)
blocks and the clip term (points 0, 1, n-1, n). A direct factorization of this 2-D grid fills in
(sparse LU: about O((n S)^1.5) work); here instead:

* **the within-shape blocks are banded**: with the points ordered 0, n, 1, n-1, 2, ... (so that
  the clip's four points are neighbours) every H_i is a band of half-width 5d - 1, factorized
  exactly (LU with partial pivoting, :func:`band_lu`, O(n) per shape);
* **the soft modes of a shape are few**: a shape resists the rigid motions and smooth bends of
  its points only through the transversal term; they are spanned per shape and coordinate by K
  Chebyshev polynomials in the point index (:data:`COARSE_DEGREE`). The Galerkin operator
  Z^T H Z on that coarse space is block-tridiagonal in the shape index (dK x dK blocks, the
  couplings between shapes a multiple of the identity), solved exactly by block LU
  (:func:`block_tridiagonal_factor`, O(S (dK)^3), a quarter of a band LU's work);
* **GMRES** (right-preconditioned, :func:`gmres`) on H with the two-level preconditioner
  "coarse solve, then the shapes' bands on its residual" converges in 5-60 iterations, each
  O(n S d K) (a symmetric variant with a second coarse solve saved only 5 % of them). The
  product H M^-1 v an iteration needs comes from the preconditioner itself: H = F + C with F
  the shapes' bands and C the coupling between shapes, so H x = v + C z for x = M^-1 v with
  fine correction z, one band product per iteration instead of two.

Solved to a relative residual of 1e-12, a step equals the sparse LU's to about 1e-11 (relative);
the damped Newton iteration (:func:`dloplan.planning.geometric.advanced_path`) asks for
1e-8 max|g| at most and so takes the same steps and stops at the same optimum as with sparse
LU (to 1e-9 m on the tests' jobs, 3e-14 m on the (100, 100) folding case; a path that goes
through many indefinite Hessians can end at another stationary point by round-off, as that case
did, 0.04 mm away, with the first damping policy).
When GMRES does not reach the residual asked for (nor :data:`ACCEPTED_RESIDUAL`) or a shape's
band is singular, :meth:`GridNewton.solve` returns None and the caller falls back to sparse LU
for that system. docs/planner.md has the measurements.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..jit import njit
from ..physics.compiled import chain_derivatives, chain_gradient

COARSE_DEGREE = 12
"""K: Chebyshev polynomials (degrees 0 .. K-1) per coordinate and shape in the coarse space."""
KRYLOV_TOLERANCE = 1e-12
"""Relative residual |H p - r| / |r| at which GMRES stops."""
ACCEPTED_RESIDUAL = 1e-8
"""Relative residual still accepted when GMRES stagnates above its tolerance: on the first,
most ill-conditioned systems (diagonal entries from 1 to 1e8) sparse LU's own residual is
about 1e-8 too."""
MAX_KRYLOV = 150
"""GMRES iterations at most (no restart)."""


@njit(cache=True)
def band_lu(ab, kl):
    """LU factorization with partial pivoting of a band matrix, in place (LAPACK ``gbtf2``).

    Parameters
    ----------
    ab : numpy.ndarray
        (N, 3 kl + 1) band by columns, ``ab[j, 2 kl + i - j] = A[i, j]`` for |i - j| <= kl
        (each column contiguous); entries 0 .. kl-1 of every column are zero on entry (room for
        the fill of U). Overwritten by L and U.
    kl : int
        Half-bandwidth (the same below and above the diagonal).

    Returns
    -------
    tuple
        Pivot rows (N,) and False when a column has no non-zero pivot (singular).
    """
    n = ab.shape[0]
    kv = 2 * kl
    piv = np.empty(n, np.int64)
    for j in range(n):
        km = min(kl, n - 1 - j)
        p = 0
        big = abs(ab[j, kv])
        for r in range(1, km + 1):
            v = abs(ab[j, kv + r])
            if v > big:
                big = v
                p = r
        piv[j] = j + p
        if big == 0.0:
            return piv, False
        last = min(j + kv, n - 1)
        if p != 0:
            for c in range(j, last + 1):
                t = ab[c, kv + j - c]
                ab[c, kv + j - c] = ab[c, kv + j + p - c]
                ab[c, kv + j + p - c] = t
        multipliers = ab[j, kv + 1: kv + 1 + km]  # slices: contiguous loops numba vectorizes
        multipliers /= ab[j, kv]
        for c in range(j + 1, last + 1):
            u = ab[c, kv + j - c]
            if u != 0.0:
                target = ab[c, kv + j - c + 1: kv + j - c + 1 + km]
                for r in range(km):
                    target[r] -= multipliers[r] * u
    return piv, True


@njit(cache=True)
def band_lu_solve(ab, kl, piv, b):
    """Solve A x = b with the factors of :func:`band_lu`; ``b`` (N,) is not modified."""
    n = ab.shape[0]
    kv = 2 * kl
    x = b.copy()
    for j in range(n):
        p = piv[j]
        if p != j:
            t = x[j]
            x[j] = x[p]
            x[p] = t
        xj = x[j]
        km = min(kl, n - 1 - j)
        below, lower = x[j + 1: j + 1 + km], ab[j, kv + 1: kv + 1 + km]
        for r in range(km):
            below[r] -= lower[r] * xj
    for j in range(n - 1, -1, -1):
        x[j] /= ab[j, kv]
        xj = x[j]
        first = max(0, j - kv)
        above, upper = x[first:j], ab[j, kv + first - j: kv]
        for i in range(j - first):
            above[i] -= upper[i] * xj
    return x


@njit(cache=True)
def band_matvec(ab, kl, x):
    """A @ x for a compact band ``ab[j, kl + i - j] = A[i, j]`` (N, 2 kl + 1) and x (N,)."""
    n = x.shape[0]
    y = np.zeros(n)
    for j in range(n):
        xj = x[j]
        first, stop = max(0, j - kl), min(n, j + kl + 1)
        rows, column = y[first:stop], ab[j, kl + first - j: kl + stop - j]
        for i in range(stop - first):
            rows[i] += column[i] * xj
    return y


@njit(cache=True)
def add_coupling(y, coupling, x):
    """y += C x in place for x, y (N,) over S equal shape blocks, C the coupling between
    neighbouring shapes (``coupling[i]`` times the identity between shapes i and i + 1)."""
    n_shapes = coupling.size + 1
    m = x.size // n_shapes
    for i in range(n_shapes - 1):
        c, above, below = coupling[i], y[i * m:(i + 1) * m], x[(i + 1) * m:(i + 2) * m]
        for t in range(m):
            above[t] += c * below[t]
    for i in range(1, n_shapes):
        c, below, above = coupling[i - 1], y[i * m:(i + 1) * m], x[(i - 1) * m:i * m]
        for t in range(m):
            below[t] += c * above[t]


@njit(cache=True)
def grid_matvec(compact, kl, coupling, shift, x):
    """(H + shift I) x for x (N,): the shapes' compact band (N, 2 kl + 1) (layout of
    :func:`band_matvec`) plus the coupling between shapes (:func:`add_coupling`)."""
    y = band_matvec(compact, kl, x)
    if shift != 0.0:
        for t in range(y.size):
            y[t] += shift * x[t]
    add_coupling(y, coupling, x)
    return y


@njit(cache=True)
def two_level(r, coarse, coupling, polynomials, d, compact, fine, kl, piv, shift):
    """The two-level preconditioner M^-1 r (N,): the coarse solve x = Z T^-1 Z^T r, then the
    shapes' bands on its residual, z = F^-1 (r - (H + shift I) x). Returns x + z and z.

    ``coarse``: :func:`block_tridiagonal_factor`'s inverses, ``polynomials`` and ``d`` Z's
    factors (:func:`restrict`), ``compact`` the unfactored band of :func:`grid_matvec`,
    ``fine`` and ``piv`` its shifted band's :func:`band_lu`.
    """
    n_shapes = coupling.size + 1
    e = block_tridiagonal_solve(coarse, coupling, restrict(r, polynomials, d, n_shapes))
    x = prolong(e, polynomials, d, n_shapes)
    z = band_lu_solve(fine, kl, piv, r - grid_matvec(compact, kl, coupling, shift, x))
    return x + z, z


@njit(cache=True)
def galerkin_blocks(ab, kl, basis, n_shapes):
    """The diagonal blocks Z^T A_ii Z (S, q, q) of a shape-block-diagonal band A.

    ``ab``: (S m, 3 kl + 1) unfactored band in the layout of :func:`band_lu`, no entry coupling
    two shapes; ``basis`` Z (m, q) one shape's coarse basis. O(S m q (kl + q)).
    """
    m, q = basis.shape
    kv = 2 * kl
    out = np.zeros((n_shapes, q, q))
    az = np.empty((m, q))
    # Z's non-zero columns by row (a coordinate's rows have only its own polynomials)
    support = np.zeros(m, np.int64)
    columns = np.empty((m, q), np.int64)
    for j in range(m):
        for c in range(q):
            if basis[j, c] != 0.0:
                columns[j, support[j]] = c
                support[j] += 1
    for i in range(n_shapes):
        offset = i * m
        az[:] = 0.0
        for j in range(m):  # column j of A_ii times row j of Z
            zj, cols = basis[j], columns[j, :support[j]]
            for p in range(max(0, j - kl), min(m, j + kl + 1)):
                a = ab[offset + j, kv + p - j]
                if a != 0.0:
                    row = az[p]
                    for c in cols:
                        row[c] += a * zj[c]
        block = out[i]
        for p in range(m):
            zp, row = basis[p], az[p]
            for r in columns[p, :support[p]]:
                z = zp[r]
                target = block[r]
                for c in range(q):
                    target[c] += z * row[c]
    return out


@njit(cache=True)
def _invert(a, out):
    """out = a^-1 (q, q) by Gauss-Jordan elimination with partial pivoting, ``a`` overwritten;
    False when a column has no non-zero pivot."""
    q = a.shape[0]
    out[:] = 0.0
    for i in range(q):
        out[i, i] = 1.0
    for col in range(q):
        p, big = col, abs(a[col, col])
        for r in range(col + 1, q):
            if abs(a[r, col]) > big:
                p, big = r, abs(a[r, col])
        if big == 0.0:
            return False
        if p != col:
            for c in range(q):
                a[col, c], a[p, c] = a[p, c], a[col, c]
                out[col, c], out[p, c] = out[p, c], out[col, c]
        pivot = a[col, col]
        for c in range(q):
            a[col, c] /= pivot
            out[col, c] /= pivot
        for r in range(q):
            f = a[r, col]
            if r != col and f != 0.0:
                for c in range(q):
                    a[r, c] -= f * a[col, c]
                    out[r, c] -= f * out[col, c]
    return True


@njit(cache=True)
def block_tridiagonal_factor(blocks, coupling, shift):
    """Block LU of the block-tridiagonal T with diagonal blocks ``blocks[i] + shift I`` (S, q,
    q) and off-diagonal blocks ``coupling[i] I`` between i and i + 1 ((S - 1,)).

    T = L U, U with the pivot blocks D_i on its diagonal (D_0 = T_00, D_i = T_ii -
    coupling[i-1]^2 D_{i-1}^-1) and coupling[i] I above, L unit lower with coupling[i-1]
    D_{i-1}^-1 below. Returns the inverses D_i^-1 (S, q, q) and False when a D_i is singular.
    O(S q^3).
    """
    n_shapes, q, _ = blocks.shape
    inverses = np.empty_like(blocks)
    pivot = np.empty((q, q))
    for i in range(n_shapes):
        pivot[:] = blocks[i]
        for r in range(q):
            pivot[r, r] += shift
        if i > 0:
            c2 = coupling[i - 1] * coupling[i - 1]
            previous = inverses[i - 1]
            for r in range(q):
                for c in range(q):
                    pivot[r, c] -= c2 * previous[r, c]
        if not _invert(pivot, inverses[i]):
            return inverses, False
    return inverses, True


@njit(cache=True)
def block_tridiagonal_solve(inverses, coupling, rhs):
    """Solve T x = rhs (S q,) with the factors of :func:`block_tridiagonal_factor`."""
    n_shapes, q, _ = inverses.shape
    y = rhs.reshape(n_shapes, q).copy()
    x = np.zeros((n_shapes, q))
    for i in range(n_shapes):  # L y = rhs, and w_i = D_i^-1 y_i (kept in x)
        if i > 0:
            c, w = coupling[i - 1], x[i - 1]
            for r in range(q):
                y[i, r] -= c * w[r]
        inv, w = inverses[i], x[i]
        for r in range(q):
            t = 0.0
            for c in range(q):
                t += inv[r, c] * y[i, c]
            w[r] = t
    for i in range(n_shapes - 2, -1, -1):  # U x = y: x_i = w_i - coupling[i] D_i^-1 x_{i+1}
        inv, c, nxt = inverses[i], coupling[i], x[i + 1]
        for r in range(q):
            t = 0.0
            for k in range(q):
                t += inv[r, k] * nxt[k]
            x[i, r] -= c * t
    return x.ravel()


@njit(cache=True, fastmath=True)
def _arnoldi(basis, k, w, column):
    """Orthogonalize w against basis[0 .. k] (classical Gram-Schmidt, twice) into basis[k + 1].

    ``column[0 .. k]`` receives the coefficients and ``column[k + 1]`` the norm left (the new
    column of the Hessenberg matrix). Plain loops, not BLAS: a threaded BLAS on a loaded
    machine costs more than these memory-bound sweeps.
    """
    n = w.size
    for _ in range(2):
        for i in range(k + 1):
            v = basis[i]
            dot = 0.0
            for t in range(n):
                dot += v[t] * w[t]
            column[i] += dot
            for t in range(n):
                w[t] -= dot * v[t]
    norm = 0.0
    for t in range(n):
        norm += w[t] * w[t]
    norm = np.sqrt(norm)
    column[k + 1] = norm
    if norm > 0.0:
        for t in range(n):
            basis[k + 1, t] = w[t] / norm


@njit(cache=True)
def _givens(h, cs, sn, k):
    """Apply the k previous Givens rotations (cs, sn) to the Hessenberg column h (k + 2,), then
    the new k-th one that zeroes h[k + 1] (stored in cs[k], sn[k])."""
    for i in range(k):
        t = cs[i] * h[i] + sn[i] * h[i + 1]
        h[i + 1] = -sn[i] * h[i] + cs[i] * h[i + 1]
        h[i] = t
    r = np.hypot(h[k], h[k + 1])
    cs[k] = h[k] / r
    sn[k] = h[k + 1] / r
    h[k] = r
    h[k + 1] = 0.0


@njit(cache=True, fastmath=True)
def _combine(coefficients, vectors):
    """sum_i coefficients[i] vectors[i] over the first len(coefficients) rows."""
    out = np.zeros(vectors.shape[1])
    for i in range(coefficients.size):
        c = coefficients[i]
        v = vectors[i]
        for t in range(out.size):
            out[t] += c * v[t]
    return out


def gmres(matvec, precondition, rhs: np.ndarray, tolerance: float, max_iterations: int,
          max_cycles: int = 4, product=None) -> tuple[np.ndarray, float, int]:
    """Right-preconditioned (flexible) GMRES for A x = rhs, restarted on the true residual.

    Each cycle builds a Krylov space of at most ``max_iterations`` on the current residual until
    the Givens estimate of the residual reaches ``tolerance``; on an ill-conditioned A the true
    residual can stay well above that estimate (loss of orthogonality), so the cycle ends with
    the true residual and, while it is above ``tolerance`` and still halving, another cycle
    starts from it.

    Parameters
    ----------
    matvec, precondition : callable
        v -> A v and v -> M^-1 v on (N,) vectors.
    rhs : numpy.ndarray
        (N,) right-hand side.
    tolerance : float
        Relative residual |rhs - A x| / |rhs| sought.
    max_iterations : int
        Krylov dimension of a cycle at most.
    max_cycles : int
        Cycles at most.
    product : callable, optional
        v -> A M^-1 v given v and M^-1 v, when the preconditioner yields it more cheaply than
        ``matvec`` (the Krylov steps use it; the cycles' true residuals still use ``matvec``).

    Returns
    -------
    tuple
        x (N,), its relative residual |rhs - A x| / |rhs| (computed, not estimated) and the
        iterations of all cycles.
    """
    beta = float(np.sqrt(np.einsum("i,i->", rhs, rhs)))  # einsum: no threaded BLAS
    x = np.zeros_like(rhs)
    if beta == 0.0:
        return x, 0.0, 0
    left, residual, total = rhs, 1.0, 0
    for _ in range(max_cycles):
        x_cycle, k = _gmres_cycle(matvec if product is None else product, precondition, left,
                                  tolerance / residual, max_iterations, product is not None)
        x += x_cycle
        total += k
        left = rhs - matvec(x)
        previous, residual = residual, float(np.sqrt(np.einsum("i,i->", left, left))) / beta
        if residual <= tolerance or residual > 0.5 * previous:
            break
    return x, residual, total


def _gmres_cycle(matvec, precondition, rhs, tolerance, max_iterations, paired=False):
    """One GMRES cycle from x = 0: (x, iterations), stopping on the Givens residual estimate.

    ``paired``: ``matvec`` is called as ``matvec(v, M^-1 v)`` (see :func:`gmres`).
    """
    beta = float(np.sqrt(np.einsum("i,i->", rhs, rhs)))
    basis = np.empty((max_iterations + 1, rhs.size))
    directions = np.empty((max_iterations, rhs.size))
    hess = np.zeros((max_iterations + 1, max_iterations))
    cs = np.zeros(max_iterations)
    sn = np.zeros(max_iterations)
    g = np.zeros(max_iterations + 1)
    g[0] = beta
    basis[0] = rhs / beta
    estimate, k = 1.0, 0
    while k < max_iterations and estimate > tolerance:
        directions[k] = precondition(basis[k])
        column = np.zeros(k + 2)
        w = matvec(basis[k], directions[k]) if paired else matvec(directions[k])
        _arnoldi(basis, k, w, column)
        _givens(column, cs, sn, k)
        hess[: k + 2, k] = column
        g[k + 1] = -sn[k] * g[k]
        g[k] = cs[k] * g[k]
        estimate = abs(g[k + 1]) / beta
        k += 1
    return _combine(np.linalg.solve(np.triu(hess[:k, :k]), g[:k]), directions), k


@njit(cache=True)
def restrict(x, polynomials, d, n_shapes):
    """Z^T x (S q,) for x (N,), Z = P (x) I_d every shape's coarse basis (:class:`GridLayout`).

    ``polynomials`` P (n + 1, K): one coordinate's orthonormal basis over the points (folded
    order); Z's other entries are zero, so this costs N K, not N d K.
    """
    n_points, k = polynomials.shape
    m, q = n_points * d, k * d
    out = np.zeros(n_shapes * q)
    column = np.empty(k)
    for i in range(n_shapes):
        shape = x[i * m:(i + 1) * m]
        for c in range(d):
            column[:] = 0.0
            for p in range(n_points):
                xp = shape[p * d + c]
                row = polynomials[p]
                for j in range(k):
                    column[j] += row[j] * xp
            out[i * q + c: (i + 1) * q: d] = column
    return out


@njit(cache=True, fastmath=True)
def prolong(e, polynomials, d, n_shapes):
    """Z e (N,) for coarse e (S q,), with Z and ``polynomials`` as in :func:`restrict`."""
    n_points, k = polynomials.shape
    m, q = n_points * d, k * d
    out = np.empty(n_shapes * m)
    column = np.empty(k)
    for i in range(n_shapes):
        for c in range(d):
            column[:] = e[i * q + c: (i + 1) * q: d]
            for p in range(n_points):
                row = polynomials[p]
                t = 0.0
                for j in range(k):
                    t += row[j] * column[j]
                out[i * m + p * d + c] = t
    return out


def plane_of(points: np.ndarray, tolerance: float = 1e-12) -> tuple[np.ndarray | None, tuple]:
    """The plane holding all ``points`` (k, 3), if any: (rotation, coordinates solved for).

    A problem whose start and target lie in one plane keeps every shape in it: the cost is
    symmetric about the plane, so its gradient has no normal component and the Hessian does not
    couple normal and in-plane coordinates; the Newton steps have no normal component. Returns

    * ``(None, (a, b))`` when a coordinate is exactly constant (an axis plane): solve for the
      other two, no rotation;
    * ``(R, (0, 1))`` when the points lie in another plane (smallest singular value of the
      centred points <= ``tolerance`` times the largest): ``R`` (3, 3) rotates them, ``x @ R.T``,
      so that the plane's normal is the third coordinate;
    * ``(None, (0, 1, 2))`` otherwise.
    """
    for c in range(3):
        if np.ptp(points[:, c]) == 0.0:
            return None, tuple(k for k in range(3) if k != c)
    sv, vt = np.linalg.svd(points - points.mean(axis=0), full_matrices=False)[1:]
    if sv[2] <= tolerance * sv[0]:
        return vt, (0, 1)
    return None, (0, 1, 2)


def folded_order(n_points: int) -> np.ndarray:
    """Points in the order 0, n, 1, n-1, 2, ... (position -> point index), (n + 1,)."""
    order = np.empty(n_points, dtype=np.int64)
    order[0::2] = np.arange((n_points + 1) // 2)
    order[1::2] = n_points - 1 - np.arange(n_points // 2)
    return order


@dataclass(frozen=True, eq=False)
class GridLayout:
    """Where every Hessian entry of the advanced stage goes, fixed for (n, S, coordinates).

    Attributes
    ----------
    n_shapes, n_points : int
        S and n + 1.
    coords : tuple of int
        The coordinates solved for (all three, or the two of a problem's plane).
    index : numpy.ndarray
        (S, n + 1, 3) position of each (shape, point, coordinate) in the solver's vectors, -1
        for a coordinate not solved for.
    half_band : int
        kl of the within-shape bands.
    slots : numpy.ndarray
        Flat band position of each within-shape Hessian entry kept (see :meth:`band`).
    pick : numpy.ndarray
        For each, the index of its value (see :func:`hessian_entries`).
    polynomials : numpy.ndarray
        (n + 1, K) orthonormalized Chebyshev polynomials over one shape's points, folded order.
    basis : numpy.ndarray
        (d (n + 1), q = d K) the coarse basis of one shape, ``polynomials`` (x) I_d (each
        coordinate its own polynomials; orthonormal).
    """

    n_shapes: int
    n_points: int
    coords: tuple[int, ...]
    index: np.ndarray
    half_band: int
    slots: np.ndarray
    pick: np.ndarray
    polynomials: np.ndarray
    basis: np.ndarray

    @property
    def size(self) -> int:
        return self.n_shapes * self.n_points * len(self.coords)

    @cached_property
    def _solved(self) -> tuple[np.ndarray, np.ndarray]:
        """The flat positions in (S, n + 1, 3) solved for, and their indices in (N,)."""
        flat = self.index.ravel()
        kept = np.flatnonzero(flat >= 0)
        return kept, flat[kept]

    def gather(self, full: np.ndarray) -> np.ndarray:
        """The solver's (N,) vector of a full (S, n + 1, 3) array (the coordinates solved for)."""
        kept, solver = self._solved
        out = np.empty(self.size)
        out[solver] = full.ravel()[kept]
        return out

    def scatter(self, reduced: np.ndarray) -> np.ndarray:
        """The full (S, n + 1, 3) array of a solver's (N,) vector, zero where not solved for."""
        kept, solver = self._solved
        out = np.zeros(self.index.size)
        out[kept] = reduced[solver]
        return out.reshape(self.index.shape)

    def band(self, values: np.ndarray, diagonal: np.ndarray) -> np.ndarray:
        """The (N, 3 kl + 1) band of the within-shape Hessian (layout of :func:`band_lu`).

        ``values``: the concatenated shape bands and clip blocks (see :func:`hessian_entries`),
        ``diagonal`` (S,) the transversal term's diagonal of each shape.
        """
        kl, size = self.half_band, self.size
        band = scatter_add(self.slots, values, self.pick, (3 * kl + 1) * size)
        band = band.reshape(size, 3 * kl + 1)
        band[:, 2 * kl] += np.repeat(diagonal, size // self.n_shapes)
        return band


@njit(cache=True)
def scatter_add(slots, values, pick, size):
    """(size,) zeros plus ``values[pick[t]]`` at ``slots[t]`` for every t, added in that order
    (``np.bincount(slots, weights=values[pick], minlength=size)`` without the copies)."""
    out = np.zeros(size)
    for t in range(slots.size):
        out[slots[t]] += values[pick[t]]
    return out


@njit(cache=True)
def shape_bands(inner, k_s, rest_lengths, k_b, rest_angles):
    """The lower Hessian bands (S, 9, 3(n + 1)) of every shape's axial and bending energy.

    The compiled kernel of the static core (:func:`dloplan.physics.compiled.chain_derivatives`,
    ``band[k, j] = H[j + k, j]``), shape by shape, weightless: ``k_s``, ``rest_lengths`` (n,),
    ``k_b`` and ``rest_angles`` (S, n - 1) as for a spring chain.
    """
    n_shapes, n_points, _ = inner.shape
    bands = np.empty((n_shapes, 9, 3 * n_points))
    grad = np.empty((n_points, 3))
    no_mass = np.zeros(n_points)
    no_gravity = np.zeros(3)
    for i in range(n_shapes):
        chain_derivatives(inner[i], k_s, rest_lengths, k_b, rest_angles[i], no_mass,
                          no_gravity, grad, bands[i])
    return bands


@njit(cache=True)
def shape_costs(inner, k_s, rest_lengths, k_b, rest_angles):
    """The summed axial and bending energy of every shape and its gradient (S, n + 1, 3).

    The static core's compiled energy and gradient
    (:func:`dloplan.physics.compiled.chain_gradient`), shape by shape, weightless, with the
    arguments of :func:`shape_bands`.
    """
    n_shapes, n_points, _ = inner.shape
    grad = np.empty_like(inner)
    no_mass = np.zeros(n_points)
    no_gravity = np.zeros(3)
    total = 0.0
    for i in range(n_shapes):
        total += chain_gradient(inner[i], k_s, rest_lengths, k_b, rest_angles[i], no_mass,
                                no_gravity, grad[i])
    return total, grad


def hessian_entries(n_links: int, n_shapes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the within-shape Hessian entries are, over the flattened (S, n + 1, 3).

    The values come from ``np.concatenate([bands.ravel(), clip.ravel()])`` with the shapes'
    lower bands (S, 9, 3(n + 1)) of :func:`shape_bands` and the clip term's blocks (S, 12, 12)
    over the points (0, 1, n-1, n).

    Returns
    -------
    tuple
        rows, cols and, for each, the index of its value in that concatenation (a band entry
        below the diagonal appears twice, as (i, j) and (j, i)).
    """
    m = 3 * (n_links + 1)
    i, k, j = np.meshgrid(np.arange(n_shapes), np.arange(9), np.arange(m), indexing="ij")
    pick = np.arange(i.size).reshape(i.shape)
    inside = j + k < m
    low_r, low_c, low_p = (i * m + j + k)[inside], (i * m + j)[inside], pick[inside]
    below = (k > 0)[inside]
    clip_points = np.array([0, 1, n_links - 1, n_links])
    local = (3 * clip_points[:, None] + np.arange(3)).ravel()
    coords = (m * np.arange(n_shapes))[:, None] + local[None]  # (S, 12)
    clip_r = np.broadcast_to(coords[:, :, None], (n_shapes, 12, 12)).ravel()
    clip_c = np.broadcast_to(coords[:, None, :], (n_shapes, 12, 12)).ravel()
    clip_p = i.size + np.arange(clip_r.size)
    return (np.concatenate([low_r, low_c[below], clip_r]),
            np.concatenate([low_c, low_r[below], clip_c]),
            np.concatenate([low_p, low_p[below], clip_p]))


def grid_layout(n_links: int, n_shapes: int, coords: tuple[int, ...] = (0, 1, 2),
                entries: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> GridLayout:
    """The :class:`GridLayout` of S shapes of n links, solving for ``coords``; ``entries``:
    :func:`hessian_entries` of (n, S) when the caller has them already."""
    n_points = n_links + 1
    d = len(coords)
    order = folded_order(n_points)
    position = np.empty(n_points, dtype=np.int64)
    position[order] = np.arange(n_points)
    m = d * n_points
    index = -np.ones((n_shapes, n_points, 3), dtype=np.int64)
    for c_new, c in enumerate(coords):
        index[:, :, c] = (np.arange(n_shapes)[:, None] * m + position[None, :] * d + c_new)
    rows, cols, pick = entries if entries is not None else hessian_entries(n_links, n_shapes)
    r, c = index.ravel()[rows], index.ravel()[cols]
    # the (9, 3(n + 1)) band of a shape holds entries of points 3 apart, zero by structure
    # (bending couples points j .. j + 2): kept, they would widen the band from 5d - 1 to 7d - 1
    coupled = (pick >= n_shapes * 9 * 3 * n_points) | (np.abs(rows // 3 - cols // 3) <= 2)
    kept = (r >= 0) & (c >= 0) & coupled
    r, c, pick = r[kept], c[kept], pick[kept]
    kl = int(np.max(np.abs(r - c)))
    slots = c * (3 * kl + 1) + 2 * kl + r - c
    degree = min(COARSE_DEGREE, n_points)
    t = np.linspace(-1.0, 1.0, n_points)[order]
    cheb = np.polynomial.chebyshev.chebvander(t, degree - 1)  # (n + 1, K), folded rows
    polynomials = np.ascontiguousarray(np.linalg.qr(cheb)[0])
    basis = np.kron(polynomials, np.eye(d))  # row p d + c, column k d + c
    return GridLayout(n_shapes, n_points, tuple(coords), index, kl, slots, pick, polynomials,
                      basis)


@dataclass(eq=False)
class GridNewton:
    """The Newton system H p = r at one iterate, solved by preconditioned GMRES.

    Parameters
    ----------
    layout : GridLayout
        The problem's layout.
    band : numpy.ndarray
        (N, 3 kl + 1) within-shape band with the transversal diagonal (:meth:`GridLayout.band`).
    coupling : numpy.ndarray
        (S - 1,) the transversal term's off-diagonal between shapes i and i + 1 (the entry of
        A, times the identity of the points' coordinates).
    """

    layout: GridLayout
    band: np.ndarray
    coupling: np.ndarray

    def __post_init__(self):
        kl = self.layout.half_band
        self._compact = np.ascontiguousarray(self.band[:, kl:])  # without the room for fill

    def matvec(self, x: np.ndarray, shift: float = 0.0) -> np.ndarray:
        """(H + shift I) x for x (N,)."""
        return grid_matvec(self._compact, self.layout.half_band, self.coupling, shift, x)

    @cached_property
    def _coarse_blocks(self) -> np.ndarray:
        """The diagonal blocks Z^T H_ii Z (S, q, q) of the Galerkin operator (computed once per
        Hessian: a retry with another shift only adds shift I, as Z^T Z = I)."""
        lay = self.layout
        return galerkin_blocks(self.band, lay.half_band, lay.basis, lay.n_shapes)

    def solve(self, rhs: np.ndarray, shift: float = 0.0,
              tolerance: float = KRYLOV_TOLERANCE) -> np.ndarray | None:
        """p with (H + shift I) p = rhs to a relative residual ``tolerance``, (N,); None when
        the solver cannot vouch for it (a singular band, or a residual above both
        ``tolerance`` and :data:`ACCEPTED_RESIDUAL`)."""
        lay = self.layout
        fine = self.band.copy()
        fine[:, 2 * lay.half_band] += shift
        fine_piv, ok = band_lu(fine, lay.half_band)
        coarse, ok_coarse = block_tridiagonal_factor(self._coarse_blocks, self.coupling, shift)
        if not (ok and ok_coarse):
            return None

        correction = []  # the last fine correction z of the preconditioner

        def precondition(r):
            x, z = two_level(r, coarse, self.coupling, lay.polynomials, len(lay.coords),
                             self._compact, fine, lay.half_band, fine_piv, shift)
            correction[:] = [z]
            return x

        def product(r, x):  # (H + shift I) x = r + C z for x = precondition(r): H + shift I
            y = r.copy()  # is the fine band F plus the coupling C between shapes, and
            add_coupling(y, self.coupling, correction[0])  # F x = F (x - z) + r - (H + shift
            return y  # I)(x - z) = r - C (x - z)

        step, residual, _ = gmres(lambda v: self.matvec(v, shift), precondition, rhs,
                                  tolerance, MAX_KRYLOV, product=product)
        if not (residual <= max(tolerance, ACCEPTED_RESIDUAL) and np.all(np.isfinite(step))):
            return None
        return step
