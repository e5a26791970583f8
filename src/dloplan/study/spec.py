"""The study description: what varies, how, how often, and what counts as success.

A :class:`StudySpec` is the ``study:`` section of a scenario file (pydantic, validated once).
Its units are fixed, whatever the scenario's ``units``, because tolerances are quoted that way
on data sheets and robot specifications:

=====================  ==========================  ============================================
parameter              spread unit                 what is perturbed
=====================  ==========================  ============================================
``youngs_modulus``     % of the nominal E          E (log-normal by default: E > 0 always)
``mass_per_length``    % of the nominal m / L      the cable's weight per metre
``length``             % of the nominal L          the rest length (mass follows m / L)
``clip_position``      mm, per axis                each clip's position (world frame)
``clip_orientation``   deg, per axis               each clip's rotation (a rotation vector in
                                                   the clip frame)
``obstacle_position``  mm, per axis                each obstacle's placement (the table: z)
=====================  ==========================  ============================================

Success criteria (:class:`CriteriaSpec`) are thresholds in mm and N; absent ones are not
checked. An optional ``correction:`` (:class:`CorrectionSpec`) adds the closed-loop success
probability: every sampled cable run as a plant and corrected once (``docs/correction.md``).
Errors are :class:`StudyError` (a ``ValueError``) with one line naming the field.
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, ValidationError, field_validator

from ..bounds import MAX_MEASURED_POINTS, MAX_STUDY_SAMPLES
from ..job_model import JobModel

PARAMETERS: dict[str, str] = {
    "youngs_modulus": "%",
    "mass_per_length": "%",
    "length": "%",
    "clip_position": "mm",
    "clip_orientation": "deg",
    "obstacle_position": "mm",
}
"""The parameters a study can vary, with the unit of their ``spread``."""

RELATIVE = ("youngs_modulus", "mass_per_length", "length")
"""Parameters varied by a factor of their nominal value (the others are signed offsets)."""

DISTRIBUTIONS = ("lognormal", "normal", "uniform")

DEFAULT_DISTRIBUTION = {"youngs_modulus": "lognormal"}
"""Distribution used when a parameter does not name one (otherwise ``normal``)."""


class StudyError(ValueError):
    """A study description that cannot be used; one line naming the field."""


class Variation(JobModel):
    """How one parameter varies.

    ``spread`` is, for ``normal``, the standard deviation; for ``lognormal``, the coefficient of
    variation (standard deviation over mean) of a log-normal factor whose median is 1; for
    ``uniform``, the half-width of the interval around the nominal value. Units: see
    :data:`PARAMETERS`. Vector parameters (clip and obstacle errors) vary each axis
    independently with this spread.
    """

    distribution: Literal["lognormal", "normal", "uniform"] | None = Field(
        None, description="lognormal (default for youngs_modulus), normal (default), uniform"
    )
    spread: float = Field(..., ge=0, allow_inf_nan=False,
                          description="% for E, mass per length, length; mm; deg")


class CriteriaSpec(JobModel):
    """When a sample succeeds: every shape of the path passes every criterion given here."""

    max_deviation: float | None = Field(
        20.0, gt=0, allow_inf_nan=False,
        description="largest point distance from the nominal stabilized shape [mm]")
    collision_free: bool = Field(True, description="no link enters an obstacle")
    target_threshold: float | None = Field(
        10.0, gt=0, allow_inf_nan=False,
        description="T_cf: largest distance of the stabilized target from the planned one [mm]")
    require_stable: bool = Field(True, description="every equilibrium converged and is stable")
    max_sag: float | None = Field(
        None, gt=0, allow_inf_nan=False,
        description="largest depth of the cable below its lower clip [mm]")
    max_tension: float | None = Field(
        None, gt=0, allow_inf_nan=False, description="largest link tension [N]")
    max_clip_force: float | None = Field(
        None, gt=0, allow_inf_nan=False, description="largest force on a clip [N]")


class CorrectionSpec(JobModel):
    """Closed-loop success beside open loop: each sampled cable corrected once (``correction:``).

    Each sample's cable (its E, mass per length and length; the clip and obstacle errors are not
    part of the plant) runs the plan as a plant (:func:`dloplan.correct.run_closed_loop`),
    measured with noise after shape ``at`` and corrected; a sample succeeds when its final
    shape's mean error against the plan's stabilized target is at most ``tolerance``.
    """

    at: int = Field(..., ge=0, description="the shape after which the cable is measured")
    noise: float = Field(1.0, ge=0, allow_inf_nan=False,
                         description="measurement noise per coordinate [mm]")
    n_measured: int = Field(200, ge=2, le=MAX_MEASURED_POINTS, description="measured points")
    tolerance: float = Field(5.0, gt=0, allow_inf_nan=False,
                             description="largest final mean error counted a success [mm]")
    plant_links: int | None = Field(None, ge=2, le=2000,
                                    description="links of the plant (default: the model's)")
    samples: int | None = Field(None, ge=1,
                                description="closed-loop runs: the first N samples (default all)")
    method: Literal["linearized", "exact"] = Field(
        "linearized", description="linearized: the correction with its derivatives frozen at "
        "the nominal plan, a chunk of samples at once (dloplan.correct.linearized); exact: "
        "correct_plan per sample, as `dloplan correct`")


DEFAULT_CHUNKS = (16, 256)
"""Smallest and largest default chunk (:attr:`StudySpec.chunk`) [samples]."""


class StudySpec(JobModel):
    """A robustness study (the ``study:`` section of a scenario file)."""

    samples: int = Field(100, ge=1, le=MAX_STUDY_SAMPLES, description="number of samples N")
    seed: int = Field(0, ge=0, description="seed of the sampler (same seed, same table)")
    sampler: Literal["lhs", "random"] = Field(
        "lhs", description="lhs: Latin hypercube (scipy.stats.qmc); random: independent draws")
    chunk_size: int | None = Field(
        None, ge=1, le=100_000,
        description="samples per task and per file (default: N / 16 within 16 .. 256; the "
                    "linearized closed loop's: its samples / 4 within 16 .. 256)")
    confidence: float = Field(0.95, gt=0, lt=1, description="level of the success interval")
    parameters: dict[str, Variation] = Field(
        default_factory=dict, description=f"any of {', '.join(PARAMETERS)}")
    criteria: CriteriaSpec = Field(default_factory=CriteriaSpec)
    correction: CorrectionSpec | None = Field(
        None, description="also the closed-loop success probability (one correction)")

    @field_validator("parameters")
    @classmethod
    def _known(cls, value: dict[str, Variation]) -> dict[str, Variation]:
        for name, variation in value.items():
            if name not in PARAMETERS:
                raise ValueError(
                    f"unknown parameter {name!r}, expected one of {', '.join(PARAMETERS)}")
            kind = distribution_of(name, variation)
            if kind == "lognormal" and name not in RELATIVE:
                raise ValueError(
                    f"{name}: a lognormal distribution needs a positive quantity; use normal or "
                    f"uniform for a signed error")
        return value

    @property
    def chunk(self) -> int:
        """Samples per task and per file: ``chunk_size``, or by default N / 16 rounded up
        within :data:`DEFAULT_CHUNKS` (a chunk of a large study is about a quarter of a second
        of one core, so a task's scheduling, transfer and file cost little; a small study still
        has up to 16 chunks to share among the workers)."""
        if self.chunk_size is not None:
            return self.chunk_size
        low, high = DEFAULT_CHUNKS
        return min(high, max(low, -(-self.samples // 16)))

    def distribution(self, name: str) -> str:
        """The distribution of a varied parameter (its default filled in)."""
        return distribution_of(name, self.parameters[name])

    def spread_si(self, name: str) -> float:
        """The spread of a varied parameter in SI: a fraction, metres or radians."""
        spread = self.parameters[name].spread
        unit = PARAMETERS[name]
        if unit == "%":
            return spread / 100.0
        if unit == "mm":
            return spread * 1e-3
        return math.radians(spread)


def distribution_of(name: str, variation: Variation) -> str:
    """The distribution named by ``variation``, or the parameter's default."""
    return variation.distribution or DEFAULT_DISTRIBUTION.get(name, "normal")


def _format(error: ValidationError, prefix: str) -> str:
    first = error.errors()[0]
    loc = ".".join(str(p) for p in (prefix, *first["loc"]) if p != "")
    message = first["msg"].removeprefix("Value error, ")
    value = first.get("input")
    shown = "" if isinstance(value, dict | list) else f" (got {value!r})"
    more = "" if len(error.errors()) == 1 else f" [and {len(error.errors()) - 1} more]"
    return f"{loc}: {message}{shown}{more}"


def parse_study(data, source: str = "study") -> StudySpec:
    """Validate a mapping (the ``study:`` section) as a :class:`StudySpec`.

    Raises
    ------
    StudyError
        One line: ``study.parameters.youngs_modulus.spread: Input should be greater than or
        equal to 0 (got -5)``.
    """
    if isinstance(data, StudySpec):
        return data
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise StudyError(f"{source}: expected a mapping, got {type(data).__name__}")
    try:
        return StudySpec.model_validate(data)
    except ValidationError as exc:
        raise StudyError(_format(exc, source)) from None
