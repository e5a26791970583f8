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
  Z^T H Z on that coarse space is block-tridiagonal in the shape index, a band of half-width
  2dK - 1, solved exactly;
* **GMRES** (right-preconditioned, :func:`gmres`) on H with the two-level preconditioner
  "coarse solve, then the shapes' bands on its residual" converges in 5-60 iterations, each
  O(n S d K) (a symmetric variant with a second coarse solve saved only 5 % of them).

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
from ..physics.compiled import chain_derivatives

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
def galerkin_blocks(ab, kl, basis, n_shapes):
    """The diagonal blocks Z^T A_ii Z (S, q, q) of a shape-block-diagonal band A.

    ``ab``: (S m, 3 kl + 1) unfactored band in the layout of :func:`band_lu`, no entry coupling
    two shapes; ``basis`` Z (m, q) one shape's coarse basis. O(S m q (kl + q)).
    """
    m, q = basis.shape
    kv = 2 * kl
    out = np.zeros((n_shapes, q, q))
    az = np.empty((m, q))
    for i in range(n_shapes):
        offset = i * m
        az[:] = 0.0
        for j in range(m):  # column j of A_ii times row j of Z
            zj = basis[j]
            for p in range(max(0, j - kl), min(m, j + kl + 1)):
                a = ab[offset + j, kv + p - j]
                if a != 0.0:
                    row = az[p]
                    for c in range(q):
                        row[c] += a * zj[c]
        block = out[i]
        for p in range(m):
            zp, row = basis[p], az[p]
            for r in range(q):
                z = zp[r]
                for c in range(q):
                    block[r, c] += z * row[c]
    return out


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
          max_cycles: int = 4) -> tuple[np.ndarray, float, int]:
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
        x_cycle, k = _gmres_cycle(matvec, precondition, left, tolerance / residual,
                                  max_iterations)
        x += x_cycle
        total += k
        left = rhs - matvec(x)
        previous, residual = residual, float(np.sqrt(np.einsum("i,i->", left, left))) / beta
        if residual <= tolerance or residual > 0.5 * previous:
            break
    return x, residual, total


def _gmres_cycle(matvec, precondition, rhs, tolerance, max_iterations):
    """One GMRES cycle from x = 0: (x, iterations), stopping on the Givens residual estimate."""
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
        _arnoldi(basis, k, matvec(directions[k]), column)
        _givens(column, cs, sn, k)
        hess[: k + 2, k] = column
        g[k + 1] = -sn[k] * g[k]
        g[k] = cs[k] * g[k]
        estimate = abs(g[k + 1]) / beta
        k += 1
    return _combine(np.linalg.solve(np.triu(hess[:k, :k]), g[:k]), directions), k


