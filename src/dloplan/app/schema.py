"""The job files' root models: a scenario (start to target) and a harness job (a board).

Both are :class:`~dloplan.io.scenario.JobSpec` (units, cable, start, planner, obstacles,
table, grippers, trajectory, check, robot) with their own sections: a scenario its target, an
identification or a study to run first or around it, its outputs and what its repair may
change; a harness job its board (:class:`~dloplan.io.harness_spec.HarnessSpec`). They live in
the application, not in :mod:`dloplan.io`, because their sections come from packages above it
(a scenario's ``study:`` is :class:`dloplan.study.spec.StudySpec`).

The JSON Schema of the job files (for editor completion: a scenario, a harness job or an
identification file) is :func:`scenario_json_schema`, printed by ``dloplan schema``.
"""

from __future__ import annotations

from typing import Any

from pydantic import Field, model_validator

from ..io.harness_spec import HarnessSpec
from ..io.scenario import (
    JobSpec,
    OutputName,
    RepairSpec,
    ShapeSpec,
    TableSpec,
    parse_model,
)
from ..study.spec import StudySpec

DEFAULT_OUTPUTS = ("json", "csv", "rapid", "figures", "report")
"""What ``dloplan plan`` writes when a job file has no ``outputs:``."""


class Scenario(JobSpec):
    """A dloplan job (schema version 1): from ``start`` to ``target``."""

    target: ShapeSpec
    identify: dict[str, Any] | None = Field(
        None, description="an identification experiment (see docs/identification.md)"
    )
    study: StudySpec | None = Field(
        None, description="a robustness study of the plan (see docs/study.md)"
    )
    outputs: list[OutputName] = Field(default_factory=lambda: list(DEFAULT_OUTPUTS))
    repair: RepairSpec = Field(default_factory=RepairSpec)

    @model_validator(mode="after")
    def _identify(self):
        if self.cable.youngs_modulus == "identify" and self.identify is None:
            raise ValueError("cable.youngs_modulus is 'identify' but there is no identify section")
        return self


class HarnessScenario(JobSpec):
    """A harness job file (schema version 1): the job's common sections and a board; the
    target follows from the board (docs/harness.md)."""

    harness: HarnessSpec
    table: TableSpec = Field(default_factory=TableSpec)
    outputs: list[OutputName] = Field(default_factory=lambda: list(DEFAULT_OUTPUTS))


def parse_scenario(data: Any, source: str = "scenario") -> Scenario:
    """Validate a mapping as a :class:`Scenario`; raises
    :class:`~dloplan.io.scenario.ScenarioError` (one line)."""
    return parse_model(Scenario, data, source)


def parse_harness(data: Any, source: str = "harness scenario") -> HarnessScenario:
    """Validate a mapping as a :class:`HarnessScenario`; raises
    :class:`~dloplan.io.scenario.ScenarioError` (one line)."""
    return parse_model(HarnessScenario, data, source)


def scenario_json_schema() -> dict:
    """The JSON Schema of the job files :func:`dloplan.app.load_job` reads: a scenario
    (:class:`Scenario`), a wire-harness job (:class:`HarnessScenario`: a ``harness:`` section,
    no ``target:``) or an identification file
    (:class:`~dloplan.app.identification.IdentificationFile`: ``identify:`` without
    ``start:``), the root's ``anyOf`` of the three (each closed to other keys, so a file is one
    of them).

    Returns
    -------
    dict
        A draft 2020-12 schema titled "dloplan scenario"; the root models under ``$defs``.
    """
    from pydantic import TypeAdapter

    from .identification import IdentificationFile  # numpy and the identification's modules

    schema = TypeAdapter(Scenario | HarnessScenario | IdentificationFile).json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "dloplan scenario"
    schema["description"] = ("a dloplan job file: a scenario (start to target), a wire-harness "
                             "job (a harness section, no target) or an identification "
                             "experiment (an identify section, no start)")
    return schema
