"""Robustness studies: how likely a plan is to work on the real cable (issue 14).

Reading order: :mod:`.spec` (the ``study:`` section: what varies and what counts as success),
:mod:`.sampling` (Latin hypercube or per-sample random draws), :mod:`.evaluate` (one sample:
perturbed cable, clips and obstacles, every shape stabilized and measured), :mod:`.backends`
(serial, local processes, Dask), :mod:`.results` (chunked Parquet/CSV files that resume),
:mod:`.summary` (success probability with its interval, rank-correlation sensitivities) and
:mod:`.run` (:func:`run_study`, tying them together).

Dask and pyarrow are imported only when a Dask backend is made or a Parquet file is touched.
"""

import importlib

_EXPORTS = {
    "backends": ("Backend", "DaskBackend", "ProcessBackend", "SerialBackend", "make_backend",
                 "map_jobs"),
    "evaluate": ("StudyProblem", "evaluate_chunk", "evaluate_sample", "study_problem"),
    "results": ("read_chunks", "read_manifest", "read_table", "write_table"),
    "run": ("Progress", "StudyResult", "run_study"),
    "sampling": ("Samples", "draw_samples", "study_frame"),
    "spec": ("CriteriaSpec", "StudyError", "StudySpec", "Variation", "parse_study"),
    "summary": ("Sensitivity", "StudySummary", "success_interval", "summarize"),
}
"""The package's names by the submodule that defines them. A submodule is imported when one of
its names is first read (``from dloplan.study import run_study``, PEP 562): a scenario's
``study:`` section needs :mod:`.spec` alone, so ``dloplan plan`` does not import the sampling,
the backends, the results' files and the summary (docs/performance.md, branch imp3)."""

_SUBMODULE = {name: module for module, names in _EXPORTS.items() for name in names}


def __getattr__(name: str):
    """``dloplan.study.<name>``: the name from its submodule, imported on first use."""
    module = _SUBMODULE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)


__all__ = [
    "Backend",
    "CriteriaSpec",
    "DaskBackend",
    "Progress",
    "ProcessBackend",
    "Samples",
    "Sensitivity",
    "SerialBackend",
    "StudyError",
    "StudyProblem",
    "StudyResult",
    "StudySpec",
    "StudySummary",
    "Variation",
    "draw_samples",
    "evaluate_chunk",
    "evaluate_sample",
    "make_backend",
    "map_jobs",
    "parse_study",
    "read_chunks",
    "read_manifest",
    "read_table",
    "run_study",
    "study_frame",
    "study_problem",
    "success_interval",
    "summarize",
    "write_table",
]
