"""Registered-shape files: CSV and JSON round trips and the errors a user can make."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dloplan.vision import RegisteredShape, read_shapes, write_shapes


def shapes():
    rng = np.random.default_rng(1)
    return [RegisteredShape(rng.normal(size=(k, 3)) * 0.1, "robot_base", f"xi_{j}")
            for j, k in enumerate((5, 11, 2))]


@pytest.mark.parametrize("suffix", [".csv", ".json"])
def test_round_trip(tmp_path, suffix):
    path = write_shapes(tmp_path / f"shapes{suffix}", shapes())
    again = read_shapes(path)
    assert [s.label for s in again] == ["xi_0", "xi_1", "xi_2"]
    for a, b in zip(again, shapes(), strict=True):
        np.testing.assert_allclose(a.points, b.points, atol=1e-9)  # 9 decimals written
        assert a.frame_id == "robot_base"


def test_csv_by_hand(tmp_path):
    path = tmp_path / "hand.csv"
    path.write_text("# measured on graph paper\nx,y,z,label,frame_id\n"
                    "0.0,0.0,0.003,a,table\n0.1,0.0,0.003,a,table\n0.2,0.01,0.003,a,table\n")
    (shape,) = read_shapes(path)
    assert shape.frame_id == "table" and shape.points.shape == (3, 3)


@pytest.mark.parametrize("suffix", [".csv", ".json"])
def test_a_file_with_a_byte_order_mark_reads_as_without(tmp_path, suffix):
    """A spreadsheet's or Notepad's UTF-8 export starts with a byte-order mark."""
    path = write_shapes(tmp_path / f"shapes{suffix}", shapes())
    marked = tmp_path / f"marked{suffix}"
    marked.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    for a, b in zip(read_shapes(marked), read_shapes(path), strict=True):
        assert (a.label, a.frame_id) == (b.label, b.frame_id)
        np.testing.assert_array_equal(a.points, b.points)


@pytest.mark.parametrize("text, message", [
    ("label,frame,x,y,z\n", "header"),
    ("label;frame_id;x;y;z\na;r;0,1;0;0\n", r"separated by ';' \(a spreadsheet's export for a "
     r"decimal comma\), expected the columns label,frame_id,x,y,z, separated by commas"),
    ("label,frame_id,x,y,z\na,r,0,0,0\nb,r,1,0,0\na,r,2,0,0\n", "continues after shape 'b'"),
    ("label,frame_id,x,y,z\na,r,0,0,zero\n", "line 2: coordinates must be numbers"),
    ("label,frame_id,x,y,z\na,r,0,0,0\na,s,1,0,0\n", "changes frame"),
    ("label,frame_id,x,y,z\na,r,0,0,0\n", "1 points given, need at least 2"),
    ("label,frame_id,x,y,z\na,r,0,0\n", "4 fields, expected 5"),
    ("label,frame_id,x,y,z\na,r,0,0,nan\na,r,1,0,0\n", "non-finite"),
])
def test_csv_errors(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        read_shapes(path)


def test_json_units_and_errors(tmp_path):
    path = tmp_path / "mm.json"
    path.write_text(json.dumps({"units": "mm", "frame_id": "robot_base", "shapes": [
        {"label": "a", "points": [[0, 0, 0], [100, 0, 0]]}]}))
    np.testing.assert_allclose(read_shapes(path)[0].points[1], [0.1, 0, 0])
    path.write_text(json.dumps({"units": "inch", "shapes": []}))
    with pytest.raises(ValueError, match="units 'inch'"):
        read_shapes(path)
    path.write_text(json.dumps({"shapes": [{"label": "a", "points": [[0, 0], [1, 1, 1]]}]}))
    with pytest.raises(ValueError, match=r"shapes\[0\]"):
        read_shapes(path)
    with pytest.raises(ValueError, match="expected .csv or .json"):
        read_shapes(tmp_path / "shapes.txt")
    with pytest.raises(ValueError, match="cannot read"):
        read_shapes(tmp_path / "missing.csv")
    with pytest.raises(ValueError, match="frame_id"):
        RegisteredShape(np.zeros((2, 3)), frame_id="a,b")
    with pytest.raises(ValueError, match="distinct non-empty labels"):
        write_shapes(tmp_path / "x.csv", [RegisteredShape(np.eye(3))])
