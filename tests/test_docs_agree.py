"""The documentation says what the command does: its commands, options, formats and limits in
README.md and docs/ are read and held against the argument parser (``dloplan.cli``), the writers'
registry, the scenario's JSON Schema (``dloplan schema``) and the bounds (``dloplan.bounds``).
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from dloplan import bounds
from dloplan.cli import build_parser
from dloplan.exit_codes import EXIT_CHECK_FAILED, EXIT_FAILURE, EXIT_OK, EXIT_WARNINGS

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


COMMANDS = _subparsers(build_parser())


def _options(command: str) -> dict[str, argparse.Action]:
    return {flag: action for action in COMMANDS[command]._actions
            for flag in action.option_strings}


def _command_spans() -> list[tuple[Path, str]]:
    """Every inline code span of the docs that is a dloplan command line."""
    spans = []
    for path in DOCS:
        for span in re.findall(r"`(dloplan [^`]+)`", path.read_text()):
            spans.append((path, span.replace("\\|", "|")))
    return spans


def _schema() -> dict:
    import contextlib
    import io
    import json

    from dloplan.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["schema"]) == EXIT_OK
    return json.loads(out.getvalue())


def _property(schema: dict, dotted: str) -> dict:
    """The JSON Schema of a dotted field (``cable.n_links``), through $refs and unions."""
    node = schema
    for key in dotted.split("."):
        node = _resolve(schema, node)
        node = node["properties"][key]
    return _resolve(schema, node)


def _resolve(schema: dict, node: dict) -> dict:
    while True:
        if "$ref" in node:
            node = schema["$defs"][node["$ref"].rsplit("/", 1)[1]]
        elif "anyOf" in node:
            node = next(n for n in node["anyOf"] if n.get("type") != "null")
        else:
            return node


def test_every_command_is_documented_in_the_command_tables():
    table = (ROOT / "docs" / "scenario.md").read_text()
    for command in COMMANDS:
        assert f"`dloplan {command}" in table or f"`dloplan {command}`" in table, command


@pytest.mark.parametrize("path, span", _command_spans(), ids=lambda v: str(v)[:60])
def test_every_option_a_doc_names_exists(path, span):
    words = span.split()
    command = words[1]
    if command not in COMMANDS:  # `dloplan calibrate` / `register` / ... lists
        assert command.rstrip("`,") in COMMANDS or command.startswith("--"), (path, span)
        return
    options = _options(command)
    for flag in re.findall(r"(?<![\w-])(--?[a-z][a-z-]*)", " ".join(words[2:])):
        assert flag in options, f"{path.name}: `{span}` names {flag}, not an option of {command}"


def test_a_documented_format_list_names_every_export_format():
    """Every format a doc lists is one; the command tables (README, docs/scenario.md) list all."""
    choices = set(_options("export")["--format"].choices)
    tables = {"README.md", "scenario.md"}
    found = set()
    for path, span in _command_spans():
        listed = re.search(r"--format ([\w|]+)", span)
        if span.startswith("dloplan export") and listed:
            names = set(listed.group(1).split("|"))
            assert names <= choices, (path.name, span)
            if path.name in tables and len(names) > 1:
                assert names == choices, (path.name, span)
                found.add(path.name)
    assert found == tables


def test_export_help_lists_every_format_and_every_writer_is_exportable():
    from dloplan.app.writers import WRITERS

    export = COMMANDS["export"]
    choices = set(_options("export")["--format"].choices)
    # figures go with the report; a correction is written by dloplan correct
    assert choices == set(WRITERS) - {"figures", "correction"}
    for name in choices:  # in the description, not only in the usage's list of choices
        assert re.search(rf"\b{name}\b", export.description), name


def test_the_schema_and_the_docs_give_the_bounds_of_the_code():
    schema = _schema()
    links = _property(schema, "cable.n_links")
    assert (links["minimum"], links["maximum"]) == (bounds.MIN_LINKS, bounds.MAX_LINKS)
    shapes = _property(schema, "planner.n_shapes")
    assert shapes["maximum"] == bounds.MAX_SHAPES
    text = (ROOT / "docs" / "scenario.md").read_text()
    for low, high in re.findall(r"n_links: \d+ +# n \((\d+)\.\.(\d+)\)", text):
        assert (int(low), int(high)) == (bounds.MIN_LINKS, bounds.MAX_LINKS)


def _number(text: str) -> float:
    text = text.strip()
    scale = 1e6 if text.endswith(" MB") else 1.0
    return float(text.removesuffix(" MB")) * scale


def test_the_limits_table_of_docs_scenario_md_is_the_code():
    from dloplan.io.job_file import MAX_VALUES

    known = {name: getattr(bounds, name) for name in dir(bounds) if name.isupper()}
    known["MAX_VALUES"] = MAX_VALUES
    text = (ROOT / "docs" / "scenario.md").read_text()
    section = text.split("### Limits", 1)[1].split("\n### ", 1)[0]
    table = [line for line in section.splitlines() if line.startswith("|")]
    rows = [line.split("|")[1:-1] for line in table[2:]]
    assert len(rows) >= 10
    named = set()
    for _, limit, _ in rows:
        names = re.findall(r"`([A-Z_]+)`", limit)
        value = limit.split("(`")[0].strip()
        numbers = [_number(v) for v in value.split("..")]
        assert names and len(names) <= len(numbers), limit
        for name, number in zip(names[::-1], numbers[::-1], strict=False):
            assert known[name] == number, (limit, name, known[name])
            named.add(name)
    assert named >= {"MAX_INPUT_BYTES", "MAX_PLAN_BYTES", "MAX_LINKS", "MIN_LINKS",
                     "MAX_SHAPES", "MAX_TRAJECTORY_SAMPLES", "MAX_WORKERS"}


def test_the_exit_codes_the_docs_give():
    for path in (ROOT / "README.md", ROOT / "docs" / "scenario.md"):
        text = re.sub(r"\s+", " ", path.read_text())
        for code in (EXIT_OK, EXIT_WARNINGS, EXIT_FAILURE, EXIT_CHECK_FAILED, 130, 143, 129):
            assert re.search(rf"\b{code}\b", text), (path.name, code)


def test_the_outputs_the_format_block_lists_are_the_schemas():
    schema = _schema()
    outputs = _property(schema, "outputs")
    allowed = set(_resolve(schema, outputs["items"])["enum"])
    text = (ROOT / "docs" / "scenario.md").read_text()
    listed = re.search(r"^outputs: \[([^\]]+)\]", text, re.M).group(1)
    assert {v.strip() for v in listed.split(",")} == allowed
