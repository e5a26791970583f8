"""Designing identification manipulations, judging them, and synthetic experiments (thesis 6.1).

Only gravity against bending stiffness carries information on E: a shape fixed by the clips
alone (an elastica) is the same for every E. The information of a manipulation is the size of
the sensitivity |d xi_sim,f / d ln E| [m] compared with the measurement noise: sd(ln E) is
about noise / |J|. It depends on the gravity-bending number q L^3 / (E I) of the cable:

* soft cables (USB, Ethernet; q L^3 / EI of 100-2500) hang almost like a chain, and E shows in
  how the cable leaves the clips: rotate the clips up so the cable must bend back down near
  them (:func:`bending_manipulation`, thesis Fig. 6.3);
* stiff hoses (PU, PA12; q L^3 / EI of 0.3-4) barely sag between two clips (clamped at both
  ends, a beam deflects 1/48 of a cantilever); hold them at one end only and let them sag as a
  cantilever (:func:`cantilever_manipulation`), which gives about 20 mm of sag per e-fold of E
  for the PA12 hose.

:func:`assess_manipulation` predicts sd(ln E) of a design before the experiment is run, and
:func:`synthetic_experiment` makes the measurement a model at a known E would give, with noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..physics.geometry import resample_by_arc_length
from ..sim.clips import ClipPoses, clip_poses_from_shape
from .experiment import Experiment, Manipulation, initial_on
from .fit import MAX_LOG_SD
from .simulate import run_manipulation


def _straight_start(cable: Cable, height: float) -> tuple[np.ndarray, ClipPoses]:
    x = np.linspace(0.0, cable.length, cable.n_points)
    start = np.stack([x, np.zeros_like(x), np.full_like(x, height)], axis=1)
    return start, clip_poses_from_shape(start)


def _check_steps(steps) -> int:
    if int(steps) != steps or steps < 1:
        raise ValueError(f"steps: got {steps!r}, expected an integer >= 1")
    return int(steps)


def bending_manipulation(
    cable: Cable,
    *,
    clip_distance: float = 0.15,
    angle: float = 90.0,
    height: float = 0.3,
    steps: int = 4,
    yaw: float = 2.0,
) -> Manipulation:
    """Both clips brought closer and rotated so the cable bends under gravity (thesis Fig. 6.3).

    The cable starts straight along +x at ``height``; over ``steps`` clip poses the clips move
    symmetrically toward each other to ``clip_distance`` and their u-axes tilt up by ``angle``
    (down for a negative angle), plus a small ``yaw`` about z that breaks the mirror symmetry a
    real setup never has (a perfectly planar, symmetric model sits on unstable symmetric
    equilibria).

    Parameters
    ----------
    cable : Cable
        The cable (its length and discretization).
    clip_distance : float
        Final distance between the clip points [m], below the cable length.
    angle : float
        Final upward tilt of both clip axes [deg].
    height : float
        Height of the clips above the table [m].
    steps : int
        Clip poses after the initial one.
    yaw : float
        Final yaw of both clips about the vertical [deg].
    """
    steps = _check_steps(steps)
    if not (math.isfinite(clip_distance) and 0 < clip_distance < cable.length):
        raise ValueError(
            f"clip_distance: got {clip_distance!r}, expected 0 < distance < the cable length "
            f"{cable.length:g} m")
    start, first = _straight_start(cable, height)
    middle = first.positions.mean(axis=0)
    poses = [first]
    for t in np.arange(1, steps + 1) / steps:
        half = 0.5 * ((1 - t) * first.distance + t * clip_distance)
        positions = middle + np.array([[-half, 0.0, 0.0], [half, 0.0, 0.0]])
        turn = Rotation.from_euler("z", yaw * t, degrees=True)
        tilts = Rotation.from_euler("y", [[-angle * t], [angle * t]], degrees=True)
        poses.append(ClipPoses(positions, turn * tilts * first.rotations))
    return Manipulation(start, poses, held="both", gravity=GRAVITY)


def cantilever_manipulation(
    cable: Cable, *, angle: float = 0.0, height: float = 0.3, steps: int = 2
) -> Manipulation:
    """The first clip holds one end, the cable hangs free as a cantilever.

    The cable starts straight along +x at ``height`` (supported, then released) and the clip
    tilts its u-axis up by ``angle`` over ``steps`` poses.

    Parameters
    ----------
    cable : Cable
        The cable.
    angle : float
        Final upward tilt of the clip axis [deg].
    height : float
        Clip height [m].
    steps : int
        Clip poses after the initial one.
    """
    steps = _check_steps(steps)
    start, first = _straight_start(cable, height)
    poses = [first]
    for t in np.arange(1, steps + 1) / steps:
        tilt = Rotation.from_euler("y", [[-angle * t], [0.0]], degrees=True)
        poses.append(ClipPoses(first.positions, tilt * first.rotations))
    return Manipulation(start, poses, held="first", gravity=GRAVITY)


def hanging_loop_manipulation(cable: Cable, *, clip_distance: float | None = None,
                              height: float = 0.3, steps: int = 4) -> Manipulation:
    """Both clips brought side by side, pointing down: the cable hangs as a loop below them.

    The loop's height and width depend on q L^3 / (E I) all along the cable, not only near the
    clips, which suits soft cables. :func:`bending_manipulation` with ``angle=-90``.

    Parameters
    ----------
    cable : Cable
        The cable.
    clip_distance : float, optional
        Final distance between the clips [m] (default a tenth of the cable length).
    height : float
        Clip height [m].
    steps : int
        Clip poses after the initial one.
    """
    distance = 0.1 * cable.length if clip_distance is None else clip_distance
    return bending_manipulation(cable, clip_distance=distance, angle=-90.0, height=height,
                                steps=steps)


@dataclass(frozen=True)
class DesignCheck:
    """How well a manipulation would identify a cable's E (see :func:`assess_manipulation`).

    Attributes
    ----------
    sensitivity : float
        |d xi_sim,f / d ln E| over all points [m].
    log_sd : float
        Predicted sd(ln E) = noise / sensitivity [-].
    informative : bool
        ``log_sd`` at most the threshold.
    message : str
        The verdict in words.
    """

    sensitivity: float
    log_sd: float
    informative: bool
    message: str


def simulate_design(cable: Cable, manipulation: Manipulation):
    """The manipulation simulated at the cable's modulus; a failing design is a ValueError."""
    run = run_manipulation(cable, manipulation, initial_on(cable, manipulation))
    if not run.success:
        raise ValueError(f"manipulation: the simulation fails at E = {cable.youngs_modulus:.3g} "
                         f"Pa ({run.message})")
    return run


