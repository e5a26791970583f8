"""Every input file read once, bounded: none can be endless or huge.

A job, identification, shape, calibration or URDF file, and a plan document, is read by
:func:`read_text`: a device, a pipe or a folder is refused before it is opened (``/dev/zero`` or a
FIFO would never end), and no more than the limit (:mod:`dloplan.bounds`) plus one byte is read
(a file that grows while read, a ``/proc`` file whose size says 0). The errors are one line
naming the file. (Writing is :mod:`dloplan.output_files`'.) :func:`parse_json` and
:func:`parse_yaml` parse the text refusing a key given twice in one mapping (JSON and YAML
parsers keep the last one silently: the first value would be lost without a word).
"""

from __future__ import annotations

import functools
import json
import os
import stat
from pathlib import Path

from .bounds import MAX_INPUT_BYTES


def read_text(path: str | os.PathLike, limit: int = MAX_INPUT_BYTES, kind: str = "file",
              advice: str = "") -> str:
    """The UTF-8 text of a regular file of at most ``limit`` bytes, read once (module
    docstring), without the byte-order mark some editors write at its start.

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
        return data.decode("utf-8-sig")  # a leading byte-order mark (Notepad, Excel) dropped
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file (not UTF-8): expected a {kind}") from None


class DuplicateKeyError(ValueError):
    """A key given twice in one mapping of a JSON or YAML file."""


def _unique_pairs(pairs: list[tuple[str, object]]) -> dict:
    """A JSON object's mapping from its ``pairs``; a key given twice is refused."""
    out: dict = {}
    for key, value in pairs:
        if key in out:
            raise DuplicateKeyError(f"key {key!r} given twice in one object (first "
                                    f"{out[key]!r}, then {value!r}); expected each key once")
        out[key] = value
    return out


def parse_json(text: str):
    """``json.loads(text)`` refusing a key given twice in one object.

    Raises
    ------
    ValueError
        Not valid JSON (:class:`json.JSONDecodeError`), or :class:`DuplicateKeyError` naming
        the key and both values.
    """
    return json.loads(text, object_pairs_hook=_unique_pairs)


def parse_yaml(text: str):
    """``yaml.safe_load(text)`` refusing a key given twice in one mapping (merge keys ``<<``
    may repeat what they merge, as YAML defines).

    Raises
    ------
    yaml.YAMLError
        Not valid YAML, or a key given twice: the message's first line names the key and both
        lines.
    """
    import yaml

    return yaml.load(text, Loader=_unique_key_loader())  # noqa: S506 - a SafeLoader subclass


@functools.cache
def _unique_key_loader():
    """The SafeLoader subclass of :func:`parse_yaml` (made on first use: yaml loads lazily)."""
    import yaml

    class UniqueKeyLoader(yaml.SafeLoader):
        def construct_mapping(self, node, deep=False):
            lines: dict = {}
            for key_node, _ in node.value if isinstance(node, yaml.MappingNode) else ():
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                line = key_node.start_mark.line + 1
                try:
                    first = lines.get(key)
                except TypeError:  # an unhashable key: SafeLoader's own error follows
                    continue
                if first is not None:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"key {key!r} given twice in one mapping (lines {first} "
                        f"and {line}); expected each key once", key_node.start_mark)
                lines[key] = line
            return super().construct_mapping(node, deep)

    return UniqueKeyLoader
