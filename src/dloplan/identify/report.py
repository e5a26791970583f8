"""What an identification says to its user: lines to print, a JSON summary, an exit code.

Kept apart from the command line (``dloplan identify`` only prints these) so any front end
gives the same verdicts:

* exit 0 (:data:`OK`): a trustworthy modulus, no warning;
* exit 1 (:data:`WARNINGS`): a modulus, with warnings (n raised for the curvature, a large
  discretization error, a manipulation that misses the measured branch, skipped simulations);
* exit 2 (:data:`FAILURE`): no modulus; the first line says why (poor fit, two basins, a
  bound, an uninformative experiment, failed simulations).

:func:`plan_warnings` compares the cable a plan uses with the identification's (discretization
and bending model): the identified E is an effective modulus of that model, and planning with
another n or bending model is a mismatch to be warned about, never silent.
"""

from __future__ import annotations

import math

from ..cable import Cable
from .fit import Identification

OK, WARNINGS, FAILURE = 0, 1, 2


def exit_code(result: Identification) -> int:
    """0 success, 1 success with warnings, 2 failure."""
    if not result.success:
        return FAILURE
    return WARNINGS if result.warnings else OK


def report_lines(result: Identification) -> list[str]:
    """The verdict first (one line), then the numbers, warnings and local minima."""
    if not result.success:
        lines = [f"identification failed: {result.reason}"]
    else:
        lo, hi = result.confidence_interval
        lines = [f"E = {result.youngs_modulus:.4g} Pa, 95 % interval {lo:.4g} to {hi:.4g} Pa "
                 f"({result.bending} bending model, n = {result.n_links})"]
    lines += [
        f"  simulations {result.simulations} (Gauss-Newton steps {result.iterations}, "
        f"failed {result.failed_simulations})",
        f"  residual: RMS distance {1e3 * result.rms_error:.2f} mm, largest "
        f"{1e3 * result.max_error:.2f} mm, {result.noise_ratio:.2f} x the stated noise",
        f"  sd(ln E) {result.log_sd:.3g} statistical"
        + ("" if math.isnan(result.discretization_error)
           else f", discretization error {result.discretization_error:.3g} (n vs 2n)"),
    ]
    for minimum in result.minima:
        where = f" at {minimum.at_bound}" if minimum.at_bound else ""
        estimated = "" if minimum.refined else " (estimated from the scan)"
        lines.append(f"  local minimum{where}: E = {minimum.youngs_modulus:.4g} Pa, cost "
                     f"{minimum.cost:.3g} m^2{estimated}")
    lines += [f"  warning: {w}" for w in result.warnings]
    return lines


def to_dict(result: Identification) -> dict:
    """A JSON-ready summary of the result."""
    return {
        "success": result.success, "exit_code": exit_code(result), "reason": result.reason,
        "warnings": list(result.warnings), "youngs_modulus": result.youngs_modulus,
        "confidence_interval": list(result.confidence_interval), "log_sd": result.log_sd,
        "discretization_error": result.discretization_error, "n_links": result.n_links,
        "bending": result.bending, "simulations": result.simulations,
        "iterations": result.iterations, "cost": result.cost, "rms_error": result.rms_error,
        "noise_ratio": result.noise_ratio, "at_bound": result.at_bound,
        "informative": result.informative, "message": result.message,
        "minima": [{"youngs_modulus": m.youngs_modulus, "cost": m.cost, "refined": m.refined,
                    "at_bound": m.at_bound} for m in result.minima],
    }


def plan_warnings(result: Identification, cable: Cable) -> list[str]:
    """Warnings for planning with ``cable`` a modulus identified as ``result`` (may be empty).

    Parameters
    ----------
    result : Identification
        A successful identification.
    cable : Cable
        The cable the plan uses.
    """
    out = []
    if cable.n_links != result.n_links:
        out.append(f"the plan uses n = {cable.n_links} links but E was identified with n = "
                   f"{result.n_links}: the identified E is an effective modulus of that "
                   "discretization; plan with it or identify with this n")
    if cable.bending != result.bending:
        out.append(f"the plan uses the {cable.bending!r} bending model but E was identified "
                   f"with {result.bending!r}: the same data give E about "
                   f"{'3 times' if result.bending == 'thesis' else 'a third of'} this one in "
                   f"the {cable.bending!r} model")
    if (cable.axial_modulus is None) != (result.cable.axial_modulus is None):
        out.append("the plan's cable and the identified one differ in having an axial modulus "
                   "of their own: the identified E belongs to the identification's axial model")
    return out
