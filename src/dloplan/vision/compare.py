"""Planned versus registered shapes: the error table of thesis 7.2.2 (Table 7.2, Fig. 7.10).

For each planned shape xi_j (n + 1 mass points) and its registered counterpart (any number of
points), the registered polyline is resampled to n + 1 points at the same fractions of its
length as the planned mass points (Fig. 6.4: equally spaced for a plan with equal links; a
slightly stretched plan is matched exactly, so a plan against itself gives zero). The errors
are taken point by point:

    e_{j,i} = x^reg_{j,i} - x^plan_{j,i}

* ``axis_errors[j]``: mean over the points (and over the repeated trials) of |e_x|, |e_y|,
  |e_z| [m];
* ``total_errors[j]``: the thesis' error_tot, the mean of the three axis errors (Table 7.2's
  error_tot column is exactly the mean of its error_x, error_y, error_z);
* ``euclidean_errors[j]``: mean of |e| (the distance between matched points) [m].

The last row ("all") averages over all shapes and points. Before comparing, each registered
shape is checked: its length must match the planned one (a shuffled point order or points not
in metres make it far longer); a registered shape listed from the other end is detected
(matching it reversed gives the smaller error) and flipped, which the result reports.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..geometry import arc_length, as_shape, shape_length
from ..io.poses import same_frame
from .shapes_io import RegisteredShape

END_ORDERS = ("detect", "keep")
TABLE_HEADER = ("shape", "error_x [m]", "error_y [m]", "error_z [m]", "error_tot [m]",
                "error_euclid [m]")


@dataclass(frozen=True)
class ShapeComparison:
    """Errors between planned shapes and registered ones (thesis Table 7.2, Fig. 7.10).

    Attributes
    ----------
    planned : numpy.ndarray
        (S + 2, n + 1, 3) planned shapes [m].
    registered : numpy.ndarray
        (T, S + 2, n + 1, 3) registered shapes of T trials, resampled (and flipped where
        reversed) [m].
    point_errors : numpy.ndarray
        (T, S + 2, n + 1, 3) signed errors registered - planned [m].
    axis_errors : numpy.ndarray
        (S + 2, 3) mean absolute error per shape and axis [m].
    total_errors : numpy.ndarray
        (S + 2,) thesis error_tot: mean of the three axis errors [m].
    euclidean_errors : numpy.ndarray
        (S + 2,) mean distance between matched points [m].
    labels : tuple of str
        One per shape.
    reversed_shapes : tuple of (int, int)
        (trial, shape) pairs whose point order was reversed to match the plan.
    message : str
        What was compared and what was corrected.
    """

    planned: np.ndarray
    registered: np.ndarray
    point_errors: np.ndarray
    axis_errors: np.ndarray
    total_errors: np.ndarray
    euclidean_errors: np.ndarray
    labels: tuple[str, ...]
    reversed_shapes: tuple[tuple[int, int], ...]
    message: str

    @property
    def axis_mean(self) -> np.ndarray:
        """(3,) mean absolute error per axis over all shapes and points [m]."""
        return np.abs(self.point_errors).mean(axis=(0, 1, 2))

    @property
    def total_mean(self) -> float:
        """The thesis' error_tot of the whole manipulation (Table 7.2) [m]."""
        return float(self.axis_mean.mean())

    @property
    def euclidean_mean(self) -> float:
        """Mean distance between matched points over all shapes [m]."""
        return float(np.linalg.norm(self.point_errors, axis=-1).mean())

    def rows(self) -> list[list]:
        """Table rows: label, error_x, error_y, error_z, error_tot, error_euclid [m]."""
        out = [[label, *axes, tot, eu] for label, axes, tot, eu in zip(
            self.labels, self.axis_errors.tolist(), self.total_errors.tolist(),
            self.euclidean_errors.tolist(), strict=True)]
        out.append(["all", *self.axis_mean.tolist(), self.total_mean, self.euclidean_mean])
        return out

    def table(self) -> str:
        """The error table as text, one row per shape and a last row for all of them."""
        width = max(len(TABLE_HEADER[0]), *(len(label) for label in self.labels), 3)
        lines = [f"{TABLE_HEADER[0]:<{width}}" + "".join(f"{h:>18}" for h in TABLE_HEADER[1:])]
        for row in self.rows():
            lines.append(f"{row[0]:<{width}}" + "".join(f"{v:>18.4f}" for v in row[1:]))
        if self.reversed_shapes:
            lines.append("reversed to match the plan (trial, shape): "
                         + ", ".join(f"({t}, {s})" for t, s in self.reversed_shapes))
        return "\n".join(lines)


def _resample_at(points: np.ndarray, fractions: np.ndarray) -> np.ndarray:
    """Points at the given fractions [0, 1] of the polyline's arc length, (len(fractions), 3)."""
    s = arc_length(points)
    keep = np.concatenate([[True], np.diff(s) > 0.0])
    s, points = s[keep] / s[-1], points[keep]
    return np.stack([np.interp(fractions, s, points[:, k]) for k in range(3)], axis=1)


def _as_points(shape, where: str) -> np.ndarray:
    if isinstance(shape, RegisteredShape):
        return shape.points
    return as_shape(shape, name=where)


def _check_frames(trial, frame_id: str, where: str) -> None:
    for k, shape in enumerate(trial):
        if isinstance(shape, RegisteredShape) and not same_frame(shape.frame_id, frame_id):
            raise ValueError(
                f"{where}[{k}]: registered in frame {shape.frame_id!r}, the plan is in "
                f"{frame_id!r}: transform it first (e.g. with the camera calibration)"
            )


