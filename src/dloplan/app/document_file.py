"""The plan document's file: ``plan.json`` written and read (the document's types and its
JSON-ready data are :mod:`dloplan.pipeline.document`'s).

Floats are written with Python's shortest round-tripping repr, so a document read back is the
document written. The file records a checksum of its content (``"checksum": "sha256:..."``, the
SHA-256 of its data as canonical JSON: sorted keys, no spaces, the checksum left out), so that a
document changed after dloplan wrote it is recognised: :func:`read_plan` refuses it (and one
without a checksum), with one line. Version 1 documents, from before checksums, are read as they
are, but an edit to one cannot be detected: the commands that read a plan say so in one warning
line and exit 1 at least (:func:`unchecked_warning`). A plan is what was planned and verified; a
hand edit (a shape, a time, a pose) would be verified, exported or corrected as if it had been:
plan the job again instead (``export --speed`` re-times a plan). Whitespace and key order are not
content.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

from ..bounds import MAX_PLAN_BYTES
from ..inputs import read_text
from ..output_files import atomic_write_text
from ..pipeline.document import PLAN_FORMAT, PlanDocument, document_from_dict, document_to_dict


def json_default(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serializable: {type(value).__name__}")


CHECKSUM = "checksum"
"""The key of the content's checksum in a plan file."""


def content_checksum(data: dict) -> str:
    """``sha256:<hex>`` of a plan file's data (parsed JSON) without its checksum: canonical
    JSON, sorted keys, no whitespace."""
    content = {key: value for key, value in data.items() if key != CHECKSUM}
    text = json.dumps(content, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return "sha256:" + hashlib.sha256(text.encode("utf-8")).hexdigest()


def plan_json(doc: PlanDocument) -> str:
    """The plan document's JSON text with its checksum (no NaN: a non-finite number is an
    error)."""
    try:
        text = json.dumps(document_to_dict(doc), allow_nan=False, default=json_default)
    except ValueError as exc:
        raise ValueError(f"plan: not writable as JSON ({exc})") from None
    data = json.loads(text)  # what a reader will parse: the checksum is of that
    return json.dumps({**data, CHECKSUM: content_checksum(data)}, indent=1) + "\n"


CHECKED_VERSION = 2
"""The first plan document version with a checksum."""


def unchecked_warning(path, doc: PlanDocument) -> str | None:
    """The warning for a plan document read from ``path`` whose edits cannot be detected (a
    version before :data:`CHECKED_VERSION`: no checksum), else None."""
    if doc.version >= CHECKED_VERSION:
        return None
    return (f"{path}: a version-{doc.version} plan document has no checksum, so an edit to it "
            "cannot be detected: re-plan to get a checked document (dloplan plan)")


def write_plan(path: str | os.PathLike, doc: PlanDocument) -> Path:
    """Write the plan document atomically to ``path`` (JSON); returns the path."""
    return atomic_write_text(path, plan_json(doc))


def read_plan(path: str | os.PathLike) -> PlanDocument:
    """Read a plan document written by :func:`write_plan` (or a version 1 file).

    Raises
    ------
    ValueError
        When the file cannot be read, is not valid JSON or not a plan document (naming the
        field), or its content is not what dloplan wrote (:func:`check_checksum`).
    """
    return plan_from_data(path, read_plan_data(path))


def read_plan_data(path: str | os.PathLike):
    """The parsed JSON of a plan file (bounded: :data:`dloplan.bounds.MAX_PLAN_BYTES`), not yet
    checked to be a plan document (:func:`plan_from_data`)."""
    try:
        return json.loads(read_text(path, MAX_PLAN_BYTES, "plan document"))
    except RecursionError:
        raise ValueError(f"{path}: nested too deeply to be a plan document") from None
    except json.JSONDecodeError as exc:
        if Path(path).suffix.lower() in (".yaml", ".yml"):
            raise ValueError(f"{path}: a YAML job file, not a plan document: plan it first "
                             "(dloplan plan JOB -o OUT) and give OUT/plan.json") from None
        raise ValueError(f"{path}: not a plan document (not valid JSON: {exc})") from None


def plan_from_data(path, data) -> PlanDocument:
    """The plan document of a plan file's parsed data, its checksum checked."""
    check_checksum(path, data)
    if isinstance(data, dict):
        data = {key: value for key, value in data.items() if key != CHECKSUM}
    return document_from_dict(data)


def check_checksum(path, data) -> None:
    """Refuse a plan file whose content is not what dloplan wrote (see the module docstring).

    Raises
    ------
    ValueError
        One line naming the file: no checksum, or one that does not match the content.
    """
    if not isinstance(data, dict) or data.get("format") != PLAN_FORMAT or \
            data.get("version") == 1:
        return  # not a plan document at all (document_from_dict says so), or one from before
    recorded = data.get(CHECKSUM)
    if recorded is None:
        raise ValueError(f"{path}: the plan document has no checksum (written by hand, or by a "
                         "dloplan before checksums): plan the job again (dloplan plan)")
    try:
        actual = content_checksum(data)
    except ValueError:  # NaN or an infinity: json.dumps(allow_nan=False) writes neither
        actual = None
    if recorded != actual:
        raise ValueError(f"{path}: the plan document was edited after dloplan wrote it (its "
                         f"checksum {str(recorded)[:19]}... does not match its content): plan "
                         "the job again (dloplan plan; export --speed re-times a plan)")
