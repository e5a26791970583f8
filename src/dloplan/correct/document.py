"""The correction of a plan document and its outputs (what ``dloplan correct`` does).

:func:`correct_document` takes a plan document (:func:`dloplan.app.read_plan`), the index of
the shape reached and the measured points, and returns the :class:`~.step.Correction`;
:func:`write_correction` writes

* ``plan.json``: the corrected plan document -- the updated model cable (E), the planned shapes,
  the corrected gripper path and its whole re-timed trajectory; its stabilized shapes are the
  shapes up to K re-stabilized with the updated E and the corrected predictions after it, its
  ``correction`` section the report below, so ``dloplan verify`` checks what will be run;
* ``trajectory.csv`` and the robot programs of the plan's cell (``rapid/`` for the YuMi,
  ``urscript/`` and ``ros_joints/`` for a described cell, docs/cells.md): the remaining motion,
  from shape K (where the robot stands) to the target, starting at time 0 -- the program to run
  now, written from a program that passes its checks
  (:func:`dloplan.robot.cell_program.make_program`);
* ``correction.json`` and ``correction.txt``: open-loop against corrected predictions, shape by
  shape, with the modulus update and the clip corrections.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..app.document_file import write_plan
from ..app.writers import WRITERS, program_files
from ..grippers import GripperPath
from ..io.export import write_trajectory_csv
from ..io.files import atomic_write_text
from ..pipeline.document import PlanDocument, document_cell
from ..sim import equilibrium
from .measurement import CorrectionRefused
from .step import Correction, correct_plan, sliced_grippers


def measured_points(path, at: int) -> np.ndarray:
    """The measured points of a registered-shape file (:func:`dloplan.vision.read_shapes`).

    A file with several shapes must hold one labelled ``xi_<at>`` (the shape reached).
    """
    from ..vision.shapes_io import read_shapes

    shapes = read_shapes(path)
    if len(shapes) == 1:
        return shapes[0].points
    wanted = f"xi_{at}"
    for shape in shapes:
        if shape.label == wanted:
            return shape.points
    labels = ", ".join(repr(s.label) for s in shapes)
    raise ValueError(f"{path}: {len(shapes)} shapes ({labels}) and none labelled {wanted!r}: "
                     "keep one shape, or label the measured one by the shape reached")


def correct_document(doc: PlanDocument, at: int, measured, *, robot: bool = False,
                     **options) -> Correction:
    """:func:`~.step.correct_plan` on a plan document (its cable, shapes, grippers, trajectory
    and stored stabilized shapes); ``options`` as there.

    With ``robot``, a correction that moves a remaining clip pose out of the YuMi's reach (at
    the world origin) while the planned one was reachable is refused
    (:func:`check_robot_reach`).
    """
    if doc.grippers is None:
        raise ValueError("plan: the document has no gripper poses ('grippers' is null): "
                         "there are no clips to correct")
    result = correct_plan(doc.cable, doc.shapes, doc.grippers, at, measured,
                          stabilized=doc.stabilized, trajectory=doc.trajectory, **options)
    if robot:
        check_robot_reach(doc.grippers, result.grippers, at)
    return result


def check_robot_reach(planned: GripperPath, corrected: GripperPath, at: int) -> None:
    """Refuse corrected clip poses after shape ``at`` that a YuMi cannot reach where it could
    reach the planned ones (:func:`dloplan.robot.check_reachability`).

    Raises
    ------
    CorrectionRefused
        Naming the shapes.
    """
    from ..robot import check_reachability

    def reachable(grippers: GripperPath) -> np.ndarray:
        reach = check_reachability(grippers.positions, Rotation.from_matrix(grippers.matrices))
        return reach.reachable.all(axis=1)

    lost = np.flatnonzero(reachable(planned) & ~reachable(corrected))
    lost = [int(k) for k in lost if k > at]
    if lost:
        raise CorrectionRefused(f"robot: the corrected clip poses of shapes {lost} are out of the "
                                "YuMi's reach (the planned ones are reachable)")


def correction_table(correction: Correction) -> str:
    """The open-loop vs corrected predictions as a plain-text table (mm, degrees)."""
    m = correction.model
    lines = [
        f"# dloplan correction at shape {correction.at} ({correction.mode} mode, reference: "
        f"{correction.reference_kind} shapes)",
        f"E: {m.youngs_modulus_before:.4g} -> {m.youngs_modulus:.4g} Pa "
        f"({m.steps} Gauss-Newton steps); measured vs model at shape {correction.at}: "
        f"{1e3 * m.residual_before:.2f} -> {1e3 * m.residual_after:.2f} mm",
        f"computed in {1e3 * correction.seconds:.0f} ms (+ "
        f"{1e3 * correction.prediction_seconds:.0f} ms predictions); remaining motion "
        f"{correction.remaining.duration:.2f} s",
        "",
        "shape  open-loop [mm]  corrected [mm]  first clip [mm, deg]  last clip [mm, deg]",
    ]
    for k, (o, c, p) in enumerate(zip(correction.open_loop_error, correction.corrected_error,
                                      correction.clip_corrections, strict=True)):
        moves = [f"{1e3 * np.linalg.norm(p[i : i + 3]):6.2f}, "
                 f"{math.degrees(np.linalg.norm(p[i + 3 : i + 6])):5.2f}" for i in (0, 6)]
        lines.append(f"{correction.at + 1 + k:5d}  {1e3 * o:14.2f}  {1e3 * c:14.2f}  "
                     f"{moves[0]:>20}  {moves[1]:>19}")
    lines += [f"warning: {w}" for w in correction.warnings]
    return "\n".join(lines) + "\n"


def write_correction(doc: PlanDocument, correction: Correction, folder, *,
                     rate: float = 100.0) -> list[Path]:
    """Write the corrected plan, the remaining trajectory and program, and the report.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    CorrectionRefused
        When the remaining motion's robot program fails its checks (nothing is written).
    """
    from ..robot.cell_program import make_program

    out = Path(folder)
    at = correction.at
    program = make_program(document_cell(doc), sliced_grippers(correction.grippers, at),
                           correction.remaining)
    if not program.ok:
        raise CorrectionRefused(f"robot: the corrected remaining motion fails its checks: "
                                f"{program.message}")
    guesses = (doc.shapes if doc.stabilized is None else doc.stabilized)[:at]
    # the shapes already run, re-stabilized with the updated E: one model for the whole document
    before = [equilibrium(correction.cable, x, doc.grippers.clip_poses(j)).shape
              for j, x in enumerate(guesses)] + [correction.model.state]
    corrected = replace(
        doc, cable=correction.cable, grippers=correction.grippers,
        trajectory=correction.trajectory, warnings=(*doc.warnings, *correction.warnings),
        stabilized=np.concatenate([before, correction.corrected]), clip_wrenches=None,
        verification=None, robot=None, program=None,
        correction={**correction.report(), "measured": correction.measured.tolist()})
    out.mkdir(parents=True, exist_ok=True)
    return [
        write_plan(out / "plan.json", corrected),
        write_trajectory_csv(out / "trajectory.csv", correction.remaining, rate=rate,
                             frame_id=doc.frame_id),
        *(path for name in program.formats
          for path in program_files(program, out / WRITERS[name].target, name)),
        atomic_write_text(out / "correction.json",
                          json.dumps(correction.report(), indent=1) + "\n"),
        atomic_write_text(out / "correction.txt", correction_table(correction)),
    ]
