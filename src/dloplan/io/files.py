"""Atomic file output: a failed run never leaves a half-written file or folder.

Every file is first written to a temporary file beside its target, flushed to disk, and only
then moved over the target with :func:`os.replace` (atomic on POSIX and Windows). A run that
writes a whole folder (:func:`staged_folder`) writes into a fresh temporary folder beside it and
moves it into place at the end, holding a lock so that a second run cannot write into the same
folder meanwhile: the folder always holds one run's complete output. Files and folders get the
permissions of the process' umask (as ``open()`` would give), not the 0600 of temporary files.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path

from ..interrupts import raise_if_interrupted

OUTPUT_MARK = "plan.json"
"""A folder holding this file is a dloplan output folder that a new run may replace."""


def umask() -> int:
    """The process' file-creation mask."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _publish(path: Path, mode: int) -> None:
    os.chmod(path, mode & ~umask())


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
            _publish(Path(temp), 0o666)
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


def _take_lock(lock: Path, target: Path) -> None:
    try:
        fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
    except FileExistsError:
        try:
            owner = int(lock.read_text().strip() or 0)
        except (OSError, ValueError):
            owner = 0
        if owner > 0 and _alive(owner):
            raise ValueError(f"{target}: another dloplan run (process {owner}) is writing this "
                             f"folder; wait for it, or choose another output folder") from None
        lock.unlink(missing_ok=True)  # left by a run that died: take it over
        fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        _remove_leftovers(target)
    with os.fdopen(fd, "w") as handle:
        handle.write(str(os.getpid()))


def _remove_leftovers(target: Path) -> None:
    """Remove the half-written folders of a run on ``target`` that died (killed, e.g. by
    ``timeout``'s SIGTERM, before its clean-up): its staging folder, and its folder of the
    previous output once ``target`` is back in place. Called holding the lock."""
    for stale in target.parent.glob(f".{target.name}.tmp-*"):
        shutil.rmtree(stale, ignore_errors=True)
    if target.exists():
        for stale in target.parent.glob(f".{target.name}.old-*"):
            shutil.rmtree(stale, ignore_errors=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@contextlib.contextmanager
def staged_folder(target: str | os.PathLike) -> Iterator[Path]:
    """Write a whole output folder atomically: yields a fresh folder to write into.

    On success the folder replaces ``target`` (created if missing; a previous dloplan output
    folder, one holding ``plan.json``, is replaced whole); on any error, or Ctrl-C, it is
    removed and ``target`` is left as it was. A lock file beside ``target`` refuses a second run
    on the same folder while the first holds it.

    Raises
    ------
    ValueError
        ``target`` is a file, or a folder with other content than a dloplan output, or locked
        by a running process.
    """
    target = Path(target)
    if target.exists() and not target.is_dir():
        raise ValueError(f"{target}: exists and is not a folder (the output folder)")
    if target.is_dir() and any(target.iterdir()) and not (target / OUTPUT_MARK).exists():
        raise ValueError(f"{target}: the folder has other files than a dloplan output "
                         f"(no {OUTPUT_MARK}); choose an empty or new output folder")
    target.parent.mkdir(parents=True, exist_ok=True)
    lock = target.with_name(f".{target.name}.lock")
    _take_lock(lock, target)
    staging = Path(tempfile.mkdtemp(dir=target.parent, prefix=f".{target.name}.tmp-"))
    try:
        _publish(staging, 0o777)
        yield staging
        raise_if_interrupted()  # a Ctrl-C dropped on its way (dloplan.interrupts): publish nothing
        if target.exists():
            old = Path(tempfile.mkdtemp(dir=target.parent, prefix=f".{target.name}.old-"))
            os.rename(target, old / "previous")
            os.rename(staging, target)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.rename(staging, target)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    finally:
        lock.unlink(missing_ok=True)
