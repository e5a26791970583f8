"""Geometry of a discretized cable: links, tangents, bending angles, arc length.

A shape is an array ``(n + 1, 3)`` of mass-point positions [m]; every function here also takes a
batch ``(..., n + 1, 3)`` and returns the matching leading axes.
"""

from __future__ import annotations

import numpy as np


def as_shape(points, n_points: int | None = None, name: str = "shape") -> np.ndarray:
    """Validate and convert points to a C-contiguous float64 array (n_points, 3).

    Parameters
    ----------
    points : array_like
        Positions [m], (k, 3), or (k, 2) for a planar shape in the x-z plane (y = 0).
    n_points : int, optional
        The number of points expected.
    name : str
        The argument's name, used in error messages.

    Raises
    ------
    ValueError
        Naming ``name`` when the array has the wrong shape, the wrong number of points, or
        non-finite coordinates.
    """
    try:
        arr = np.ascontiguousarray(points, dtype=float)
    except (TypeError, ValueError) as exc:
        kind = type(points).__name__
        raise ValueError(f"{name}: expected an array of points, got {kind}") from exc
    if arr.ndim == 2 and arr.shape[1] == 2:
        arr = np.stack([arr[:, 0], np.zeros(len(arr)), arr[:, 1]], axis=1)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name}: expected points of shape (k, 3), got shape {arr.shape}")
    if n_points is not None and arr.shape[0] != n_points:
        raise ValueError(f"{name}: {arr.shape[0]} points given, expected {n_points} (n_links + 1)")
    if arr.shape[0] < 2:
        raise ValueError(f"{name}: {arr.shape[0]} points given, need at least 2")
    if not np.all(np.isfinite(arr)):
        bad = int(np.argwhere(~np.isfinite(arr))[0, 0])
        raise ValueError(f"{name}: point {bad} has a non-finite coordinate (NaN or inf); "
                         f"expected finite numbers")
    return arr


def as_path(path, n_points: int | None = None, name: str = "path") -> np.ndarray:
    """Validate and convert a path of shapes to float64 (n_shapes, n_points, 3) [m].

    Parameters
    ----------
    path : array_like
        (n_shapes, n_points, 3) positions [m]; a single shape (n_points, 3) is a path of one.
    n_points : int, optional
        The number of points every shape must have (n_links + 1).
    name : str
        The argument's name, used in error messages.

    Raises
    ------
    ValueError
        Naming ``name`` for a wrong array shape, a wrong or too small number of points per
        shape, or non-finite coordinates (with the shape and point).
    """
    try:
        arr = np.asarray(path, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected an array of shapes, got {type(path).__name__}") from exc
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[2] != 3 or arr.shape[0] < 1:
        raise ValueError(f"{name}: expected shape (n_shapes, n_points, 3), got {arr.shape}")
    if n_points is not None and arr.shape[1] != n_points:
        raise ValueError(f"{name}: {arr.shape[1]} points per shape, expected {n_points} "
                         f"(n_links + 1)")
    if arr.shape[1] < 2:
        raise ValueError(f"{name}: {arr.shape[1]} points per shape, need at least 2")
    if not np.all(np.isfinite(arr)):
        shape_index, point = np.argwhere(~np.isfinite(arr))[0, :2]
        raise ValueError(
            f"{name}: shape {shape_index}, point {point} has a non-finite coordinate (NaN or inf); "
            "expected finite numbers"
        )
    return arr


def norms(v: np.ndarray) -> np.ndarray:
    """Euclidean norms over the last axis, (...,): ``np.linalg.norm(v, axis=-1)`` without its
    per-call overhead, which counts in the solvers' inner loops."""
    return np.sqrt(np.einsum("...k,...k->...", v, v))


def link_vectors(x: np.ndarray) -> np.ndarray:
    """Link vectors e_i = x_i - x_{i-1} [m], shape (..., n, 3)."""
    return x[..., 1:, :] - x[..., :-1, :]


def link_lengths(x: np.ndarray) -> np.ndarray:
    """Link lengths l_i = |x_i - x_{i-1}| [m], shape (..., n)."""
    return norms(link_vectors(x))


def shape_length(x: np.ndarray) -> np.ndarray:
    """Total polyline length [m], shape (...)."""
    return link_lengths(x).sum(axis=-1)


def tangents(x: np.ndarray) -> np.ndarray:
    """Unit link directions u_i, shape (..., n, 3)."""
    e = link_vectors(x)
    return e / norms(e)[..., None]


def bending_angles(x: np.ndarray) -> np.ndarray:
    """Bending angles beta_i in [0, pi] between consecutive links [rad], shape (..., n - 1).

    Computed as atan2(|e_i x e_{i+1}|, e_i . e_{i+1}), accurate at 0 and at pi.
    """
    e = link_vectors(x)
    a, b = e[..., :-1, :], e[..., 1:, :]
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.einsum("...k,...k", a, b))


