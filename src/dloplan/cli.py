"""The ``dloplan`` command: parse, load, call one library function, write.

``main(argv=None) -> int`` returns the exit code: 0 success, 1 success with warnings, 2 bad
input or a job that cannot be planned (a one-line error naming the problem, never a traceback,
no output written), 3 planned but a check failed (the plan and its report are written, no robot
program), 128 + the signal when interrupted: 130 Ctrl-C (SIGINT), 143 SIGTERM, 129 SIGHUP (nothing
written, every process the command started ended; :mod:`dloplan.interrupts`).
"""

from __future__ import annotations

import argparse
import json
import math
import numbers
import os
import signal
import sys
import time
from pathlib import Path

from . import __version__
from .bounds import (
    MAX_INPUT_BYTES,
    MAX_LINKS,
    MAX_MEASURED_POINTS,
    MAX_MODULUS_STEPS,
    MAX_RATE,
    MAX_STUDY_SAMPLES,
    MAX_WORKERS,
    MIN_LINKS,
    SLOWEST,
)
from .exit_codes import (  # noqa: F401 - EXIT_INTERRUPTED re-exported: the command's codes
    EXIT_CHECK_FAILED,
    EXIT_FAILURE,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_WARNINGS,
)
from .interrupts import (
    SIGNALS,
    catching_interrupts,
    interrupt_of,
    keeping,
    kept_of,
    raise_if_interrupted,
    shielded,
)
from .lazy_modules import defer_numpy_submodules, skip_scipy_docstring_edits

EXPORT_FORMATS = {
    "json": "the plan document",
    "csv": "the dual-arm TCP trajectory sampled at --rate",
    "ros": "a ROS 2 MultiDOFJointTrajectory",
    "ros_joints": "a ROS 2 JointTrajectory per arm",
    "urscript": "a URScript program per arm, cells of 6-joint arms",
    "ur_rtde": "the UR pair's RTDE streamer, cells of two UR arms",
    "rapid": "ABB RAPID modules, YuMi cells",
    "report": "the HTML report",
}
"""What ``dloplan export --format`` writes (the writers of :mod:`dloplan.app.writers`)."""

ALLOW_PLACEMENT = ("let the repair move or turn the job on the table where the robot reaches it, "
                   "as `repair: {placement: true}` in the job file does (otherwise such a move "
                   "is only proposed, exit 3; docs/repair.md)")
"""Help of ``--allow-placement`` (plan, demo, study, simulate, verify, correct)."""

NO_FIGURES = ("draw no figures: no figures/ folder, and the report (when the job asks for one) "
              "without them; the plan and its programs as with them, with less CPU beside the "
              "verification")
"""Help of ``plan --no-figures``."""

SVG = ("write each figure as SVG too (a vector copy for print, beside its PNG: a second drawing "
       "of each, about 1.5-1.8 times the figures' CPU); the figures are PNG only without it")
"""Help of ``--svg`` (plan, demo, study, simulate, compare, identify: every command that draws
figures)."""

FIGURE_WORKERS = 2
"""Processes drawing a plan's figures (:mod:`dloplan.app.figure_workers`; a harness job's while
it is verified: one fewer than the cores, on 2 cores one)."""

BLAS_THREADS = {"OPENBLAS_NUM_THREADS": "1"}
"""The command's BLAS threads (:func:`run`; a variable the caller set is kept). dloplan's linear
algebra is small (a cable's bands, 3x3 to 7x7 systems, splines through a few sub-steps), and
OpenBLAS's threads only cost there: waking and spinning them around each call took 8 ms CPU per
3-point spline of a robot program on the shared host (0.25 ms on one thread), and on 2 cores
they spin on the core the figure workers draw on (docs/performance.md)."""


def use_command_blas_threads() -> None:
    """Put :data:`BLAS_THREADS` into the environment (a variable the caller set is kept), for
    this process and the processes it starts; effective only before numpy loads OpenBLAS."""
    for name, value in BLAS_THREADS.items():
        os.environ.setdefault(name, value)


class Console:
    """Human-readable progress on stderr (silenced by -q); results on stdout."""

    def __init__(self, quiet: bool) -> None:
        self.quiet = quiet
        self.start = time.perf_counter()

    def stage(self, text: str) -> None:
        raise_if_interrupted()
        if not self.quiet:
            elapsed = time.perf_counter() - self.start
            print(f"[{elapsed:7.2f} s] {text}", file=sys.stderr, flush=True)


def _constants_table(n_links: int) -> str:
    from .cable import CATALOGUE_NAMES, catalogue_cable

    cables = [catalogue_cable(name, n_links=n_links) for name in CATALOGUE_NAMES]
    keys = list(cables[0].constants())
    width = max(len(k) for k in keys)
    lines = [" " * width + "".join(f"{c.name:>13}" for c in cables)]
    for key in keys:
        lines.append(f"{key:<{width}}" + "".join(f"{c.constants()[key]:>13.4g}" for c in cables))
    return "\n".join(lines)


def _cmd_cables(args: argparse.Namespace) -> int:
    if args.json:
        from .cable import CATALOGUE_NAMES, catalogue_cable

        print(json_text({"n_links": args.links, "bending": "rod", "cables": {
            name: catalogue_cable(name, n_links=args.links).constants()
            for name in CATALOGUE_NAMES}}, indent=2))
        return EXIT_OK
    print(f"The thesis' cables (section 7.2), n = {args.links}, bending model 'rod':")
    print(_constants_table(args.links))
    return EXIT_OK


def _number(text: str) -> float:
    """``text`` as a float; NaN when it is not a number (the callers refuse NaN)."""
    try:
        return float(text)
    except ValueError:
        return math.nan


def positive_number(text: str) -> float:
    """An option's value as a finite number > 0 (argparse names the option when it fails)."""
    value = _number(text)
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"got {text!r}, expected a finite number > 0")
    return value


def non_negative_number(text: str) -> float:
    """An option's value as a finite number >= 0 (argparse names the option when it fails)."""
    value = _number(text)
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"got {text!r}, expected a finite number >= 0")
    return value


def hsv_range(text: str) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """``H,S,V:H,S,V`` as its low and high corners, integers in OpenCV's HSV (H 0..179, S and V
    0..255: :class:`dloplan.vision.HsvRange`; the parse took them as floats, which the range
    refuses, so every ``--hsv`` was refused)."""
    try:
        low, high = (tuple(int(v) for v in part.split(",")) for part in text.split(":"))
    except ValueError:
        low = high = ()
    limits = (179, 255, 255)
    if not (len(low) == 3 and len(high) == 3 and all(
            0 <= v <= m for corner in (low, high) for v, m in zip(corner, limits, strict=True))):
        raise argparse.ArgumentTypeError(f"got {text!r}, expected H,S,V:H,S,V (six integers, H "
                                         "in 0..179, S and V in 0..255: OpenCV's HSV)")
    for k, channel in ((1, "S"), (2, "V")):
        if low[k] > high[k]:
            raise argparse.ArgumentTypeError(
                f"got {text!r}: its {channel} range {low[k]}..{high[k]} is empty; expected "
                "low:high with S and V low <= high (H may wrap: 170,...:10,... takes the reds)")
    return low, high


