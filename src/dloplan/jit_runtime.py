"""numba's runtime functions (NRT) kept compiled on disk, as numba keeps the kernels.

Every process that runs a compiled kernel first initializes numba's runtime, and numba compiles
the runtime's own small LLVM module for it (reference counting, atomic operations: numba's
``nrtdynmod.compile_nrt_functions``) in each process: about 0.04 s of CPU, LLVM's optimization
and code generation, before the first kernel of every command, test worker and study worker.
:func:`cached_nrt_functions` compiles it once, keeps the library's object code and bitcode (as
numba's cache keeps a kernel's: ``serialize_using_object_code``) in a file named by what decides
the code (the module's IR text, numba's and llvmlite's versions, the CPU and its features, the
optimization level), and later processes load it from there (about 0.004 s). The file is written
atomically; where it cannot be written or read, the runtime is compiled as numba compiles it.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import pickle
import tempfile
from pathlib import Path

import llvmlite
import numba
from numba.core import codegen, config
from numba.core.runtime import nrtdynmod

NUMBA_NRT_FUNCTIONS = nrtdynmod.compile_nrt_functions
"""numba's own ``compile_nrt_functions`` (compiles the runtime's module in every process)."""

PACKAGE_CACHE = Path(__file__).resolve().parent / "__pycache__"
"""Where the compiled runtime is kept unless numba's ``NUMBA_CACHE_DIR`` is set: beside the
cache files of dloplan's own kernels."""

NEEDED = ("create_nrt_module", "compile_nrt_functions")
"""What :func:`cached_nrt_functions` uses of numba's ``nrtdynmod`` (numba 0.68), besides the
code library's ``enable_object_caching`` and ``serialize_using_object_code``."""


def runtime_file(ir_text: str, magic: tuple) -> Path:
    """The file of the compiled runtime whose module is ``ir_text``, for the CPU and features
    ``magic`` (the codegen's ``magic_tuple``), this numba and llvmlite and numba's optimization
    level: in numba's ``NUMBA_CACHE_DIR`` if set, else :data:`PACKAGE_CACHE`."""
    key = repr((ir_text, magic, numba.__version__, llvmlite.__version__, str(config.OPT)))
    digest = hashlib.sha256(key.encode()).hexdigest()[:24]
    folder = Path(config.CACHE_DIR) if config.CACHE_DIR else PACKAGE_CACHE
    return folder / f"numba-runtime-{digest}.nbr"


def save_state(path: Path, state) -> None:
    """Write ``state`` pickled to ``path`` atomically (a temporary file replaced); nothing
    where the folder cannot be written."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    except OSError:
        return  # a read-only installation: compiled in every process, as by numba
    try:
        with os.fdopen(handle, "wb") as out:
            out.write(pickle.dumps(state, protocol=-1))
        os.replace(temporary, path)
    except OSError:
        with contextlib.suppress(OSError):
            os.unlink(temporary)


def cached_nrt_functions(ctx):
    """numba's ``compile_nrt_functions(ctx)``: the runtime's library, loaded from its file
    (:func:`runtime_file`) when there is one, else compiled as numba compiles it and saved."""
    ir_module, library = nrtdynmod.create_nrt_module(ctx)
    library_codegen = ctx.codegen()
    path = runtime_file(str(ir_module), library_codegen.magic_tuple())
    try:
        state = pickle.loads(path.read_bytes())
    except (OSError, EOFError, pickle.UnpicklingError):
        state = None
    if state is not None:
        return library_codegen.unserialize_library(state)
    library.enable_object_caching()
    library.add_ir_module(ir_module)
    library.finalize()
    save_state(path, library.serialize_using_object_code())
    return library


def install_runtime_cache() -> bool:
    """Make numba initialize its runtime through :func:`cached_nrt_functions` (idempotent).

    Returns False, leaving numba's own compilation, when this numba lacks what
    :func:`cached_nrt_functions` uses.
    """
    if not all(callable(getattr(nrtdynmod, name, None)) for name in NEEDED) or not all(
            callable(getattr(codegen.CPUCodeLibrary, name, None))
            for name in ("enable_object_caching", "serialize_using_object_code")):
        return False
    nrtdynmod.compile_nrt_functions = cached_nrt_functions
    return True