def assess_manipulation(
    cable: Cable, manipulation: Manipulation, *, noise: float = 1e-3,
    max_log_sd: float = MAX_LOG_SD,
) -> DesignCheck:
    """Predict how precisely a manipulation identifies E near the cable's current modulus.

    One simulation at ``cable.youngs_modulus`` (the expected E): sd(ln E) ~ noise / |J|, the
    Gauss-Newton estimate of :func:`~dloplan.identify.fit.identify_youngs_modulus`.

    Parameters
    ----------
    cable : Cable
        The cable with the expected modulus.
    manipulation : Manipulation
        The design.
    noise : float
        Measurement standard deviation per coordinate [m].
    max_log_sd : float
        Threshold of an informative experiment [-].
    """
    if not (math.isfinite(noise) and noise > 0):
        raise ValueError(f"noise: got {noise!r}, expected a distance > 0 [m]")
    run = simulate_design(cable, manipulation)
    size = float(np.linalg.norm(run.sensitivity))
    log_sd = noise / size if size > 0 else math.inf
    ok = log_sd <= max_log_sd
    verdict = "informative" if ok else "not informative"
    return DesignCheck(size, log_sd, ok, (
        f"{verdict}: the final shape moves {1e3 * size:.1f} mm per e-fold of E, so with "
        f"{1e3 * noise:g} mm noise sd(ln E) ~ {log_sd:.3g}"))


def synthetic_experiment(
    cable: Cable,
    manipulation: Manipulation,
    *,
    noise: float = 1e-3,
    n_measured: int | None = None,
    seed: int = 0,
    name: str = "synthetic",
) -> Experiment:
    """The experiment a model cable at a known E would give: simulated, resampled, noisy.

    The final shape of the quasi-static simulation at ``cable.youngs_modulus`` is resampled by
    arc length to ``n_measured`` points (a measurement of another resolution; the default
    3 n + 1 keeps the model's points among them) and every coordinate gets independent Gaussian
    noise of standard deviation ``noise`` (as a registration's points would: noise added to
    the model's points before resampling would be averaged, hence weaker and correlated,
    between them). The experiment states ``noise`` as its measurement noise (at least 0.1 mm).

    Parameters
    ----------
    cable : Cable
        The model cable, with the modulus to recover.
    manipulation : Manipulation
        The manipulation.
    noise : float
        Noise standard deviation [m] (0 for none).
    n_measured : int, optional
        Points of the measured polyline (default 3 n + 1, not the model's n + 1).
    seed : int
        Seed of the noise.
    name : str
        Label of the experiment.
    """
    if not (math.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise: got {noise!r}, expected a distance >= 0 [m]")
    run = simulate_design(cable, manipulation)
    rng = np.random.default_rng(seed)
    points = resample_by_arc_length(run.final, n_measured or 3 * cable.n_links + 1)
    measured = points + rng.normal(0.0, noise, points.shape)
    return Experiment(manipulation, measured, measurement_noise=max(noise, 1e-4), name=name)
