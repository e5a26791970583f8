"""Data-driven tuning (thesis 6.2, Fig. 6.11): from an identified E to a cable ready to plan.

The identified modulus sets, in one call, the simulation's E (the returned :class:`Cable`) and
the planner's stiffness family and weights (:mod:`dloplan.planning.tuning`, thesis Tables 6.1
and 6.2).

The families are defined on the thesis' moduli, which belong to the thesis' bending model
(k_b = 3EI/l). A modulus identified with ``bending="rod"`` (k_b = EI/l) describes the same
bending stiffness with three times the E, so the family is chosen from the
**thesis-equivalent modulus** E_thesis = k_b l / (3 I): E / 3 for a rod-model cable, E itself
for a thesis-model one. Otherwise a USB cable identified with the rod model (about 7.5e6 Pa)
would be filed as "medium" instead of the thesis' "soft".
"""

from __future__ import annotations

from dataclasses import dataclass

from ..cable import Cable
from ..planning.tuning import PlannerWeights, planner_weights, stiffness_family
from .fit import Identification


@dataclass(frozen=True, eq=False)
class TunedSetup:
    """What the planner needs for an identified cable.

    Attributes
    ----------
    cable : Cable
        The cable with the identified Young's modulus.
    thesis_modulus : float
        The thesis-equivalent modulus k_b l / (3 I) [Pa]: the E the thesis' own bending model
        would need for the same bending stiffness (for comparison with the thesis' values).
    family : str
        ``"soft"``, ``"medium"`` or ``"stiff"`` (thesis Fig. 6.9), of the identified modulus by
        the planner's rule (:func:`dloplan.planning.tuning.stiffness_family`).
    weights : dloplan.planning.tuning.PlannerWeights
        The planner's weights for the family (thesis Tables 6.1, 6.2).
    identification : Identification
        The identification it came from.
    """

    cable: Cable
    thesis_modulus: float
    family: str
    weights: PlannerWeights
    identification: Identification


def thesis_equivalent_modulus(cable: Cable) -> float:
    """The modulus [Pa] giving the cable's bending stiffness in the thesis' model, k_b l / (3 I)."""
    return cable.bending_stiffness / (3.0 * cable.second_moment)


def tune_for_identified(identification: Identification, *, boundaries=None,
                        overrides: dict | None = None) -> TunedSetup:
    """The cable, stiffness family and planner weights for an identified modulus (Fig. 6.11).

    Parameters
    ----------
    identification : Identification
        A successful identification (its ``cable`` carries the identified E).
    boundaries : dloplan.planning.tuning.FamilyBoundaries, optional
        Family boundaries [Pa] (thesis-model moduli).
    overrides : dict, optional
        Weight overrides passed to :func:`dloplan.planning.tuning.planner_weights`.

    Raises
    ------
    ValueError
        When the identification did not succeed (a bound, failed simulations): no modulus to
        tune with.
    """
    if not isinstance(identification, Identification):
        raise ValueError(f"identification: got {type(identification).__name__}, expected an "
                         "Identification")
    if not identification.success:
        raise ValueError(f"identification: not successful, nothing to tune with "
                         f"({identification.message})")
    cable = identification.cable
    modulus = thesis_equivalent_modulus(cable)
    # the same rule as the planner's: the family of the modulus as identified (docs/planner.md)
    family = stiffness_family(cable.youngs_modulus, boundaries)
    weights = planner_weights(family=family, boundaries=boundaries, overrides=overrides)
    return TunedSetup(cable, modulus, family, weights, identification)
