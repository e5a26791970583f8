"""Stiffness families and the planner's cost weights (thesis 6.2, Tables 6.1 and 6.2).

The thesis sorts cables into three stiffness families by Young's modulus (its Figure 6.9 with
the boundaries is lost) and tunes the physical-stage weights per family (Table 6.2); the
geometric weights are the same for all (Table 6.1).

Family boundaries (configurable through :class:`FamilyBoundaries`): the labels the thesis gives
its cables fix only the order -- USB 2.5e6 Pa *soft*, Ethernet 7.5e6 Pa *medium*, PA12 1e9 Pa
*stiff*. We put

* soft | medium at **5e6 Pa** (between USB and Ethernet, near their geometric mean 4.3e6), and
* medium | stiff at **3e8 Pa** (near the geometric mean 3.2e8 of PU and PA12).

The PU hose (1e8 Pa) is therefore **medium**. The thesis calls it "quite" stiff but says its
stiffness only "slightly compensates gravity deformations" (7.2.2), while PA12 shows "an almost
null deformation due to gravity" (7.2.2, labelled stiff). The self-weight parameter
q L^3 / (E I) of a 0.5 m, 6 mm, 10 g hose is about 4 at 1e8 Pa (visible sag, the medium
regime of the Ethernet cable) and 0.4 at 1e9 Pa (almost none): a boundary near 3e8 Pa, where it
is about 1, separates "sags" from "does not" for the cable size the thesis assumes (L ~ 0.5 m,
d ~ 6 mm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Literal

import numpy as np

from ..cable import Cable

Family = Literal["soft", "medium", "stiff"]
FAMILIES: tuple[str, ...] = ("soft", "medium", "stiff")


def _weight(name: str, value) -> float:
    value = float(value)
    if not math.isfinite(value) or value < 0.0:
        raise ValueError(f"{name}: got {value!r}, expected a finite weight >= 0")
    return value


def _check_weights(obj, prefix: str) -> None:
    for f in fields(obj):
        value = getattr(obj, f.name)
        if f.name == "steps":
            steps = np.atleast_1d(np.asarray(value, dtype=float))
            if steps.ndim != 1 or not np.all(np.isfinite(steps)) or np.any(steps <= 0.0):
                raise ValueError(
                    f"{prefix}.steps: got {value!r}, expected a weight > 0 or one per step"
                )
            object.__setattr__(obj, "steps", float(steps[0]) if steps.size == 1 else
                               tuple(float(v) for v in steps))
        else:
            object.__setattr__(obj, f.name, _weight(f"{prefix}.{f.name}", value))


@dataclass(frozen=True)
class BasicWeights:
    """Weights of the basic geometric cost (eq. 4.15 / 6.6, Table 6.1: w_i,b = w_f,b = 1).

    Parameters
    ----------
    steps : float or sequence of float
        w_i for the steps gamma_1 .. gamma_S (one value for all, or S values) [-], > 0.
    final : float
        w_f for the last step gamma_f [-], > 0.
    """

    steps: float | tuple[float, ...] = 1.0
    final: float = 1.0

    def __post_init__(self) -> None:
        _check_weights(self, "weights.basic")
        if self.final <= 0.0:
            raise ValueError(f"weights.basic.final: got {self.final!r}, expected > 0")


@dataclass(frozen=True)
class AdvancedWeights:
    """Weights of the advanced geometric cost (eq. 4.17 / 6.7, Table 6.1).

    Parameters
    ----------
    steps, final : float
        w_i,a and w_f,a of the transversal terms (thesis: 20, 20); ``steps`` may hold S values.
    delta : float
        w_delta of the link-length change term (thesis: 10).
    clip : float
        w_clip of the 1/Delta_clip term (thesis: 0.008).
    beta : float
        w_beta of the bending-angle term (thesis: 40).
    """

    steps: float | tuple[float, ...] = 20.0
    final: float = 20.0
    delta: float = 10.0
    clip: float = 0.008
    beta: float = 40.0

    def __post_init__(self) -> None:
        _check_weights(self, "weights.advanced")


@dataclass(frozen=True)
class PhysicalWeights:
    """Weights of the physical cost w_sigma |sigma|^2 + w_b |F_b|^2 + w_s |F_s|^2 (eq. 4.19).

    Only used by the ``"thesis"`` physical mode. Defaults: the medium family of Table 6.2.
    """

    sigma: float = 10.0
    bending: float = 100.0
    axial: float = 1.0

    def __post_init__(self) -> None:
        _check_weights(self, "weights.physical")
        if self.sigma + self.bending + self.axial <= 0.0:
            raise ValueError("weights.physical: all three weights are zero")


PHYSICAL_WEIGHTS: dict[str, PhysicalWeights] = {
    "soft": PhysicalWeights(sigma=10.0, bending=1000.0, axial=10.0),
    "medium": PhysicalWeights(sigma=10.0, bending=100.0, axial=1.0),
    "stiff": PhysicalWeights(sigma=0.1, bending=100.0, axial=1.0),
}
"""Table 6.2 of the thesis, by stiffness family."""


@dataclass(frozen=True)
class PlannerWeights:
    """All the planner's weights: basic, advanced (Table 6.1) and physical (Table 6.2)."""

    basic: BasicWeights = field(default_factory=BasicWeights)
    advanced: AdvancedWeights = field(default_factory=AdvancedWeights)
    physical: PhysicalWeights = field(default_factory=PhysicalWeights)

    def __post_init__(self) -> None:
        for name, kind in (("basic", BasicWeights), ("advanced", AdvancedWeights),
                           ("physical", PhysicalWeights)):
            value = getattr(self, name)
            if isinstance(value, dict):
                value = kind(**value)
            if not isinstance(value, kind):
                raise ValueError(
                    f"weights.{name}: got {type(value).__name__}, expected {kind.__name__} "
                    f"or a dict of its fields"
                )
            object.__setattr__(self, name, value)


