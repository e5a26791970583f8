"""Compiled kernels of the chain's energy: one pass for energy, gradient and Hessian band.

The numpy kernels of :mod:`dloplan.physics.axial`, :mod:`dloplan.physics.bending` and
:mod:`dloplan.physics.gravity` are the readable reference (vectorized over a batch of shapes);
these are the same formulas written point by point and compiled by numba (``cache=True``: the
first call of a fresh install compiles them, about a second, later runs load them from disk).
They exist for speed alone: a Newton iteration at n = 50 is about 10 microseconds of arithmetic,
and the numpy kernels spend most of their time in per-call overhead on small arrays.

Formulas (thesis eqs. 3.8, 3.20, 3.28; see the reference modules for the derivations):

* axial, per link e = x_{i+1} - x_i, t = e / |e|: U = 1/2 k_s (|e| - l0)^2,
  dU/de = k_s (|e| - l0) t, d^2U/de^2 = k_s (t t^T + (|e| - l0)/|e| (I - t t^T));
* bending, per joint with link directions u, v and c = u . v: U = 1/2 k_b (beta - beta0)^2 with
  beta = atan2(|u x v|, c); H = G'(c) d^2c + G''(c) dc dc^T (``bending_derivatives``);
* gravity: U = -sum_i m_i g . x_i (linear, no Hessian).

Bands use the lower layout of :func:`dloplan.physics.chain.gradient_and_hessian_band`:
``band[k, j] = H[j + k, j]`` over the 3(n + 1) coordinates, half bandwidth 8. Contacts are not
here: obstacles are Python objects; their penalty is added by :mod:`dloplan.physics.chain`.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit, njit_leaf

_SERIES_BELOW = 1e-3  # as in dloplan.physics.bending
_SIN_FLOOR = 1e-12


@njit(cache=True, inline="always")
def _cos_first(k_b, beta0, s, beta):
    """dG/dc of G = 1/2 k_b (arccos c - beta0)^2 (as ``bending._cos_derivatives``): all a
    gradient needs, without the second derivative's powers of sin."""
    s_safe = max(s, _SIN_FLOOR)
    beta_over_s = 1.0 + beta * beta / 6.0 if beta < _SERIES_BELOW else beta / s_safe
    return -k_b * (beta_over_s - beta0 / s_safe)


@njit(cache=True)
def _cos_derivatives(k_b, beta0, c, s, beta):
    """dG/dc and d^2G/dc^2 of G = 1/2 k_b (arccos c - beta0)^2 (as ``bending._cos_derivatives``)."""
    s_safe = max(s, _SIN_FLOOR)
    if beta < _SERIES_BELOW:
        curvature = 1.0 / 3.0 + 2.0 * (beta * beta) / 15.0
    else:
        curvature = (s - beta * c) / s_safe**3
    d2 = k_b * (curvature + beta0 * c / s_safe**3)
    return _cos_first(k_b, beta0, s, beta), d2


@njit(cache=True, inline="always")
def _unit_link(x, i):
    """Length and unit direction (a 3-tuple) of link i of x: the length's squares summed in
    axis order, the direction divided by it."""
    e0 = x[i + 1, 0] - x[i, 0]
    e1 = x[i + 1, 1] - x[i, 1]
    e2 = x[i + 1, 2] - x[i, 2]
    length = math.sqrt(0.0 + e0 * e0 + e1 * e1 + e2 * e2)
    return length, (e0 / length, e1 / length, e2 / length)


@njit(cache=True, inline="always")
def _joint_angle(u, v):
    """c = u.v, sin and angle beta between unit directions u, v (3-tuples or arrays)."""
    cx = u[1] * v[2] - u[2] * v[1]
    cy = u[2] * v[0] - u[0] * v[2]
    cz = u[0] * v[1] - u[1] * v[0]
    s = math.sqrt(cx * cx + cy * cy + cz * cz)
    c = u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
    return c, s, math.atan2(s, c)


