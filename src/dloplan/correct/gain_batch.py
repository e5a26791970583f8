"""The gain checks of many corrections at once (the study's linearized closed loop).

:func:`~.step.check_gain` judges one correction: the predicted gain must exceed
``significance`` sd of it (:func:`~.step.parameter_sds`, linearized in ln E, alpha and beta)
and stay a gain with the clamp length ``significance`` sd off, evaluated. A study's chunk
judges hundreds, each with a dozen small numpy calls; :func:`clear_gains` evaluates the same
two checks for B corrections on arrays and tells which pass both by more than round-off
(:data:`MARGIN`), and :func:`judged_gains` words the refusals of the first check by more than
round-off as ``check_gain`` does where every number printed is clear of a rounding boundary.
The others -- refused by the second check, or too close to a threshold or a rounding
boundary for arrays summed in another order to vouch for the verdict or the text -- go to
:func:`~.step.check_gain` itself: so every decision and reason is the per-sample check's.
"""

from __future__ import annotations

import numpy as np

from .step import gain_refusal

MARGIN = 1e-9
"""A check passes here when it passes by more than this share of the open loop's predicted
error (round-off of the mean distances is about 1e-16 of it)."""

PRINT_MARGIN = 1e-6
"""A printed number [mm, two decimals] counts as the per-sample check's when it is more than this
share of a hundredth from a rounding boundary (round-off moves it by about 1e-13 of it)."""

NAMES = ("modulus", "discretization", "grip")
"""The estimated quantities, in the order of the sds' columns."""


def clear_gains(open_loop: np.ndarray, corrected: np.ndarray, reference: np.ndarray,
                directions: dict, sds: np.ndarray, correlation: np.ndarray,
                significance: float) -> np.ndarray:
    """Which of B corrections pass both gain checks of :func:`~.step.check_gain` by more than
    :data:`MARGIN` (module docstring).

    Parameters
    ----------
    open_loop, corrected : numpy.ndarray
        (B, n + 1, 3) the target's predictions at the planned and the corrected clips, the
        bias included [m].
    reference : numpy.ndarray
        (n + 1, 3) the shape aimed at [m].
    directions : dict
        Per name of :data:`NAMES`, (B, n + 1, 3) the target's response to it [m].
    sds : numpy.ndarray
        (B, 3) the quantities' sds (:func:`~.step.parameter_sds`, in the order of
        :data:`NAMES`).
    correlation : numpy.ndarray
        (B,) of ln E and alpha (:attr:`~.step.ModelUpdate.correlation`).
    significance : float

    Returns
    -------
    numpy.ndarray
        (B,) bool.
    """
    return judged_gains(open_loop, corrected, reference, directions, sds, correlation,
                        significance)[0]


def judged_gains(open_loop: np.ndarray, corrected: np.ndarray, reference: np.ndarray,
                 directions: dict, sds: np.ndarray, correlation: np.ndarray,
                 significance: float) -> tuple[np.ndarray, list]:
    """:func:`clear_gains` (the same arguments), and the refusal of each correction whose
    predicted gain is within ``significance`` sd of zero by more than :data:`MARGIN` (the
    first check of :func:`~.step.check_gain`), worded as it words it
    (:func:`~.step.gain_refusal`) where every number it prints is clear of a rounding
    boundary by more than :data:`PRINT_MARGIN` (the arrays are summed in another order than
    its own, to round-off); None for the others (passed, or left to ``check_gain``).

    Returns
    -------
    tuple
        ``(clear (B,) bool, refusals, spread)``: a list of B str or None, and (B,) the gains'
        sds [m] (:func:`~.step.check_gain`'s, for :func:`.length.check_length`).
    """
    def errors(x):
        return np.linalg.norm(x - reference, axis=-1)  # (B, n + 1)

    open_errors, corrected_errors = errors(open_loop), errors(corrected)
    before, after = open_errors.mean(axis=-1), corrected_errors.mean(axis=-1)
    du = ((open_loop - reference) / np.maximum(open_errors, 1e-300)[:, :, None]
          - (corrected - reference) / np.maximum(corrected_errors, 1e-300)[:, :, None])
    t = np.stack([np.mean(np.sum(du * directions[name], axis=-1), axis=-1) for name in NAMES],
                 axis=1) * sds
    variance = np.sum(t * t, axis=1) + 2.0 * correlation * t[:, 0] * t[:, 1]
    spread = np.sqrt(np.maximum(variance, 0.0))
    margin = MARGIN * before
    clear = before - after > significance * spread + margin
    bound = (significance * sds[:, 2])[:, None, None] * directions["grip"]
    for sign in (-1.0, 1.0):
        shift = sign * bound
        gain = errors(open_loop + shift).mean(axis=-1) - errors(corrected + shift).mean(axis=-1)
        clear &= gain > margin
    refused = before - after < significance * spread - margin
    printed = 1e3 * np.stack([before - after, before, after, significance * spread, spread])
    refusals = [gain_refusal(float(before[b]), float(after[b]), float(spread[b]), significance)
                if refused[b] and _clear_of_rounding(printed[:, b]) else None
                for b in range(len(before))]
    return clear, refusals, spread


def _clear_of_rounding(values: np.ndarray) -> bool:
    """Whether numbers [mm] printed to two decimals print the same when they move by
    round-off: each more than :data:`PRINT_MARGIN` of a hundredth from a boundary between two
    printed values (and from zero, where the sign would print)."""
    hundredths = np.abs(values) * 100.0
    offset = hundredths - np.floor(hundredths)
    return bool(np.all(np.isfinite(values)) and np.all(np.abs(offset - 0.5) > PRINT_MARGIN)
                and np.all(hundredths > PRINT_MARGIN))
