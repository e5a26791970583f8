"""A robustness study of a job: the very plan ``dloplan plan`` makes, perturbed sample by sample.

The nominal plan is the one ``dloplan plan`` makes (:func:`dloplan.pipeline.make_plan`: the
same weights, family, physical mode, obstacle re-planning, gripper frames, checks and repairs),
so the study's nominal stabilized shapes are the plan's, and a sample with zero spread
reproduces them. The study itself runs in :mod:`dloplan.study`.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

from ..cable import GRAVITY
from ..output_files import atomic_write_text
from ..pipeline.document import PlanDocument
from ..pipeline.job import Job
from ..study.evaluate import StudyProblem
from ..study.run import StudyResult
from ..study.spec import StudyError, StudySpec, parse_study


def study_problem_of(doc: PlanDocument) -> StudyProblem:
    """The study problem of a plan document: its shapes, gripper clip poses and stabilized path."""
    from ..pipeline.stages import settled_shapes

    return StudyProblem(doc.cable, doc.shapes, tuple(doc.clip_poses()), settled_shapes(doc),
                        tuple(doc.obstacles), GRAVITY)


def study_spec(job: Job, samples: int | None = None, seed: int | None = None) -> StudySpec:
    """The job's ``study:`` section with command-line overrides, validated by the same schema.

    Raises
    ------
    StudyError
        No ``study:`` section or no parameters (a study with nothing to vary), an override the
        schema refuses (e.g. ``samples: 0``), or a ``correction.at`` that is not a shape before
        the target: all before any work is done.
    """
    if job.study is None:
        raise StudyError(f"{job.source}: no study section: nothing to vary (see docs/study.md)")
    data = job.study.model_dump()
    data.update({k: v for k, v in (("samples", samples), ("seed", seed)) if v is not None})
    spec = parse_study(data, f"{job.source}: study")
    if not spec.parameters:
        raise StudyError(f"{job.source}: study.parameters: none given: nothing varies; "
                         "expected at least one parameter with its spread (docs/study.md)")
    last = job.planner.n_shapes  # shapes 0 .. S + 1; the target cannot be corrected
    if spec.correction is not None and spec.correction.at > last:
        raise StudyError(f"{job.source}: study.correction.at: got {spec.correction.at}, "
                         f"expected a shape 0 .. {last} (the plan has S + 2 = {last + 2} "
                         "shapes; the target cannot be corrected)")
    return spec


def with_closed_loop(doc: PlanDocument, result: StudyResult, backend=None) -> StudyResult:
    """The study result with its closed-loop success (the spec's ``correction:`` section).

    Runs :func:`dloplan.correct.closed_loop_study` on the study's samples and the plan; the
    summary gains ``closed_loop`` (its lines, ``summary.json`` and the figures show it); with a
    study folder, ``closed_loop.json`` holds every sample's row and ``summary.json`` is
    rewritten. Without a ``correction:`` section the result is returned as it is. The samples
    run on ``backend`` (default: this process), like the study's.
    """
    from ..correct import closed_loop_study
    from ..pipeline.stages import settled_shapes

    spec = result.spec.correction
    if spec is None:
        return result
    rows, success = closed_loop_study(doc.cable, doc.shapes, doc.grippers, result.samples, spec,
                                      stabilized=settled_shapes(doc), trajectory=doc.trajectory,
                                      confidence=result.spec.confidence, gravity=GRAVITY,
                                      backend=backend, chunk_size=result.spec.chunk_size)
    summary = replace(result.summary, closed_loop=success)
    if result.folder is not None:
        folder = Path(result.folder)
        atomic_write_text(folder / "closed_loop.json", json.dumps(
            {"correction": spec.model_dump(mode="json"), "success": success.to_dict(),
             "rows": rows}, indent=2, allow_nan=True))
        atomic_write_text(folder / "summary.json", json.dumps(summary.to_dict(), indent=2))
    return replace(result, summary=summary)