def arc_length(x: np.ndarray) -> np.ndarray:
    """Cumulative arc length at each point [m], shape (..., n + 1), starting at 0."""
    lengths = link_lengths(x)
    zero = np.zeros(lengths.shape[:-1] + (1,))
    return np.concatenate([zero, np.cumsum(lengths, axis=-1)], axis=-1)


_EPS = 1e-12
"""Squared length [m^2] below which a segment is a point, and the parallel test's scale."""


def segment_distance(p0, p1, q0, q1) -> np.ndarray:
    """Closest distance between segments [p0, p1] and [q0, q1], vectorized.

    Closed form of Ericson, *Real-Time Collision Detection* (2005), sec. 5.1.9: minimize
    |p0 + s d1 - q0 - t d2| over s, t in [0, 1], clamping s and then t, with the degenerate
    cases (a segment of zero length, parallel segments) handled explicitly.

    Parameters
    ----------
    p0, p1, q0, q1 : array_like
        (..., 3) end points [m], broadcast together.

    Returns
    -------
    numpy.ndarray
        (...,) distances [m].
    """
    p0, p1, q0, q1 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (p0, p1, q0, q1)))
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = np.einsum("...k,...k", d1, d1)
    e = np.einsum("...k,...k", d2, d2)
    f = np.einsum("...k,...k", d2, r)
    c = np.einsum("...k,...k", d1, r)
    b = np.einsum("...k,...k", d1, d2)
    denom = a * e - b * b
    # s on the infinite lines (0 when parallel: any s is closest, pick the start), clamped.
    s = np.where(denom > _EPS * np.maximum(a * e, _EPS),
                 (b * f - c * e) / np.where(denom > 0, denom, 1.0), 0.0)
    s = np.clip(s, 0.0, 1.0)
    t = (b * s + f) / np.where(e > _EPS, e, 1.0)
    # t outside [0, 1]: clamp it and recompute s for the clamped t.
    t_clamped = np.clip(t, 0.0, 1.0)
    s = np.where(t != t_clamped,
                 np.clip((b * t_clamped - c) / np.where(a > _EPS, a, 1.0), 0.0, 1.0), s)
    t = t_clamped
    # Degenerate segments (points).
    point_p = a <= _EPS
    point_q = e <= _EPS
    s = np.where(point_p, 0.0, s)
    t = np.where(point_p & ~point_q, np.clip(f / np.where(e > _EPS, e, 1.0), 0.0, 1.0), t)
    t = np.where(point_q, 0.0, t)
    s = np.where(point_q & ~point_p, np.clip(-c / np.where(a > _EPS, a, 1.0), 0.0, 1.0), s)
    closest = (p0 + s[..., None] * d1) - (q0 + t[..., None] * d2)
    return np.linalg.norm(closest, axis=-1)


def resample_by_arc_length(points, n_points: int) -> np.ndarray:
    """Resample a polyline to ``n_points`` points equally spaced in arc length (thesis Fig. 6.4).

    Parameters
    ----------
    points : array_like
        Polyline (k, 3) [m], k >= 2, no zero-length total.
    n_points : int
        Number of output points, >= 2.

    Returns
    -------
    numpy.ndarray
        (n_points, 3) points on the polyline, first and last points kept.
    """
    x = as_shape(points, name="points")
    if n_points < 2:
        raise ValueError(f"n_points: got {n_points}, expected >= 2")
    s = arc_length(x)
    if s[-1] <= 0.0:
        raise ValueError("points: the polyline has zero length")
    keep = np.concatenate([[True], np.diff(s) > 0.0])
    s, x = s[keep], x[keep]
    target = np.linspace(0.0, s[-1], n_points)
    return np.stack([np.interp(target, s, x[:, k]) for k in range(3)], axis=1)
