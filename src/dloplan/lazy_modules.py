"""Import work a command never uses, left undone: numpy's unused submodules made lazy, scipy's
docstring edits skipped.

**numpy's submodules.** scipy (1.15 and later) vendors ``array_api_compat``, whose numpy
namespace is a clone of numpy's: it asks ``hasattr(numpy, name)`` for every name ``dir(numpy)``
lists, and numpy lists its lazily imported submodules there, so the first import of any scipy
subpackage imports ``numpy.testing`` (with ``unittest``), ``numpy.f2py`` (with its Fortran parser
and ``charset_normalizer``) and ``numpy.ma``. A plan uses ``numpy.ma`` (numba's ``typeof`` reads
``np.ma.MaskedArray`` on a kernel's first call), never the other two: about 40 modules, 0.05-0.1 s
of CPU in every command that imports scipy (docs/performance.md, branch imp2).

:func:`defer_numpy_submodules` puts these submodules into ``sys.modules`` (and on ``numpy``)
as :class:`importlib.util.LazyLoader` modules before scipy is imported: the clone then finds
them without running them, and the first attribute anyone reads from one
(``numpy.testing.assert_allclose``) executes the real module in place, as an import would have.
Nothing else changes: the same module objects, the same attributes once used.

**scipy's docstrings.** :func:`skip_scipy_docstring_edits`: scipy decorates its public functions
with ``xp_capabilities``, which parses each docstring (numpydoc's ``FunctionDoc``), appends an
"Array API Standard Support" table and renders it back, at import; a plan's scipy imports run it
154 times (module docstring of that function).
"""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Callable

NUMPY_UNUSED = ("testing", "f2py")
"""The numpy submodules made lazy: those scipy's namespace clone imports that a plan never uses
(``numpy.ma`` is: numba's ``typeof`` reads ``np.ma.MaskedArray`` on a kernel's first call, so
deferring it would only move its import)."""


def defer_numpy_submodules(names: tuple[str, ...] = NUMPY_UNUSED) -> list[str]:
    """Make numpy's submodules ``names`` lazy (see the module docstring); imports numpy.

    A submodule already imported (or without a loader that can be deferred) is left as it is.
    Call it before scipy is imported, from the main thread (Python 3.11's lazy modules are
    not safe to run first from two threads at once).

    Returns
    -------
    list of str
        The full names of the submodules made lazy by this call.
    """
    import numpy

    deferred = []
    for name in names:
        full = f"{numpy.__name__}.{name}"
        if full in sys.modules:
            continue
        spec = importlib.util.find_spec(full)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            continue
        spec.loader = importlib.util.LazyLoader(spec.loader)
        module = importlib.util.module_from_spec(spec)
        sys.modules[full] = module
        spec.loader.exec_module(module)
        setattr(numpy, name, module)  # as an import would: ``numpy.__getattr__`` is not asked
        deferred.append(full)
    return deferred


class _KeptDoc:
    """Stands for scipy's ``FunctionDoc`` in its ``xp_capabilities`` decorator: parses nothing,
    takes the note appended to its ``Notes`` section and gives back the function's own
    docstring (after the signature line the decorator cuts off)."""

    def __init__(self, function) -> None:
        self._doc = getattr(function, "__doc__", None) or ""

    def __getitem__(self, section: str) -> list:
        return []  # the note appended to it is dropped

    def __str__(self) -> str:
        return "\n" + self._doc


def _no_note(*args, **kwargs) -> str:
    """Stands for scipy's ``_make_capabilities_note``: no table to render."""
    return ""


def _keeps_docstrings(decorate: Callable, table: dict) -> bool:
    """Whether scipy's ``xp_capabilities`` (``decorate``), with the stand-ins in place, leaves a
    function's docstring as it is and still records the function in its ``table``."""

    def probe() -> None:
        """The probe's summary.

        Notes
        -----
        Its own note.
        """

    expected = probe.__doc__.lstrip(" \n")
    try:
        decorated = decorate()(probe)
    except Exception:  # noqa: BLE001 - another scipy's decorator: leave it alone
        return False
    recorded = table.pop(probe, None) is not None
    return decorated is probe and probe.__doc__ == expected and recorded


def skip_scipy_docstring_edits() -> bool:
    """Skip the docstring edits scipy makes while a command imports it; imports ``scipy._lib``.

    **Where scipy's import CPU goes.** Profiling the imports of the 210 scipy modules a plan
    imports (scipy 1.17: ``-X importtime``, then cProfile of the same imports) puts about a
    third of their time in docstrings: ``scipy._lib._array_api.xp_capabilities``, the decorator
    on scipy's public functions and ufuncs (``Rotation``'s module, ``scipy.special``,
    ``scipy.sparse``, ``scipy.linalg``), parses each docstring with numpydoc's ``FunctionDoc``
    (``textwrap``, ``inspect.cleandoc``, regular expressions, a deep copy of the section
    table), appends an "Array API Standard Support" table to its Notes and renders it back
    into ``__doc__``; 154 functions per plan. Besides, the decorator records the function's
    capabilities in ``xp_capabilities_table`` (read by scipy's own test suite). scipy's
    ``doccer`` (the distributions' docstrings) runs in ``scipy.stats`` and ``scipy.ndimage``,
    which a plan does not import.

    **What is skipped, and how.** The decorator looks up ``FunctionDoc`` and
    ``_make_capabilities_note`` in its module when it decorates; they are replaced by stand-ins
    that parse and render nothing, so the decorator records the capabilities as before and
    sets ``__doc__`` to the function's own docstring (leading blank lines stripped), without
    the table. Nothing scipy computes depends on a docstring; only ``help()`` on a scipy
    function in this process would miss the table. Before relying on it the stand-ins are
    tried on a probe function: if this scipy's decorator does not keep its docstring and record
    it (another version, another decorator), they are taken back and nothing is skipped.

    **When.** Only in a process that has not imported scipy yet (a command run from the shell:
    ``dloplan plan``, ``dloplan demo``): a process that has (a test session, a program calling
    :func:`dloplan.cli.main`) has had its docstrings edited already, and keeps scipy as it is.
    Call it after :func:`defer_numpy_submodules` (it imports scipy).

    Returns
    -------
    bool
        True if the edits are skipped from now on in this process.
    """
    if "scipy" in sys.modules:  # (any of its subpackages imports it first)
        return False
    try:
        from scipy._lib import _array_api
    except ImportError:
        return False
    return skip_docstring_edits_of(_array_api)


def skip_docstring_edits_of(api) -> bool:
    """Put the stand-ins of :func:`skip_scipy_docstring_edits` into ``api`` (scipy's
    ``scipy._lib._array_api``, or a module with the same four names) and keep them if its
    ``xp_capabilities`` then leaves a probe function's docstring as it is and records the
    probe in ``xp_capabilities_table``; otherwise put its own back.

    Returns
    -------
    bool
        True if the stand-ins are in place.
    """
    names = ("FunctionDoc", "_make_capabilities_note", "xp_capabilities", "xp_capabilities_table")
    if not all(hasattr(api, name) for name in names):
        return False
    kept = api.FunctionDoc, api._make_capabilities_note
    api.FunctionDoc, api._make_capabilities_note = _KeptDoc, _no_note
    if _keeps_docstrings(api.xp_capabilities, api.xp_capabilities_table):
        return True
    api.FunctionDoc, api._make_capabilities_note = kept
    return False
