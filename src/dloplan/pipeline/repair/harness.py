"""A harness job planned, verified and repaired (thesis 7.3; docs/harness.md, docs/repair.md).

:func:`plan_harness` is the harness job's way through :func:`dloplan.pipeline.plan.make_plan`:
the job planned (:func:`dloplan.pipeline.stages.run_harness_job`), verified phase by phase
(:func:`dloplan.pipeline.harness.verify_harness_plan` through
:func:`dloplan.pipeline.stages.verify_plan`) and repaired by a slower tensioning where that is
what failed.
"""

from __future__ import annotations

import time
from dataclasses import replace

from ...harness.verification import HarnessVerification
from ..document import PlanDocument
from ..stages import run_harness_job, verify_plan, with_verification

TENSIONING_SPEEDS = (0.5, 0.25, 0.125)
"""Factors on the tensioning's speeds tried by the repair, in this order."""


def slower_tensioning_helps(verification: HarnessVerification) -> bool:
    """The tensioning failed on the dynamic replay alone (its peak tension above the rated load,
    a deviation, a cable not at rest), every configuration within the rated load: a slower
    pull is the repair that applies."""
    row = verification.row("tensioning")
    return row.failed and all(note.startswith("replay:") for note in row.notes)


def plan_harness(job, *, verify: bool = False, check_robot: bool = True, repair: bool = True,
                 progress=lambda text: None, planned=None) -> PlanDocument:
    """A harness job's plan document (:func:`dloplan.pipeline.stages.run_harness_job`),
    verified with ``verify`` (every check per phase,
    :func:`dloplan.pipeline.harness.verify_harness_plan`); a plan that
    fails only in the tensioning's replay is planned again with the tensioning slowed down
    (:data:`TENSIONING_SPEEDS`, ``HarnessSettings.tensioning_speed``) until it passes, the
    repair recorded in the document's ``repairs`` (or its refusal). A plan whose tensioning
    failed when planned (no offset: its harness check failed, exit 3) has nothing to verify
    and is returned as it is. ``planned`` (optional) is called with each planned document
    before it is verified (the command line draws its figures meanwhile)."""
    doc = run_harness_job(job, check_robot=check_robot, progress=progress, planned=planned)
    if not verify or doc.harness.get("offset") is None:
        return doc
    t0 = time.perf_counter()
    verification = verify_plan(doc, robot=check_robot, progress=progress)
    progress(f"verification: {'passed' if verification.ok else 'FAILED'}")
    verified = with_verification(doc, verification)
    verified = replace(verified, timings={**verified.timings,
                                          "verify": time.perf_counter() - t0})
    if verification.ok or not repair or not slower_tensioning_helps(verification):
        return verified
    start = time.perf_counter()
    before = "; ".join(verification.row("tensioning").notes)
    for factor in TENSIONING_SPEEDS:
        progress(f"repair (tensioning): the tensioning at {factor:g} times its speed")
        candidate = run_harness_job(replace(job, settings=replace(
            job.settings, tensioning_speed=factor)), check_robot=check_robot, progress=progress,
            planned=planned)
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
    progress(f"repair refused: {refusal['change']}")
    return replace(verified, repairs=(refusal,))


__all__ = ["TENSIONING_SPEEDS", "plan_harness", "slower_tensioning_helps"]
