"""The wire-harness job's plan document (thesis 7.3): both phases, insertion, tensioning, and the
robot program in the cell of the job file's ``robot:`` section."""

from __future__ import annotations

from ..pipeline.document import PlanDocument, cycle_to_dict
from ..pipeline.stages import plan_program, quiet, with_program
from .resolve import robot_cell


def run_harness_job(job, *, check_robot: bool = True, progress=quiet) -> PlanDocument:
    """The wire-harness job (thesis 7.3) as a plan document: both phases, insertion, tensioning.

    One knot per shape of the whole job; the harness numbers in the ``harness`` section, the
    forces of each phase in ``forces``, the board's pegs and fixtures as obstacles.
    """
    from ..harness import harness_summary
    from ..harness.files import run_harness_job as run

    progress(f"harness job: {job.cable.name or 'cable'}, board checked")
    result = run(job)
    progress(result.message)
    doc = PlanDocument(
        cable=job.cable, shapes=result.shapes, grippers=result.grippers,
        trajectory=result.trajectory, warnings=tuple(result.warnings), source=job.source,
        obstacles=tuple(result.board.contacts()), forces=dict(result.forces),
        harness=harness_summary(result), cycle=cycle_to_dict(result.cycle),
        timings=dict(result.timings))
    if not check_robot:
        return doc
    cell = robot_cell(job.scenario, job.scenario.scale)
    return with_program(doc, plan_program(cell, result.grippers, result.trajectory, progress))
