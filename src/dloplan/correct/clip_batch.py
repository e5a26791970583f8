"""The study's clip fits of a chunk of samples at once (the linearized closed loop).

:mod:`.linearized` fits each sample's target clip correction by a Levenberg-Marquardt loop with
its Jacobian frozen (a chord method, :data:`~.linearized.CHORD_TRIALS` trials per iteration),
every trial an exact equilibrium of the updated model's fit chain. Run per sample, the loop's
own arithmetic (a 12 x 12 solve, the limits' projection, the guess, the residual: about 20
small numpy calls per trial) cost about as much CPU as the trial's compiled Newton solve.
:func:`fit_clips_batch` runs the same loop for B samples in lockstep: each round every sample
still fitting makes its next trial, all of them one batch of arrays (one stacked solve, the
projection and residuals as array operations) and one ``solve`` call for their equilibria;
acceptance, damping and the stop are decided per sample on arrays, as the per-sample loop
decides them. The arithmetic is the per-sample loop's but for the order of the sums of the
stacked products (round-off), so a sample's fit is the per-sample fit to solver tolerance.

A sample whose normal equations are not finite or have no positive trace (nothing moves the
shape: the per-sample loop's floor is 0 then, its solve singular) is not fitted here: the
caller runs the per-sample loop on it (``fitted`` False).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .step import CLIP_DAMPING, COST_TOLERANCE, CorrectionLimits


def fit_clips_batch(jacobians: np.ndarray, fine: np.ndarray, moves: np.ndarray,
                    starts: np.ndarray, bias: np.ndarray, reference: np.ndarray,
                    scale: np.ndarray, limits: CorrectionLimits, clamp_links: int, trials: int,
                    solve: Callable) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """B clip fits of the linearized closed loop in lockstep (module docstring).

    Sample b fits p (12,) so that the fit chain's every k-th point plus its bias, moved with
    the clips by ``moves``, meets the ``reference``: the residual is ``x[::k] + bias[b] -
    reference + moves[b] @ (p scale)``, from p = 0 at ``starts[b]``, with the frozen Jacobian
    ``jacobians[b]``, the damping :data:`~.step.CLIP_DAMPING` on diag(J^T J) above a floor of
    1e-12 trace(J^T J), each trial projected onto the ``limits``
    (:func:`~.step.within_limits`), at most ``trials`` trials per iteration and
    ``limits.iterations`` iterations, stopping when a step gains less than
    :data:`~.step.COST_TOLERANCE` of the cost.

    Parameters
    ----------
    jacobians : numpy.ndarray
        (B, 3 (n + 1), 12) d residual / d p, scaled coordinates [m].
    fine : numpy.ndarray
        (B, 3 (k n + 1), 12) the fit chain's clip Jacobian at all its points (the trials'
        guesses), scaled coordinates [m].
    moves : numpy.ndarray
        (B, 3 (n + 1), 12) how the bias moves with the clips, scaled coordinates [m].
    starts : numpy.ndarray
        (B, k n + 1, 3) the fit chain's equilibria at the planned clips [m].
    bias : numpy.ndarray
        (B, n + 1, 3) the bias the fit chain leaves, at the planned clips [m].
    reference : numpy.ndarray
        (n + 1, 3) the shape aimed at [m].
    scale : numpy.ndarray
        (12,) the clip coordinates' scale (1 for metres, L / 2 for radians).
    limits : CorrectionLimits
    clamp_links : int
        k.
    trials : int
        Trials per iteration.
    solve : callable
        ``solve(index, p, guesses)``: the fit chain's equilibria of the samples ``index`` (m,)
        at the clip corrections ``p`` (m, 12) from ``guesses`` (m, k n + 1, 3), a list of
        (k n + 1, 3) arrays [m], None where there is no stable equilibrium.

    Returns
    -------
    tuple
        ``(p (B, 12), x (B, k n + 1, 3), fitted (B,) bool)``: the corrections and their
        equilibria, and which samples were fitted here (the others hold p = 0 and their
        start, for the per-sample loop).
    """
    count = len(starts)
    k = clamp_links
    normal = np.matmul(np.swapaxes(jacobians, 1, 2), jacobians)  # (B, 12, 12)
    trace = np.trace(normal, axis1=1, axis2=2)
    fitted = np.all(np.isfinite(normal), axis=(1, 2)) & (trace > 0)
    diagonal = normal * np.eye(12)  # the damping's shape, mu diag(J^T J)
    normal = normal + 1e-12 * trace[:, None, None] * np.eye(12)  # the fit's floor
    x = np.array(starts, dtype=float)
    p = np.zeros((count, 12))
    r = _residuals(x, p, bias, reference, moves, scale, k)
    cost = np.einsum("bi,bi->b", r, r)
    mu = np.full(count, CLIP_DAMPING.initial)
    gradient = np.einsum("bij,bi->bj", jacobians, r)
    iteration = np.zeros(count, dtype=np.int64)
    trial = np.zeros(count, dtype=np.int64)
    active = fitted & (limits.iterations > 0)
    while np.any(active):
        index = np.flatnonzero(active)
        steps = np.linalg.solve(normal[index] + mu[index, None, None] * diagonal[index],
                                gradient[index, :, None])[:, :, 0]
        trial_p = within_limits_batch(p[index] - steps / scale, limits)
        guesses = x[index] + np.matmul(fine[index], ((trial_p - p[index]) * scale)[:, :, None]
                                       ).reshape(x[index].shape)
        shapes = solve(index, trial_p, guesses)
        solved = np.array([s is not None for s in shapes], dtype=bool)
        accepted = np.zeros(len(index), dtype=bool)
        trial_x = guesses.copy()
        if np.any(solved):
            trial_x[solved] = np.array([s for s in shapes if s is not None])
            r_trial = _residuals(trial_x, trial_p, bias[index], reference, moves[index],
                                 scale, k)
            trial_cost = np.einsum("bi,bi->b", r_trial, r_trial)
            accepted = solved & (trial_cost <= cost[index])
        rejected = index[~accepted]
        mu[rejected] *= CLIP_DAMPING.increase
        trial[rejected] += 1
        active[rejected[trial[rejected] >= trials]] = False
        if np.any(accepted):
            took = index[accepted]
            before, after = cost[took], trial_cost[accepted]
            gain = np.where(before > 0, (before - after) / np.where(before > 0, before, 1.0),
                            0.0)
            x[took], p[took] = trial_x[accepted], trial_p[accepted]
            r_took = r_trial[accepted]
            cost[took] = after
            mu[took] = np.maximum(mu[took] / CLIP_DAMPING.decrease, CLIP_DAMPING.minimum)
            iteration[took] += 1
            trial[took] = 0
            active[took[(gain < COST_TOLERANCE) | (iteration[took] >= limits.iterations)]] = False
            gradient[took] = np.einsum("bij,bi->bj", jacobians[took], r_took)
    return p, x, fitted


def _residuals(x, p, bias, reference, moves, scale, k) -> np.ndarray:
    """(B, 3 (n + 1)): every k-th point of ``x`` (B, k n + 1, 3) plus ``bias`` less the
    ``reference``, moved with the clips ``p`` (B, 12) by ``moves`` [m]."""
    return ((x[:, ::k] + bias - reference).reshape(len(x), -1)
            + np.matmul(moves, (p * scale)[:, :, None])[:, :, 0])


def within_limits_batch(p: np.ndarray, limits: CorrectionLimits) -> np.ndarray:
    """:func:`~.step.within_limits` of B clip corrections (B, 12) at once: each clip's
    translation and rotation vector shortened to ``limits.max_translation`` /
    ``max_rotation``."""
    groups = np.array(p, dtype=float).reshape(len(p), 4, 3)
    bounds = np.array([limits.max_translation, limits.max_rotation] * 2)
    norms = np.sqrt(np.einsum("bgi,bgi->bg", groups, groups))
    over = norms > bounds
    factor = np.where(over, bounds / np.where(over, norms, 1.0), 1.0)
    groups = np.where(over[:, :, None], groups * factor[:, :, None], groups)
    return groups.reshape(len(p), 12)
