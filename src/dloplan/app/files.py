"""Files in, folders out: the routines behind ``dloplan plan`` (one file or many) and the
commands that take either a plan or a scenario.

:func:`plan_into` runs the pipeline on a resolved job (a scenario or a wire-harness job) and
writes its outputs; :func:`plan_file` is the batch mode's task (one file, one sub-folder, a
status line), run on local processes or Dask by :func:`dloplan.study.map_jobs`;
:func:`document_of` reads a plan document, or plans a scenario file into one;
:func:`export_plan` writes one output of a plan document (``dloplan export``).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

from ..exit_codes import (  # noqa: F401 - re-exported: the codes of the command
    EXIT_CHECK_FAILED,
    EXIT_FAILURE,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_WARNINGS,
)
from ..io.job_file import draws_figures, svg_copies
from ..io.scenario import PROGRAM_NAMES
from ..output_files import output_lock, staged_folder
from ..pipeline.document import PlanDocument
from ..pipeline.job import Job
from ..pipeline.plan import make_plan
from ..pipeline.stages import quiet
from ..plots.figures import figure_formats
from ..robot.plugins import program_formats
from .document_file import plan_from_data, read_plan_data
from .figure_workers import figure_workers as workers_for
from .load import file_kind, load_job
from .writers import WRITERS, WriteOptions, write_outputs

ROBOT_OUTPUTS = ("csv", "ros", "rapid", "ros_joints", "urscript", "ur_rtde")
"""The outputs a robot could run: not written for a plan that failed a check."""


def exit_code(doc: PlanDocument) -> int:
    """0 when the plan is ok without warnings, 1 with warnings, 3 when a check failed."""
    if not doc.ok:
        return EXIT_CHECK_FAILED
    return EXIT_WARNINGS if doc.warnings else EXIT_OK


def export_plan(doc: PlanDocument, name: str, target: Path, options: WriteOptions) -> list[Path]:
    """Write output ``name`` of a plan document to ``target`` under :func:`plan_into`'s rule: a
    plan that failed a check gets no robot program or trajectory (ValueError naming them).
    The target's lock (:func:`dloplan.output_files.output_lock`) refuses a second export to it while
    this one writes."""
    failed = doc.failed_checks
    if name in ROBOT_OUTPUTS and failed:
        raise ValueError(f"{name}: not written, the plan failed a check ({', '.join(failed)}; "
                         "dloplan verify shows the table): a robot must not run it; json and "
                         "report export it for inspection")
    with output_lock(target):  # a second export to the same target waits for none: refused
        return WRITERS[name].write(doc, target, options)


def plan_into(job, folder, *, verify: bool = False, check_robot: bool = True,
              repair: bool = True, progress=quiet, budget=None, figure_workers: int = 0,
              figures: bool = True, svg: bool = False):
    """Plan a resolved job and write its outputs into ``folder``: ``(document, written paths)``.

    The folder is written whole or not at all (:func:`dloplan.output_files.staged_folder`): a run
    that fails or is interrupted leaves it as it was, and a second run on the same folder is
    refused while this one holds it. A plan that failed a check gets its plan document, figures
    and report, but no robot program or trajectory file. With ``repair`` a plan that fails a
    check is repaired first (:func:`dloplan.pipeline.make_plan`: every check with ``verify``,
    else the robot program's; ``budget`` a :class:`dloplan.pipeline.repair.Budget`).
    With ``figure_workers`` > 0 the figures are drawn on that many worker processes
    (:mod:`dloplan.app.figure_workers`), from the moment the plan is made, while its robot
    program is made and it is verified; the files written are the same. ``figures`` False
    (``--no-figures``): no figure is drawn, the job's ``figures`` output is left out and its
    report has none. The figures are PNG; ``svg`` (``--svg``), or ``svg`` among the job's
    outputs, writes each as SVG too (a job that draws no figure gets none).
    """
    folder = Path(folder)
    formats = job.outputs
    drawn = figures and draws_figures(formats)
    kinds = figure_formats(svg or svg_copies(formats))
    with staged_folder(folder) as staging, \
            workers_for(staging, figure_workers if drawn else 0, kinds) as drawer:
        doc = make_plan(job, verify=verify, check_robot=check_robot, repair=repair,
                        budget=budget, progress=progress,
                        planned=None if drawer is None else drawer.draft)
        options = WriteOptions(figure_workers=drawer, figures=figures, figure_formats=kinds)
        if isinstance(job, Job):
            options = replace(options, rate=job.motion.rate)
        if not doc.ok:
            formats = tuple(f for f in formats if f not in ROBOT_OUTPUTS)
            progress("a check failed: writing the plan and its report, no robot program")
        elif doc.robot is None and isinstance(job, Job) and "rapid" not in \
                program_formats(job.robot):
            formats = tuple(f for f in formats if f not in PROGRAM_NAMES)
            progress("no robot checks: no program for a described cell (nothing verified)")
        written = write_outputs(doc, staging, formats, options=options)
    paths = [folder / path.relative_to(staging) for path in written]
    progress(f"wrote {len(paths)} files into {folder}")
    return doc, paths


def batch_folder(output, path) -> Path:
    """The sub-folder of ``output`` that the batch mode plans job file ``path`` into:
    ``<output>/<stem>/``, the file's name without its suffix."""
    return Path(output) / Path(path).stem


def folders_written_since(output, paths, since: float) -> list[str]:
    """The batch folders (:func:`batch_folder`) of ``paths`` whose plan was written at or after
    ``since`` (``time.time()`` [s]): each complete (staged, then moved into place), also one a
    worker published just before the batch was interrupted, before its result came back."""
    found = []
    for path in paths:
        plan = batch_folder(output, path) / "plan.json"
        try:
            if plan.stat().st_mtime >= since:
                found.append(str(plan.parent))
        except OSError:
            continue
    return found


def refuse_shared_folders(output, paths) -> None:
    """Refuse a batch in which two job files would be planned into one sub-folder
    (:func:`batch_folder`): ``a/job.yaml`` and ``b/job.yaml``, ``job.yaml`` and ``job.json``,
    or one file given twice. Each run replaces a finished output folder, so the second plan
    would replace the first one's files after its status line named them (or, on two workers,
    be refused by the first one's lock).

    Raises
    ------
    ValueError
        Naming both files, the folder and what is expected; before any file is read.
    """
    seen: dict[Path, str] = {}
    for path in paths:
        folder = batch_folder(output, path)
        if folder in seen:
            same = Path(seen[folder]).resolve() == Path(path).resolve()
            if same:
                raise ValueError(f"{path}: given twice (both runs would plan into {folder}); "
                                 "expected each file once")
            raise ValueError(
                f"{seen[folder]} and {path} would both be planned into {folder} (the batch "
                f"mode writes each file into {Path(output)}/<its name without suffix>/); "
                "expected files of different names: rename one, or plan them into "
                "different output folders (-o)")
        seen[folder] = path


class FileResult(NamedTuple):
    """What :func:`plan_file` did with one file of a batch.

    Attributes
    ----------
    path : str
        The job file.
    code : int
        Its exit code (``EXIT_WARNINGS`` for a skipped file).
    line : str
        Its status line.
    skipped : bool
        An identification file, not planned (the batch's summary counts it apart).
    folder : str
        The plan's folder, written complete; ``""`` when nothing was written.
    """

    path: str
    code: int
    line: str
    skipped: bool = False
    folder: str = ""


def plan_file(options: dict, path: str) -> FileResult:
    """Plan one job file into ``<output>/<stem>/`` (the batch mode's task,
    :func:`batch_folder`; :func:`refuse_shared_folders` is called before the batch starts).

    An identification file is skipped with a pointer to ``dloplan identify``, a bad file
    gives its one-line error.
    """
    from ..io.scenario import read_mapping

    folder = batch_folder(options["output"], path)
    try:
        if file_kind(read_mapping(path)) == "identification":
            return FileResult(path, EXIT_WARNINGS, f"{path}: skipped (an identification file: "
                              "use dloplan identify)", skipped=True)
        job = load_job(path, allow_placement=options.get("allow_placement", False))
        doc, _ = plan_into(job, folder, verify=options["verify"],
                           check_robot=options.get("check_robot", True),
                           repair=options.get("repair", True),
                           figures=options.get("figures", True),
                           svg=options.get("svg", False))
    except ValueError as exc:
        text = str(exc)  # most errors name the file already
        return FileResult(path, EXIT_FAILURE, f"{path}: error: "
                          f"{text.removeprefix(f'{path}: ')}")
    code = exit_code(doc)
    status = {EXIT_OK: "ok", EXIT_WARNINGS: "warnings", EXIT_CHECK_FAILED: "check FAILED"}[code]
    return FileResult(path, code, f"{path}: {status} -> {folder}", folder=str(folder))


def document_of(path, progress=quiet, *, allow_placement: bool = False,
                harness: str | None = None) -> PlanDocument:
    """A plan document: read from a plan file, or planned now from a job file the way
    ``dloplan plan`` plans it (:func:`dloplan.pipeline.make_plan`: checked and repaired).

    ``harness`` (a command that takes no wire-harness job, what takes it instead): a harness
    job file is refused before it is planned (ValueError naming the file and ``harness``); a
    harness plan file is read (the command refuses its document).
    """
    if Path(path).suffix.lower() == ".json":  # read once, bounded as a plan document
        data = read_plan_data(path)
        if isinstance(data, dict) and file_kind(data) == "plan":
            return plan_from_data(path, data)
    job = load_job(path, progress, allow_placement=allow_placement)
    if harness is not None and not isinstance(job, Job):
        raise ValueError(f"{path}: a harness job, expected a scenario: {harness}")
    return make_plan(job, progress=progress)
