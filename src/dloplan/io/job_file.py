"""Reading a job file into a mapping, before any of its models: a light module (yaml, no
numpy or pydantic), so that the command can look at a job's ``outputs`` before it imports the
planner (:func:`draws_figures`: the figure workers' server is started only for a job that
draws; :func:`dloplan.cli.main`'s ``plan``).

:func:`read_mapping` and :class:`ScenarioError` are re-exported by :mod:`dloplan.io.scenario`,
whose models validate the mapping.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import yaml

from ..bounds import MAX_INPUT_BYTES
from ..inputs import parse_json, parse_yaml, read_text

FIGURE_OUTPUTS = frozenset({"figures", "report"})
"""The outputs that draw a plan's figures (the report shows them)."""

SVG_OUTPUT = "svg"
"""The output that asks for the figures' SVG copies beside their PNGs (``--svg``); it draws
nothing by itself: a job lists it with ``figures`` or ``report``."""


class ScenarioError(ValueError):
    """A scenario that cannot be used; the message is one line naming the field."""


def draws_figures(outputs: Iterable[str]) -> bool:
    """Whether a job with these ``outputs`` draws its plan's figures (:data:`FIGURE_OUTPUTS`)."""
    return not FIGURE_OUTPUTS.isdisjoint(outputs)


def svg_copies(outputs: Iterable[str]) -> bool:
    """Whether a job with these ``outputs`` writes its figures as SVG too (:data:`SVG_OUTPUT`).

    Raises
    ------
    ScenarioError
        ``svg`` listed without an output that draws the figures (:data:`FIGURE_OUTPUTS`).
    """
    outputs = list(outputs)
    if SVG_OUTPUT not in outputs:
        return False
    if not draws_figures(outputs):
        raise ScenarioError("outputs: 'svg' writes the figures as SVG too, and no figure is "
                            "drawn: list 'figures' (or 'report') with it")
    return True


def may_draw_figures(data) -> bool:
    """Whether a job file's mapping, not validated yet, may draw figures: ``False`` only when
    it lists its ``outputs`` (names) and :func:`draws_figures` says no; a file without
    ``outputs:`` writes the default outputs, figures among them (:mod:`dloplan.app.schema`)."""
    outputs = data.get("outputs") if isinstance(data, dict) else None
    if not isinstance(outputs, list) or not all(isinstance(name, str) for name in outputs):
        return True
    return draws_figures(outputs)


MAX_FILE_BYTES = MAX_INPUT_BYTES
"""Largest job file read [bytes] (:data:`dloplan.bounds.MAX_INPUT_BYTES`)."""

MAX_VALUES = 5_000_000
"""Most values (numbers, strings, lists, mappings) a job file may hold once its YAML aliases are
expanded: a 10 MB file of plain numbers holds at most about this many; a few lines of nested
aliases would otherwise expand to billions (the "billion laughs")."""


def expanded_size(data) -> int:
    """The number of values in ``data`` with every shared list or mapping counted as often as
    it is referenced (what validating it would visit), in time linear in the distinct ones."""
    sizes: dict[int, int] = {}

    def size(node) -> int:
        if not isinstance(node, dict | list):
            return 1
        key = id(node)
        if key not in sizes:
            sizes[key] = 0  # a cycle (YAML allows them) counts once
            items = node.values() if isinstance(node, dict) else node
            sizes[key] = 1 + sum(size(item) for item in items)
        return sizes[key]

    try:
        return size(data)
    except RecursionError:
        return MAX_VALUES + 1


def read_mapping(path: str | Path) -> dict:
    """Read a YAML or JSON file into a mapping; one-line errors for unreadable files (a regular
    text file of at most :data:`MAX_FILE_BYTES`, :func:`dloplan.inputs.read_text`)."""
    path = Path(path)
    try:
        text = read_text(path, MAX_FILE_BYTES, "job file", " (thin out its points: shapes "
                         "are resampled to n + 1 points anyway)")
    except ValueError as exc:
        raise ScenarioError(str(exc)) from None
    try:
        data = parse_json(text) if path.suffix.lower() == ".json" else parse_yaml(text)
    except (ValueError, yaml.YAMLError) as exc:  # ValueError: JSONDecodeError, a key twice
        detail = str(exc).splitlines()[0]
        kind = "JSON" if path.suffix.lower() == ".json" else "YAML"
        raise ScenarioError(f"{path}: not valid {kind}: {detail}") from None
    except RecursionError:
        raise ScenarioError(f"{path}: nested too deeply to be a job file") from None
    values = expanded_size(data)
    if values > MAX_VALUES:
        raise ScenarioError(f"{path}: expands to {values:.3g} values (YAML aliases repeat what "
                            f"they name), more than the {MAX_VALUES:.0e} a job file may hold")
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: expected a mapping at the top level, got "
                            f"{type(data).__name__}")
    return data
