"""Robustness studies: how likely a plan is to work on the real cable (issue 14).

Reading order: :mod:`.spec` (the ``study:`` section: what varies and what counts as success),
:mod:`.sampling` (Latin hypercube or per-sample random draws), :mod:`.evaluate` (one sample:
perturbed cable, clips and obstacles, every shape stabilized and measured), :mod:`.backends`
(serial, local processes, Dask), :mod:`.results` (chunked Parquet/CSV files that resume),
:mod:`.summary` (success probability with its interval, rank-correlation sensitivities) and
:mod:`.run` (:func:`run_study`, tying them together).

Dask and pyarrow are imported only when a Dask backend is made or a Parquet file is touched.
"""

from .backends import (
    Backend,
    DaskBackend,
    ProcessBackend,
    SerialBackend,
    make_backend,
    map_jobs,
)
from .evaluate import StudyProblem, evaluate_chunk, evaluate_sample, study_problem
from .results import read_chunks, read_manifest, read_table, write_table
from .run import Progress, StudyResult, run_study
from .sampling import Samples, draw_samples
from .spec import CriteriaSpec, StudyError, StudySpec, Variation, parse_study
from .summary import Sensitivity, StudySummary, success_interval, summarize

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
    "study_problem",
    "success_interval",
    "summarize",
    "write_table",
]