@njit_leaf(cache=True)
def joint_directions(x, i, u, v):
    """Link directions u, v (filled in), lengths, c = u.v, sin and angle beta of joint i."""
    la, du = _unit_link(x, i)
    lb, dv = _unit_link(x, i + 1)
    for a in range(3):
        u[a] = du[a]
        v[a] = dv[a]
    c, s, beta = _joint_angle(du, dv)
    return la, lb, c, s, beta


@njit_leaf(cache=True)
def chain_energy(x, k_s, rest_lengths, k_b, rest_angles, masses, gravity):
    """Energy U^s + U^b + U^g [J] of one shape x (n + 1, 3) (contacts excluded).

    Each link's direction is computed once and serves both joints it belongs to (the same
    values as computing it per joint), and nothing is allocated.
    """
    n_points = x.shape[0]
    total = 0.0
    for i in range(n_points - 1):
        dx = x[i + 1, 0] - x[i, 0]
        dy = x[i + 1, 1] - x[i, 1]
        dz = x[i + 1, 2] - x[i, 2]
        stretch = math.sqrt(dx * dx + dy * dy + dz * dz) - rest_lengths[i]
        total += 0.5 * k_s * stretch * stretch
    if n_points > 2:
        v = _unit_link(x, 0)[1]
        for i in range(n_points - 2):
            u = v  # the joint's first link is the joint before's second
            v = _unit_link(x, i + 1)[1]
            beta = _joint_angle(u, v)[2]
            total += 0.5 * k_b * (beta - rest_angles[i]) ** 2
    for i in range(n_points):
        total -= masses[i] * (gravity[0] * x[i, 0] + gravity[1] * x[i, 1] + gravity[2] * x[i, 2])
    return total


@njit_leaf(cache=True)
def add_point_blocks(band, blocks):
    """Add one symmetric 3x3 block per point (n + 1, 3, 3) to the band's diagonal blocks."""
    for i in range(blocks.shape[0]):
        for a in range(3):
            for b in range(a + 1):
                band[a - b, 3 * i + b] += blocks[i, a, b]


@njit(cache=True, inline="always")
def _axial_link(i, e, length, k_s, rest_length, grad, band, with_band):
    """Add link i's axial gradient (and Hessian, ``with_band``) into grad, band, from its
    vector e (a 3-tuple) and length [m]; return its energy [J]."""
    stretch = length - rest_length
    inverse = 1.0 / length
    t = (e[0] * inverse, e[1] * inverse, e[2] * inverse)
    for a in range(3):
        g = k_s * stretch * t[a]
        grad[i + 1, a] += g
        grad[i, a] -= g
    if with_band:
        ratio = stretch * inverse
        for a in range(3):  # blocks (i, i) and (i+1, i+1): h; (i+1, i): -h
            for b in range(3):
                tt = t[a] * t[b]
                h = k_s * (tt + ratio * ((1.0 if a == b else 0.0) - tt))
                if a >= b:
                    band[a - b, 3 * i + b] += h
                    band[a - b, 3 * i + 3 + b] += h
                band[3 + a - b, 3 * i + b] -= h
    return 0.5 * k_s * stretch * stretch


@njit_leaf(cache=True)
def _axial_terms(x, k_s, rest_lengths, grad, band, with_band):
    """Add U^s's gradient (and Hessian, ``with_band``) into grad, band; return U^s [J]."""
    total = 0.0
    for i in range(x.shape[0] - 1):
        e0 = x[i + 1, 0] - x[i, 0]
        e1 = x[i + 1, 1] - x[i, 1]
        e2 = x[i + 1, 2] - x[i, 2]
        length = math.sqrt(0.0 + e0 * e0 + e1 * e1 + e2 * e2)
        total += _axial_link(i, (e0, e1, e2), length, k_s, rest_lengths[i], grad, band,
                             with_band)
    return total


