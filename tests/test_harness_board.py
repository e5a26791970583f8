"""Harness boards: validation before planning, the harness: section and its loader."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from harness_boards import DIAGONAL, demo_board, demo_start

from dloplan.app import load_job
from dloplan.app.load import file_kind
from dloplan.cable import catalogue_cable
from dloplan.harness import (
    Board,
    Fixture,
    HarnessSettings,
    Peg,
    check_board,
    route_length,
    run_harness,
)
from dloplan.io.scenario import ScenarioError

EXAMPLES = Path(__file__).parent.parent / "examples"


@pytest.fixture
def no_planning(monkeypatch):
    """Fail the test if the planner is called: errors must come before planning."""
    import dloplan.harness.phases as phases

    def forbidden(*args, **kwargs):
        raise AssertionError("the planner was called")

    monkeypatch.setattr(phases, "plan", forbidden)


def test_a_fixture_out_of_reach_is_an_error_before_planning(no_planning):
    cable = catalogue_cable("usb", n_links=10)
    # clip points 0.46 m apart; the cable spans L - l = 0.45 m between its clip points
    board = demo_board(cable, fixture_y=0.23)
    with pytest.raises(ValueError, match=r"fixtures: .* 0\.46 m apart, out of reach of the "
                                         r"0\.5 m cable .* 0\.45 m"):
        run_harness(cable, demo_start(cable), board, HarnessSettings(n_shapes=(3, 3)))


def test_a_route_around_the_pegs_longer_than_the_cable_is_an_error(no_planning):
    cable = catalogue_cable("usb", n_links=10)
    board = demo_board(cable, peg_x=0.22)  # the loop would have to reach 28 cm toward the robot
    assert route_length(board, cable) > cable.length - cable.rest_link_length
    with pytest.raises(ValueError, match="pegs: the route from fixture_right around peg"):
        run_harness(cable, demo_start(cable), board)


def test_route_length_is_the_polyline_around_the_pegs():
    cable = catalogue_cable("usb", n_links=10)
    board = demo_board(cable)
    via_x = 0.38 - 0.012 - cable.diameter / 2
    expected = 2 * np.hypot(0.50 - via_x, 0.15)
    assert route_length(board, cable) == pytest.approx(expected, rel=1e-12)


def test_a_peg_overlapping_a_fixture_is_an_error(no_planning):
    cable = catalogue_cable("usb", n_links=10)
    board = demo_board(cable)
    peg = Peg((0.505, -0.16, 0.0), 0.012, 0.06, name="peg_in_slot")
    crowded = Board(board.fixtures, (peg,), board.obstacles, board.table)
    with pytest.raises(ValueError, match="peg_in_slot: overlaps fixture_right"):
        run_harness(cable, demo_start(cable), crowded)


def test_a_slot_narrower_than_the_cable_is_an_error():
    cable = catalogue_cable("pu", n_links=10)  # 6 mm
    board = demo_board(cable)
    narrow = Fixture(board.fixtures[0].position, board.fixtures[0].axis, slot_width=0.005,
                     name="narrow")
    with pytest.raises(ValueError, match=r"narrow.slot_width: 5.00 mm is narrower than the "
                                         r"cable \(6.00 mm"):
        check_board(Board((narrow, board.fixtures[1]), board.pegs), cable)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"plate_height": 0.07}, "plate_height: got 0.07 m, expected below the peg's top"),
        ({"radius": -0.01}, "peg.radius: got -0.01, expected a length > 0"),
        ({"side": (0.0, 0.0, 1.0)}, r"peg.side \(horizontal part\)"),
        ({"plate_height": 0.03, "plate_size": (0.02, 0.1)}, "does not extend beyond the peg"),
    ],
)
def test_bad_peg_dimensions_are_named(kwargs, match):
    args = {"base": (0.4, 0.0, 0.0), "radius": 0.012, "height": 0.06} | kwargs
    with pytest.raises(ValueError, match=match):
        Peg(**args)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"axis": (0, 0, 0)}, "fixture.axis: got .* expected a non-zero direction"),
        ({"opening": (1.0, 0.0, 0.3)}, "fixture.opening: .* expected perpendicular"),
        ({"depth": -0.01}, "fixture.depth: got -0.01, expected a length >= 0"),
        ({"position": (0.5, np.nan, 0.0)}, "fixture.position"),
    ],
)
def test_bad_fixtures_are_named(kwargs, match):
    args = {"position": (0.5, 0.0, 0.03), "axis": (1.0, 0.0, 0.0)} | kwargs
    with pytest.raises(ValueError, match=match):
        Fixture(**args)


def test_fixture_frame_is_normalized_and_the_approach_is_out_of_the_slot():
    f = Fixture((0.5, 0.1, 0.03), (-2.0, 2.0, 0.0), opening=(0.01, 0.0, 2.0), depth=0.012)
    assert np.linalg.norm(f.axis) == pytest.approx(1.0, abs=1e-15)
    assert np.dot(f.axis, f.opening) == pytest.approx(0.0, abs=1e-15)
    assert np.allclose(f.axis, [-DIAGONAL, DIAGONAL, 0.0])
    assert np.linalg.norm(f.approach - np.asarray(f.position)) == pytest.approx(0.012)


def test_the_examples_are_harness_files_and_load():
    for name in ("usb", "ethernet", "pu"):
        path = EXAMPLES / f"harness_{name}.yaml"
        assert file_kind(yaml.safe_load(path.read_text())) == "harness"
        job = load_job(path)
        assert job.cable.name == name
        assert len(job.board.pegs) == 1 and len(job.board.obstacles) == 1
        assert job.settings.n_shapes == (4, 4)
    moduli = [load_job(EXAMPLES / f"harness_{c}.yaml").cable.youngs_modulus
              for c in ("usb", "ethernet", "pu")]
    assert moduli == [2.5e6, 7.5e6, 1e8]  # thesis Table 7.3
    assert file_kind(yaml.safe_load((EXAMPLES / "harness_phase1_obstacle.yaml").read_text())) \
        == "scenario"


def test_a_harness_file_resolves_once_into_a_frozen_job_with_its_cell(tmp_path):
    """The harness job keeps no file model (nothing of pydantic) into plan time: its robot cell
    (base position in the file's units, converted) and its outputs are resolved at load, and
    the job is frozen."""
    import dataclasses

    from pydantic import BaseModel

    from dloplan.pipeline import HarnessJob

    def placed(data):
        data["units"] = "m"
        data["robot"] = {"base_position": [0.0, 0.02, 0.0]}
        data["outputs"] = ["json"]

    job = load_job(_example(tmp_path, placed))
    assert isinstance(job, HarnessJob)
    values = [getattr(job, f.name) for f in dataclasses.fields(job)]
    assert not any(isinstance(v, BaseModel) for v in values)
    assert not any(isinstance(v, BaseModel) for v in dataclasses.asdict(job.settings).values())
    assert np.allclose(job.robot.base_position, [0.0, 0.02, 0.0])
    assert job.outputs == ("json",)
    with pytest.raises(dataclasses.FrozenInstanceError):
        job.outputs = ("json", "rapid")


def _example(tmp_path, edit) -> Path:
    data = yaml.safe_load((EXAMPLES / "harness_usb.yaml").read_text())
    edit(data)
    path = tmp_path / "job.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_harness_file_errors_are_one_line_and_name_the_field(tmp_path):
    def far(data):
        data["harness"]["fixtures"][1]["position"] = [0.5, 0.40, 0.03]

    with pytest.raises(ScenarioError, match=r"harness: fixtures: .* out of reach") as info:
        load_job(_example(tmp_path, far))
    assert "\n" not in str(info.value)

    def one_fixture(data):
        data["harness"]["fixtures"] = data["harness"]["fixtures"][:1]

    with pytest.raises(ScenarioError, match="harness.fixtures: List should have at least 2"):
        load_job(_example(tmp_path, one_fixture))

    def typo(data):
        data["harness"]["pegs"][0]["radious"] = 0.01

    with pytest.raises(ScenarioError, match="harness.pegs.0.radious: Extra inputs"):
        load_job(_example(tmp_path, typo))


def test_a_harness_file_without_pegs_is_refused_when_loaded_so_check_refuses_it(tmp_path,
                                                                               capsys):
    """A board without pegs loaded, ``dloplan check`` said "ok board ..." (exit 0) and
    ``dloplan plan`` refused it after loading ("board: no pegs; a harness job tensions the
    cable against pegs"). The file's model requires a peg: the loader, the check, the plan and
    the JSON Schema (``minItems``) refuse it alike, naming the field."""
    from dloplan.app.schema import scenario_json_schema
    from dloplan.cli import main

    def no_pegs(data):
        data["harness"]["pegs"] = []

    def pegs_left_out(data):
        del data["harness"]["pegs"]

    for edit, fragment in ((no_pegs, "harness.pegs: List should have at least 1 item"),
                           (pegs_left_out, "harness.pegs: Field required")):
        path = _example(tmp_path, edit)
        with pytest.raises(ScenarioError, match=fragment):
            load_job(path)
        assert main(["check", str(path), "-q"]) == 2
        assert fragment in capsys.readouterr().err
    assert scenario_json_schema()["$defs"]["HarnessSpec"]["properties"]["pegs"]["minItems"] == 1


def test_a_name_two_parts_of_the_board_share_is_refused_and_left_out_names_are_numbered(
        tmp_path, capsys):
    """Two fixtures named alike were planned (exit 0, unseen-case sweep round 2, left there)
    while every message and the report name the board's parts by their names; the loader
    refuses a name two parts share, naming both fields. Names left out are numbered by
    position, so a board whose parts are all unnamed still loads, with distinct names."""
    from dloplan.cli import main

    def twins(data):
        data["harness"]["fixtures"][1]["name"] = data["harness"]["fixtures"][0]["name"]

    def peg_as_a_default_fixture(data):
        for fixture in data["harness"]["fixtures"]:
            del fixture["name"]
        data["harness"]["pegs"][0]["name"] = "fixture_2"

    for edit, fragment in ((twins, "harness: fixtures[1].name: 'fixture_right' is also "
                                   "fixtures[0]'s name"),
                           (peg_as_a_default_fixture, "harness: pegs[0].name: 'fixture_2' is "
                                                      "also fixtures[1]'s name")):
        path = _example(tmp_path, edit)
        with pytest.raises(ScenarioError, match=re.escape(fragment)):
            load_job(path)
        assert main(["check", str(path), "-q"]) == 2
        assert fragment in capsys.readouterr().err

    def unnamed(data):
        for part in data["harness"]["fixtures"] + data["harness"]["pegs"]:
            del part["name"]

    board = load_job(_example(tmp_path, unnamed)).board
    assert [f.name for f in board.fixtures] == ["fixture_1", "fixture_2"]
    assert [p.name for p in board.pegs] == ["peg"]


def test_the_rated_load_is_read_in_newtons_and_a_bad_one_is_named(tmp_path):
    def rated(value):
        def edit(data):
            data["harness"]["tension"]["rated_load"] = value
        return edit

    assert load_job(_example(tmp_path, rated(2.5))).settings.rated_load == 2.5
    assert load_job(EXAMPLES / "harness_usb.yaml").settings.rated_load is None
    with pytest.raises(ScenarioError, match="harness.tension.rated_load: Input should be greater"):
        load_job(_example(tmp_path, rated(-1.0)))


def test_a_board_goes_through_the_plan_document_unchanged():
    """board_to_dict and board_from_dict (with the document's obstacle volumes) give the board
    back: the fixtures and pegs field by field, the wall and the table."""
    from dloplan.harness.board import board_from_dict, board_to_dict

    board = load_job(EXAMPLES / "harness_pu.yaml").board
    again = board_from_dict(json.loads(json.dumps(board_to_dict(board))), board.contacts())
    assert again.fixtures == board.fixtures and again.pegs == board.pegs
    assert again.obstacles == board.obstacles and again.table == board.table
    with pytest.raises(ValueError, match="harness.board: 'pegs'"):
        board_from_dict({"fixtures": board_to_dict(board)["fixtures"]})


def test_millimetre_files_are_converted(tmp_path):
    def to_mm(data):
        data["units"] = "mm"
        h = data["harness"]
        for f in h["fixtures"]:
            f["position"] = [1e3 * v for v in f["position"]]
            f["slot_width"], f["depth"] = 8.0, 10.0
        peg = h["pegs"][0]
        peg.update(base=[1e3 * v for v in peg["base"]], radius=12.0, height=60.0,
                   plate_height=30.0, plate_size=[80.0, 120.0])
        h["approach_height"], h["clearance"] = 80.0, 5.0
        h["tension"]["max_offset"] = 50.0
        data["start"]["placement"]["position"] = [220.0, -250.0, 50.0]
        data["obstacles"][0].update(center=[300.0, 0.0, 30.0], size=[30.0, 160.0, 60.0])

    mm = load_job(_example(tmp_path, to_mm))
    m = load_job(EXAMPLES / "harness_usb.yaml")
    assert mm.board.fixtures[1].position == pytest.approx(m.board.fixtures[1].position)
    assert mm.board.pegs[0].plate().top == pytest.approx(m.board.pegs[0].plate().top)
    assert mm.settings.max_offset == pytest.approx(m.settings.max_offset)
    assert np.allclose(mm.start, m.start)


def test_a_length_left_out_of_a_millimetre_file_is_its_default_in_metres(tmp_path):
    """A harness file in mm that leaves out the lengths with defaults (a fixture's slot width,
    depth, length and wall, a peg's plate size and thickness, the approach height, the
    clearance, the largest offset) got each default read in mm: a 3 um plate, a 0.05 mm
    largest offset, phase 1 ending 0.08 mm above the board; the USB job in mm tensioned at
    22.87 mm where the same job in metres tensions at 23.49 mm. A default is in metres
    whatever the units (as the check's and the TCP speed's): both files give one board and
    one set of settings."""
    def bare(data):
        h = data["harness"]
        for f in h["fixtures"]:
            del f["slot_width"], f["depth"]
        del h["pegs"][0]["plate_size"], h["approach_height"], h["clearance"]
        del h["tension"]["max_offset"]

    def bare_mm(data):
        bare(data)
        data["units"] = "mm"
        h = data["harness"]
        for f in h["fixtures"]:
            f["position"] = [1e3 * v for v in f["position"]]
        peg = h["pegs"][0]
        peg.update(base=[1e3 * v for v in peg["base"]], radius=12.0, height=60.0,
                   plate_height=30.0)
        data["start"]["placement"]["position"] = [220.0, -250.0, 50.0]
        data["obstacles"][0].update(center=[300.0, 0.0, 30.0], size=[30.0, 160.0, 60.0])

    (tmp_path / "m").mkdir()
    m = load_job(_example(tmp_path / "m", bare))
    mm = load_job(_example(tmp_path, bare_mm))
    for a, b in zip(mm.board.fixtures + mm.board.pegs, m.board.fixtures + m.board.pegs,
                    strict=True):
        for name, value in vars(a).items():
            assert value == pytest.approx(getattr(b, name), rel=1e-12, abs=1e-15), name
    assert mm.board.pegs[0].plate_thickness == 0.003
    for name in ("approach_height", "clearance", "max_offset"):
        assert getattr(mm.settings, name) == pytest.approx(getattr(m.settings, name)), name


def test_a_harness_document_without_what_the_checks_need_is_refused_by_name():
    """A harness plan written before harness plans were verified (no board, section or planned
    states in its harness section), or whose tensioning failed (no offset), is refused with the
    entry named, not verified on made-up data."""
    from dloplan.cable import catalogue_cable
    from dloplan.grippers import gripper_path
    from dloplan.pipeline.document import PlanDocument
    from dloplan.pipeline.harness import harness_model
    from dloplan.shapes import arc_shape

    cable = catalogue_cable("usb")
    shapes = np.stack([arc_shape(cable.length, cable.n_links, a) for a in (1.0, 1.5, 2.0)])
    doc = PlanDocument(cable=cable, shapes=shapes, grippers=gripper_path(shapes, cable=cable),
                       harness={"offset": 0.02, "knots": {"phase1": [0, 2]}})
    with pytest.raises(ValueError, match=r"plan.harness: no board, section_links, sections"):
        harness_model(doc)
    failed = PlanDocument(cable=cable, shapes=shapes, grippers=doc.grippers,
                          harness={"offset": None, "message": "no force"})
    with pytest.raises(ValueError, match="plan.harness.offset: none, the tensioning failed.*"
                                         "expected a plan whose tensioning succeeded"):
        harness_model(failed)
    with pytest.raises(ValueError, match="not a wire-harness plan"):
        harness_model(PlanDocument(cable=cable, shapes=shapes))


def test_plan_verify_of_a_harness_job_whose_tensioning_failed_is_the_failed_plan(monkeypatch):
    """``plan --verify`` of a harness job whose tensioning failed when planned (the PA12 cable
    on the board of examples/harness_usb.yaml: 6 N against its 5 N limit; the unseen-case
    sweep, round 2) returns that plan, its check failed (exit 3, written for inspection), not
    the verifier's refusal of a plan without an offset (exit 2, "nothing to verify")."""
    import dloplan.pipeline.repair.harness as repair
    from dloplan.cable import catalogue_cable
    from dloplan.grippers import gripper_path
    from dloplan.pipeline.document import PlanDocument
    from dloplan.shapes import arc_shape

    cable = catalogue_cable("pa12")
    shapes = np.stack([arc_shape(cable.length, cable.n_links, a) for a in (1.0, 1.5)])
    failed = PlanDocument(cable=cable, shapes=shapes, grippers=gripper_path(shapes, cable=cable),
                          harness={"offset": None, "message": "the link tension reaches 6 N"})
    monkeypatch.setattr(repair, "run_harness_job", lambda job, **options: failed)
    assert repair.plan_harness(None, verify=True) is failed
