"""Decimate the robots' public visual meshes into the compact files the HTML report embeds.

An offline tool, run by hand when a mesh source changes (never at test time); its output,
``src/dloplan/robot/data/meshes/<model>.npz``, is package data. Per model it reads the visual
meshes of the public description (sources, commits and licences in :data:`MODELS`), places each
in the frame of the URDF link it belongs to (the visual origin, and for the gripper the fixed
joints from the arm's last moving link), drops stray specks, merges the pieces of one colour,
decimates them (MeshLab's quadric edge collapse, ``pymeshlab``), splits vertices at creases
(35 deg) for flat-where-sharp shading, and quantizes:

- positions: uint16 per axis over the mesh's bounding box (``bounds`` (2, 3) float32 [m]);
- normals: int8 per axis (x 127);
- triangles: uint16 (uint32 above 65535 vertices) vertex indices.

The npz also holds ``manifest`` (JSON as uint8): the model's source, licence, the moving joints
of its chain as dloplan reads them from the vendored URDF (name, origin xyz [m], origin
quaternion x-y-z-w, axis) for matching an arm to its meshes, and its parts (mesh, the moving
joint whose child link carries it or null for the base link, the fixed transform mesh-to-link,
the colour), so that the report draws each part at ``link_to_world(q) @ mesh_to_link``.

Needs, besides dloplan's ``robot`` extra: ``pip install pycollada pymeshlab``.
Usage (the three repositories checked out at the commits of :data:`MODELS`)::

    python tools/build_robot_meshes.py --checkout OrebroUniversity/yumi=DIR \
        --checkout UniversalRobots/Universal_Robots_ROS2_Description=DIR \
        --checkout frankaemika/franka_ros=DIR

It prints per model the triangles kept and the file size.
"""

from __future__ import annotations

import argparse
import io
import json
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from dloplan.robot.description import load_arm, vendored

OUT = Path(__file__).resolve().parents[1] / "src" / "dloplan" / "robot" / "data" / "meshes"
CREASE = np.radians(35.0)
"""Edges sharper than this keep separate normals on either side."""
SPECK = 0.01
"""Connected pieces with fewer than this fraction of a mesh's triangles are dropped (stray
triangles far off in the YuMi's link_6.stl, tiny screws)."""
PI = np.pi


