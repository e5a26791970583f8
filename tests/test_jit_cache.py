"""numba's on-disk cache under concurrent saves (dloplan.jit).

Two processes (pytest-xdist workers) that save different overloads of one kernel at the same
moment must not lose an index entry or map a key to another overload's code. The interleaving
is forced here: each saver waits after reading the index until the others have read it too.
"""

from __future__ import annotations

import os
import signal
import threading

import pytest
from numba.core import caching, codegen

from dloplan import jit
from dloplan.interrupts import Interrupted, catching_interrupts

fcntl = pytest.importorskip("fcntl")


def _save_concurrently(folder, save, keys):
    """Save ``keys`` (each as its own data) from one thread per key into one cache file; after
    reading the index each saver waits (up to 0.5 s) until every saver has read it. Returns the
    index and each key's loaded data."""
    cache_file = caching.IndexDataCacheFile(str(folder), "kernel-1.py311", b"source stamp")
    read_index = cache_file._load_index
    all_read = threading.Barrier(len(keys), timeout=0.5)

    def slow_read():
        overloads = read_index()
        try:
            all_read.wait()
        except threading.BrokenBarrierError:  # a lock keeps the other savers out
            pass
        return overloads

    cache_file._load_index = slow_read
    threads = [threading.Thread(target=save, args=(cache_file, key, f"code of {key}"))
               for key in keys]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    cache_file._load_index = read_index
    return read_index(), {key: cache_file.load(key) for key in keys}


def test_numbas_own_save_loses_an_overload_under_this_interleaving(tmp_path):
    # the race the lock removes: both savers take data file number 1
    index, loaded = _save_concurrently(tmp_path, jit.NUMBA_SAVE, ["width 8", "width 10"])
    assert len(index) == 1
    assert sorted(map(str, loaded.values())) != ["code of width 10", "code of width 8"]


def test_locked_save_keeps_every_overload_with_its_own_code(tmp_path):
    keys = ["width 8", "width 10", "width 1"]
    index, loaded = _save_concurrently(tmp_path, jit.locked_save, keys)
    assert sorted(index) == sorted(keys)
    assert len(set(index.values())) == 3  # three data files
    assert loaded == {key: f"code of {key}" for key in keys}


def test_locked_save_overwrites_a_key_in_its_own_file(tmp_path):
    cache_file = caching.IndexDataCacheFile(str(tmp_path), "kernel-1.py311", b"stamp")
    jit.locked_save(cache_file, "a", "first")
    jit.locked_save(cache_file, "b", "other")
    jit.locked_save(cache_file, "a", "second")
    assert cache_file._load_index() == {"a": "kernel-1.py311.1.nbc", "b": "kernel-1.py311.2.nbc"}
    assert cache_file.load("a") == "second" and cache_file.load("b") == "other"


def test_the_kernels_compile_through_the_locked_cache():
    from dloplan.sim import newton

    assert caching.IndexDataCacheFile.save is jit.locked_save
    assert newton.cholesky_band._cache._cache_file.save.__func__ is jit.locked_save


def test_a_numba_without_the_cache_internals_keeps_its_own_save(monkeypatch):
    monkeypatch.setattr(caching.IndexDataCacheFile, "save", jit.NUMBA_SAVE)
    monkeypatch.delattr(caching.IndexDataCacheFile, "_save_index")
    assert jit.install_cache_lock() is False
    assert caching.IndexDataCacheFile.save is jit.NUMBA_SAVE


def test_a_signal_during_a_cached_load_is_raised_after_the_load(monkeypatch, terminal_sigint):
    """A Ctrl-C that comes while numba rebuilds a cached overload waits for the rebuild to end
    (a half-linked library segfaulted, 1 in 20 Ctrl-Cs in identify), then ends the run."""
    jit.install_cache_lock()
    assert caching.Cache.load_overload is jit.shielded_load
    steps = []

    def load(cache, sig, context):
        steps.append("started")
        os.kill(os.getpid(), signal.SIGINT)  # delivered at the next byte code
        steps.append("finished")
        return "overload"

    monkeypatch.setattr(jit, "KERNEL_LOAD", load)
    monkeypatch.setattr(jit, "stamp_callees", steps.append)  # the index stamped before
    with catching_interrupts(), pytest.raises(Interrupted):
        jit.shielded_load(None, None, None)
    assert steps == [None, "started", "finished"] if jit.CAN_STAMP else ["started", "finished"]


