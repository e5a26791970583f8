"""The model's structural error: what a coarse chain gets wrong, estimated and measured.

A chain of n links converges to the elastic rod at first order in 1 / n (the held end link and
the lumped masses: the demo's stabilized target moves 7.5, 3.6, 1.5, 0.5 mm for n = 20, 40, 80,
160 against n = 320). A real cable, or a plant of n = 100, therefore differs from the plan's
n = 20 model by more than a wrong modulus can explain, and differently at every shape: the
effective E that matches a nearly straight shape is not the one that matches a bent one.

The correction carries that error as an **output bias of known shape and measured amplitude**:

    x_plant(C) ~ x_n(C) + alpha d(C),     d(C) = R_n[x_2n(C)] - x_n(C),

where x_2n is the same cable on twice the links, clamped over the same length (the Richardson
direction of the discretization error; R_n resamples by arc length onto the model's n + 1
points). alpha is fitted to the measurement together with log E (:func:`fit_model_error`): about
1 for a plant on 2n links, 1.6 for n = 100 against n = 20, 2 for the continuum (a first-order
error: x_inf - x_n = 2 d). The clips are then fitted so that x_n + alpha d, not x_n, matches the
reference, with d re-evaluated at the corrected clips.
"""

from __future__ import annotations

import math

import numpy as np

from ..cable import GRAVITY, Cable
from ..geometry import resample_by_arc_length
from ..physics.chain import SpringChain
from ..sim import ClipPoses
from ..sim.result import residual_tolerance
from ..sim.statics import minimize_energy
from .measurement import CorrectionRefused

MAX_ALPHA = 4.0
"""Largest discretization-error amplitude accepted (2 is the continuum's); beyond, it is clipped."""


def clamped_equilibrium(cable: Cable, guess, clips: ClipPoses, clamp_links: int = 1, *,
                        gravity=GRAVITY, rtol: float | None = None,
                        chain: SpringChain | None = None):
    """Stable equilibrium of a cable whose grippers each clamp ``clamp_links`` links.

    The clamped links lie straight along the clip's u-axis, centred on the clip point (one
    link: the model's own convention, :func:`dloplan.sim.equilibrium`); the free points are
    solved by the trust-region Newton method of every equilibrium
    (:func:`dloplan.sim.statics.minimize_energy`).

    Parameters
    ----------
    cable : Cable
        The cable (n links).
    guess : array_like
        (n + 1, 3) start [m]; selects the branch.
    clips : ClipPoses
        The clip poses.
    clamp_links : int
        Links held by each gripper (>= 1).
    gravity : array_like
        Gravity [m/s^2].
    rtol : float, optional
        Convergence when the largest free force is below rtol times the cable's force scale
        (default: 1e-10 or the round-off floor of its stiffest spring,
        :func:`dloplan.sim.result.residual_tolerance`).
    chain : SpringChain, optional
        The chain of ``cable`` under ``gravity``.

    Returns
    -------
    tuple
        ``(shape (n + 1, 3), stable, message)``.
    """
    k = int(clamp_links)
    offsets = (np.arange(k + 1) - 0.5 * k) * cable.rest_link_length
    u = clips.u_axes
    x = np.array(guess, dtype=float)
    x[: k + 1] = clips.positions[0] + offsets[:, None] * u[0]
    x[::-1][: k + 1] = clips.positions[1] + offsets[:, None] * u[1]
    if chain is None:
        chain = SpringChain.from_cable(cable, gravity)
    x, _, _, _, stable, _, message = minimize_energy(
        chain, x, slice(k + 1, cable.n_points - k - 1), cable.length,
        residual_tolerance(cable, gravity, rtol, x))
    return x, stable, message


def discretization_error(cable: Cable, shape: np.ndarray, clips: ClipPoses, *,
                         gravity=GRAVITY, fine_chain: SpringChain | None = None,
                         fine_guess: np.ndarray | None = None) -> np.ndarray:
    """d = R_n[x_2n] - x_n: the Richardson direction of the model's discretization error.

    Parameters
    ----------
    cable : Cable
        The model cable (n links).
    shape : numpy.ndarray
        (n + 1, 3) its stable equilibrium x_n at ``clips`` [m].
    clips : ClipPoses
        The clip poses.
    gravity : array_like
        Gravity [m/s^2].
    fine_chain : SpringChain, optional
        The chain of ``cable.with_links(2 n)`` (saves its construction in loops).
    fine_guess : numpy.ndarray, optional
        (2 n + 1, 3) start of the refined solve [m] (default ``shape`` resampled; the refined
        shape of a nearby modulus saves iterations). Overwritten with the refined equilibrium.

    Returns
    -------
    numpy.ndarray
        (n + 1, 3) [m]; x_inf - x_n is about 2 d.
    """
    fine = cable.with_links(2 * cable.n_links)
    if fine_chain is None:
        fine_chain = SpringChain.from_cable(fine, gravity)
    guess = resample_by_arc_length(shape, fine.n_points) if fine_guess is None else fine_guess
    x, stable, message = clamped_equilibrium(fine, guess, clips, 2, gravity=gravity,
                                             chain=fine_chain)
    if not stable:
        raise CorrectionRefused(f"model: the refined model (n = {fine.n_links}) finds no stable "
                                f"equilibrium at these clip poses ({message})")
    if fine_guess is not None:
        fine_guess[:] = x
    return resample_by_arc_length(x, cable.n_points) - shape


