"""A wire-harness plan verified from its plan document alone (thesis 7.3; docs/harness.md).

The document of a harness job (:func:`dloplan.pipeline.stages.run_harness_job`) records, besides
every knot's shape, the gripper poses and the timed trajectory, the board (fixtures and pegs in
its ``harness`` section, the other volumes and the table in ``obstacles``), the section's
discretization, the plan's section at the approach poses, in the slots and tensioned, the
tensioning offset, the regrasp's duration and the cable's rated load. :func:`harness_model`
rebuilds the held cable of :mod:`dloplan.harness.held` from it and :func:`verify_harness_plan`
runs every check of :mod:`dloplan.harness.verification` on it, with the robot program's check
rows: what ``dloplan plan --verify`` and ``dloplan verify`` report for a harness plan (the
harness job's repairs are :mod:`dloplan.pipeline.repair.harness`).
"""

from __future__ import annotations

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
                         f"({section.get('message', '')}): nothing to verify; expected a "
                         "plan whose tensioning succeeded (its plan exited 3)")
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


__all__ = ["harness_model", "verify_harness_plan"]
