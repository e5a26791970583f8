"""Shape sensitivity: how a stabilized equilibrium moves with the clips and with E.

A stable equilibrium x*(p) of a cable held by two clips satisfies g_f(x*, p) = 0, the net force on
every free point (:func:`dloplan.sim.statics.equilibrium`). Differentiating that identity
(implicit function theorem) gives the first-order change of the whole shape:

    dx*_f / dp = -H_ff^-1 H_fh dh/dp,          dx*_h / dp = dh/dp,

where f are the free coordinates (points 2 .. n-2), h the twelve coordinates of the four held
points, H the Hessian of the energy (the tangent stiffness, :mod:`dloplan.physics.chain`) and
h(p) the held points as placed by the clips (:meth:`dloplan.sim.ClipPoses.held_points`).

The 12 clip coordinates p (:data:`CLIP_COORDINATES`) are the displacement of the first clip
point [m], a small rotation vector of the first clip [rad] (world frame, applied on the left:
R -> exp([phi]) R), then the same for the last clip; :func:`perturbed_clips` applies them. The
held points follow as h = c -/+ (l / 2) u with u = R e_x, so dh/dphi = -(+/- l/2)[u]_x.

Young's modulus scales the axial, bending and twisting stiffnesses alike (k = E x geometry), so
d g / d log E is the elastic part of the gradient; at equilibrium it balances the weight, and

    dx*_f / d log E = -H_ff^-1 g^el_f = -H_ff^-1 (m g)_f :

a stiffer cable sags less, exactly as if gravity were weaker. (In statics E and the mass enter
only through the ratio E / m: one sensitivity serves both.) A cable with an axial modulus of its
own (``Cable.axial_modulus``: the composite catalogue cables) keeps its axial springs when E
changes, so their part of the gradient (the links' tensions) is left out of g^el.

With torsion (:func:`dloplan.sim.torsion.equilibrium_with_twist`) the state also holds one twist
angle per link; the clips hold the two end links' angles too, and a small clip rotation phi turns
its held link's material frame about the link tangent t by phi . t (first order), besides moving
the held points. The same formula applies to the joint Hessian of points and angles, assembled
here from the public kernels (:func:`dloplan.physics.chain.hessian`,
:func:`dloplan.physics.twist.twist_derivatives`).

One factorization of H_ff (banded Cholesky, O(n)) serves all 13 right-hand sides.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..geometry import as_shape, tangents
from ..physics.axial import axial_gradient
from ..physics.chain import HALF_BANDWIDTH, SpringChain, gradient_and_hessian_band, hessian
from ..physics.compiled import chain_derivatives
from ..physics.twist import TwistChain, twist_derivatives
from .clips import HELD_INDICES, ClipPoses
from .compiled import held_response

CLIP_COORDINATES = (
    "first.x", "first.y", "first.z", "first.rx", "first.ry", "first.rz",
    "last.x", "last.y", "last.z", "last.rx", "last.ry", "last.rz",
)
"""Names of the 12 clip coordinates, in order: position [m] and rotation vector [rad] of each
clip (world frame)."""


@dataclass(frozen=True, eq=False)
class ShapeSensitivity:
    """First-order sensitivity of a stabilized shape (module docstring).

    Attributes
    ----------
    shape : numpy.ndarray
        (n + 1, 3) the equilibrium [m].
    clips : numpy.ndarray
        (n + 1, 3, 12) d x / d p: metres per metre (clip positions) and metres per radian (clip
        rotation vectors), in the order of :data:`CLIP_COORDINATES`.
    log_modulus : numpy.ndarray
        (n + 1, 3) d x / d log E [m] (zero at the held points).
    torsion : bool
        Whether the derivative includes the twist of the material frames.
    """

    shape: np.ndarray
    clips: np.ndarray
    log_modulus: np.ndarray
    torsion: bool = False

    def predict(self, delta_clips=None, delta_log_modulus: float = 0.0) -> np.ndarray:
        """The linearized shape after small changes of the clips (12,) and of log E, (n + 1, 3)."""
        x = self.shape.copy()
        if delta_clips is not None:
            x += self.clips @ np.asarray(delta_clips, dtype=float)
        return x + delta_log_modulus * self.log_modulus


def perturbed_clips(clips: ClipPoses, delta) -> ClipPoses:
    """Clip poses moved by the 12 clip coordinates ``delta`` (:data:`CLIP_COORDINATES`).

    Positions move by ``delta[0:3]``, ``delta[6:9]`` [m]; rotations turn by the world-frame
    rotation vectors ``delta[3:6]``, ``delta[9:12]`` [rad] (``exp([phi]) R``).
    """
    d = np.asarray(delta, dtype=float)
    if d.shape != (12,) or not np.all(np.isfinite(d)):
        raise ValueError(f"delta: expected 12 finite clip coordinates, got shape {d.shape}")
    turn = Rotation.from_rotvec(d.reshape(2, 2, 3)[:, 1])
    return ClipPoses(clips.positions + d.reshape(2, 2, 3)[:, 0], turn * clips.rotations)


def held_point_jacobian(clips: ClipPoses, link_length: float, clamp_links: int = 1
                        ) -> np.ndarray:
    """d h / d p: the held points w.r.t. the clip coordinates.

    Each gripper holds ``clamp_links`` links straight along its u-axis, centred on the clip
    point (:func:`held_indices`): point j of the first clip is c + o_j u with o_j = (j - k / 2) l,
    j = 0 .. k, and point n - j of the last clip likewise (k = 1: the four held points of
    :data:`HELD_INDICES`, o = -/+ l / 2). A rotation phi moves o u by o phi x u, so
    d h / d phi = -o [u]_x.

    Parameters
    ----------
    clips : ClipPoses
        The clip poses.
    link_length : float
        The rest length l of one link [m].
    clamp_links : int
        Links k held by each gripper (default 1, the model's own grip).

    Returns
    -------
    numpy.ndarray
        (2 (k + 1), 3, 12) [m/m, m/rad], the held points in the order of :func:`held_indices`.
    """
    k = _clamp(clamp_links)
    u = clips.u_axes
    offsets = (np.arange(k + 1) - 0.5 * k) * link_length
    jac = np.zeros((2, k + 1, 3, 12))  # per clip, its points in the order of held_indices
    for clip, o in ((0, offsets), (1, offsets[::-1])):
        jac[clip, :, :, 6 * clip : 6 * clip + 3] = np.eye(3)
        jac[clip, :, :, 6 * clip + 3 : 6 * clip + 6] = -o[:, None, None] * _cross_matrix(u[clip])
    return jac.reshape(2 * (k + 1), 3, 12)


def held_indices(n_points: int, clamp_links: int = 1) -> np.ndarray:
    """The points held by the two grippers, each clamping ``clamp_links`` links: 0 .. k and
    n - k .. n (k = 1: :data:`HELD_INDICES`), (2 (k + 1),)."""
    k = _clamp(clamp_links)
    return np.r_[0 : k + 1, n_points - k - 1 : n_points]


def _clamp(clamp_links) -> int:
    if isinstance(clamp_links, bool) or int(clamp_links) != clamp_links or clamp_links < 1:
        raise ValueError(f"clamp_links: got {clamp_links!r}, expected an integer >= 1")
    return int(clamp_links)


def _cross_matrix(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def equilibrium_sensitivity(
    cable: Cable, shape, clips: ClipPoses, *, gravity=GRAVITY, chain: SpringChain | None = None,
    clamp_links: int = 1,
) -> ShapeSensitivity:
    """Sensitivity of a stable equilibrium without torsion to the clips and to log E.

    Parameters
    ----------
    cable : Cable
        The cable.
    shape : array_like
        (n + 1, 3) a converged, stable equilibrium held by ``clips`` [m] (e.g.
        ``equilibrium(...).shape``); the derivative is that of the equilibrium branch through it.
    clips : ClipPoses
        The clip poses holding it.
    gravity : array_like
        Gravity [m/s^2].
    chain : SpringChain, optional
        The chain of ``cable`` under ``gravity`` (saves its construction in loops).
    clamp_links : int
        Links held by each gripper, straight along the clip's u-axis and centred on the clip
        point (default 1, the model's own grip; a finer chain holding the same length of cable
        holds several, :func:`dloplan.correct.model_error.clamped_equilibrium`): the free
        points are k + 1 .. n - k - 1.

    Returns
    -------
    ShapeSensitivity

    Raises
    ------
    ValueError
        For a shape with the wrong number of points, or one whose free Hessian is not positive
        definite (not a stable equilibrium: the derivative does not exist).
    """
    x = as_shape(shape, cable.n_points, "shape")
    if chain is None:
        chain = SpringChain.from_cable(cable, gravity)
    n_dof = 3 * cable.n_points
    g_elastic, band = _elastic_derivatives(chain, x)
    points = held_indices(cable.n_points, clamp_links)
    edge = 3 * len(points) // 2  # the held coordinates at either end
    dh = held_point_jacobian(clips, cable.rest_link_length, clamp_links).reshape(-1, 12)
    g_scaled = _modulus_gradient(cable, chain, x, g_elastic)
    solved = np.empty((n_dof - 2 * edge, 13))
    if not held_response(band, edge, dh, np.ascontiguousarray(g_scaled).ravel(), solved):
        raise ValueError("shape: the free Hessian is not positive definite (not a stable "
                         "equilibrium), its sensitivity is undefined")
    return _assemble(x, dh, solved[:, :12], solved[:, 12], torsion=False, held=points)


def _elastic_derivatives(chain: SpringChain, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Elastic gradient (n + 1, 3) [N] and lower Hessian band [N/m], in the compiled kernel.

    :func:`dloplan.physics.compiled.chain_derivatives` with zero gravity (the weight is linear:
    no Hessian, and it is not part of d g / d log E); a chain with contacts takes the general
    :func:`dloplan.physics.chain.gradient_and_hessian_band`.
    """
    if chain.contacts:
        return gradient_and_hessian_band(chain, x)
    k_s, rest_lengths, k_b, rest_angles, masses, _ = chain.constants
    grad = np.empty(x.shape)
    band = np.empty((HALF_BANDWIDTH + 1, x.size))
    chain_derivatives(np.ascontiguousarray(x), k_s, rest_lengths, k_b, rest_angles, masses,
                      np.zeros(3), grad, band)
    return grad, band


def _modulus_gradient(cable: Cable, chain: SpringChain, x: np.ndarray,
                      g_elastic: np.ndarray) -> np.ndarray:
    """d g / d log E (n + 1, 3) [N]: the elastic gradient, without the axial springs' part when
    the cable has an axial modulus of its own (it does not change with E)."""
    if cable.axial_modulus is None:
        return g_elastic
    return g_elastic - axial_gradient(x, chain.k_axial, chain.rest_lengths)


def _assemble(x, dh, free_clips, free_log_modulus, torsion: bool,
              held=HELD_INDICES) -> ShapeSensitivity:
    """The (n + 1)-point derivatives from the held points' ``dh`` and the free points' solves
    (``held``: the held indices, :func:`held_indices`)."""
    n_points = len(x)
    edge = len(held) // 2
    free = slice(edge, n_points - edge)
    jac = np.zeros((n_points, 3, 12))
    jac[list(held)] = dh.reshape(len(held), 3, 12)
    jac[free] = free_clips.reshape(n_points - len(held), 3, 12)
    dlog = np.zeros((n_points, 3))
    dlog[free] = free_log_modulus.reshape(n_points - len(held), 3)
    return ShapeSensitivity(x, jac, dlog, torsion)


def twist_equilibrium_sensitivity(
    cable: Cable,
    equilibrium,
    *,
    natural_twist: float = 0.0,
    gravity=GRAVITY,
) -> ShapeSensitivity:
    """Sensitivity of a stable equilibrium with torsion to the clips and to log E.

    Parameters
    ----------
    cable : Cable
        The cable.
    equilibrium : TwistEquilibrium
        A converged, stable result of :func:`dloplan.sim.torsion.equilibrium_with_twist`
        (its shape, directors and clips are used).
    natural_twist : float
        The natural twist it was solved with [rad].
    gravity : array_like
        Gravity [m/s^2].

    Returns
    -------
    ShapeSensitivity
        The shape's derivatives (the twist angles' are solved for and dropped).
    """
    x = as_shape(equilibrium.shape, cable.n_points, "equilibrium.shape")
    d1 = np.asarray(equilibrium.directors, dtype=float)
    if d1.shape != (cable.n_links, 3):
        raise ValueError(f"equilibrium.directors: expected shape ({cable.n_links}, 3), "
                         f"got {d1.shape}")
    clips = equilibrium.clips
    tc = TwistChain.from_cable(cable, natural_twist)
    chain = SpringChain.from_cable(cable, gravity)
    if tc.directional:  # as in equilibrium_with_twist: the directional term replaces rest angles
        chain = replace(chain, rest_angles=np.zeros_like(chain.rest_angles))
    n_links = cable.n_links
    n_points = cable.n_points
    # interleaved coordinates (x_i, y_i, z_i, theta_i), theta in radians, last point without one
    point_dofs = (4 * np.arange(n_points)[:, None] + np.arange(3)).ravel()
    angle_dofs = 4 * np.arange(n_links) + 3
    n_dof = 4 * n_links + 3
    pos = hessian(chain, x).tocoo()
    t = tangents(x)
    td = twist_derivatives(tc, x, t, d1, np.zeros(n_links))
    stencil = 4 * np.arange(n_links - 1)[:, None] + np.arange(11)  # point s, angle s, ..., s + 2
    rows = np.broadcast_to(stencil[:, :, None], td.blocks.shape)
    cols = np.broadcast_to(stencil[:, None, :], td.blocks.shape)
    joint = sp.coo_matrix(
        (np.concatenate([pos.data, td.blocks.ravel()]),
         (np.concatenate([point_dofs[pos.row], rows.ravel()]),
          np.concatenate([point_dofs[pos.col], cols.ravel()]))),
        shape=(n_dof, n_dof),
    ).tocsr()
    g_elastic = np.zeros(n_dof)
    g_points = _modulus_gradient(cable, chain, x, gradient_and_hessian_band(chain, x)[0])
    g_elastic[point_dofs] = (g_points + td.twist_gradient + td.direction_gradient).ravel()
    g_elastic[angle_dofs] = td.angle_gradient
    held_points = np.r_[point_dofs[:6], point_dofs[-6:]]
    held = np.r_[held_points, angle_dofs[[0, -1]]]
    free = np.setdiff1d(np.arange(n_dof), held)
    dh = held_point_jacobian(clips, cable.rest_link_length).reshape(12, 12)
    # a clip rotation phi turns its held link's frame about the link tangent by phi . t
    d_angles = np.zeros((2, 12))
    d_angles[0, 3:6] = t[0]
    d_angles[1, 9:12] = t[-1]
    d_held = np.concatenate([dh, d_angles])
    h_ff = joint[free][:, free].tocsc()
    rhs = np.concatenate([-(joint[free][:, held] @ d_held), -g_elastic[free, None]], axis=1)
    try:
        solved = spla.splu(h_ff).solve(rhs)
    except RuntimeError as exc:
        raise ValueError(f"equilibrium: the free Hessian is singular ({exc})") from exc
    free_points = np.searchsorted(free, point_dofs[6:-6])
    return _assemble(x, dh, solved[free_points, :12], solved[free_points, 12], torsion=True)


__all__ = [
    "CLIP_COORDINATES",
    "ShapeSensitivity",
    "equilibrium_sensitivity",
    "held_indices",
    "held_point_jacobian",
    "perturbed_clips",
    "twist_equilibrium_sensitivity",
]
