"""Every output of a plan, written from its plan document by a writer found in one registry.

A writer takes the document, its target (a file, or a folder for rapid and figures) and the
:class:`WriteOptions`, and returns the paths it wrote. A new format is one function and one line
in :data:`WRITERS`.

=========  ==================================================================================
name       what it writes
=========  ==================================================================================
json       ``plan.json``, the plan document itself (:mod:`dloplan.pipeline.document`)
csv        ``trajectory.csv``, the dual-arm TCP trajectory sampled at the rate
ros        ``trajectory.yaml``, a ROS 2 ``trajectory_msgs/MultiDOFJointTrajectory``
rapid      ``rapid/``, one ABB RAPID module per YuMi arm (ABB cells only)
ros_joints ``ros_joints/``, a ROS 2 ``trajectory_msgs/JointTrajectory`` per arm (verified joints
           along the time law) and the gripper action list
urscript   ``urscript/``, one URScript program per arm (cells of two 6-joint arms)
ur_rtde    ``ur_rtde/``, one Python program streaming both UR arms over RTDE, in lockstep
figures    ``figures/``, PNG figures (and their SVG copies with ``WriteOptions.figure_formats``)
report     ``report.html``, the self-contained interactive report (with the figures)
correction ``correction.json`` and ``correction.txt``: a corrected plan's correction report
=========  ==================================================================================
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..io.export import DEFAULT_CSV_RATE, write_ros_trajectory, write_trajectory_csv
from ..io.job_file import SVG_OUTPUT, svg_copies
from ..pipeline.document import PlanDocument, cycle_actions, program_offset
from ..plots.figures import PNG, WITH_SVG
from .document_file import write_plan
from .report import write_figures, write_plan_report


@dataclass(frozen=True)
class WriteOptions:
    """Settings of the writers: sampling rate [Hz] of csv and ros (None: ros writes the knots);
    ``figure_workers`` the :class:`dloplan.app.figure_workers.FigureWorkers` that draw the
    figures (None: drawn by the writer itself); ``figures`` False: no figure is drawn (no
    ``figures`` output, a report without its figures: ``dloplan plan --no-figures``);
    ``figure_formats`` the formats of each figure (:data:`dloplan.plots.figures.PNG`, or
    :data:`~dloplan.plots.figures.WITH_SVG`: ``--svg``, a job's ``outputs: [..., svg]``)."""

    rate: float | None = DEFAULT_CSV_RATE
    figure_workers: object | None = None
    figures: bool = True
    figure_formats: tuple[str, ...] = PNG


def _needs_trajectory(doc: PlanDocument, name: str) -> None:
    if doc.trajectory is None:
        raise ValueError(f"{name}: the plan has no timed trajectory (no gripper poses)")


def write_json(doc: PlanDocument, target: Path, options: WriteOptions) -> list[Path]:
    """The plan document."""
    return [write_plan(target, doc)]


def trajectory_note(doc: PlanDocument) -> str | None:
    """The sentence the TCP trajectory files (csv, ros) carry when the robot programs do not
    run the job where the trajectory has it: a described cell's placement moves the programs'
    poses by its ``offset`` and leaves the plan's shapes and trajectory in the scenario's frame
    (docs/cells.md, "The placement offset"); None otherwise (the YuMi's placement moves the
    plan itself)."""
    from ..robot.placement import format_offset

    offset = program_offset(doc)
    if not np.any(offset):
        return None
    return (f"the robot programs run this job moved by {format_offset(offset)} m on the table "
            "(the cell's placement, plan.json: placement): add it to these positions to follow "
            "them")


def write_csv(doc: PlanDocument, target: Path, options: WriteOptions) -> list[Path]:
    """The trajectory sampled at ``options.rate`` (:func:`trajectory_note` in its header)."""
    _needs_trajectory(doc, "csv")
    return [write_trajectory_csv(target, doc.trajectory, rate=options.rate or DEFAULT_CSV_RATE,
                                 frame_id=doc.frame_id, note=trajectory_note(doc))]


def write_ros(doc: PlanDocument, target: Path, options: WriteOptions) -> list[Path]:
    """The ROS 2 MultiDOFJointTrajectory (YAML, or JSON for a ``.json`` target;
    :func:`trajectory_note` as a YAML comment)."""
    _needs_trajectory(doc, "ros")
    return [write_ros_trajectory(target, doc.trajectory, rate=options.rate,
                                 frame_id=doc.frame_id, note=trajectory_note(doc))]


def verified_program(doc: PlanDocument, name: str):
    """The document's verified robot program (:func:`dloplan.pipeline.stages.program_of`) for
    the program format ``name``.

    Raises
    ------
    ValueError
        A plan without trajectory, or a cell that does not take the format.
    """
    from ..pipeline.stages import program_of
    from ..robot.plugins import cell_name

    _needs_trajectory(doc, name)
    program = program_of(doc)
    if name not in program.formats:
        raise ValueError(f"{name}: the cell {cell_name(program.cell)!r} takes "
                         f"{', '.join(program.formats)}, not {name} (docs/cells.md)")
    return program


def write_rapid_program(doc: PlanDocument, target: Path, options: WriteOptions) -> list[Path]:
    """The RAPID modules of both YuMi arms, in the folder ``target``: exactly the verified
    robot program of the document (:func:`verified_program`; ABB cells only). A plan made
    without robot checks (``--no-verify``) gets its program written with the checks' verdict
    in the module header; a program that failed its checks is refused."""
    return program_files(verified_program(doc, "rapid"), target, "rapid", doc.trajectory,
                         cycle_actions(doc.cycle), force=doc.robot is None,
                         notes=program_notes(doc))


def program_notes(doc: PlanDocument) -> tuple[str, ...]:
    """What a robot program of the document says in its header beyond its checks: where the
    job must be placed on the table when a repair moved it (its ``placement`` section)."""
    if doc.placement is None or not doc.placement.applied:
        return ()
    return (f"Place the cable where dloplan moved the job: {doc.placement.message}; this "
            "program runs only with it there (plan.json: placement).",)


def program_files(program, folder: Path, name: str, trajectory, actions=(), *,
                  force: bool = False, notes=()) -> list[Path]:
    """Write a verified program (:class:`dloplan.robot.program.RobotProgram`) in the format
    ``name`` (one of its ``formats``: rapid, urscript, ur_rtde, ros_joints) into ``folder``:
    its motion along ``trajectory`` (the plan's timing it was verified with) and every gripper
    action of the plan's cycle (``actions``, :class:`~dloplan.trajectory.GripperAction` s,
    placed at their targets by :func:`dloplan.robot.actions.program_timeline`); ``force``
    writes a RAPID program made without checks (its verdict in the module header); ``notes``
    are comment lines for the program's header (:func:`program_notes`)."""
    from ..robot.actions import program_timeline

    if name == "rapid":
        from ..io.rapid import write_rapid

        return list(write_rapid(folder, program, force=force, notes=notes,
                                actions=actions).values())
    if name not in PROGRAM_FORMATS:
        raise ValueError(f"{name}: not a robot program format ({', '.join(PROGRAM_FORMATS)})")
    timeline = program_timeline(program, trajectory, actions)
    if name == "urscript":
        from ..io.urscript import write_urscript

        return write_urscript(folder, **program.writer_arguments("urscript"),
                              actions=timeline.actions, notes=notes)
    if name == "ur_rtde":
        from ..io.ur_rtde import write_ur_rtde

        return write_ur_rtde(folder, timeline, **program.writer_arguments("ur_rtde"),
                             notes=notes)
    from ..io.ros_joints import write_joint_trajectories

    return write_joint_trajectories(folder, timeline, **program.writer_arguments("ros_joints"),
                                    notes=notes)


PROGRAM_FORMATS = ("rapid", "urscript", "ur_rtde", "ros_joints")
"""The robot program formats (:func:`program_files`)."""


def _passed(doc: PlanDocument, name: str):
    program = verified_program(doc, name)
    if doc.robot is not None and not program.ok:
        raise ValueError(f"{name}: {program.message}")
    return program


def write_joint_trajectory_files(doc: PlanDocument, target: Path,
                                 options: WriteOptions) -> list[Path]:
    """One ROS 2 JointTrajectory per arm in the folder ``target``: the verified joints of the
    document's robot program at its target times (:mod:`dloplan.io.ros_joints`); a program
    that failed its checks is refused, as for RAPID."""
    return program_files(_passed(doc, "ros_joints"), target, "ros_joints", doc.trajectory,
                         cycle_actions(doc.cycle), notes=program_notes(doc))


def write_urscript_files(doc: PlanDocument, target: Path, options: WriteOptions) -> list[Path]:
    """One URScript program per arm in the folder ``target`` (:mod:`dloplan.io.urscript`): the
    verified joints of a described cell of 6-joint arms; a program that failed its checks is
    refused."""
    return program_files(_passed(doc, "urscript"), target, "urscript", doc.trajectory,
                         cycle_actions(doc.cycle), notes=program_notes(doc))


def write_ur_rtde_files(doc: PlanDocument, target: Path, options: WriteOptions) -> list[Path]:
    """The UR pair's program streamed from a PC over RTDE in the folder ``target``
    (:mod:`dloplan.io.ur_rtde`): both arms in lockstep along the plan's time law, the
    gripper actions on the way; a program that failed its checks is refused."""
    return program_files(_passed(doc, "ur_rtde"), target, "ur_rtde", doc.trajectory,
                         cycle_actions(doc.cycle), notes=program_notes(doc))


def write_figure_files(doc: PlanDocument, target: Path, options: WriteOptions) -> list[Path]:
    """Every figure in the options' formats (PNG, and SVG when asked), in the folder ``target``
    (drawn on the options' figure workers when given)."""
    if options.figure_workers is not None:
        return options.figure_workers.render(doc, target, options.figure_formats)
    return write_figures(doc, target, options.figure_formats)


def write_report_file(doc: PlanDocument, target: Path, options: WriteOptions) -> list[Path]:
    """The HTML report, with the PNG figures of the ``figures/`` folder beside it embedded and
    both robot arms drawn when the plan has a robot program."""
    images = sorted((target.parent / WRITERS["figures"].target).glob("*.png"))
    program = None
    if doc.robot is not None and doc.trajectory is not None:
        from ..pipeline.stages import program_of

        program = program_of(doc)
    return [write_plan_report(doc, target, images, program)]


def write_correction_report(doc: PlanDocument, target: Path,
                            options: WriteOptions) -> list[Path]:
    """A corrected plan's correction report (``dloplan correct``): ``correction.json`` (the
    report's numbers, SI units) and ``correction.txt`` beside it (the same as a table)."""
    import json

    from ..correct.report import correction_table
    from ..output_files import atomic_write_text

    if doc.correction is None:
        raise ValueError("correction: the plan is not a corrected plan (no correction section)")
    report = {k: v for k, v in doc.correction.items() if k not in ("measured", "predicted")}
    return [atomic_write_text(target, json.dumps(report, indent=1) + "\n"),
            atomic_write_text(target.with_suffix(".txt"), correction_table(report))]


@dataclass(frozen=True)
class Writer:
    """One output: its default file (or folder) name in an output folder, and its function."""

    target: str
    write: Callable[[PlanDocument, Path, WriteOptions], list[Path]]


WRITERS: dict[str, Writer] = {
    "json": Writer("plan.json", write_json),
    "csv": Writer("trajectory.csv", write_csv),
    "ros": Writer("trajectory.yaml", write_ros),
    "rapid": Writer("rapid", write_rapid_program),
    "ros_joints": Writer("ros_joints", write_joint_trajectory_files),
    "urscript": Writer("urscript", write_urscript_files),
    "ur_rtde": Writer("ur_rtde", write_ur_rtde_files),
    "figures": Writer("figures", write_figure_files),
    "report": Writer("report.html", write_report_file),
    "correction": Writer("correction.json", write_correction_report),
}
"""Output name -> writer, in the order they run (the report embeds the figures)."""


def write_outputs(doc: PlanDocument, folder, formats=("json",), *,
                  options: WriteOptions | None = None, progress=lambda text: None) -> list[Path]:
    """Write the plan document into ``folder`` in the formats asked for (``json`` always).

    ``report`` brings ``figures`` along (it embeds them), unless ``options.figures`` is False
    (then neither is drawn, and the report has no figures). ``svg`` (a job's output name, not a
    writer: :data:`dloplan.io.job_file.SVG_OUTPUT`) writes the figures as SVG too, as
    ``options.figure_formats`` :data:`~dloplan.plots.figures.WITH_SVG` does; it needs
    ``figures`` or ``report`` beside it (ValueError). Every file is written atomically.
    Returns the written paths.
    """
    unknown = set(formats) - set(WRITERS) - {SVG_OUTPUT}
    if unknown:
        raise ValueError(f"formats: unknown {sorted(unknown)}, expected some of "
                         f"{', '.join([*WRITERS, SVG_OUTPUT])}")
    options = options or WriteOptions()
    if svg_copies(formats):
        options = replace(options, figure_formats=WITH_SVG)
    wanted = {"json", *formats} | ({"figures"} if "report" in formats else set())
    if not options.figures:
        wanted.discard("figures")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for name, writer in WRITERS.items():
        if name in wanted:
            paths = writer.write(doc, folder / writer.target, options)
            written += paths
            progress(f"{name}: {paths[0]}" + (f" and {len(paths) - 1} more files"
                                              if len(paths) > 1 else ""))
    return written
