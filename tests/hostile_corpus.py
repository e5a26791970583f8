"""A corpus of hostile inputs on every surface of the ``dloplan`` command.

Each :class:`Case` is one bad input a new user or a hostile one might give: a file that is not
what it claims (a device, a pipe, a folder, a symlink loop, binary data, an endless or huge
stream, deep nesting), a field with a wrong value (text for a number, NaN, a count of a billion),
a URDF that is broken, a plan document edited by hand, an option out of range, an output that
would replace an input. The expected outcome of every one is the same: exit 2, exactly one line
on stderr naming what is wrong (its ``fragments``), nothing written, no traceback, no hang.

The cases are data: an ``argv`` template whose ``{placeholders}`` are filled from a
:class:`World` (files made once: a small job, its plan, an identification file, a measured
shape, a URDF) and from the case's own file (``make``: a function of the case's folder and the
world that writes it and returns its path). ``tests/test_hostile_inputs.py`` runs them.
"""

from __future__ import annotations

import copy
import json
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
ALONG_Y = {"euler": [0, 0, 90]}
SMALL = {
    "cable": {"name": "pa12", "n_links": 8},
    "start": {"kind": "straight", "placement": {"position": [0.4, -0.25, 0.2],
                                                 "rotation": ALONG_Y}},
    "target": {"kind": "arc", "angle": 60,
               "placement": {"position": [0.35, -0.22, 0.25], "rotation": ALONG_Y}},
    "planner": {"n_shapes": 2},
    "outputs": ["json", "csv", "report"],
}
NAN, INF = float("nan"), float("inf")


@dataclass(frozen=True)
class World:
    """The good files the cases start from (made once per test session)."""

    folder: Path
    job: Path  # SMALL as YAML
    plan: Path  # its plan.json (dloplan plan)
    identification: Path  # examples/identify_ethernet.yaml, copied
    measured: Path  # the plan's stabilized shape 1 as a registered-shape CSV
    urdf: Path  # the vendored UR5e description, copied
    study: Path  # examples/study_m2_ethernet.yaml, copied


@dataclass(frozen=True)
class Case:
    """One hostile input: ``argv`` with ``{job}``, ``{plan}``, ``{ident}``, ``{measured}``,
    ``{urdf}``, ``{study}``, ``{world}`` (the world's files), ``{f}`` (the case's file, made by
    ``make``) and ``{out}`` (an output path that must stay unwritten); the ``fragments`` that its
    one line must hold."""

    id: str
    argv: tuple[str, ...]
    fragments: tuple[str, ...]
    make: Callable[[Path, World], Path] | None = field(default=None, compare=False)


def write_yaml(folder: Path, data, name: str = "job.yaml") -> Path:
    path = folder / name
    path.write_text(yaml.safe_dump(data, sort_keys=False) if not isinstance(data, str)
                    else data)
    return path


def job_with(change: Callable[[dict], None], name: str = "job.yaml"):
    """A maker: SMALL changed by ``change`` (which edits the mapping in place)."""
    def make(folder: Path, world: World) -> Path:
        data = copy.deepcopy(SMALL)
        change(data)
        return write_yaml(folder, data, name)
    return make


def setting(path: str, value):
    """A change setting the dotted ``path`` of the job to ``value``."""
    def change(data: dict) -> None:
        keys = path.split(".")
        node = data
        for key in keys[:-1]:
            node = node.setdefault(key, {}) if not key.isdigit() else node[int(key)]
        node[keys[-1] if not keys[-1].isdigit() else int(keys[-1])] = value
    return change


def raw(text: str | bytes, name: str = "job.yaml"):
    """A maker writing ``text`` (or bytes) as it is."""
    def make(folder: Path, world: World) -> Path:
        path = folder / name
        if isinstance(text, bytes):
            path.write_bytes(text)
        else:
            path.write_text(text)
        return path
    return make


def special(kind: str, name: str = "job.yaml"):
    """A maker of a path that is no regular file: a device, a folder, a pipe, a loop, nothing."""
    def make(folder: Path, world: World) -> Path:
        path = folder / name
        if kind == "zero":
            return Path("/dev/zero")
        if kind == "urandom":
            return Path("/dev/urandom")
        if kind == "folder":
            path.mkdir()
        elif kind == "fifo":
            os.mkfifo(path)
        elif kind == "loop":
            other = folder / f"other-{name}"
            path.symlink_to(other)
            other.symlink_to(path)
        elif kind == "huge":
            with path.open("w") as handle:
                handle.write("cable: {name: pa12}\nstart: {kind: straight}\ntarget:\n  kind: "
                             "points\n  points:\n")
                handle.write("  - [0.0, 0.0, 0.0]\n" * 600_000)
        elif kind == "deep":
            depth = 100_000
            path.write_text("[" * depth + "]" * depth)
        elif kind == "deep_map":
            depth = 100_000
            path.write_text("cable: " + "{a: " * depth + "1" + "}" * depth + "\n")
        elif kind == "bomb":
            lines = ["a: &a [x, x, x, x, x, x, x, x, x, x]"]
            for k in range(1, 9):
                previous = chr(ord("a") + k - 1)
                lines.append(f"{chr(ord('a') + k)}: &{chr(ord('a') + k)} "
                             f"[*{previous}, *{previous}, *{previous}, *{previous}, "
                             f"*{previous}, *{previous}, *{previous}, *{previous}, "
                             f"*{previous}, *{previous}]")
            lines.append("cable: {name: pa12}\nstart: {kind: points, points: *i}\n"
                         "target: {kind: straight}")
            path.write_text("\n".join(lines) + "\n")
        return path
    return make


