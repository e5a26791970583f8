"""The study table on disk: one file per chunk, a manifest, and the final concatenation.

A study table is tidy: one row per sample and shape, columns as plain numpy arrays
(``dict[str, numpy.ndarray]``; no pandas needed). A study folder holds::

    DIR/
      manifest.json            what the study is (fingerprint, spec, N, chunk size, columns)
      chunks/chunk-00000.parquet   rows of samples [0, c), written as soon as the chunk is done
      chunks/chunk-00001.parquet   rows of samples [c, 2c) ...
      results.parquet          every chunk concatenated in sample order (written at the end)
      summary.json             success probability, interval, sensitivities

(``.csv`` instead of ``.parquet`` with ``file_format="csv"``.) Every file is written to a
temporary name and moved into place (:func:`os.replace`), so a chunk file is either complete or
absent: a study interrupted at any moment resumes by skipping the chunks whose file exists and
loses at most the chunks that were running. The manifest's fingerprint (a SHA-256 of the spec
and the nominal problem) refuses to resume a different study into the same folder.

Parquet files carry each column's unit in the field metadata (``unit``) and the fingerprint in
the schema metadata; pyarrow is imported only when a Parquet file is read or written.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
from pathlib import Path

import numpy as np

from ..output_files import atomic_file, atomic_write_text

MANIFEST = "manifest.json"
FORMAT_NAME = "dloplan-study"
FORMAT_VERSION = 1
FILE_FORMATS = ("parquet", "csv")


def _pyarrow():
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as exc:  # pragma: no cover - pyarrow comes with the study extra
        raise ImportError("Parquet output needs pyarrow: pip install 'dloplan[study]' "
                          "(or use file_format='csv')") from exc
    return pa, pq


def dtype_name(values: np.ndarray) -> str:
    """The stored type of a column: ``bool``, ``int64``, ``float64`` or ``string``."""
    if values.dtype == bool:
        return "bool"
    if np.issubdtype(values.dtype, np.integer):
        return "int64"
    if np.issubdtype(values.dtype, np.floating):
        return "float64"
    return "string"


def concat_tables(tables: list[dict]) -> dict:
    """Rows of several tables with the same columns, in the given order."""
    if not tables:
        return {}
    return {name: np.concatenate([t[name] for t in tables]) for name in tables[0]}


def table_rows(table: dict) -> int:
    """Number of rows of a table."""
    return len(next(iter(table.values()))) if table else 0


def fingerprint(*parts) -> str:
    """SHA-256 of arrays, strings and JSON-able values: the identity of a study."""
    digest = hashlib.sha256()
    for part in parts:
        if isinstance(part, np.ndarray):
            digest.update(np.ascontiguousarray(part, dtype=float).tobytes())
        else:
            digest.update(json.dumps(part, sort_keys=True, default=repr).encode())
        digest.update(b"\x00")
    return digest.hexdigest()


# -- one table file ---------------------------------------------------------------------------
def write_table(path, table: dict, units: dict | None = None,
                metadata: dict | None = None) -> Path:
    """Write a table as Parquet or CSV (by the suffix), atomically.

    Parameters
    ----------
    path : str or os.PathLike
        ``*.parquet`` or ``*.csv``.
    table : dict
        Column name -> (rows,) array.
    units : dict, optional
        Column name -> unit, stored in the Parquet field metadata.
    metadata : dict, optional
        String key -> string value, stored in the Parquet schema metadata.
    """
    path = Path(path)
    kind = path.suffix.lstrip(".").lower()
    if kind not in FILE_FORMATS:
        raise ValueError(f"path: got {str(path)!r}, expected a .parquet or .csv file")
    if kind == "csv":
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(list(table))
        columns = [_csv_values(v) for v in table.values()]
        writer.writerows(zip(*columns, strict=True))
        return atomic_write_text(path, buffer.getvalue())
    pa, pq = _pyarrow()
    units = units or {}
    fields, arrays = [], []
    for name, values in table.items():
        kind = dtype_name(values)
        typ = {"bool": pa.bool_(), "int64": pa.int64(), "float64": pa.float64(),
               "string": pa.string()}[kind]
        data = values.astype(str).tolist() if kind == "string" else values
        fields.append(pa.field(name, typ, metadata={"unit": units.get(name, "")}))
        arrays.append(pa.array(data, type=typ))
    schema = pa.schema(fields, metadata=metadata or {})
    arrow = pa.Table.from_arrays(arrays, schema=schema)
    with atomic_file(path) as temp:
        pq.write_table(arrow, temp)
    return path


def _csv_values(values: np.ndarray) -> list:
    if values.dtype.kind == "f":
        return [repr(float(v)) for v in values]  # repr round-trips a double exactly
    return [str(v) for v in values.tolist()]


def read_table(path, dtypes: dict | None = None) -> dict:
    """Read a table written by :func:`write_table`.

    ``dtypes`` (column -> :func:`dtype_name`) types the columns of a CSV file (the manifest
    holds them); Parquet files carry their own types.
    """
    path = Path(path)
    if path.suffix.lower() == ".csv":
        with open(path, encoding="utf-8", newline="") as handle:
            rows = list(csv.reader(handle))
        header, body = rows[0], rows[1:]
        cols = list(zip(*body, strict=True)) if body else [()] * len(header)
        dtypes = dtypes or {}
        return {name: _parse(values, dtypes.get(name, "float64"))
                for name, values in zip(header, cols, strict=True)}
    _, pq = _pyarrow()
    arrow = pq.read_table(path)
    out = {}
    for name in arrow.column_names:
        column = arrow.column(name)
        values = column.to_pylist()
        if str(column.type) == "string":
            out[name] = np.asarray(values, dtype=object)
        else:
            out[name] = column.to_numpy()
    return out


def _parse(values, kind: str) -> np.ndarray:
    if kind == "bool":
        return np.asarray([v == "True" for v in values], dtype=bool)
    if kind == "int64":
        return np.asarray([int(v) for v in values], dtype=np.int64)
    if kind == "string":
        return np.asarray(list(values), dtype=object)
    return np.asarray([float(v) for v in values], dtype=float)


# -- the study folder -------------------------------------------------------------------------
def chunk_path(folder, chunk: int, file_format: str = "parquet") -> Path:
    """``DIR/chunks/chunk-00000.parquet``."""
    return Path(folder) / "chunks" / f"chunk-{chunk:05d}.{file_format}"


def result_path(folder, file_format: str = "parquet") -> Path:
    """``DIR/results.parquet``: the concatenated table."""
    return Path(folder) / f"results.{file_format}"


def open_folder(folder, manifest: dict, *, resume: bool = True) -> list[int]:
    """Prepare a study folder; return the chunks already completed (empty for a new study).

    Parameters
    ----------
    folder : str or os.PathLike
        The study folder (created if missing).
    manifest : dict
        What this study is: ``fingerprint``, ``file_format``, ``n_chunks`` and whatever else
        describes it; written as ``manifest.json`` for a new study.
    resume : bool
        Keep completed chunks of the same study (default). ``False`` starts over, removing the
        folder's chunk files.

    Raises
    ------
    ValueError
        When the folder holds another study (a different fingerprint) and ``resume`` is True,
        or a manifest that is not a study's.
    """
    folder = Path(folder)
    file_format = manifest["file_format"]
    if file_format not in FILE_FORMATS:
        raise ValueError(f"file_format: got {file_format!r}, expected 'parquet' or 'csv'")
    path = folder / MANIFEST
    if path.exists() and resume:
        try:
            old = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as exc:
            raise ValueError(f"out: {path} is not a readable study manifest ({exc})") from None
        if old.get("format") != FORMAT_NAME:
            raise ValueError(f"out: {path} is not a dloplan study manifest")
        if old.get("fingerprint") != manifest["fingerprint"] or \
                old.get("file_format") != file_format:
            raise ValueError(
                f"out: {folder} holds a different study (another spec, plan, cable or file "
                "format); choose another folder or start over (resume=False / --overwrite)")
        return [k for k in range(manifest["n_chunks"])
                if chunk_path(folder, k, file_format).exists()]
    chunks = folder / "chunks"
    if chunks.exists():
        for stale in chunks.glob("chunk-*"):
            stale.unlink()
    for stale in (result_path(folder, f) for f in FILE_FORMATS):
        with contextlib.suppress(FileNotFoundError):
            stale.unlink()
    atomic_write_text(path, json.dumps({"format": FORMAT_NAME, "version": FORMAT_VERSION,
                                        **manifest}, indent=2, default=repr))
    return []


def read_manifest(folder) -> dict:
    """The manifest of a study folder."""
    path = Path(folder) / MANIFEST
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"folder: {path} is not a readable study manifest ({exc})") from None


def read_chunks(folder, manifest: dict | None = None) -> dict:
    """The table of every completed chunk of a study folder, in sample order."""
    manifest = manifest or read_manifest(folder)
    fmt = manifest["file_format"]
    dtypes = {name: spec["dtype"] for name, spec in manifest["columns"].items()}
    tables = [read_table(chunk_path(folder, k, fmt), dtypes)
              for k in range(manifest["n_chunks"]) if chunk_path(folder, k, fmt).exists()]
    return concat_tables(tables)
