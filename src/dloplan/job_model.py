"""The base of every pydantic model a job file is read with (the scenario's sections, the
harness section, the identification file, the study section).

Closed to other keys and frozen. A number may be written as text (PyYAML reads YAML 1.1, where
``1.0e7`` is text, and pydantic converts it; the schema takes numbers as text too,
:func:`dloplan.app.schema.scenario_json_schema`), but a boolean is not a number: pydantic would
read ``true`` (and YAML's ``yes`` and ``on``) as 1, so ``tcp_speed: yes`` was 1 m/s. A field
that takes numbers and no boolean refuses one at its place, naming the value.

The other way round, a boolean field takes YAML's booleans only (``true``/``false``, and
YAML 1.1's ``yes``/``no``/``on``/``off`` unquoted, which PyYAML reads as booleans): pydantic
would read the text ``'yes'``, ``'0'`` or ``'off'`` and the numbers 1 and 0 as booleans, so
``degrees: 1`` read Euler angles in degrees and ``place: 'no'`` was false by a rule no YAML
reader shares. Such a value is refused at its place, naming it.
"""

from __future__ import annotations

import typing

from pydantic import BaseModel, ConfigDict, model_validator


def _mentions(annotation, types: tuple[type, ...]) -> bool:
    """Whether ``annotation`` is one of ``types`` or has one among its type arguments."""
    if annotation in types:
        return True
    return any(_mentions(arg, types) for arg in typing.get_args(annotation))


class NotANumber:
    """A boolean given where a number is expected, as the field's validation sees it: not a
    number, so pydantic refuses it at the field's own place ("cable.n_links: Input should be a
    valid integer (got True, a boolean: ...)")."""

    def __init__(self, value: bool):
        self.value = value

    def __repr__(self) -> str:
        return f"{self.value}, a boolean: YAML reads true, yes and on as booleans"


class NotABoolean:
    """A value other than a boolean given where a boolean is expected, as the field's
    validation sees it: not a boolean, so pydantic refuses it at the field's own place
    ("robot.place: Input should be a valid boolean (got 'yes', text: ...)")."""

    def __init__(self, value):
        self.value = value

    def __repr__(self) -> str:
        kind = "text" if isinstance(self.value, str) else "a number"
        return f"{self.value!r}, {kind}: expected true or false, unquoted"


def _numbers_only(value):
    """``value`` with every boolean in it (in lists and tuples, at any depth) a
    :class:`NotANumber`."""
    if isinstance(value, bool):
        return NotANumber(value)
    if isinstance(value, list | tuple):
        return [_numbers_only(v) for v in value]
    return value


class JobModel(BaseModel):
    """A model of a job file's section (module docstring)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    @model_validator(mode="before")
    @classmethod
    def _no_boolean_numbers(cls, data):
        if not isinstance(data, dict):
            return data
        numeric, boolean = set(), set()
        for key, field in cls.model_fields.items():
            if not _mentions(field.annotation, (bool,)):
                numeric |= {key} if _mentions(field.annotation, (int, float)) else set()
            elif not _mentions(field.annotation, (int, float, str)):
                boolean.add(key)
        return {key: _numbers_only(value) if key in numeric
                else NotABoolean(value) if key in boolean and isinstance(value, str | int | float)
                and not isinstance(value, bool) else value
                for key, value in data.items()}


__all__ = ["JobModel"]