def fit_model_error(jacobian: np.ndarray, direction: np.ndarray | None,
                    residual: np.ndarray) -> tuple[float, float]:
    """Least-squares (delta log E, alpha) with residual ~ J delta + alpha d.

    Parameters
    ----------
    jacobian : numpy.ndarray
        (n + 1, 3) d x / d log E [m].
    direction : numpy.ndarray or None
        (n + 1, 3) the discretization direction d [m]; None fits delta alone (alpha = 0).
    residual : numpy.ndarray
        (n + 1, 3) measured minus predicted [m].

    Returns
    -------
    tuple of float
        ``(delta, alpha)``; alpha clipped to [0, :data:`MAX_ALPHA`] (delta refitted then).
    """
    j, r = jacobian.ravel(), residual.ravel()
    jj = float(j @ j)
    if direction is None:
        return (float(j @ r) / jj if jj > 0 else 0.0), 0.0
    d = direction.ravel()
    a = np.stack([j, d], axis=1)
    delta, alpha = np.linalg.lstsq(a, r, rcond=1e-10)[0]
    if not 0.0 <= alpha <= MAX_ALPHA:
        alpha = float(np.clip(alpha, 0.0, MAX_ALPHA))
        delta = float(j @ (r - alpha * d)) / jj if jj > 0 else 0.0
    return float(delta), float(alpha)


def log_modulus_sd(jacobian: np.ndarray, direction: np.ndarray | None,
                   residual: np.ndarray) -> float:
    """Standard deviation of the fitted delta log E (Gauss-Newton linearization).

    The residual left by the fit gives the scatter per coordinate, s^2 = |r|^2 / (N - p) (N
    coordinates, p = 1 or 2 parameters); var(delta) = s^2 [(A^T A)^-1]_00 with A = [J, d]: the
    discretization direction takes its share of the information when it is fitted too.

    Parameters
    ----------
    jacobian : numpy.ndarray
        (n + 1, 3) d x / d log E [m].
    direction : numpy.ndarray or None
        (n + 1, 3) the discretization direction d [m], or None (E alone).
    residual : numpy.ndarray
        (n + 1, 3) what the fit leaves: measured minus the fitted model [m].

    Returns
    -------
    float
        sd(ln E) (inf when the shape does not depend on E).
    """
    columns = [jacobian.ravel()] + ([] if direction is None else [direction.ravel()])
    a = np.stack(columns, axis=1)
    dof = max(a.shape[0] - a.shape[1], 1)
    s2 = float(residual.ravel() @ residual.ravel()) / dof
    normal = a.T @ a
    try:
        inverse = np.linalg.inv(normal)
    except np.linalg.LinAlgError:
        return math.inf
    variance = s2 * float(inverse[0, 0])
    return math.sqrt(variance) if variance >= 0 and math.isfinite(variance) else math.inf


def grip_direction(cable: Cable, shape: np.ndarray, clips: ClipPoses, *,
                   gravity=GRAVITY) -> np.ndarray:
    """The change of the model's shape when each gripper clamps half a link more cable.

    A real gripper's jaws end somewhere near the clip, not exactly where the model's held link
    does (L / n). The chain on 2 n links clamps 2 of its links (the model's grip) and 3 (half a
    model link more); the difference, resampled onto the model's points, is the shape's
    response to the clamp length, used for the prediction's uncertainty (:mod:`.step`).

    Parameters
    ----------
    cable : Cable
        The model cable (n links).
    shape : numpy.ndarray
        (n + 1, 3) its equilibrium at ``clips`` [m] (the branch).
    clips : ClipPoses
        The clip poses.
    gravity : array_like
        Gravity [m/s^2].

    Returns
    -------
    numpy.ndarray
        (n + 1, 3) [m] per L / (2 n) of clamp length.
    """
    fine = cable.with_links(2 * cable.n_links)
    chain = SpringChain.from_cable(fine, gravity)
    guess = resample_by_arc_length(shape, fine.n_points)
    shapes = []
    for links in (2, 3):
        guess, stable, message = clamped_equilibrium(fine, guess, clips, links, gravity=gravity,
                                                     chain=chain)
        if not stable:
            raise CorrectionRefused(f"model: the refined model (n = {fine.n_links}) clamped over "
                                    f"{links} links finds no stable equilibrium ({message})")
        shapes.append(resample_by_arc_length(guess, cable.n_points))
    return shapes[1] - shapes[0]
