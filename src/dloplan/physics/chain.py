"""The whole mass-spring chain: total energy, forces split by spring type, sparse Hessian.

:class:`SpringChain` holds the constants of one discretized cable under one gravity field; the
functions below evaluate U = U^s + U^b + U^g (eqs. 3.6-3.8, 3.20, 3.28), its gradient and its
Hessian for a shape ``(n + 1, 3)`` [m] (energy and gradient also for a batch ``(..., n + 1, 3)``).

The Hessian couples a point with its two neighbours on each side (bending joints span three
points), so in the 3(n + 1) coordinates it is a symmetric band of half-width 8. It is assembled
once per call into that band by a ``bincount`` on index arrays fixed for the chain's size, and
is returned either banded (for the Cholesky solves of the static solver) or as a
``scipy.sparse`` matrix.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np
import scipy.sparse as sp

from ..cable import GRAVITY, Cable
from .axial import axial_energy, axial_gradient, axial_hessian_blocks, axial_link_forces
from .bending import bending_derivatives, bending_energy, bending_gradient
from .compiled import add_point_blocks, chain_derivatives, chain_energy, chain_term_gradients
from .contact import contact_energy, contact_gradient, contact_hessian_diagonal
from .gravity import gravity_energy, gravity_force

HALF_BANDWIDTH = 8
"""Half bandwidth of the Hessian in scalar coordinates (points i and i+2 are coupled)."""


@dataclass(frozen=True)
class Forces:
    """Per-point forces of a shape [N], each (..., n + 1, 3): the negative energy gradients.

    ``axial`` is F^s (eq. 3.17), ``bending`` is F^b (eq. 3.18), ``gravity`` is m_i g (eq. 3.20),
    ``contact`` the push of obstacles in contact (None without contacts), ``twist`` the
    twisting force F^t (eq. 3.19) of a cable with material frames (None without torsion).
    """

    axial: np.ndarray
    bending: np.ndarray
    gravity: np.ndarray
    contact: np.ndarray | None = None
    twist: np.ndarray | None = None

    @property
    def total(self) -> np.ndarray:
        """Sum of the parts [N]."""
        total = self.axial + self.bending + self.gravity
        for part in (self.contact, self.twist):
            if part is not None:
                total = total + part
        return total


@dataclass(frozen=True, eq=False)
class SpringChain:
    """Constants of the energy of one discretized cable.

    Parameters
    ----------
    k_axial : float
        k_s [N/m].
    rest_lengths : numpy.ndarray
        Rest link lengths l_i^0 [m], (n,).
    k_bending : float
        k_b [N m].
    rest_angles : numpy.ndarray
        Rest bending angles beta0 [rad], (n - 1,).
    point_masses : numpy.ndarray
        m_i [kg], (n + 1,).
    gravity : numpy.ndarray
        Gravity acceleration [m/s^2], (3,).
    contacts : tuple
        Obstacles the points cannot enter (one-sided penalty, :mod:`dloplan.physics.contact`).
    contact_radius : float
        Radius of the cable for contacts [m].
    contact_stiffness : float
        Penalty stiffness k_c [N/m].
    stiff_axial : bool
        The axial springs are much stiffer than the bending modulus gives them
        (:attr:`dloplan.cable.Cable.stiff_axial`): the static solvers correct their steps' link
        lengths.
    """

    k_axial: float
    rest_lengths: np.ndarray
    k_bending: float
    rest_angles: np.ndarray
    point_masses: np.ndarray
    gravity: np.ndarray
    contacts: tuple = ()
    contact_radius: float = 0.0
    contact_stiffness: float = 0.0
    stiff_axial: bool = False

    @classmethod
    def from_cable(cls, cable: Cable, gravity=GRAVITY, contacts=(),
                   contact_stiffness: float | None = None) -> SpringChain:
        """The chain of ``cable`` under ``gravity`` [m/s^2] (pass zeros for a weightless cable).

        Without contacts, the chain of a cable and gravity is built once and then reused.

        ``contacts``: obstacles the cable rests on or wraps around (pegs, plates, the table),
        with the penalty stiffness ``contact_stiffness`` [N/m] (default 100 E A / l: a hundred
        times the axial springs of the bending modulus E, so a composite cable's copper axial
        modulus does not make the penalty a thousand times stiffer).
        """
        g = np.asarray(gravity, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"gravity: got {gravity!r}, expected 3 finite numbers [m/s^2]")
        plain = not contacts and contact_stiffness is None
        key = tuple(g.tolist())
        if plain and key in _CHAINS.get(cable, {}):  # a cable is frozen: so is its chain
            return _CHAINS[cable][key]
        chain = cls(
            contacts=tuple(contacts),
            contact_radius=cable.diameter / 2,
            rest_lengths=np.full(cable.n_links, cable.rest_link_length),
            rest_angles=cable.rest_angles,
            point_masses=cable.point_masses,
            gravity=g,
            **_moduli(cable, contact_stiffness),
        )
        if plain:
            _CHAINS.setdefault(cable, {})[key] = chain
        return chain

    @property
    def n_points(self) -> int:
        return len(self.point_masses)

    @cached_property
    def constants(self) -> tuple:
        """The arguments of the compiled kernels (:mod:`dloplan.physics.compiled`)."""
        return (float(self.k_axial), np.ascontiguousarray(self.rest_lengths, dtype=float),
                float(self.k_bending), np.ascontiguousarray(self.rest_angles, dtype=float),
                np.ascontiguousarray(self.point_masses, dtype=float),
                np.ascontiguousarray(self.gravity, dtype=float))



_CHAINS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""The contact-free chains built so far, per cable (while it lives) and gravity: solvers called
in loops (studies, continuations) build each once."""


