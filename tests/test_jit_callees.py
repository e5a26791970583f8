"""A kernel's cache made stale by a change of a kernel it calls in another file
(dloplan.jit_callees)."""

from __future__ import annotations

import subprocess
import sys
import types

import numpy as np

from dloplan import jit_callees
from dloplan.jit import njit
from dloplan.sim import compiled, newton

CALLEE = '''
from dloplan.jit import njit


@njit(cache=True)
def inner(x):
    return x * 2.0
'''

CONSTANTS = '''
OFFSET = 1.0
'''

CALLER = '''
import sys

from dloplan.jit import njit
from callee import inner
from constants import OFFSET


@njit(cache=True)
def outer(x):
    return inner(x) + OFFSET


def check(expected, cached):
    assert outer(3.0) == expected, outer(3.0)
    stats = outer.stats
    assert (stats.cache_hits if cached else stats.cache_misses), stats
'''


def _run(folder, expected, cached):
    """outer(3.0) in a fresh process with ``folder``'s own numba cache."""
    env = {"NUMBA_CACHE_DIR": str(folder / "cache"), "PATH": "/usr/bin:/bin"}
    done = subprocess.run(
        [sys.executable, "-c", f"import caller; caller.check({expected}, {cached})"],
        cwd=folder, env=env, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr[-2000:]


def test_a_kernel_sees_a_changed_kernel_it_calls_from_another_file(tmp_path):
    """outer (caller.py) calls inner (callee.py) and reads OFFSET (constants.py). After inner's
    body changes, a new process's outer computes with the new inner, and after OFFSET changes
    with the new OFFSET (numba alone: the cached outer kept the old code, 7.0 both times);
    unchanged, outer loads from the cache (the stamp is the same in every process)."""
    (tmp_path / "callee.py").write_text(CALLEE)
    (tmp_path / "constants.py").write_text(CONSTANTS)
    (tmp_path / "caller.py").write_text(CALLER)
    _run(tmp_path, 7.0, cached=False)
    _run(tmp_path, 7.0, cached=True)
    (tmp_path / "callee.py").write_text(CALLEE.replace("x * 2.0", "x * 5.0"))
    _run(tmp_path, 16.0, cached=False)
    (tmp_path / "constants.py").write_text(CONSTANTS.replace("1.0", "0.5"))
    _run(tmp_path, 15.5, cached=False)


SCALE = (2.0, np.arange(3.0))


@njit
def _scaled(x):
    return x * SCALE[0]


def test_references_follow_globals_module_attributes_cells_and_tuples():
    kernels = (_scaled,)

    def reader(x):
        return compiled.model_step(x) + kernels[0](x) + newton.NEUTRAL + SCALE[1][0] + np.pi

    found, constants = jit_callees.references(reader)
    assert set(found) == {compiled.model_step, _scaled}
    assert f"SCALE={jit_callees.constant_text(SCALE)}" in constants
    assert f"dloplan.sim.newton.NEUTRAL={newton.NEUTRAL!r}" in constants
    assert f"numpy.pi={np.pi!r}" in constants


def test_constant_text_changes_with_the_value_and_skips_other_objects():
    assert jit_callees.constant_text(np.arange(3.0)) != jit_callees.constant_text(np.arange(3))
    assert jit_callees.constant_text((1, np.float64(2.0))) == "(1, np.float64(2.0))"
    assert jit_callees.constant_text((1, object())) is None
    assert jit_callees.constant_text(types) is None


def test_the_digest_of_a_dloplan_kernel_covers_the_files_of_its_callees(monkeypatch):
    """newton_twist (sim/compiled.py) calls kernels of sim/newton.py and
    physics/twist_compiled.py, which calls kernels of physics/rod_frames.py: a change in any of
    these files changes its digest; a file none of its kernels is in does not."""
    kernel = compiled.newton_twist.py_func
    before = jit_callees.callees_digest(kernel)
    assert jit_callees.callees_digest(kernel) == before
    real = jit_callees.file_digest
    for module, changed in (("sim.newton", True), ("physics.twist_compiled", True),
                            ("physics.rod_frames", True), ("sim.stepping", False)):
        path = sys.modules[f"dloplan.{module}"].__file__
        monkeypatch.setattr(jit_callees, "file_digest",
                            lambda p, path=path: "edited" if p == path else real(p))
        assert (jit_callees.callees_digest(kernel) != before) is changed, module