@dataclass(frozen=True)
class FamilyBoundaries:
    """Young's modulus boundaries of the stiffness families [Pa] (see the module docstring).

    ``E < soft_below``: soft; ``soft_below <= E < stiff_from``: medium; ``E >= stiff_from``:
    stiff.
    """

    soft_below: float = 5e6
    stiff_from: float = 3e8

    def __post_init__(self) -> None:
        for name in ("soft_below", "stiff_from"):
            value = float(getattr(self, name))
            if not math.isfinite(value) or value <= 0.0:
                raise ValueError(f"boundaries.{name}: got {value!r}, expected a modulus > 0 [Pa]")
            object.__setattr__(self, name, value)
        if self.soft_below >= self.stiff_from:
            raise ValueError(
                f"boundaries: soft_below {self.soft_below:g} Pa must be below stiff_from "
                f"{self.stiff_from:g} Pa"
            )


def stiffness_family(youngs_modulus: float, boundaries: FamilyBoundaries | None = None) -> str:
    """The stiffness family ("soft", "medium" or "stiff") of a Young's modulus [Pa] (thesis 6.2)."""
    e = float(youngs_modulus)
    if not math.isfinite(e) or e <= 0.0:
        raise ValueError(f"youngs_modulus: got {youngs_modulus!r}, expected a modulus > 0 [Pa]")
    b = boundaries if boundaries is not None else FamilyBoundaries()
    if e < b.soft_below:
        return "soft"
    return "medium" if e < b.stiff_from else "stiff"


def planner_weights(
    cable: Cable | None = None,
    *,
    family: str | None = None,
    boundaries: FamilyBoundaries | None = None,
    overrides: dict | None = None,
) -> PlannerWeights:
    """The thesis' weights for a cable (or an explicit family), with user overrides.

    Parameters
    ----------
    cable : Cable, optional
        Its Young's modulus chooses the family (see :func:`stiffness_family`).
    family : {"soft", "medium", "stiff"}, optional
        Chooses the physical weights directly (wins over ``cable``); default "medium".
    boundaries : FamilyBoundaries, optional
        Family boundaries [Pa].
    overrides : dict, optional
        ``{"basic": {...}, "advanced": {...}, "physical": {...}}``: fields replacing the
        defaults, e.g. ``{"advanced": {"clip": 0.02}}``.
    """
    if family is None:
        family = stiffness_family(cable.youngs_modulus, boundaries) if cable else "medium"
    if family not in FAMILIES:
        raise ValueError(f"family: got {family!r}, expected one of {', '.join(FAMILIES)}")
    weights = PlannerWeights(physical=PHYSICAL_WEIGHTS[family])
    for stage, changes in (overrides or {}).items():
        if stage not in ("basic", "advanced", "physical"):
            raise ValueError(
                f"overrides: unknown stage {stage!r}, expected 'basic', 'advanced' or 'physical'"
            )
        current = getattr(weights, stage)
        unknown = set(changes) - {f.name for f in fields(current)}
        if unknown:
            raise ValueError(
                f"overrides.{stage}: unknown weight(s) {sorted(unknown)}, expected some of "
                f"{[f.name for f in fields(current)]}"
            )
        weights = replace(weights, **{stage: replace(current, **changes)})
    return weights
