"""The figures' formats: PNG by default, SVG copies only when asked (``--svg``, a job's
``outputs: [..., svg]``); what is written is what the command lists, the report embeds the PNGs
either way, and every command that draws figures takes ``--svg``."""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest
import yaml
from PIL import Image

from dloplan.cli import EXIT_FAILURE, EXIT_OK, EXIT_WARNINGS, build_parser, main

ALONG_Y = {"euler": [0, 0, 90]}
QUICK = {  # a stiff cable bent by 60 degrees in two shapes: planned in about a second
    "cable": {"name": "pa12", "n_links": 10},
    "start": {"kind": "straight",
              "placement": {"position": [0.4, -0.25, 0.2], "rotation": ALONG_Y}},
    "target": {"kind": "arc", "angle": 60,
               "placement": {"position": [0.35, -0.22, 0.25], "rotation": ALONG_Y}},
    "planner": {"n_shapes": 2},
}
SVG_NAMESPACE = "{http://www.w3.org/2000/svg}"


def _job(tmp_path, outputs=None) -> Path:
    path = tmp_path / "job.yaml"
    path.write_text(yaml.safe_dump(QUICK if outputs is None else {**QUICK, "outputs": outputs}))
    return path


def _plan(tmp_path, capsys, *options, outputs=None) -> tuple[Path, list[Path]]:
    out = tmp_path / "out"
    code = main(["plan", str(_job(tmp_path, outputs)), "-o", str(out), "-q", "--json", *options])
    summary = json.loads(capsys.readouterr().out)
    assert code in (EXIT_OK, EXIT_WARNINGS), summary
    return out, [Path(p) for p in summary["written"]]