def plan_edited(change: Callable[[dict], None], name: str = "plan.json", text=None):
    """A maker: the world's plan document, its JSON changed by ``change`` (or replaced by
    ``text(original_text)``)."""
    def make(folder: Path, world: World) -> Path:
        original = world.plan.read_text()
        if text is not None:
            content = text(original)
        else:
            data = json.loads(original)
            change(data)
            content = json.dumps(data)
        path = folder / name
        path.write_text(content)
        return path
    return make


def shape_file(rows: list[str], name: str = "measured.csv"):
    """A maker of a registered-shape CSV with the given point rows (x,y,z)."""
    def make(folder: Path, world: World) -> Path:
        path = folder / name
        frame = json.loads(world.plan.read_text())["frame_id"]
        path.write_text("label,frame_id,x,y,z\n" + "".join(f"xi_1,{frame},{row}\n"
                                                           for row in rows))
        return path
    return make


def shapes_json(top: dict | None = None, shape: dict | None = None) -> str:
    """A shapes JSON text of one two-point shape, ``top`` and ``shape`` changing the file's and
    the shape's fields."""
    entry = {"label": "xi_1", "frame_id": "world", "points": [[0.3, 0, 0.2], [0.5, 0, 0.2]],
             **(shape or {})}
    return json.dumps({"format": "dloplan-shapes", "version": 1, "units": "m",
                       "shapes": [entry], **(top or {})})


def measured_scaled(factor: float, name: str = "measured.csv"):
    """A maker: the world's measured shape with every coordinate times ``factor`` (1000: a
    millimetre file read as metres)."""
    def make(folder: Path, world: World) -> Path:
        lines = world.measured.read_text().splitlines()
        out = []
        for line in lines:
            parts = line.split(",")
            if len(parts) == 5 and parts[0].startswith("xi"):
                parts[2:] = [f"{float(v) * factor:.9f}" for v in parts[2:]]
            out.append(",".join(parts))
        path = folder / name
        path.write_text("\n".join(out) + "\n")
        return path
    return make


def identification_with(change: Callable[[dict], None], name: str = "ident.yaml"):
    """A maker: the world's identification file changed by ``change``."""
    def make(folder: Path, world: World) -> Path:
        data = yaml.safe_load(world.identification.read_text())
        change(data)
        return write_yaml(folder, data, name)
    return make


def study_with(change: Callable[[dict], None], name: str = "study.yaml"):
    """A maker: the world's study scenario changed by ``change``."""
    def make(folder: Path, world: World) -> Path:
        data = yaml.safe_load(world.study.read_text())
        change(data)
        return write_yaml(folder, data, name)
    return make


def cell_job(arm_change: Callable[[dict], None] | None = None,
             urdf: Callable[[Path, World], Path] | None = None):
    """A maker: SMALL on a cell of two UR5e described by URDF (the left arm's entry changed by
    ``arm_change``, its URDF made by ``urdf``)."""
    def make(folder: Path, world: World) -> Path:
        data = copy.deepcopy(SMALL)
        left = {"urdf": str(world.urdf), "tip_link": "tool0", "base_position": [0, 0.4, 0],
                "home_deg": [0, -90, 90, -90, -90, 0]}
        right = {**left, "base_position": [0, -0.4, 0]}
        if urdf is not None:
            left["urdf"] = str(urdf(folder, world))
        if arm_change is not None:
            arm_change(left)
        data["robot"] = {"cell": {"arms": {"left": left, "right": right}}}
        return write_yaml(folder, data, "cell.yaml")
    return make


def urdf_edited(old: str, new: str, name: str = "arm.urdf"):
    def make(folder: Path, world: World) -> Path:
        text = world.urdf.read_text()
        assert old in text, old
        path = folder / name
        path.write_text(text.replace(old, new, 1))
        return path
    return make


def urdf_raw(content: str | bytes, name: str = "arm.urdf"):
    return raw(content, name)


def png(folder: Path, world: World) -> Path:
    """A maker of a real (black, 8 x 8) PNG image."""
    import cv2
    import numpy as np

    path = folder / "image.png"
    cv2.imwrite(str(path), np.zeros((8, 8, 3), dtype=np.uint8))
    return path


VISION_INTRINSICS = {"fx": 10.0, "fy": 10.0, "cx": 4.0, "cy": 4.0, "width": 8, "height": 8,
                     "distortion": []}