@njit(cache=True)
def shapewise(x, matrix, n_shapes):
    """Every shape's slice of x (S rows,) times ``matrix`` (rows, cols): (S cols,).

    With the coarse basis Z (m, q) of one shape, Z^T r = ``shapewise(r, Z, S)`` (restriction)
    and Z e = ``shapewise(e, Z.T, S)`` (prolongation).
    """
    rows, cols = matrix.shape
    out = np.zeros(n_shapes * cols)
    for i in range(n_shapes):
        for p in range(rows):
            xp = x[i * rows + p]
            for c in range(cols):
                out[i * cols + c] += matrix[p, c] * xp
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
    basis : numpy.ndarray
        (d (n + 1), q) orthonormal coarse basis of one shape, in the folded point order.
    """

    n_shapes: int
    n_points: int
    coords: tuple[int, ...]
    index: np.ndarray
    half_band: int
    slots: np.ndarray
    pick: np.ndarray
    basis: np.ndarray

    @property
    def size(self) -> int:
        return self.n_shapes * self.n_points * len(self.coords)

    def gather(self, full: np.ndarray) -> np.ndarray:
        """The solver's (N,) vector of a full (S, n + 1, 3) array (the coordinates solved for)."""
        flat = self.index.ravel()
        out = np.empty(self.size)
        out[flat[flat >= 0]] = full.ravel()[flat >= 0]
        return out

    def scatter(self, reduced: np.ndarray) -> np.ndarray:
        """The full (S, n + 1, 3) array of a solver's (N,) vector, zero where not solved for."""
        flat = self.index.ravel()
        out = np.zeros(flat.size)
        out[flat >= 0] = reduced[flat[flat >= 0]]
        return out.reshape(self.index.shape)

    def band(self, values: np.ndarray, diagonal: np.ndarray) -> np.ndarray:
        """The (N, 3 kl + 1) band of the within-shape Hessian (layout of :func:`band_lu`).

        ``values``: the concatenated shape bands and clip blocks (see :func:`hessian_entries`),
        ``diagonal`` (S,) the transversal term's diagonal of each shape.
        """
        kl, size = self.half_band, self.size
        band = np.bincount(self.slots, weights=values[self.pick],
                           minlength=(3 * kl + 1) * size).reshape(size, 3 * kl + 1)
        band[:, 2 * kl] += np.repeat(diagonal, size // self.n_shapes)
        return band


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


def grid_layout(n_links: int, n_shapes: int, coords: tuple[int, ...] = (0, 1, 2)) -> GridLayout:
    """The :class:`GridLayout` of S shapes of n links, solving for ``coords``."""
    n_points = n_links + 1
    d = len(coords)
    order = folded_order(n_points)
    position = np.empty(n_points, dtype=np.int64)
    position[order] = np.arange(n_points)
    m = d * n_points
    index = -np.ones((n_shapes, n_points, 3), dtype=np.int64)
    for c_new, c in enumerate(coords):
        index[:, :, c] = (np.arange(n_shapes)[:, None] * m + position[None, :] * d + c_new)
    rows, cols, pick = hessian_entries(n_links, n_shapes)
    r, c = index.ravel()[rows], index.ravel()[cols]
    kept = (r >= 0) & (c >= 0)
    r, c, pick = r[kept], c[kept], pick[kept]
    kl = int(np.max(np.abs(r - c)))
    slots = c * (3 * kl + 1) + 2 * kl + r - c
    degree = min(COARSE_DEGREE, n_points)
    t = np.linspace(-1.0, 1.0, n_points)[order]
    cheb = np.polynomial.chebyshev.chebvander(t, degree - 1)  # (n + 1, K), folded rows
    basis = np.einsum("pk,cd->pckd", cheb, np.eye(d)).reshape(m, degree * d)
    basis = np.linalg.qr(basis)[0]
    return GridLayout(n_shapes, n_points, tuple(coords), index, kl, slots, pick, basis)


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
        lay = self.layout
        y = band_matvec(self._compact, lay.half_band, x)
        if shift:
            y += shift * x
        xs, ys = x.reshape(lay.n_shapes, -1), y.reshape(lay.n_shapes, -1)
        ys[:-1] += self.coupling[:, None] * xs[1:]
        ys[1:] += self.coupling[:, None] * xs[:-1]
        return y

    @cached_property
    def _coarse_blocks(self) -> np.ndarray:
        """The diagonal blocks Z^T H_ii Z (S, q, q) of the Galerkin operator (computed once per
        Hessian: a retry with another shift only adds shift I, as Z^T Z = I)."""
        lay = self.layout
        return galerkin_blocks(self.band, lay.half_band, lay.basis, lay.n_shapes)

    def _coarse_band(self, shift: float) -> np.ndarray:
        """The Galerkin operator Z^T (H + shift I) Z as a band (half-width 2q - 1)."""
        lay = self.layout
        s, q = lay.n_shapes, lay.basis.shape[1]
        blocks = self._coarse_blocks + shift * np.eye(q)
        kc = 2 * q - 1
        band = np.zeros((s * q, 3 * kc + 1))
        r, c = np.meshgrid(np.arange(q), np.arange(q), indexing="ij")
        rows = (np.arange(s)[:, None, None] * q + r).ravel()
        cols = (np.arange(s)[:, None, None] * q + c).ravel()
        band[cols, 2 * kc + rows - cols] = blocks.ravel()
        diag = np.arange((s - 1) * q)
        band[diag + q, 2 * kc - q] = self.coupling.repeat(q)  # (i, i + 1): coupling * I
        band[diag, 2 * kc + q] = self.coupling.repeat(q)
        return band

    def solve(self, rhs: np.ndarray, shift: float = 0.0,
              tolerance: float = KRYLOV_TOLERANCE) -> np.ndarray | None:
        """p with (H + shift I) p = rhs to a relative residual ``tolerance``, (N,); None when
        the solver cannot vouch for it (a singular band, or a residual above both
        ``tolerance`` and :data:`ACCEPTED_RESIDUAL`)."""
        lay = self.layout
        s, q = lay.n_shapes, lay.basis.shape[1]
        fine = self.band.copy()
        fine[:, 2 * lay.half_band] += shift
        fine_piv, ok = band_lu(fine, lay.half_band)
        coarse = self._coarse_band(shift)
        kc = 2 * q - 1
        coarse_piv, ok_coarse = band_lu(coarse, kc)
        if not (ok and ok_coarse):
            return None

        prolongation = np.ascontiguousarray(lay.basis.T)

        def precondition(r):  # coarse, then the shapes' bands on the residual
            e = band_lu_solve(coarse, kc, coarse_piv, shapewise(r, lay.basis, s))
            x = shapewise(e, prolongation, s)
            return x + band_lu_solve(fine, lay.half_band, fine_piv, r - self.matvec(x, shift))

        step, residual, _ = gmres(lambda v: self.matvec(v, shift), precondition, rhs,
                                           tolerance, MAX_KRYLOV)
        if not (residual <= max(tolerance, ACCEPTED_RESIDUAL) and np.all(np.isfinite(step))):
            return None
        return step
