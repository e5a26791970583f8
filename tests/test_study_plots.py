"""Study figures: written as PNG (and SVG when asked), axes labelled with units."""

from __future__ import annotations

from study_cases import hanging_problem

from dloplan.plots.figures import WITH_SVG
from dloplan.plots.study import study_figures
from dloplan.study import run_study


def test_study_figures_are_written_with_units(tmp_path):
    result = run_study(hanging_problem(), {
        "samples": 16, "chunk_size": 8,
        "parameters": {"youngs_modulus": {"spread": 40}, "clip_position": {"spread": 1}}})
    stems = ("study_success_youngs_modulus", "study_deviation", "study_tornado")
    pngs = study_figures(result.table, result.summary, result.spec.criteria, tmp_path / "png")
    assert sorted(p.name for p in pngs) == sorted(f"{stem}.png" for stem in stems)
    assert sorted(p.name for p in (tmp_path / "png").iterdir()) == sorted(p.name for p in pngs)
    paths = study_figures(result.table, result.summary, result.spec.criteria, tmp_path,
                          formats=WITH_SVG)
    names = sorted(p.name for p in paths)
    assert names == sorted(f"{stem}.{ext}" for stem in stems for ext in ("png", "svg"))
    assert all(p.stat().st_size > 1000 for p in paths)
    svg = (tmp_path / "study_success_youngs_modulus.svg").read_text()
    assert "MPa" in svg
    assert "deviation [mm]" in (tmp_path / "study_deviation.svg").read_text()


def test_study_figures_are_saved_whole_without_a_tight_crop(tmp_path):
    """Each PNG is its figure's size at 110 dpi, as laid out (no tight bounding box: finding it
    was one more draw of the figure): the success figure 6.0 x 3.8 in, the deviations 9.0 x 3.8
    in, the tornado 6.5 in wide (its height follows its parameters)."""
    from PIL import Image

    result = run_study(hanging_problem(), {
        "samples": 8, "chunk_size": 8, "parameters": {"youngs_modulus": {"spread": 40}}})
    study_figures(result.table, result.summary, result.spec.criteria, tmp_path)
    sizes = {p.stem: Image.open(p).size for p in tmp_path.glob("*.png")}
    assert sizes["study_success_youngs_modulus"] == (660, 418)
    assert sizes["study_deviation"] == (990, 418)
    assert sizes["study_tornado"][0] == 715