VISION_LAYOUT = {"dictionary": "DICT_4X4_50", "marker_length": 0.06, "markers": [
    {"id": k, "pose": {"position": {"x": 0.3, "y": y, "z": 0.0},
                       "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}
    for k, y in ((0, 0.15), (1, -0.15))]}
VISION_CALIBRATION = {
    "format": "dloplan-camera-calibration", "version": 1, "frame_id": "robot_base",
    "camera_to_robot": {"translation": {"x": 0.38, "y": 0.04, "z": 0.62},
                        "rotation": {"x": 1.0, "y": 0.0, "z": 0.0, "w": 0.0}},
    "intrinsics": VISION_INTRINSICS, "marker_ids": [0, 1], "reprojection_rms_px": 0.1,
    "success": True, "message": "camera pose from 2 marker(s)"}


def vision_files(change: Callable[[dict], None], file: str):
    """A maker of a folder ``vision`` with a camera's files: ``image.png`` (black, 8 x 8),
    ``intrinsics.json``, ``layout.json`` and ``calibration.json``, the one named ``file``
    changed by ``change`` (which edits its mapping in place, or returns a text to write
    instead); returns the folder (``{f}/calibration.json`` in a case's argv)."""
    def make(folder: Path, world: World) -> Path:
        out = folder / "vision"
        out.mkdir()
        png(out, world)
        for name, data in (("intrinsics", VISION_INTRINSICS), ("layout", VISION_LAYOUT),
                           ("calibration", VISION_CALIBRATION)):
            data = copy.deepcopy(data)
            text = change(data) if name == file else None
            (out / f"{name}.json").write_text(text if isinstance(text, str)
                                              else json.dumps(data))
        return out
    return make


BOMB_XML = ('<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY a "aaaaaaaaaa">'
            '<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;"><!ENTITY c "&b;&b;&b;&b;&b;&b;&b;&b;&b;'
            '&b;">]>\n<robot name="&c;"><link name="base"/></robot>\n')


def _cases() -> list[Case]:  # noqa: C901 - one long table
    cases: list[Case] = []

    def add(id_: str, argv: str | list, fragments, make=None):
        argv = argv.split() if isinstance(argv, str) else argv
        frags = (fragments,) if isinstance(fragments, str) else tuple(fragments)
        cases.append(Case(id_, tuple(argv), frags, make))

    # -- files that are not job files, on every command that reads one ---------------------
    files = {
        "dev-zero": (special("zero"), "not a regular file"),
        "dev-urandom": (special("urandom"), "not a regular file"),
        "folder": (special("folder"), "not a regular file"),
        "fifo": (special("fifo"), "not a regular file"),
        "symlink-loop": (special("loop"), "symbolic links"),
        "missing": (lambda folder, world: folder / "missing.yaml", "No such file"),
        "empty": (raw(""), "expected a mapping"),
        "binary": (raw(b"\x00\xff\xfe\x00 binary \x81"), "not a text file"),
        "latin1": (raw("cable: {name: caf\xe9}\n".encode("latin-1")), "not a text file"),
        "huge": (special("huge"), "more than the 10 MB"),
        "deep-json": (special("deep", "job.json"), "nested too deeply"),
        "deep-yaml": (special("deep_map"), "nested too deeply"),
        "alias-bomb": (special("bomb"), "YAML aliases"),
        "list": (raw("- 1\n- 2\n"), "expected a mapping"),
        "scalar": (raw("42\n"), "expected a mapping"),
        "json-nan": (raw('{"cable": {"name": "pa12"}, "start": {"kind": "straight", "placement":'
                         ' {"position": [NaN, 0, 0]}}, "target": {"kind": "straight"}}',
                         "job.json"), "start"),
        "yaml-tab": (raw("cable:\n\t name: pa12\n"), "not valid YAML"),
        "json-suffix-yaml": (raw("cable: {name: pa12}\n", "job.json"), "not valid JSON"),
        "unknown-key": (job_with(setting("colour", "red")), "colour"),
        "duplicate-key-yaml": (raw(yaml.safe_dump(SMALL, sort_keys=False).replace(
            "cable:\n", "cable:\n  n_links: 9\n", 1)), ("'n_links' given twice", "lines 2 and 4")),
        "duplicate-key-json": (raw(json.dumps(SMALL).replace('"n_links": 8', '"n_links": 8, '
                                                             '"n_links": 9'), "job.json"),
                               ("'n_links' given twice", "first 8, then 9")),
        "plan-document": (lambda folder, world: world.plan, "plan document"),
    }
    for name, (make, fragment) in files.items():
        add(f"plan-file-{name}", "plan {f} -o {out}", fragment, make)
    for command in ("check {f}", "simulate {f} -o {out}", "study {f} -o {out}",
                    "identify {f} -o {out}"):
        for name in ("dev-zero", "folder", "fifo", "binary", "deep-yaml", "empty"):
            make, fragment = files[name]
            add(f"{command.split()[0]}-file-{name}", command, fragment, make)

    # -- scenario fields -------------------------------------------------------------------
    fields = [
        ("n-links-3", "cable.n_links", 3, "cable.n_links"),
        ("n-links-5000", "cable.n_links", 5000, "cable.n_links"),
        ("n-links-text", "cable.n_links", "ten", "cable.n_links"),
        ("n-links-float", "cable.n_links", 10.5, "cable.n_links"),
        ("n-links-bool", "cable.n_links", True, "cable.n_links"),
        ("n-links-huge", "cable.n_links", 10 ** 30, "cable.n_links"),
        ("n-shapes-0", "planner.n_shapes", 0, "planner.n_shapes"),
        ("n-shapes-million", "planner.n_shapes", 10 ** 6, "planner.n_shapes"),
        ("n-shapes-negative", "planner.n_shapes", -1, "planner.n_shapes"),
        ("tcp-speed-negative", "trajectory.tcp_speed", -1, "trajectory.tcp_speed"),
        ("tcp-speed-zero", "trajectory.tcp_speed", 0, "trajectory.tcp_speed"),
        ("tcp-speed-nan", "trajectory.tcp_speed", NAN, "trajectory.tcp_speed"),
        ("tcp-speed-inf", "trajectory.tcp_speed", INF, "trajectory.tcp_speed"),
        ("tcp-speed-text", "trajectory.tcp_speed", "fast", "trajectory.tcp_speed"),
        ("tcp-speed-tiny", "trajectory.tcp_speed", 1e-300, "1e-300"),
        ("rate-huge", "trajectory.rate", 1e12, "trajectory.rate"),
        ("angular-speed-negative", "trajectory.angular_speed", -2, "trajectory.angular_speed"),
        ("position-nan", "start.placement.position", [NAN, 0, 0], "start"),
        ("position-inf", "start.placement.position", [INF, 0, 0], "start"),
        ("position-far", "start.placement.position", [1e12, -0.25, 0.2], "start"),
        ("position-text", "start.placement.position", ["a", 0, 0], "start"),
        ("position-2", "start.placement.position", [0.4, 0.2], "start"),
        ("position-nested", "start.placement.position", [[0, 0, 0]], "start"),
        ("euler-2", "start.placement.rotation", {"euler": [0, 90]}, "start"),
        ("quaternion-zero", "start.placement.rotation", {"quaternion": [0, 0, 0, 0]}, "start"),
        ("quaternion-nan", "start.placement.rotation", {"quaternion": [NAN, 0, 0, 1]},
         "start"),
        ("rotation-both", "start.placement.rotation", {"euler": [0, 0, 90],
                                                       "quaternion": [0, 0, 0, 1]}, "start"),
        ("cable-unknown", "cable.name", "spaghetti", "spaghetti"),
        ("length-negative", "cable.length", -0.5, "cable.length"),
        ("length-zero", "cable.length", 0, "cable.length"),
        ("length-huge", "cable.length", 1e9, "start"),
        ("diameter-zero", "cable.diameter", 0, "cable.diameter"),
        ("mass-negative", "cable.mass", -1, "cable.mass"),
        ("modulus-negative", "cable.youngs_modulus", -7e6, "cable.youngs_modulus"),
        ("modulus-identify-alone", "cable.youngs_modulus", "identify", "identify"),
        ("poisson-big", "cable.poisson_ratio", 0.9, "cable.poisson_ratio"),
        ("units-furlongs", "units", "furlongs", "units"),
        ("version-99", "version", 99, "version"),
        ("target-kind-unknown", "target.kind", "spiral", "target"),
        ("arc-angle-nan", "target.angle", NAN, "target"),
        ("arc-angle-huge", "target.angle", 1e9, "target"),
        ("sine-periods-zero", "target", {"kind": "sine", "amplitude": 0.05, "periods": 0},
         "target"),
        ("points-one", "target", {"kind": "points", "points": [[0.3, 0, 0.2]]}, "target"),
        ("points-nan", "target", {"kind": "points", "points": [[0.3, 0, 0.2], [NAN, 0, 0.2],
                                                               [0.5, 0, 0.2]]}, "target"),
        ("points-text", "target", {"kind": "points", "points": "many"}, "target"),
        ("obstacle-negative-size", "obstacles", [{"type": "box", "center": [0.4, 0, 0.05],
                                                  "size": [-0.1, 0.1, 0.1]}], "obstacles"),
        ("obstacle-both-forms", "obstacles", [{"type": "box", "center": [0.4, 0, 0.05],
                                               "size": [0.1, 0.1, 0.1], "min": [0, 0, 0],
                                               "max": [1, 1, 1]}], "obstacles"),
        ("obstacle-cylinder-radius-0", "obstacles", [{"type": "cylinder", "base": [0.3, 0, 0],
                                                      "radius": 0, "height": 0.04}],
         "obstacles"),
        ("obstacle-type-unknown", "obstacles", [{"type": "pyramid"}], "obstacles"),
        ("obstacles-not-list", "obstacles", "wall", "obstacles"),
        ("table-height-nan", "table.height", NAN, "table"),
        ("outputs-unknown", "outputs", ["json", "pdf"], "outputs"),
        ("outputs-text", "outputs", "json", "outputs"),
        ("gripper-method-unknown", "grippers.method", "magic", "grippers.method"),
        ("auxiliary-zero", "grippers.auxiliary_vector", [0, 0, 0], "grippers"),
        ("check-threshold-negative", "check.threshold", -1, "check.threshold"),
        ("max-rounds-huge", "check.max_rounds", 10 ** 9, "check.max_rounds"),
        ("weights-negative", "planner.weights", {"advanced": {"clip": -1}}, "planner.weights"),
        ("family-unknown", "planner.family", "jelly", "planner.family"),
        ("robot-preset-unknown", "robot", {"cell": {"preset": "r2d2"}}, "robot.cell.preset"),
        ("robot-preset-separation-text", "robot", {"cell": {"preset": "ur5e_pair",
                                                            "separation": "far"}},
         "robot.cell"),
        ("robot-preset-separation-negative", "robot", {"cell": {"preset": "ur5e_pair",
                                                                "separation": -1}},
         "separation"),
        ("robot-cell-text", "robot", {"cell": "yumi"}, "robot.cell"),
    ]
    for id_, path, value, fragment in fields:
        add(f"field-{id_}", "plan {f} -o {out}", fragment, job_with(setting(path, value)))

    # -- described cells and their URDFs ---------------------------------------------------
    urdfs = {
        "empty": (urdf_raw(""), "not a URDF file"),
        "truncated": (lambda folder, world: urdf_raw(world.urdf.read_text()[:3000])(folder,
                                                                                     world),
                      "not a URDF file"),
        "binary": (urdf_raw(b"\x89PNG\r\n\x1a\n\x00\x00\xff"), "not a text file"),
        "symlink-loop": (special("loop", "arm.urdf"), "symbolic links"),
        "folder": (special("folder", "arm.urdf"), "not a regular file"),
        "dev-zero": (special("zero"), "not a regular file"),
        "missing": (lambda folder, world: folder / "none.urdf", "No such file"),
        "yaml": (urdf_raw("cable: {name: pa12}\n"), "not a URDF file"),
        "not-robot": (urdf_raw("<launch><node/></launch>"), "expected <robot>"),
        "entity-bomb": (urdf_raw(BOMB_XML), "not"),
        "zero-axis": (urdf_edited('<axis xyz="0 0 1"/>', '<axis xyz="0 0 0"/>'), "axis"),
        "nan-origin": (urdf_edited('xyz="0 0 0.1625"', 'xyz="nan 0 0.1625"'), "origin"),
        "text-axis": (urdf_edited('<axis xyz="0 0 1"/>', '<axis xyz="a b c"/>'), "'a'"),
        "limits-reversed": (urdf_edited('lower="-3.141592653589793" upper="3.141592653589793"',
                                        'lower="3" upper="-3"'), "limits"),
        "velocity-negative": (urdf_edited('velocity="3.141592653589793" effort="150"',
                                          'velocity="-1" effort="150"'), "velocity"),
        "prismatic": (urdf_edited('type="revolute"', 'type="prismatic"'), "prismatic"),
        "cylinder-negative": (urdf_edited('<cylinder radius="0.065" length="0.07"/>',
                                          '<cylinder radius="-0.065" length="0.07"/>'),
                              "radius"),
        "no-joints": (urdf_raw('<robot name="x"><link name="base"/></robot>'), "tool0"),
        "huge": (lambda folder, world: raw("<robot>" + " " * 11_000_000 + "</robot>",
                                           "arm.urdf")(folder, world), "10 MB"),
    }
    for name, (make, fragment) in urdfs.items():
        add(f"urdf-{name}", "plan {f} -o {out}", ("robot.cell.arms.left", fragment),
            cell_job(urdf=make))
    arms = [
        ("home-text", "home_deg", "zero"), ("home-short", "home_deg", [0, 1]),
        ("home-nan", "home_deg", [0, 0, 0, 0, 0, NAN]), ("rpy-text", "base_rpy", "up"),
        ("rpy-nan", "base_rpy", [0, NAN, 0]), ("rpy-inf", "base_rpy", [0, INF, 0]),
        ("rpy-two", "base_rpy", [0, 0]), ("position-nan", "base_position", [0, NAN, 0]),
        ("position-text", "base_position", "here"), ("tcp-two", "tcp_offset", [0, 0]),
        ("radius-negative", "tool_radius", -1), ("radius-text", "tool_radius", "wide"),
        ("tip-missing", "tip_link", "nope"), ("tip-list", "tip_link", ["tool0"]),
        ("base-missing", "base_link", "nope"), ("along-unknown", "cable_along", "q"),
        ("urdf-list", "urdf", ["a.urdf"]), ("urdf-null", "urdf", None),
        ("unknown-key", "colour", "red"),
    ]
    for id_, key, value in arms:
        add(f"cell-{id_}", "plan {f} -o {out}", ("robot.cell.arms.left", key if key != "colour"
                                                   else "colour"),
            cell_job(arm_change=lambda arm, key=key, value=value: arm.__setitem__(key, value)))

    # -- plan documents ----------------------------------------------------------------------
    documents = {
        "dev-zero": (special("zero"), "not a regular file"),
        "dev-urandom": (special("urandom"), "not a regular file"),
        "folder": (special("folder", "plan.json"), "not a regular file"),
        "empty": (raw("", "plan.json"), "not a plan document"),
        "truncated": (plan_edited(None, text=lambda t: t[: len(t) // 2]), "JSON"),
        "yaml-job": (lambda folder, world: world.job, "plan"),
        "list": (raw("[1, 2]", "plan.json"), "plan"),
        "scenario-json": (raw(json.dumps(SMALL), "plan.json"), "plan"),
        "hand-edited-shape": (plan_edited(lambda d: d["shapes"][1][3].__setitem__(2, 0.5)),
                              "edited"),
        "hand-edited-speed": (plan_edited(lambda d: d["trajectory"].__setitem__(
            "max_speed", 10 * d["trajectory"]["max_speed"])), "edited"),
        "checksum-removed": (plan_edited(lambda d: d.pop("checksum", None)), "checksum"),
        "nan-literal": (plan_edited(lambda d: d["shapes"][1][2].__setitem__(0, NAN)), "edited"),
        "version-99": (plan_edited(lambda d: d.__setitem__("version", 99)), "edited"),
        "no-cable": (plan_edited(lambda d: d.pop("cable")), "edited"),
        "deep": (special("deep", "plan.json"), "nested too deeply"),
    }
    for name, (make, fragment) in documents.items():
        if name in ("yaml-job", "scenario-json"):  # verify plans a job file first: export not
            add(f"export-plan-{name}", "export {f} --format csv -o {out}", fragment, make)
        else:
            add(f"verify-plan-{name}", "verify {f}", fragment, make)
    for command in ("export {f} --format csv -o {out}", "simulate {f} -o {out}",
                    "correct {f} --at 1 --measured {measured} -o {out}",
                    "compare {f} {measured} -o {out}"):
        for name in ("dev-zero", "truncated", "hand-edited-shape", "checksum-removed",
                     "nan-literal"):
            make, fragment = documents[name]
            add(f"{command.split()[0]}-plan-{name}", command, fragment, make)

    # -- options -----------------------------------------------------------------------------
    options = [
        ("export-rate-zero", "export {plan} --format csv --rate 0 -o {out}", "--rate"),
        ("export-rate-negative", "export {plan} --format csv --rate -1 -o {out}", "--rate"),
        ("export-rate-nan", "export {plan} --format csv --rate nan -o {out}", "--rate"),
        ("export-rate-inf", "export {plan} --format csv --rate inf -o {out}", "--rate"),
        ("export-rate-text", "export {plan} --format csv --rate fast -o {out}", "--rate"),
        ("export-rate-huge", "export {plan} --format csv --rate 1e12 -o {out}", "--rate"),
        ("export-speed-tiny", "export {plan} --format csv --speed 1e-12 -o {out}", "--speed"),
        ("export-speed-zero", "export {plan} --format csv --speed 0 -o {out}", "--speed"),
        ("export-angular-negative", "export {plan} --format csv --angular-speed -1 -o {out}",
         "--angular-speed"),
        ("export-format-unknown", "export {plan} --format pdf -o {out}", "--format"),
        ("export-no-output", "export {plan} --format csv", "-o"),
        ("export-over-its-plan-json", "export {plan} --format json -o {plan}", "input"),
        ("export-report-over-plan", "export {plan} --format report -o {plan}", "input"),
        ("export-rapid-over-its-folder", "export {plan} --format rapid -o {world}/planned",
         "input"),
        ("verify-tolerance-zero", "verify {plan} --tolerance 0", "--tolerance"),
        ("verify-tolerance-nan", "verify {plan} --tolerance nan", "--tolerance"),
        ("verify-tensile-negative", "verify {plan} --tensile-limit -3", "--tensile-limit"),
        ("simulate-cap-negative", "simulate {plan} --modulus-cap -1", "--modulus-cap"),
        ("simulate-cap-nan", "simulate {plan} --modulus-cap nan", "--modulus-cap"),
        ("simulate-cap-text", "simulate {plan} --modulus-cap stiff", "--modulus-cap"),
        ("simulate-damping-unknown", "simulate {plan} --damping wet", "--damping"),
        ("simulate-over-its-plan", "simulate {plan} -o {world}/planned", "input"),
        ("design-nothing", "identify --design", "--cable"),
        ("design-both", "identify {ident} --design --cable ethernet", "not both"),
        ("design-points-zero", "identify --design --cable ethernet --points 0", "--points"),
        ("design-points-negative", "identify --design --cable ethernet --points -5",
         "--points"),
        ("design-points-billion", "identify --design --cable ethernet --points 1000000000",
         "--points"),
        ("design-points-text", "identify --design --cable ethernet --points many", "--points"),
        ("design-noise-negative", "identify --design --cable ethernet --noise -1", "--noise"),
        ("design-noise-zero", "identify --design --cable ethernet --noise 0", "--noise"),
        ("design-noise-nan", "identify --design --cable ethernet --noise nan", "--noise"),
        ("design-noise-inf", "identify --design --cable ethernet --noise inf", "--noise"),
        ("design-modulus-negative", "identify --design --cable ethernet --modulus -1",
         "--modulus"),
        ("design-modulus-nan", "identify --design --cable ethernet --modulus nan", "--modulus"),
        ("design-links-3", "identify --design --cable ethernet --links 3", "--links"),
        ("design-links-5000", "identify --design --cable ethernet --links 5000", "--links"),
        ("design-cable-unknown", "identify --design --cable spaghetti", "spaghetti"),
        ("identify-nothing", "identify", "experiment"),
        ("identify-over-its-file", "identify {ident} -o {ident}", "input"),
        ("cables-links-3", "cables --links 3", "--links"),
        ("cables-links-5000", "cables --links 5000", "--links"),
        ("cables-links-text", "cables --links ten", "--links"),
        ("study-samples-zero", "study {study} --samples 0 -o {out}", "samples"),
        ("study-samples-negative", "study {study} --samples -5 -o {out}", "samples"),
        ("study-samples-trillion", "study {study} --samples 1000000000000 -o {out}", "samples"),
        ("study-samples-text", "study {study} --samples many -o {out}", "--samples"),
        ("study-seed-negative", "study {study} --seed -1 -o {out}", "seed"),
        ("study-workers-zero", "study {study} --workers 0 -o {out}", "--workers"),
        ("study-workers-million", "study {study} --workers 1000000 -o {out}", "--workers"),
        ("study-scheduler-nonsense", "study {study} --scheduler nonsense -o {out}",
         "scheduler"),
        # local workers and a Dask cluster at once: the workers were ignored silently
        ("study-workers-and-scheduler",
         "study {study} --workers 2 --scheduler tcp://127.0.0.1:9 -o {out}", "not allowed with"),
        ("plan-workers-and-scheduler",
         "plan {job} {job} --workers 2 --scheduler tcp://127.0.0.1:9 -o {out}",
         "not allowed with"),
        ("study-over-its-scenario", "study {study} -o {study}", "input"),
        ("study-no-section", "study {job} -o {out}", "nothing to vary"),
        ("plan-workers-zero", "plan {job} {job} --workers 0 -o {out}", "--workers"),
        ("plan-workers-million", "plan {job} --workers 1000000 -o {out}", "--workers"),
        ("plan-over-its-job", "plan {job} -o {job}", "input"),
        ("plan-into-the-job-folder", "plan {job} -o {world}", "input"),
        ("correct-at-negative", "correct {plan} --at -1 --measured {measured} -o {out}",
         "--at"),
        ("correct-at-huge", "correct {plan} --at 1000000000 --measured {measured} -o {out}",
         "1000000000"),
        ("correct-at-text", "correct {plan} --at one --measured {measured} -o {out}", "--at"),
        ("correct-steps-negative", "correct {plan} --at 1 --measured {measured} "
         "--modulus-steps -1 -o {out}", "--modulus-steps"),
        ("correct-steps-billion", "correct {plan} --at 1 --measured {measured} "
         "--modulus-steps 1000000000 -o {out}", "--modulus-steps"),
        ("correct-over-its-plan", "correct {plan} --at 1 --measured {measured} -o "
         "{world}/planned", "input"),
        ("compare-plane-unknown", "compare {plan} {measured} --plane xw", "--plane"),
        ("register-links-zero", "register {f} --calibration {f} --hsv 0,0,0:1,1,1 --links 0 "
         "-o {out}", "--links"),
        ("register-links-billion", "register {f} --calibration {f} --hsv 0,0,0:1,1,1 --links "
         "1000000000 -o {out}", "--links"),
        ("register-height-nan", "register {f} --calibration {f} --hsv 0,0,0:1,1,1 --height nan "
         "-o {out}", "--height"),
        ("register-hsv-bad", "register {f} --calibration {f} --hsv red -o {out}", "--hsv"),
        ("register-hsv-reversed", "register {f} --calibration {f} --hsv 120,255,255:95,120,60 "
         "-o {out}", ("argument --hsv", "S range 255..120 is empty")),
        ("unknown-command", "launch", "launch"),
        ("unknown-option", "plan {job} --turbo", "--turbo"),
    ]
    for id_, argv, fragment in options:
        needs_file = "{f}" in argv
        add(id_, argv, fragment, raw("x", "image.png") if needs_file else None)

    # -- measured shapes (correct, compare) ------------------------------------------------------
    shapes = {
        "dev-zero": (special("zero"), "'/dev/zero'"),
        "missing": (lambda folder, world: folder / "none.csv", "No such file"),
        "folder": (special("folder", "measured.csv"), "not a regular file"),
        "empty": (raw("", "measured.csv"), "measured.csv"),
        "header-only": (shape_file([]), "measured.csv"),
        "nan": (shape_file(["0.3,0,0.2", "nan,0,0.2", "0.5,0,0.2"]), "measured.csv"),
        "text": (shape_file(["a,b,c", "0.4,0,0.2"]), "measured.csv"),
        "two-points": (shape_file(["0.35,-0.22,0.25", "0.45,-0.22,0.25"]), "measured"),
        "millimetres": (measured_scaled(1000.0), "mm"),
        "wrong-suffix": (raw("x", "measured.txt"), ".csv or .json"),
        "json-duplicate-key": (raw(json.dumps({"format": "dloplan-shapes", "units": "m",
                                               "shapes": []}).replace(
            '"units": "m"', '"units": "m", "units": "mm"'), "measured.json"),
            ("'units' given twice", "first 'm', then 'mm'")),
        "json-unknown-key": (raw(shapes_json({"colour": "red"}), "measured.json"),
                             ("unknown key 'colour'", "expected only")),
        "json-shape-unknown-key": (raw(shapes_json(shape={"colour": "red"}),
                                       "measured.json"),
                                   ("shapes[0]: unknown key 'colour'", "expected only")),
        "json-points-text": (raw(shapes_json(shape={"points": "many"}), "measured.json"),
                             ("shapes[0].points", "'many'", "expected a list")),
        "json-nan": (raw(shapes_json(shape={"points": [[0.3, 0, 0.2], [NAN, 0, 0.2],
                                                      [0.5, 0, 0.2]]}), "measured.json"),
                     ("shapes[0]", "point 1", "expected finite numbers")),
        "json-units-list": (raw(shapes_json({"units": [1]}), "measured.json"),
                            ("units [1]", "expected one of")),
        "huge": (lambda folder, world: raw("label,frame_id,x,y,z\n" + "xi_1,b,0,0,0\n" * 900_000,
                                           "measured.csv")(folder, world), "10 MB"),
        # round 9: pairs were read as planar points, booleans and texts as numbers
        "json-points-pairs": (raw(shapes_json(shape={"points": [[0.3, 0.2], [0.5, 0.2]]}),
                                  "measured.json"),
                              ("shapes[0].points[0]: got [0.3, 0.2]", "expected [x, y, z]")),
        "json-points-booleans": (raw(shapes_json(shape={"points": [[True, False, True],
                                                                   [0.5, 0, 0.2]]}),
                                     "measured.json"),
                                 ("shapes[0].points[0]: got [True, False, True]",)),
        "json-points-texts": (raw(shapes_json(shape={"points": [["0.3", "0", "0.2"],
                                                               [0.5, 0, 0.2]]}),
                                 "measured.json"), ("shapes[0].points[0]: got ['0.3'",)),
        "coordinate-huge": (shape_file(["0.3,0,0.2", "0.4,0,1e300", "0.5,0,0.2"]),
                            ("point 1 [0.4, 0.0, 1e+300]", "expected within 10 m")),
    }
    for name, (make, fragment) in shapes.items():
        add(f"correct-measured-{name}", "correct {plan} --at 1 --measured {f} -o {out}",
            fragment, make)
    for name in ("dev-zero", "missing", "nan", "text", "huge"):
        make, fragment = shapes[name]
        add(f"compare-shapes-{name}", "compare {plan} {f} -o {out}", fragment, make)

    # -- identification files -----------------------------------------------------------------
    identify = [
        ("bounds-reversed", lambda d: d["identify"].__setitem__("bounds", [1e9, 1e5]), "bounds"),
        ("bounds-negative", lambda d: d["identify"].__setitem__("bounds", [-1, 1e9]), "bounds"),
        ("simulator-unknown", lambda d: d["identify"].__setitem__("simulator", "guess"),
         "simulator"),
        ("substeps-huge", lambda d: d["identify"].__setitem__("substeps", 10 ** 9), "substeps"),
        ("noise-zero", lambda d: d["identify"].__setitem__("measurement_noise", 0),
         "measurement_noise"),
        ("no-trajectory", lambda d: d["identify"].__setitem__("trajectory", []), "trajectory"),
        ("measured-nan", lambda d: d["identify"]["measured_shape"][1].__setitem__(0, NAN),
         "measured_shape"),
        ("measured-one-point", lambda d: d["identify"].__setitem__(
            "measured_shape", d["identify"]["measured_shape"][:1]), "measured"),
        ("measured-both", lambda d: d["identify"].__setitem__("measured_file", {
            "path": "shapes.csv"}), "measured"),
        ("measured-file-dev-zero", lambda d: (d["identify"].pop("measured_shape"),
                                              d["identify"].__setitem__("measured_file", {
                                                  "path": "/dev/zero"})), "'/dev/zero'"),
        ("measured-file-missing", lambda d: (d["identify"].pop("measured_shape"),
                                             d["identify"].__setitem__("measured_file", {
                                                 "path": "none.csv"})), "No such file"),
        ("cable-unknown", lambda d: d["cable"].__setitem__("name", "spaghetti"), "spaghetti"),
        ("units-unknown", lambda d: d.__setitem__("units", "inch"), "units"),
    ]
    for id_, change, fragment in identify:
        add(f"identify-{id_}", "identify {f} -o {out}", fragment, identification_with(change))

    # -- study sections: refused before any work ------------------------------------------------
    studies = [
        ("correction-at-huge", lambda d: d["study"].__setitem__("correction", {"at": 99}),
         "correction.at"),
        ("correction-at-negative", lambda d: d["study"].__setitem__("correction", {"at": -1}),
         "correction.at"),
        ("chunk-zero", lambda d: d["study"].__setitem__("chunk_size", 0), "chunk_size"),
        ("parameter-unknown", lambda d: d["study"]["parameters"].__setitem__(
            "colour", {"spread": 1}), "colour"),
        ("spread-negative", lambda d: d["study"]["parameters"]["youngs_modulus"].__setitem__(
            "spread", -30), "spread"),
        ("criteria-negative", lambda d: d["study"]["criteria"].__setitem__("max_deviation", -1),
         "max_deviation"),
        ("confidence-two", lambda d: d["study"].__setitem__("confidence", 2), "confidence"),
        ("sampler-unknown", lambda d: d["study"].__setitem__("sampler", "dice"), "sampler"),
        ("section-samples-trillion", lambda d: d["study"].__setitem__("samples", 10 ** 12),
         "samples"),
        ("study-text", lambda d: d.__setitem__("study", "yes"), "study"),
    ]
    for id_, change, fragment in studies:
        add(f"study-{id_}", "study {f} -o {out}", fragment, study_with(change))

    # -- camera tooling -------------------------------------------------------------------------
    add("calibrate-image-dev-zero", "calibrate /dev/zero --intrinsics {f} --markers {f} -o "
        "{out}", "/dev/zero", raw("{}", "i.json"))
    add("calibrate-image-text", "calibrate {f} --intrinsics {f} --markers {f} -o {out}",
        "image", raw("not an image", "i.png"))
    add("calibrate-intrinsics-dev-zero", "calibrate {f} --intrinsics /dev/zero --markers {f} "
        "-o {out}", "/dev/zero", png)
    add("register-calibration-dev-zero", "register {f} --calibration /dev/zero --hsv "
        "0,0,0:1,1,1 -o {out}", "/dev/zero", raw("x", "i.png"))
    # round 9: a wrong type read as another value (success 'no' as true, fx true as 1 px,
    # marker_ids 'abc' as three ids), a number out of any camera's range (SVD did not
    # converge), a marker that can never be seen or given twice (the first pose lost)
    register = ("register {f}/image.png --calibration {f}/calibration.json --hsv 0,0,0:1,1,1 "
                "-o {out}")
    calibrate = ("calibrate {f}/image.png --intrinsics {f}/intrinsics.json --markers "
                 "{f}/layout.json -o {out}")
    camera = [
        ("calibration-success-text", "calibration", lambda d: d.__setitem__("success", "no"),
         ("calibration.json: success: got 'no'", "expected true or false")),
        ("calibration-rms-text", "calibration",
         lambda d: d.__setitem__("reprojection_rms_px", "small"),
         ("reprojection_rms_px: got 'small'", "expected a finite number")),
        ("calibration-marker-ids-text", "calibration",
         lambda d: d.__setitem__("marker_ids", "abc"), ("marker_ids: got 'abc'",)),
        ("calibration-translation-huge", "calibration",
         lambda d: d["camera_to_robot"]["translation"].__setitem__("z", 1e300),
         ("camera_to_robot.translation", "expected within 10 m")),
        ("calibration-truncated", "calibration", lambda d: json.dumps(d)[:200],
         ("calibration.json", "not valid JSON")),
        ("calibration-fx-true", "calibration",
         lambda d: d["intrinsics"].__setitem__("fx", True), ("intrinsics: fx: got True",)),
        ("calibration-distortion-nested", "calibration",
         lambda d: d["intrinsics"].__setitem__("distortion", [[0.1, 0.2], [0.0, 0.0]]),
         ("intrinsics: distortion: got [[0.1, 0.2]", "expected a list of 0, 4, 5 or 8")),
        ("calibration-distortion-text", "calibration",
         lambda d: d["intrinsics"].__setitem__("distortion", "none"),
         ("intrinsics: distortion: got 'none'",)),
    ]
    for id_, file, change, fragments in camera:
        add(f"register-{id_}", register, fragments, vision_files(change, file))
    intrinsics = [
        ("intrinsics-cx-huge", "intrinsics", lambda d: d.__setitem__("cx", 1e300),
         ("cx: got 1e+300", "expected a principal point within -8 .. 16 px")),
        ("intrinsics-fx-nan", "intrinsics", lambda d: d.__setitem__("fx", NAN),
         ("fx: got nan", "expected a focal length")),
        ("intrinsics-width-huge", "intrinsics", lambda d: d.__setitem__("width", 10 ** 9),
         ("width: got 1000000000", "expected an image size of 1 .. 100000")),
        ("layout-id-beyond-the-dictionary", "layout",
         lambda d: d["markers"][1].__setitem__("id", 10 ** 30),
         ("layout.json: marker id 1000000000000000000000000000000 is not in DICT_4X4_50",)),
        ("layout-id-twice", "layout", lambda d: d["markers"][1].__setitem__("id", 0),
         ("layout.json: markers[1].id: 0 given twice",)),
        ("layout-frame-list", "layout", lambda d: d.__setitem__("frame_id", ["robot_base"]),
         ("layout.json: frame_id: got ['robot_base']",)),
    ]
    for id_, file, change, fragments in intrinsics:
        add(f"calibrate-{id_}", calibrate, fragments, vision_files(change, file))
    return cases


CASES = _cases()
