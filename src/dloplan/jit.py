"""numba's ``njit`` with an on-disk cache that concurrent processes cannot corrupt.

Every compiled kernel of dloplan is ``@njit(cache=True)``: numba writes each compiled overload
to ``__pycache__/<function>-<line>.pyXY.<number>.nbc`` and maps the overload's key (argument
types, CPU, the function's bytecode and closure values) to that file name in one index file per
function, ``<function>-<line>.pyXY.nbi``. numba (0.68) saves an overload by reading the index,
taking the lowest unused number, writing the index and then the data file, with no lock between
processes (numba issue #10128). Two processes that save *different* overloads of one function at
the same moment (two pytest-xdist workers on an empty cache, or two ``dloplan`` runs) both take
the same number: one index entry is lost, and when the data files are written in the other order
than the index, the surviving entry points at the other overload's machine code. A later process
then loads, for example, one literal step of the banded Cholesky's bulk pass where it asked for
another (``dloplan.sim.newton._bulk`` has one overload per step: factor, forward, backward) and the
solver runs the wrong code (measured: 8 processes compiling
the 8 closure variants of one small kernel at once, 4 of 12 trials ended with an index entry
whose code computes another variant's result and 2 more lost an entry; with this module, none
in 12. The three variants of dloplan's own kernel, compiled by three processes at once, did not
hit the race in 10 trials under load 7-9: the window is the few milliseconds of one save).

:func:`njit` is ``numba.njit`` after :func:`install_cache_lock` has made every save of that
cache hold an exclusive ``flock`` on a lock file in the cache folder, for the whole read of the
index, the choice of the number and both writes, and write the data file before the index entry
that names it. Loading is unchanged: files are replaced atomically, an index entry appears only
after its data file is complete, and a number is never reused for another key while the index is
current, so a reader needs no lock. Compiled code, cache file names and formats are numba's own.
Without ``fcntl`` (Windows), or with a numba whose cache class lacks what the locked save uses,
the cache is numba's, unlocked.

Loading a cached overload skips numba's refresh of its registries (:func:`lean_load`): numba's
``Cache.load_overload`` first refreshes the target context, which imports and installs every
lowering and typing registry numba has (its linear algebra, typed containers, random
generators, jitclass...: about 0.25 s of CPU in each process, the largest part of the first
kernel's call in a ``dloplan`` run). A cached overload is machine code: it needs numba's runtime
(NRT) initialized, which :func:`lean_load` does, not the registries, which only a compilation
uses, and numba's compiler refreshes them itself before it compiles (``CompilerBase``).

A cached overload's shared bitcode is parsed only when a compilation links against it
(:func:`lazy_unserialize`, :func:`linking_module`): numba keeps beside each cached library's
machine code its LLVM module, for inlining into kernels compiled later, and parsed it (then
listed its symbols for the JIT engine) on every load: about 0.6 of the 0.85 s of CPU that
loading ``harness_pu``'s 33 overloads took, for modules a run that compiles nothing never uses. The
defined symbols are read from the machine code's ELF symbol table instead
(:mod:`dloplan.elf_symbols`: the same names, checked on all 128 of dloplan's overloads), and
the module is parsed at the first link against it. numba's runtime module is likewise loaded
compiled (:mod:`dloplan.jit_runtime`).

Loading a cached overload is also shielded from signals (:func:`shielded_load`): numba rebuilds
the machine code through ctypes, and a Ctrl-C raised in the middle of it (or swallowed in one of
its callbacks) left a half-linked library whose environment pointer numba then wrote through, a
segmentation fault instead of exit 130 (1 in 20 Ctrl-Cs during ``dloplan identify``'s first
equilibria). A load takes milliseconds; the signal is raised as soon as it is done.

A kernel's cache is stale when a kernel it calls changes, in whatever file
(:mod:`dloplan.jit_callees`): numba's stamp covers the kernel's own file only, and a caller kept
the old callee's machine code after a ``git pull`` that changed the callee's file alone.

A kernel called from another kernel with a constant argument (``f(x, 3)``, ``g(x, True)``) is
compiled for the constant's literal type (``Literal[int](3)``), so two calls with two constants
compile two overloads of the callee where one would do (and the warm-up compiles both). Where
the constant only selects an offset or a branch, the caller passes a typed value instead
(``np.int64(3)``, ``np.bool_(True)``, ``bool(flag)``): one overload, the same arithmetic. Where
the constant is a loop bound that numba should unroll (the banded Cholesky's widths in
:mod:`dloplan.sim.newton`), the literal is kept on purpose.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import weakref

import llvmlite.binding as ll
import numba
from numba.core import caching, codegen
from numba.core.runtime import rtsys

from .elf_symbols import defined_symbols
from .interrupts import raise_if_interrupted, shielded
from .jit_callees import stamp_callees
from .jit_runtime import install_runtime_cache

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: numba's unlocked cache
    fcntl = None

NUMBA_SAVE = caching.IndexDataCacheFile.save
"""numba's own, unlocked ``IndexDataCacheFile.save`` (kept to show the race it has)."""

