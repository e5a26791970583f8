"""Atomic file output: a failed run never leaves a half-written file.

Every file is first written to a temporary file beside its target, flushed to disk, and only
then moved over the target with :func:`os.replace` (atomic on POSIX and Windows).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path


def atomic_write_texts(
    files: Mapping[str | os.PathLike, str], encoding: str = "utf-8"
) -> list[Path]:
    """Write several text files; none is touched unless all of them could be written.

    All contents are written to temporary files first; the targets are replaced only when every
    temporary file is complete, so an error while writing (disk full, bad text) leaves every
    target as it was. Missing parent folders are created.

    Parameters
    ----------
    files : mapping
        Target path -> text.
    encoding : str
        Text encoding.

    Returns
    -------
    list of pathlib.Path
        The written targets, in the mapping's order.
    """
    temps: list[tuple[str, Path]] = []
    try:
        for target, text in files.items():
            path = Path(target)
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, temp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
            temps.append((temp, path))
            with os.fdopen(fd, "w", encoding=encoding, newline="") as handle:
                handle.write(text)
                handle.flush()
                os.fsync(handle.fileno())
        for temp, path in temps:
            os.replace(temp, path)
    except BaseException:
        for temp, _ in temps:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(temp)
        raise
    return [path for _, path in temps]


def atomic_write_text(path: str | os.PathLike, text: str, encoding: str = "utf-8") -> Path:
    """Write one text file atomically (see :func:`atomic_write_texts`)."""
    return atomic_write_texts({path: text}, encoding)[0]
