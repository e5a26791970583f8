"""A kernel's on-disk cache made stale by a change of the kernels it calls, in any file.

numba keys a kernel's cached overloads on the kernel's own bytecode and closure, and stamps the
kernel's cache index with the modification time and size of the kernel's own source file: a
change of that file makes the index stale and the kernel compiles again. A kernel that calls a
kernel of another file (``model_step`` in ``sim/compiled.py`` calls ``cholesky_band`` of
``sim/newton.py``) has the callee compiled into its own machine code, and numba kept that code
after the callee's file changed: a ``git pull`` on a checkout with a warm cache ran the old
callee inside the unchanged caller until the caller's file changed too. The same holds for a
constant imported from another module (``GRAVITY``, ``ENTRY_DEPTH``), which numba freezes into
the code. A fresh clone or a new installation has no cache and is not affected.

:func:`stamp_callees` adds to the index's stamp (numba's own: the file's time and size) a
digest of what the kernel's code depends on beyond its file (:func:`callees_digest`): the source
files of every kernel it calls, directly or through the kernels they call, and the values of the
constants all of them read. When any of these changes, the index is stale as it is when the
kernel's own file changes: numba compiles the kernel again and replaces the index. The kernels
called are found in the names their bytecode reads (:func:`references`): a global, an attribute
of a module read through a global (``compiled.model_step``), a closure cell, or a tuple of them.
Closure variants of one kernel share one index and so must share one stamp: the cells' values
are in numba's key, not in the stamp, and variants that hold kernels of different files would
recompile each other (dloplan has no kernel with a closure). A kernel handed to a kernel as an
argument is not followed (no kernel of dloplan takes one: no cached signature names a kernel).

The digest is the callees' contents, not their times: checking out another branch and back, or
touching a callee's file, leaves the cache as it was (the kernel's own file still counts by
numba's time-and-size stamp). It is computed once per kernel and process, at its
first load from the cache (each file read and hashed once per process: a few milliseconds for
all of dloplan's kernel files).
"""

from __future__ import annotations

import functools
import hashlib
import types
import weakref

import numpy as np
from numba.core.dispatcher import Dispatcher

CONSTANT_TYPES = (bool, int, float, complex, str, bytes, type(None), np.generic)
"""Values numba freezes into a kernel's code that are written down by their ``repr``."""


def code_names(code: types.CodeType) -> frozenset[str]:
    """The global and attribute names ``code`` reads, its nested functions' included."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= code_names(const)
    return frozenset(names)


def constant_text(value) -> str | None:
    """A text that changes when the constant ``value`` does (numbers, strings, None, numpy
    scalars, numeric arrays, tuples of these), or None for any other value."""
    if isinstance(value, CONSTANT_TYPES):
        return repr(value)
    if isinstance(value, np.ndarray) and value.dtype != object:
        data = hashlib.sha256(np.ascontiguousarray(value).tobytes()).hexdigest()
        return f"array({value.dtype.str}, {value.shape}, {data})"
    if isinstance(value, tuple):
        parts = [constant_text(part) for part in value]
        return None if None in parts else f"({', '.join(parts)})"
    return None


def kernels_in(value) -> list[Dispatcher]:
    """The kernels ``value`` is or holds in (nested) tuples."""
    if isinstance(value, Dispatcher):
        return [value]
    if isinstance(value, tuple):
        return [kernel for part in value for kernel in kernels_in(part)]
    return []


@functools.cache
def references(function: types.FunctionType) -> tuple[tuple[Dispatcher, ...], tuple[str, ...]]:
    """The kernels ``function`` reads and the constants it reads, as ``name=text`` (once per
    function and process: a kernel called by many is looked at once).

    Looked up are the names its bytecode reads, in its module's globals and, for a global that
    is a module, among that module's own attributes (not its ``__getattr__``: no lazy import
    is triggered); tuples are searched for kernels. Its closure cells are searched for kernels
    only: numba's own key holds the cells' values (so closure variants of one kernel, which
    share one index, get one stamp).
    """
    names = code_names(function.__code__)
    found = [(name, function.__globals__[name]) for name in sorted(names)
             if name in function.__globals__]
    kernels, constants, modules = [], [], set()
    for cell in function.__closure__ or ():
        try:
            kernels += kernels_in(cell.cell_contents)
        except ValueError:  # an empty cell
            continue
    while found:
        name, value = found.pop()
        if isinstance(value, types.ModuleType):
            if value.__name__ not in modules:
                modules.add(value.__name__)
                scope = vars(value)
                found += [(f"{value.__name__}.{attribute}", scope[attribute])
                          for attribute in sorted(names) if attribute in scope]
            continue
        held = kernels_in(value)
        text = None if held else constant_text(value)
        kernels += held
        if text is not None:
            constants.append(f"{name}={text}")
    return tuple(kernels), tuple(constants)


@functools.cache
def file_digest(path: str) -> str:
    """sha256 of the file at ``path`` (read once per process), or of its name where it cannot
    be read (code not from a file)."""
    try:
        with open(path, "rb") as handle:
            return hashlib.sha256(handle.read()).hexdigest()
    except OSError:
        return hashlib.sha256(path.encode()).hexdigest()


def callees_digest(function: types.FunctionType) -> str:
    """sha256 over the source files of the kernels ``function`` calls, directly or through
    other kernels (its own file included), and the constants read by it and by them."""
    files, constants = set(), set()
    seen, stack = {id(function)}, [function]
    while stack:
        current = stack.pop()
        files.add(file_digest(current.__code__.co_filename))
        kernels, read = references(current)
        constants.update(f"{current.__module__}.{current.__qualname__}:{text}" for text in read)
        for kernel in kernels:
            if id(kernel.py_func) not in seen:
                seen.add(id(kernel.py_func))
                stack.append(kernel.py_func)
    text = "\n".join(sorted(files) + sorted(constants))
    return hashlib.sha256(text.encode()).hexdigest()


STAMPED: weakref.WeakSet = weakref.WeakSet()
"""The numba caches whose index stamp :func:`stamp_callees` has extended in this process."""


def stamp_callees(cache) -> None:
    """Extend the stamp of numba's cache ``cache`` (a kernel's ``Cache``) with
    :func:`callees_digest` of its kernel, once: an index saved under another digest, or under
    numba's own stamp alone, is stale (read as empty, then replaced)."""
    if cache in STAMPED:
        return
    cache_file = cache._cache_file
    cache_file._source_stamp = (cache_file._source_stamp, callees_digest(cache._py_func))
    STAMPED.add(cache)
