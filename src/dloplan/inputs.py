"""Every input file read once, bounded: none can be endless or huge.

A job, identification, shape, calibration or URDF file, and a plan document, is read by
:func:`read_text`: a device, a pipe or a folder is refused before it is opened (``/dev/zero`` or a
FIFO would never end), and no more than the limit (:mod:`dloplan.bounds`) plus one byte is read
(a file that grows while read, a ``/proc`` file whose size says 0). The errors are one line
naming the file. (Writing is :mod:`dloplan.output_files`'.)
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from .bounds import MAX_INPUT_BYTES


def read_text(path: str | os.PathLike, limit: int = MAX_INPUT_BYTES, kind: str = "file",
              advice: str = "") -> str:
    """The UTF-8 text of a regular file of at most ``limit`` bytes, read once (module
    docstring).

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    limit : int
        Largest size accepted [bytes].
    kind : str
        What the file should be, for the messages ("job file", "plan document").
    advice : str
        Appended to the message of a file that is too large.

    Raises
    ------
    ValueError
        One line naming the file: it cannot be read (missing, a symlink loop, no permission),
        is not a regular file, is larger than ``limit``, or is not UTF-8 text.
    """
    path = Path(path)
    try:
        status = path.stat()
        if not stat.S_ISREG(status.st_mode):
            raise ValueError(f"{path}: not a regular file (a folder, a device or a pipe); "
                             f"expected a {kind}")
        with path.open("rb") as handle:
            data = handle.read(limit + 1)
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    if len(data) > limit:
        size = max(status.st_size, len(data))
        more = f"{size / 1e6:.1f} MB" if status.st_size > limit else f"over {limit / 1e6:g} MB"
        raise ValueError(f"{path}: the file is {more}, more than the {limit / 1e6:g} MB a "
                         f"{kind} may have{advice}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file (not UTF-8): expected a {kind}") from None
