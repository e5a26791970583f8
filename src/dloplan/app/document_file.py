"""The plan document's file: ``plan.json`` written and read (the document's types and its
JSON-ready data are :mod:`dloplan.pipeline.document`'s).

Floats are written with Python's shortest round-tripping repr, so a document read back is the
document written.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..io.files import atomic_write_text
from ..pipeline.document import PlanDocument, document_from_dict, document_to_dict


def json_default(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serializable: {type(value).__name__}")


def plan_json(doc: PlanDocument) -> str:
    """The plan document's JSON text (no NaN: a non-finite number is an error)."""
    try:
        return json.dumps(document_to_dict(doc), indent=1, allow_nan=False,
                          default=json_default) + "\n"
    except ValueError as exc:
        raise ValueError(f"plan: not writable as JSON ({exc})") from None


def write_plan(path: str | os.PathLike, doc: PlanDocument) -> Path:
    """Write the plan document atomically to ``path`` (JSON); returns the path."""
    return atomic_write_text(path, plan_json(doc))


def read_plan(path: str | os.PathLike) -> PlanDocument:
    """Read a plan document written by :func:`write_plan` (or a version 1 file).

    Raises
    ------
    ValueError
        When the file cannot be read, is not valid JSON or not a plan document (naming the
        field).
    """
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        if Path(path).suffix.lower() in (".yaml", ".yml"):
            raise ValueError(f"{path}: a YAML job file, not a plan document: plan it first "
                             "(dloplan plan JOB -o OUT) and give OUT/plan.json") from None
        raise ValueError(f"{path}: not a plan document (not valid JSON: {exc})") from None
    return document_from_dict(data)
