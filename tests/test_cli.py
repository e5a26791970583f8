"""The dloplan command: exit codes, one-line errors, machine-readable output."""

from __future__ import annotations

import json

import pytest
import yaml

from dloplan.cli import EXIT_FAILURE, EXIT_OK, EXIT_WARNINGS, main

STIFF = {
    "cable": {"name": "pa12", "n_links": 10},
    "start": {"kind": "straight", "placement": {"position": [0.3, -0.25, 0.2]}},
    "target": {"kind": "arc", "angle": 60, "placement": {"position": [0.3, -0.2, 0.25]}},
}


def write(tmp_path, data, name="job.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def test_check_passes_a_stable_job(tmp_path, capsys):
    code = main(["check", str(write(tmp_path, STIFF)), "-q"])
    out = capsys.readouterr().out
    assert code == EXIT_OK, out
    assert "target stability" in out


def test_check_warns_on_an_unstable_target_and_reports_json(tmp_path, capsys):
    soft = {**STIFF, "cable": {"name": "usb", "n_links": 10}}
    code = main(["check", str(write(tmp_path, soft)), "-q", "--json"])
    summary = json.loads(capsys.readouterr().out)
    assert code == EXIT_WARNINGS
    assert summary["warnings"] == 1 and summary["errors"] == 0


def test_check_fails_when_the_target_sits_in_an_obstacle(tmp_path, capsys):
    data = {**STIFF, "obstacles": [{"type": "box", "center": [0.45, -0.15, 0.2],
                                    "size": [0.4, 0.4, 0.4]}]}
    code = main(["check", str(write(tmp_path, data)), "-q"])
    out = capsys.readouterr().out
    assert code == EXIT_FAILURE
    assert "ERROR" in out and "collides" in out


@pytest.mark.parametrize(
    "content, fragment",
    [
        ("[1, 2]", "expected a mapping"),
        ("cable: {name: copper}\nstart: {kind: straight}\ntarget: {kind: straight}", "copper"),
    ],
)
def test_bad_scenarios_exit_2_with_one_line(tmp_path, capsys, content, fragment):
    path = tmp_path / "bad.yaml"
    path.write_text(content)
    assert main(["check", str(path)]) == EXIT_FAILURE
    err = capsys.readouterr().err.strip()
    assert fragment in err and len(err.splitlines()) == 1


def test_schema_and_cables(capsys):
    assert main(["schema"]) == EXIT_OK
    assert json.loads(capsys.readouterr().out)["title"] == "dloplan scenario"
    assert main(["cables"]) == EXIT_OK
    assert "k_b [N m]" in capsys.readouterr().out
