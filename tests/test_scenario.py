"""Scenario files: parsing, unit conversion, parametric shapes and one-line errors."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from dloplan.app import load_scenario
from dloplan.app.resolve import resolve_scenario
from dloplan.app.schema import parse_scenario, scenario_json_schema
from dloplan.io.scenario import ScenarioError
from dloplan.physics import link_lengths, shape_length

BASE = {
    "cable": {"name": "ethernet", "n_links": 10},
    "start": {"kind": "straight", "placement": {"position": [0.1, 0.0, 0.1]}},
    "target": {"kind": "arc", "angle": 90, "placement": {"position": [0.15, 0.1, 0.1]}},
}


def with_(path: str, value):
    """BASE with the dotted ``path`` set to ``value`` (None deletes it)."""
    data = json.loads(json.dumps(BASE))
    keys = path.split(".")
    node = data
    for key in keys[:-1]:
        node = node.setdefault(key, {})
    if value is None:
        node.pop(keys[-1], None)
    else:
        node[keys[-1]] = value
    return data


def test_a_parametric_scenario_resolves_in_si_units():
    job = resolve_scenario(parse_scenario(BASE))
    assert job.cable.name == "ethernet" and job.cable.n_links == 10
    assert job.start.shape == (11, 3) and job.target.shape == (11, 3)
    assert np.allclose(link_lengths(job.target), 0.05)
    assert np.allclose(job.start[0], [0.1, 0, 0.1])


def test_millimetres_are_converted():
    data = with_("units", "mm")
    data["cable"] = {"name": "ethernet", "length": 500, "diameter": 5}
    data["start"] = {"kind": "points", "points": [[0, 0, 100], [250, 0, 100], [500, 0, 100]]}
    data["obstacles"] = [{"type": "box", "center": [300, 0, 30], "size": [100, 100, 60]}]
    job = resolve_scenario(parse_scenario(data))
    assert job.cable.length == pytest.approx(0.5) and job.cable.diameter == pytest.approx(0.005)
    assert shape_length(job.start) == pytest.approx(0.5)
    assert job.obstacles[0].top == pytest.approx(0.06)
    metres = {**data, "cable": {"name": "ethernet", "length": 0.5}}  # metres in a mm file
    with pytest.raises(ScenarioError, match=r"cable.length: got 0.5 file units \(0.0005 m\), "
                                            r"expected at least 0.02 m \(a length in metres"):
        resolve_scenario(parse_scenario(metres))
    metres["cable"] = {"name": "ethernet", "diameter": 0.005}
    with pytest.raises(ScenarioError, match="cable.diameter: got 0.005 file units"):
        resolve_scenario(parse_scenario(metres))


def test_sine_shape_has_the_cable_length():
    data = with_("target", {"kind": "sine", "amplitude": 0.05, "periods": 1.5})
    job = resolve_scenario(parse_scenario(data))
    assert shape_length(job.target) == pytest.approx(job.cable.length, rel=5e-3)


def test_yaml_and_json_files(tmp_path):
    (tmp_path / "job.json").write_text(json.dumps(BASE))
    (tmp_path / "job.yaml").write_text(
        "cable: {name: usb}\nstart: {kind: straight}\ntarget: {kind: arc, angle: 60}\n"
    )
    assert load_scenario(tmp_path / "job.json").cable.name == "ethernet"
    assert load_scenario(tmp_path / "job.yaml").cable.name == "usb"


def test_json_schema_describes_the_format():
    schema = scenario_json_schema()
    assert schema["title"] == "dloplan scenario"
    assert {"cable", "start", "target"} <= set(schema["$defs"]["Scenario"]["required"])


def test_json_schema_takes_every_kind_of_job_file_the_loader_takes():
    """A harness job (a ``harness:`` section, no ``target:``) and an identification file
    (``identify:``, no ``start:``) load, and the printed schema refused both ("'harness' was
    unexpected", "'start' is a required property"): an editor pointed at it marked every
    harness file. The schema is now the three root models' ``anyOf``; a file that mixes them
    is refused by both."""
    jsonschema = pytest.importorskip("jsonschema")
    import yaml

    from dloplan.app.identification import parse_identification
    from dloplan.app.load import resolve_mapping

    examples = Path(__file__).parents[1] / "examples"
    harness = yaml.safe_load((examples / "harness_usb.yaml").read_text())
    harness["cable"] = {"name": "ethernet", "n_links": 12}
    harness["harness"]["pegs"][0]["base"] = [0.37, 0.01, 0.0]
    identification = yaml.safe_load((examples / "identify_ethernet.yaml").read_text())
    identification["identify"]["measurement_noise"] = 0.002
    validator = jsonschema.Draft202012Validator(scenario_json_schema())
    resolve_mapping(harness, "harness")
    parse_identification(identification, "identification")
    for data in (harness, identification, BASE):
        assert validator.is_valid(data), jsonschema.exceptions.best_match(
            validator.iter_errors(data)).message
    mixed = {**harness, "target": BASE["target"]}
    assert not validator.is_valid(mixed)
    with pytest.raises(ScenarioError, match="target: Extra inputs are not permitted"):
        resolve_mapping(mixed, "mixed")


def _harness_with(path: str, value):
    """harness_usb.yaml with the dotted ``path`` set to ``value`` (digits index lists)."""
    import yaml

    data = yaml.safe_load((Path(__file__).parents[1] / "examples" / "harness_usb.yaml")
                          .read_text())
    *keys, last = [int(k) if k.isdigit() else k for k in path.split(".")]
    node = data
    for key in keys:
        node = node[key]
    node[last] = value
    return data


EDGES = [
    (_harness_with("harness.n_shapes", [0, 4]), False),
    (_harness_with("harness.n_shapes", [4, 501]), False),
    (_harness_with("harness.n_shapes", [1, 500]), True),
    (_harness_with("cable.n_links", "10"), True),
    (_harness_with("cable.n_links", 10.0), True),
    (_harness_with("cable.n_links", True), False),
    (_harness_with("cable.youngs_modulus", "2.5e6"), True),
    (_harness_with("harness.approach_height", "0.08"), True),
    (_harness_with("harness.approach_height", "ten"), False),
    (_harness_with("harness.fixtures.0.depth", True), False),
    (with_("cable.n_links", "12"), True),
    (with_("cable.n_links", "12.5"), False),
    (with_("cable.length", "1.0e-1"), True),
    (with_("trajectory.tcp_speed", True), False),
    (with_("start.placement.position", [True, 0, 0]), False),
    (with_("planner.n_shapes", "4"), True),
]


@pytest.mark.parametrize("data, valid", EDGES)
def test_the_schema_and_the_loader_agree_on_edge_values(data, valid):
    """The schema and the loader took different files: harness ``n_shapes: [0, 4]`` passed
    the schema (its items had no bounds) and the loader refused it; ``n_links: '10'`` loaded
    (pydantic converts numbers written as text, as PyYAML reads ``2.5e6``) and the schema
    refused it; ``tcp_speed: yes`` (YAML's boolean) loaded as 1 m/s. Each edge value now gets
    one answer from both (the bounds of a number written as text are the loader's alone)."""
    jsonschema = pytest.importorskip("jsonschema")
    from dloplan.app.load import resolve_mapping

    assert jsonschema.Draft202012Validator(scenario_json_schema()).is_valid(data) is valid
    if valid:
        resolve_mapping(data, "edge")
    else:
        with pytest.raises(ScenarioError):
            resolve_mapping(data, "edge")


BOOLEANS = [
    ("start.placement.rotation", {"euler": [0, 0, 1.5], "degrees": 1},
     "start.placement.rotation.degrees: Input should be a valid boolean (got 1, a number: "
     "expected true or false"),
    ("repair.placement", "yes", "repair.placement: Input should be a valid boolean (got 'yes', "
     "text: expected true or false"),
    ("robot", {"preset": "yumi", "place": "off"}, "robot.place: Input should be a valid "
     "boolean (got 'off', text"),
    ("robot", {"preset": "yumi", "place": 0.0}, "robot.place: Input should be a valid boolean"),
]


@pytest.mark.parametrize("path, value, message", BOOLEANS)
def test_a_boolean_field_takes_yaml_booleans_only(path, value, message):
    """Pydantic read the text 'yes', 'off' and the numbers 1 and 0 as booleans, so
    ``degrees: 1`` read Euler angles in degrees and ``place: 'off'`` was false by a rule no
    YAML reader shares; the schema refused them. A boolean field takes true and false (and
    YAML 1.1's unquoted yes, no, on, off, which PyYAML reads as booleans) and refuses anything
    else at its place, naming the value; schema and loader agree."""
    import yaml

    jsonschema = pytest.importorskip("jsonschema")
    data = with_(path, value)
    with pytest.raises(ScenarioError, match=re.escape(message)):
        parse_scenario(data, "job.yaml")
    assert not jsonschema.Draft202012Validator(scenario_json_schema()).is_valid(data)
    unquoted = yaml.safe_load("repair: {placement: yes}\nstart: {placement: {rotation: "
                              "{euler: [0, 0, 90], degrees: on}}}")
    assert parse_scenario({**BASE, "repair": unquoted["repair"]}).repair.placement is True
    assert unquoted["start"]["placement"]["rotation"]["degrees"] is True


BAD = [
    (with_("cable.name", "copper"), "unknown cable name 'copper'"),
    (with_("cable", {"length": 0.5}), "give diameter, mass, youngs_modulus"),
    (with_("cable.length", -0.5), "cable.length: Input should be greater than 0"),
    (with_("cable.diameter", "thin"), "cable.diameter"),
    (with_("cable.n_links", 2), "cable.n_links"),
    (with_("cable.n_links", 4.5), "cable.n_links"),
    (with_("cable.poisson_ratio", 0.7), "cable.poisson_ratio"),
    (with_("cable.youngs_modulus", "nan"), "cable.youngs_modulus"),
    (with_("cable.youngs_modulus", "identify"), "no identify section"),
    (with_("start", None), "start: Field required"),
    (with_("target.kind", "spiral"), "target"),
    (with_("target", {"kind": "points", "points": [[0, 0, 0], [1, 0, 0]]}),
     "target.points: 2 points given, need at least 3"),
    (with_("target", {"kind": "points", "points": [[0, 0, 0], [1, 0], [2, 0, 0]]}),
     "3 (x, y, z) or 2 (x, z) coordinates"),
    (with_("target", {"kind": "points", "points": [[0, 0, 0], [1, 0, float("nan")],
                                                   [2, 0, 0]]}), "finite"),
    (with_("target.placement.position", [float("nan"), 0, 0]),
     "target.placement.position: position must be finite numbers, got [nan, 0.0, 0.0]"),
    (with_("target.angle", None), "target.angle: Field required"),
    (with_("start.placement.position", [0, 0]), "start.placement.position"),
    (with_("start.placement.rotation", {"euler": [0, 0]}), "euler has 2 angles"),
    (with_("start.placement.rotation", {"quaternion": [0, 0, 0, 0]}), "zero norm"),
    (with_("obstacles", [{"type": "box", "center": [0, 0, 0]}]),
     "center and size, or min and max"),
    (with_("obstacles", [{"type": "box", "center": [0, 0, 0], "size": [0.1, -0.1, 0.1]}]),
     "size"),
    (with_("obstacles", [{"type": "sphere"}]), "obstacles.0"),
    (with_("planner.n_shapes", 0), "planner.n_shapes"),
    (with_("planner.weights", {"physical": {"bending": -1}}), "weight physical.bending"),
    (with_("planner.weights", {"geometric": {"clip": 1}}), "planner.weights"),
    (with_("trajectory.tcp_speed", 0), "trajectory.tcp_speed"),
    (with_("units", "inch"), "units"),
    (with_("colour", "red"), "colour: Extra inputs are not permitted"),
    (with_("target", {"kind": "sine", "amplitude": 0.5, "periods": 3}), "target: amplitude"),
]


@pytest.mark.parametrize("data, fragment", BAD)
def test_bad_scenarios_give_one_line_errors(data, fragment):
    with pytest.raises(ScenarioError) as info:
        resolve_scenario(parse_scenario(data))
    message = str(info.value)
    assert fragment in message
    assert "\n" not in message and message.count("got ") <= 1  # the value shown once


@pytest.mark.parametrize(
    "text, suffix, fragment",
    [
        ("- just\n- a list\n", ".yaml", "expected a mapping"),
        ("cable: [unclosed\n", ".yaml", "not valid YAML"),
        ("{bad json", ".json", "not valid JSON"),
    ],
)
def test_unreadable_files(tmp_path, text, suffix, fragment):
    path = tmp_path / f"job{suffix}"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=fragment):
        load_scenario(path)
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(tmp_path / "missing.yaml")


def test_check_defaults_are_the_thesis_lengths_whatever_the_units():
    metres = resolve_scenario(parse_scenario(BASE))
    millimetres = resolve_scenario(parse_scenario(with_("units", "mm") | {
        "cable": {"name": "ethernet", "length": 500, "diameter": 5}}))
    for job in (metres, millimetres):
        assert (job.target_threshold, job.planner.z_safety) == pytest.approx((0.01, 0.02))
        assert job.motion.tcp_speed == pytest.approx(0.1)  # 100 mm/s whatever the units
    given = resolve_scenario(parse_scenario(with_("units", "mm") | {
        "cable": {"name": "ethernet", "length": 500}, "check": {"threshold": 5}}))
    assert (given.target_threshold, given.planner.z_safety) == pytest.approx((0.005, 0.02))


FULL_METRES = {
    "cable": {"name": "pu", "n_links": 12, "length": 0.6, "diameter": 0.008,
              "rest_shape": {"kind": "arc", "angle": 40}},
    "start": {"kind": "sine", "amplitude": 0.03, "periods": 1.5,
              "placement": {"position": [0.35, -0.2, 0.15], "rotation": {"euler": [0, 0, 80]}}},
    "target": {"kind": "points", "points": [[0.3, 0.0, 0.2], [0.45, 0.1, 0.25],
                                            [0.6, 0.25, 0.22], [0.7, 0.4, 0.2]]},
    "obstacles": [{"type": "box", "center": [0.4, 0.1, 0.05], "size": [0.03, 0.3, 0.1],
                   "yaw": 10},
                  {"type": "box", "min": [0.5, -0.3, 0.0], "max": [0.55, -0.25, 0.04]},
                  {"type": "cylinder", "base": [0.6, 0.0, 0.0], "radius": 0.01, "height": 0.08}],
    "table": {"height": 0.01},
    "check": {"threshold": 0.015, "z_safety": 0.025},
    "trajectory": {"tcp_speed": 0.08, "acceleration": 0.8, "jerk": 6.0, "zone": 0.005},
    "planner": {"n_shapes": 4},
}


def _in_millimetres(data):
    """FULL_METRES with every length in mm (angles, counts and moduli unchanged)."""
    lengths = {"length", "diameter", "amplitude", "position", "points", "center", "size", "min",
               "max", "base", "radius", "height", "threshold", "z_safety", "tcp_speed",
               "acceleration", "jerk", "zone", "approach"}

    def convert(key, value):
        if isinstance(value, dict):
            return {k: convert(k, v) for k, v in value.items()}
        if isinstance(value, list) and value and isinstance(value[0], dict):
            return [convert(key, v) for v in value]
        if key in lengths:
            return np.multiply(value, 1e3).tolist()
        return value

    return {"units": "mm", **{k: convert(k, v) for k, v in data.items()}}


def test_a_scenario_in_metres_and_millimetres_resolves_to_the_same_job():
    metres = resolve_scenario(parse_scenario(FULL_METRES))
    millimetres = resolve_scenario(parse_scenario(_in_millimetres(FULL_METRES)))
    close = {"rtol": 1e-12, "atol": 1e-15}
    assert metres.cable.constants() == pytest.approx(millimetres.cable.constants(), rel=1e-12)
    assert np.allclose(metres.cable.rest_shape, millimetres.cable.rest_shape, **close)
    for name in ("start", "target"):
        assert np.allclose(getattr(metres, name), getattr(millimetres, name), **close)
    assert len(metres.obstacles) == len(millimetres.obstacles) == 4
    for a, b in zip(metres.obstacles, millimetres.obstacles, strict=True):
        assert type(a) is type(b)
        for key, value in vars(a).items():
            if isinstance(value, str):
                assert value == getattr(b, key)
            else:
                assert np.allclose(value, getattr(b, key), **close), key
    assert metres.target_threshold == pytest.approx(millimetres.target_threshold, rel=1e-12)
    assert metres.planner == millimetres.planner
    assert vars(metres.motion.limits) == pytest.approx(vars(millimetres.motion.limits),
                                                       rel=1e-12)
    for key in ("zone", "grasp_time", "release_time", "rate"):
        assert getattr(metres.motion, key) == pytest.approx(getattr(millimetres.motion, key),
                                                            rel=1e-12), key
    assert metres.motion.tcp_speed == pytest.approx(0.08, rel=1e-12)