@njit(cache=True, inline="always")
def _link_blocks(a, b, terms):
    """Entry (a, b) of a joint's link blocks d^2U/da^2, d^2U/da db, d^2U/db^2 [N/m] (a = x1 -
    x0, b = x2 - x1): d1 d^2c + d2 dc dc^T with d^2c -(u w^T + w u^T + c P_u)/|a|^2,
    (P_v - u z^T)/(|a||b|) and its b counterpart (u, v the unit links, dca = w / |a|,
    dcb = z / |b| the gradients of c, ia = 1/|a|, ib = 1/|b|, d1 and d2 dU/dc and d^2U/dc^2:
    ``terms`` = (u, v, dca, dcb, c, ia, ib, d1, d2))."""
    u, v, dca, dcb, c, ia, ib, d1, d2 = terms
    caa_eye = -c * ia * ia  # the identity's coefficients in d^2c/da^2, d^2c/dadb, d^2c/db^2
    cab_eye = ia * ib
    cbb_eye = -c * ib * ib
    caa = -(u[a] * dca[b] + dca[a] * u[b]) * ia + caa_eye * (-u[a] * u[b])
    cab = cab_eye * (-v[a] * v[b]) - u[a] * dcb[b] * ia
    cbb = -(v[a] * dcb[b] + dcb[a] * v[b]) * ib + cbb_eye * (-v[a] * v[b])
    if a == b:
        caa += caa_eye
        cab += cab_eye
        cbb += cbb_eye
    return (d1 * caa + d2 * dca[a] * dca[b], d1 * cab + d2 * dca[a] * dcb[b],
            d1 * cbb + d2 * dcb[a] * dcb[b])


@njit(cache=True, inline="always")
def _bending_joint(i, la, lb, u, v, angle, k_b, rest_angle, grad, band, with_band):
    """Add joint i's bending gradient (and Hessian, ``with_band``) into grad, band, from its
    links' lengths la, lb [m], unit directions u, v (3-tuples) and ``angle`` = (c, s, beta)
    (:func:`_joint_angle`); return its energy [J]."""
    c, s, beta = angle
    if with_band:
        d1, d2 = _cos_derivatives(k_b, rest_angle, c, s, beta)
    else:  # the gradient alone (the explicit step's): no second derivative
        d1, d2 = _cos_first(k_b, rest_angle, s, beta), 0.0
    ia = 1.0 / la
    ib = 1.0 / lb
    dca = ((v[0] - c * u[0]) * ia, (v[1] - c * u[1]) * ia,
           (v[2] - c * u[2]) * ia)  # dc/da = w / |a|
    dcb = ((u[0] - c * v[0]) * ib, (u[1] - c * v[1]) * ib,
           (u[2] - c * v[2]) * ib)  # dc/db = z / |b|
    for a in range(3):
        grad[i, a] -= d1 * dca[a]
        grad[i + 1, a] += d1 * (dca[a] - dcb[a])
        grad[i + 2, a] += d1 * dcb[a]
    if with_band:
        # point blocks of the joint's points (i, i+1, i+2) from the link blocks: on and below
        # the diagonal: haa; hba - haa; haa - hab - hba + hbb; -hba; hba - hbb; hbb
        r0 = 3 * i
        terms = (u, v, dca, dcb, c, ia, ib, d1, d2)
        blocks = (_link_blocks(0, 0, terms), _link_blocks(0, 1, terms),
                  _link_blocks(0, 2, terms), _link_blocks(1, 0, terms),
                  _link_blocks(1, 1, terms), _link_blocks(1, 2, terms),
                  _link_blocks(2, 0, terms), _link_blocks(2, 1, terms),
                  _link_blocks(2, 2, terms))  # entry (a, b) at 3 a + b: no array to allocate
        for a in range(3):
            for b in range(3):
                haa, hab, hbb = blocks[3 * a + b]
                hba = blocks[3 * b + a][1]
                band[3 + a - b, r0 + b] += hba - haa  # (i+1, i)
                band[6 + a - b, r0 + b] -= hba  # (i+2, i)
                band[3 + a - b, r0 + 3 + b] += hba - hbb  # (i+2, i+1)
                if a >= b:
                    band[a - b, r0 + b] += haa
                    band[a - b, r0 + 3 + b] += haa - hab - hba + hbb
                    band[a - b, r0 + 6 + b] += hbb
    return 0.5 * k_b * (beta - rest_angle) ** 2