LOCK_NAME = "dloplan-numba-cache.lock"
"""The lock file in each cache folder (``__pycache__`` beside the kernels' source files)."""


@contextlib.contextmanager
def cache_folder_lock(folder: str):
    """Hold an exclusive lock on ``folder``'s cache lock file, shared by all processes."""
    if fcntl is None:  # pragma: no cover
        yield
        return
    with open(os.path.join(folder, LOCK_NAME), "a+b") as handle:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle.fileno(), fcntl.LOCK_UN)


def locked_save(cache_file: caching.IndexDataCacheFile, key, data) -> None:
    """``IndexDataCacheFile.save`` under :func:`cache_folder_lock`, the data file written first.

    The same choice of file name as numba's (the key's own file, else the lowest unused number).
    """
    with cache_folder_lock(cache_file._cache_path):
        overloads = cache_file._load_index()
        name = overloads.get(key)
        if name is None:
            used = set(overloads.values())
            name = next(n for n in map(cache_file._data_name, itertools.count(1))
                        if n not in used)
            overloads[key] = name
        cache_file._save_data(name, data)
        cache_file._save_index(overloads)


NUMBA_METHODS = ("_load_index", "_data_name", "_save_data", "_save_index")
"""The methods :func:`locked_save` calls on numba's ``IndexDataCacheFile`` (numba 0.68),
besides its ``_cache_path`` attribute (set in ``__init__``)."""


NUMBA_LOAD = caching.Cache.load_overload
"""numba's own ``Cache.load_overload`` (rebuilds a cached overload's machine code)."""


LOAD_METHODS = ("_guard_against_spurious_io_errors", "_load_overload")
"""The methods :func:`lean_load` calls on numba's ``Cache`` (numba 0.68)."""


def lean_load(cache: caching.Cache, sig, target_context):
    """numba's ``Cache.load_overload`` without the refresh of the target context's registries
    it starts with (module docstring): numba's runtime initialized, then the overload loaded as
    numba loads it (None when the cache has none: the dispatcher then compiles, and the
    compiler refreshes the registries first)."""
    rtsys.initialize(target_context)
    with cache._guard_against_spurious_io_errors():
        return cache._load_overload(sig, target_context)


KERNEL_LOAD = lean_load if all(callable(getattr(caching.Cache, name, None))
                                for name in LOAD_METHODS) else NUMBA_LOAD
"""How :func:`shielded_load` loads: :func:`lean_load`, or numba's own ``load_overload`` with a
numba whose ``Cache`` lacks what :func:`lean_load` uses."""


STAMP_NAMES = ("_py_func", "_cache_file")
"""What :func:`dloplan.jit_callees.stamp_callees` uses of numba's ``Cache`` (set in its
``__init__``), besides the index file's ``_source_stamp``."""

CAN_STAMP = all(name in caching.Cache.__init__.__code__.co_names for name in STAMP_NAMES) \
    and "_source_stamp" in caching.IndexDataCacheFile.__init__.__code__.co_names
"""Whether this numba's cache lets :func:`stamp_callees` extend an index's stamp (numba 0.68
does); without it, the cache is stale only when the kernel's own file changes, as numba's."""

NUMBA_SAVE_OVERLOAD = caching.Cache.save_overload
"""numba's own ``Cache.save_overload`` (saves a compiled overload and the index naming it)."""


def stamped_save(cache: caching.Cache, sig, data) -> None:
    """numba's ``Cache.save_overload``, the index stamped with the kernel's callees first
    (:func:`stamp_callees`; numba's dispatcher loads before it compiles and saves, so the stamp
    is usually there already)."""
    stamp_callees(cache)
    NUMBA_SAVE_OVERLOAD(cache, sig, data)


def shielded_load(cache: caching.Cache, sig, target_context):
    """A cached overload loaded (:data:`KERNEL_LOAD`) to the end: a signal meanwhile is raised
    after it. The index is first stamped with the kernel's callees (:func:`stamp_callees`,
    where :data:`CAN_STAMP`): an index saved before a kernel it calls changed is stale."""
    if CAN_STAMP:
        stamp_callees(cache)
    with shielded():
        data = KERNEL_LOAD(cache, sig, target_context)
    raise_if_interrupted()
    return data


NUMBA_UNSERIALIZE = codegen.CPUCodeLibrary._unserialize.__func__
"""numba's own ``CPUCodeLibrary._unserialize`` (rebuilds a cached library, its shared bitcode
parsed)."""

NUMBA_LINKING_MODULE = codegen.CPUCodeLibrary._get_module_for_linking
"""numba's own ``CPUCodeLibrary._get_module_for_linking`` (the library's module for linking
into a later compilation)."""

LAZY_METHODS = ("_unserialize", "_get_module_for_linking", "enable_object_caching",
                "_set_compiled_object", "_finalize_final_module")
"""The methods :func:`lazy_unserialize` and :func:`linking_module` use on numba's
``CPUCodeLibrary`` (numba 0.68), besides its ``_shared_module`` attribute and the JIT engine's
``_defined_symbols`` set."""

