"""Atomic file output: a failed run never leaves a half-written file or folder.

Every file is first written to a temporary file beside its target, flushed to disk, and only
then moved over the target with :func:`os.replace` (atomic on POSIX and Windows). A run that
writes a whole folder (:func:`staged_folder`) writes into a fresh temporary folder beside it and
moves it into place at the end, holding a lock (:func:`output_lock`, also taken by commands that
write single files) so that a second run cannot write into the same output meanwhile: the folder
always holds one run's complete output. Temporary names are unique, so two runs never write into
one temporary file; a signal never leaves a half-published folder
(:func:`dloplan.interrupts.shielded`), and a full disk's error names the file. Files and folders
get the permissions of the process' umask (as ``open()`` would give), not the 0600 of temporary
files.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path

from .interrupts import raise_if_interrupted, shielded

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: the lock file alone, no stale-lock take-over
    fcntl = None

OUTPUT_MARK = "plan.json"
"""A folder holding this file is a dloplan output folder that a new run may replace."""


def umask() -> int:
    """The process' file-creation mask."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _publish(path: Path, mode: int) -> None:
    os.chmod(path, mode & ~umask())


def refuse_overwriting_inputs(output: str | os.PathLike | None, inputs, option: str = "-o") -> None:
    """Refuse an output that is, or holds, an input of the same command (``export
    OUT/plan.json --format report -o OUT/plan.json`` would replace the plan with its report;
    ``plan OUT/job.yaml -o OUT`` would replace the folder holding the job). Paths are compared
    with their symlinks resolved.

    Raises
    ------
    ValueError
        Naming the option, the output and the input it would replace.
    """
    if output is None:
        return
    target = Path(os.path.realpath(output))
    for given in inputs:
        if given is None:
            continue
        source = Path(os.path.realpath(given))
        if source == target or target in source.parents:
            raise ValueError(f"{option} {output}: it would replace {given}, an input of this "
                             "command; choose another output")


def _named(exc: OSError, path) -> OSError:
    """``exc`` with the file named (a full disk's ``write()`` names none)."""
    if exc.filename is None:
        return OSError(exc.errno, exc.strerror or str(exc), str(path))
    return exc


def _file_target(path: str | os.PathLike) -> Path:
    """``path`` as the target of a file writer; a folder there is refused naming it (the
    replace at the end would fail naming the temporary file, an inner detail)."""
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path}: is a folder; expected the path of a file to write")
    return path


