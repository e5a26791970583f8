"""``dloplan correct``: a plan document corrected from a measured shape, checked, written as a plan.

The library (:func:`dloplan.correct.correct_plan`) corrects the clip poses of the rest of a plan;
this adapter makes the result a plan again:

* :func:`measured_points` reads the measured shape as strictly as ``dloplan compare`` does: its
  frame must be the plan's, a file with several shapes must label one ``xi_<K>``;
* :func:`corrected_document` is the corrected plan document: the updated cable (E), the
  corrected gripper path and its whole re-timed trajectory, the plan's robot **cell** kept and
  its program made again on the whole corrected path; its stabilized shapes are equilibria of
  the updated model (the shapes up to K re-stabilized, the corrected equilibria after it); the
  discretization bias stays a prediction, in the ``correction`` section
  (``predicted``) beside the report and the resampled measurement;
* :func:`check_correction` refuses a correction whose plan fails what ``dloplan verify`` checks:
  the robot program of the whole path (what already ran plus the corrected rest) and of the
  remaining motion, and the physics (stability, snap-through, replay); the refusal names the
  failed check, and says when the other mode (``--mode all``) passes;
* :func:`correct_into` writes the corrected plan and the remaining motion (from shape K, at time
  0: the program to run now) through the writer registry (:data:`dloplan.app.writers.WRITERS`)
  into an output folder written whole or not at all;
* :class:`CorrectionService` keeps a plan, its cell and the compiled kernels warm: one
  correction after the first costs milliseconds (``dloplan correct --serve``).
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..correct import Correction, CorrectionRefused, correct_plan
from ..correct.step import sliced_grippers
from ..io.poses import same_frame
from ..output_files import staged_folder
from ..pipeline.document import (
    PlanDocument,
    cycle_actions,
    cycle_to_dict,
    document_cell,
    program_offset,
)
from ..pipeline.stages import (
    program_of,
    quiet,
    verify_plan,
    with_program,
    with_trajectory,
    with_verification,
)
from ..robot.armangle import arm_angle
from ..robot.cell import RobotCell
from ..robot.program import HeldArms
from ..robot.yumi import ARMS
from ..sim import equilibrium
from ..trajectory import plan_cycle
from .writers import WRITERS, WriteOptions, write_outputs

MODES = ("target", "all")


def measured_points(path, at: int, frame_id: str) -> np.ndarray:
    """The measured points of a registered-shape file (:func:`dloplan.vision.read_shapes`).

    A file with several shapes must hold one labelled ``xi_<at>`` (the shape reached); its
    frame must be the plan's ``frame_id`` (as ``dloplan compare`` requires).

    Raises
    ------
    ValueError
        Naming the file, the shape and the field.
    """
    from ..vision.shapes_io import read_shapes

    shapes = read_shapes(path)
    if len(shapes) == 1:
        shape = shapes[0]
    else:
        wanted = f"xi_{at}"
        found = [s for s in shapes if s.label == wanted]
        if not found:
            labels = ", ".join(repr(s.label) for s in shapes)
            raise ValueError(f"{path}: {len(shapes)} shapes ({labels}) and none labelled "
                             f"{wanted!r}: keep one shape, or label the measured one by the "
                             "shape reached")
        shape = found[0]
    if not same_frame(shape.frame_id, frame_id):
        raise ValueError(f"{path}: shape {shape.label!r} is registered in frame "
                         f"{shape.frame_id!r}, the plan is in {frame_id!r}: transform it first "
                         "(e.g. with the camera calibration, dloplan register)")
    return shape.points


def correct_document(doc: PlanDocument, at: int, measured, **options) -> Correction:
    """:func:`dloplan.correct.correct_plan` on a plan document (its cable, shapes, grippers,
    trajectory and stored stabilized shapes); ``options`` as there."""
    if doc.grippers is None:
        raise ValueError("plan: the document has no gripper poses ('grippers' is null): "
                         "there are no clips to correct")
    if doc.harness is not None:
        raise ValueError("plan: a wire-harness plan is not corrected (its cable is pressed "
                         "into the board's fixtures, the correction models a free cable)")
    return correct_plan(doc.cable, doc.shapes, doc.grippers, at, measured,
                        stabilized=doc.stabilized, trajectory=doc.trajectory, **options)


def corrected_document(doc: PlanDocument, correction: Correction) -> PlanDocument:
    """The corrected plan document, its robot program made again on the plan's cell.

    Its stabilized shapes are stable equilibria of the updated cable: shapes 0 .. K - 1
    settled under their (unchanged) clips from the plan's stabilized shapes, shape K the
    updated model's state at the measurement, the rest the corrected equilibria. The
    predictions with the discretization bias (what the cable is expected to do) are in
    ``correction["predicted"]``.

    Raises
    ------
    CorrectionRefused
        When a shape already run has no stable equilibrium with the updated E.
    """
    at = correction.at
    guesses = (doc.shapes if doc.stabilized is None else doc.stabilized)[:at]
    before = []
    for j, x in enumerate(guesses):
        eq = equilibrium(correction.cable, x, doc.grippers.clip_poses(j))
        if not eq.success:
            raise CorrectionRefused(f"model: shape {j}, already run, has no stable equilibrium "
                                    f"with the updated E ({eq.message})")
        before.append(eq.shape)
    stabilized = np.concatenate([np.reshape(before, (-1, *doc.shapes.shape[1:])),
                                 correction.model.state[None], correction.equilibria])
    section = {**correction.report(), "measured": correction.measured.tolist(),
               "predicted": correction.corrected.tolist()}
    corrected = replace(
        with_trajectory(doc, correction.trajectory), cable=correction.cable,
        grippers=correction.grippers, warnings=(*doc.warnings, *correction.warnings),
        stabilized=stabilized, clip_wrenches=None, robot=None, program=None,
        correction=section, repairs=())
    return with_program(corrected, _program(doc, correction.grippers, correction.trajectory))


def remaining_document(doc: PlanDocument, corrected: PlanDocument,
                       correction: Correction) -> PlanDocument:
    """The remaining motion as a plan document: shapes K .. T, the gripper path from K and its
    trajectory starting at time 0, the program made on the plan's cell from the arms holding
    the cable (:func:`remaining_program`; its warning, if any, among the document's): what the
    robot runs now, written by the same writers (csv, the cell's program formats)."""
    at = correction.at
    grippers = sliced_grippers(correction.grippers, at)
    cycle = plan_cycle(correction.remaining, remaining_actions(corrected, at))
    program, warning = remaining_program(doc, grippers, correction.remaining, at)
    remaining = replace(corrected, shapes=corrected.shapes[at:], grippers=grippers,
                        trajectory=correction.remaining, stabilized=corrected.stabilized[at:],
                        robot=None, program=None, verification=None, cycle=cycle_to_dict(cycle),
                        stages=None, twist=None, avoidance=None, target_check=None,
                        warnings=(*corrected.warnings, *([warning] if warning else [])))
    return with_program(remaining, program)


def held_arms(doc: PlanDocument, at: int) -> HeldArms | None:
    """The arms holding the cable at shape ``at`` of the plan ``doc`` as its recorded program
    runs it: the assignment, both arms' joints at that shape's target (a described cell's
    program drops a knot the arms reach in no time: then the target of the shape before it,
    the same pose) and, on a described cell, the job's placement; None for a plan without a
    program."""
    record = None if doc.robot is None else doc.robot.program
    if not record:
        return None
    target = max((t for t in record["targets"]
                  if t["label"].startswith("shape ") and t["shape"] <= at),
                 key=lambda t: t["shape"])
    joints = tuple(np.radians(target["arms"][arm]["joints_deg"]) for arm in ARMS)
    return HeldArms(int(record["assignment"]["left_clip"]), joints, program_offset(doc))


def remaining_program(doc: PlanDocument, grippers, trajectory, at: int):
    """The robot program of the remaining motion from shape ``at`` on the plan's cell, and a
    warning (None when there is none).

    The arms hold the cable at shape ``at``: the program starts from the joints the plan's
    program holds it with (:class:`~dloplan.robot.program.HeldArms`), the assignment kept. On
    the YuMi: no approach (and so no retreat: the cell's ``approach`` is both; after the
    release the arms stay where they let go), each arm's arm angle kept; when that program
    fails a check and a program from a fresh joint solution passes, the fresh one is returned
    with a warning naming the held one's failure and the arm angles to take, the cable held,
    before it runs. On a described cell the job keeps the plan's placement (no search), and a
    program that fails from the held joints is returned as it is: a fresh solution of a
    redundant arm at the same pose is another configuration, reached only by moving the arm
    with the cable held."""
    from ..robot.plugins import robot_program

    held = held_arms(doc, at)
    cell = document_cell(doc)
    if held is None:
        return robot_program(grippers, trajectory, cell), None
    if not isinstance(cell, RobotCell):
        return robot_program(grippers, trajectory, cell, held=held), None
    cell = replace(cell, approach=0.0)
    program = robot_program(grippers, trajectory, cell, held=held)
    if program.ok:
        return program, None
    fresh = robot_program(grippers, trajectory, cell)
    if not fresh.ok:
        return program, None
    angles = ", ".join(f"{arm} {fresh.targets.arm_angles[0, a]:.1f} deg (held "
                       f"{np.degrees(arm_angle(fresh.cell.arms[a], held.joints[a])):.1f})"
                       for a, arm in enumerate(ARMS))
    return fresh, (f"robot program (the remaining motion from shape {at}): from the joints that "
                   f"hold the cable it fails ({program.failure_text()}); the program written "
                   f"starts from another joint solution: arm angles {angles}; bring the arms "
                   f"there at shape {at}, the cable held, before running it")


def remaining_actions(doc: PlanDocument, at: int) -> tuple:
    """The plan's gripper actions still to come after shape ``at`` (the arms hold the cable
    there), on the knots of the remaining motion (which starts at shape ``at``): what its
    programs carry (the release at the end, a regrasp still ahead)."""
    return tuple(replace(a, knot=a.knot - at) for a in cycle_actions(doc.cycle) if a.knot > at)


def _program(doc: PlanDocument, grippers, trajectory):
    from ..robot.plugins import robot_program

    return robot_program(grippers, trajectory, document_cell(doc))


def check_correction(doc: PlanDocument, correction: Correction, *, verify: bool = True,
                     progress=quiet) -> tuple[PlanDocument, PlanDocument]:
    """The corrected and the remaining plan documents, checked as ``dloplan verify`` checks.

    Parameters
    ----------
    doc : PlanDocument
        The plan that was corrected.
    correction : Correction
        Its correction.
    verify : bool
        Also verify the physics of the whole corrected plan (stability, snap-through, replay:
        :func:`dloplan.pipeline.stages.verify_plan`); the robot programs are always checked.
    progress : callable
        Called with a line of text after each step.

    Returns
    -------
    tuple of PlanDocument
        ``(corrected, remaining)``; a warning of the remaining motion's program
        (:func:`remaining_program`) is among the remaining document's warnings.

    Raises
    ------
    CorrectionRefused
        Naming the failed check.
    """
    corrected = corrected_document(doc, correction)
    progress(f"whole corrected path: {corrected.robot.message}")
    if not corrected.robot.ok:
        raise CorrectionRefused(f"robot program (the whole path: shapes 0 .. {correction.at} "
                                f"as run, the corrected rest): {corrected.robot.message}")
    remaining = remaining_document(doc, corrected, correction)
    if not remaining.robot.ok:
        raise CorrectionRefused(f"robot program (the remaining motion from shape "
                                f"{correction.at}): {remaining.robot.message}")
    if verify:
        verification = verify_plan(corrected, progress=progress)
        if not verification.ok:
            raise CorrectionRefused("verification of the corrected plan: "
                                    + "; ".join(verification.messages))
        corrected = with_verification(corrected, verification)
    return corrected, remaining


def check_recorded_program(doc: PlanDocument) -> None:
    """Refuse a plan document whose recorded robot program is not the one its gripper path and
    trajectory give (a hand-edited plan), as ``dloplan verify`` and ``export`` refuse it
    (:func:`dloplan.pipeline.stages.program_of`)."""
    if doc.robot is not None and doc.trajectory is not None and doc.grippers is not None:
        program_of(doc)


def correct_and_check(doc: PlanDocument, at: int, measured, *, verify: bool = True,
                      progress=quiet, **options) -> tuple[Correction, PlanDocument, PlanDocument]:
    """Correct a plan document and check the result (:func:`check_correction`).

    When the correction in one mode is refused by a check, the other mode
    (:data:`dloplan.correct.step.MODES`) is tried: the refusal then says whether it passes.

    Returns
    -------
    tuple
        ``(correction, corrected document, remaining document)``; the correction's warnings
        with the remaining motion program's (:func:`remaining_program`).

    Raises
    ------
    CorrectionRefused
        The first mode's reason, and whether the other mode passes.
    """
    check_recorded_program(doc)
    mode = options.pop("mode", "target")
    try:
        correction = correct_document(doc, at, measured, mode=mode, **options)
        corrected, remaining = check_correction(doc, correction, verify=verify,
                                                progress=progress)
        added = remaining.warnings[len(corrected.warnings):]
        return replace(correction, warnings=(*correction.warnings, *added)), corrected, remaining
    except CorrectionRefused as exc:
        hint = placement_hint(doc, at, measured)
        if hint:
            raise CorrectionRefused(f"{exc}; {hint}") from None
        other = MODES[1 - MODES.index(mode)] if mode in MODES else None
        if other is None:
            raise
        try:
            alternative = correct_document(doc, at, measured, mode=other, **options)
            check_correction(doc, alternative, verify=verify)
        except CorrectionRefused:
            raise CorrectionRefused(f"{exc} (mode {other!r} is refused too)") from None
        raise CorrectionRefused(f"{exc}; mode {other!r} passes every check: run again with "
                                f"--mode {other}") from None


def placement_hint(doc: PlanDocument, at: int, measured) -> str | None:
    """Why a refused measurement may lie off the plan: a described cell's placement runs the
    job ``offset`` from the plan's shapes, which stay in the scenario's frame (docs/cells.md),
    so a shape measured where the robots hold the cable is ``offset`` away. Said when the
    measured points [m] lie less than half as far (mean distance to the nearest point of the
    plan's shape ``at``) from the shape with the offset taken out; else None."""
    offset = program_offset(doc)
    if not np.any(offset) or doc.stabilized is None:
        return None
    from ..robot.placement import format_offset

    shape = np.asarray(doc.stabilized[at], float)
    points = np.asarray(measured, float)

    def mean_distance(p):
        return float(np.mean(np.min(np.linalg.norm(p[:, None] - shape[None], axis=2), axis=1)))

    off, back = mean_distance(points), mean_distance(points - offset)
    if not back < 0.5 * off:
        return None
    return (f"the points lie on average {1e3 * off:.1f} mm from the plan's shape {at} and "
            f"{1e3 * back:.1f} mm with the cell's placement offset {format_offset(offset)} m "
            "taken out: the plan's shapes are where the job file put the cable, the robots run "
            "it moved by the offset (docs/cells.md); subtract it from the measurement")


def correct_into(corrected: PlanDocument, remaining: PlanDocument, folder, *,
                 rate: float | None = None, progress=quiet) -> list[Path]:
    """Write a checked correction (:func:`check_correction`) into ``folder``, whole or not at
    all (:func:`dloplan.output_files.staged_folder`): ``plan.json`` and ``correction.json`` /
    ``correction.txt`` of the corrected plan; ``trajectory.csv`` and the cell's robot program
    formats of the remaining motion. Returns the written paths (in ``folder``)."""
    folder = Path(folder)
    options = WriteOptions() if rate is None else WriteOptions(rate=rate)
    with staged_folder(folder) as staging:
        written = write_outputs(corrected, staging, ("json", "correction"), options=options)
        for name in ("csv", *remaining.program.formats):  # the motion to run now
            writer = WRITERS[name]
            written += writer.write(remaining, staging / writer.target, options)
    paths = [folder / path.relative_to(staging) for path in written]
    progress(f"wrote {len(paths)} files into {folder}")
    return paths


class CorrectionService:
    """A plan kept in memory for repeated corrections (a robot cell's closed loop).

    The first correction compiles and loads the kernels; each one after costs milliseconds
    (docs/correction.md, "A correction service"). :meth:`correct` answers with the correction,
    its predictions (``predict``) and the remaining motion's robot program checked on the
    plan's cell (``check_program``); the physics of the whole corrected plan is not verified
    here (``dloplan correct`` does it, at a cost of seconds).

    Parameters
    ----------
    doc : PlanDocument
        The plan being run.
    predict : bool
        Predict the remaining shapes open loop and corrected, with the interval (default).
    check_program : bool
        Make and check the remaining motion's robot program on the plan's cell (default).
    **options
        Passed to :func:`dloplan.correct.correct_plan` (mode, reference, modulus_steps, ...).
    """

    def __init__(self, doc: PlanDocument, *, predict: bool = True, check_program: bool = True,
                 **options) -> None:
        if doc.grippers is None:
            raise ValueError("plan: the document has no gripper poses ('grippers' is null): "
                             "there are no clips to correct")
        check_recorded_program(doc)
        self.doc = doc
        self.cell = document_cell(doc)
        self.predict = predict
        self.check_program = check_program
        self.options = options

    def correct(self, at: int, points, *, predict: bool | None = None,
                check_program: bool | None = None) -> dict:
        """One correction from the points measured at shape ``at`` (in the plan's frame).

        ``predict`` and ``check_program`` override the service's for this call.

        Returns
        -------
        dict
            ``ok`` True with ``correction`` (:meth:`dloplan.correct.Correction.report`: its
            ``seconds`` / ``cpu_seconds`` until the remaining motion was ready), ``remaining``
            (times [s], TCP positions [m] and quaternions x-y-z-w per arm), ``program`` (the
            check's verdict, its message and the warning of :func:`remaining_program`, or
            None) and ``seconds`` / ``cpu_seconds`` of the whole call; or
            ``ok`` False with ``error`` (the reason of a refusal or a bad input).
        """
        predict = self.predict if predict is None else bool(predict)
        check = self.check_program if check_program is None else bool(check_program)
        t0, cpu0 = time.perf_counter(), time.process_time()
        try:
            result = correct_document(self.doc, at, points, predict=predict, **self.options)
            program = warning = None
            if check:
                program, warning = remaining_program(
                    self.doc, sliced_grippers(result.grippers, result.at), result.remaining,
                    result.at)
                if not program.ok:
                    raise CorrectionRefused(f"robot program (the remaining motion from shape "
                                            f"{result.at}): {program.message}")
        except (ValueError, ArithmeticError) as exc:
            return {"ok": False, "error": str(exc),
                    "seconds": time.perf_counter() - t0,
                    "cpu_seconds": time.process_time() - cpu0}
        remaining = result.remaining
        return {
            "ok": True,
            "correction": result.report(),
            "remaining": {
                "time": remaining.times.tolist(),
                "arms": [{"position": remaining.positions[:, a].tolist(),
                          "quaternion_xyzw": remaining.rotations[a].as_quat().tolist()}
                         for a in (0, 1)],
            },
            "program": None if program is None else {"ok": program.ok,
                                                     "message": program.message,
                                                     "warning": warning},
            "seconds": time.perf_counter() - t0,
            "cpu_seconds": time.process_time() - cpu0,
        }
