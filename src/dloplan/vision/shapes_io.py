"""Registered cable shapes on disk: CSV and JSON of points in metres with a frame name.

A registered shape is an ordered polyline of k >= 2 points measured on a real cable (by the
camera, by hand on graph paper, by a tracker) in a named frame, normally the robot base frame.
Identification and comparison both read these files. Formats (details and examples in
docs/vision.md):

CSV, one point per row, the rows of a shape consecutive and in order along the cable::

    # any comment line
    label,frame_id,x,y,z
    xi_0,robot_base,0.1000,0.0000,0.0030
    xi_0,robot_base,0.1500,0.0100,0.0030

JSON::

    {"format": "dloplan-shapes", "version": 1, "units": "m",
     "shapes": [{"label": "xi_0", "frame_id": "robot_base", "points": [[x, y, z], ...]}]}

(``"units": "mm"`` is accepted and converted; CSV coordinates are always metres.)
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..bounds import WORKSPACE
from ..geometry import as_shape
from ..inputs import parse_json, read_text
from ..output_files import atomic_write_text

SHAPES_FORMAT = "dloplan-shapes"
CSV_COLUMNS = ("label", "frame_id", "x", "y", "z")
UNITS = {"m": 1.0, "mm": 1e-3}
JSON_KEYS = ("format", "version", "units", "frame_id", "shapes")
"""The keys of a shapes JSON file."""
SHAPE_KEYS = ("label", "frame_id", "points")
"""The keys of one shape of a shapes JSON file."""


@dataclass(frozen=True)
class RegisteredShape:
    """A measured cable shape.

    Attributes
    ----------
    points : numpy.ndarray
        (k, 3) points along the cable, in order from one end to the other [m].
    frame_id : str
        The frame the points are expressed in (``"robot_base"`` for the planner's frame).
    label : str
        A name, e.g. the planned shape it shows (``"xi_0"``).
    """

    points: np.ndarray
    frame_id: str = "robot_base"
    label: str = ""

    def __post_init__(self) -> None:
        where = f"shape {self.label!r}" if self.label else "points"
        object.__setattr__(self, "points", as_shape(self.points, name=where))
        for name in ("frame_id", "label"):
            value = getattr(self, name)
            if not isinstance(value, str) or any(c in value for c in ",\n\r\""):
                raise ValueError(
                    f"{name}: got {value!r}, expected a string without commas, quotes or "
                    "line breaks"
                )
        if not self.frame_id:
            raise ValueError("frame_id: empty, expected the name of the points' frame")


def _check_shapes(shapes) -> list[RegisteredShape]:
    if isinstance(shapes, RegisteredShape):
        shapes = [shapes]
    if not isinstance(shapes, Sequence) or not shapes:
        raise ValueError("shapes: expected a non-empty sequence of RegisteredShape")
    for k, shape in enumerate(shapes):
        if not isinstance(shape, RegisteredShape):
            raise ValueError(f"shapes[{k}]: expected a RegisteredShape, got {type(shape).__name__}")
    return list(shapes)


def shapes_to_csv(shapes) -> str:
    """The CSV text of shapes (one row per point, 9 decimals = nanometres)."""
    shapes = _check_shapes(shapes)
    labels = [s.label for s in shapes]
    if "" in labels or len(set(labels)) != len(labels):
        raise ValueError(f"shapes: CSV needs distinct non-empty labels, got {labels}")
    out = io.StringIO()
    out.write("# dloplan registered shapes; coordinates in metres\n")
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    for shape in shapes:
        for p in shape.points:
            writer.writerow([shape.label, shape.frame_id, *(f"{v:.9f}" for v in p)])
    return out.getvalue()


def shapes_to_json(shapes) -> str:
    """The JSON text of shapes (metres)."""
    shapes = _check_shapes(shapes)
    data = {"format": SHAPES_FORMAT, "version": 1, "units": "m",
            "shapes": [{"label": s.label, "frame_id": s.frame_id,
                        "points": np.round(s.points, 9).tolist()} for s in shapes]}
    return json.dumps(data, indent=1) + "\n"


def write_shapes(path, shapes) -> Path:
    """Write registered shapes to ``.csv`` or ``.json`` (by the suffix), atomically."""
    suffix = Path(path).suffix.lower()
    if suffix == ".csv":
        return atomic_write_text(path, shapes_to_csv(shapes))
    if suffix == ".json":
        return atomic_write_text(path, shapes_to_json(shapes))
    raise ValueError(f"path: {str(path)!r} has suffix {suffix!r}, expected .csv or .json")


def _shapes_from_csv(text: str, where: str) -> list[RegisteredShape]:
    lines = [(n, line) for n, line in enumerate(text.splitlines(), 1)
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise ValueError(f"{where}: no header line {','.join(CSV_COLUMNS)}")
    header = [c.strip() for c in next(csv.reader([lines[0][1]]))]
    if sorted(header) != sorted(CSV_COLUMNS):
        separated = " separated by ';' (a spreadsheet's export for a decimal comma)" if \
            len(header) == 1 and ";" in header[0] else ""
        raise ValueError(
            f"{where}: line {lines[0][0]}: header {header}{separated}, expected the columns "
            f"{','.join(CSV_COLUMNS)}, separated by commas (coordinates in metres, decimal "
            "points)"
        )
    col = {name: header.index(name) for name in CSV_COLUMNS}
    groups: dict[str, tuple[str, list]] = {}
    order: list[str] = []
    for n, line in lines[1:]:
        row = [c.strip() for c in next(csv.reader([line]))]
        if len(row) != len(header):
            raise ValueError(f"{where}: line {n}: {len(row)} fields, expected {len(header)}")
        label, frame = row[col["label"]], row[col["frame_id"]]
        try:
            point = [float(row[col[c]]) for c in "xyz"]
        except ValueError as exc:
            raise ValueError(f"{where}: line {n}: coordinates must be numbers: {exc}") from exc
        if label not in groups:
            groups[label] = (frame, [])
            order.append(label)
        elif order[-1] != label:
            raise ValueError(
                f"{where}: line {n}: shape {label!r} continues after shape {order[-1]!r}: the "
                "rows of a shape must be consecutive, in order along the cable"
            )
        if frame != groups[label][0]:
            raise ValueError(
                f"{where}: line {n}: shape {label!r} changes frame from "
                f"{groups[label][0]!r} to {frame!r}"
            )
        groups[label][1].append(point)
    if not order:
        raise ValueError(f"{where}: no shapes (only a header)")
    try:
        shapes = [RegisteredShape(np.array(groups[k][1]), groups[k][0], k) for k in order]
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from exc
    for shape in shapes:
        _check_workspace(shape, where)
    return shapes


def _json_points(value, where: str, units: str) -> np.ndarray:
    """(k, 3) the points of a JSON shape as given (in ``units``): a list of [x, y, z], each
    three numbers (not a pair, a text or a boolean: none of them is read as a coordinate)."""
    if not isinstance(value, list):
        raise ValueError(f"{where}: got {value!r:.60}, expected a list of [x, y, z] numbers in "
                         f"{units}")
    for i, point in enumerate(value):
        if not (isinstance(point, list) and len(point) == 3 and all(
                isinstance(v, int | float) and not isinstance(v, bool) for v in point)):
            raise ValueError(f"{where}[{i}]: got {point!r:.60}, expected [x, y, z]: three "
                             f"numbers in {units}")
    return np.array(value, dtype=float).reshape(-1, 3)


def _check_workspace(shape: RegisteredShape, where: str) -> None:
    """Refuse a shape with a point beyond :data:`~dloplan.bounds.WORKSPACE` of its frame's
    origin (a length in wrong units, or a number gone astray)."""
    distance = np.hypot(shape.points[:, 0], np.hypot(shape.points[:, 1], shape.points[:, 2]))
    far = int(np.argmax(distance))
    if distance[far] > WORKSPACE:
        raise ValueError(f"{where}: shape {shape.label!r}: point {far} "
                         f"{np.round(shape.points[far], 6).tolist()} is {distance[far]:.4g} m "
                         f"from the origin of {shape.frame_id!r}, expected within {WORKSPACE:g} "
                         "m (millimetres read as metres? a registered-shape CSV is in metres; a "
                         "JSON one may say \"units\": \"mm\")")


def _known_keys(mapping: dict, known: tuple[str, ...], where: str) -> None:
    """Refuse a key of ``mapping`` not in ``known`` (a misspelt ``units`` would be ignored)."""
    unknown = sorted(set(mapping) - set(known))
    if unknown:
        raise ValueError(f"{where}: unknown key {unknown[0]!r}, expected only {list(known)}")


def _shapes_from_json(text: str, where: str) -> list[RegisteredShape]:
    try:
        data = parse_json(text)
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, a key twice
        raise ValueError(f"{where}: not valid JSON: {exc}") from exc
    if not isinstance(data, dict) or not isinstance(data.get("shapes"), list):
        raise ValueError(f"{where}: expected an object with a 'shapes' list")
    _known_keys(data, JSON_KEYS, where)
    if data.get("version", 1) != 1:
        raise ValueError(f"{where}: version {data['version']!r}, expected 1")
    if data.get("format", SHAPES_FORMAT) != SHAPES_FORMAT:
        raise ValueError(f"{where}: format {data.get('format')!r}, expected {SHAPES_FORMAT!r}")
    units = data.get("units", "m")
    if not isinstance(units, str) or units not in UNITS:
        raise ValueError(f"{where}: units {units!r}, expected one of {sorted(UNITS)}")
    default_frame = data.get("frame_id", "robot_base")
    shapes = []
    for k, entry in enumerate(data["shapes"]):
        if not isinstance(entry, dict) or "points" not in entry:
            raise ValueError(f"{where}: shapes[{k}] needs 'points'")
        _known_keys(entry, SHAPE_KEYS, f"{where}: shapes[{k}]")
        points = _json_points(entry["points"], f"{where}: shapes[{k}].points", units)
        try:
            shapes.append(RegisteredShape(points * UNITS[units],
                                          entry.get("frame_id", default_frame),
                                          entry.get("label", f"shape {k}")))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{where}: shapes[{k}]: {exc}") from exc
        _check_workspace(shapes[-1], f"{where}: shapes[{k}]")
    if not shapes:
        raise ValueError(f"{where}: no shapes")
    return shapes


def read_shapes(path) -> list[RegisteredShape]:
    """Read registered shapes from a ``.csv`` or ``.json`` file (by the suffix).

    Raises
    ------
    ValueError
        Naming the file, the line (CSV) or the shape, and what is wrong.
    """
    where = str(path)
    suffix = Path(path).suffix.lower()
    if suffix not in (".csv", ".json"):
        raise ValueError(f"path: {where!r} has suffix {suffix!r}, expected .csv or .json")
    text = read_text(path, kind="shape file (.csv or .json)")
    return _shapes_from_csv(text, where) if suffix == ".csv" else _shapes_from_json(text, where)
