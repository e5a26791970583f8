"""A wire-harness plan verified from its plan document alone (thesis 7.3; docs/harness.md).

The document of a harness job (:func:`dloplan.pipeline.stages.run_harness_job`) records, besides
every knot's shape, the gripper poses and the timed trajectory, the board (fixtures and pegs in
its ``harness`` section, the other volumes and the table in ``obstacles``), the section's
discretization, the plan's section at the approach poses, in the slots and tensioned, the
tensioning offset, the regrasp's duration and the cable's rated load. :func:`harness_model`
rebuilds the held cable of :mod:`dloplan.harness.held` from it and :func:`verify_harness_plan`
runs every check of :mod:`dloplan.harness.verification` on it, with the robot program's check
rows: what ``dloplan plan --verify`` and ``dloplan verify`` report for a harness plan.
:func:`plan_harness` is the harness job's way through :func:`dloplan.pipeline.plan.make_plan`:
planned, verified, and repaired by a slower tensioning where that is what failed.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ..harness.board import board_from_dict
from ..harness.held import HeldModel, held_model
from ..harness.verification import REPLAY_TOLERANCE, HarnessVerification, verify_harness
from .document import PlanDocument


def _knots(doc: PlanDocument) -> dict:
    try:
        return {name: (int(a), int(b)) for name, (a, b) in doc.harness["knots"].items()}
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"plan.harness.knots: {exc}") from None


def harness_model(doc: PlanDocument) -> HeldModel:
    """The held cable of a harness plan document (:func:`dloplan.harness.held.held_model`).

    Raises
    ------
    ValueError
        For a document that is not a harness plan, one whose tensioning failed (no offset), or
        whose harness section lacks what the checks need (a document written before they
        were), naming the missing entry.
    """
    section = doc.harness
    if section is None:
        raise ValueError("plan: not a wire-harness plan (no harness section)")
    if doc.grippers is None:
        raise ValueError("plan: no gripper poses, the harness job was not planned to the end")
    if section.get("offset") is None:
        raise ValueError("plan.harness.offset: none, the tensioning failed when planned "
                         f"({section.get('message', '')}): nothing to verify")
    missing = [key for key in ("board", "section_links", "sections") if key not in section]
    if missing:
        raise ValueError(f"plan.harness: no {', '.join(missing)} (a plan written before harness "
                         "plans were verified): plan the job again")
    board = board_from_dict(section["board"], doc.obstacles)
    sections = section["sections"]
    try:
        planned = np.array([sections[k] for k in ("approach", "inserted", "tensioned")], float)
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"plan.harness.sections: {exc}") from None
    return held_model(doc.cable, board, doc.shapes, doc.clip_poses(), _knots(doc),
                      float(section["offset"]), int(section["section_links"]), planned)


def verify_harness_plan(doc: PlanDocument, *, snap: bool = True, replay: bool = True,
                        robot_rows=None, rated_load: float | None = None,
                        tolerance: float = REPLAY_TOLERANCE, youngs_modulus_cap=None,
                        progress=lambda text: None) -> HarnessVerification:
    """Every check of a harness plan document, with a verdict per phase (module docstring).

    Parameters
    ----------
    doc : PlanDocument
        A harness job's plan document.
    snap, replay : bool
        Run the snap-through continuation, the dynamic replay.
    robot_rows : sequence, optional
        The robot program's check rows (``program.checks``).
    rated_load : float, optional
        The cable's rated load [N]; default the document's (``harness.rated_load``).
    tolerance : float
        Largest replay deviation accepted [m].
    youngs_modulus_cap : float, optional
        Fictitious modulus of the replay.
    progress : callable
        Called with a line of text before each long step.
    """
    progress("harness verification: the held cable followed through the job (fixtures, pegs)")
    model = harness_model(doc)
    limit = doc.harness.get("rated_load") if rated_load is None else rated_load
    law = None if doc.trajectory is None else doc.trajectory.law
    if doc.trajectory is None:
        replay = False
    times = doc.trajectory.times if doc.trajectory is not None else np.arange(len(doc.shapes),
                                                                                dtype=float)
    return verify_harness(model, times, doc.clip_poses(), _knots(doc), law=law,
                          regrasp_time=float(doc.harness.get("regrasp_time", 0.0)),
                          rated_load=limit, robot_rows=robot_rows, snap=snap,
                          replay_run=replay, tolerance=tolerance,
                          youngs_modulus_cap=youngs_modulus_cap, progress=progress)


TENSIONING_SPEEDS = (0.5, 0.25, 0.125)
"""Factors on the tensioning's speeds tried by the repair, in this order."""


def slower_tensioning_helps(verification: HarnessVerification) -> bool:
    """The tensioning failed on the dynamic replay alone (its peak tension above the rated load,
    a deviation, a cable not at rest), every configuration within the rated load: a slower
    pull is the repair that applies."""
    row = verification.row("tensioning")
    return row.failed and all(note.startswith("replay:") for note in row.notes)


def plan_harness(job, *, verify: bool = False, check_robot: bool = True, repair: bool = True,
                 progress=lambda text: None) -> PlanDocument:
    """A harness job's plan document (:func:`dloplan.pipeline.stages.run_harness_job`),
    verified with ``verify`` (every check per phase, :func:`verify_harness_plan`); a plan that
    fails only in the tensioning's replay is planned again with the tensioning slowed down
    (:data:`TENSIONING_SPEEDS`, ``HarnessSettings.tensioning_speed``) until it passes, the
    repair recorded in the document's ``repairs`` (or its refusal)."""
    from .stages import run_harness_job, verify_plan, with_verification

    doc = run_harness_job(job, check_robot=check_robot, progress=progress)
    if not verify:
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
    progress(f"repair refused: {refusal['change']}")
    return replace(verified, repairs=(refusal,))


__all__ = ["TENSIONING_SPEEDS", "harness_model", "plan_harness", "slower_tensioning_helps",
           "verify_harness_plan"]
