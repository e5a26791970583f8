"""Run a study: draw the samples, evaluate them in chunks on a backend, store, summarize.

:func:`run_study` is the library function behind ``dloplan study``. The N samples are split
into chunks of ``spec.chunk`` consecutive sample indices; a chunk is one task on the
backend and one file in the study folder. Chunks complete in any order; each is written the
moment it arrives, and ``progress`` is called after each. An interruption (Ctrl-C, a killed
job, a ``progress`` callback that raises) leaves the completed chunks on disk; running the
same study into the same folder again evaluates only the missing chunks, and the final table
(chunks concatenated in sample order) is the same as that of an uninterrupted run.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..interrupts import keeping
from ..output_files import atomic_write_text
from .backends import Backend, SerialBackend, map_jobs
from .evaluate import COLUMN_TYPES, OUTCOME_COLUMNS, StudyProblem, evaluate_chunk
from .results import (
    MANIFEST,
    chunk_path,
    concat_tables,
    fingerprint,
    open_folder,
    read_chunks,
    result_path,
    write_table,
)
from .sampling import Samples, draw_samples, parameter_columns, study_frame
from .spec import StudySpec, parse_study
from .summary import StudySummary, summarize


@dataclass(frozen=True)
class Progress:
    """Passed to the progress callback after every chunk.

    Attributes
    ----------
    chunks_done, chunks_total : int
        Chunks completed (including those found on disk when resuming) and in all.
    samples_done, samples_total : int
        Samples completed and in all.
    elapsed : float
        Wall time since the start of this run [s].
    chunk : int
        The chunk just completed.
    samples_run : int
        Samples evaluated by this run (not those resumed from disk).
    """

    chunks_done: int
    chunks_total: int
    samples_done: int
    samples_total: int
    elapsed: float
    chunk: int
    samples_run: int = 0

    def line(self) -> str:
        """``chunk 3/10, 48/160 samples, 2.1 s, 23 samples/s, about 4.9 s left`` (the rate of
        this run alone, so a resumed study does not count the samples found on disk)."""
        rate = self.samples_run / self.elapsed if self.elapsed > 0 else 0.0
        left = (self.samples_total - self.samples_done) / rate if rate > 0 else float("nan")
        eta = f", about {left:.0f} s left" if rate > 0 and left > 0 else ""
        return (f"chunk {self.chunks_done}/{self.chunks_total}, {self.samples_done}/"
                f"{self.samples_total} samples, {self.elapsed:.1f} s, {rate:.1f} samples/s{eta}")


@dataclass(frozen=True, eq=False)
class StudyResult:
    """A finished study.

    Attributes
    ----------
    table : dict
        Column -> (N (S + 2),) array, one row per sample and shape, sample-major.
    summary : StudySummary
        Success probability, interval, failures per criterion, sensitivities.
    samples : Samples
        The parameter values of every sample.
    spec : StudySpec
        The study description.
    folder : pathlib.Path or None
        Where the chunks, table and summary were written.
    chunks_run, chunks_resumed : int
        Chunks evaluated by this call, and found complete on disk.
    elapsed : float
        Wall time of this call [s].
    backend : str
        Where the chunks ran.
    """

    table: dict
    summary: StudySummary
    samples: Samples
    spec: StudySpec
    folder: Path | None
    chunks_run: int
    chunks_resumed: int
    elapsed: float
    backend: str

    @property
    def success(self) -> bool:
        """Every sample was evaluated (the study itself ran; not that the plan is robust)."""
        return len(np.unique(self.table["sample"])) == self.spec.samples

    @property
    def message(self) -> str:
        return self.summary.lines()[0]


def column_schema(n_obstacles: int) -> dict:
    """Every column of a study table: ``{name: {"unit": ..., "dtype": ...}}``, in order."""
    units = {"sample": "", "shape": "", **parameter_columns(n_obstacles), **OUTCOME_COLUMNS}
    return {name: {"unit": unit, "dtype": COLUMN_TYPES.get(name, "float64")}
            for name, unit in units.items()}


def problem_fingerprint(problem: StudyProblem, spec: StudySpec) -> str:
    """Identity of a study: spec, cable, planned shapes, clips, obstacles and gravity.

    The ``correction:`` section is left out: the closed loop runs after the table, every time,
    so changing it keeps the completed chunks (and folders from before it existed stay valid).
    The job's frame on the table (:func:`~dloplan.study.sampling.study_frame`) is in it when it
    is not the world's.
    """
    cable = problem.cable
    constants = {k: v for k, v in asdict(cable).items() if k != "rest_shape"}
    rest = cable.rest_shape if cable.rest_shape is not None else np.zeros(0)
    clips = np.concatenate([np.concatenate([c.positions.ravel(), c.rotations.as_quat().ravel()])
                            for c in problem.clips])
    # a job not along +y draws its offsets turned (round 9): a folder its samples were drawn
    # for in the world frame is another study; a job along +y draws what it drew, and keeps it
    turn = study_frame(problem.clips[0]).as_rotvec()
    frame = [turn] if turn.any() else []
    return fingerprint(spec.model_dump(mode="json", exclude={"correction"}), constants, rest,
                       problem.planned, clips, [repr(o) for o in problem.obstacles],
                       problem.gravity, *frame)


def chunk_items(samples: Samples, chunk_size: int, chunks) -> list[dict]:
    """The work items of the given chunks: ``{"sample": indices, <parameter columns>}``."""
    n = len(samples)
    items = []
    for k in chunks:
        indices = np.arange(k * chunk_size, min((k + 1) * chunk_size, n))
        items.append({"sample": indices, **samples.take(indices)})
    return items


def run_study(
    problem: StudyProblem,
    spec: StudySpec | dict,
    *,
    out=None,
    backend: Backend | None = None,
    progress: Callable[[Progress], None] | None = None,
    resume: bool = True,
    file_format: str = "parquet",
) -> StudyResult:
    """Evaluate every sample of a study (see the module docstring).

    Parameters
    ----------
    problem : StudyProblem
        The nominal plan (:func:`~dloplan.study.evaluate.study_problem`).
    spec : StudySpec or dict
        The study description (a dict is validated as the ``study:`` section).
    out : str or os.PathLike, optional
        Study folder (see :mod:`dloplan.study.results`); ``None`` keeps everything in memory
        (no resume).
    backend : Backend, optional
        Where chunks run; default :class:`~dloplan.study.backends.SerialBackend`.
    progress : callable, optional
        Called with a :class:`Progress` after each chunk; an exception it raises stops the
        study (completed chunks stay on disk).
    resume : bool
        Skip chunks already in ``out`` (default); ``False`` starts the folder over.
    file_format : {"parquet", "csv"}
        Format of the chunk and result files.

    Returns
    -------
    StudyResult
        The table (same for the same spec and problem, whatever the backend and however often
        the study was interrupted) and its summary.
    """
    started = time.perf_counter()
    spec = parse_study(spec)
    if not isinstance(problem, StudyProblem):
        raise ValueError(f"problem: got {type(problem).__name__}, expected a StudyProblem "
                         "(dloplan.study.study_problem)")
    backend = backend or SerialBackend()
    samples = draw_samples(spec, problem.cable, problem.obstacles,
                           study_frame(problem.clips[0]))
    n_chunks = -(-spec.samples // spec.chunk)
    schema = column_schema(len(problem.obstacles))
    units = {name: c["unit"] for name, c in schema.items()}
    folder = None if out is None else Path(out)
    on_disk = 0  # chunk files complete in the folder (kept() reads its current value)

    def kept() -> str | None:
        if folder is None or not (folder / MANIFEST).exists():
            return None
        return (f"the study folder {folder} with {on_disk} of {n_chunks} chunks complete "
                "(the same command resumes from it)")

    with keeping(kept):
        done: list[int] = []
        if folder is not None:
            manifest = {"fingerprint": problem_fingerprint(problem, spec),
                        "file_format": file_format, "n_samples": spec.samples,
                        "chunk_size": spec.chunk, "n_chunks": n_chunks,
                        "n_shapes": problem.n_shapes, "study": spec.model_dump(mode="json"),
                        "columns": schema}
            done = open_folder(folder, manifest, resume=resume)
            on_disk = len(done)
        todo = [k for k in range(n_chunks) if k not in set(done)]
        tables: dict[int, dict] = {}
        samples_done = sum(_chunk_length(k, spec) for k in done)
        samples_run = 0
        items = chunk_items(samples, spec.chunk, todo)
        metadata = {"fingerprint": manifest["fingerprint"]} if folder else None
        for count, (position, table) in enumerate(
                map_jobs(evaluate_chunk, items, backend, shared=problem), start=1):
            chunk = todo[position]
            if folder is not None:
                write_table(chunk_path(folder, chunk, file_format), table, units, metadata)
                on_disk += 1
            else:
                tables[chunk] = table
            samples_done += _chunk_length(chunk, spec)
            samples_run += _chunk_length(chunk, spec)
            if progress is not None:
                progress(Progress(len(done) + count, n_chunks, samples_done, spec.samples,
                                  time.perf_counter() - started, chunk, samples_run))
    if folder is not None:
        table = read_chunks(folder)
        write_table(result_path(folder, file_format), table, units, metadata)
    else:
        table = concat_tables([tables[k] for k in sorted(tables)])
    summary = summarize(table, spec.criteria, confidence=spec.confidence)
    if folder is not None:
        atomic_write_text(folder / "summary.json", json.dumps(summary.to_dict(), indent=2))
    return StudyResult(table, summary, samples, spec, folder, len(todo), len(done),
                       time.perf_counter() - started, backend.describe())


def _chunk_length(chunk: int, spec: StudySpec) -> int:
    return min(spec.chunk, spec.samples - chunk * spec.chunk)
