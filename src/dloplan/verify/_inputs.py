"""Validation of the inputs shared by the verification checks (paths, clip poses, times)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..sim.clips import ClipPoses, clip_poses_from_shape


def as_clip_sequence(
    clip_poses: Sequence[ClipPoses] | None, path: np.ndarray, name: str = "clip_poses"
) -> list[ClipPoses]:
    """One ClipPoses per shape of ``path``; ``None`` reads them off the shapes' end links."""
    if clip_poses is None:
        return [clip_poses_from_shape(x) for x in path]
    poses = list(clip_poses)
    if len(poses) != len(path):
        raise ValueError(
            f"{name}: {len(poses)} clip poses given, expected {len(path)} (one per shape)"
        )
    for k, pose in enumerate(poses):
        if not isinstance(pose, ClipPoses):
            raise ValueError(f"{name}[{k}]: got {type(pose).__name__}, expected ClipPoses")
    return poses


def as_times(times, count: int, name: str = "times", repeats: bool = False) -> np.ndarray:
    """``count`` finite, strictly increasing times [s].

    Parameters
    ----------
    times : array_like
        (count,) times [s].
    count : int
        How many times are expected.
    name : str
        The field named in an error.
    repeats : bool
        Whether a time may equal the one before it (non-decreasing times): a time law's knot
        times repeat across a segment where nothing moves (``dloplan.trajectory.TimeLaw``).

    Returns
    -------
    numpy.ndarray
        (count,) the times [s].
    """
    try:
        t = np.asarray(times, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected {count} times [s], got {type(times).__name__}") from exc
    if t.shape != (count,):
        raise ValueError(f"{name}: got shape {t.shape}, expected ({count},) (one time per shape)")
    steps = np.diff(t)
    if not np.all(np.isfinite(t)) or np.any(steps < 0 if repeats else steps <= 0):
        order = "non-decreasing" if repeats else "strictly increasing"
        raise ValueError(f"{name}: expected finite, {order} times [s], got {t}")
    return t


def max_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Largest point-to-point distance between two shapes (n + 1, 3) [m]."""
    return float(np.max(np.linalg.norm(a - b, axis=-1)))
