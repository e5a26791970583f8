"""Calls between dloplan's compiled kernels pass typed values, not literal constants.

numba compiles a kernel called from another kernel with a constant argument (``f(x, 2)``,
``g(x, True)``) for the constant's literal type (``Literal[int](2)``): a second overload of the
callee beside the one that a call with a variable, or from Python, compiles. The warm-up, and a
first run, compile and cache both (docs/performance.md: ``ik_compiled.solve``, ``model_step``,
``twist_trial``, ``twist_stencils``... had two overloads each). Where the constant only selects
an offset or a branch the caller passes ``np.int64(2)`` or ``np.bool_(True)`` (:mod:`dloplan.jit`).
A kernel inlined at numba's IR level (``inline="always"``) has no overload of its own and may
take literals (the banded Cholesky's unrolled widths, :mod:`dloplan.sim.newton`).
"""

from __future__ import annotations

import ast
from pathlib import Path

import dloplan

SOURCE = Path(dloplan.__file__).parent


def _njit_options(function: ast.FunctionDef) -> dict | None:
    """The keyword options of the function's ``@njit(...)`` decorator, None if it has none."""
    for decorator in function.decorator_list:
        call = decorator if isinstance(decorator, ast.Call) else None
        name = call.func if call is not None else decorator
        if getattr(name, "id", getattr(name, "attr", None)) == "njit":
            return {} if call is None else {k.arg: k.value for k in call.keywords}
    return None


def _kernels(trees) -> dict[str, bool]:
    """Every module-level kernel's name -> whether it has an overload of its own (not inlined)."""
    kernels: dict[str, bool] = {}
    for tree in trees.values():
        for node in tree.body:
            options = _njit_options(node) if isinstance(node, ast.FunctionDef) else None
            if options is not None:
                inline = options.get("inline")
                own = not (isinstance(inline, ast.Constant) and inline.value == "always")
                kernels[node.name] = kernels.get(node.name, False) or own
    return kernels


def literal_calls(root: Path = SOURCE) -> list[str]:
    """``file:line caller -> callee(literals)`` for every call from a kernel to a kernel with an
    overload of its own that passes an int or bool literal."""
    trees = {path: ast.parse(path.read_text()) for path in sorted(root.rglob("*.py"))}
    kernels = _kernels(trees)
    found = []
    for path, tree in trees.items():
        for caller in tree.body:
            if not isinstance(caller, ast.FunctionDef) or _njit_options(caller) is None:
                continue
            for call in ast.walk(caller):
                if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name)
                        and kernels.get(call.func.id)):
                    continue
                values = [*call.args, *(k.value for k in call.keywords)]
                literals = [ast.unparse(v) for v in values if isinstance(v, ast.Constant)
                            and isinstance(v.value, (bool, int))]
                if literals:
                    found.append(f"{path.relative_to(root)}:{call.lineno} {caller.name} -> "
                                 f"{call.func.id}({', '.join(literals)})")
    return found


def test_no_kernel_passes_a_literal_to_another_kernel():
    assert literal_calls() == []


def test_the_check_sees_a_literal_between_kernels_and_not_into_an_inlined_one(tmp_path):
    (tmp_path / "kernels.py").write_text(
        "from numba import njit\n\n"
        "@njit(cache=True)\ndef callee(x, flag):\n    return x\n\n"
        "@njit(cache=True, inline='always')\ndef inlined(x, width):\n    return x\n\n"
        "@njit(cache=True)\ndef caller(x):\n"
        "    return callee(x, True) + callee(x, np.bool_(True)) + inlined(x, 8)\n\n"
        "def python(x):\n    return callee(x, 2)\n")
    assert literal_calls(tmp_path) == ["kernels.py:13 caller -> callee(True)"]