def compare_trials(planned, trials: Sequence[Sequence], *, labels: Sequence[str] | None = None,
                   frame_id: str = "robot_base", end_order: str = "detect",
                   length_tolerance: float | None = 0.25) -> ShapeComparison:
    """Compare planned shapes with registered shapes of one or more repeated trials.

    Parameters
    ----------
    planned : array_like
        (S + 2, n + 1, 3) planned (or stabilized) shapes [m].
    trials : sequence of sequences
        T trials, each S + 2 registered shapes in the plan's order: RegisteredShape or (k, 3)
        arrays [m] in the plan's frame (k >= 2 points, any k).
    labels : sequence of str, optional
        One per shape; default: the registered labels of the first trial, else "xi_j".
    frame_id : str
        The plan's frame; a RegisteredShape in another frame is an error.
    end_order : {"detect", "keep"}
        "detect": a registered shape closer to the plan when reversed is flipped (and
        listed in ``reversed_shapes``); "keep": use the given order.
    length_tolerance : float or None
        A registered shape whose length differs from the planned one by more than this
        fraction is an error (shuffled points, wrong units, a cable partly out of view);
        None to skip the check.

    Returns
    -------
    ShapeComparison

    Raises
    ------
    ValueError
        For a different number of registered and planned shapes, a wrong frame, or a length
        outside the tolerance.
    """
    plan = np.asarray(planned, dtype=float)
    if plan.ndim != 3 or plan.shape[-1] != 3 or plan.shape[0] < 1 or plan.shape[1] < 2:
        raise ValueError(f"planned: expected shape (S + 2, n + 1, 3), got {plan.shape}")
    if not np.all(np.isfinite(plan)):
        raise ValueError("planned: non-finite coordinates")
    if end_order not in END_ORDERS:
        raise ValueError(f"end_order: got {end_order!r}, expected one of {END_ORDERS}")
    if length_tolerance is not None and not length_tolerance > 0:
        raise ValueError(f"length_tolerance: got {length_tolerance!r}, expected > 0 or None")
    if isinstance(trials, np.ndarray) or not isinstance(trials, Sequence) or not trials:
        raise ValueError("trials: expected a non-empty list of trials (lists of shapes)")
    n_shapes, n_points = plan.shape[:2]
    planned_lengths = shape_length(plan)
    if np.any(planned_lengths <= 0):
        raise ValueError(f"planned: shape {int(np.argmin(planned_lengths))} has zero length")
    fractions = arc_length(plan) / planned_lengths[:, None]
    registered = np.empty((len(trials), n_shapes, n_points, 3))
    flipped = []
    for t, trial in enumerate(trials):
        where = f"trials[{t}]" if len(trials) > 1 else "registered"
        if isinstance(trial, RegisteredShape) or not isinstance(trial, Sequence | np.ndarray):
            raise ValueError(f"{where}: expected a sequence of shapes")
        if len(trial) != n_shapes:
            raise ValueError(
                f"{where}: {len(trial)} registered shapes for {n_shapes} planned shapes "
                "(S + 2): give one registered shape per planned shape, in the plan's order"
            )
        _check_frames(trial, frame_id, where)
        for j, shape in enumerate(trial):
            points = _as_points(shape, f"{where}[{j}]")
            ratio = shape_length(points) / planned_lengths[j]
            if length_tolerance is not None and abs(ratio - 1.0) > length_tolerance:
                raise ValueError(
                    f"{where}[{j}]: registered shape is {shape_length(points):.4g} m long, the "
                    f"planned one {planned_lengths[j]:.4g} m (ratio {ratio:.2f}, tolerance "
                    f"{length_tolerance:.0%}): are its points shuffled (not in order along the "
                    "cable), not in metres, or is part of the cable missing?"
                )
            resampled = _resample_at(points, fractions[j])
            if end_order == "detect":
                backward = _resample_at(points[::-1], fractions[j])
                direct = np.linalg.norm(resampled - plan[j], axis=-1).mean()
                if np.linalg.norm(backward - plan[j], axis=-1).mean() < direct:
                    resampled = backward
                    flipped.append((t, j))
            registered[t, j] = resampled
    errors = registered - plan
    axis_errors = np.abs(errors).mean(axis=(0, 2))
    if labels is None:
        first = trials[0]
        given = [s.label if isinstance(s, RegisteredShape) else "" for s in first]
        labels = given if all(given) else [f"xi_{j}" for j in range(n_shapes)]
    labels = tuple(str(label) for label in labels)
    if len(labels) != n_shapes:
        raise ValueError(f"labels: {len(labels)} labels for {n_shapes} shapes")
    message = f"{len(trials)} trial(s) of {n_shapes} shapes compared at {n_points} points"
    if flipped:
        message += f"; {len(flipped)} registered shape(s) reversed to match the plan"
    return ShapeComparison(plan, registered, errors, axis_errors, axis_errors.mean(axis=1),
                           np.linalg.norm(errors, axis=-1).mean(axis=(0, 2)), labels,
                           tuple(flipped), message)


def compare_shapes(planned, registered: Sequence, **kwargs) -> ShapeComparison:
    """Compare planned shapes (S + 2, n + 1, 3) with one trial of S + 2 registered shapes.

    Keyword arguments are those of :func:`compare_trials`.
    """
    return compare_trials(planned, [registered], **kwargs)