@lru_cache(maxsize=64)
def _band_index(n_points: int) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """Flat indices into the lower band (HALF_BANDWIDTH + 1, 3 n_points) of every block entry.

    One (index, keep) pair for the axial 6x6 blocks and one for the bending 9x9 blocks, in the
    order the kernels return them; ``keep`` marks the entries on or below the diagonal.
    """
    n_dof = 3 * n_points

    def block_targets(n_blocks: int, size: int) -> tuple[np.ndarray, np.ndarray]:
        start = 3 * np.arange(n_blocks)[:, None, None]
        rows = start + np.arange(size)[None, :, None]
        cols = start + np.arange(size)[None, None, :]
        rows, cols = np.broadcast_arrays(rows, cols)
        lower = (rows >= cols).ravel()
        flat = ((rows - cols) * n_dof + cols).ravel()
        return flat[lower], lower

    return block_targets(n_points - 1, 6), block_targets(n_points - 2, 9)


def energy(chain: SpringChain, x: np.ndarray) -> np.ndarray:
    """Total potential energy U [J] of shape(s) ``x`` (..., n + 1, 3)."""
    total = (
        axial_energy(x, chain.k_axial, chain.rest_lengths)
        + bending_energy(x, chain.k_bending, chain.rest_angles)
        + gravity_energy(x, chain.point_masses, chain.gravity)
    )
    if chain.contacts:
        total = total + _contact_energy(chain, x)
    return total


def _contact_energy(chain: SpringChain, x: np.ndarray):
    return contact_energy(x, chain.contacts, chain.contact_radius, chain.contact_stiffness)


def _contact_gradient(chain: SpringChain, x: np.ndarray) -> np.ndarray:
    return contact_gradient(x, chain.contacts, chain.contact_radius, chain.contact_stiffness)


def energy_terms(chain: SpringChain, x: np.ndarray) -> dict[str, np.ndarray]:
    """The axial, bending, gravity (and contact) parts of U [J], each of shape (...)."""
    terms = {
        "axial": axial_energy(x, chain.k_axial, chain.rest_lengths),
        "bending": bending_energy(x, chain.k_bending, chain.rest_angles),
        "gravity": gravity_energy(x, chain.point_masses, chain.gravity),
    }
    if chain.contacts:
        terms["contact"] = _contact_energy(chain, x)
    return terms