def _on_disk(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*") if p.is_file())


def _embedded_pngs(report: Path) -> int:
    return len(re.findall(r"data:image/png;base64,", report.read_text()))


def test_a_plan_draws_its_figures_as_png_only_by_default(tmp_path, capsys):
    """No ``--svg``: every figure once, as PNG (the SVG copies were drawn for every plan, 30-45 %
    of each figure's CPU); the files the command lists are the files on disk; the report
    embeds each PNG."""
    out, written = _plan(tmp_path, capsys)
    figures = sorted((out / "figures").iterdir())
    assert figures and all(p.suffix == ".png" for p in figures)
    assert {p.stem for p in figures} >= {"planned_path", "stabilized_path", "forces", "lengths",
                                         "motion_profile"}
    assert sorted(written) == _on_disk(out)
    assert _embedded_pngs(out / "report.html") == len(figures)


def _assert_svg_copies(out: Path, written: list[Path]) -> None:
    """Each PNG of ``out/figures`` has its SVG copy: well-formed XML, the figure's size (110 dpi
    pixels as 72 dpi points) and its texts; the report embeds the PNGs only."""
    pngs = sorted((out / "figures").glob("*.png"))
    svgs = sorted((out / "figures").glob("*.svg"))
    assert pngs and [p.stem for p in svgs] == [p.stem for p in pngs]
    assert sorted(written) == _on_disk(out)
    for png, svg in zip(pngs, svgs, strict=True):
        root = ElementTree.parse(svg).getroot()
        assert root.tag == f"{SVG_NAMESPACE}svg"
        width, height = Image.open(png).size
        assert (root.get("width"), root.get("height")) == (f"{width * 72 / 110:g}pt",
                                                           f"{height * 72 / 110:g}pt"), svg.name
    path_svg = (out / "figures" / "planned_path.svg").read_text()
    assert "Planned shapes and gripper frames" in path_svg and "top view" in path_svg
    assert "TCP speed and acceleration" in (out / "figures" / "motion_profile.svg").read_text()
    assert _embedded_pngs(out / "report.html") == len(pngs)


def test_plan_svg_writes_each_figure_as_png_and_svg(tmp_path, capsys):
    out, written = _plan(tmp_path, capsys, "--svg")
    _assert_svg_copies(out, written)


def test_a_job_file_asks_for_svg_in_its_outputs(tmp_path, capsys):
    """``outputs: [..., figures, svg]``: the SVG copies as with ``--svg``; the report alone
    draws the figures too (``report`` brings ``figures`` along), and with ``svg`` their copies."""
    out, written = _plan(tmp_path, capsys, outputs=["json", "rapid", "figures", "report", "svg"])
    _assert_svg_copies(out, written)
    (tmp_path / "second").mkdir()
    out, written = _plan(tmp_path / "second", capsys, outputs=["json", "report", "svg"])
    _assert_svg_copies(out, written)


def test_svg_without_figures_in_a_job_file_is_refused(tmp_path, capsys):
    """``svg`` draws nothing by itself: listed without ``figures`` or ``report`` the job is
    refused (exit 2, one line), nothing written."""
    out = tmp_path / "out"
    code = main(["plan", str(_job(tmp_path, ["json", "rapid", "svg"])), "-o", str(out), "-q"])
    assert code == EXIT_FAILURE
    assert "outputs: 'svg' writes the figures as SVG too" in capsys.readouterr().err
    assert not out.exists()


def test_svg_and_no_figures_are_refused_together(tmp_path, capsys):
    """``--svg --no-figures`` asks for copies of figures that are not drawn: exit 2 (argparse's
    one line) for plan and study; ``--no-figures`` wins over a job file's ``svg``."""
    job = _job(tmp_path, ["json", "figures", "svg"])
    for command in ("plan", "study"):
        code = main([command, str(job), "-o", str(tmp_path / command), "--svg", "--no-figures"])
        assert code == EXIT_FAILURE
        assert "not allowed with argument" in capsys.readouterr().err
    out, written = _plan(tmp_path, capsys, "--no-figures", outputs=["json", "figures", "svg"])
    assert [p.name for p in written] == ["plan.json"] and _on_disk(out) == written


@pytest.mark.parametrize("command", [["compare", "plan.json", "shapes.csv"],
                                     ["simulate", "plan.json"], ["identify", "experiment.yaml"]])
def test_svg_without_an_output_folder_is_refused(tmp_path, capsys, command):
    """compare, simulate and identify draw their figures only into ``-o``: ``--svg`` without
    it is refused at once (exit 2), before anything is read."""
    assert main([*command, "--svg", "-q"]) == EXIT_FAILURE
    assert "--svg: the figures are written only into an output folder" in capsys.readouterr().err


def test_every_command_that_draws_figures_takes_svg():
    """plan, demo, study, simulate, compare and identify draw figures: each takes ``--svg``
    (off by default); verify, export, correct and the others draw none and do not."""
    drawing = {"plan", "demo", "study", "simulate", "compare", "identify"}
    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    for name, sub in commands.items():
        flags = {flag for action in sub._actions for flag in action.option_strings}
        assert ("--svg" in flags) == (name in drawing), name
    assert parser.parse_args(["demo", "--svg"]).svg
    assert not parser.parse_args(["demo"]).svg


def test_the_batch_mode_passes_svg_on(tmp_path):
    from dloplan.app.files import plan_file

    job = _job(tmp_path, ["json", "figures"])
    for svg in (False, True):
        result = plan_file({"output": str(tmp_path / f"batch_{svg}"), "verify": False,
                            "svg": svg}, str(job))
        assert result.code in (EXIT_OK, EXIT_WARNINGS), result.line
        suffixes = {p.suffix for p in (tmp_path / f"batch_{svg}" / "job" / "figures").iterdir()}
        assert suffixes == ({".png", ".svg"} if svg else {".png"})


def test_save_figure_writes_the_formats_asked_for(tmp_path):
    """One file per format, in order; an unknown, empty or repeated format list is refused
    before anything is written (and the figure is closed)."""
    from dloplan.plots.figures import PNG, WITH_SVG, lengths_figure, pyplot, save_figure

    def figure():
        return lengths_figure({"basic": [0.5, 0.49]}, 0.5)

    assert save_figure(figure(), tmp_path, "a") == [tmp_path / "a.png"]
    assert save_figure(figure(), tmp_path, "b", WITH_SVG) == [tmp_path / "b.png",
                                                              tmp_path / "b.svg"]
    assert save_figure(figure(), tmp_path, "c", ("svg",)) == [tmp_path / "c.svg"]
    assert save_figure(figure(), tmp_path, "d", PNG) == [tmp_path / "d.png"]
    for bad in ((), ("pdf",), ("png", "png")):
        with pytest.raises(ValueError, match="formats: got"):
            save_figure(figure(), tmp_path, "e", bad)
    assert not list(tmp_path.glob("e.*")) and not pyplot().get_fignums()
