"""The one way a job becomes a plan: plan, check, repair, check again.

:func:`make_plan` is what every command that plans calls (``dloplan plan`` and its batch mode,
``demo``, ``study`` for its nominal plan, ``simulate`` and ``verify`` of a job file,
``correct``): so they all study, simulate, verify and correct the plan ``dloplan plan`` writes.

::

    run_job ─► (robot program fails, or --verify) verify_plan ─► repair_plan ─► verified again
                                                                   (dloplan.pipeline.repair)
"""

from __future__ import annotations

import time
from dataclasses import replace

from .document import PlanDocument
from .job import HarnessJob, Job
from .repair import Budget, diagnose, repair_plan
from .repair.placement import placement_section
from .stages import completed_program, quiet, run_job, verify_plan, with_verification


def make_plan(job: Job | HarnessJob, *, verify: bool = False, check_robot: bool = True,
              repair: bool = True, budget: Budget | None = None, progress=quiet,
              planned=None) -> PlanDocument:
    """Plan a job, check the plan, repair what fails and check it again (docs/repair.md).

    Parameters
    ----------
    job : Job or HarnessJob
        A resolved job (:func:`dloplan.app.load_job`). A wire-harness job is planned by its
        own stages (:func:`~dloplan.pipeline.stages.run_harness_job`), verified on its held
        cable phase by phase and repaired by a slower tensioning where that is what failed
        (:func:`dloplan.pipeline.repair.harness.plan_harness`).
    verify : bool
        Check the physics too (stability, snap-through, dynamic replay: ``--verify``). Without,
        only the robot program's checks run: a plan whose program passes is returned as
        planned, without a verification section; one whose program fails is repaired for its
        reach and verified for it.
    check_robot : bool
        Make and check the robot program (``--no-verify`` turns it off, and the repair with it).
    repair : bool
        Repair a plan that fails a check (``--no-repair``: the verdict as found).
    budget : Budget, optional
        What the repair may spend (default :class:`~dloplan.pipeline.repair.Budget`).
    progress : callable
        Called with a line of text after each step.
    planned : callable, optional
        ``planned(doc, provisional=False)``: called as :func:`~dloplan.pipeline.stages.run_job`
        calls it (the planned document before its robot program, provisionally, and with its
        program when that passes), and with each repaired document before it is verified again
        (the command line draws its figures then: a figure depends on no verification).

    Returns
    -------
    PlanDocument
        With its verification section when a check was run, the repairs kept
        (``repairs``), and a refusal among its warnings when no repair works. A placement of
        the job on the table is made only when the job allows it (``job.repair.placement``),
        else proposed (a warning, the ``placement`` section with ``applied`` False, and the
        robot check failed as it was); a placement made is the ``placement`` section with
        ``applied`` True.
    """
    if isinstance(job, HarnessJob):
        from .repair.harness import plan_harness  # the harness package: harness jobs only

        return plan_harness(job, verify=verify, check_robot=check_robot, repair=repair,
                            progress=progress, planned=planned)
    if not (check_robot and repair):
        return run_job(job, verify=verify, check_robot=check_robot, progress=progress,
                       planned=planned)
    # the plan's program is completed only if it is kept (the reach repair replaces one that
    # fails), after its figures were started (run_job's ``planned``)
    doc = run_job(job, progress=progress, planned=planned, complete_program=False)
    t0 = time.perf_counter()
    if not verify and (doc.program is None or doc.program.ok):
        return completed_program(doc)
    verification = verify_plan(doc, snap=verify, replay=verify)
    progress(f"verification: {'passed' if verification.ok else 'FAILED'}")
    if not diagnose(doc, verification):
        doc = with_verification(completed_program(doc), verification)
        return replace(doc, timings={**doc.timings, "verify": time.perf_counter() - t0})
    result = repair_plan(job, doc, verification, budget, progress, repaired=planned)
    out, placement = result.document, None  # (complete: repair_plan)
    if result.proposal is not None:
        out = replace(out, warnings=out.warnings + (result.proposal.line(),))
        placement = placement_section(result.proposal.move, applied=False)
    elif result.refusal is not None:
        progress(f"repair refused: {result.refusal}")
        out = replace(out, warnings=out.warnings + (f"repair refused: {result.refusal}",))
    if not result.move.is_identity:
        placement = placement_section(result.move, applied=True)
        progress(f"placement: {placement.message}: place the cable there")
    timings = {**out.timings, "verify": time.perf_counter() - t0 - result.seconds,
               "repair": result.seconds,  # and the parts of it no kind of repair spent:
               **{f"repair: {name}": seconds for name, seconds in result.parts.items()}}
    return replace(out, timings=timings, repairs=tuple(r.to_dict() for r in result.repairs),
                   placement=placement)