@njit_leaf(cache=True)
def _bending_terms(x, k_b, rest_angles, grad, band, with_band):
    """Add U^b's gradient (and Hessian, ``with_band``) into grad, band; return U^b [J]."""
    total = 0.0
    if x.shape[0] < 3:
        return total
    lb, v = _unit_link(x, 0)
    for i in range(x.shape[0] - 2):
        la, u = lb, v  # the joint's first link is the joint before's second
        lb, v = _unit_link(x, i + 1)
        total += _bending_joint(i, la, lb, u, v, _joint_angle(u, v), k_b, rest_angles[i], grad,
                                band, with_band)
    return total


@njit_leaf(cache=True)
def _gravity_terms(x, masses, gravity, grad):
    """Add U^g's gradient -m_i g into grad; return U^g [J]."""
    total = 0.0
    for i in range(x.shape[0]):
        for a in range(3):
            w_a = masses[i] * gravity[a]
            total -= w_a * x[i, a]
            grad[i, a] -= w_a
    return total


@njit_leaf(cache=True)
def chain_derivatives(x, k_s, rest_lengths, k_b, rest_angles, masses, gravity, grad, band):
    """Energy [J], and in place its gradient (n + 1, 3) [N] and lower Hessian band [N/m].

    ``grad`` and ``band`` (9, 3(n + 1)) are overwritten; the gradient includes gravity (as
    :func:`dloplan.physics.chain.gradient`), the band the axial and bending terms.
    """
    grad[:] = 0.0
    band[:] = 0.0
    with_band = np.bool_(True)  # a bool, not Literal[bool](True): one overload (dloplan.jit)
    return (_axial_terms(x, k_s, rest_lengths, grad, band, with_band)
            + _bending_terms(x, k_b, rest_angles, grad, band, with_band)
            + _gravity_terms(x, masses, gravity, grad))


GEOMETRY_COLUMNS = 10
"""Columns of a chain's geometry rows (:func:`chain_geometry`): link i's vector e (0-2) and
length (3) [m], its unit direction (4-6), and joint i's (links i, i + 1) c, sin and angle beta
(7-9; the last row's unused)."""


@njit_leaf(cache=True)
def chain_geometry(x, geometry):
    """The link vectors, lengths and directions and the joint angles of a shape x (n + 1, 3)
    [m], written into ``geometry`` (n, :data:`GEOMETRY_COLUMNS`): the values the energy and the
    derivatives compute (:func:`_unit_link`, :func:`_joint_angle`), kept so that the
    derivatives at an accepted trial need not compute them again
    (:func:`kept_chain_derivatives`)."""
    u = (0.0, 0.0, 0.0)
    for i in range(x.shape[0] - 1):
        before = u  # the joint's (i - 1) first link
        length, u = _unit_link(x, i)
        for a in range(3):
            geometry[i, a] = x[i + 1, a] - x[i, a]
            geometry[i, 4 + a] = u[a]
        geometry[i, 3] = length
        if i > 0:
            c, s, beta = _joint_angle(before, u)
            geometry[i - 1, 7] = c
            geometry[i - 1, 8] = s
            geometry[i - 1, 9] = beta


@njit_leaf(cache=True)
def kept_chain_energy(x, k_s, rest_lengths, k_b, rest_angles, masses, gravity, geometry):
    """:func:`chain_energy` [J], bit for bit, its geometry kept in ``geometry``
    (:func:`chain_geometry`)."""
    chain_geometry(x, geometry)
    total = 0.0
    for i in range(x.shape[0] - 1):
        stretch = geometry[i, 3] - rest_lengths[i]
        total += 0.5 * k_s * stretch * stretch
    for i in range(x.shape[0] - 2):
        total += 0.5 * k_b * (geometry[i, 9] - rest_angles[i]) ** 2
    for i in range(x.shape[0]):
        total -= masses[i] * (gravity[0] * x[i, 0] + gravity[1] * x[i, 1] + gravity[2] * x[i, 2])
    return total


