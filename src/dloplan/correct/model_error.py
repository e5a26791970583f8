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
error: x_inf - x_n = 2 d), with that first-order value as its prior (:func:`alpha_prior`) so
that a direction the measurement cannot tell from d (the clamp length's g, on the coarse U demo)
does not take alpha's share. The clips are then fitted so that x_n + alpha d, not x_n, matches
the reference, with d re-evaluated at the corrected clips.
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from ..cable import GRAVITY, Cable
from ..physics.chain import SpringChain
from ..physics.compiled import resample_polyline
from ..sim import ClipPoses
from ..sim.clips import HELD_INDICES
from ..sim.result import residual_tolerance
from ..sim.statics import minimize_energy
from .measurement import CorrectionRefused

MAX_ALPHA = 4.0
"""Largest discretization-error amplitude accepted (2 is the continuum's); beyond, it is clipped."""

ALPHA_SD = 0.5
"""Standard deviation of the prior on alpha (:func:`alpha_prior`): the first-order value leaves
out the second-order terms, O(1 / n) of it (a quarter at n = 12 on the sagging demo, whose
target moves 7.5, 3.6, 1.5 mm for n = 20, 40, 80: ratios 2.1 and 2.4, not 2), and the
measured cable's own resolution when it is not known (1.6 for a 100-link plant at n = 20, 2
for the continuum: 0.8 sd apart)."""


def alpha_prior(n_links: int, measured_links: int | None = None) -> tuple[float, float]:
    """The prior (centre, sd) of the discretization error's amplitude alpha.

    A chain of n links converges to the rod at first order in 1 / n, x_N - x_n = c (1 / n -
    1 / N), so with d = x_2n - x_n = c / (2 n) the cable measured (N links; the continuum for a
    real cable) is x_n + alpha d with

        alpha = 2 (1 - n / N)        (2 for N -> inf, 1.76 for N = 100 at n = 12).

    Parameters
    ----------
    n_links : int
        The model's links n.
    measured_links : int, optional
        The measured cable's own discretization N (a simulated plant's links or edges); None:
        a real cable, the continuum.

    Returns
    -------
    tuple
        ``(alpha_0, sd)``, sd = :data:`ALPHA_SD`.
    """
    ratio = 0.0 if measured_links is None else n_links / measured_links
    return 2.0 * (1.0 - min(ratio, 1.0)), ALPHA_SD


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
    x = np.array(guess, dtype=float, order="C")  # C: a transposed guess compiled 2nd overloads
    x[: k + 1] = clips.positions[0] + offsets[:, None] * u[0]
    x[::-1][: k + 1] = clips.positions[1] + offsets[:, None] * u[1]
    if chain is None:
        chain = SpringChain.from_cable(cable, gravity)
    x, _, _, _, stable, _, message = minimize_energy(
        chain, x, slice(k + 1, cable.n_points - k - 1), cable.length,
        residual_tolerance(cable, gravity, rtol, x))
    return x, stable, message


MAX_GRIP = 1.0
"""Largest clamp-length change accepted, in half model links (:func:`model_error_directions`'
g): the gripper's jaws end within half a link of where the model's held link ends."""


_REFINED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""The refined cable (2 n links) per model cable, while it lives: its chain is then built once
(:meth:`dloplan.physics.chain.SpringChain.from_cable` keeps one per cable object)."""


def refined_cable(cable: Cable) -> Cable:
    """``cable.with_links(2 n)``, the same object for the same ``cable`` (its chain built once)."""
    fine = _REFINED.get(cable)
    if fine is None:
        fine = _REFINED[cable] = cable.with_links(2 * cable.n_links)
    return fine


def model_error_directions(cable: Cable, shape: np.ndarray, clips: ClipPoses, *, grip: bool,
                           gravity=GRAVITY, fine_chain: SpringChain | None = None,
                           fine_guess: np.ndarray | None = None):
    """d, the Richardson direction of the discretization error, and g, the response to the
    clamp length.

    The chain on 2 n links is clamped over 2 of its links (the model's grip, L / n) and, with
    ``grip``, over 3 (half a model link more):

        d = R_n[x_2n,2] - x_n,        g = R_n[x_2n,3] - R_n[x_2n,2],

    R_n resampling by arc length onto the model's n + 1 points. A real gripper's jaws end
    somewhere near the clip, not exactly where the model's held link does; a clamp of
    (1 + beta / 2) L / n changes the shape by about beta g (:func:`fit_model_error`).

    Parameters
    ----------
    cable : Cable
        The model cable (n links).
    shape : numpy.ndarray
        (n + 1, 3) its stable equilibrium x_n at ``clips`` [m].
    clips : ClipPoses
        The clip poses.
    grip : bool
        Also compute g (one more solve on 2 n links).
    gravity : array_like
        Gravity [m/s^2].
    fine_chain : SpringChain, optional
        The chain of ``cable.with_links(2 n)`` (saves its construction in loops).
    fine_guess : numpy.ndarray, optional
        (2 n + 1, 3) start of the refined solve [m] (default ``shape`` resampled; the refined
        shape of a nearby modulus saves iterations). Overwritten with the refined equilibrium
        clamped over 2 links.

    Returns
    -------
    tuple
        ``(d, g)``, each (n + 1, 3) [m] (x_inf - x_n is about 2 d; g per L / (2 n) of clamp
        length); g is None without ``grip``.
    """
    fine = refined_cable(cable)
    if fine_chain is None:
        fine_chain = SpringChain.from_cable(fine, gravity)
    guess = resampled(shape, fine.n_points) if fine_guess is None else fine_guess
    on_model = []
    for links in (2, 3) if grip else (2,):
        guess, stable, message = clamped_equilibrium(fine, guess, clips, links, gravity=gravity,
                                                     chain=fine_chain)
        if not stable:
            raise CorrectionRefused(f"model: the refined model (n = {fine.n_links}) clamped over "
                                    f"{links} links finds no stable equilibrium ({message})")
        if links == 2 and fine_guess is not None:
            fine_guess[:] = guess
        on_model.append(resampled(guess, cable.n_points))
    return on_model[0] - shape, (on_model[1] - on_model[0] if grip else None)


def resampled(points: np.ndarray, n_points: int) -> np.ndarray:
    """:func:`dloplan.geometry.resample_by_arc_length` of a shape (k, 3) [m] to ``n_points``
    by the compiled :func:`dloplan.physics.compiled.resample_polyline` (the same interpolation
    to round-off, without the per-call cost of numpy's: twice per refined solve)."""
    out = np.empty((n_points, 3))
    resample_polyline(np.ascontiguousarray(points, dtype=float), out)
    return out


def discretization_error(cable: Cable, shape: np.ndarray, clips: ClipPoses, *,
                         gravity=GRAVITY, fine_chain: SpringChain | None = None,
                         fine_guess: np.ndarray | None = None) -> np.ndarray:
    """d = R_n[x_2n] - x_n (n + 1, 3) [m]: :func:`model_error_directions` without g."""
    return model_error_directions(cable, shape, clips, grip=False, gravity=gravity,
                                  fine_chain=fine_chain, fine_guess=fine_guess)[0]


BOUNDS = ((0.0, MAX_ALPHA), (-MAX_GRIP, MAX_GRIP))
"""The ranges of the directions' amplitudes (alpha, beta) :func:`fit_model_error` accepts."""


def fit_model_error(jacobian: np.ndarray, directions, residual: np.ndarray, prior=None
                    ) -> tuple[float, np.ndarray]:
    """Least-squares (delta log E, amplitudes) with residual ~ J delta + sum_k c_k D_k.

    With ``prior`` (alpha_0, sd) on alpha, the first amplitude (:func:`alpha_prior`), the
    least squares is the maximum a posteriori estimate: one more row (s / sd)(alpha - alpha_0),
    s the scatter per coordinate of the fit without the prior (:func:`_scatter`), so alpha
    stays near alpha_0 along what the measurement cannot tell (d and g nearly parallel) and
    follows the measurement where it can.

    Parameters
    ----------
    jacobian : numpy.ndarray
        (n + 1, 3) d x / d log E [m] (zeros: the amplitudes alone).
    directions : sequence of numpy.ndarray
        The error directions D_k (n + 1, 3) [m]: none (E alone), d, or d and g
        (:func:`model_error_directions`).
    residual : numpy.ndarray
        (n + 1, 3) measured minus predicted [m].
    prior : tuple of float, optional
        (alpha_0, sd) of alpha (ignored without directions); None: no prior.

    Returns
    -------
    tuple
        ``(delta, amplitudes)``: amplitudes (len(directions),), alpha clipped to
        [0, :data:`MAX_ALPHA`], beta to [-:data:`MAX_GRIP`, :data:`MAX_GRIP`] (:data:`BOUNDS`);
        the others refitted with a clipped one held.
    """
    a, r = _system(jacobian, directions, residual, prior)
    columns = list(a.T)
    bounds = [(-math.inf, math.inf), *BOUNDS[: len(directions)]]
    values = np.zeros(len(columns))
    held = np.zeros(len(columns), dtype=bool)
    for _ in columns:  # clip one amplitude at a time, refit the others
        free = np.flatnonzero(~held)
        rest = r - sum((values[k] * columns[k] for k in np.flatnonzero(held)), np.zeros_like(r))
        if np.any(np.abs(a[:, free]).sum(axis=0) > 0):
            values[free] = np.linalg.lstsq(a[:, free], rest, rcond=1e-10)[0]
        out = [k for k in free if not bounds[k][0] <= values[k] <= bounds[k][1]]
        if not out:
            break
        k = max(out, key=lambda k: max(bounds[k][0] - values[k], values[k] - bounds[k][1]))
        values[k] = min(max(values[k], bounds[k][0]), bounds[k][1])
        held[k] = True
    return float(values[0]), values[1:]


def _scatter(a: np.ndarray, r: np.ndarray) -> float:
    """s^2, the scatter per coordinate the unbounded least squares a c ~ r leaves [m^2]."""
    left = r - a @ np.linalg.lstsq(a, r, rcond=1e-10)[0]
    return float(left @ left) / max(a.shape[0] - a.shape[1], 1)


def _system(jacobian, directions, residual, prior) -> tuple[np.ndarray, np.ndarray]:
    """The least-squares system [J, D_1, ...] c ~ r, with the prior's row on alpha appended."""
    r = residual.ravel()
    a = np.stack([jacobian.ravel()] + [d.ravel() for d in directions], axis=1)
    if prior is None or not directions:
        return a, r
    centre, sd = prior
    weight = math.sqrt(_scatter(a, r)) / sd
    row = np.zeros(a.shape[1])
    row[1] = weight
    return np.vstack([a, row]), np.r_[r, weight * centre]


def parameter_covariance(jacobian: np.ndarray, directions, residual: np.ndarray,
                         prior=None) -> np.ndarray:
    """Covariance of the fitted (delta log E, amplitudes) (Gauss-Newton linearization).

    The residual left by the fit gives the scatter per coordinate, s^2 = |r|^2 / (N - p) (N
    coordinates, p parameters); C = s^2 (A^T A + (s / sd)^2 e e^T)^-1 with A = [J, D_1, ...]
    and e the unit vector of alpha (the prior's row; absent without a prior): each direction
    fitted takes its share of the information, the prior on alpha adds its own. The columns
    overlap (d x / d log E and d are both sag-like: ln E and alpha correlate, -0.73 on the 3D
    job's shape 1), which the off-diagonal terms carry.

    Parameters
    ----------
    jacobian : numpy.ndarray
        (n + 1, 3) d x / d log E [m]; all zeros: E held (known), its row and column 0.
    directions : sequence of numpy.ndarray
        The error directions fitted with it (:func:`fit_model_error`).
    residual : numpy.ndarray
        (n + 1, 3) what the fit leaves: measured minus the fitted model [m].
    prior : tuple of float, optional
        (alpha_0, sd) of alpha, as given to :func:`fit_model_error`.

    Returns
    -------
    numpy.ndarray
        (p, p), p = 1 + len(directions), ln E first; inf on the diagonal and 0 off it when the
        information is singular (the shape does not inform the parameters).
    """
    a = np.stack([jacobian.ravel()] + [d.ravel() for d in directions], axis=1)
    known = not np.any(jacobian)  # E held: its column is zero and its sd 0
    dof = max(a.shape[0] - a.shape[1] + known, 1)
    s2 = float(residual.ravel() @ residual.ravel()) / dof
    information = a.T @ a
    information[0, 0] += known  # decoupled (a zero column): leaves the others' variances
    if prior is not None and directions:
        information[1, 1] += s2 / prior[1] ** 2
    try:
        covariance = s2 * np.linalg.inv(information)
    except np.linalg.LinAlgError:
        return np.diag(np.full(a.shape[1], math.inf))
    if known:
        covariance[0, :] = covariance[:, 0] = 0.0
    return covariance


def parameter_sds(jacobian: np.ndarray, directions, residual: np.ndarray,
                  prior=None) -> np.ndarray:
    """Standard deviations of the fitted (delta log E, amplitudes): the square roots of the
    diagonal of :func:`parameter_covariance` (same parameters).

    Returns
    -------
    numpy.ndarray
        (1 + len(directions),) sd(ln E) first (inf where the shape does not inform it; 0 for
        E held, a zero ``jacobian``).
    """
    return standard_deviations(parameter_covariance(jacobian, directions, residual, prior))


def standard_deviations(covariance: np.ndarray) -> np.ndarray:
    """The square roots of a covariance's diagonal (p,), inf where a variance is not finite
    or negative (a parameter the data do not inform)."""
    variance = np.diag(covariance)
    ok = np.isfinite(variance) & (variance >= 0)
    return np.where(ok, np.sqrt(np.where(ok, variance, 0.0)), math.inf)


def measured_offset(residual: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The measurement's offset o (a rigid translation of every measured point, e.g. a camera's
    calibration error) and its standard deviations, from the held points.

    The model's four held points (:data:`dloplan.sim.clips.HELD_INDICES`) lie on the clips,
    which the robot places, and E, the discretization bias and the clamp length leave them
    where they are (d, g and d x / d log E vanish there; a shorter real clamp moves them at
    second order): what the measurement puts them off by is its offset. Fitted jointly with
    the other directions over every point it would take up their misfit instead (on the 3D
    Ethernet job a third of a millimetre with no offset at all, and the clamp length could no
    longer be told).

    Parameters
    ----------
    residual : numpy.ndarray
        (n + 1, 3) measured minus the model's equilibrium [m].

    Returns
    -------
    tuple
        ``(offset (3,) [m], sds (3,) [m])``: the mean of the held points' residuals, and its
        standard deviations from their scatter about it (s / 2, s^2 = sum |r - o|^2 / 9: 12
        coordinates, 3 fitted).
    """
    held = residual[list(HELD_INDICES)]
    offset = held.mean(axis=0)
    scatter = math.sqrt(float(np.sum((held - offset) ** 2)) / (held.size - 3))
    return offset, np.full(3, scatter / math.sqrt(len(held)))


def offset_covariance(sds: np.ndarray, u_axes: np.ndarray, noise: float) -> np.ndarray:
    """The covariance of the measured offset (:func:`measured_offset`) [m^2], (3, 3).

    The held points' scatter about their mean gives the part of their errors that differs
    between them, ``sds``; it misses the part they share at each end. The smoothed measurement
    (:func:`.measurement.resample_measured`) starts at the first measured point's position along
    the cable and ends at the last's, so both points of a clip slide along its axis u_c with
    that point's noise, sd sigma (``noise``, :func:`.measurement.noise_sd`): the mean of the
    four moves by (e_1 u_1 + e_2 u_2) / 2, so

        C = diag(sds^2) + sigma^2 / 4 (u_1 u_1^T + u_2 u_2^T).

    (On the 3D job's shape 1 with 1 mm noise on 200 points the offset's component along the
    clips' axes scatters 0.60 mm, the held points' scatter says 0.29 mm; 29 % of noise draws
    showed an offset at the chi 95 % level, 5.7 % with this covariance.)

    Parameters
    ----------
    sds : numpy.ndarray
        (3,) the sds from the held points' scatter [m].
    u_axes : numpy.ndarray
        (2, 3) the clips' unit u-axes (:attr:`dloplan.sim.ClipPoses.u_axes`).
    noise : float
        sigma, the measurement's noise per coordinate [m].
    """
    u = np.asarray(u_axes, dtype=float)
    return np.diag(np.asarray(sds, dtype=float) ** 2) + 0.25 * noise**2 * (u.T @ u)
