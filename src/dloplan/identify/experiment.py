"""The identification experiment as data (thesis 6.1, Figs. 6.3-6.4).

An experiment (:class:`Experiment`) is one manipulation (:class:`Manipulation`) of the real
cable and its outcome:

* the **initial shape**, a polyline [m] of any number of points (the cable as it lies in the
  clips before the manipulation; it is only the starting guess of the first equilibrium, so
  its accuracy matters little),
* the **clip trajectory**, the sequence of :class:`~dloplan.sim.clips.ClipPoses` the robot
  visits (the first one holds the initial shape), slow enough for the cable to stay in
  equilibrium (quasi-static),
* the **measured final shape**, a polyline [m] of any number of points, in the robot's world
  frame (e.g. from :mod:`dloplan.vision`, or read off graph paper as the thesis did),
* how the cable is held: ``"both"`` clips, or ``"first"`` only (a cantilever: the last clip
  has let go; ``clips[k].positions[1]`` is then ignored),
* the measurement accuracy [m] (one standard deviation per coordinate), used to judge
  whether the experiment tells moduli apart.

The experiment is cable-independent data (the clip poses are where the clips are, whatever the
discretization: a model of n links holds the middle of its end links there, thesis Fig. 4.5):
:func:`prepare_shapes` checks the measurement against a cable (length, units, which end is
first, the frame), orients it, and gives the initial shape and a guess of the final one on the
cable's n + 1 points (the measured shape smoothed and resampled by arc length, Fig. 6.4).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..geometry import as_shape
from ..shapes import LENGTH_TOLERANCE, discretize, units_hint
from ..sim.clips import ClipPoses
from .measured import MeasuredCurve, measured_curve, point_scatter

HELD_MODES = ("both", "first")

END_TOLERANCE = 0.05
"""Largest distance between a measured end and its clip, as a fraction of the cable length."""


@dataclass(frozen=True, eq=False)
class Manipulation:
    """What the robot does in an identification experiment.

    Parameters
    ----------
    initial_shape : array_like
        (k, 3) polyline [m] of the cable at the start, k >= 2 (or (k, 2) = (x, z) points).
    clips : sequence of ClipPoses
        The clip poses visited, in order, the first holding the initial shape.
    held : {"both", "first"}
        Both clips hold the cable, or only the first (a cantilever).
    gravity : array_like
        Gravity acceleration in the world frame [m/s^2].
    """

    initial_shape: np.ndarray
    clips: tuple[ClipPoses, ...]
    held: str = "both"
    gravity: np.ndarray = field(default_factory=GRAVITY.copy)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "initial_shape", as_shape(self.initial_shape, name="initial_shape"))
        clips = tuple(self.clips) if isinstance(self.clips, Sequence) else None
        if not clips or not all(isinstance(c, ClipPoses) for c in clips):
            raise ValueError(
                f"clips: got {type(self.clips).__name__}, expected a non-empty sequence of "
                "ClipPoses (the clip trajectory)"
            )
        set_(self, "clips", clips)
        if self.held not in HELD_MODES:
            raise ValueError(f"held: got {self.held!r}, expected 'both' or 'first'")
        g = np.asarray(self.gravity, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"gravity: got {self.gravity!r}, expected 3 finite numbers [m/s^2]")
        set_(self, "gravity", g)

    @property
    def final_clips(self) -> ClipPoses:
        """The clip poses at the end of the manipulation."""
        return self.clips[-1]


@dataclass(frozen=True, eq=False)
class Experiment:
    """One identification manipulation and its measured outcome.

    Parameters
    ----------
    manipulation : Manipulation
        Initial shape, clip trajectory, held mode, gravity.
    measured_shape : array_like
        (k, 3) polyline [m] of the final shape, any k >= 2, in the world frame.
    measurement_noise : float
        Standard deviation of a measured coordinate [m] (default 1 mm).
    name : str
        A label.
    """

    manipulation: Manipulation
    measured_shape: np.ndarray
    measurement_noise: float = 1e-3
    name: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.manipulation, Manipulation):
            raise ValueError(
                f"manipulation: got {type(self.manipulation).__name__}, expected a Manipulation"
            )
        object.__setattr__(self, "measured_shape",
                           as_shape(self.measured_shape, name="measured_shape"))
        noise = float(self.measurement_noise)
        if not (math.isfinite(noise) and noise > 0):
            raise ValueError(
                f"measurement_noise: got {self.measurement_noise!r}, expected a distance > 0 [m]"
            )
        object.__setattr__(self, "measurement_noise", noise)


@dataclass(frozen=True, eq=False)
class PreparedShapes:
    """The experiment's shapes for one cable (see :func:`prepare_shapes`).

    Attributes
    ----------
    initial : numpy.ndarray
        (n + 1, 3) initial shape [m].
    measured : numpy.ndarray
        (k, 3) measured points [m], from the first clip's end to the other.
    guess : numpy.ndarray
        (n + 1, 3) the measured shape smoothed and resampled by arc length [m]: the start of
        the final equilibrium on the measured branch.
    curve : MeasuredCurve
        The smoothed measurement (length, smallest bend radius).
    reversed : bool
        True when the measured points were given from the last clip's end and were reversed.
    """

    initial: np.ndarray
    measured: np.ndarray
    guess: np.ndarray
    curve: MeasuredCurve
    reversed: bool


def seat_in_first_clip(shape: np.ndarray, clips: ClipPoses, link_length: float) -> np.ndarray:
    """Move a shape rigidly so its first link lies in the first clip (position and u-axis).

    A shape written for one discretization, held at the middle of its first link, starts half a
    link of another n away from the clip's held points; a cantilever's solver holds points 0 and
    1 where the clip says, so the shape is moved there first (a two-clip solver conforms its
    guess itself).
    """
    held = clips.held_points(link_length)[:2]
    rotation, _ = Rotation.align_vectors([held[1] - held[0]], [shape[1] - shape[0]])
    middle = 0.5 * (shape[0] + shape[1])
    return rotation.apply(shape - middle) + 0.5 * (held[0] + held[1])


def initial_on(cable: Cable, manipulation: Manipulation) -> np.ndarray:
    """The manipulation's initial shape on the cable's n + 1 points, in the first clips [m]."""
    initial = discretize(manipulation.initial_shape, cable, "initial_shape")
    if manipulation.held == "first":
        initial = seat_in_first_clip(initial, manipulation.clips[0], cable.rest_link_length)
    return initial


NOISIER = 2.0
"""A measurement whose points scatter more than this many times its stated noise is said so."""

OUTLIER = 10.0
"""A point off its neighbours' line by more than this many sd (sqrt(6) / 2 sigma) is named."""