def gradient(chain: SpringChain, x: np.ndarray) -> np.ndarray:
    """dU/dx [N], shape (..., n + 1, 3)."""
    grad = (
        axial_gradient(x, chain.k_axial, chain.rest_lengths)
        + bending_gradient(x, chain.k_bending, chain.rest_angles)
        - gravity_force(chain.point_masses, chain.gravity)
    )
    if chain.contacts:
        grad += _contact_gradient(chain, x)
    return grad


def forces(chain: SpringChain, x: np.ndarray) -> Forces:
    """Per-point axial, bending and gravity forces [N] of shape(s) x (eqs. 3.17, 3.18, 3.20)."""
    weight = np.broadcast_to(gravity_force(chain.point_masses, chain.gravity), x.shape)
    return Forces(
        axial=-axial_gradient(x, chain.k_axial, chain.rest_lengths),
        bending=-bending_gradient(x, chain.k_bending, chain.rest_angles),
        gravity=weight.copy(),
        contact=-_contact_gradient(chain, x) if chain.contacts else None,
    )


def link_tensions(chain: SpringChain, x: np.ndarray) -> np.ndarray:
    """Axial force carried by each link [N], (..., n); positive in tension."""
    return axial_link_forces(x, chain.k_axial, chain.rest_lengths)


def hessian_band(
    chain: SpringChain, x: np.ndarray, terms: tuple[str, ...] = ("axial", "bending")
) -> np.ndarray:
    """Lower band of the Hessian; see :func:`gradient_and_hessian_band`."""
    return gradient_and_hessian_band(chain, x, terms)[1]


def gradient_and_hessian_band(
    chain: SpringChain, x: np.ndarray, terms: tuple[str, ...] = ("axial", "bending")
) -> tuple[np.ndarray, np.ndarray]:
    """Gradient of the selected terms [N] and the lower band of their Hessian [N/m].

    The band has shape (HALF_BANDWIDTH + 1, 3(n + 1)) and ``band[k, j] = H[j + k, j]``, the
    layout of ``scipy.linalg.cholesky_banded(lower=True)``.
    ``terms`` selects the springs whose Hessian is summed (gravity is linear: no Hessian), e.g.
    ``("bending",)`` for d F^b / dx = -H^b. Contacts (if the chain has any) are included with
    the axial term.
    """
    n_dof = 3 * chain.n_points
    (ax_index, ax_keep), (be_index, be_keep) = _band_index(chain.n_points)
    index, values = [], []
    grad = np.zeros(x.shape)
    if "axial" in terms:
        ax = axial_hessian_blocks(x, chain.k_axial, chain.rest_lengths).ravel()
        grad += axial_gradient(x, chain.k_axial, chain.rest_lengths)
        index.append(ax_index)
        values.append(ax[ax_keep])
    if "bending" in terms:
        be_grad, be = bending_derivatives(x, chain.k_bending, chain.rest_angles)
        grad += be_grad
        be = be.ravel()
        index.append(be_index)
        values.append(be[be_keep])
    if "axial" in terms and chain.contacts:
        grad += _contact_gradient(chain, x)
        diag = contact_hessian_diagonal(x, chain.contacts, chain.contact_radius,
                                        chain.contact_stiffness)
        rows = 3 * np.arange(chain.n_points)[:, None, None] + np.arange(3)[None, :, None]
        cols = 3 * np.arange(chain.n_points)[:, None, None] + np.arange(3)[None, None, :]
        lower = (rows >= cols)
        index.append(((rows - cols) * n_dof + cols)[np.broadcast_to(lower, diag.shape)])
        values.append(diag[np.broadcast_to(lower, diag.shape)])
    index = np.concatenate(index)
    values = np.concatenate(values)
    band = np.bincount(index, weights=values, minlength=(HALF_BANDWIDTH + 1) * n_dof)
    return grad, band.reshape(HALF_BANDWIDTH + 1, n_dof)


def shape_energy(chain: SpringChain, x: np.ndarray) -> float:
    """U [J] of one shape (n + 1, 3): :func:`energy` by the compiled kernel (contacts added)."""
    total = chain_energy(x, *chain.constants)
    if chain.contacts:
        total += float(_contact_energy(chain, x))
    return total


