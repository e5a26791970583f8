"""The damped least-squares / trust-region loop shared by the planner, the correction and the
identification's fits.

Every damped Newton or Levenberg-Marquardt iteration of dloplan does the same thing: linearize
the problem at the current state, solve the shifted system (A + mu D) p = -b for a trial step,
evaluate the trial, accept it if the cost does not rise, and adapt the shift mu to how well the
linear model predicted the decrease (the gain ratio rho = actual / predicted decrease, a trust
region in Levenberg-Marquardt form). What differs between problems is only the linear algebra
(dense 12 x 12, a banded Cholesky, a sparse LU or GMRES on a grid), what a trial costs (a
residual, or a whole equilibrium solve that may fail) and the numbers of the policy. So:

* :class:`Damping` is the policy: where mu starts, how it grows after a rejected or poor step
  and falls after a good one, and when it resets to 0 (a pure Newton / Gauss-Newton step);
* :func:`gain_ratio` the ratio of actual to predicted decrease;
* :func:`damped_minimize` the loop, with the problem-specific parts passed in: ``linearize``
  (the system at a state, or None when converged) and ``evaluate`` (a trial's state and cost, or
  None when the trial fails).

Users: the physical planner's thesis-mode least squares (:mod:`dloplan.planning.physical`, banded
normal equations), the correction's clip fit (:mod:`dloplan.correct.step`, dense, every trial an
equilibrium), and the advanced planner's damped Newton (:mod:`dloplan.planning.geometric`, its
policy :data:`dloplan.planning.geometric.PLANNER_DAMPING`). The static solvers' trust-region
Newton (:mod:`dloplan.sim.newton`) keeps its compiled loop (it runs inside numba), with the same
ratio test in :func:`dloplan.sim.newton.step_verdict`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol


@dataclass(frozen=True)
class Damping:
    """A Levenberg-Marquardt damping policy (the shift mu, relative to the caller's scale).

    Parameters
    ----------
    initial : float
        mu of the first trial.
    start : float
        The smallest mu after a rejected or poor step (from 0).
    increase : float
        Factor on mu after a rejected trial or an accepted step with a poor gain ratio.
    decrease : float
        Factor by which mu falls after a good step.
    minimum : float
        mu never falls below this (0: it may).
    reset_below : float
        After a good step a mu at or below this becomes 0 (a pure Newton step next).
    good, poor : float
        Gain ratios: at least ``good`` lowers mu, below ``poor`` raises it, in between keeps it.
    maximum : float
        A trial needing mu above this ends the loop (stalled).
    """

    initial: float = 0.0
    start: float = 1e-4
    increase: float = 10.0
    decrease: float = 10.0
    minimum: float = 0.0
    reset_below: float = 0.0
    good: float = 0.9
    poor: float = 0.25
    maximum: float = math.inf

    def raised(self, shift: float) -> float:
        """mu after a rejected trial (or a trial whose system could not be solved)."""
        return max(self.increase * shift, self.start)

    def after(self, shift: float, ratio: float) -> float:
        """mu after an accepted step whose gain ratio is ``ratio`` (-inf: rejected)."""
        if ratio < self.poor:
            return self.raised(shift)
        if ratio < self.good:
            return shift
        if shift <= self.reset_below:
            return 0.0
        return max(shift / self.decrease, self.minimum)


def gain_ratio(cost: float, trial_cost: float, predicted: float | None) -> float:
    """Actual over predicted decrease of the cost; -inf when the cost rose, 1 without a
    prediction or when the prediction is at round-off."""
    actual = cost - trial_cost
    if actual < 0:
        return -math.inf
    if predicted is None or not predicted > 1e-15 * max(abs(cost), 1e-300):
        return 1.0
    return actual / predicted


class Linearization(Protocol):
    """The system of one iteration: ``solve(shift)`` a step (None when the shifted system
    cannot be solved), ``predicted(step, shift)`` the linear model's decrease of the cost for
    that step (None: no prediction, the ratio test is skipped)."""

    def solve(self, shift: float): ...

    def predicted(self, step, shift: float) -> float | None: ...


@dataclass(frozen=True, eq=False)
class DampedRun:
    """Outcome of :func:`damped_minimize`: the final state and cost, iterations, success, a
    message, and the shift mu at the end."""

    state: object
    cost: float
    iterations: int
    success: bool
    message: str
    shift: float


def damped_minimize(
    state,
    cost: float,
    linearize: Callable[[object], Linearization | None],
    evaluate: Callable[[object, object, Linearization], tuple[object, float] | None],
    damping: Damping,
    *,
    max_iterations: int,
    max_trials: int | None = None,
    stop_gain: float = 0.0,
) -> DampedRun:
    """Damped (Levenberg-Marquardt / trust-region) iterations on a least-squares or energy cost.

    Parameters
    ----------
    state : object
        The start (whatever ``evaluate`` builds).
    cost : float
        Its cost.
    linearize : callable
        ``linearize(state)`` -> the iteration's :class:`Linearization`, or None when the state
        is converged (the caller's test: a gradient norm, a Newton decrement).
    evaluate : callable
        ``evaluate(state, step, system)`` -> ``(trial state, trial cost)``, or None when the
        trial fails (an equilibrium that does not converge); ``system`` is the iteration's
        linearization (a warm start for the trial).
    damping : Damping
        The policy.
    max_iterations : int
        Iterations (linearizations) at most.
    max_trials : int, optional
        Trials per iteration at most (default: until mu exceeds ``damping.maximum``); when they
        run out the loop ends, successfully (nothing lowers the cost from here).
    stop_gain : float
        An accepted step that lowers the cost by less than this fraction of it ends the loop
        (converged).

    Returns
    -------
    DampedRun
    """
    shift = damping.initial
    for iteration in range(1, max_iterations + 1):
        system = linearize(state)
        if system is None:
            return DampedRun(state, cost, iteration - 1, True,
                             f"converged in {iteration - 1} iterations", shift)
        trials = 0
        while True:
            trials += 1
            step = system.solve(shift)
            trial = None if step is None else evaluate(state, step, system)
            if trial is not None and trial[1] <= cost:
                ratio = gain_ratio(cost, trial[1], system.predicted(step, shift))
                gain = (cost - trial[1]) / max(cost, 1e-300)
                state, cost = trial
                shift = damping.after(shift, ratio)
                break
            shift = damping.raised(shift)
            if shift > damping.maximum:
                return DampedRun(state, cost, iteration, False,
                                 f"stalled after {iteration} iterations (cost {cost:.3g})", shift)
            if max_trials is not None and trials >= max_trials:
                return DampedRun(state, cost, iteration, True,
                                 f"converged in {iteration} iterations (no trial lowers the "
                                 "cost)", shift)
        if gain < stop_gain:
            return DampedRun(state, cost, iteration, True,
                             f"converged in {iteration} iterations (no further decrease)", shift)
    return DampedRun(state, cost, max_iterations, False,
                     f"no convergence in {max_iterations} iterations (cost {cost:.3g})", shift)
