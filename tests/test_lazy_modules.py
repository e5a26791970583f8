"""scipy's docstring edits skipped at import (dloplan.lazy_modules.skip_scipy_docstring_edits).

- In a fresh process the skip takes: the scipy modules a plan imports record the same
  functions in scipy's capabilities table as without it, their docstrings are their own
  (none carries the appended "Array API Standard Support" table, every one does without the
  skip), and what scipy computes is the same.
- A process that imported scipy already is left as it is; a decorator that does not keep the
  probe's docstring (another scipy) gets its own parts back.
"""

from __future__ import annotations

import json
import subprocess
import sys
import types

from dloplan.lazy_modules import skip_docstring_edits_of, skip_scipy_docstring_edits

NOTE = "Array API Standard Support"

IMPORTS = """
import json, sys
from dloplan.lazy_modules import defer_numpy_submodules, skip_scipy_docstring_edits
defer_numpy_submodules()
skipped = skip_scipy_docstring_edits() if sys.argv[1] == "skip" else None
import numpy as np
import scipy.linalg, scipy.sparse.linalg, scipy.special
from scipy.spatial.transform import Rotation
from scipy._lib._array_api import xp_capabilities_table as table
docs = {f"{getattr(f, '__module__', '')}.{f.__name__}": f.__doc__ or "" for f in table}
rotation = Rotation.from_euler("xyz", [0.1, 0.2, 0.3]).as_quat().tolist()
values = scipy.special.logsumexp(np.arange(5.0)), scipy.linalg.expm(np.eye(2)).sum()
print(json.dumps([skipped, docs, rotation, [float(v) for v in values]]))
"""


def _imported(mode: str) -> list:
    done = subprocess.run([sys.executable, "-c", IMPORTS, mode], capture_output=True,
                          text=True, check=True)
    return json.loads(done.stdout.splitlines()[-1])


def test_a_fresh_process_skips_the_edits_and_keeps_everything_else():
    skipped, docs, rotation, values = _imported("skip")
    _, edited, rotation_edited, values_edited = _imported("edit")
    assert skipped is True
    assert docs.keys() == edited.keys() and len(docs) > 100
    assert not any(NOTE in doc for doc in docs.values())
    assert all(NOTE in doc for doc in edited.values())
    # the function's own text, as scipy's rendering of it began (its summary line)
    logsumexp = "scipy.special._logsumexp.logsumexp"
    assert docs[logsumexp].splitlines()[0] == edited[logsumexp].splitlines()[0]
    assert "Parameters" in docs[logsumexp]
    assert rotation == rotation_edited and values == values_edited


def test_a_process_with_scipy_imported_is_left_as_it_is():
    from scipy._lib import _array_api

    builder = _array_api.FunctionDoc
    assert "scipy" in sys.modules
    assert skip_scipy_docstring_edits() is False
    assert _array_api.FunctionDoc is builder


def test_a_decorator_that_does_not_keep_the_docstring_gets_its_parts_back():
    def builder(function):
        raise AssertionError("not called by this decorator")

    def note(*args):
        return "note"

    def rewriting(**kwargs):
        def decorate(f):
            table[f] = kwargs
            f.__doc__ = "rewritten"
            return f
        return decorate

    table = {}
    api = types.SimpleNamespace(FunctionDoc=builder, _make_capabilities_note=note,
                                xp_capabilities=rewriting, xp_capabilities_table=table)
    assert skip_docstring_edits_of(api) is False
    assert api.FunctionDoc is builder and api._make_capabilities_note is note
    assert skip_docstring_edits_of(types.SimpleNamespace(FunctionDoc=builder)) is False