KERNELS = '''
import sys

import numpy as np

from dloplan.jit import njit


@njit(cache=True)
def scaled(a, b):
    # LAPACK through numba's helper library (getrf) and an array from its runtime; the
    # determinant compiles in 40 % of np.linalg.solve's CPU (1.9 against 4.5 s), the same kinds
    # of calls for the cache to load
    return np.linalg.det(a) * b


def check(cached):
    x = scaled(np.array([[2.0, 1.0], [1.0, 3.0]]), np.array([3.0, 5.0]))
    assert np.allclose(x, [15.0, 25.0]), x
    # a cached overload comes without numba's registries (its polynomials among them), which
    # its compilation refreshed
    assert ("numba.np.polynomial.polynomial_core" in sys.modules) is not cached
    assert scaled.stats.cache_hits if cached else scaled.stats.cache_misses
    if cached:  # a kernel compiled afterwards in the same process gets them (numba's compiler
        # refreshes); after a compilation they are there: nothing of dloplan's to check
        fresh = njit(lambda a: np.linalg.det(a) + np.sum(np.empty(2) * 0.0))
        assert abs(fresh(np.eye(3) * 2.0) - 8.0) < 1e-12
'''


def test_a_cached_kernel_loads_without_numbas_registries_and_compiling_still_works(tmp_path):
    """jit.lean_load: the overload loaded from the cache runs, and so does a compilation after it
    (in a fresh process each: the first compiles and saves, the second loads)."""
    import subprocess
    import sys

    (tmp_path / "kernels.py").write_text(KERNELS)
    for cached in (False, True):
        done = subprocess.run([sys.executable, "-c", f"import kernels; kernels.check({cached})"],
                              cwd=tmp_path, capture_output=True, text=True, check=False)
        assert done.returncode == 0, done.stderr[-2000:]


LINKED = '''
import pickle
from pathlib import Path

import llvmlite.binding as ll
import numpy as np

from dloplan import jit
from dloplan.elf_symbols import defined_symbols


@jit.njit(cache=True)
def inner(x, k):
    return np.sum(x * x) + k


def check(cached):
    x = np.arange(4.0)
    assert inner(x, 0.5) == 14.5
    library = inner.overloads[inner.signatures[0]].library
    assert inner.stats.cache_hits if cached else inner.stats.cache_misses
    # loaded from the cache: its bitcode not parsed; compiled: numba's own library
    assert (library in jit.SHARED_BITCODE) is cached
    assert (library._shared_module is None) is cached
    # a kernel compiled afterwards that calls it links against its module (parsed now)
    fresh = jit.njit(lambda y: inner(y, 2.0) + 1.0)
    assert fresh(x) == 17.0
    assert library not in jit.SHARED_BITCODE and library._shared_module is not None
    # the object's symbol table names what the parsed module defines
    data = next(Path("__pycache__").glob("*.nbc")).read_bytes()
    _, kind, (object_code, bitcode) = pickle.loads(data)[0]
    module = ll.parse_bitcode(bitcode)
    assert kind == "object" and defined_symbols(object_code) == {
        g.name for group in (module.functions, module.global_variables) for g in group
        if not g.is_declaration}
'''


def test_a_cached_kernels_bitcode_is_parsed_only_when_a_compilation_links_it(tmp_path):
    """jit.lazy_unserialize: a kernel loaded from the cache runs without its shared bitcode
    parsed; a kernel compiled after it that calls it still links and computes the right value
    (a fresh process each, with its own cache folder: the first compiles and saves, the second
    loads)."""
    import subprocess
    import sys

    (tmp_path / "linked.py").write_text(LINKED)
    for cached in (False, True):
        done = subprocess.run([sys.executable, "-c", f"import linked; linked.check({cached})"],
                              cwd=tmp_path, capture_output=True, text=True, check=False)
        assert done.returncode == 0, done.stderr[-2000:]


def test_a_library_that_is_not_an_elf_object_is_loaded_by_numba(monkeypatch):
    calls = []
    monkeypatch.setattr(jit, "NUMBA_UNSERIALIZE", lambda *args: calls.append(args) or "numba's")
    state = ("kernel", "object", (b"\xcf\xfa\xed\xfe Mach-O", b"bitcode"))
    assert jit.lazy_unserialize(codegen.JITCodeLibrary, None, state) == "numba's"
    assert calls == [(codegen.JITCodeLibrary, None, state)]


def test_a_numba_without_the_library_internals_keeps_its_own_loading(monkeypatch):
    monkeypatch.setattr(codegen.CPUCodeLibrary, "_unserialize",
                        classmethod(jit.NUMBA_UNSERIALIZE))
    monkeypatch.setattr(codegen.CPUCodeLibrary, "_set_compiled_object", None)
    assert jit.install_lazy_linking() is False
    assert codegen.CPUCodeLibrary._unserialize.__func__ is jit.NUMBA_UNSERIALIZE