@njit_leaf(cache=True)
def kept_chain_derivatives(x, k_s, rest_lengths, k_b, rest_angles, masses, gravity, geometry,
                           grad, band):
    """:func:`chain_derivatives`, bit for bit, from x's geometry computed before
    (:func:`chain_geometry`, :func:`kept_chain_energy`): no square root or atan2."""
    grad[:] = 0.0
    band[:] = 0.0
    with_band = np.bool_(True)
    axial = 0.0
    for i in range(x.shape[0] - 1):
        axial += _axial_link(i, (geometry[i, 0], geometry[i, 1], geometry[i, 2]),
                             geometry[i, 3], k_s, rest_lengths[i], grad, band, with_band)
    bending = 0.0
    for i in range(x.shape[0] - 2):
        bending += _bending_joint(
            i, geometry[i, 3], geometry[i + 1, 3],
            (geometry[i, 4], geometry[i, 5], geometry[i, 6]),
            (geometry[i + 1, 4], geometry[i + 1, 5], geometry[i + 1, 6]),
            (geometry[i, 7], geometry[i, 8], geometry[i, 9]), k_b, rest_angles[i], grad, band,
            with_band)
    return axial + bending + _gravity_terms(x, masses, gravity, grad)


@njit(cache=True)
def chain_gradient(x, k_s, rest_lengths, k_b, rest_angles, masses, gravity, grad):
    """Energy [J], and in place its gradient (n + 1, 3) [N] (gravity included)."""
    grad[:] = 0.0
    band = np.empty((0, 0))
    with_band = np.bool_(False)
    return (_axial_terms(x, k_s, rest_lengths, grad, band, with_band)
            + _bending_terms(x, k_b, rest_angles, grad, band, with_band)
            + _gravity_terms(x, masses, gravity, grad))


@njit(cache=True)
def chain_term_gradients(x, k_s, rest_lengths, k_b, rest_angles, axial, bending):
    """The axial and the bending gradient [N], each (n + 1, 3), written in place."""
    axial[:] = 0.0
    bending[:] = 0.0
    band = np.empty((0, 0))
    with_band = np.bool_(False)
    _axial_terms(x, k_s, rest_lengths, axial, band, with_band)
    _bending_terms(x, k_b, rest_angles, bending, band, with_band)


@njit(cache=True)
def stretch_to_length(chord, deviation, need):
    """The amplitude a >= 0 at which the polyline ``chord + a deviation`` is ``need`` long.

    Both (k, 3) [m]; the chord's length must be below ``need`` and the deviation non-zero. The
    length is convex in a, so Newton's method started where it is too long decreases
    monotonically to the root.
    """
    k = chord.shape[0] - 1

    def length_and_slope(a):
        total = 0.0
        slope = 0.0
        for i in range(k):
            e0 = chord[i + 1, 0] - chord[i, 0] + a * (deviation[i + 1, 0] - deviation[i, 0])
            e1 = chord[i + 1, 1] - chord[i, 1] + a * (deviation[i + 1, 1] - deviation[i, 1])
            e2 = chord[i + 1, 2] - chord[i, 2] + a * (deviation[i + 1, 2] - deviation[i, 2])
            length = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            total += length
            if length > 0.0:
                slope += (e0 * (deviation[i + 1, 0] - deviation[i, 0])
                          + e1 * (deviation[i + 1, 1] - deviation[i, 1])
                          + e2 * (deviation[i + 1, 2] - deviation[i, 2])) / length
        return total, slope

    high = 1.0
    while length_and_slope(high)[0] < need:
        high *= 2.0
    a = high
    for _ in range(100):
        total, slope = length_and_slope(a)
        step = (total - need) / slope
        a -= step
        if abs(step) <= 1e-12 * high:
            break
    return a


