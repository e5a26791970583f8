"""The planned-vs-registered error table (thesis Table 7.2, Fig. 7.10) and its figures.

Exact cases: a plan against itself has zero error; against the plan shifted by 5 mm every
error is 5 mm (to 1e-12 m: the resampling of an unchanged polyline is exact up to rounding).
"""

from __future__ import annotations

import numpy as np
import pytest

from dloplan.geometry import resample_by_arc_length
from dloplan.plots.compare import write_comparison_figures
from dloplan.vision import RegisteredShape, compare_shapes, compare_trials


def planned_path(n_shapes=4, n_links=10):
    """(S + 2, n + 1, 3) arcs of growing curvature, 0.5 m long, lifted 0.1 m."""
    shapes = []
    for k in range(n_shapes):
        angle = np.linspace(-0.3 * k, 0.3 * k, n_links + 1) + 1e-9
        s = np.linspace(0, 0.5, n_links + 1)
        shapes.append(np.column_stack([s, 0.05 * k * np.sin(2 * np.pi * s / 0.5),
                                       0.1 + 0.02 * np.cos(angle)]))
    return np.array([resample_by_arc_length(x, n_links + 1) for x in shapes])


def test_plan_against_itself_is_zero():
    plan = planned_path()
    result = compare_shapes(plan, list(plan))
    np.testing.assert_allclose(result.point_errors, 0.0, atol=1e-15)  # rounding only
    assert result.reversed_shapes == ()
    assert result.labels == ("xi_0", "xi_1", "xi_2", "xi_3")


def test_shift_by_5_mm():
    plan = planned_path()
    direction = np.array([1.0, -2.0, 2.0]) / 3.0
    result = compare_shapes(plan, list(plan + 0.005 * direction))
    np.testing.assert_allclose(result.euclidean_errors, 0.005, atol=1e-12)
    np.testing.assert_allclose(result.axis_errors, np.tile(0.005 * np.abs(direction), (4, 1)),
                               atol=1e-12)
    along_x = compare_shapes(plan, list(plan + [0.005, 0.0, 0.0]))
    np.testing.assert_allclose(along_x.axis_mean, [0.005, 0.0, 0.0], atol=1e-12)
    # the thesis' error_tot is the mean of the three axis errors (Table 7.2)
    assert along_x.total_mean == pytest.approx(0.005 / 3, abs=1e-12)
    assert along_x.euclidean_mean == pytest.approx(0.005, abs=1e-12)
    table = along_x.table()
    assert "error_tot [m]" in table and table.splitlines()[-1].split()[1:] == [
        "0.0050", "0.0000", "0.0000", "0.0017", "0.0050"]


def test_registered_shapes_are_resampled():
    plan = planned_path()
    weights = np.linspace(0.0, 1.0, 31)[:-1, None]  # every link cut in 30 pieces
    dense = [RegisteredShape(np.vstack([(1 - weights) * a + weights * b
                                        for a, b in zip(x[:-1], x[1:], strict=True)] + [x[-1:]]),
                             label=f"s{k}") for k, x in enumerate(plan)]
    assert len(dense[0].points) == 301
    result = compare_shapes(plan, dense)
    assert result.labels == ("s0", "s1", "s2", "s3")
    np.testing.assert_allclose(result.point_errors, 0.0, atol=1e-12)
    # a plan with unequal links is matched at its own arc-length fractions
    stretched = plan.copy()
    stretched[:, 1:-1] += 0.3 * (plan[:, 2:] - plan[:, 1:-1])
    assert compare_shapes(stretched, list(stretched)).euclidean_mean < 1e-15


def test_reversed_order_is_detected_and_reported():
    plan = planned_path()
    registered = list(plan)
    registered[2] = plan[2][::-1]
    result = compare_shapes(plan, registered)
    assert result.reversed_shapes == ((0, 2),) and result.euclidean_mean < 1e-12
    assert "reversed to match the plan (trial, shape): (0, 2)" in result.table()
    kept = compare_shapes(plan, registered, end_order="keep")
    assert kept.reversed_shapes == () and kept.euclidean_errors[2] > 0.1


def test_shuffled_points_are_an_error():
    plan = planned_path()
    registered = list(plan)
    registered[1] = np.random.default_rng(0).permutation(plan[1])
    with pytest.raises(ValueError, match=r"registered\[1\]: .* are its points shuffled"):
        compare_shapes(plan, registered)


def test_mismatches_are_errors():
    plan = planned_path()
    with pytest.raises(ValueError, match="3 registered shapes for 4 planned shapes"):
        compare_shapes(plan, list(plan[:3]))
    in_camera = [RegisteredShape(x, frame_id="camera") for x in plan]
    with pytest.raises(ValueError, match="registered in frame 'camera'"):
        compare_shapes(plan, in_camera)
    with pytest.raises(ValueError, match=r"planned: expected shape \(S \+ 2, n \+ 1, 3\)"):
        compare_shapes(plan[0], list(plan))
    with pytest.raises(ValueError, match="end_order"):
        compare_shapes(plan, list(plan), end_order="guess")
    with pytest.raises(ValueError, match=r"registered\[0\]: 1 points given"):
        compare_shapes(plan, [plan[0][:1], *plan[1:]])


def test_trials_are_averaged():
    plan = planned_path()
    result = compare_trials(plan, [list(plan + [0.002, 0, 0]), list(plan + [0.004, 0, 0])])
    np.testing.assert_allclose(result.axis_errors[:, 0], 0.003, atol=1e-12)
    assert result.registered.shape == (2, *plan.shape)


def test_figures_are_written_as_png_and_as_svg_when_asked(tmp_path):
    """PNG only by default (what the report embeds); the SVG copies with WITH_SVG (compare
    --svg), labelled as the PNGs."""
    from dloplan.plots.figures import WITH_SVG

    plan = planned_path()
    result = compare_shapes(plan, list(plan + [0.0, 0.004, 0.0]))
    paths = write_comparison_figures(result, tmp_path / "png")
    assert sorted(p.name for p in paths) == ["registered_shapes.png", "shape_errors.png"]
    assert sorted(p.name for p in (tmp_path / "png").iterdir()) == sorted(p.name for p in paths)
    paths = write_comparison_figures(result, tmp_path / "svg", formats=WITH_SVG)
    names = sorted(p.name for p in paths)
    assert names == ["registered_shapes.png", "registered_shapes.svg", "shape_errors.png",
                     "shape_errors.svg"]
    assert all(p.stat().st_size > 1000 for p in paths)
    svg = (tmp_path / "svg" / "registered_shapes.svg").read_text()
    assert "x [m]" in svg and "y [m]" in svg
    with pytest.raises(ValueError, match="plane"):
        write_comparison_figures(result, tmp_path, plane="xx")


def test_shapes_in_the_vision_files_frame_name_compare_with_a_plan_in_world():
    """docs/vision.md names the planner's frame ``robot_base`` (the default of calibrations
    and registered-shape files, the CSV example) while plans say ``world``: every registered
    shape of the documented format was refused as "in another frame" (the unseen-case sweep).
    The two names are one frame; any other name is still refused."""
    plan = planned_path()
    in_base = [RegisteredShape(x, frame_id="robot_base") for x in plan]
    result = compare_trials(plan, [in_base], frame_id="world")
    assert result.rows()[-1][-1] == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match="registered in frame 'camera', the plan is in 'world'"):
        compare_trials(plan, [[RegisteredShape(x, frame_id="camera") for x in plan]],
                       frame_id="world")