def scatter_hint(points, noise: float) -> str:
    """Why a measured shape reads longer than its cable, when its points say so ("" if not).

    Noise beyond the stated ``noise`` [m] (the smoothing spline, fitted to that noise, follows
    the rest) or one outlier (the spline follows it out and back) lengthen the smoothed curve;
    :func:`dloplan.identify.measured.point_scatter` tells them apart without a fit.
    """
    scatter = point_scatter(points)
    if scatter.noise > NOISIER * noise:
        return (f" (the points scatter about {1e3 * scatter.noise:.2g} mm, from their second "
                f"differences, more than the stated measurement_noise of {1e3 * noise:.2g} mm: "
                "state the noise they have)")
    if scatter.offset > OUTLIER * 0.5 * math.sqrt(6.0) * max(noise, scatter.noise):
        return (f" (point {scatter.worst} lies {1e3 * scatter.offset:.1f} mm off the line of "
                f"its neighbours, {scatter.offset / noise:.0f} times the stated noise: an "
                "outlier? remove it)")
    return ""


def prepare_shapes(cable: Cable, experiment: Experiment,
                   curve: MeasuredCurve | None = None) -> PreparedShapes:
    """Check the experiment's shapes against a cable and put them on its n + 1 points.

    Checks, each a ``ValueError`` naming the shape: its length (of the smoothed measurement,
    :mod:`dloplan.identify.measured`, which noise does not inflate) against the cable's (within
    5 %; a length about 1000 times the cable's or a thousandth of it is named as a unit slip),
    and the measured ends against the final clips (within 5 % of the cable length; a measured
    polyline running from the last clip to the first is reversed, and said so).

    Parameters
    ----------
    cable : Cable
        The cable whose discretization is used.
    experiment : Experiment
        The experiment.
    curve : MeasuredCurve, optional
        The smoothed measurement, when already computed.
    """
    manipulation = experiment.manipulation
    initial = initial_on(cable, manipulation)
    if curve is None:
        curve = measured_curve(experiment.measured_shape, experiment.measurement_noise)
    ratio = curve.length / cable.length
    if abs(ratio - 1.0) > LENGTH_TOLERANCE:
        k = len(experiment.measured_shape)
        hint = units_hint(ratio) or (
            f" (only {k} points measured: the polyline through them cuts the bends short; "
            f"measure at least n + 1 = {cable.n_links + 1} points along the cable)"
            if ratio < 1.0 and k < cable.n_links + 1 else
            scatter_hint(experiment.measured_shape, experiment.measurement_noise)
            if ratio > 1.0 else "")
        raise ValueError(
            f"measured_shape: the shape is {curve.length:.4g} m long but the cable is "
            f"{cable.length:.4g} m{hint}; expected within {100 * LENGTH_TOLERANCE:g} %")
    ends = manipulation.final_clips.held_points(cable.rest_link_length)[[0, 3]]
    checked = 1 if manipulation.held == "first" else 2

    def misfit(points: np.ndarray) -> float:
        return float(np.max(np.linalg.norm(points[[0, -1]][:checked] - ends[:checked], axis=1)))

    reverse = misfit(curve.points[::-1]) < misfit(curve.points)
    if reverse:
        curve = curve.reversed()
    worst = misfit(curve.points)
    limit = END_TOLERANCE * cable.length
    if worst > limit:
        raise ValueError(
            f"measured_shape: its end is {1e3 * worst:.1f} mm from the final clip's held end "
            f"(expected within {1e3 * limit:.0f} mm): is the shape in the robot's world frame, "
            "and are the clip poses the ones of the measured manipulation?"
        )
    guess = curve.resampled(cable.n_points)
    if manipulation.held == "first":
        guess = seat_in_first_clip(guess, manipulation.final_clips, cable.rest_link_length)
    return PreparedShapes(initial, curve.points, guess, curve, bool(reverse))
