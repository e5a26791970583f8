"""Hard contact of mass points with obstacles, compiled: the explicit simulator's contacts.

An obstacle is given as a row of 8 numbers (its ``contact_row()``, :mod:`dloplan.obstacles`):
``[PLANE, height, 0...]`` for the table plane, ``[CYLINDER, base (3), radius, height, 0, 0]``
for a vertical cylinder (a peg), ``[BOX, center (3), half sizes (3), yaw]`` for a box turned
about z [m, rad]. :func:`point_distance` is the obstacles' ``signed_distance`` for one point
(tested equal); :func:`push_out` moves the points that come closer than the cable's radius back
out along the normal and removes their velocity into the obstacle: an inelastic contact, as the
simulator's ground plane (:mod:`dloplan.sim.stepping`), with Coulomb friction on the impulse.
It runs at every explicit step, so it measures a point's distance only to the obstacles whose
bounding box comes within the radius of the points' (on a harness board the taut section is
clear of the wall and the table), and of those only for the points within the radius of the
obstacle's box (a cable's few points at a peg), each box's turn computed once per call. The
statics use a penalty instead (:mod:`dloplan.physics.contact`): its stiffness, a hundred times
the axial springs', would need a ten times smaller explicit time step.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit

PLANE, CYLINDER, BOX = 0.0, 1.0, 2.0
"""Kinds of obstacle rows (the row's first entry)."""


@njit(cache=True)
def _box_like(q0, q1, q2, e0, e1, e2, count):
    """:func:`dloplan.obstacles.shapes._box_normal` for one point: the normal's components in
    the frame of q (signs from q) and the signed distance, for ``count`` (2 or 3) components."""
    o0, o1, o2 = max(e0, 0.0), max(e1, 0.0), max(e2, 0.0) if count == 3 else 0.0
    dist = math.sqrt(o0 * o0 + o1 * o1 + o2 * o2)
    if dist == 0.0:  # inside: through the face of the largest excess
        n0, n1, n2 = 0.0, 0.0, 0.0
        phi = e0
        if e1 > phi:
            phi = e1
        if count == 3 and e2 > phi:
            phi = e2
        if e0 == phi:
            n0 = 1.0
        elif e1 == phi:
            n1 = 1.0
        else:
            n2 = 1.0
    else:
        n0, n1, n2 = o0 / dist, o1 / dist, o2 / dist
        phi = dist
    n0 = n0 if q0 >= 0.0 else -n0
    n1 = n1 if q1 >= 0.0 else -n1
    n2 = n2 if q2 >= 0.0 else -n2
    return phi, n0, n1, n2


@njit(cache=True)
def point_distance(x, y, z, row):
    """Signed distance [m] and outward unit normal of one point to one obstacle row, as the
    obstacle's ``signed_distance``: ``(phi, nx, ny, nz)``."""
    c, s = row_turn(row)
    return turned_distance(x, y, z, row, c, s)


@njit(cache=True, inline="always")
def row_turn(row):
    """cos and sin of a box row's yaw ((1, 0) for the other kinds): what
    :func:`turned_distance` needs of it, computed once for the points of a loop."""
    if row[0] == BOX:
        return math.cos(row[7]), math.sin(row[7])
    return 1.0, 0.0


@njit(cache=True, inline="always")
def turned_distance(x, y, z, row, c, s):
    """:func:`point_distance` with the row's ``c, s = row_turn(row)`` given."""
    kind = row[0]
    if kind == PLANE:
        return z - row[1], 0.0, 0.0, 1.0
    if kind == CYLINDER:
        qx, qy, qz = x - row[1], y - row[2], z - row[3]
        rho = math.sqrt(qx * qx + qy * qy)
        rx, ry = (qx / rho, qy / rho) if rho > 0.0 else (1.0, 0.0)
        above = qz > 0.5 * row[5]
        phi, w0, w1, _ = _box_like(1.0, 1.0, 1.0, rho - row[4],
                                   qz - row[5] if above else -qz, 0.0, np.int64(2))
        return phi, w0 * rx, w0 * ry, w1 if above else -w1
    qx, qy, qz = x - row[1], y - row[2], z - row[3]
    lx, ly = c * qx + s * qy, -s * qx + c * qy
    phi, n0, n1, n2 = _box_like(lx, ly, qz, abs(lx) - row[4], abs(ly) - row[5],
                                abs(qz) - row[6], np.int64(3))  # int64 (dloplan.jit)
    return phi, c * n0 - s * n1, s * n0 + c * n1, n2


@njit(cache=True)
def signed_distances(points, rows, phi, normals):
    """:func:`point_distance` of points (m, 3) to every row (K, 8) into ``phi`` (K, m) [m] and
    ``normals`` (K, m, 3)."""
    for k in range(rows.shape[0]):
        c, s = row_turn(rows[k])
        for i in range(points.shape[0]):
            d, nx, ny, nz = turned_distance(points[i, 0], points[i, 1], points[i, 2], rows[k],
                                            c, s)
            phi[k, i] = d
            normals[k, i, 0] = nx
            normals[k, i, 1] = ny
            normals[k, i, 2] = nz


REACH_MARGIN = 1e-9
"""Slack [m] of :func:`push_out`'s bounding-box tests, far above the round-off of a distance,
so that a point the tests pass over is one :func:`point_distance` finds clear."""


@njit(cache=True, inline="always")
def _reach_box(row, c, s, reach):
    """The obstacle row's own bounding box grown by ``reach`` [m]: ``(x0, x1, y0, y1, z0, z1)``
    (a plane: the half-space below it, z1 its only bound); ``c, s = row_turn(row)``."""
    if row[0] == PLANE:
        return -math.inf, math.inf, -math.inf, math.inf, -math.inf, row[1] + reach
    if row[0] == CYLINDER:
        ex, ey, bottom, top = row[4], row[4], row[3], row[3] + row[5]
    else:
        ex = abs(c) * row[4] + abs(s) * row[5]
        ey = abs(s) * row[4] + abs(c) * row[5]
        bottom, top = row[3] - row[6], row[3] + row[6]
    return (row[1] - ex - reach, row[1] + ex + reach, row[2] - ey - reach,
            row[2] + ey + reach, bottom - reach, top + reach)


@njit(cache=True, inline="always")
def _within(box, plane, lo0, lo1, lo2, hi0, hi1, hi2):
    """Whether the bounding box [lo, hi] [m] meets ``box`` (:func:`_reach_box`; ``plane``:
    of a plane row, whose box bounds z only)."""
    if plane:
        return lo2 < box[5]
    return (lo0 < box[1] and hi0 > box[0] and lo1 < box[3] and hi1 > box[2]
            and lo2 < box[5] and hi2 > box[4])


@njit(cache=True, inline="always")
def _outside(box, plane, x, y, z):
    """Whether the point (x, y, z) [m] lies out of ``box`` (:func:`_within`'s box and
    ``plane``), decided only where its coordinates say so (a NaN is not outside)."""
    if plane:
        return z >= box[5]
    return (x >= box[1] or x <= box[0] or y >= box[3] or y <= box[2] or z >= box[5]
            or z <= box[4])


@njit(cache=True)
def push_out(x, v, accel, rows, radius, friction, first, stop):
    """Hard one-sided contact of points ``first .. stop - 1`` of x, v, accel (n + 1, 3) [m],
    [m/s], [m/s^2], with Coulomb friction.

    A point closer than ``radius`` to an obstacle row is moved out along the normal to that
    distance and loses its velocity into the obstacle (an inelastic contact, as the simulator's
    ground plane): a normal impulse per unit mass j = -v.n. Friction takes at most
    ``friction`` j of its tangential velocity (Coulomb's law for impulses: a point pressed by
    its weight sticks while the tangential pull is below ``friction`` times the pressing
    force). The acceleration's part the obstacle carries (into it, and along it within the
    friction cone) is removed too, so that a cable resting on an obstacle counts as at rest.
    """
    lo0, lo1, lo2 = x[first, 0], x[first, 1], x[first, 2]  # the points' bounding box: an
    hi0, hi1, hi2 = lo0, lo1, lo2  # obstacle whose own box is farther than the radius from it
    for i in range(first + 1, stop):  # touches none of them
        lo0, lo1, lo2 = min(lo0, x[i, 0]), min(lo1, x[i, 1]), min(lo2, x[i, 2])
        hi0, hi1, hi2 = max(hi0, x[i, 0]), max(hi1, x[i, 1]), max(hi2, x[i, 2])
    for k in range(rows.shape[0]):
        c, s = row_turn(rows[k])
        box, plane = _reach_box(rows[k], c, s, radius + REACH_MARGIN), rows[k][0] == PLANE
        if not _within(box, plane, lo0, lo1, lo2, hi0, hi1, hi2):
            continue
        for i in range(first, stop):
            if _outside(box, plane, x[i, 0], x[i, 1], x[i, 2]):  # nor a point out of its box
                continue
            phi, nx, ny, nz = turned_distance(x[i, 0], x[i, 1], x[i, 2], rows[k], c, s)
            if phi >= radius:
                continue
            depth = radius - phi
            x[i, 0] += depth * nx
            x[i, 1] += depth * ny
            x[i, 2] += depth * nz
            inward = v[i, 0] * nx + v[i, 1] * ny + v[i, 2] * nz
            if inward < 0.0:
                v[i, 0] -= inward * nx
                v[i, 1] -= inward * ny
                v[i, 2] -= inward * nz
                if friction > 0.0:
                    slip = math.sqrt(v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2)
                    if slip > 0.0:  # v is tangential now
                        keep = max(0.0, 1.0 - friction * (-inward) / slip)
                        v[i, 0] *= keep
                        v[i, 1] *= keep
                        v[i, 2] *= keep
            pressed = accel[i, 0] * nx + accel[i, 1] * ny + accel[i, 2] * nz
            if pressed < 0.0:
                accel[i, 0] -= pressed * nx
                accel[i, 1] -= pressed * ny
                accel[i, 2] -= pressed * nz
                along = math.sqrt(accel[i, 0] ** 2 + accel[i, 1] ** 2 + accel[i, 2] ** 2)
                if along <= friction * (-pressed):
                    accel[i, 0] = 0.0
                    accel[i, 1] = 0.0
                    accel[i, 2] = 0.0
