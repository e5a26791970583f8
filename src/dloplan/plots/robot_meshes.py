"""The robots' visual meshes for the HTML report: which arm is which robot, and its parts.

The meshes ship as package data in ``dloplan/robot/data/meshes/<model>.npz`` (YuMi, UR5e,
Panda; made by ``tools/build_robot_meshes.py`` from the public descriptions, sources and
licences in ``dloplan/robot/data/README.md``): per mesh quantized positions, normals and
triangles, and a manifest with the model's moving joints (as dloplan reads them from the
vendored URDF) and its parts (mesh, the joint whose child link carries it, the fixed
mesh-to-link transform).

An arm is drawn with a model's meshes when every one of its joints is a joint of the model with
the same origin and axis (so a URDF that only borrows joint names gets no wrong meshes); else the
report draws the arm's capsules.
"""

from __future__ import annotations

import base64
import json
from functools import cache
from importlib import resources

import numpy as np
from scipy.spatial.transform import Rotation

MODELS = ("yumi", "ur5e", "panda")
"""The models with meshes in ``dloplan/robot/data/meshes``."""

MATCH_TOLERANCE = 1e-6
"""[m] and [rad]: how far an arm's joint origin or axis may be from the model's."""


@cache
def load_model(name: str) -> tuple[dict, dict[str, np.ndarray]]:
    """The manifest and the arrays (``"<piece>/<field>"``) of a model's mesh file."""
    if name not in MODELS:
        raise ValueError(f"name: expected one of {MODELS}, got {name!r}")
    source = resources.files("dloplan.robot").joinpath("data", "meshes", f"{name}.npz")
    with source.open("rb") as file, np.load(file) as data:
        arrays = {key: data[key] for key in data.files}
    manifest = json.loads(arrays.pop("manifest").tobytes())
    return manifest, arrays


def _same_joint(mine: dict, theirs: dict) -> bool:
    turn = (Rotation.from_quat(mine["quaternion"]).inv()
            * Rotation.from_quat(theirs["quaternion"])).magnitude()
    return bool(np.allclose(mine["xyz"], theirs["xyz"], atol=MATCH_TOLERANCE)
                and np.allclose(mine["axis"], theirs["axis"], atol=MATCH_TOLERANCE)
                and turn < MATCH_TOLERANCE)


def match_model(joints) -> str | None:
    """The model whose meshes fit an arm's chain, or None.

    Parameters
    ----------
    joints : sequence of dict
        The arm's moving joints, base to tip: ``name``, ``xyz`` (3,) origin [m] and
        ``quaternion`` (4,) x-y-z-w origin rotation in the parent link's frame, ``axis`` (3,).
    """
    for name in MODELS:
        manifest, _ = load_model(name)
        known = {joint["name"]: joint for joint in manifest["joints"]}
        if all(j["name"] in known and _same_joint(j, known[j["name"]]) for j in joints):
            return name
    return None


def model_parts(name: str, joint_names) -> tuple[list[dict], bool]:
    """The parts of model ``name`` an arm with these joints carries, and whether they include
    its gripper.

    Each part: ``mesh`` (a key of :func:`encoded_meshes`), ``link`` (the index of the moving
    joint whose child link carries it in ``joint_names``, -1 for the base link), ``xyz`` and
    ``quaternion`` (x-y-z-w) of the mesh in that link's frame.
    """
    manifest, _ = load_model(name)
    index = {joint: i for i, joint in enumerate(joint_names)}
    parts = [{"mesh": f"{name}/{part['mesh']}",
              "link": -1 if part["joint"] is None else index[part["joint"]],
              "xyz": part["xyz"], "quaternion": part["quaternion"]}
             for part in manifest["parts"] if part["joint"] is None or part["joint"] in index]
    return parts, bool(manifest["gripper"])


def _base64(values: np.ndarray) -> str:
    """The array's bytes, little-endian, as base64."""
    little = np.ascontiguousarray(values, dtype=values.dtype.newbyteorder("<"))
    return base64.b64encode(little.tobytes()).decode("ascii")


def encoded_meshes(keys) -> dict[str, list[dict]]:
    """The meshes ``"<model>/<mesh>"`` for the page: per mesh its pieces (one per colour),
    each with ``colour`` (r, g, b in 0..1), ``bounds`` (2, 3) [m] and the base64 of its
    little-endian arrays ``positions`` (uint16, (V, 3), over the bounds), ``normals`` (int8,
    (V, 3), x 127) and ``indices`` (uint16 or uint32 per ``index_bytes``, (T, 3))."""
    out = {}
    for key in sorted(set(keys)):
        model, mesh = key.split("/", 1)
        manifest, arrays = load_model(model)
        pieces = []
        for piece in manifest["meshes"][mesh]["pieces"]:
            name = piece["key"]
            indices = arrays[f"{name}/indices"]
            pieces.append({
                "colour": piece["colour"],
                "bounds": arrays[f"{name}/bounds"].astype(float).round(6).tolist(),
                "index_bytes": indices.dtype.itemsize,
                **{field: _base64(arrays[f"{name}/{field}"])
                   for field in ("positions", "normals", "indices")}})
        out[key] = pieces
    return out


def credits(models) -> list[str]:
    """One line per model drawn: what it is, where its meshes come from, their licence."""
    lines = []
    for name in sorted(set(models)):
        m, _ = load_model(name)
        lines.append(f"{m['title']}: visual meshes from github.com/{m['repository']} "
                     f"({m['commit'][:7]}), {m['licence']}, decimated")
    return lines