SHARED_BITCODE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""The shared bitcode of each library loaded by :func:`lazy_unserialize`, not yet parsed."""


def lazy_unserialize(cls, library_codegen, state):
    """numba's ``CPUCodeLibrary._unserialize`` of a cached library with its shared bitcode
    parsed only when a later compilation links against it (:func:`linking_module`).

    numba parses the bitcode kept beside a cached library's object code on every load (the
    library's LLVM module, made for inlining into later compilations), then lists the module's
    defined functions and variables for the JIT engine's symbol look-ups: the larger part of
    loading a kernel, for a module a run that compiles nothing never links. Here the object
    code is loaded as numba loads it, the defined symbols are read from the object's ELF
    symbol table (:func:`dloplan.elf_symbols.defined_symbols`: the same names) and the bitcode
    is kept unparsed. Anything but an ELF object (another platform, numba's ``bitcode`` kind)
    is numba's own path.
    """
    name, kind, data = state
    symbols = defined_symbols(data[0]) if kind == "object" else None
    engine_symbols = getattr(getattr(library_codegen, "_engine", None), "_defined_symbols", None)
    if symbols is None or not isinstance(engine_symbols, set):
        return NUMBA_UNSERIALIZE(cls, library_codegen, state)
    object_code, shared_bitcode = data
    library = library_codegen.create_library(name)
    library.enable_object_caching()
    library._set_compiled_object(object_code)
    SHARED_BITCODE[library] = shared_bitcode
    library._finalize_final_module()
    engine_symbols |= symbols
    return library


def linking_module(library):
    """numba's ``CPUCodeLibrary._get_module_for_linking``, the shared bitcode of a library
    loaded by :func:`lazy_unserialize` parsed first (once)."""
    bitcode = SHARED_BITCODE.pop(library, None)
    if bitcode is not None:
        library._shared_module = ll.parse_bitcode(bitcode)
    return NUMBA_LINKING_MODULE(library)


def install_lazy_linking() -> bool:
    """Make numba load cached libraries through :func:`lazy_unserialize` (idempotent).

    Returns False, leaving numba's own loading, when this numba's ``CPUCodeLibrary`` or JIT
    engine lacks what :func:`lazy_unserialize` uses.
    """
    library = codegen.CPUCodeLibrary
    if not all(callable(getattr(library, name, None)) for name in LAZY_METHODS) \
            or "_shared_module" not in library.__init__.__code__.co_names \
            or "_defined_symbols" not in codegen.JitEngine.__init__.__code__.co_names:
        return False
    library._unserialize = classmethod(lazy_unserialize)
    library._get_module_for_linking = linking_module
    return True


def install_cache_lock() -> bool:
    """Make numba's on-disk cache save through :func:`locked_save` (idempotent, per process).

    Loading is lean and shielded from signals (:func:`shielded_load`) in any case, and an
    index is stale when a kernel the kernel calls changes (:func:`stamp_callees`); a cached
    library's shared bitcode is parsed lazily (:func:`install_lazy_linking`) and numba's
    runtime is loaded compiled (:func:`dloplan.jit_runtime.install_runtime_cache`) where this
    numba allows it.

    Returns False, leaving numba's own save, when this numba's ``IndexDataCacheFile`` lacks what
    :func:`locked_save` uses (a numba that reorganized its cache): the lock is then off, never a
    crash at the first compilation.
    """
    caching.Cache.load_overload = shielded_load
    if CAN_STAMP:
        caching.Cache.save_overload = stamped_save
    install_lazy_linking()
    install_runtime_cache()
    cache_file = caching.IndexDataCacheFile
    if not all(callable(getattr(cache_file, name, None)) for name in NUMBA_METHODS) \
            or "_cache_path" not in cache_file.__init__.__code__.co_names:
        return False
    cache_file.save = locked_save
    return True


def njit(*args, **options):
    """``numba.njit(*args, **options)`` with the cache lock installed (see the module docstring)."""
    install_cache_lock()
    return numba.njit(*args, **options)


def njit_leaf(*args, **options):
    """:func:`njit` for a kernel that allocates nothing: numba's runtime (NRT) off for it.

    numba counts the references of every array a compiled function receives or slices: an
    atomic increment and decrement of the array's counter per argument and view, on every call.
    The solvers' small kernels (a chain's energy and derivatives, the banded Cholesky, a Newton
    step: each a few hundred to a few thousand floating-point operations on arrays of a few
    dozen points) are called several times per Newton iteration, and those atomics were about
    a third of the plants' Newton loop (``perf`` on a closed-loop study, docs/performance.md,
    branch cl6). A kernel compiled without the runtime neither counts references nor can
    allocate (numba refuses to compile ``np.empty`` there): its arrays are borrowed from the
    caller, which holds them for the call, as every compiled caller does. The arithmetic is the
    same instructions, bit for bit.

    numba's option for this is ``_nrt`` (numba 0.68: one of :class:`numba.core.cpu.CPUTargetOptions`
    mapped to the compiler flag ``nrt``); the kernel's other options are ``njit``'s.
    """
    return njit(*args, _nrt=False, **options)
