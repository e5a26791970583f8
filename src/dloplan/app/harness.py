"""The wire-harness job's plan document (thesis 7.3): both phases, insertion, tensioning, and the
robot program in the cell of the job file's ``robot:`` section; verified phase by phase
(:mod:`dloplan.pipeline.harness`) and repaired by a slower tensioning where that is what failed.
"""

from __future__ import annotations

import time
from dataclasses import replace

from ..pipeline.document import PlanDocument, cycle_to_dict
from ..pipeline.stages import plan_program, quiet, verify_plan, with_program, with_verification
from .resolve import robot_cell

TENSIONING_SPEEDS = (0.5, 0.25, 0.125)
"""Factors on the tensioning's speeds tried by the repair, in this order."""


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


def slower_tensioning_helps(verification) -> bool:
    """The tensioning failed on the dynamic replay alone (its peak tension above the rated load,
    a deviation, a cable not at rest), every configuration within the rated load: a slower
    pull is the repair that applies."""
    row = verification.row("tensioning")
    return row.failed and all(note.startswith("replay:") for note in row.notes)


def plan_harness(job, *, verify: bool = False, check_robot: bool = True, repair: bool = True,
                 progress=quiet) -> PlanDocument:
    """A harness job's plan document, verified with ``verify`` (every check per phase,
    :func:`dloplan.pipeline.harness.verify_harness_plan`); a plan that fails only in the
    tensioning's replay is planned again with the tensioning slowed down
    (:data:`TENSIONING_SPEEDS`, ``HarnessSettings.tensioning_speed``) until it passes, the
    repair recorded in the document's ``repairs`` (or its refusal)."""
    doc = run_harness_job(job, check_robot=check_robot, progress=progress)
    if not verify:
        return doc
    verification = verify_plan(doc, robot=check_robot, progress=progress)
    progress(f"verification: {'passed' if verification.ok else 'FAILED'}")
    verified = with_verification(doc, verification)
    if verification.ok or not repair or not slower_tensioning_helps(verification):
        return verified
    start = time.perf_counter()
    before = "; ".join(verification.row("tensioning").notes)
    for factor in TENSIONING_SPEEDS:
        progress(f"repair (tensioning): the tensioning at {factor:g} times its speed")
        candidate = run_harness_job(replace(job, settings=replace(
            job.settings, tensioning_speed=factor)), check_robot=check_robot, progress=progress)
        checked = verify_plan(candidate, robot=check_robot, progress=progress)
        if checked.ok:
            record = {"kind": "tensioning", "failed": "replay", "before": before,
                      "change": f"the tensioning slowed to {factor:g} times its speed",
                      "after": checked.messages[-1], "seconds": time.perf_counter() - start}
            progress(f"repair (tensioning): passes at {factor:g} times the speed")
            return replace(with_verification(candidate, checked), repairs=(record,))
    refusal = {"kind": "tensioning", "failed": "replay", "before": before,
               "change": "refused: the tensioning fails at "
                         f"{min(TENSIONING_SPEEDS):g} times its speed too",
               "after": before, "seconds": time.perf_counter() - start}
    return replace(verified, repairs=(refusal,))
