"""Compiled capsule-box distance: the golden-section search of :mod:`.shapes`, point by point.

:meth:`dloplan.obstacles.shapes.Box.penetration` minimizes the (convex) distance to the box
along each link by a golden-section search (60 steps, bracket 3e-13). Vectorized with numpy
that costs about 120 small array calls per shape, which dominated a robustness study's
collision checks; this is the same search with the same arithmetic compiled by numba
(``cache=True``), one loop per link.
"""

from __future__ import annotations

import math

from ..jit import njit

_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
_SEARCH_STEPS = 60  # as in .shapes


@njit(cache=True)
def _box_distance(px, py, pz, center, half, c, s):
    """Distance [m] from the point p to the box (centre, half sizes, yaw cos/sin c, s)."""
    qx = px - center[0]
    qy = py - center[1]
    qz = pz - center[2]
    ex = max(abs(c * qx + s * qy) - half[0], 0.0)
    ey = max(abs(-s * qx + c * qy) - half[1], 0.0)
    ez = max(abs(qz) - half[2], 0.0)
    return math.sqrt(ex * ex + ey * ey + ez * ez)


@njit(cache=True)
def box_segment_distances(a, b, center, half, yaw, out):
    """Smallest distance [m] from each segment a[i] -> b[i] ((m, 3) each) to the box, into
    ``out`` (m,): the box at ``center`` (3,) with half edge lengths ``half`` (3,) [m], turned by
    ``yaw`` [rad] about z."""
    c = math.cos(yaw)
    s = math.sin(yaw)
    for i in range(a.shape[0]):
        ax, ay, az = a[i, 0], a[i, 1], a[i, 2]
        dx, dy, dz = b[i, 0] - ax, b[i, 1] - ay, b[i, 2] - az
        lo = 0.0
        hi = 1.0
        for _ in range(_SEARCH_STEPS):
            t1 = hi - _GOLDEN * (hi - lo)
            t2 = lo + _GOLDEN * (hi - lo)
            if (_box_distance(ax + t1 * dx, ay + t1 * dy, az + t1 * dz, center, half, c, s)
                    < _box_distance(ax + t2 * dx, ay + t2 * dy, az + t2 * dz, center, half, c,
                                    s)):
                hi = t2
            else:
                lo = t1
        t = 0.5 * (lo + hi)
        middle = _box_distance(ax + t * dx, ay + t * dy, az + t * dz, center, half, c, s)
        ends = min(_box_distance(ax, ay, az, center, half, c, s),
                   _box_distance(b[i, 0], b[i, 1], b[i, 2], center, half, c, s))
        out[i] = min(middle, ends)

