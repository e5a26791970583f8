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


NUMBER_TEXT = {"integer": r"^\s*[+-]?[0-9][0-9_]*(\.0*)?\s*$",
               "number": r"^\s*[+-]?([0-9][0-9_]*\.?[0-9_]*|\.[0-9][0-9_]*)([eE][+-]?[0-9]+)?\s*$"}
"""Patterns of the text the loader reads as an integer or a finite number (pydantic's lax
conversion; PyYAML reads YAML 1.1, where ``1.0e7`` is text)."""


def _numbers_as_text(node):
    """``node`` with every integer or number schema also taking the text the loader reads as
    one (:data:`NUMBER_TEXT`; the bounds are the number's, which a validator cannot apply to
    text)."""
    if isinstance(node, list):
        return [_numbers_as_text(item) for item in node]
    if not isinstance(node, dict):
        return node
    node = {key: _numbers_as_text(value) for key, value in node.items()}
    kind = node.get("type")
    if not isinstance(kind, str) or kind not in NUMBER_TEXT:
        return node
    outer = {key: node.pop(key) for key in ("title", "description", "default") if key in node}
    return {**outer, "anyOf": [node, {"type": "string", "pattern": NUMBER_TEXT[kind]}]}


def scenario_json_schema() -> dict:
    """The JSON Schema of the job files :func:`dloplan.app.load_job` reads: a scenario
    (:class:`Scenario`), a wire-harness job (:class:`HarnessScenario`: a ``harness:`` section,
    no ``target:``) or an identification file
    (:class:`~dloplan.app.identification.IdentificationFile`: ``identify:`` without
    ``start:``), the root's ``anyOf`` of the three (each closed to other keys, so a file is one
    of them). A number may be written as text, as the loader reads it (:func:`_numbers_as_text`).

    Returns
    -------
    dict
        A draft 2020-12 schema titled "dloplan scenario"; the root models under ``$defs``.
    """
    from pydantic import TypeAdapter

    from .identification import IdentificationFile  # numpy and the identification's modules

    schema = _numbers_as_text(
        TypeAdapter(Scenario | HarnessScenario | IdentificationFile).json_schema())
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "dloplan scenario"
    schema["description"] = ("a dloplan job file: a scenario (start to target), a wire-harness "
                             "job (a harness section, no target) or an identification "
                             "experiment (an identify section, no start)")
    return schema
