"""Compiled closed-form twist and directional-bending derivatives at a chart's centre.

:func:`dloplan.physics.twist.twist_derivatives` is the readable reference: it differentiates the
energies U^t and U^d (:mod:`dloplan.physics.twist`) in any chart by second-order forward
differentiation. The solvers only ever need the derivatives at the chart's *centre* (reference
tangents t0 = the current link directions, reference directors = the current ones, angles 0);
there they have closed forms, written out here point by point and compiled by numba
(``cache=True``), one pass over the interior points.

Twist (Bergou et al. 2008, 2010; thesis eqs. 3.14, 3.16, 3.19). In the chart the directors of
link j are m1_j = R(t_j, theta_j) P(t0_j -> t_j) m1_j, and turning a link's frame about its axis
commutes with parallel transport, so the discrete twist is exactly
psi_i = psi0_i(e_a, e_b) + theta_b - theta_a (a = i - 1, b = i). With t = e / |e|,
chi = 1 + t_a . t_b, kb = 2 t_a x t_b / chi and tt = (t_a + t_b) / chi, at the centre:

* dpsi0/de_a = kb / (2 |e_a|), dpsi0/de_b = kb / (2 |e_b|);
* d2psi0/de_a2 = -(kb (t_a + tt)^T + (t_a + tt) kb^T) / (4 |e_a|^2) (and a <-> b);
* d2psi0/de_a de_b = ([t_a]_x 2 / chi - kb tt^T) / (2 |e_a| |e_b|),

so U^t = 1/2 k_t s^2 (s = psi - psibar) has gradient k_t s dpsi and Hessian
k_t (dpsi dpsi^T + s d2psi).

Directional bending (3.9): U^d_i = 1/2 k_b (|omegabar|^2 - sum_j (q_j wbar_j0 - p_j wbar_j1)),
p_j = kappa . m1_j and q_j = kappa . m2_j with the curvature binormal kappa = f(c) t_a x t_b
(f = beta / sin beta, :func:`dloplan.physics.rod_frames.angle_ratio`). Turning link j by theta_j
turns (p_j, q_j) in their plane, which gives the angle derivatives in closed form; the edge
derivatives follow from those of the factors by the product rule:

* t(e): dt/de = Q / |e| (Q = I - t t^T),
  d2t_k/de_i de_j = -(Q_kj t_i + Q_ki t_j + t_k Q_ij) / |e|^2;
* m1(e) = P(t0 -> t(e)) m1 = m1 - (m1 . t)(t0 + t) / (1 + t0 . t): dm1/de = -t m1^T / |e|,
  d2m1_k/de_i de_j = (t_k (m1_i t_j + m1_j t_i) - (m1_i Q_kj + m1_j Q_ki) / 2) / |e|^2;
* m2 = t x m1, kappa = f(c) t_a x t_b with c = t_a . t_b.

Tests check these kernels against the reference to round-off and against finite differences.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from .compiled import joint_directions
from .rod_frames import angle_ratio_scalar


@njit(cache=True)
def _unit(e, off, v, J, H):
    """t = e / |e| with its derivatives in columns off .. off + 2 of J (3, 6), H (3, 6, 6)."""
    length = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    for k in range(3):
        v[k] = e[k] / length
    inv2 = 1.0 / (length * length)
    for k in range(3):
        for i in range(3):
            q_ki = (1.0 if k == i else 0.0) - v[k] * v[i]
            J[k, off + i] = q_ki / length
            for j in range(3):
                q_kj = (1.0 if k == j else 0.0) - v[k] * v[j]
                q_ij = (1.0 if i == j else 0.0) - v[i] * v[j]
                H[k, off + i, off + j] = -(q_kj * v[i] + q_ki * v[j] + v[k] * q_ij) * inv2
    return length


@njit(cache=True)
def _transported(t, m1, length, off, J, H):
    """Derivatives of m1(e) = P(t0 -> t(e)) m1 at t = t0 (columns off .. off + 2)."""
    inv2 = 1.0 / (length * length)
    for k in range(3):
        for i in range(3):
            J[k, off + i] = -t[k] * m1[i] / length
            q_ki = (1.0 if k == i else 0.0) - t[k] * t[i]
            for j in range(3):
                q_kj = (1.0 if k == j else 0.0) - t[k] * t[j]
                H[k, off + i, off + j] = (t[k] * (m1[i] * t[j] + m1[j] * t[i])
                                          - 0.5 * (m1[i] * q_kj + m1[j] * q_ki)) * inv2


@njit(cache=True)
def _cross2(a, Ja, Ha, b, Jb, Hb, v, J, H):
    """v = a x b with its gradient J and Hessian H (product rule over 6 variables)."""
    for k in range(3):
        k1 = (k + 1) % 3
        k2 = (k + 2) % 3
        v[k] = a[k1] * b[k2] - a[k2] * b[k1]
        for i in range(6):
            J[k, i] = Ja[k1, i] * b[k2] + a[k1] * Jb[k2, i] - Ja[k2, i] * b[k1] - a[k2] * Jb[k1, i]
            for j in range(6):
                H[k, i, j] = (Ha[k1, i, j] * b[k2] + a[k1] * Hb[k2, i, j]
                              + Ja[k1, i] * Jb[k2, j] + Ja[k1, j] * Jb[k2, i]
                              - Ha[k2, i, j] * b[k1] - a[k2] * Hb[k1, i, j]
                              - Ja[k2, i] * Jb[k1, j] - Ja[k2, j] * Jb[k1, i])


@njit(cache=True)
def _dot2(a, Ja, Ha, b, Jb, Hb, g, h):
    """a . b; its gradient g (6,) and Hessian h (6, 6) written in place."""
    value = 0.0
    for k in range(3):
        value += a[k] * b[k]
    for i in range(6):
        g[i] = 0.0
        for k in range(3):
            g[i] += Ja[k, i] * b[k] + a[k] * Jb[k, i]
        for j in range(6):
            s = 0.0
            for k in range(3):
                s += (Ha[k, i, j] * b[k] + a[k] * Hb[k, i, j]
                      + Ja[k, i] * Jb[k, j] + Ja[k, j] * Jb[k, i])
            h[i, j] = s
    return value


@njit(cache=True)
def _twist_local(ta, tb, la, lb, s, k_t, g, h, kb, tt, d, full):
    """Add U^t's local gradient g (8,) and Hessian h (8, 8) at twist strain s (closed form);
    kb, tt (3,) and d (8,) are scratch; without ``full`` only the angles' Hessian."""
    chi = 1.0 + ta[0] * tb[0] + ta[1] * tb[1] + ta[2] * tb[2]
    inverse_chi = 1.0 / chi
    for k in range(3):
        k1 = (k + 1) % 3
        k2 = (k + 2) % 3
        kb[k] = 2.0 * (ta[k1] * tb[k2] - ta[k2] * tb[k1]) * inverse_chi
        tt[k] = (ta[k] + tb[k]) * inverse_chi
    half_a = 0.5 / la
    half_b = 0.5 / lb
    for k in range(3):
        d[k] = kb[k] * half_a
        d[3 + k] = kb[k] * half_b
    d[6] = -1.0
    d[7] = 1.0
    for i in range(8):
        g[i] += k_t * s * d[i]
    if not full:
        for i in range(6, 8):
            for j in range(6, 8):
                h[i, j] += k_t * d[i] * d[j]
        return
    for i in range(8):
        for j in range(8):
            h[i, j] += k_t * d[i] * d[j]
    ks = k_t * s
    ca = -0.25 / (la * la)
    cb = -0.25 / (lb * lb)
    cab = 0.5 / (la * lb)
    for i in range(3):
        for j in range(3):
            h[i, j] += ks * ca * (kb[i] * (ta[j] + tt[j]) + (ta[i] + tt[i]) * kb[j])
            h[3 + i, 3 + j] += ks * cb * (kb[i] * (tb[j] + tt[j]) + (tb[i] + tt[i]) * kb[j])
            # [t_a]_x[i, j] = -eps_ijk t_a[k]
            skew = 0.0
            if j == (i + 1) % 3:
                skew = -ta[(i + 2) % 3]
            elif j == (i + 2) % 3:
                skew = ta[(i + 1) % 3]
            mixed = ks * cab * (2.0 / chi * skew - kb[i] * tt[j])
            h[i, 3 + j] += mixed
            h[3 + j, i] += mixed