def scheduler_address(text: str) -> str:
    """A Dask scheduler address ``tcp://HOST:PORT`` (checked before any work; connected to
    later)."""
    scheme, _, rest = text.partition("://")
    host, _, port = rest.rpartition(":")
    if not (scheme and host and port.isdigit() and 0 < int(port) < 65536):
        raise argparse.ArgumentTypeError(f"got {text!r}, expected an address like "
                                         "tcp://HOST:PORT")
    return text


def motion_limit(text: str) -> float:
    """A speed limit [m/s or rad/s]: a number of at least :data:`dloplan.bounds.SLOWEST`."""
    value = positive_number(text)
    if value < SLOWEST:
        raise argparse.ArgumentTypeError(f"got {text!r}, expected at least {SLOWEST:g}")
    return value


def rate(text: str) -> float:
    """A sampling rate [Hz]: a number > 0 and at most :data:`dloplan.bounds.MAX_RATE`."""
    value = positive_number(text)
    if value > MAX_RATE:
        raise argparse.ArgumentTypeError(f"got {text!r}, expected at most {MAX_RATE:g} Hz")
    return value


def finite_number(text: str) -> float:
    """An option's value as a finite number (not nan, not inf)."""
    value = _number(text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"got {text!r}, expected a finite number")
    return value


def point(text: str) -> tuple[float, float, float]:
    """``X,Y,Z`` as a point: three finite numbers."""
    try:
        values = tuple(finite_number(v) for v in text.split(","))
    except argparse.ArgumentTypeError:
        values = ()
    if len(values) != 3:
        raise argparse.ArgumentTypeError(f"got {text!r}, expected X,Y,Z (three finite numbers "
                                         "[m])")
    return values


def integer(low: int, high: int | None = None):
    """The type of an integer option in ``low..high`` (bounds of :mod:`dloplan.bounds`)."""
    expected = f"an integer >= {low}" if high is None else f"an integer in {low}..{high}"

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"got {text!r}, expected {expected}") from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"got {text!r}, expected {expected}")
        return value

    parse.__name__ = expected
    return parse


