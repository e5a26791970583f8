"""numpy's submodules that importing scipy loads and a command never uses, made lazy.

scipy (1.15 and later) vendors ``array_api_compat``, whose numpy namespace is a clone of
numpy's: it asks ``hasattr(numpy, name)`` for every name ``dir(numpy)`` lists, and numpy lists
its lazily imported submodules there, so the first import of any scipy subpackage imports
``numpy.testing`` (with ``unittest``), ``numpy.f2py`` (with its Fortran parser and
``charset_normalizer``) and ``numpy.ma``. A plan uses ``numpy.ma`` (numba's ``typeof`` reads
``np.ma.MaskedArray`` on a kernel's first call), never the other two: about 40 modules, 0.05-0.1 s
of CPU in every command that imports scipy (docs/performance.md, branch imp2).

:func:`defer_numpy_submodules` puts these submodules into ``sys.modules`` (and on ``numpy``)
as :class:`importlib.util.LazyLoader` modules before scipy is imported: the clone then finds
them without running them, and the first attribute anyone reads from one
(``numpy.testing.assert_allclose``) executes the real module in place, as an import would have.
Nothing else changes: the same module objects, the same attributes once used.
"""

from __future__ import annotations

import importlib.util
import sys

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
