"""A robustness study of a job: the very plan ``dloplan plan`` makes, perturbed sample by sample.

The nominal plan comes from the pipeline (:func:`dloplan.app.pipeline.run_job`: the same
weights, family, physical mode, obstacle re-planning and gripper frames as ``dloplan plan``), so
the study's nominal stabilized shapes are the plan's, and a sample with zero spread reproduces
them. The study itself runs in :mod:`dloplan.study`.
"""

from __future__ import annotations

from ..cable import GRAVITY
from ..study.evaluate import StudyProblem
from ..study.spec import StudyError, StudySpec, parse_study
from .document import PlanDocument
from .job import Job


def study_problem_of(doc: PlanDocument) -> StudyProblem:
    """The study problem of a plan document: its shapes, gripper clip poses and stabilized path."""
    from .pipeline import settled_shapes

    return StudyProblem(doc.cable, doc.shapes, tuple(doc.clip_poses()), settled_shapes(doc),
                        tuple(doc.obstacles), GRAVITY)


def study_spec(job: Job, samples: int | None = None, seed: int | None = None) -> StudySpec:
    """The job's ``study:`` section with command-line overrides, validated by the same schema.

    Raises
    ------
    StudyError
        No ``study:`` section or no parameters (a study with nothing to vary), or an override
        the schema refuses (e.g. ``samples: 0``).
    """
    if job.study is None:
        raise StudyError(f"{job.source}: no study section: nothing to vary (see docs/study.md)")
    data = job.study.model_dump()
    data.update({k: v for k, v in (("samples", samples), ("seed", seed)) if v is not None})
    spec = parse_study(data, f"{job.source}: study")
    if not spec.parameters:
        raise StudyError(f"{job.source}: study.parameters: none given: nothing varies")
    return spec