@njit(cache=True)
def resample_polyline(points, out):
    """``out`` (m, 3) <- m points equally spaced in arc length on the polyline ``points``
    (k, 3) [m], first and last kept; compiled :func:`dloplan.geometry.resample_by_arc_length`
    (the same linear interpolation, zero-length links skipped). The polyline must have a
    positive length."""
    k = points.shape[0]
    m = out.shape[0]
    s = np.empty(k)
    s[0] = 0.0
    for i in range(k - 1):
        s[i + 1] = s[i] + math.sqrt((points[i + 1, 0] - points[i, 0]) ** 2
                                    + (points[i + 1, 1] - points[i, 1]) ** 2
                                    + (points[i + 1, 2] - points[i, 2]) ** 2)
    j = 0
    for q in range(m):
        target = s[k - 1] * q / (m - 1)
        while j < k - 2 and s[j + 1] <= target:
            j += 1
        span = s[j + 1] - s[j]
        fraction = min(max((target - s[j]) / span, 0.0), 1.0) if span > 0.0 else 1.0
        for a in range(3):
            out[q, a] = points[j, a] + fraction * (points[j + 1, a] - points[j, a])
    for a in range(3):
        out[0, a] = points[0, a]
        out[m - 1, a] = points[k - 1, a]


@njit(cache=True)
def _bow_direction(chord, gravity):
    """Unit vector perpendicular to ``chord``: gravity's part, else world down, else y."""
    length = math.sqrt(chord[0] ** 2 + chord[1] ** 2 + chord[2] ** 2)
    axis = chord / length
    candidates = np.array([[gravity[0], gravity[1], gravity[2]], [0.0, 0.0, -1.0],
                           [0.0, 1.0, 0.0]])
    for c in range(3):
        candidate = candidates[c]
        perp = candidate - np.dot(candidate, axis) * axis
        size = math.sqrt(np.dot(perp, perp))
        if size > 1e-6 * max(math.sqrt(np.dot(candidate, candidate)), 1e-300):
            return perp / size
    return np.array([1.0, 0.0, 0.0])


@njit(cache=True)
def conform_free_part(x, held, need, length, gravity):
    """Points 1 .. n-1 of ``x`` (n + 1, 3) [m] made a polyline of length ``need`` [m] from
    ``held[1]`` to ``held[2]``, in place (the body of :func:`dloplan.sim.clips.conform_guess`).

    The guess is moved so its ends meet the inner held points (the offsets blended linearly in
    arc length s), its deviation from the chord is scaled by :func:`stretch_to_length` until the
    length is ``need``, and the points are spaced evenly along it. A chord longer than ``need``
    is taken straight; a straight guess is bowed by 1/2 (1 - cos 2 pi s) ``length`` toward
    gravity (or any perpendicular) first. ``held`` (4, 3) are the clips' held points, in the
    order of :data:`dloplan.sim.clips.HELD_INDICES`.
    """
    k = x.shape[0] - 2  # inner points 1 .. n-1
    inner = x[1:-1].copy()
    s = np.empty(k)
    s[0] = 0.0
    for i in range(k - 1):
        s[i + 1] = s[i] + math.sqrt(np.sum((inner[i + 1] - inner[i]) ** 2))
    total = s[k - 1]
    for i in range(k):
        s[i] = s[i] / total if total > 0.0 else i / (k - 1)
    start = held[1] - inner[0]
    end = held[2] - inner[k - 1]
    chord = np.empty((k, 3))
    deviation = np.empty((k, 3))
    largest = 0.0
    for i in range(k):
        inner[i] += (1.0 - s[i]) * start + s[i] * end
        chord[i] = held[1] + s[i] * (held[2] - held[1])
        deviation[i] = inner[i] - chord[i]
        largest = max(largest, math.sqrt(np.sum(deviation[i] ** 2)))
    x[0] = held[0]
    x[-1] = held[3]
    current = 0.0
    for i in range(k - 1):
        current += math.sqrt(np.sum((inner[i + 1] - inner[i]) ** 2))
    if abs(current / need - 1.0) < 1e-6:
        x[1:-1] = inner
        return
    if math.sqrt(np.sum((held[2] - held[1]) ** 2)) >= need:
        resample_polyline(chord, x[1:-1])
        return
    if largest < 1e-9 * length:
        bow = _bow_direction(held[2] - held[1], gravity)
        for i in range(k):
            deviation[i] = 0.5 * (1.0 - math.cos(2.0 * math.pi * s[i])) * length * bow
    amplitude = stretch_to_length(chord, deviation, need)
    resample_polyline(chord + amplitude * deviation, x[1:-1])
