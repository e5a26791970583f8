"""Measured points projected onto polylines, compiled: the nearest point of each segment.

:func:`.measurement.nearest_points` asks, for every measured point (200 of them) and every
segment of a shape (n of them), where on the segment the point is nearest; in numpy that is a
dozen (k, m) temporaries per coordinate, about 0.1 ms for one measurement and, for a study's
chunk of 256 measurements at once, arrays too large for the cache (0.3 ms a measurement). Here
the same arithmetic runs point by point: for the segment a b,

    t = clip(((p - a) . (b - a)) / |b - a|^2, 0, 1),   d^2 = |p - a - t (b - a)|^2,

the first segment of least d^2 wins, and the point's position along the polyline is the arc
length at a plus t |b - a|.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit


@njit(cache=True)
def project_points(points, polylines, along, distance):
    """The nearest point of ``polylines[b]`` (or of ``polylines[0]``, when only one is given)
    to each of ``points[b]``, in place.

    Parameters
    ----------
    points : numpy.ndarray
        (B, k, 3) [m].
    polylines : numpy.ndarray
        (B, m, 3) or (1, m, 3) [m], m >= 2.
    along, distance : numpy.ndarray
        (B, k) out: its arc length along the polyline and its distance [m].
    """
    m = polylines.shape[1]
    s = np.empty(m)
    lengths = np.empty(m - 1)
    for b in range(points.shape[0]):
        line = polylines[b if polylines.shape[0] > 1 else 0]
        s[0] = 0.0
        for j in range(m - 1):
            lengths[j] = math.sqrt((line[j + 1, 0] - line[j, 0]) ** 2
                                   + (line[j + 1, 1] - line[j, 1]) ** 2
                                   + (line[j + 1, 2] - line[j, 2]) ** 2)
            s[j + 1] = s[j] + lengths[j]
        for i in range(points.shape[1]):
            best, segment, position = math.inf, 0, 0.0
            for j in range(m - 1):
                ab0 = line[j + 1, 0] - line[j, 0]
                ab1 = line[j + 1, 1] - line[j, 1]
                ab2 = line[j + 1, 2] - line[j, 2]
                r0 = points[b, i, 0] - line[j, 0]
                r1 = points[b, i, 1] - line[j, 1]
                r2 = points[b, i, 2] - line[j, 2]
                t = (r0 * ab0 + r1 * ab1 + r2 * ab2) / (ab0 * ab0 + ab1 * ab1 + ab2 * ab2)
                t = min(max(t, 0.0), 1.0)
                squared = (r0 - t * ab0) ** 2 + (r1 - t * ab1) ** 2 + (r2 - t * ab2) ** 2
                if squared < best:
                    best, segment, position = squared, j, t
            along[b, i] = s[segment] + position * lengths[segment]
            distance[b, i] = math.sqrt(best)
