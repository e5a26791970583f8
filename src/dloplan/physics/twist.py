"""Twist springs and direction-aware bending of a cable with material frames (thesis 3.4.3, 3.9).

The state of a twisted cable is its points x (n + 1, 3) [m] and one material director m1_j per
link (:mod:`.rod_frames`). Two energies depend on the directors:

* **twist** (eqs. 3.14, 3.16): U^t = sum_i 1/2 k_t (psi_i - psibar_i)^2 over the interior points,
  psi_i the discrete twist between links i-1 and i and psibar_i = theta / (n - 1) the natural
  (rest) twist: the thesis' material twist theta spread evenly (3.4.3). k_t = G I_p / l.
* **bending with a direction** (3.9): for a curved rest shape, 1/2 k_b sum_i 1/2 sum_j
  |omega_i^j - omegabar_i^j|^2 with the material curvatures omega of :mod:`.rod_frames` and the
  rest ones omegabar measured on the rest shape in its rest frames. Since |omega| = beta, this is
  the torsion-free 1/2 k_b beta_i^2 (:mod:`.bending` with zero rest angles) plus the term
  U^d = 1/2 k_b sum_i (betabar_i^2 - sum_j omega_i^j . omegabar_i^j) computed here, which knows in
  which direction the cable is curved. For a straight rest shape U^d = 0 and the bending energy is
  exactly that of the torsion-free model.

Derivatives use a **chart** around a state: the directors of the links are written as
m1_j = R(t_j, theta_j) P(t0_j -> t_j) d0_j, the chart's reference directors d0 (at tangents t0)
carried to the current tangents by parallel transport and turned by the twist angles theta [rad].
:func:`twist_derivatives` returns the exact gradient with respect to the points and the angles and
the exact Hessian blocks of each interior point's stencil (points i-1, i, i+1 and angles i-1, i),
by second-order forward differentiation (:mod:`.jet`); the position gradient of U^t is the
twisting force of eq. 3.19 (its 8 terms per point are the contributions of the two neighbouring
stencils). At the chart's centre (t = t0, theta = 0) the angles measure the twist of each link
against the parallel-transported reference, as in Bergou et al. (2010).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..cable import Cable
from ..frames import frame_from_axis
from ..geometry import tangents
from . import jet
from .rod_frames import (
    angle_ratio,
    discrete_twist,
    material_curvatures,
    parallel_transport,
    rotate_about,
    transported_directors,
)
from .twist_compiled import scratch, twist_stencils

N_LOCAL = 8  # stencil variables: e_a (3), e_b (3), theta_a, theta_b

STENCIL_MAP = np.zeros((N_LOCAL, 11))
"""Map from the 11 stencil coordinates (x_{i-1}, theta_{i-1}, x_i, theta_i, x_{i+1}) to the local
variables (e_a = x_i - x_{i-1}, e_b = x_{i+1} - x_i, theta_a, theta_b)."""
STENCIL_MAP[0:3, 0:3] = -np.eye(3)
STENCIL_MAP[0:3, 4:7] = np.eye(3)
STENCIL_MAP[3:6, 4:7] = -np.eye(3)
STENCIL_MAP[3:6, 8:11] = np.eye(3)
STENCIL_MAP[6, 3] = 1.0
STENCIL_MAP[7, 7] = 1.0


@dataclass(frozen=True, eq=False)
class TwistChain:
    """Constants of the twist and directional-bending energies of one discretized cable.

    Parameters
    ----------
    k_twist : float
        k_t = G I_p / l [N m / rad^2] (eq. 3.16).
    k_bending : float
        k_b [N m / rad^2] (eq. 3.13).
    rest_twist : numpy.ndarray
        psibar_i [rad], (n - 1,): the natural twist theta / (n - 1) per interior point.
    rest_curvatures : numpy.ndarray or None
        omegabar [rad], (n - 1, 2, 2), or None for a straight rest shape (no U^d).
    rest_directors : numpy.ndarray or None
        m1 of the rest shape in its rest frames, (n, 3), None for a straight rest shape.
    """

    k_twist: float
    k_bending: float
    rest_twist: np.ndarray
    rest_curvatures: np.ndarray | None = None
    rest_directors: np.ndarray | None = None

    @classmethod
    def from_cable(cls, cable: Cable, natural_twist: float = 0.0) -> TwistChain:
        """The twist constants of ``cable`` with a natural twist theta [rad] end to end.

        The rest frames of a curved rest shape start on link 0 with the v-axis of the default
        clip frame of that link (:func:`dloplan.frames.frame_from_axis`, z toward world up) and
        are carried along by parallel transport, turned by the natural twist; so the rest shape's
        placement fixes which material line lies on the inside of its curve.
        """
        natural_twist = float(natural_twist)
        if not np.isfinite(natural_twist):
            raise ValueError(f"natural_twist: got {natural_twist!r}, expected a finite angle [rad]")
        rest_twist = np.full(cable.n_links - 1, natural_twist / (cable.n_links - 1))
        if not cable.is_curved:
            return cls(cable.k_twist, cable.k_bending, rest_twist)
        rest = cable.rest_shape
        directors = rest_frame_directors(rest, rest_twist)
        return cls(cable.k_twist, cable.k_bending, rest_twist,
                   material_curvatures(tangents(rest), directors), directors)

    @property
    def directional(self) -> bool:
        """True when the bending energy depends on the material frames (curved rest shape)."""
        return self.rest_curvatures is not None

    @cached_property
    def constants(self) -> tuple:
        """The arguments of the compiled kernels (:mod:`dloplan.physics.twist_compiled`):
        k_t, psibar, k_b, omegabar (zeros for a straight rest shape), directional."""
        bar = (self.rest_curvatures if self.directional
               else np.zeros((len(self.rest_twist), 2, 2)))
        return (float(self.k_twist), np.ascontiguousarray(self.rest_twist, dtype=float),
                float(self.k_bending), np.ascontiguousarray(bar, dtype=float), self.directional)


def rest_frame_directors(rest_shape: np.ndarray, rest_twist: np.ndarray) -> np.ndarray:
    """m1 of the rest frames of a rest shape, (n, 3) (see :meth:`TwistChain.from_cable`)."""
    t = tangents(rest_shape)
    first = frame_from_axis(t[0]).apply([0.0, 1.0, 0.0])[0]
    turned = np.concatenate([[0.0], np.cumsum(rest_twist)])
    return rotate_about(transported_directors(rest_shape, first), t, turned)


def twist_energy_terms(tc: TwistChain, x: np.ndarray, d1: np.ndarray) -> dict[str, float]:
    """The twist energy U^t and the directional bending term U^d [J] of a state.

    Parameters
    ----------
    tc : TwistChain
        Constants.
    x : numpy.ndarray
        (n + 1, 3) points [m].
    d1 : numpy.ndarray
        (n, 3) material directors m1 (unit, perpendicular to their links).
    """
    t = tangents(x)
    psi = discrete_twist(t, d1)
    terms = {"twist": 0.5 * tc.k_twist * float(np.sum((psi - tc.rest_twist) ** 2))}
    if tc.directional:
        omega = material_curvatures(t, d1)
        bar = tc.rest_curvatures
        rest_beta2 = np.sum(bar[:, 0] ** 2, axis=-1)
        terms["bending_direction"] = 0.5 * tc.k_bending * float(
            np.sum(rest_beta2 - np.sum(omega * bar, axis=(-1, -2)))
        )
    else:
        terms["bending_direction"] = 0.0
    return terms


def twist_energy(tc: TwistChain, x: np.ndarray, d1: np.ndarray) -> float:
    """U^t + U^d [J] of a state (see :func:`twist_energy_terms`)."""
    return sum(twist_energy_terms(tc, x, d1).values())


def chart_directors(x: np.ndarray, t0: np.ndarray, d0: np.ndarray, theta: np.ndarray):
    """Directors m1 (n, 3) of the chart (t0, d0) at points x and angles theta [rad]."""
    t = tangents(x)
    return rotate_about(parallel_transport(d0, t0, t), t, theta)


def _link_frame(e: jet.Jet, t0: np.ndarray, d0: np.ndarray, theta: jet.Jet):
    t = e / jet.sqrt(jet.dot(e, e)).expand()
    k = jet.cross(t0, t)
    c = jet.dot(t0, t)
    ref = d0 + jet.cross(k, d0) + jet.cross(k, jet.cross(k, d0)) / (c + 1.0).expand()
    other = jet.cross(t, ref)
    cos, sin = jet.cos(theta).expand(), jet.sin(theta).expand()
    return t, ref * cos + other * sin, other * cos - ref * sin


@dataclass(frozen=True)
class TwistDerivatives:
    """Energies, gradients and Hessian blocks of U^t and U^d in a chart.

    Attributes
    ----------
    twist_energy, direction_energy : float
        U^t and U^d [J].
    twist_gradient, direction_gradient : numpy.ndarray
        (n + 1, 3) dU^t/dx and dU^d/dx [N]; the twisting force of eq. 3.19 is minus the first.
    angle_gradient : numpy.ndarray
        (n,) d(U^t + U^d)/dtheta [N m]: minus the torque on each link about its axis.
    blocks : numpy.ndarray
        (n - 1, 11, 11) Hessian of U^t + U^d over each stencil's coordinates (x_{i-1},
        theta_{i-1}, x_i, theta_i, x_{i+1}) [N/m, N/rad, N m/rad^2].
    """

    twist_energy: float
    direction_energy: float
    twist_gradient: np.ndarray
    direction_gradient: np.ndarray
    angle_gradient: np.ndarray
    blocks: np.ndarray


def twist_derivatives(tc: TwistChain, x: np.ndarray, t0: np.ndarray, d0: np.ndarray,
                      theta: np.ndarray) -> TwistDerivatives:
    """Exact derivatives of U^t and U^d in the chart (t0, d0) at points x and angles theta.

    Parameters
    ----------
    tc : TwistChain
        Constants.
    x : numpy.ndarray
        (n + 1, 3) points [m].
    t0, d0 : numpy.ndarray
        (n, 3) chart tangents and reference directors (unit, d0 perpendicular to t0).
    theta : numpy.ndarray
        (n,) twist angles [rad] against the chart's reference.
    """
    e = np.diff(x, axis=0)
    ea = jet.Jet.variables(e[:-1], 0, N_LOCAL)
    eb = jet.Jet.variables(e[1:], 3, N_LOCAL)
    tha = jet.Jet.variables(theta[:-1], 6, N_LOCAL)
    thb = jet.Jet.variables(theta[1:], 7, N_LOCAL)
    ta, m1a, m2a = _link_frame(ea, t0[:-1], d0[:-1], tha)
    tb, m1b, m2b = _link_frame(eb, t0[1:], d0[1:], thb)
    cos_part = jet.dot(m1a, m1b) + jet.dot(m2a, m2b)
    sin_part = jet.dot(jet.cross(m1a, m1b) + jet.cross(m2a, m2b), ta + tb) * 0.5
    strain = jet.atan2(sin_part, cos_part) - tc.rest_twist
    u_twist = strain * strain * (0.5 * tc.k_twist)
    local = [u_twist]
    if tc.directional:
        bar = tc.rest_curvatures
        c = jet.dot(ta, tb)
        kb = jet.cross(ta, tb) * c.apply(*angle_ratio(c.val)).expand()
        pairing = 0.0
        for j, (m1, m2) in enumerate(((m1a, m2a), (m1b, m2b))):
            pairing = pairing + jet.dot(kb, m2) * bar[:, j, 0] - jet.dot(kb, m1) * bar[:, j, 1]
        rest_beta2 = np.sum(bar[:, 0] ** 2, axis=-1)
        local.append((rest_beta2 - pairing) * (0.5 * tc.k_bending))
    grads = [part.grad @ STENCIL_MAP for part in local]  # (n - 1, 11) each
    hess = sum(part.hess for part in local)
    blocks = np.einsum("ka,nkl,lb->nab", STENCIL_MAP, hess, STENCIL_MAP)
    point_grads = [_scatter_points(g, len(x)) for g in grads]
    angle_gradient = np.zeros(len(e))
    for g in grads:
        angle_gradient[:-1] += g[:, 3]
        angle_gradient[1:] += g[:, 7]
    energies = [float(part.val.sum()) for part in local]
    return TwistDerivatives(
        twist_energy=energies[0],
        direction_energy=energies[1] if tc.directional else 0.0,
        twist_gradient=point_grads[0],
        direction_gradient=point_grads[1] if tc.directional else np.zeros_like(x),
        angle_gradient=angle_gradient,
        blocks=blocks,
    )


def centred_twist_derivatives(tc: TwistChain, x: np.ndarray, d1: np.ndarray) -> TwistDerivatives:
    """:func:`twist_derivatives` at the centre of the chart of the state (x, d1), in closed form.

    The same values as ``twist_derivatives(tc, x, tangents(x), d1, zeros(n))`` to round-off,
    from the compiled kernel :func:`dloplan.physics.twist_compiled.twist_stencils`; arguments
    as in :func:`twist_energy_terms`.
    """
    x = np.ascontiguousarray(x, dtype=float)
    d1 = np.ascontiguousarray(d1, dtype=float)
    n = len(d1)
    twist_gradient = np.empty_like(x)
    direction_gradient = np.empty_like(x)
    angle_gradient = np.empty(n)
    blocks = np.empty((n - 1, 11, 11))
    # full=True passed, as the compiled callers pass it: one compiled overload
    u_twist, u_direction = twist_stencils(x, d1, *tc.constants, scratch(), twist_gradient,
                                          direction_gradient, angle_gradient, blocks, True)
    return TwistDerivatives(u_twist, u_direction, twist_gradient, direction_gradient,
                            angle_gradient, blocks)


def _scatter_points(g: np.ndarray, n_points: int) -> np.ndarray:
    out = np.zeros((n_points, 3))
    out[:-2] += g[:, 0:3]
    out[1:-1] += g[:, 4:7]
    out[2:] += g[:, 8:11]
    return out