def _unwritable(exc: OSError, target: Path) -> OSError:
    """``exc`` (creating ``target``'s folder or its lock beside it failed) as the one line of
    an output that cannot be written there: it names ``target``, the folder and what is
    expected (not the lock file, an inner detail)."""
    blocker = next((p for p in reversed(target.parents) if p.exists() and not p.is_dir()),
                   None)
    reason = (f"{blocker} is a file, not a folder" if blocker is not None
              else f"{target.parent}: {exc.strerror or exc}")
    return OSError(exc.errno, f"cannot write this output ({reason}); expected a path in a "
                              f"folder that exists or can be made, and may be written to",
                   str(target))


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike) -> Iterator[Path]:
    """Write one file atomically by any writer: yields a fresh temporary path beside ``path``
    (a unique name, so two runs writing the same file never write into one temporary file)
    to write; on success it replaces ``path`` with the umask's permissions; on any error it is
    removed and ``path`` is left as it was. An ``OSError`` that names no file (a full disk)
    is raised naming ``path``. Missing parent folders are created."""
    path = _file_target(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _unwritable(exc, path) from None
    try:
        with shielded():  # a signal cannot end the run between the file's creation and its name
            fd, temp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
            os.close(fd)
    except OSError as exc:
        raise _named(exc, path) from None
    try:
        raise_if_interrupted()  # one that came meanwhile: the temporary file is removed below
        yield Path(temp)
        _publish(Path(temp), 0o666)
        os.replace(temp, path)
    except OSError as exc:
        with shielded():
            with contextlib.suppress(FileNotFoundError):
                os.unlink(temp)
        raise _named(exc, path) from None
    except BaseException:
        with shielded():
            with contextlib.suppress(FileNotFoundError):
                os.unlink(temp)
        raise


def atomic_write_texts(
    files: Mapping[str | os.PathLike, str], encoding: str = "utf-8"
) -> list[Path]:
    """Write several text files; none is touched unless all of them could be written.

    All contents are written to temporary files first; the targets are replaced only when every
    temporary file is complete, so an error while writing (disk full, bad text) leaves every
    target as it was. Missing parent folders are created. An ``OSError`` that names no file (a
    full disk) is raised naming the file being written.

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
    path = None
    try:
        for target, text in files.items():
            path = _file_target(target)
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise _unwritable(exc, path) from None
            with shielded():  # no signal between the file's creation and its name kept
                fd, temp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.",
                                            suffix=".tmp")
                temps.append((temp, path))
            with os.fdopen(fd, "w", encoding=encoding, newline="") as handle:
                raise_if_interrupted()  # one that came meanwhile: removed below
                handle.write(text)
                handle.flush()
                os.fsync(handle.fileno())
            _publish(Path(temp), 0o666)
        with shielded():  # all targets or none: a signal waits until every one is replaced
            for temp, path in temps:
                os.replace(temp, path)
    except BaseException as exc:
        with shielded():
            for temp, _ in temps:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(temp)
        if isinstance(exc, OSError):
            raise _named(exc, path) from None
        raise
    return [path for _, path in temps]


def atomic_write_text(path: str | os.PathLike, text: str, encoding: str = "utf-8") -> Path:
    """Write one text file atomically (see :func:`atomic_write_texts`)."""
    return atomic_write_texts({path: text}, encoding)[0]


LOCK_RETRIES = 5
"""Attempts to take a lock whose file a finishing run removed meanwhile."""


@contextlib.contextmanager
def output_lock(target: str | os.PathLike) -> Iterator[None]:
    """Hold the lock of an output (file or folder) ``target`` while the block runs: a second
    run on the same output is refused (ValueError naming the process that holds it).

    The lock is ``.NAME.lock`` beside ``target``, held with ``flock`` (released by the kernel
    when its process ends, however it ends); it holds the owner's process id and is removed at
    the end. A lock file that nobody holds was left by a run that was killed before its clean-up
    (SIGKILL, a power cut): it is taken over, and that run's staging folders beside ``target``
    are removed. Missing parent folders of ``target`` are created (and removed again, when
    empty, if the block fails).
    """
    target = Path(target)
    lock = target.with_name(f".{target.name}.lock")
    with _parents(target):
        with _locked(target, lock):
            yield


@contextlib.contextmanager
def _parents(target: Path) -> Iterator[None]:
    """Create the missing parent folders of ``target``; remove them again (when still empty)
    if the block fails, so a failed run writes nothing."""
    missing = [p for p in reversed(target.parents) if not p.exists()]
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _unwritable(exc, target) from None
    try:
        yield
    except BaseException:
        with shielded():
            for folder in reversed(missing):
                with contextlib.suppress(OSError):
                    folder.rmdir()
        raise


@contextlib.contextmanager
def _locked(target: Path, lock: Path) -> Iterator[None]:
    for _ in range(LOCK_RETRIES):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_RDWR, 0o644)
            stale = False
        except FileExistsError:
            try:
                fd = os.open(lock, os.O_RDWR)
            except FileNotFoundError:  # its run ended just now: try again
                continue
            stale = True
        except OSError as exc:
            raise _unwritable(exc, target) from None
        try:
            if fcntl is None and stale:
                raise BlockingIOError
            if fcntl is not None:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            owner = os.read(fd, 32).decode(errors="replace").strip() or "?"
            os.close(fd)
            raise ValueError(f"{target}: another dloplan run (process {owner}) is writing "
                             f"this output; wait for it, or choose another output") from None
        try:
            same = os.stat(lock).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)  # the lock file was removed by its finishing run after we opened it
    else:
        raise ValueError(f"{target}: the lock {lock} keeps changing: another run is busy there")
    try:
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        if stale:
            _remove_leftovers(target)
        yield
    finally:
        with shielded():
            lock.unlink(missing_ok=True)
            os.close(fd)


def _remove_leftovers(target: Path) -> None:
    """Remove the half-written folders of a run on ``target`` that was killed before its
    clean-up: its staging folder, and its folder of the previous output once ``target`` is back
    in place. Called holding the lock."""
    for stale in target.parent.glob(f".{target.name}.tmp-*"):
        shutil.rmtree(stale, ignore_errors=True)
    if target.exists():
        for stale in target.parent.glob(f".{target.name}.old-*"):
            shutil.rmtree(stale, ignore_errors=True)


@contextlib.contextmanager
def staged_folder(target: str | os.PathLike) -> Iterator[Path]:
    """Write a whole output folder atomically: yields a fresh folder to write into.

    On success the folder replaces ``target`` (created if missing; a previous dloplan output
    folder, one holding ``plan.json``, is replaced whole); on any error, or a signal
    (:mod:`dloplan.interrupts`), it is removed and ``target`` is left as it was. The lock of
    :func:`output_lock` refuses a second run on the same folder while the first holds it.

    Raises
    ------
    ValueError
        ``target`` is a file, or a folder with other content than a dloplan output, or locked
        by a running process.
    """
    target = Path(target)
    if target.exists() and not target.is_dir():
        raise ValueError(f"{target}: exists and is a file; expected an output folder (a new "
                         f"path, or a folder dloplan wrote)")
    if target.is_dir() and any(target.iterdir()) and not (target / OUTPUT_MARK).exists():
        raise ValueError(f"{target}: the folder has other files than a dloplan output "
                         f"(no {OUTPUT_MARK}); choose an empty or new output folder")
    with output_lock(target):
        try:
            staging = Path(tempfile.mkdtemp(dir=target.parent, prefix=f".{target.name}.tmp-"))
        except OSError as exc:
            raise _named(exc, target) from None
        try:
            _publish(staging, 0o777)
            yield staging
            raise_if_interrupted()  # a signal dropped on its way (dloplan.interrupts)
            with shielded():  # a signal waits until the folder is in place
                _publish_folder(staging, target)
        except BaseException as exc:
            with shielded():
                shutil.rmtree(staging, ignore_errors=True)
            if isinstance(exc, OSError):
                raise _named(exc, target) from None
            raise


@contextlib.contextmanager
def staged_files(folder: str | os.PathLike) -> Iterator[Path]:
    """Write files into a folder that may hold other files (a folder of figures): yields a fresh
    staging folder beside it to write into; on success every file written there is moved into
    ``folder`` (created if missing; files of the same name replaced, others left alone), on any
    error or signal nothing is. The folder is locked meanwhile (:func:`output_lock`)."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"{folder}: exists and is a file; expected a folder for the output "
                         f"files")
    with output_lock(folder):
        try:
            staging = Path(tempfile.mkdtemp(dir=folder.parent, prefix=f".{folder.name}.tmp-"))
        except OSError as exc:
            raise _named(exc, folder) from None
        created = not folder.exists()
        try:
            yield staging
            raise_if_interrupted()
            with shielded():
                folder.mkdir(exist_ok=True)
                for path in sorted(staging.rglob("*")):
                    if path.is_file():
                        target = folder / path.relative_to(staging)
                        target.parent.mkdir(parents=True, exist_ok=True)
                        os.replace(path, target)
        except BaseException as exc:
            with shielded():
                if created and folder.exists() and not any(folder.iterdir()):
                    folder.rmdir()
            if isinstance(exc, OSError):
                raise _named(exc, folder) from None
            raise
        finally:
            with shielded():
                shutil.rmtree(staging, ignore_errors=True)


def _publish_folder(staging: Path, target: Path) -> None:
    """Move ``staging`` into the place of ``target`` (the previous output, if any, is removed;
    put back if the move fails)."""
    if not target.exists():
        os.rename(staging, target)
        return
    old = Path(tempfile.mkdtemp(dir=target.parent, prefix=f".{target.name}.old-"))
    os.rename(target, old / "previous")
    try:
        os.rename(staging, target)
    except BaseException:
        os.rename(old / "previous", target)
        raise
    finally:
        shutil.rmtree(old, ignore_errors=True)
