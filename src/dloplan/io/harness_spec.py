"""The ``harness:`` section of a job file (schema version 1; lengths in the file's units, a
length left out its default in metres, :func:`dloplan.app.resolve.file_length`).

A harness file is a job file with a ``harness:`` section instead of a target
(:class:`dloplan.app.schema.HarnessScenario`): the board's two fixtures and its pegs, and the
job's settings. Forces are in N. :mod:`dloplan.app.resolve` turns it into the
:class:`~dloplan.harness.board.Board` and :class:`~dloplan.harness.job.HarnessSettings` in SI
units (docs/harness.md).
"""

from __future__ import annotations

import math

from pydantic import Field, model_validator

from ..job_model import JobModel

_Vec3 = list[float]


def _finite_list(values, size: int, name: str):
    if values is None:
        return values
    if len(values) != size or not all(math.isfinite(v) for v in values):
        raise ValueError(f"{name}: expected {size} finite numbers, got {values!r}")
    return values


class FixtureSpec(JobModel):
    """A fixture in a scenario's ``harness:`` section (lengths in file units; a length left
    out is its default in metres whatever the units)."""

    name: str | None = Field(None, min_length=1, description="named in messages and the report "
                             "(default fixture_1, fixture_2 by position)")
    position: _Vec3 = Field(..., description="cable axis at the slot bottom")
    axis: _Vec3 = Field(..., description="slot direction, pointing inward (toward the route)")
    opening: _Vec3 = Field(default_factory=lambda: [0.0, 0.0, 1.0])
    slot_width: float = Field(0.008, gt=0, allow_inf_nan=False)
    depth: float = Field(0.01, ge=0, allow_inf_nan=False, description="insertion depth")
    length: float = Field(0.015, gt=0, allow_inf_nan=False)
    wall: float = Field(0.005, ge=0, allow_inf_nan=False)

    @model_validator(mode="after")
    def _vectors(self):
        for key in ("position", "axis", "opening"):
            _finite_list(getattr(self, key), 3, key)
        return self


class PegSpec(JobModel):
    """A peg (with an optional plate) in a ``harness:`` section (lengths in file units; a
    length left out is its default in metres whatever the units)."""

    name: str | None = Field(None, min_length=1, description="named in messages and the report "
                             "(default peg, or peg_1, peg_2... where there are several)")
    base: _Vec3
    radius: float = Field(..., gt=0, allow_inf_nan=False)
    height: float = Field(..., gt=0, allow_inf_nan=False)
    plate_height: float | None = Field(None, gt=0, allow_inf_nan=False)
    plate_size: list[float] = Field(default_factory=lambda: [0.08, 0.08])
    plate_thickness: float = Field(0.003, gt=0, allow_inf_nan=False)
    side: _Vec3 = Field(default_factory=lambda: [-1.0, 0.0, 0.0],
                        description="horizontal direction to the side the cable passes")

    @model_validator(mode="after")
    def _vectors(self):
        _finite_list(self.base, 3, "base")
        _finite_list(self.side, 3, "side")
        _finite_list(self.plate_size, 2, "plate_size")
        return self


class TensionSpec(JobModel):
    """Insertion and tensioning settings (forces in N, lengths in file units; a length left
    out is its default in metres whatever the units)."""

    contact_force: float = Field(0.2, gt=0, allow_inf_nan=False,
                                 description="wanted force of the cable on the peg(s) [N]")
    min_tension: float = Field(0.01, gt=0, allow_inf_nan=False,
                               description="tension every inner link of the section reaches [N]")
    max_axial_force: float = Field(5.0, gt=0, allow_inf_nan=False,
                                   description="largest link tension allowed [N]")
    max_offset: float = Field(0.05, gt=0, allow_inf_nan=False,
                              description="largest pull-apart offset per arm")
    n_links: int | None = Field(None, ge=6, le=2000,
                                description="links of the insertion simulation (default: auto)")
    substeps: int = Field(8, ge=1, le=200, description="equilibria while inserting")
    rated_load: float | None = Field(None, gt=0, allow_inf_nan=False,
                                     description="largest tension the cable may carry [N] "
                                                 "(the checks fail above it)")


class HarnessSpec(JobModel):
    """The ``harness:`` section of a scenario: the board and the job's settings (a length
    left out is its default in metres whatever the units)."""

    fixtures: list[FixtureSpec] = Field(..., min_length=2, max_length=2)
    pegs: list[PegSpec] = Field(..., min_length=1, description="at least one: the cable is "
                                "tensioned against the pegs")
    approach_height: float = Field(0.08, gt=0, allow_inf_nan=False,
                                   description="phase 1 ends this high above the insertion pose")
    clearance: float = Field(0.005, ge=0, allow_inf_nan=False,
                             description="gap kept to the pegs by the planned shapes")
    n_shapes: list[int] = Field(default_factory=lambda: [4, 4], min_length=2, max_length=2,
                                description="intermediate shapes of phase 1 and phase 2",
                                json_schema_extra={"items": {"type": "integer", "minimum": 1,
                                                             "maximum": 500}})
    tension: TensionSpec = Field(default_factory=TensionSpec)

    @model_validator(mode="after")
    def _counts(self):
        if any(s < 1 or s > 500 for s in self.n_shapes):
            raise ValueError(f"n_shapes: got {self.n_shapes}, expected two integers in 1..500")
        return self

    @model_validator(mode="after")
    def _distinct_names(self):
        named: dict[str, str] = {}
        places = [f"fixtures[{i}]" for i in range(len(self.fixtures))] + [
            f"pegs[{i}]" for i in range(len(self.pegs))]
        for place, name in zip(places, self.fixture_names() + self.peg_names(), strict=True):
            if name in named:
                raise ValueError(f"{place}.name: {name!r} is also {named[name]}'s name; expected "
                                 "a name of its own (messages and the report name the board's "
                                 "fixtures and pegs by it)")
            named[name] = place
        return self

    def fixture_names(self) -> list[str]:
        """The fixtures' names: each one's own, else ``fixture_1``, ``fixture_2``."""
        return [f.name or f"fixture_{i + 1}" for i, f in enumerate(self.fixtures)]

    def peg_names(self) -> list[str]:
        """The pegs' names: each one's own, else ``peg`` (``peg_1``, ``peg_2``... where there
        are several)."""
        if len(self.pegs) == 1:
            return [self.pegs[0].name or "peg"]
        return [p.name or f"peg_{i + 1}" for i, p in enumerate(self.pegs)]