@njit(cache=True)
def _link_pairing(kap, Jk, Hk, m1, Jm1, Hm1, m2, Jm2, Hm2, bar, th, half, g, h):
    """q wbar_0 - p wbar_1 of one link (p = kappa . m1, q = kappa . m2); adds ``half`` times
    its local gradient and Hessian (edges, and the link's angle ``th``) into g, h."""
    gp = np.empty(6)
    hp = np.empty((6, 6))
    gq = np.empty(6)
    hq = np.empty((6, 6))
    p = _dot2(kap, Jk, Hk, m1, Jm1, Hm1, gp, hp)
    q = _dot2(kap, Jk, Hk, m2, Jm2, Hm2, gq, hq)
    b0 = bar[0]
    b1 = bar[1]
    g[th] += half * -(p * b0 + q * b1)
    h[th, th] += half * -(q * b0 - p * b1)
    for i in range(6):
        g[i] += half * (gq[i] * b0 - gp[i] * b1)
        cross = half * -(gp[i] * b0 + gq[i] * b1)
        h[i, th] += cross
        h[th, i] += cross
        for k in range(6):
            h[i, k] += half * (hq[i, k] * b0 - hp[i, k] * b1)
    return q * b0 - p * b1


@njit(cache=True)
def _direction_local(ea, eb, m1a, m1b, bar, k_b, g, h, work):
    """Add U^d's local gradient g (8,) and Hessian h (8, 8); return U^d of the stencil [J]."""
    (ta, Jta, Hta, tb, Jtb, Htb, m1av, Jm1a, Hm1a, m1bv, Jm1b, Hm1b,
     m2a, Jm2a, Hm2a, m2b, Jm2b, Hm2b, w, Jw, Hw, kap, Jk, Hk) = work
    Jta[:] = 0.0
    Hta[:] = 0.0
    Jtb[:] = 0.0
    Htb[:] = 0.0
    Jm1a[:] = 0.0
    Hm1a[:] = 0.0
    Jm1b[:] = 0.0
    Hm1b[:] = 0.0
    first, second = np.int64(0), np.int64(3)  # int64, not literals: one overload (dloplan.jit)
    la = _unit(ea, first, ta, Jta, Hta)
    lb = _unit(eb, second, tb, Jtb, Htb)
    m1av[:] = m1a
    m1bv[:] = m1b
    _transported(ta, m1a, la, first, Jm1a, Hm1a)
    _transported(tb, m1b, lb, second, Jm1b, Hm1b)
    _cross2(ta, Jta, Hta, m1av, Jm1a, Hm1a, m2a, Jm2a, Hm2a)
    _cross2(tb, Jtb, Htb, m1bv, Jm1b, Hm1b, m2b, Jm2b, Hm2b)
    _cross2(ta, Jta, Hta, tb, Jtb, Htb, w, Jw, Hw)
    gc = np.empty(6)
    hc = np.empty((6, 6))
    c = _dot2(ta, Jta, Hta, tb, Jtb, Htb, gc, hc)
    f0, f1, f2 = angle_ratio_scalar(c)
    for k in range(3):
        kap[k] = f0 * w[k]
        for i in range(6):
            Jk[k, i] = f0 * Jw[k, i] + f1 * w[k] * gc[i]
            for j in range(6):
                Hk[k, i, j] = (f0 * Hw[k, i, j] + f1 * (Jw[k, i] * gc[j] + gc[i] * Jw[k, j])
                               + f2 * w[k] * gc[i] * gc[j] + f1 * w[k] * hc[i, j])
    half = -0.5 * k_b
    th_a, th_b = np.int64(6), np.int64(7)
    total = _link_pairing(kap, Jk, Hk, m1av, Jm1a, Hm1a, m2a, Jm2a, Hm2a, bar[0], th_a, half, g,
                          h)
    total += _link_pairing(kap, Jk, Hk, m1bv, Jm1b, Hm1b, m2b, Jm2b, Hm2b, bar[1], th_b, half, g,
                           h)
    rest = bar[0, 0] ** 2 + bar[0, 1] ** 2
    return 0.5 * k_b * (rest - total)