def shape_derivatives(chain: SpringChain, x: np.ndarray, grad: np.ndarray | None = None,
                      band: np.ndarray | None = None) -> tuple[float, np.ndarray, np.ndarray]:
    """Energy [J], gradient [N] and lower Hessian band [N/m] of one shape in one compiled pass.

    The same as :func:`energy`, :func:`gradient` (gravity included) and
    :func:`gradient_and_hessian_band`'s band (axial, bending and contacts), computed by
    :func:`dloplan.physics.compiled.chain_derivatives`. ``grad`` (n + 1, 3) and ``band``
    (HALF_BANDWIDTH + 1, 3(n + 1)) are filled in place when given.
    """
    if grad is None:
        grad = np.empty(x.shape)
    if band is None:
        band = np.empty((HALF_BANDWIDTH + 1, x.size))
    total = chain_derivatives(x, *chain.constants, grad, band)
    if chain.contacts:
        total += float(_contact_energy(chain, x))
        grad += _contact_gradient(chain, x)
        add_point_blocks(band, contact_hessian_diagonal(x, chain.contacts, chain.contact_radius,
                                                        chain.contact_stiffness))
    return total, grad, band


def shape_forces(chain: SpringChain, x: np.ndarray) -> Forces:
    """:func:`forces` of one shape (n + 1, 3) by the compiled kernel."""
    axial, bending = np.empty(x.shape), np.empty(x.shape)
    k_s, rest_lengths, k_b, rest_angles, *_ = chain.constants
    chain_term_gradients(x, k_s, rest_lengths, k_b, rest_angles, axial, bending)
    return Forces(
        axial=-axial,
        bending=-bending,
        gravity=gravity_force(chain.point_masses, chain.gravity),
        contact=-_contact_gradient(chain, x) if chain.contacts else None,
    )


def band_to_sparse(band: np.ndarray) -> sp.csr_matrix:
    """The symmetric sparse matrix whose lower band is ``band`` (see :func:`hessian_band`)."""
    n_dof = band.shape[1]  # fewer than the band's rows on a short chain (n = 4: 3 free dof)
    diagonals = [band[k, : n_dof - k] for k in range(min(band.shape[0], n_dof))]
    offsets = list(range(len(diagonals)))
    lower = sp.diags(diagonals, [-k for k in offsets], shape=(n_dof, n_dof))
    upper = sp.diags(diagonals[1:], offsets[1:], shape=(n_dof, n_dof))
    return (lower + upper).tocsr()


def sparse_to_band(matrix: sp.spmatrix, width: int = HALF_BANDWIDTH) -> np.ndarray:
    """Lower band (width + 1, N) of a symmetric sparse matrix: the inverse of
    :func:`band_to_sparse` (entries farther than ``width`` from the diagonal must be zero)."""
    coo = sp.tril(matrix).tocoo()
    band = np.zeros((width + 1, matrix.shape[0]))
    band[coo.row - coo.col, coo.col] = coo.data
    return band


def hessian(
    chain: SpringChain, x: np.ndarray, terms: tuple[str, ...] = ("axial", "bending")
) -> sp.csr_matrix:
    """Sparse Hessian d^2U/dx^2 [N/m], (3(n + 1), 3(n + 1)), coordinates ordered point-major.

    This is the tangent stiffness matrix of the shape (gravity is linear and does not enter);
    ``terms`` as in :func:`hessian_band`.
    """
    return band_to_sparse(hessian_band(chain, x, terms))


def _moduli(cable: Cable, contact_stiffness: float | None) -> dict:
    """The fields of :class:`SpringChain` that depend on the cable's moduli: k_s, k_b, the
    contact penalty (``contact_stiffness`` [N/m], or 100 E A / l when None) and stiff_axial."""
    return {"k_axial": cable.k_axial, "k_bending": cable.k_bending,
            "contact_stiffness": 100.0 * cable.youngs_modulus * cable.area
            / cable.rest_link_length if contact_stiffness is None else float(contact_stiffness),
            "stiff_axial": cable.stiff_axial}
