"""The cable's length: the explanation of a measured shape the model update does not carry.

The model update (:func:`~.step.update_modulus`) explains the shape measured at K by E, the
discretization bias alpha d and the clamp length's beta g. A cable a little shorter or longer
than the plan's is none of them, and at K the clamp length stands in for it: both change the
free length. They differ elsewhere: a longer clamp also moves the free part's ends along the
clips' axes. On a compressed arch (fig4_8's shape 3, the clips 0.48 m apart for a 0.5 m cable)
the clamp length fitted for a cable 10.7 mm short predicted the target 13.9 mm off and the
corrected one 1.1 mm off; the plant went 4.9 -> 6.9 mm, and the model with the cable's length
predicted 5.1 -> 6.7 mm (docs/correction.md, "The cable's length").

:func:`length_alternative` fits the measurement at K with the length in the clamp length's
place (ln E as updated, alpha and lambda, lambda the relative change of the rest length, with
alpha's prior) and :func:`check_length` refuses a correction whose predicted gain does not hold
under it, where the measurement tells the length and it explains the measurement at least as
well as the model's own estimate: a correction that cannot be shown to help is not applied.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..cable import GRAVITY, Cable
from ..sim import ClipPoses, equilibrium
from .measurement import CorrectionRefused

MARGIN = 1e-9
"""A batch's verdict (:func:`clear_lengths`) stands when it is clear by more than this share of
the compared numbers (their round-off, arrays summed in another order, is about 1e-16)."""

TOLD = 2.0
"""The length counts as an explanation when its estimate is at least this many sd from 0 (the
rule by which the model update takes E and the clamp length, :data:`.step.SIGNIFICANCE`): a
length the measurement does not tell is no alternative (on the study example a cable "0.2 mm
short" fitting as well as the estimate re-judged a correction's gain at its threshold)."""

LENGTH_STEP = -0.01
"""The relative change of the rest length over which :func:`length_direction` takes its secant
(a cable 1 % shorter: the study's spreads, and the few millimetres of a cut cable)."""


def length_direction(cable: Cable, shape: np.ndarray, clips: ClipPoses, gravity=GRAVITY
                     ) -> np.ndarray:
    """l, the model's equilibrium's response to its rest length (n + 1, 3) [m per unit of
    relative length]: (x(L (1 + h)) - x(L)) / h with h = :data:`LENGTH_STEP`, the mass per
    length kept, held by its end links as the model is, from ``shape`` (x(L), the model's stable
    equilibrium at ``clips``).

    Raises
    ------
    CorrectionRefused
        When the changed cable finds no stable equilibrium there.
    """
    length = cable.length * (1.0 + LENGTH_STEP)
    rest = cable.rest_shape
    changed = replace(cable, length=length, mass=cable.mass * (1.0 + LENGTH_STEP),
                      rest_shape=None if rest is None else rest * (1.0 + LENGTH_STEP))
    eq = equilibrium(changed, shape, clips, gravity=gravity)
    if not eq.success:
        raise CorrectionRefused(f"length: the model {-100 * LENGTH_STEP:g} % shorter finds no "
                                f"stable equilibrium ({eq.message})")
    return (eq.shape - shape) / LENGTH_STEP


@dataclass(frozen=True)
class LengthAlternative:
    """The measurement at K explained with the cable's length (:func:`length_alternative`).

    Attributes
    ----------
    discretization : float
        alpha fitted with the length.
    length : float
        lambda, the rest length's relative change (-0.02: 2 % shorter).
    length_sd : float
        lambda's sd (:func:`length_sd`).
    rms_model, rms_length : float
        [m] the residual per coordinate the model update's estimate and the length's leave.
    """

    discretization: float
    length: float
    length_sd: float
    rms_model: float
    rms_length: float

    @property
    def told(self) -> bool:
        """Whether the measurement tells the length (:data:`TOLD` sd) and the length explains
        it at least as well as the estimate."""
        return (abs(self.length) >= TOLD * self.length_sd
                and self.rms_length <= self.rms_model)


def length_sd(d: np.ndarray, l_k: np.ndarray, rms: float) -> np.ndarray:
    """lambda's sd from the fit on [d, l] ((..., n + 1, 3) each [m]) leaving ``rms`` per
    coordinate (...,) [m]: s^2 (A^T A)^-1 at lambda's place, s^2 = rms^2 m / (m - 2), m the
    coordinates (the prior on alpha left out: it only narrows alpha)."""
    dd, ll = np.sum(d * d, axis=(-2, -1)), np.sum(l_k * l_k, axis=(-2, -1))
    dl = np.sum(d * l_k, axis=(-2, -1))
    m = d.shape[-2] * d.shape[-1]
    determinant = np.maximum(dd * ll - dl * dl, 1e-300)
    return np.sqrt(np.asarray(rms) ** 2 * m / (m - 2) * dd / determinant)


def length_alternative(residual: np.ndarray, d: np.ndarray, g: np.ndarray, l_k: np.ndarray,
                       discretization: float, grip: float, fitted) -> LengthAlternative:
    """The measured ``residual`` at K (measured minus the updated model's equilibrium,
    (n + 1, 3) [m]) explained by alpha' d + lambda l in the place of the estimate's alpha d +
    beta g (d, g and l at K (n + 1, 3); ``discretization``, ``grip``: the estimate's alpha and
    beta; ``fitted``: (alpha', lambda), the model-error fit of the residual on [d, l] with
    alpha's prior, :func:`.model_error.fit_model_error` or its normal equations,
    :func:`.normal_fits.fit_estimate`)."""
    alpha, lam = fitted

    def rms(left: np.ndarray) -> float:
        return float(np.sqrt(np.mean(left**2)))

    left = rms(residual - alpha * d - lam * l_k)
    return LengthAlternative(float(alpha), float(lam), float(length_sd(d, l_k, left)),
                             rms(residual - discretization * d - grip * g), left)


def clear_lengths(residual: np.ndarray, at_k: tuple, estimate: np.ndarray,
                  fitted: np.ndarray, predictions: tuple, at_t: tuple, reference: np.ndarray,
                  needed: np.ndarray) -> np.ndarray:
    """Which of B corrections :func:`check_length` passes by more than :data:`MARGIN` (a
    study chunk's at once; the others go to :func:`check_length` itself, which words a
    refusal).

    Parameters
    ----------
    residual : numpy.ndarray
        (B, n + 1, 3) the measurements at K less the updated models [m].
    at_k : tuple of numpy.ndarray
        d, g and l at K, each (B, n + 1, 3) [m].
    estimate, fitted : numpy.ndarray
        (B, 2) the estimate's (alpha, beta) and the alternative's (alpha', lambda).
    predictions : tuple of numpy.ndarray
        The open loop's and the corrected target (B, n + 1, 3) [m], the estimate's bias
        included.
    at_t : tuple of numpy.ndarray
        d and g at the planned target clips, d and g at the corrected ones and l at the planned
        ones, each (B, n + 1, 3) [m].
    reference : numpy.ndarray
        (n + 1, 3) [m].
    needed : numpy.ndarray
        (B,) the gain the first gain check asked for [m].
    """
    def weighted(a: np.ndarray, x: np.ndarray) -> np.ndarray:
        return a[:, None, None] * x

    d_k, g_k, l_k = at_k
    rms_model = np.sqrt(np.mean((residual - weighted(estimate[:, 0], d_k)
                                 - weighted(estimate[:, 1], g_k)) ** 2, axis=(1, 2)))
    rms_length = np.sqrt(np.mean((residual - weighted(fitted[:, 0], d_k)
                                  - weighted(fitted[:, 1], l_k)) ** 2, axis=(1, 2)))
    d_planned, g_planned, d_corrected, g_corrected, l_t = at_t
    change, lam = fitted[:, 0] - estimate[:, 0], fitted[:, 1]

    def error(x: np.ndarray, d: np.ndarray, g: np.ndarray) -> np.ndarray:
        moved = x + weighted(change, d) - weighted(estimate[:, 1], g) + weighted(lam, l_t)
        return np.mean(np.linalg.norm(moved - reference, axis=-1), axis=-1)

    before = error(predictions[0], d_planned, g_planned)
    gain = before - error(predictions[1], d_corrected, g_corrected)
    untold = np.abs(lam) < TOLD * length_sd(d_k, l_k, rms_length) * (1.0 - MARGIN)
    return (untold | (rms_length > rms_model * (1.0 + MARGIN))
            | (gain > needed + MARGIN * before))


def check_length(open_loop: np.ndarray, corrected: np.ndarray, reference: np.ndarray,
                 planned: tuple, directions: dict, discretization: float, grip: float,
                 alternative: LengthAlternative, l_t: np.ndarray, cable_length: float,
                 needed: float) -> None:
    """Refuse a correction whose predicted gain is lost when the cable's length, not the
    estimate, explains the measurement at K (:attr:`LengthAlternative.told`).

    Both predictions (``open_loop`` and ``corrected``, (n + 1, 3) [m], the estimate's bias
    included) are moved to the alternative's: the estimate's alpha d + beta g taken off, at
    the planned target clips (``planned``: d and g there) and at the corrected ones
    (``directions`` of :func:`~.step.check_gain`), and alpha' d + lambda l_t put on (l_t the
    target's response to the length at the planned clips, :func:`length_direction`; its change
    with the clips is left out: 0.6 of the 1.5 mm the alternative's corrected error moved on
    fig4_8's sample 56); the gain, the mean distances to ``reference`` [m] before less after,
    is evaluated there, as the clamp length's bounds are (:func:`~.step.check_gain`), and
    must exceed ``needed`` [m], what :func:`~.step.check_gain` asked of the estimate's gain
    (its significance times the gain's sd): the same rule under either explanation.

    Raises
    ------
    CorrectionRefused
        When the alternative is told and its gain does not exceed ``needed``: the plan is
        kept.
    """
    if not alternative.told:
        return
    change = alternative.discretization - discretization

    def error(x: np.ndarray, d: np.ndarray, g: np.ndarray) -> float:
        moved = x + change * d - grip * g + alternative.length * l_t
        return float(np.mean(np.linalg.norm(moved - reference, axis=1)))

    before = error(open_loop, *planned)
    after = error(corrected, directions["discretization"], directions["grip"])
    if before - after > needed:
        return
    raise CorrectionRefused(
        f"length: the measurement is explained better by a cable "
        f"{1e3 * abs(alternative.length) * cable_length:.1f} mm "
        f"{'shorter' if alternative.length < 0 else 'longer'} than the plan's (residual "
        f"{1e3 * alternative.rms_length:.2f} mm against {1e3 * alternative.rms_model:.2f} mm "
        "with E, the discretization bias and the clamp length as estimated), and with that "
        f"length the correction's predicted final error goes {1e3 * before:.2f} -> "
        f"{1e3 * after:.2f} mm, a gain within the {1e3 * needed:.2f} mm the gain check asks: "
        "the plan is kept")