@njit(cache=True)
def _twist_angle(ta, tb, m1a, m1b):
    """Discrete twist psi between two links (:func:`dloplan.physics.rod_frames.discrete_twist`)."""
    # m2 = t x m1 of both links, as scalars (no arrays: this runs per joint and energy)
    a0 = ta[1] * m1a[2] - ta[2] * m1a[1]
    a1 = ta[2] * m1a[0] - ta[0] * m1a[2]
    a2 = ta[0] * m1a[1] - ta[1] * m1a[0]
    b0 = tb[1] * m1b[2] - tb[2] * m1b[1]
    b1 = tb[2] * m1b[0] - tb[0] * m1b[2]
    b2 = tb[0] * m1b[1] - tb[1] * m1b[0]
    cos_part = (m1a[0] * m1b[0] + m1a[1] * m1b[1] + m1a[2] * m1b[2]
                + a0 * b0 + a1 * b1 + a2 * b2)
    # axial_k = (m1a x m1b + m2a x m2b)_k, projected on (t_a + t_b) / 2
    axial0 = m1a[1] * m1b[2] - m1a[2] * m1b[1] + a1 * b2 - a2 * b1
    axial1 = m1a[2] * m1b[0] - m1a[0] * m1b[2] + a2 * b0 - a0 * b2
    axial2 = m1a[0] * m1b[1] - m1a[1] * m1b[0] + a0 * b1 - a1 * b0
    sin_part = 0.5 * (axial0 * (ta[0] + tb[0]) + axial1 * (ta[1] + tb[1])
                      + axial2 * (ta[2] + tb[2]))
    return math.atan2(sin_part, cos_part)


