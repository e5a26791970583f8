"""numba's runtime functions kept compiled on disk (dloplan.jit_runtime)."""

from __future__ import annotations

import os
import subprocess
import sys

from numba.core.runtime import nrtdynmod

from dloplan import jit_runtime

RUNTIME = '''
import sys
from pathlib import Path

import numpy as np
from numba.core.runtime import rtsys

from dloplan import jit


@jit.njit(cache=True)
def doubled(x):
    out = np.empty_like(x)  # allocated and reference counted by numba's runtime
    out[:] = 2.0 * x
    return out


def check(cached):
    files = sorted(Path(sys.argv[1]).glob("numba-runtime-*.nbr"))
    assert len(files) == int(cached), files
    assert doubled(np.arange(3.0)).tolist() == [0.0, 2.0, 4.0]
    # loaded from its file (lazily, as a cached kernel), or compiled and then saved
    assert (rtsys.library in jit.SHARED_BITCODE) is cached
    assert len(list(Path(sys.argv[1]).glob("numba-runtime-*.nbr"))) == 1
    # a kernel compiled afterwards links the runtime's functions and runs
    fresh = jit.njit(lambda n: np.ones(n).sum() + doubled(np.ones(n)).sum())
    assert fresh(4) == 12.0
'''


def test_the_runtime_is_compiled_once_then_loaded_and_still_links(tmp_path):
    """The first process compiles numba's runtime and saves it (with NUMBA_CACHE_DIR set, in
    that folder), the second loads it; kernels cached and compiled after it run in both."""
    (tmp_path / "runtime.py").write_text(RUNTIME)
    cache = tmp_path / "cache"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    for cached in (False, True):
        done = subprocess.run([sys.executable, "-c", f"import runtime; runtime.check({cached})",
                               str(cache)], cwd=tmp_path, env=env, capture_output=True,
                              text=True, check=False)
        assert done.returncode == 0, done.stderr[-2000:]


def test_the_file_is_named_by_the_module_and_the_cpu():
    one = jit_runtime.runtime_file("define void @f()", ("x86_64", "znver3", "+avx2"))
    assert one == jit_runtime.runtime_file("define void @f()", ("x86_64", "znver3", "+avx2"))
    assert one != jit_runtime.runtime_file("define void @g()", ("x86_64", "znver3", "+avx2"))
    assert one != jit_runtime.runtime_file("define void @f()", ("x86_64", "znver3", "-avx2"))


def test_a_folder_that_cannot_be_written_leaves_no_file_and_no_error(tmp_path):
    blocker = tmp_path / "a file"
    blocker.write_text("")  # its "folder" cannot be made (as a read-only installation's)
    jit_runtime.save_state(blocker / "cache" / "numba-runtime-x.nbr", ("nrt", "object", ()))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a file"]


def test_a_numba_without_the_runtime_module_keeps_its_own(monkeypatch):
    monkeypatch.setattr(nrtdynmod, "compile_nrt_functions", jit_runtime.NUMBA_NRT_FUNCTIONS)
    monkeypatch.delattr(nrtdynmod, "create_nrt_module")
    assert jit_runtime.install_runtime_cache() is False
    assert nrtdynmod.compile_nrt_functions is jit_runtime.NUMBA_NRT_FUNCTIONS
