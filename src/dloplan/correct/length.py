"""The cable's length: the explanation of a measured shape the model update does not carry.

The model update (:func:`~.step.update_modulus`) explains the shape measured at K by E, the
discretization bias alpha d and the clamp length's beta g. A cable a little shorter or longer
than the plan's is none of them, and at K the clamp length stands in for it: both change the
free length. They differ elsewhere: a longer clamp also moves the free part's ends along the
clips' axes. On a compressed arch (fig4_8's shape 3, the clips 0.48 m apart for a 0.5 m cable)
the clamp length fitted for a cable 10.7 mm short predicted the target 13.9 mm off and the
corrected one 1.1 mm off; the plant, and the model with the cable's length, went 4.9 -> 6.9 mm
(docs/correction.md, "The cable's length").

:func:`length_alternative` fits the measurement at K with the length in the clamp length's
place (ln E as updated, alpha and lambda, lambda the relative change of the rest length, with
alpha's prior) and :func:`check_length` refuses a correction whose predicted gain is lost when
the length explains the measurement at least as well as the model's own estimate: a correction
that cannot be shown to help is not applied.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..cable import GRAVITY, Cable
from ..sim import ClipPoses, equilibrium
from .measurement import CorrectionRefused

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
    rms_model, rms_length : float
        [m] the residual per coordinate the model update's estimate and the length's leave.
    """

    discretization: float
    length: float
    rms_model: float
    rms_length: float

    @property
    def told(self) -> bool:
        """Whether the length explains the measurement at least as well as the estimate."""
        return self.rms_length <= self.rms_model


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

    return LengthAlternative(float(alpha), float(lam),
                             rms(residual - discretization * d - grip * g),
                             rms(residual - alpha * d - lam * l_k))


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