def pose(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> np.ndarray:
    """4x4 transform of a URDF ``<origin xyz rpy>`` (rpy: fixed axes x, y, z)."""
    t = np.eye(4)
    t[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()
    t[:3, 3] = xyz
    return t


def chain(*transforms) -> np.ndarray:
    """The product of 4x4 transforms, left to right (parent to child)."""
    out = np.eye(4)
    for t in transforms:
        out = out @ t
    return out


# YuMi gripper (yumi_description/urdf/yumi.urdf): yumi_link_7_* -> gripper_*_base fixed at
# z 7 mm turned by pi; fingers on prismatic joints at (0, -+6.5 mm, 83.7 mm), the second turned
# by pi, both opening along -x; drawn closed (0 mm).
YUMI_GRIPPER = pose((0, 0, 0.007), (0, 0, PI))
YUMI_FINGERS = (chain(YUMI_GRIPPER, pose((0, -0.0065, 0.0837))),
                chain(YUMI_GRIPPER, pose((0, 0.0065, 0.0837), (0, 0, PI))))
# Franka Hand (franka_description/robots/common/franka_{robot,hand}.xacro): panda_link7 ->
# panda_link8 (z 107 mm) -> panda_hand (yaw -pi/4); fingers at z 58.4 mm, opening along +-y
# (drawn 10 mm open each, a clip between them), the right finger's mesh turned by pi.
PANDA_HAND = chain(pose((0, 0, 0.107)), pose(rpy=(0, 0, -PI / 4)))
PANDA_OPEN = 0.01
PANDA_FINGERS = (chain(PANDA_HAND, pose((0, PANDA_OPEN, 0.0584))),
                 chain(PANDA_HAND, pose((0, -PANDA_OPEN, 0.0584)), pose(rpy=(0, 0, PI))))
YUMI_LINKS = {1: "1", 2: "2", 3: "7", 4: "3", 5: "4", 6: "5", 7: "6"}
"""YuMi link k is the child of joint yumi_joint_<n>_* (joints named by ABB axis number)."""
GREY, LIGHT_GREY = (0.5, 0.5, 0.5), (0.8, 0.8, 0.8)  # yumi_description's materials
FINGER_GREY = (0.22, 0.25, 0.28)
"""The YuMi fingers' colour: the description's "Blue" would read as the cable in the report."""

MODELS = {
    "yumi": {
        "title": "ABB YuMi (IRB 14000) with SmartGrippers",
        "repository": "OrebroUniversity/yumi",
        "commit": "fb7f57df05444e6a28df6eda26034de730b8f8fe",
        "licence": "BSD-2-Clause, LICENSE-yumi_description",
        "urdf": ("yumi.urdf", [("yumi_link_7_l", "yumi_body"), ("yumi_link_7_r", "yumi_body")]),
        "folder": "yumi_description/meshes",
        # (mesh name, file, target triangles, colour); body, link_2 and the gripper base only
        # as the description's coarse meshes (the fine ones are Git LFS objects not mirrored)
        "meshes": [("body", "coarse/body.stl", 2000, LIGHT_GREY)]
        + [(f"link_{k}", f"link_{k}.stl" if k != 2 else "coarse/link_2.stl", 2400, GREY)
           for k in range(1, 7)]
        + [("link_7", "link_7.stl", 600, GREY),
           ("gripper_base", "gripper/coarse/base.stl", 1200, LIGHT_GREY),
           ("finger", "gripper/finger.stl", 300, FINGER_GREY)],
        "parts": [("body", None, np.eye(4))]
        + [(f"link_{k}", f"yumi_joint_{YUMI_LINKS[k]}_{s}", np.eye(4))
           for s in "lr" for k in range(1, 8)]
        + [(name, f"yumi_joint_6_{s}", t) for s in "lr"
           for name, t in (("gripper_base", YUMI_GRIPPER), ("finger", YUMI_FINGERS[0]),
                           ("finger", YUMI_FINGERS[1]))],
        "gripper": True,
    },
    "ur5e": {
        "title": "Universal Robots UR5e",
        "repository": "UniversalRobots/Universal_Robots_ROS2_Description",
        "commit": "2221ec0f720fb1af99339eb891639b499b62f1da",
        "licence": "BSD-3-Clause, LICENSE-ur_description",
        "urdf": ("ur5e.urdf", [("tool0", None)]),
        "folder": "meshes/ur5e/visual",
        "meshes": [("base", "base.dae", 1500, None), ("shoulder", "shoulder.dae", 2000, None),
                   ("upperarm", "upperarm.dae", 3500, None),
                   ("forearm", "forearm.dae", 3000, None), ("wrist1", "wrist1.dae", 1800, None),
                   ("wrist2", "wrist2.dae", 1800, None), ("wrist3", "wrist3.dae", 600, None)],
        # urdf/ur_macro.xacro visual origins (shoulder_offset 0.138, elbow_offset 0.007 and the
        # wrists' visual_offset from config/ur5e/*.yaml); the vendored root "base" is
        # ur_description's base_link_inertia (base_link turned by pi)
        "parts": [("base", None, pose(rpy=(0, 0, PI))),
                  ("shoulder", "shoulder_pan_joint", pose(rpy=(0, 0, PI))),
                  ("upperarm", "shoulder_lift_joint", pose((0, 0, 0.138), (PI / 2, 0, -PI / 2))),
                  ("forearm", "elbow_joint", pose((0, 0, 0.007), (PI / 2, 0, -PI / 2))),
                  ("wrist1", "wrist_1_joint", pose((0, 0, -0.127), (PI / 2, 0, 0))),
                  ("wrist2", "wrist_2_joint", pose((0, 0, -0.0997))),
                  ("wrist3", "wrist_3_joint", pose((0, 0, -0.0989), (PI / 2, 0, 0)))],
        "gripper": False,
    },
    "panda": {
        "title": "Franka Emika Panda with the Franka Hand",
        "repository": "frankaemika/franka_ros",
        "commit": "c11f000c2737acc22ed8dfeff40555b2644a4294",
        "licence": "Apache-2.0, LICENSE-franka_description",
        "urdf": ("panda.urdf", [("panda_hand", "panda_link0")]),
        "folder": "franka_description/meshes/visual",
        "meshes": [("link0", "link0.dae", 2500, None)]
        + [(f"link{k}", f"link{k}.dae", 2200, None) for k in range(1, 8)]
        + [("hand", "hand.dae", 1500, None), ("finger", "finger.dae", 300, None)],
        "parts": [("link0", None, np.eye(4))]
        + [(f"link{k}", f"panda_joint{k}", np.eye(4)) for k in range(1, 8)]
        + [("hand", "panda_joint7", PANDA_HAND), ("finger", "panda_joint7", PANDA_FINGERS[0]),
           ("finger", "panda_joint7", PANDA_FINGERS[1])],
        "gripper": True,
    },
}


def colour_pieces(path: Path, colour) -> list[tuple[tuple, object]]:
    """The mesh file as (colour (r, g, b) in 0..1, trimesh) pieces, one per material colour
    (a COLLADA file's materials; ``colour`` for an STL), specks dropped."""
    import trimesh

    scene = trimesh.load(path, force="scene")
    pieces: dict[tuple, list] = {}
    for geometry in scene.dump():
        if colour is not None:
            rgb = tuple(colour)
        else:
            material = getattr(geometry.visual, "material", None)
            diffuse = getattr(material, "diffuse", None)
            if diffuse is None:
                diffuse = getattr(material, "baseColorFactor", None)
            rgb = tuple(np.round(np.asarray(diffuse[:3], float) / 255.0, 3))
        pieces.setdefault(rgb, []).append(trimesh.Trimesh(geometry.vertices, geometry.faces,
                                                          process=True))
    total = sum(len(m.faces) for ms in pieces.values() for m in ms)
    out = []
    for rgb, meshes in pieces.items():
        merged = trimesh.util.concatenate(meshes)
        kept = [c for c in merged.split(only_watertight=False)
                if len(c.faces) >= SPECK * total]
        if kept:
            out.append((rgb, trimesh.util.concatenate(kept)))
    return out


def decimate(mesh, target: int):
    """The mesh with about ``target`` triangles (unchanged when it has fewer): MeshLab's
    quadric edge collapse (``fast-simplification`` stalls at 4-5x on these CAD meshes)."""
    import pymeshlab
    import trimesh

    if len(mesh.faces) <= target:
        return mesh
    meshes = pymeshlab.MeshSet()
    meshes.add_mesh(pymeshlab.Mesh(np.asarray(mesh.vertices, float), np.asarray(mesh.faces)))
    meshes.meshing_merge_close_vertices()
    meshes.meshing_decimation_quadric_edge_collapse(
        targetfacenum=target, preservenormal=True, qualitythr=0.3, planarquadric=True,
        autoclean=True)
    out = meshes.current_mesh()
    return trimesh.Trimesh(out.vertex_matrix(), out.face_matrix(), process=True)


def deviation(original, small) -> float:
    """Largest distance [m] of 4000 points sampled on ``original`` from ``small``."""
    import trimesh

    points = original.sample(4000, seed=0)
    return float(np.abs(trimesh.proximity.signed_distance(small, points)).max())


def quantized(mesh) -> dict[str, np.ndarray]:
    """Positions (uint16 over ``bounds``), creased normals (int8) and triangles."""
    import trimesh

    shaded = trimesh.graph.smooth_shade(mesh, angle=CREASE)
    vertices = np.asarray(shaded.vertices, float)
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    positions = np.round((vertices - lo) / span * 65535.0).astype(np.uint16)
    normals = np.round(127.0 * np.asarray(shaded.vertex_normals, float)).astype(np.int8)
    dtype = np.uint16 if len(vertices) <= 65536 else np.uint32
    return {"positions": positions, "normals": normals,
            "indices": np.asarray(shaded.faces).astype(dtype),
            "bounds": np.array([lo, lo + span], np.float32)}


def chain_record(model: dict) -> list[dict]:
    """The moving joints of the model's vendored URDF as dloplan reads them (for matching)."""
    filename, tips = model["urdf"]
    joints = {}
    for tip, base in tips:
        d = load_arm(vendored(filename), tip, base_link=base)
        for i, name in enumerate(d.joint_names):
            joints[name] = {"name": name, "xyz": d.origin_xyz[i].tolist(),
                            "quaternion": Rotation.from_matrix(d.origin_rot[i]).as_quat().tolist(),
                            "axis": d.axes[i].tolist()}
    return list(joints.values())


def build(name: str, model: dict, checkout: Path) -> Path:
    """Write ``OUT/<name>.npz``; returns its path."""
    arrays: dict[str, np.ndarray] = {}
    meshes = {}
    for mesh_name, filename, target, colour in model["meshes"]:
        pieces = colour_pieces(checkout / model["folder"] / filename, colour)
        faces = sum(len(m.faces) for _, m in pieces)
        records, worst = [], 0.0
        for k, (rgb, mesh) in enumerate(pieces):
            share = max(24, round(target * len(mesh.faces) / faces))
            small = decimate(mesh, share)
            worst = max(worst, deviation(mesh, small))
            key = f"{mesh_name}.{k}"
            for field, values in quantized(small).items():
                arrays[f"{key}/{field}"] = values
            records.append({"key": key, "colour": list(rgb), "triangles": len(small.faces)})
        meshes[mesh_name] = {"file": f"{model['folder']}/{filename}", "pieces": records,
                             "deviation": round(worst, 5)}
        print(f"  {mesh_name}: {faces} -> {sum(r['triangles'] for r in records)} triangles, "
              f"largest deviation {1e3 * worst:.1f} mm")
    parts = [{"mesh": mesh, "joint": joint,
              "xyz": t[:3, 3].round(9).tolist(),
              "quaternion": Rotation.from_matrix(t[:3, :3]).as_quat().round(12).tolist()}
             for mesh, joint, t in model["parts"]]
    manifest = {"model": name, "title": model["title"], "repository": model["repository"],
                "commit": model["commit"], "licence": model["licence"],
                "gripper": model["gripper"], "joints": chain_record(model), "parts": parts,
                "meshes": meshes}
    arrays["manifest"] = np.frombuffer(json.dumps(manifest).encode(), dtype=np.uint8)
    OUT.mkdir(parents=True, exist_ok=True)
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    path = OUT / f"{name}.npz"
    path.write_bytes(buffer.getvalue())
    triangles = sum(p["triangles"] for m in meshes.values() for p in m["pieces"])
    print(f"{name}: {len(meshes)} meshes, {triangles} triangles, {path.stat().st_size} bytes")
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkout", action="append", default=[], metavar="REPO=DIR",
                        help="a checkout of a source repository (owner/name=folder)")
    parser.add_argument("models", nargs="*", default=list(MODELS), help="models to build")
    args = parser.parse_args()
    folders = dict(item.split("=", 1) for item in args.checkout)
    for name in args.models:
        model = MODELS[name]
        if model["repository"] not in folders:
            parser.error(f"{name}: give --checkout {model['repository']}=DIR")
        build(name, model, Path(folders[model["repository"]]))


if __name__ == "__main__":
    main()
