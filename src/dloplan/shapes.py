"""Parametric cable shapes: straight segment, circular arc, sine wave, placed in the world.

Each builder returns ``n_links + 1`` points [m] of a curve of the given arc length, drawn in its
local x-y plane starting at the origin along +x, then moved by :func:`place`. Straight and arc
shapes have links of exactly ``length / n_links`` (the arc is the discrete arc: equal chords
turning by a constant angle), so they can serve as rest shapes; the sine wave is resampled by arc
length by choosing its extent so that n links of exactly L/n walked along it end at its end.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from .geometry import as_shape, resample_by_arc_length, shape_length


def _check(length: float, n_links: int) -> None:
    if not (math.isfinite(length) and length > 0):
        raise ValueError(f"length: got {length!r}, expected a length > 0 [m]")
    if int(n_links) != n_links or n_links < 1:
        raise ValueError(f"n_links: got {n_links!r}, expected an integer >= 1")


def straight_shape(length: float, n_links: int) -> np.ndarray:
    """A straight cable along +x from the origin, (n + 1, 3) [m]."""
    _check(length, n_links)
    x = np.linspace(0.0, length, n_links + 1)
    return np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)


def arc_shape(length: float, n_links: int, angle: float) -> np.ndarray:
    """A discrete circular arc turning by ``angle`` [rad] (positive toward +y), (n + 1, 3) [m].

    The n links of length L/n turn by angle/(n - 1) at every interior point, so the tangent
    turns by ``angle`` from the first link to the last.
    """
    _check(length, n_links)
    if not math.isfinite(angle):
        raise ValueError(f"angle: got {angle!r}, expected a finite angle [rad]")
    turn = angle / max(n_links - 1, 1)
    headings = turn * (np.arange(n_links) - (n_links - 1) / 2)  # symmetric about +x
    steps = np.stack([np.cos(headings), np.sin(headings), np.zeros(n_links)], 1)
    return np.vstack([np.zeros(3), np.cumsum(steps * (length / n_links), axis=0)])


def sine_shape(length: float, n_links: int, amplitude: float, periods: float = 1.0) -> np.ndarray:
    """A sine wave y = A sin(2 pi periods x / X) drawn with n links of exactly L/n, (n + 1, 3) [m].

    The extent X is chosen so that n equal chords walked along the wave end at its end.
    """
    _check(length, n_links)
    if not (math.isfinite(amplitude) and math.isfinite(periods) and periods > 0):
        raise ValueError(
            f"amplitude, periods: got {amplitude!r}, {periods!r}, expected finite values, "
            "periods > 0"
        )
    link = length / n_links
    fine = np.linspace(0.0, 1.0, 4001)

    def chords(extent: float) -> tuple[np.ndarray, float]:
        curve = np.stack([fine * extent, amplitude * np.sin(2 * np.pi * periods * fine),
                          np.zeros_like(fine)], axis=1)
        return _walk_chords(curve, link, n_links)

    if chords(length)[1] > 0:  # even a flat extent L is too short for the chords
        extent = length
    else:
        low = 1e-6 * length
        if chords(low)[1] < 0:
            raise ValueError(
                f"amplitude: {amplitude} m with {periods} periods needs more than {length} m "
                "of cable"
            )
        from scipy.optimize import brentq  # here: scipy.optimize costs the CLI 0.13 s to import

        extent = brentq(lambda e: chords(e)[1], low, length, xtol=1e-12)
    points, miss = chords(extent)
    if abs(miss) > 1e-6 * length:
        raise ValueError(
            f"amplitude: a {amplitude} m sine with {periods} periods is too wavy for {n_links} "
            f"links of {link:.4g} m (use more links or a smaller amplitude)"
        )
    return points


def _walk_chords(curve: np.ndarray, link: float, n_links: int) -> tuple[np.ndarray, float]:
    """Points at chord distance ``link`` along a fine polyline, and the signed miss at its end.

    The miss is > 0 when the chords run past the curve's end (the last point is extrapolated
    along the last segment), < 0 when they stop short of it.
    """
    points = [curve[0]]
    start = 0
    for _ in range(n_links):
        distance = np.linalg.norm(curve[start:] - points[-1], axis=1)
        beyond = np.flatnonzero(distance >= link)
        if len(beyond) == 0:  # ran off the end: continue straight along the last segment
            direction = curve[-1] - curve[-2]
            direction /= np.linalg.norm(direction)
            points.append(points[-1] + link * direction)
            start = len(curve) - 1
            continue
        k = start + int(beyond[0])
        a, b = curve[k - 1], curve[k]
        # the point on segment a-b at distance link from the last point
        d = b - a
        f = a - points[-1]
        qa, qb, qc = d @ d, 2 * f @ d, f @ f - link**2
        t = (-qb + math.sqrt(max(qb * qb - 4 * qa * qc, 0.0))) / (2 * qa)
        points.append(a + t * d)
        start = k - 1
    out = np.array(points)
    end = curve[-1]
    past = float(np.dot(out[-1] - end, curve[-1] - curve[-2]))
    miss = np.linalg.norm(out[-1] - end) * (1.0 if past > 0 else -1.0)
    return out, float(miss)


LENGTH_TOLERANCE = 0.05
"""Relative difference between a given shape's length and the cable's accepted at the input."""


def units_hint(ratio: float) -> str:
    """The unit slip a shape's length ``ratio`` to its cable's points at, or "".

    About 1000 times long: millimetres read as metres; about 1000 times short: metres written
    into a file in millimetres (which the loader scaled by 1e-3).

    Parameters
    ----------
    ratio : float
        The shape's length over the cable's [-].
    """
    if 500 < ratio < 2000:
        return " (given in millimetres?)"
    if 1 / 2000 < ratio < 1 / 500:
        return " (given in metres in a file in millimetres?)"
    return ""


def discretize(points, cable, name: str = "shape",
               length_tolerance: float = LENGTH_TOLERANCE) -> np.ndarray:
    """A user's shape as the cable's n + 1 points [m].

    (k, 2) x-z shapes are lifted to 3D, other point counts resampled by arc length, and the
    length checked against the cable's.

    Parameters
    ----------
    points : array_like
        (k, 3) or (k, 2) points [m], k >= 2.
    cable : Cable
        The cable (its n_links and length).
    name : str
        The argument's name, used in error messages.
    length_tolerance : float
        Accepted relative difference between the shape's length and the cable's.

    Raises
    ------
    ValueError
        Naming ``name`` for a malformed array, coincident consecutive points, or a length off
        by more than ``length_tolerance`` (with a hint when it is about 1000 times off:
        :func:`units_hint`).
    """
    x = as_shape(points, name=name)
    if x.shape[0] != cable.n_points:
        if shape_length(x) <= 0.0:
            raise ValueError(f"{name}: the polyline has zero length")
        x = resample_by_arc_length(x, cable.n_points)
    if np.any(np.linalg.norm(np.diff(x, axis=0), axis=1) <= 1e-9 * cable.length):
        raise ValueError(f"{name}: two consecutive points coincide (a zero-length link)")
    length = float(shape_length(x))
    ratio = length / cable.length
    if abs(ratio - 1.0) > length_tolerance:
        hint = units_hint(ratio)
        raise ValueError(
            f"{name}: the shape is {length:.4g} m long but the cable is {cable.length:.4g} m"
            f"{hint}; expected within {100 * length_tolerance:g} % (length_tolerance)"
        )
    return x


def place(shape, position=(0.0, 0.0, 0.0), rotation: Rotation | None = None) -> np.ndarray:
    """Move a shape rigidly: x -> rotation x + position [m]."""
    x = np.asarray(shape, dtype=float)
    if rotation is not None:
        x = rotation.apply(x)
    return x + np.asarray(position, dtype=float)