def scratch() -> tuple:
    """Scratch arrays of :func:`twist_stencils`: value, gradient and Hessian of 8 vectors of the
    directional term (allocate once per solve)."""
    parts: list[np.ndarray] = []
    for _ in range(8):
        parts += [np.empty(3), np.empty((3, 6)), np.empty((3, 6, 6))]
    return tuple(parts)


# the map from local variables to stencil coordinate a: s1[a] * local k1[a] - local k2[a]
_K1 = np.array([0, 1, 2, 6, 0, 1, 2, 7, 3, 4, 5])
_S1 = np.array([-1.0, -1.0, -1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
_K2 = np.array([-1, -1, -1, -1, 3, 4, 5, -1, -1, -1, -1])  # -1: none


@njit(cache=True)
def _stencil_map(g8, h8, g11, h11, hm, full):
    """Local variables (e_a, e_b, theta_a, theta_b) to stencil coordinates (x_{i-1},
    theta_{i-1}, x_i, theta_i, x_{i+1}): e_a = x_i - x_{i-1}, e_b = x_{i+1} - x_i.
    ``h11`` gets M^T h8 M added (without ``full`` only its angle entries); ``hm`` (8, 11) is
    scratch."""
    k1 = _K1
    s1 = _S1
    k2 = _K2
    if not full:
        for a in range(11):
            g11[a] = s1[a] * g8[k1[a]]
            if k2[a] >= 0:
                g11[a] -= g8[k2[a]]
        for a in (3, 7):
            for b in (3, 7):
                h11[a, b] += h8[k1[a], k1[b]]
        return
    for a in range(11):
        g11[a] = s1[a] * g8[k1[a]]
        if k2[a] >= 0:
            g11[a] -= g8[k2[a]]
        for r in range(8):
            hm[r, a] = s1[a] * h8[r, k1[a]]
            if k2[a] >= 0:
                hm[r, a] -= h8[r, k2[a]]
    for a in range(11):
        for b in range(11):
            value = s1[a] * hm[k1[a], b]
            if k2[a] >= 0:
                value -= hm[k2[a], b]
            h11[a, b] += value


@njit(cache=True)
def _scatter(g11, s, point_grad, angle_grad):
    """Add stencil s's gradient (x_s, theta_s, x_{s+1}, theta_{s+1}, x_{s+2}) into the points'
    (n + 1, 3) and the angles' (n,) gradients."""
    for k in range(3):
        point_grad[s, k] += g11[k]
        point_grad[s + 1, k] += g11[4 + k]
        point_grad[s + 2, k] += g11[8 + k]
    angle_grad[s] += g11[3]
    angle_grad[s + 1] += g11[7]


@njit(cache=True)
def twist_stencils(x, d1, k_t, rest_twist, k_b, rest_curvatures, directional, work,
                   twist_grad, direction_grad, angle_grad, blocks, full=True):
    """U^t and U^d [J] at the chart's centre; their derivatives written in place.

    Parameters
    ----------
    x : numpy.ndarray
        (n + 1, 3) points [m].
    d1 : numpy.ndarray
        (n, 3) material directors m1 (unit, perpendicular to the links).
    k_t, rest_twist, k_b, rest_curvatures
        :class:`dloplan.physics.twist.TwistChain`'s constants (rest curvatures (n - 1, 2, 2),
        any array when ``directional`` is False).
    directional : bool
        Include U^d (curved rest shape).
    work : tuple
        Scratch arrays (:func:`scratch`).
    twist_grad, direction_grad : numpy.ndarray
        (n + 1, 3) dU^t/dx and dU^d/dx [N], overwritten.
    angle_grad : numpy.ndarray
        (n,) d(U^t + U^d)/dtheta [N m], overwritten.
    blocks : numpy.ndarray
        (n - 1, 11, 11) Hessian of U^t + U^d over each stencil's coordinates, overwritten.
    full : bool
        False: only the angles' entries of ``blocks`` (3 and 7; the rest left as they were,
        not even zeroed), for the dynamic simulator's angle relaxation.

    Returns
    -------
    tuple
        ``(U^t, U^d)`` [J].
    """
    twist_grad[:] = 0.0
    direction_grad[:] = 0.0
    angle_grad[:] = 0.0
    ea = np.empty(3)
    eb = np.empty(3)
    ta = np.empty(3)
    tb = np.empty(3)
    g8 = np.empty(8)
    h8 = np.empty((8, 8))
    g11 = np.empty(11)
    hm = np.empty((8, 11))
    kb = np.empty(3)
    tt = np.empty(3)
    d8 = np.empty(8)
    hessian = bool(full)  # a bool even when ``full`` is a literal: one overload of the helpers
    if hessian:
        blocks[:] = 0.0
    else:  # the angle entries alone: zeroing all 121 per stencil costs more than the rest
        for s in range(blocks.shape[0]):
            for a in (3, 7):
                for b in (3, 7):
                    blocks[s, a, b] = 0.0
    u_twist = 0.0
    u_direction = 0.0
    for s in range(x.shape[0] - 2):
        for k in range(3):
            ea[k] = x[s + 1, k] - x[s, k]
            eb[k] = x[s + 2, k] - x[s + 1, k]
        la = math.sqrt(ea[0] ** 2 + ea[1] ** 2 + ea[2] ** 2)
        lb = math.sqrt(eb[0] ** 2 + eb[1] ** 2 + eb[2] ** 2)
        inverse_a = 1.0 / la
        inverse_b = 1.0 / lb
        for k in range(3):
            ta[k] = ea[k] * inverse_a
            tb[k] = eb[k] * inverse_b
        strain = _twist_angle(ta, tb, d1[s], d1[s + 1]) - rest_twist[s]
        u_twist += 0.5 * k_t * strain * strain
        g8[:] = 0.0
        h8[:] = 0.0
        _twist_local(ta, tb, la, lb, strain, k_t, g8, h8, kb, tt, d8, hessian)
        _stencil_map(g8, h8, g11, blocks[s], hm, hessian)
        _scatter(g11, s, twist_grad, angle_grad)
        if not directional:
            continue
        g8[:] = 0.0
        h8[:] = 0.0
        u_direction += _direction_local(ea, eb, d1[s], d1[s + 1], rest_curvatures[s], k_b,
                                        g8, h8, work)
        _stencil_map(g8, h8, g11, blocks[s], hm, hessian)
        _scatter(g11, s, direction_grad, angle_grad)
    return u_twist, u_direction


_FOLDED = 1e-12
"""1 + t_a . t_b at or below which two unit link directions count as opposite (an angle within
about 1.4e-6 rad of pi: round-off of exactly opposite links leaves about 1e-16)."""


@njit(cache=True)
def link_tangents(x, tangents, lengths):
    """Unit link directions t_j (n, 3) and lengths |e_j| (n,) [m] of x (n + 1, 3), in place."""
    for j in range(x.shape[0] - 1):
        length = 0.0
        for k in range(3):
            tangents[j, k] = x[j + 1, k] - x[j, k]
            length += tangents[j, k] * tangents[j, k]
        length = math.sqrt(length)
        inverse = 1.0 / length
        for k in range(3):
            tangents[j, k] *= inverse
        lengths[j] = length


@njit(cache=True)
def twist_load(tangents, lengths, d1, k_t, rest_twist, point_grad, angle_grad):
    """U^t [J] at the chart's centre with its gradient, in one pass: no Hessian, no U^d.

    The dynamic simulator's twisting force for a straight rest shape (eq. 3.19 is minus
    ``point_grad``): the gradient of :func:`twist_stencils`' U^t, k_t s (kb / (2 |e_a|),
    kb / (2 |e_b|), -1, 1) per joint, written straight into the points' (n + 1, 3) [N] and the
    angles' (n,) [N m] gradients (both overwritten), from the links' unit tangents (n, 3) and
    lengths (n,) [m] (:func:`link_tangents`). Its angle Hessian needs no pass: it is the
    constant tridiagonal k_t (2, -1) (d psi / d theta_{a, b} = -1, 1).
    """
    point_grad[:] = 0.0
    angle_grad[:] = 0.0
    u_twist = 0.0
    for s in range(d1.shape[0] - 1):
        ta = tangents[s]
        tb = tangents[s + 1]
        strain = _twist_angle(ta, tb, d1[s], d1[s + 1]) - rest_twist[s]
        u_twist += 0.5 * k_t * strain * strain
        force = k_t * strain
        inverse_chi = 1.0 / (1.0 + ta[0] * tb[0] + ta[1] * tb[1] + ta[2] * tb[2])
        half_a = 0.5 / lengths[s]
        half_b = 0.5 / lengths[s + 1]
        for k in range(3):
            k1 = (k + 1) % 3
            k2 = (k + 2) % 3
            kb = 2.0 * (ta[k1] * tb[k2] - ta[k2] * tb[k1]) * inverse_chi
            ga = force * (kb * half_a)
            gb = force * (kb * half_b)
            point_grad[s, k] += -ga
            point_grad[s + 1, k] += ga - gb
            point_grad[s + 2, k] += gb
        angle_grad[s] += -force
        angle_grad[s + 1] += force
    return u_twist


@njit(cache=True)
def carry_directors(tangents, lengths, x_new, d1, angles, first, stop):
    """:func:`moved_directors` in place, from the old links' unit tangents: links
    ``first .. stop - 1`` of d1 (n, 3) are carried to the links of ``x_new`` (n + 1, 3) [m] and
    turned by ``angles`` (n,) [rad]; ``tangents`` (n, 3) and ``lengths`` (n,) [m] become those of
    ``x_new`` (all links), ready for the next step's :func:`twist_load`.

    Returns False, and stops, where the new links cannot carry frames: a link of zero length (or
    not finite), a carried link turned by half a turn, or two neighbouring links folded back onto
    each other (1 + t_a . t_b <= 1e-12, where the twist is undefined): a diverging run.
    """
    t = np.empty(3)
    v = np.empty(3)
    for j in range(d1.shape[0]):
        length = 0.0
        for k in range(3):
            t[k] = x_new[j + 1, k] - x_new[j, k]
            length += t[k] * t[k]
        length = math.sqrt(length)
        if not 0.0 < length < math.inf:
            return False
        inverse = 1.0 / length
        for k in range(3):
            t[k] *= inverse
        if j > 0 and not (1.0 + tangents[j - 1, 0] * t[0] + tangents[j - 1, 1] * t[1]
                          + tangents[j - 1, 2] * t[2]) > _FOLDED:  # link j - 1 is new already
            return False
        if first <= j < stop:
            t0 = tangents[j]
            c = 0.0
            a = 0.0
            for k in range(3):
                c += t0[k] * t[k]
                a += d1[j, k] * t[k]
            if not 1.0 + c > _FOLDED:
                return False
            _turn_transported(d1[j], t0, t, a / (1.0 + c), angles[j], v, d1[j])
        for k in range(3):
            tangents[j, k] = t[k]
        lengths[j] = length
    return True


@njit(cache=True)
def twist_energies(x, d1, k_t, rest_twist, k_b, rest_curvatures, directional):
    """U^t and U^d [J] of a state (:func:`dloplan.physics.twist.twist_energy_terms`), compiled.

    Arguments as in :func:`twist_stencils`.
    """
    ta = np.empty(3)
    tb = np.empty(3)
    u_twist = 0.0
    pairing = 0.0
    for s in range(x.shape[0] - 2):
        c = joint_directions(x, s, ta, tb)[2]
        strain = _twist_angle(ta, tb, d1[s], d1[s + 1]) - rest_twist[s]
        u_twist += 0.5 * k_t * strain * strain
        if not directional:
            continue
        f = angle_ratio_scalar(c)[0]
        bar = rest_curvatures[s]
        pairing -= bar[0, 0] ** 2 + bar[0, 1] ** 2
        for j in range(2):
            t = ta if j == 0 else tb
            m1 = d1[s + j]
            p = 0.0
            q = 0.0
            for k in range(3):
                k1 = (k + 1) % 3
                k2 = (k + 2) % 3
                kappa = f * (ta[k1] * tb[k2] - ta[k2] * tb[k1])
                p += kappa * m1[k]
                q += kappa * (t[k1] * m1[k2] - t[k2] * m1[k1])
            pairing += q * bar[j, 0] - p * bar[j, 1]
    return u_twist, -0.5 * k_b * pairing


@njit(cache=True)
def twist_angles(x, d1, out):
    """Discrete twist psi_i [rad] at the interior points of x (n + 1, 3) with directors d1
    (n, 3), into ``out`` (n - 1,): :func:`dloplan.physics.rod_frames.discrete_twist`, compiled."""
    ta = np.empty(3)
    tb = np.empty(3)
    for s in range(x.shape[0] - 2):
        joint_directions(x, s, ta, tb)
        out[s] = _twist_angle(ta, tb, d1[s], d1[s + 1])


@njit(cache=True, inline="always")
def _turn_transported(d, t0, t, ratio, angle, v, out):
    """``out`` (3,) <- the director d (3,), perpendicular to the unit t0, carried to the unit t
    by parallel transport, P(t0 -> t) d = d - ratio (t0 + t) with ratio = (d . t) / (1 + t0 . t),
    turned by ``angle`` [rad] about t and made exactly unit and perpendicular to t; ``v`` (3,)
    is scratch, ``out`` may be d."""
    for k in range(3):
        v[k] = d[k] - ratio * (t0[k] + t[k])
    cos = math.cos(angle)
    sin = math.sin(angle)
    dot = 0.0
    for k in range(3):
        k1 = (k + 1) % 3
        k2 = (k + 2) % 3
        out[k] = cos * v[k] + sin * (t[k1] * v[k2] - t[k2] * v[k1])
        dot += out[k] * t[k]
    norm = 0.0
    for k in range(3):
        out[k] -= dot * t[k]
        norm += out[k] * out[k]
    inverse = 1.0 / math.sqrt(norm)
    for k in range(3):
        out[k] *= inverse


@njit(cache=True)
def moved_directors(x_old, x_new, d1, angles, out):
    """Directors after a step: d1 carried by parallel transport from the links of ``x_old`` to
    those of ``x_new``, turned by ``angles`` [rad] (n,) about the new links, and made exactly
    unit and perpendicular (:func:`dloplan.physics.twist.chart_directors`); into ``out`` (n, 3).
    """
    t0 = np.empty(3)
    t = np.empty(3)
    v = np.empty(3)
    for j in range(d1.shape[0]):
        l0 = 0.0
        l1 = 0.0
        for k in range(3):
            t0[k] = x_old[j + 1, k] - x_old[j, k]
            t[k] = x_new[j + 1, k] - x_new[j, k]
            l0 += t0[k] * t0[k]
            l1 += t[k] * t[k]
        l0 = math.sqrt(l0)
        l1 = math.sqrt(l1)
        c = 0.0
        a = 0.0
        for k in range(3):
            t0[k] /= l0
            t[k] /= l1
            c += t0[k] * t[k]
            a += d1[j, k] * t[k]
        _turn_transported(d1[j], t0, t, a / (1.0 + c), angles[j], v, out[j])


@njit(cache=True)
def interleaved_band(band_pos, blocks, link, band):
    """The joint lower band (11, 4 n + 3) over interleaved (x_i, y_i, z_i, l theta_i).

    ``band_pos`` (9, 3(n + 1)) is the points' band [N/m] (entries of points three apart are
    structural zeros and dropped), ``blocks`` (n - 1, 11, 11) the twist stencils' Hessians
    (angles in rad, scaled here to l theta with the link length ``link`` [m]); ``band`` is
    overwritten.
    """
    band[:] = 0.0
    n_pos = band_pos.shape[1]
    for k in range(band_pos.shape[0]):
        for j in range(n_pos - k):
            row = j + k
            q_row = 4 * (row // 3) + row % 3
            q_col = 4 * (j // 3) + j % 3
            if q_row - q_col < band.shape[0]:
                band[q_row - q_col, q_col] += band_pos[k, j]
    for s in range(blocks.shape[0]):
        for a in range(11):
            sa = 1.0 / link if a == 3 or a == 7 else 1.0
            for b in range(a + 1):
                sb = 1.0 / link if b == 3 or b == 7 else 1.0
                band[a - b, 4 * s + b] += blocks[s, a, b] * sa * sb