def _finite(value):
    """``value`` with every number that is not finite (NaN, an infinity: a quantity not
    defined, such as a failed identification's E) replaced by None, in dicts, lists and
    tuples."""
    if isinstance(value, dict):
        return {key: _finite(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(item) for item in value]
    if isinstance(value, numbers.Real) and not isinstance(value, numbers.Integral) \
            and not math.isfinite(value):
        return None
    return value


def json_text(data, **options) -> str:
    """``data`` as strict JSON (RFC 8259 has no NaN or infinity: such a number is written as
    ``null``), what ``--json`` prints: ``json.loads`` of Python reads ``NaN``, but most readers
    (JavaScript's ``JSON.parse``, ``jq``, serde) refuse the whole answer. ``options`` are
    :func:`json.dumps`'s."""
    return json.dumps(_finite(data), allow_nan=False, **options)


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``dloplan plan: error: argument --workers: got '0',
    expected an integer in 1..256 (dloplan plan --help)``, exit 2, as for every bad input."""

    def error(self, message: str):
        self.exit(EXIT_FAILURE, f"{self.prog}: error: {message} ({self.prog} --help)\n")


def _cmd_schema(args: argparse.Namespace) -> int:
    from .app.schema import scenario_json_schema

    print(json_text(scenario_json_schema(), indent=2))
    return EXIT_OK


def _cmd_check(args: argparse.Namespace) -> int:
    from .app import Job, check_harness_job, check_job, load_job

    console = Console(args.quiet)
    job = load_job(args.scenario, console.stage)
    console.stage(f"loaded {args.scenario}: {job.cable.name or 'cable'}, n = {job.cable.n_links}")
    if isinstance(job, Job):
        report = check_job(job)
        console.stage("checked start, target, target stability and obstacles")
    else:  # a harness board is checked when it is resolved
        report = check_harness_job(job)
        console.stage("checked the board and the clips held before planning")
    if args.json:
        print(json_text({"findings": [f.__dict__ for f in report.findings],
                          "errors": len(report.errors), "warnings": len(report.warnings)},
                         indent=2))
    else:
        for finding in report.findings:
            print(finding.line())
    if report.errors:
        return EXIT_FAILURE
    return EXIT_WARNINGS if report.warnings else EXIT_OK


def _cmd_export(args: argparse.Namespace) -> int:
    from .app import read_plan
    from .app.files import export_plan
    from .app.writers import WriteOptions
    from .pipeline.stages import retimed

    console = Console(args.quiet)
    doc = read_plan(args.plan)
    unchecked = _unchecked(args.plan, doc)
    if args.speed is not None or args.angular_speed is not None:
        doc = retimed(doc, args.speed, args.angular_speed)
    written = export_plan(doc, args.format, Path(args.output), WriteOptions(rate=args.rate))
    console.stage(f"wrote {', '.join(str(p) for p in written)}")
    warnings, notes = _twist_lines(doc)
    for warning in warnings:
        print(f"warning: {warning}", file=sys.stderr)
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    if args.json:
        print(json_text({"written": [str(p) for p in written],
                         "warnings": ([unchecked] if unchecked else []) + warnings,
                         "notes": notes, "plan_ok": doc.ok}))
    return _plan_verdict(doc, EXIT_WARNINGS if warnings or unchecked else EXIT_OK)


def _twist_lines(doc) -> tuple[list[str], list[str]]:
    """``export``'s lines on the plan's twist: a warning (exit 1) when the plan fails its own
    twist check (:func:`dloplan.pipeline.repair.failures.twist_failures`: the torsion model's
    twist under the clip frames, the frames' relative turn only for a plan without it, and
    the frames' flips); a note when only the frames' relative turn is over the gripper path's
    limit (the cable's twist is the torsion model's: the turn alone twists nothing it does
    not say)."""
    from .pipeline.repair.failures import twist_failures

    grippers = doc.grippers
    if grippers is None:
        return [], []
    limit = math.degrees(grippers.max_twist)
    failed = twist_failures(doc)
    if failed:
        return [f"twist: the plan fails its twist check: {'; '.join(f.message for f in failed)}"
                f" ({grippers.message})"], []
    turn = math.degrees(float(abs(grippers.twist).max()))
    if turn <= limit or doc.twist is None:
        return [], []
    twist = math.degrees(float(abs(doc.twist.twist).max()))
    return [], [f"grippers: the clip frames turn {turn:.1f} deg against each other, more than "
                f"{limit:.0f} deg, but the torsion model's twist under them is {twist:.1f} deg "
                f"(the plan's twist check passes; {grippers.message})"]


def _cmd_correct(args: argparse.Namespace) -> int:
    from .app.correct import correct_and_check, correct_into, measured_points
    from .app.files import document_of

    wall0, cpu0 = time.perf_counter(), time.process_time()
    console = Console(args.quiet)
    doc = document_of(args.plan, progress=console.stage, allow_placement=args.allow_placement)
    unchecked = _unchecked(args.plan, doc)
    from .correct import CorrectionLimits

    options = dict(mode=args.mode, reference=args.reference, modulus_steps=args.modulus_steps,
                   model_error=args.model_error, grip=args.grip, offset=args.offset,
                   modulus=args.modulus, limits=CorrectionLimits(gain_significance=args.gain_sd),
                   fit_links=args.fit_links)
    if args.serve:
        return _serve_corrections(doc, options)
    if args.at is None or args.measured is None:
        raise ValueError("correct: --at and --measured are required (or --serve)")
    points = measured_points(args.measured, args.at, doc.frame_id)
    result, corrected, remaining = correct_and_check(doc, args.at, points,
                                                     verify=not args.no_verify,
                                                     progress=console.stage, **options)
    console.stage(result.message)
    written = correct_into(corrected, remaining, args.output, progress=console.stage)
    for warning in result.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    timing = (f"correction {1e3 * result.seconds:.0f} ms wall, {1e3 * result.cpu_seconds:.0f} "
              f"ms CPU; the whole command {wall:.2f} s wall, {cpu:.2f} s CPU (loading, "
              f"{'checks' if args.no_verify else 'verification'} and writing {len(written)} "
              "files included)")
    if args.json:
        print(json_text({**result.report(), "command_seconds": wall,
                          "command_cpu_seconds": cpu, "written": [str(p) for p in written]}))
    else:
        print(result.message)
        print(timing)
    return EXIT_WARNINGS if result.warnings or unchecked else EXIT_OK


def _request_lines(stream, limit: int):
    """The lines of ``stream``, each read bounded: a line longer than ``limit`` characters (an
    endless one: ``< /dev/zero``) is skipped to its end, in pieces, and given as ``None``."""
    while True:
        line = stream.readline(limit + 1)
        if not line:
            return
        if len(line) > limit and not line.endswith("\n"):
            while (rest := stream.readline(limit + 1)) and not rest.endswith("\n"):
                pass
            yield None
            continue
        yield line


def _serve_corrections(doc, options: dict) -> int:
    """``dloplan correct --serve``: one JSON request per line on stdin, one answer per line on
    stdout (docs/correction.md, "A correction service")."""
    from .app.correct import CorrectionService
    from .io.poses import same_frame

    service = CorrectionService(doc, **options)
    for line in _request_lines(sys.stdin, MAX_INPUT_BYTES):
        if line is not None and not line.strip():
            continue
        try:
            if line is None:
                raise ValueError(f"longer than {MAX_INPUT_BYTES / 1e6:g} MB (dloplan.bounds)")
            request = json.loads(line)
            if not isinstance(request, dict):
                raise ValueError("expected a JSON object {\"at\": K, \"points\": [[x, y, z], ...]}")
            frame = request.get("frame_id", doc.frame_id)
            if not isinstance(frame, str) or not same_frame(frame, doc.frame_id):
                raise ValueError(f"frame_id: got {frame!r}, the plan is in {doc.frame_id!r}")
            units = request.get("units", "m")
            if units not in ("m", "mm"):
                raise ValueError(f"units: got {units!r}, expected 'm' or 'mm'")
            if "at" not in request or "points" not in request:
                raise ValueError("expected the keys 'at' and 'points'")
            scale = 1e-3 if units == "mm" else 1.0
            flags = {key: request[key] for key in ("predict", "check_program") if key in request}
            if any(not isinstance(v, bool) for v in flags.values()):
                raise ValueError(f"predict, check_program: got {flags!r}, expected true or false")
            answer = service.correct(request["at"], _points(request["points"]) * scale, **flags)
        except (ValueError, TypeError) as exc:
            answer = {"ok": False, "error": f"request: {exc}"}
        except RecursionError:
            answer = {"ok": False, "error": "request: nested too deeply"}
        print(json_text(answer), flush=True)
    return EXIT_OK


def _points(value):
    import numpy as np

    points = np.asarray(value, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"points: got an array of shape {points.shape}, expected (k, 3)")
    return points


def _cmd_verify(args: argparse.Namespace) -> int:
    from .app import verify_plan
    from .app.files import document_of

    console = Console(args.quiet)
    doc = document_of(args.plan, progress=console.stage, allow_placement=args.allow_placement)
    unchecked = _unchecked(args.plan, doc)
    if doc.harness is not None and doc.harness.get("offset") is None and not doc.ok:
        line = ("nothing to verify: the harness job's tensioning failed when planned "
                f"({doc.harness.get('message', '')})")
        if args.json:
            print(json_text({"ok": False, "messages": [line], "robot": None}, indent=2))
        print(f"dloplan: {line}", file=sys.stderr)
        return _plan_verdict(doc, EXIT_CHECK_FAILED)
    console.stage(f"verifying {len(doc.shapes)} shapes of {args.plan}")
    result = verify_plan(doc, snap=not args.no_snap, replay=not args.no_replay,
                         tensile_limit=args.tensile_limit, tolerance=args.tolerance,
                         robot=not args.no_robot, progress=console.stage)
    console.stage("done: " + ", ".join(f"{k} {v:.2f} s" for k, v in result.timings.items()))
    program = None
    if not args.no_robot and doc.trajectory is not None:
        from .pipeline.stages import program_of

        program = program_of(doc)
    if args.json:
        print(json_text({**result.to_dict(), "robot": None if program is None
                          else program.to_dict()}, indent=2))
    else:
        print(result.table())
        if program is not None:
            print(program_table(program.summary()))
            print(program.message)
    if args.place and doc.grippers is not None and doc.trajectory is not None:
        from .pipeline.document import document_cell
        from .robot.plugins import placement_message

        cell = program.cell if program is not None else document_cell(doc)  # built once
        print(f"placement: {placement_message(cell, doc.grippers, doc.trajectory)}")
    if not result.ok or (program is not None and not program.ok):
        return EXIT_CHECK_FAILED
    return EXIT_WARNINGS if unchecked or result.warnings else EXIT_OK


def _cmd_compare(args: argparse.Namespace) -> int:
    from .app import read_plan
    from .pipeline.stages import settled_shapes
    from .vision import compare_trials, read_shapes

    console = Console(args.quiet)
    _svg_needs_output(args)
    doc = read_plan(args.plan)
    unchecked = _unchecked(args.plan, doc)
    planned = settled_shapes(doc) if args.stabilized else doc.shapes
    trials = [read_shapes(path) for path in args.shapes]
    result = compare_trials(planned, trials, frame_id=doc.frame_id, end_order=args.end_order)
    if args.output:
        from .output_files import staged_files
        from .plots.compare import write_comparison_figures
        from .plots.figures import figure_formats
        from .plots.report import write_report

        header = ["shape", "error_x [m]", "error_y [m]", "error_z [m]", "error_tot [m]",
                  "error_euclid [m]"]
        rows = [[r[0], *(f"{v:.4f}" for v in r[1:])] for r in result.rows()]
        with staged_files(args.output) as folder:  # the figures and the report, or nothing
            written = write_comparison_figures(result, folder, args.plane,
                                               figure_formats(args.svg))
            write_report(folder / "report.html", title=f"dloplan compare: {args.plan}",
                         shapes=planned, stabilized=result.registered[0],
                         overlay_label="registered (trial 1)", summary=[result.message],
                         tables=[("Planned vs registered (thesis Table 7.2)", header, rows)],
                         images=[p for p in written if p.suffix == ".png"])
        report = Path(args.output) / "report.html"
        console.stage(f"figures: {', '.join(p.name for p in written)}; report: {report}")
    print(json_text({"rows": result.rows(), "message": result.message}, indent=2, default=float)
          if args.json else result.table())
    return EXIT_WARNINGS if result.reversed_shapes or unchecked else EXIT_OK


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from .io.scenario import read_mapping
    from .vision import (
        CameraIntrinsics,
        calibrate_extrinsics,
        read_image,
        read_marker_layout,
        write_calibration,
    )

    image = read_image(args.image)
    intrinsics = CameraIntrinsics.from_dict(read_mapping(args.intrinsics))
    result = calibrate_extrinsics(image, intrinsics, read_marker_layout(args.markers))
    write_calibration(args.output, result)
    print(json_text({"output": str(args.output), "success": result.success,
                     "message": result.message, "marker_ids": list(result.marker_ids),
                     "missing_ids": list(result.missing_ids),
                     "reprojection_rms_px": result.reprojection_rms}, indent=2)
          if args.json else result.message)
    return EXIT_OK if result.success else EXIT_WARNINGS


def _cmd_register(args: argparse.Namespace) -> int:
    from .vision import HsvRange, read_calibration, read_image, register_on_plane, write_shapes

    calibration = read_calibration(args.calibration)
    if not calibration.success:
        raise ValueError(f"{args.calibration}: the calibration failed its check "
                         f"({calibration.message}); expected one that passed (dloplan "
                         "calibrate exit 0): calibrate again")
    colour = HsvRange(*args.hsv)
    shapes = [register_on_plane(calibration.intrinsics.check_image(read_image(path), str(path)),
                                calibration, colour, args.links + 1, args.height,
                                start_near=args.start_near, label=f"xi_{k}")
              for k, path in enumerate(args.images)]
    write_shapes(args.output, shapes)
    print(json_text({"output": str(args.output), "shapes": [
        {"label": s.label, "frame_id": s.frame_id, "points": len(s.points)} for s in shapes]},
        indent=2) if args.json else f"registered {len(shapes)} shape(s) into {args.output}")
    return EXIT_OK


def _cmd_identify(args: argparse.Namespace) -> int:
    from .app.identification import load_identification
    from .identify import identify_youngs_modulus
    from .identify.report import exit_code, report_lines, to_dict

    console = Console(args.quiet)
    if args.design:
        _design_writes_no_file(args)
        from .app.identification import design_cable
        from .identify.recommend import recommend_design

        cable = design_cable(args.cable, args.experiment, modulus=args.modulus,
                             n_links=args.links)
        noise = 1.0 if args.noise is None else args.noise
        console.stage(f"scoring experiments for the {cable.name or 'cable'} at E = "
                      f"{cable.youngs_modulus:.3g} Pa, {noise:g} mm noise")
        report = recommend_design(cable, noise=1e-3 * noise, n_measured=args.points or 100)
        print(json_text(report.to_dict(), indent=2) if args.json else "\n".join(report.lines()))
        return EXIT_OK if report.recommended is not None else EXIT_FAILURE
    if args.experiment is None:
        raise ValueError("experiment: give an identification file (or --design --cable NAME)")
    design_only = [f"--{name}" for name in ("cable", "modulus", "noise", "points", "links")
                   if getattr(args, name) is not None]
    if design_only:
        raise ValueError(f"{', '.join(design_only)}: options of identify --design; the "
                         "identification takes its cable, noise and n from the experiment "
                         f"file: expected {', '.join(design_only)} with --design, or the "
                         "file's fields")
    _svg_needs_output(args)
    job = load_identification(args.experiment)
    console.stage(f"identifying E of the {job.cable.name or 'cable'} in "
                  f"[{job.bounds[0]:.3g}, {job.bounds[1]:.3g}] Pa ({job.simulator} simulation)")
    result = identify_youngs_modulus(job.cable, job.experiment, bounds=job.bounds,
                                     simulator=job.simulator)
    console.stage(f"{result.simulations} simulations")
    if args.output and result.success:  # a failure (exit 2) writes nothing, as every exit 2
        from .output_files import staged_files
        from .plots.figures import figure_formats, identification_figure, save_figure

        figure = identification_figure(result.curve[:, 0], result.curve[:, 1],
                                       result.youngs_modulus)
        with staged_files(args.output) as folder:
            written = save_figure(figure, folder, "identification_cost",
                                  figure_formats(args.svg))
        console.stage("figure: " + ", ".join(str(Path(args.output) / p.name) for p in written))
    print(json_text(to_dict(result), indent=2) if args.json else "\n".join(report_lines(result)))
    return exit_code(result)


def _design_writes_no_file(args: argparse.Namespace) -> None:
    """Refuse ``-o`` and ``--svg`` with ``identify --design`` (ValueError, exit 2): the design
    prints its table and draws no figure, so the options would be ignored without a word
    (docs/decisions.md)."""
    given = [name for name, value in (("-o", args.output), ("--svg", args.svg)) if value]
    if given:
        raise ValueError(f"{' and '.join(given)}: identify --design draws no figure and writes "
                         "no file (it prints its table; --json prints it as JSON); expected "
                         f"{' and '.join(given)} without --design")


def _svg_needs_output(args: argparse.Namespace) -> None:
    """Refuse ``--svg`` without ``-o`` (ValueError, exit 2): the command's figures are drawn
    only into its output folder, so the SVG copies asked for would never be written."""
    if args.svg and not args.output:
        raise ValueError("--svg: the figures are written only into an output folder: give "
                         "-o FOLDER")


def _print_plan(doc, written, args) -> None:
    if args.json:
        print(json_text({
            "scenario": doc.source, "ok": doc.ok, "warnings": list(doc.warnings),
            "n_shapes": doc.n_shapes,
            "family": None if doc.stages is None else doc.stages.family,
            "duration_s": None if doc.trajectory is None else doc.trajectory.duration,
            "obstacles": None if doc.avoidance is None else doc.avoidance.status,
            "verified": None if doc.verification is None else doc.verification.ok,
            "harness": doc.harness,
            "written": [str(p) for p in written],
        }, indent=2, default=float))
        return
    from .app.report import summary_lines

    lines = summary_lines(doc)
    print(f"{doc.source}: {doc.n_shapes} intermediate shapes, {lines[0]}")
    for line in lines[2:]:
        print(f"  {line}")
    for warning in doc.warnings:
        print(f"  warning: {warning}")
    if doc.verification is not None:
        print(doc.verification.table())
    if doc.robot is not None:
        print(program_table(doc.robot.program["summary"]))
    print(f"  wrote {len(written)} files into {Path(written[0]).parent}"
          + ("" if doc.ok else " (a check failed: no robot program)"))


def program_table(summary: list[dict]) -> str:
    """The robot program's checks as fixed-width text, one line per check."""
    width = max([13] + [len(line["check"]) for line in summary])
    lines = [f"{'robot check':<{width}} {'verdict':<7} {'worst':>12}  where"]
    for line in summary:
        lines.append(f"{line['check']:<{width}} {'ok' if line['ok'] else 'FAILED':<7} "
                     f"{line['worst'] + 0.0:>8.4g} {line['unit']:<3}  {line['where']}")
    return "\n".join(lines)


def _plan_one(job, output: Path, args, console: Console) -> int:
    from .app.files import exit_code, plan_into

    doc, written = plan_into(job, output, verify=args.verify, check_robot=not args.no_verify,
                             repair=not args.no_repair, progress=console.stage,
                             figure_workers=FIGURE_WORKERS, figures=not args.no_figures,
                             svg=args.svg)
    _print_plan(doc, written, args)
    return exit_code(doc)


def _cmd_plan(args: argparse.Namespace) -> int:
    from .io.job_file import may_draw_figures, read_mapping
    from .plots.worker import start_server

    console = Console(args.quiet)
    if _batch(args):
        return _plan_batch(args, console)
    path = args.scenarios[0]
    data = read_mapping(path)  # before the planner's import: which outputs the job asks for
    if not args.no_figures and may_draw_figures(data):
        start_server()  # the figure workers' server warms up while the planner is imported
    defer_numpy_submodules()  # before scipy: numpy.testing and numpy.f2py run only if used
    skip_scipy_docstring_edits()  # scipy's docstrings, which a command never reads
    from .app.load import resolve_mapping

    job = resolve_mapping(data, str(path), console.stage, allow_placement=args.allow_placement)
    console.stage(f"loaded {job.source}: {job.cable.name or 'cable'}, E "
                  f"{job.cable.youngs_modulus:.3g} Pa, n = {job.cable.n_links}")
    return _plan_one(job, Path(args.output), args, console)


def _batch(args: argparse.Namespace) -> bool:
    """``dloplan plan`` in batch mode: several files, or one on workers or a scheduler."""
    return len(args.scenarios) > 1 or args.workers > 1 or bool(args.scheduler)


def _plan_batch(args: argparse.Namespace, console: Console) -> int:
    from .app.files import folders_written_since, plan_file, refuse_shared_folders
    from .study.backends import make_backend, map_jobs

    refuse_shared_folders(args.output, args.scenarios)
    options = {"output": str(Path(args.output)), "verify": args.verify,
               "check_robot": not args.no_verify, "repair": not args.no_repair,
               "allow_placement": args.allow_placement, "figures": not args.no_figures,
               "svg": args.svg}
    results, started = [], time.time()  # (position in args.scenarios, FileResult)

    def kept() -> str | None:  # read on disk: a worker may have published one unheard of
        written = folders_written_since(args.output, args.scenarios, started)
        return None if not written else (f"{len(written)} of {len(args.scenarios)} plans, "
                                         f"each complete: {', '.join(written)}")

    with keeping(kept), make_backend(None if args.scheduler else args.workers, args.scheduler,
                                     preload=("dloplan.study.evaluate",)) as backend:
        for index, result in map_jobs(plan_file, args.scenarios, backend, shared=options):
            results.append((index, result))
            console.stage(result.line)
    files = [result for _, result in sorted(results, key=lambda pair: pair[0])]
    codes = [result.code for result in files]
    skipped = sum(result.skipped for result in files)
    counts = {"ok": codes.count(EXIT_OK), "warnings": codes.count(EXIT_WARNINGS) - skipped,
              "failed_check": codes.count(EXIT_CHECK_FAILED),
              "not_planned": codes.count(EXIT_FAILURE), "skipped": skipped}
    code = max(codes)  # the worst of the batch
    if args.json:
        print(json_text({"files": [{"path": r.path, "exit_code": r.code, "skipped": r.skipped,
                                    "folder": r.folder or None, "line": r.line}
                                   for r in files],
                         **counts, "exit_code": code}, indent=2))  # in the files' order
        return code
    print(f"planned {len(codes)} scenarios: {counts['ok']} ok, {counts['warnings']} with "
          f"warnings, {counts['failed_check']} failed a check, {counts['not_planned']} could "
          "not be planned"
          + (f", {skipped} skipped (identification files: dloplan identify)" if skipped else ""))
    return code


def _cmd_demo(args: argparse.Namespace) -> int:
    from importlib import resources

    from .plots.worker import start_server

    start_server()  # the figure workers' server warms up while the planner is imported
    defer_numpy_submodules()  # before scipy: numpy.testing and numpy.f2py run only if used
    skip_scipy_docstring_edits()  # scipy's docstrings, which a command never reads
    from .app.load import resolve_mapping
    from .io.scenario import read_mapping

    console = Console(args.quiet)
    source = resources.files("dloplan.data").joinpath("demo.yaml")
    with resources.as_file(source) as path:
        job = resolve_mapping(read_mapping(path), "demo (embedded)",
                              allow_placement=args.allow_placement)
    console.stage("the embedded demo: an Ethernet cable moved over an obstacle on the table")
    output = Path(args.output)
    code = _plan_one(job, output, args, console)
    print(f"open {output / 'report.html'} in a browser; figures are in {output / 'figures'}")
    return code


def _cmd_study(args: argparse.Namespace) -> int:
    from .output_files import output_lock

    with output_lock(args.output):  # refused at once while another run writes the folder
        return _study(args)


def _study(args: argparse.Namespace) -> int:
    from .app import load_scenario
    from .app.study import study_problem_of, study_spec, with_closed_loop
    from .pipeline import make_plan
    from .study.backends import make_backend
    from .study.run import run_study

    console = Console(args.quiet)
    job = load_scenario(args.scenario, console.stage, allow_placement=args.allow_placement)
    spec = study_spec(job, args.samples, args.seed)

    def table_kept() -> str:  # once run_study has written them
        return (f"the study's table and summary in {args.output} (the same command resumes "
                "from them)")

    with make_backend(None if args.scheduler else args.workers, args.scheduler) as backend:
        backend.start()  # local workers' server: it loads the kernels while the plan is made
        doc = make_plan(job, progress=console.stage)
        problem = study_problem_of(doc)
        console.stage(f"the plan of dloplan plan: {doc.n_shapes} shapes; running "
                      f"{spec.samples} samples")
        result = run_study(problem, spec, out=args.output, backend=backend,
                           progress=lambda p: console.stage(p.line()),
                           resume=not args.overwrite, file_format="csv" if args.csv else "parquet")
        with keeping(table_kept):
            if spec.correction is not None:
                console.stage(f"closed loop: one correction after shape {spec.correction.at} "
                              f"({spec.correction.method})")
            result = with_closed_loop(doc, result, backend)
    with keeping(table_kept):
        return _study_outputs(args, console, doc, problem, result)


def _study_outputs(args: argparse.Namespace, console: Console, doc, problem, result) -> int:
    """The study's figures and report (into its folder) and its summary (printed)."""
    from .plots.figures import figure_formats
    from .plots.report import write_report
    from .plots.study import study_figures

    written = [] if args.no_figures else study_figures(result.table, result.summary,
                                                       result.spec.criteria, args.output,
                                                       formats=figure_formats(args.svg))
    report = write_report(Path(args.output) / "report.html", title=f"dloplan study: "
                          f"{args.scenario}", shapes=doc.shapes, stabilized=problem.nominal,
                          obstacles=doc.obstacles, summary=result.summary.lines(),
                          images=[p for p in written if p.suffix == ".png"])
    console.stage(f"{len(written)} figures and the report {report} in {args.output}")
    if args.json:
        print(json_text({"scenario": str(args.scenario), "plan_ok": bool(doc.ok),
                          "summary": result.summary.to_dict(), "report": str(report),
                          "figures": [str(p) for p in written]}, indent=2))
    else:
        for line in result.summary.lines():
            print(line)
    return _plan_verdict(doc, EXIT_OK)


def _cmd_simulate(args: argparse.Namespace) -> int:
    from .app.files import document_of
    from .pipeline.stages import simulate_plan

    console = Console(args.quiet)
    _svg_needs_output(args)
    doc = document_of(args.file, progress=console.stage, allow_placement=args.allow_placement,
                      harness="a harness plan is replayed phase by phase by dloplan verify "
                      "(docs/harness.md)")
    unchecked = _unchecked(args.file, doc)
    if doc.trajectory is None:
        raise ValueError(f"{args.file}: the plan has no timed trajectory to simulate")
    console.stage(f"simulating {doc.trajectory.duration:.2f} s of motion at real speed")
    run, comparison = simulate_plan(doc, damping=args.damping, torsion=args.torsion,
                                    youngs_modulus_cap=args.modulus_cap)
    console.stage(run.message)
    if args.output:
        from .output_files import staged_files
        from .plots.compare import write_comparison_figures
        from .plots.figures import figure_formats

        with staged_files(args.output) as folder:
            written = write_comparison_figures(comparison, folder, "xz",
                                               figure_formats(args.svg))
        console.stage(f"figures: {', '.join(p.name for p in written)}")
    if args.json:
        print(json_text({"ok": run.ok, "message": run.message, "rows": comparison.rows()},
                         indent=2, default=float))
    else:
        print(run.message)
        print("replay deviations from the planned stabilized shapes (model against model; "
              "measured shapes: dloplan compare)")
        print(comparison.table())
    return _plan_verdict(doc, EXIT_OK if run.ok and not unchecked else EXIT_WARNINGS)


def _unchecked(path, doc) -> str | None:
    """The warning (printed on stderr, and returned) for a plan read from ``path`` whose edits
    cannot be detected (:func:`dloplan.app.document_file.unchecked_warning`: a version-1
    document); None for a checked one, or a job file planned now."""
    from .app.document_file import unchecked_warning

    line = unchecked_warning(path, doc)
    if line is not None:
        print(f"warning: {line}", file=sys.stderr)
    return line


def _plan_verdict(doc, code: int) -> int:
    """``code``, or 3 with one line on stderr when the plan a command worked on failed a check
    (the plan ``dloplan plan`` writes without a robot program, exit 3)."""
    if doc.ok:
        return code
    print(f"dloplan: the plan failed a check ({', '.join(doc.failed_checks)}): it has no "
          "robot program (dloplan plan exits 3 on it)", file=sys.stderr)
    return EXIT_CHECK_FAILED


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="dloplan",
        description="Plan dual-arm robot manipulation of cables and hoses (deformable linear "
                    "objects).",
    )
    parser.add_argument("--version", action="version", version=f"dloplan {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def command(name: str, func, help_: str) -> argparse.ArgumentParser:
        p = sub.add_parser(name, help=help_, description=help_)
        p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
        p.add_argument("--json", action="store_true", help="machine-readable summary on stdout")
        p.set_defaults(func=func)
        return p

    plan = command("plan", _cmd_plan, "plan one scenario (or many, in batch) and write the "
                   "plan, robot programs, figures and report")
    plan.add_argument("scenarios", nargs="+", help="scenario file(s) (.yaml or .json)")
    plan.add_argument("-o", "--output", default="out/plan", help="output folder")
    checks = plan.add_mutually_exclusive_group()
    checks.add_argument("--verify", action="store_true",
                        help="also verify the physics: stability, snap-through, dynamic replay "
                        "(the robot program's checks always run)")
    checks.add_argument("--no-verify", action="store_true",
                        help="skip the robot program's checks too (the program is written "
                        "with the checks' verdict in its header)")
    plan.add_argument("--no-repair", action="store_true", help="report failed "
                      "checks without repairing the plan (docs/repair.md)")
    plan.add_argument("--allow-placement", action="store_true", help=ALLOW_PLACEMENT)
    drawn = plan.add_mutually_exclusive_group()  # figures as PNG (and SVG), or none
    drawn.add_argument("--no-figures", action="store_true", help=NO_FIGURES)
    drawn.add_argument("--svg", action="store_true", help=SVG)
    backend = plan.add_mutually_exclusive_group()  # local workers or a Dask cluster, not both
    backend.add_argument("--workers", type=integer(1, MAX_WORKERS), default=1,
                         help="batch: local worker processes")
    backend.add_argument("--scheduler", type=scheduler_address,
                         help="batch: Dask scheduler address tcp://HOST:PORT")

    demo = command("demo", _cmd_demo, "run the embedded default job (needs no input)")
    demo.add_argument("-o", "--output", default="out/demo", help="output folder")
    demo.set_defaults(verify=True, no_verify=False, no_repair=False, no_figures=False)
    demo.add_argument("--allow-placement", action="store_true", help=ALLOW_PLACEMENT)
    demo.add_argument("--svg", action="store_true", help=SVG)

    study = command("study", _cmd_study, "robustness study of a scenario's plan over cable and "
                    "pose tolerances (its study section)")
    study.add_argument("scenario")
    study.add_argument("--samples", type=integer(1, MAX_STUDY_SAMPLES),
                       help="override the number of samples")
    study.add_argument("--seed", type=integer(0), help="override the seed")
    backend = study.add_mutually_exclusive_group()
    backend.add_argument("--workers", type=integer(1, MAX_WORKERS), default=1,
                         help="local worker processes")
    backend.add_argument("--scheduler", type=scheduler_address,
                         help="Dask scheduler address tcp://HOST:PORT")
    study.add_argument("--csv", action="store_true", help="CSV instead of Parquet")
    study.add_argument("--overwrite", action="store_true", help="start over, do not resume")
    study.add_argument("-o", "--output", default="out/study", help="study folder")
    study.add_argument("--allow-placement", action="store_true", help=ALLOW_PLACEMENT)
    drawn = study.add_mutually_exclusive_group()
    drawn.add_argument("--no-figures", action="store_true", help="draw no figures: the table, "
                       "summary.json and report.html without the study's figures")
    drawn.add_argument("--svg", action="store_true", help=SVG)

    simulate = command("simulate", _cmd_simulate, "run a plan's timed trajectory through the "
                       "dynamic simulator and tabulate its deviations from the planned shapes")
    simulate.add_argument("file", help="plan.json, or a job file (planned first, as dloplan "
                          "plan plans it)")
    simulate.add_argument("--damping", choices=["relative", "absolute"], default="relative",
                          help="relative: dashpots between neighbours; absolute: the thesis' "
                          "drag -k_d v (eq. 3.3)")
    simulate.add_argument("--torsion", action="store_true",
                          help="simulate with twist (the gripper frames set the material frames)")
    simulate.add_argument("--modulus-cap", type=positive_number,
                          help="fictitious modulus [Pa] for the time step (thesis Fig. 6.5): "
                          "larger steps for stiff cables")
    simulate.add_argument("-o", "--output", help="folder for the figures")
    simulate.add_argument("--svg", action="store_true", help=SVG + " (with -o)")
    simulate.add_argument("--allow-placement", action="store_true", help=ALLOW_PLACEMENT)

    cables = command("cables", _cmd_cables, "print the model constants of the thesis' cables")
    cables.add_argument("--links", type=integer(MIN_LINKS, MAX_LINKS), default=10,
                        help="number of links n")
    command("schema", _cmd_schema, "print the JSON Schema of job files (scenario, harness, "
            "identification)")
    check = command("check", _cmd_check, "check a scenario without planning (target stability, "
                    "clip reach, obstacles at start and target)")
    check.add_argument("scenario", help="scenario file (.yaml or .json)")

    identify = command("identify", _cmd_identify, "identify the Young's modulus from a "
                       "measured manipulation (thesis 6.1)")
    identify.add_argument("experiment", nargs="?", help="identification file (.yaml/.json) "
                          "or a scenario with an identify section")
    identify.add_argument("-o", "--output", help="folder for the cost-vs-E figure (written "
                          "when E is identified)")
    identify.add_argument("--svg", action="store_true", help=SVG + " (with -o)")
    identify.add_argument("--design", action="store_true", help="score candidate experiments "
                          "by the predicted sd of E and recommend one")
    identify.add_argument("--cable", help="--design: catalogue cable name")
    identify.add_argument("--modulus", type=positive_number, help="--design: expected E [Pa]")
    identify.add_argument("--noise", type=positive_number,
                          help="--design: measurement noise [mm] (default 1)")
    identify.add_argument("--points", type=integer(2, MAX_MEASURED_POINTS),
                          help="--design: measured points along the cable (default 100)")
    identify.add_argument("--links", type=integer(MIN_LINKS, MAX_LINKS),
                          help="--design: starting n")

    export = command("export", _cmd_export, "export one output of a plan: " + "; ".join(
        f"{name} ({what})" for name, what in EXPORT_FORMATS.items()))
    export.add_argument("plan", help="plan file written by dloplan plan (plan.json)")
    export.add_argument("--format", choices=list(EXPORT_FORMATS), required=True)
    export.add_argument("-o", "--output", required=True,
                        help="output file (a folder for rapid, urscript, ur_rtde, ros_joints)")
    export.add_argument("--rate", type=rate, help="sampling rate [Hz] for csv/ros")
    export.add_argument("--speed", type=motion_limit,
                        help="re-time with this TCP speed [m/s]")
    export.add_argument("--angular-speed", type=motion_limit,
                        help="re-time: angular limit [rad/s]")

    verify = command("verify", _cmd_verify, "verify a plan: elastic stability, snap-through, "
                     "dynamic replay (exit 3 when a check fails)")
    verify.add_argument("plan", help="plan.json, or a job file (planned first, as dloplan plan "
                        "plans it)")
    verify.add_argument("--no-snap", action="store_true", help="skip the snap-through check")
    verify.add_argument("--no-replay", action="store_true", help="skip the dynamic replay")
    verify.add_argument("--no-robot", action="store_true",
                        help="skip the robot program's checks (reach, clearance, joint speeds)")
    verify.add_argument("--place", action="store_true",
                        help="search an offset of the whole job on the table where every pose "
                        "is reachable")
    verify.add_argument("--tensile-limit", type=positive_number, help="largest axial force [N]")
    verify.add_argument("--tolerance", type=positive_number, default=0.01,
                        help="largest replay deviation accepted [m]")
    verify.add_argument("--allow-placement", action="store_true", help=ALLOW_PLACEMENT)

    compare = command("compare", _cmd_compare, "compare a plan with registered shapes "
                      "(thesis Table 7.2)")
    compare.add_argument("plan", help="plan.json")
    compare.add_argument("shapes", nargs="+", help="registered shape files, one per trial")
    compare.add_argument("--stabilized", action="store_true",
                         help="compare with the stabilized shapes (what the thesis does)")
    compare.add_argument("--end-order", choices=["detect", "keep"], default="detect")
    compare.add_argument("--plane", choices=["xy", "xz", "yz"], default="xy")
    compare.add_argument("-o", "--output", help="folder for the figures")
    compare.add_argument("--svg", action="store_true", help=SVG + " (with -o)")

    correct = command("correct", _cmd_correct, "correct the rest of a plan from the shape "
                      "measured at shape K (closed loop, docs/correction.md)")
    correct.add_argument("plan", help="plan.json, or a job file (planned as dloplan plan plans "
                         "it)")
    correct.add_argument("--allow-placement", action="store_true", help=ALLOW_PLACEMENT)
    correct.add_argument("--at", type=integer(0), help="K, the shape just reached")
    correct.add_argument("--measured", help="measured shape (.csv or .json, in the plan's "
                         "frame; docs/correction.md shows the format)")
    correct.add_argument("-o", "--output", default="out/correct", help="output folder")
    correct.add_argument("--mode", choices=["target", "all"], default="target")
    correct.add_argument("--reference", choices=["stabilized", "planned"], default="stabilized")
    correct.add_argument("--modulus-steps", type=integer(0, MAX_MODULUS_STEPS), default=3,
                         help="Gauss-Newton steps of the E update (0: keep E)")
    correct.add_argument("--model-error", choices=["discretization", "modulus"],
                         default="discretization",
                         help="identify E and the discretization bias (default), or E alone")
    correct.add_argument("--grip", choices=["estimate", "model", "known"], default="estimate",
                         help="the clamp length (where the gripper's jaws end on the cable): "
                         "estimated with E and the bias when the measurement tells it, else the "
                         "model's with its uncertainty in the interval (default), always the "
                         "model's with its uncertainty, or known to be the model's L/n")
    correct.add_argument("--modulus", choices=["estimate", "known"], default="estimate",
                         help="Young's modulus: estimated when the measurement tells it "
                         "(default), or known to be the plan's (identified beforehand: kept, "
                         "no uncertainty in the interval)")
    correct.add_argument("--offset", choices=["estimate", "none"], default="estimate",
                         help="the measurement's offset (a rigid translation of the measured "
                         "shape, e.g. a camera's calibration error): estimated with E when the "
                         "measurement tells it, else its size in the interval (default), or "
                         "taken as zero")
    correct.add_argument("--fit-links", type=integer(MIN_LINKS, MAX_LINKS), default=None,
                         help="fit the clips on the cable as a chain of this many links, a "
                         "multiple of the plan's n, each gripper clamping the plan's L/n (the "
                         "plan's n: its own chain; default: the multiple nearest to 60)")
    correct.add_argument("--no-verify", action="store_true",
                         help="skip the physics verification of the corrected plan (stability, "
                         "snap-through, replay); its robot programs are still checked")
    correct.add_argument("--gain-sd", type=non_negative_number, default=2.0,
                         help="keep the plan unless the correction's predicted gain is more "
                         "than this many of its sd from zero and still a gain with the clamp "
                         "length this many sd off (default 2; 0: any gain)")
    correct.add_argument("--serve", action="store_true",
                         help="keep the plan warm: read one JSON request per line on stdin "
                         "({\"at\": K, \"points\": [[x, y, z], ...]}), answer one JSON line each")

    calibrate = command("calibrate", _cmd_calibrate, "extrinsic camera calibration from ArUco "
                        "markers (eq. 7.2)")
    calibrate.add_argument("image")
    calibrate.add_argument("--intrinsics", required=True, help="camera intrinsics (JSON/YAML)")
    calibrate.add_argument("--markers", required=True, help="marker layout (JSON)")
    calibrate.add_argument("-o", "--output", required=True, help="calibration.json to write")

    register = command("register", _cmd_register, "register cable shapes from top-view "
                       "images onto the table plane")
    register.add_argument("images", nargs="+")
    register.add_argument("--calibration", required=True)
    register.add_argument("--hsv", required=True, type=hsv_range,
                          help="colour range H,S,V:H,S,V (OpenCV HSV)")
    register.add_argument("--links", type=integer(MIN_LINKS, MAX_LINKS), default=10,
                          help="n: shapes get n + 1 points")
    register.add_argument("--height", type=finite_number, default=0.0,
                          help="plane height z [m]")
    register.add_argument("--start-near", type=point, metavar="X,Y,Z",
                          help="each shape starts at the cable end nearer this point [m] (e.g. "
                          "the plan's first clip; default: the end at the image's left)")
    register.add_argument("-o", "--output", required=True, help="shapes .csv or .json")
    return parser


INPUTS = {"plan": ("scenarios",), "study": ("scenario",), "simulate": ("file",),
          "export": ("plan",), "correct": ("plan", "measured"), "compare": ("plan", "shapes"),
          "identify": ("experiment",), "calibrate": ("image", "intrinsics", "markers"),
          "register": ("images", "calibration")}
"""The input arguments of each command that writes ``-o``: an output that is (or holds) one
of them is refused before any work (:func:`dloplan.output_files.refuse_overwriting_inputs`)."""


def _inputs(args: argparse.Namespace) -> list:
    found = []
    for name in INPUTS.get(args.command, ()):
        value = getattr(args, name, None)
        found += value if isinstance(value, list) else [value]
    return found


def _outputs(args: argparse.Namespace) -> list[tuple[str, object]]:
    """What the command replaces, each with the option that names it: ``-o``, or a batch's
    ``<output>/<stem>/`` folders (the batch leaves the other files in ``-o`` as they are)."""
    output = getattr(args, "output", None)
    if args.command != "plan" or output is None or not _batch(args):
        return [("-o", output)]
    from .app.files import batch_folder

    return [(f"-o {output}: the batch's folder", batch_folder(output, path))
            for path in args.scenarios]


def main(argv: list[str] | None = None) -> int:
    """Run the command of ``argv`` (default ``sys.argv[1:]``); returns its exit code, also for
    a bad option (2, one line) and ``--help`` or ``--version`` (0)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else EXIT_OK
    with catching_interrupts():
        try:
            if args.command in INPUTS:
                from .output_files import refuse_overwriting_inputs

                for option, output in _outputs(args):
                    refuse_overwriting_inputs(output, _inputs(args), option)
            return args.func(args)
        except BaseException as exc:
            with shielded():  # a second signal waits: the first one's line is printed
                code = _failed(exc)
            if code is None:
                raise
            return code


def _failed(exc: BaseException) -> int | None:
    """The exit code of a command that ended with ``exc``, its one line printed: a signal
    (``128 + signal``, the processes it started ended), a file that cannot be read or written, or
    bad input (2); ``None`` for a bug (its traceback is shown). Called shielded."""
    interrupt = interrupt_of(exc)
    if interrupt is None and not isinstance(exc, OSError | ValueError | ArithmeticError):
        return None
    from .processes import end_forkserver

    end_forkserver()  # were it still importing its preload, it would hold our pipes
    if interrupt is not None:
        cause = "" if interrupt.signum == signal.SIGINT else f" by {interrupt.name}"
        kept = kept_of(exc)
        written = "nothing written" if kept is None else f"kept {kept}; nothing else written"
        print(f"dloplan: interrupted{cause} ({written})", file=sys.stderr)
        return interrupt.exit_code
    if isinstance(exc, OSError):
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"dloplan: error: {where}{exc.strerror or exc}", file=sys.stderr)
    else:
        print(f"dloplan: error: {exc}", file=sys.stderr)
    return EXIT_FAILURE


def run() -> None:  # pragma: no cover - the console script, exercised by subprocess tests
    """The ``dloplan`` console script: :func:`main`, then exit without the interpreter's
    teardown.

    Tearing down numba, scipy and matplotlib (module by module, object by object) takes about a
    second after the work is done; every file is written and closed by then, so the output is
    flushed and the process ends at once, after the ``atexit`` handlers. Under a profiler or a
    tracer (``python -m cProfile``, coverage) the interpreter ends as usual, so that they write
    their results.
    """
    import atexit

    use_command_blas_threads()  # before numpy and scipy load OpenBLAS
    code = main()
    for signum in SIGNALS:  # done: a late signal must not cut the flush below short
        signal.signal(signum, signal.SIG_IGN)
    if sys.getprofile() is not None or sys.gettrace() is not None:
        sys.exit(code)
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (dloplan ... | head): nothing to flush to
            pass
    os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    run()
