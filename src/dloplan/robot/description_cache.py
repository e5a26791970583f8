"""Parsed robot descriptions kept on disk, so that a run reads a URDF without parsing it.

Reading a URDF arm (:func:`dloplan.robot.description.load_arm`) imports ``yourdfpy``, which
imports ``trimesh``, ``networkx``, ``lxml``, PIL and shapely: about 0.17 s of CPU (500 modules)
in every ``dloplan`` run on a described cell, for a parse of about 2 ms. The parse's result
(the chain's arrays and names before :class:`~dloplan.robot.description.ArmDescription` is
made of them) is kept here, under a key of everything it depends on:

- the URDF's text, its resolved path (relative mesh files are found beside it) and the
  arguments of the read (tip and base link, the ``package://`` folders);
- the content of every mesh file the parse looked for (a BLAKE2b digest; a file that was
  missing is recorded as missing): checked when the entry is read, so an entry whose mesh
  changed, appeared or went is not used.

A changed description is therefore parsed again (and its new entry kept); an entry is used
only when all of this is equal, so what :func:`load_arm` returns is the same, array for array,
as parsing. Entries are ``.npz`` files (no pickle) in ``__pycache__/descriptions`` beside this
module, written atomically; at most :data:`MAX_ENTRIES` are kept (the oldest go). A folder that
cannot be written, or an entry that cannot be read, costs a parse, never an error.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
from pathlib import Path

import numpy as np

from ..output_files import atomic_file

FOLDER = Path(__file__).resolve().parent / "__pycache__" / "descriptions"
"""Where the entries are kept."""

FORMAT = 1
"""Version of the entries' layout and of the parse they keep (part of every key): raise it when
:func:`~dloplan.robot.description.load_arm` parses differently."""

MAX_ENTRIES = 64
"""Entries kept at most (tests and user cells write new ones; the oldest are removed)."""

ARRAYS = ("origin_xyz", "origin_rot", "axes", "lower", "upper", "max_velocity", "tip_xyz",
          "tip_rot", "capsules", "capsule_link", "radii")
"""The parse's array fields (the rest: ``joint_names``, ``base_link``, ``tip_link``)."""


def digest(data: bytes) -> str:
    """BLAKE2b hex digest (16 bytes) of ``data``."""
    return hashlib.blake2b(data, digest_size=16).hexdigest()


def file_digest(path: str) -> str | None:
    """:func:`digest` of a file's content, None when it is not a readable regular file."""
    try:
        with open(path, "rb") as handle:
            return digest(handle.read())
    except OSError:
        return None


def entry_key(path: Path, text: str, tip_link: str, base_link: str | None,
              package_dirs: dict[str, str] | None) -> str:
    """The key of a parse: the URDF's resolved path and text, the read's arguments."""
    parts = {"format": FORMAT, "path": str(path.resolve()), "tip_link": tip_link,
             "base_link": base_link, "package_dirs": sorted((str(package), str(folder))
                                  for package, folder in (package_dirs or {}).items())}
    return digest(json.dumps(parts).encode() + b"\0" + text.encode("utf-8"))


def load(key: str, folder: Path | None = None) -> dict | None:
    """The kept parse of ``key`` (the fields of :func:`save`), or None when there is none, it
    cannot be read, or a mesh file it was made from changed."""
    try:
        with np.load((folder or FOLDER) / f"{key}.npz", allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            fields = {name: data[name] for name in ARRAYS}
    except (OSError, ValueError, KeyError):
        return None
    if meta.get("format") != FORMAT:
        return None
    if any(file_digest(mesh) != known for mesh, known in meta["meshes"]):
        return None
    return {**fields, "joint_names": tuple(meta["joint_names"]),
            "base_link": meta["base_link"], "tip_link": meta["tip_link"]}


def save(key: str, fields: dict, meshes: dict[str, str | None],
         folder: Path | None = None) -> None:
    """Keep a parse: ``fields`` (:data:`ARRAYS`, ``joint_names``, ``base_link``,
    ``tip_link``), ``meshes`` the mesh files it looked for -> their digest (None: missing).
    Nothing is kept (and nothing raised) where the folder cannot be written."""
    folder = folder or FOLDER
    meta = {"format": FORMAT, "joint_names": list(fields["joint_names"]),
            "base_link": fields["base_link"], "tip_link": fields["tip_link"],
            "meshes": sorted(meshes.items(), key=lambda item: item[0])}
    try:
        with atomic_file(folder / f"{key}.npz") as temp, open(temp, "wb") as handle:
            np.savez(handle, meta=np.array(json.dumps(meta)),
                     **{name: np.asarray(fields[name]) for name in ARRAYS})
        prune(folder)
    except OSError:
        pass


def prune(folder: Path, keep: int = MAX_ENTRIES) -> None:
    """Remove the oldest entries of ``folder`` beyond ``keep`` (by modification time)."""
    entries = []
    for entry in folder.glob("*.npz"):
        with contextlib.suppress(OSError):
            entries.append((entry.stat().st_mtime_ns, entry))
    for _, entry in sorted(entries)[:max(0, len(entries) - keep)]:
        with contextlib.suppress(OSError):
            entry.unlink()
