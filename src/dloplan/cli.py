"""The ``dloplan`` command: parse, load, call one library function, write.

``main(argv=None) -> int`` returns the exit code: 0 success, 1 success with warnings, 2 failure
or bad input (a one-line error naming the problem, never a traceback, no output written).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from . import __version__
from .cable import CATALOGUE_NAMES, catalogue_cable

EXIT_OK, EXIT_WARNINGS, EXIT_FAILURE = 0, 1, 2


class Console:
    """Human-readable progress on stderr (silenced by -q); results on stdout."""

    def __init__(self, quiet: bool) -> None:
        self.quiet = quiet
        self.start = time.perf_counter()

    def stage(self, text: str) -> None:
        if not self.quiet:
            elapsed = time.perf_counter() - self.start
            print(f"[{elapsed:7.2f} s] {text}", file=sys.stderr, flush=True)


def _constants_table(n_links: int) -> str:
    cables = [catalogue_cable(name, n_links=n_links) for name in CATALOGUE_NAMES]
    keys = list(cables[0].constants())
    width = max(len(k) for k in keys)
    lines = [" " * width + "".join(f"{c.name:>13}" for c in cables)]
    for key in keys:
        lines.append(f"{key:<{width}}" + "".join(f"{c.constants()[key]:>13.4g}" for c in cables))
    return "\n".join(lines)


def _cmd_cables(args: argparse.Namespace) -> int:
    print(f"The thesis' cables (section 7.2), n = {args.links}, bending model 'rod':")
    print(_constants_table(args.links))
    return EXIT_OK


def _cmd_schema(args: argparse.Namespace) -> int:
    from .io.scenario import scenario_json_schema

    print(json.dumps(scenario_json_schema(), indent=2))
    return EXIT_OK


def _cmd_check(args: argparse.Namespace) -> int:
    from .harness.files import is_harness, parse_harness, resolve_harness
    from .io.scenario import read_mapping
    from .jobs import check_job, load_job

    console = Console(args.quiet)
    data = read_mapping(args.scenario)
    if is_harness(data):  # the board's checks run when it is resolved (docs/harness.md)
        job = resolve_harness(parse_harness(data, args.scenario), args.scenario)
        print(f"ok      board: fixtures within reach of the {job.cable.length:.3g} m cable, "
              "pegs clear of the fixtures, slots wide enough")
        return EXIT_OK
    job, _ = load_job(args.scenario, console.stage)
    console.stage(f"loaded {args.scenario}: {job.cable.name or 'cable'}, n = {job.cable.n_links}")
    report = check_job(job)
    console.stage("checked start, target, target stability and obstacles")
    if args.json:
        print(json.dumps({"findings": [f.__dict__ for f in report.findings],
                          "errors": len(report.errors), "warnings": len(report.warnings)},
                         indent=2))
    else:
        for finding in report.findings:
            print(finding.line())
    if report.errors:
        return EXIT_FAILURE
    return EXIT_WARNINGS if report.warnings else EXIT_OK


def _cmd_export(args: argparse.Namespace) -> int:
    from .io.export import (
        read_plan_json,
        write_plan_json,
        write_ros_trajectory,
        write_trajectory_csv,
    )
    from .io.rapid import RapidSettings, write_rapid
    from .trajectory import trajectory_from_grippers

    console = Console(args.quiet)
    doc = read_plan_json(args.plan)
    trajectory = doc.trajectory
    if doc.grippers is not None and (args.speed or args.angular_speed or trajectory is None):
        trajectory = trajectory_from_grippers(
            doc.grippers, max_speed=args.speed or 0.1, max_angular_speed=args.angular_speed or 1.0
        )
    if trajectory is None and args.format != "json":
        raise ValueError(f"{args.plan}: the plan has no gripper poses to build a trajectory from")
    out = Path(args.output)
    if args.format == "json":
        written = [write_plan_json(out, doc.cable, doc.shapes, doc.grippers, trajectory,
                                   doc.warnings, doc.extra)]
    elif args.format == "csv":
        written = [write_trajectory_csv(out, trajectory, rate=args.rate or 100.0)]
    elif args.format == "ros":
        written = [write_ros_trajectory(out, trajectory, rate=args.rate)]
    else:
        settings = RapidSettings(tools=(args.tool_left, args.tool_right), wobj=args.wobj)
        written = list(write_rapid(out, trajectory, settings).values())
    console.stage(f"wrote {', '.join(str(p) for p in written)}")
    if args.json:
        print(json.dumps({"written": [str(p) for p in written]}))
    twisted = doc.grippers is not None and not doc.grippers.success
    return EXIT_WARNINGS if twisted else EXIT_OK


def _cmd_correct(args: argparse.Namespace) -> int:
    from .correct.document import correct_document, measured_points, write_correction
    from .io.export import read_plan_json

    console = Console(args.quiet)
    doc = read_plan_json(args.plan)
    result = correct_document(doc, args.at, measured_points(args.measured, args.at),
                              robot=not args.no_robot, mode=args.mode,
                              reference=args.reference, modulus_steps=args.modulus_steps)
    console.stage(result.message)
    written = write_correction(doc, result, args.output)
    console.stage(f"wrote {len(written)} files into {args.output}")
    print(json.dumps(result.report()) if args.json else result.message)
    return EXIT_WARNINGS if result.warnings else EXIT_OK


def _cmd_verify(args: argparse.Namespace) -> int:
    from .io.export import read_plan_json
    from .jobs import verify_document

    console = Console(args.quiet)
    doc = read_plan_json(args.plan)
    console.stage(f"verifying {len(doc.shapes)} shapes of {args.plan}")
    result = verify_document(doc, snap=not args.no_snap, replay=not args.no_replay,
                             tensile_limit=args.tensile_limit, tolerance=args.tolerance,
                             robot=not args.no_robot)
    console.stage("done: " + ", ".join(f"{k} {v:.2f} s" for k, v in result.timings.items()))
    print(json.dumps(result.to_dict(), indent=2) if args.json else result.table())
    if args.place and doc.grippers is not None:
        from scipy.spatial.transform import Rotation

        from .robot import search_placement

        placement = search_placement(doc.grippers.positions,
                                     Rotation.from_matrix(doc.grippers.matrices))
        print(f"placement: {placement.message}")
    return EXIT_OK if result.ok else EXIT_FAILURE


def _cmd_compare(args: argparse.Namespace) -> int:
    from .io.export import read_plan_json
    from .jobs import stabilized_shapes
    from .vision import compare_trials, read_shapes

    console = Console(args.quiet)
    doc = read_plan_json(args.plan)
    planned = stabilized_shapes(doc) if args.stabilized else doc.shapes
    trials = [read_shapes(path) for path in args.shapes]
    result = compare_trials(planned, trials, frame_id=doc.frame_id, end_order=args.end_order)
    if args.output:
        from .plots.compare import write_comparison_figures
        from .plots.report import write_report

        folder = Path(args.output)
        folder.mkdir(parents=True, exist_ok=True)
        written = write_comparison_figures(result, folder, args.plane)
        header = ["shape", "error_x [m]", "error_y [m]", "error_z [m]", "error_tot [m]",
                  "error_euclid [m]"]
        rows = [[r[0], *(f"{v:.4f}" for v in r[1:])] for r in result.rows()]
        report = write_report(folder / "report.html", title=f"dloplan compare: {args.plan}",
                              shapes=planned, stabilized=result.registered[0],
                              overlay_label="registered (trial 1)", summary=[result.message],
                              tables=[("Planned vs registered (thesis Table 7.2)", header,
                                       rows)],
                              images=[p for p in written if p.suffix == ".png"])
        console.stage(f"figures: {', '.join(p.name for p in written)}; report: {report}")
    print(json.dumps({"rows": result.rows(), "message": result.message}, indent=2, default=float)
          if args.json else result.table())
    return EXIT_WARNINGS if result.reversed_shapes else EXIT_OK


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from .io.scenario import read_mapping
    from .vision import (
        CameraIntrinsics,
        calibrate_extrinsics,
        read_marker_layout,
        write_calibration,
    )
    from .vision._deps import cv2

    image = cv2().imread(args.image)
    if image is None:
        raise ValueError(f"{args.image}: cannot read the image")
    intrinsics = CameraIntrinsics.from_dict(read_mapping(args.intrinsics))
    result = calibrate_extrinsics(image, intrinsics, read_marker_layout(args.markers))
    write_calibration(args.output, result)
    print(result.message)
    return EXIT_OK if result.success else EXIT_WARNINGS


def _cmd_register(args: argparse.Namespace) -> int:
    from .vision import HsvRange, RegisteredShape, read_calibration, register_on_plane, write_shapes
    from .vision._deps import cv2

    calibration = read_calibration(args.calibration)
    try:
        low, high = ([float(v) for v in part.split(",")] for part in args.hsv.split(":"))
    except ValueError:
        raise ValueError(f"--hsv: got {args.hsv!r}, expected H,S,V:H,S,V") from None
    colour = HsvRange(tuple(low), tuple(high))
    shapes = []
    for k, path in enumerate(args.images):
        image = cv2().imread(path)
        if image is None:
            raise ValueError(f"{path}: cannot read the image")
        points = register_on_plane(image, calibration, colour, args.links + 1, args.height)
        shapes.append(RegisteredShape(points, frame_id="world", label=f"xi_{k}"))
    write_shapes(args.output, shapes)
    print(f"registered {len(shapes)} shape(s) into {args.output}")
    return EXIT_OK


def _cmd_identify(args: argparse.Namespace) -> int:
    from .identify import identify_youngs_modulus
    from .identify.files import load_identification

    console = Console(args.quiet)
    job = load_identification(args.experiment)
    console.stage(f"identifying E of the {job.cable.name or 'cable'} in "
                  f"[{job.bounds[0]:.3g}, {job.bounds[1]:.3g}] Pa ({job.simulator} simulation)")
    result = identify_youngs_modulus(job.cable, job.experiment, bounds=job.bounds,
                                     simulator=job.simulator)
    console.stage(f"{result.simulations} simulations")
    if args.output:
        from .plots.figures import identification_figure, save_figure

        figure = identification_figure(result.curve[:, 0], result.curve[:, 1],
                                       result.youngs_modulus if result.success else None)
        written = save_figure(figure, args.output, "identification_cost")
        console.stage(f"figure: {', '.join(str(p) for p in written)}")
    if args.json:
        print(json.dumps({"success": result.success, "youngs_modulus": result.youngs_modulus,
                          "confidence_interval": list(result.confidence_interval),
                          "simulations": result.simulations, "iterations": result.iterations,
                          "cost": result.cost, "rms_error": result.rms_error,
                          "at_bound": result.at_bound, "informative": result.informative,
                          "message": result.message}, indent=2))
    else:
        print(result.message)
        for key, value in result.table().items():
            print(f"  {key:<30} {value:.4g}")
    if not result.success:
        return EXIT_FAILURE
    return EXIT_OK if result.informative else EXIT_WARNINGS


def _print_outcome(outcome, written, args) -> None:
    result = outcome.plan
    if args.json:
        print(json.dumps({
            "scenario": outcome.job.source, "ok": outcome.ok, "warnings": outcome.warnings,
            "n_shapes": result.n_shapes, "family": outcome.family,
            "duration_s": outcome.trajectory.duration,
            "obstacles": None if result.avoidance is None else result.avoidance.status,
            "verified": None if outcome.verification is None else outcome.verification.ok,
            "written": [str(p) for p in written],
        }, indent=2))
        return
    print(f"{outcome.job.source}: {result.n_shapes} intermediate shapes, "
          f"trajectory {outcome.trajectory.duration:.2f} s, "
          f"{'OK' if outcome.ok else 'FAILED'}")
    for warning in outcome.warnings:
        print(f"  warning: {warning}")
    if outcome.verification is not None:
        print(outcome.verification.table())
    print(f"  wrote {len(written)} files into {Path(written[0]).parent}")


def _plan_one(job, output: Path, args, console: Console, identification=None) -> int:
    from .jobs import plan_job, write_outputs

    outcome = plan_job(job, verify=args.verify, progress=console.stage,
                       identification=identification)
    written = write_outputs(outcome, output, progress=console.stage)
    report = output / "report.html"
    if report.exists():
        console.stage(f"report: {report}")
    _print_outcome(outcome, written, args)
    if not outcome.ok:
        return EXIT_FAILURE
    return EXIT_WARNINGS if outcome.warnings else EXIT_OK


def _plan_harness(data: dict, source: str, args, console: Console) -> int:
    from .jobs import plan_harness_file

    result, written = plan_harness_file(data, source, Path(args.output), console.stage)
    if args.json:
        print(json.dumps({"scenario": source, "ok": result.success, "warnings": result.warnings,
                          "cycle_time_s": result.cycle_time, "phases": result.phase_times(),
                          "written": [str(p) for p in written]}, indent=2))
    else:
        print(f"{source}: {result.message}")
        for name, (t0, t1) in result.phase_times().items():
            print(f"  {name}: {t0:.2f} s to {t1:.2f} s")
        for warning in result.warnings:
            print(f"  warning: {warning}")
        print(f"  wrote {len(written)} files into {args.output}")
    if not result.success:
        return EXIT_FAILURE
    return EXIT_WARNINGS if result.warnings else EXIT_OK


def _cmd_plan(args: argparse.Namespace) -> int:
    from .harness.files import is_harness
    from .io.scenario import read_mapping
    from .jobs import load_job

    console = Console(args.quiet)
    if len(args.scenarios) > 1 or args.workers > 1 or args.scheduler:
        return _plan_batch(args, console)
    data = read_mapping(args.scenarios[0])
    if is_harness(data):
        return _plan_harness(data, args.scenarios[0], args, console)
    job, identification = load_job(args.scenarios[0], console.stage)
    console.stage(f"loaded {job.source}: {job.cable.name or 'cable'}, E "
                  f"{job.cable.youngs_modulus:.3g} Pa, n = {job.cable.n_links}")
    return _plan_one(job, Path(args.output), args, console, identification)


def _plan_batch(args: argparse.Namespace, console: Console) -> int:
    from .study.backends import make_backend, map_jobs

    output = Path(args.output)
    options = {"output": str(output), "verify": args.verify}
    codes = {}
    with make_backend(None if args.scheduler else args.workers, args.scheduler) as backend:
        for _, (path, code, line) in map_jobs(plan_file, args.scenarios, backend,
                                              shared=options):
            codes[path] = code
            console.stage(line)
    worst = max(codes.values())
    print(f"planned {len(codes)} scenarios: "
          f"{sum(c == EXIT_OK for c in codes.values())} ok, "
          f"{sum(c == EXIT_WARNINGS for c in codes.values())} with warnings, "
          f"{sum(c == EXIT_FAILURE for c in codes.values())} failed")
    return worst


def plan_file(options: dict, path: str) -> tuple[str, int, str]:
    """Plan one scenario file into ``<output>/<stem>/`` (the batch mode's task)."""
    from .harness.files import is_harness
    from .io.scenario import read_mapping
    from .jobs import load_job, plan_harness_file, plan_job, write_outputs

    folder = Path(options["output"]) / Path(path).stem
    try:
        data = read_mapping(path)
        if "start" not in data and "identify" in data:
            return path, EXIT_WARNINGS, f"{path}: skipped (an identification file: use " \
                "dloplan identify)"
        if is_harness(data):
            result = plan_harness_file(data, path, folder)[0]
            ok, warnings = result.success, result.warnings
        else:
            job, identification = load_job(path)
            outcome = plan_job(job, verify=options["verify"], identification=identification)
            write_outputs(outcome, folder)
            ok, warnings = outcome.ok, outcome.warnings
    except ValueError as exc:
        return path, EXIT_FAILURE, f"{path}: error: {exc}"
    code = EXIT_OK if ok and not warnings else (EXIT_WARNINGS if ok else EXIT_FAILURE)
    status = {EXIT_OK: "ok", EXIT_WARNINGS: "warnings", EXIT_FAILURE: "FAILED"}[code]
    return path, code, f"{path}: {status} -> {folder}"


def _cmd_demo(args: argparse.Namespace) -> int:
    from importlib import resources

    from .io.scenario import parse_scenario, read_mapping, resolve

    console = Console(args.quiet)
    source = resources.files("dloplan.data").joinpath("demo.yaml")
    with resources.as_file(source) as path:
        job = resolve(parse_scenario(read_mapping(path), "demo"), "demo (embedded)")
    console.stage("the embedded demo: an Ethernet cable moved over an obstacle on the table")
    output = Path(args.output)
    code = _plan_one(job, output, args, console)
    print(f"open {output / 'report.html'} in a browser; figures are in {output / 'figures'}")
    return code


def _cmd_study(args: argparse.Namespace) -> int:
    from .planning import plan
    from .plots.study import study_figures
    from .study.backends import make_backend
    from .study.run import job_problem, load_study, run_study

    console = Console(args.quiet)
    job, spec = load_study(args.scenario)
    update = {k: v for k, v in (("samples", args.samples), ("seed", args.seed)) if v is not None}
    spec = spec.model_copy(update=update) if update else spec
    from .shapes import discretize

    planned = plan(job.cable, discretize(job.start, job.cable, "start"),
                   discretize(job.target, job.cable, "target"), job.scenario.planner.n_shapes)
    console.stage(f"planned {planned.n_shapes} shapes; running {spec.samples} samples")
    problem = job_problem(job, path=planned.path)
    with make_backend(None if args.scheduler else args.workers, args.scheduler) as backend:
        result = run_study(problem, spec, out=args.output, backend=backend,
                           progress=lambda p: console.stage(p.line()),
                           resume=not args.overwrite, file_format="csv" if args.csv else "parquet")
    written = study_figures(result.table, result.summary, spec.criteria, args.output)
    from .plots.report import write_report

    report = write_report(Path(args.output) / "report.html", title=f"dloplan study: "
                          f"{args.scenario}", shapes=planned.path, stabilized=problem.nominal,
                          summary=result.summary.lines(),
                          images=[p for p in written if p.suffix == ".png"])
    console.stage(f"{len(written)} figures and the report {report} in {args.output}")
    for line in result.summary.lines():
        print(line)
    return EXIT_OK


def _cmd_simulate(args: argparse.Namespace) -> int:
    from .jobs import load_plan_or_scenario, simulate_document

    console = Console(args.quiet)
    doc = load_plan_or_scenario(args.file, progress=console.stage)
    console.stage(f"simulating {doc.trajectory.duration:.2f} s of motion at real speed")
    run, comparison = simulate_document(doc, damping=args.damping, torsion=args.torsion,
                                        youngs_modulus_cap=args.modulus_cap)
    console.stage(run.message)
    if args.output:
        from .plots.compare import write_comparison_figures

        Path(args.output).mkdir(parents=True, exist_ok=True)
        written = write_comparison_figures(comparison, args.output, "xz")
        console.stage(f"figures: {', '.join(p.name for p in written)}")
    if args.json:
        print(json.dumps({"ok": run.ok, "message": run.message, "rows": comparison.rows()},
                         indent=2, default=float))
    else:
        print(run.message)
        print(comparison.table())
    return EXIT_OK if run.ok else EXIT_WARNINGS


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
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
    plan.add_argument("--verify", action="store_true", help="also verify the plan")
    plan.add_argument("--workers", type=int, default=1,
                      help="batch: local worker processes")
    plan.add_argument("--scheduler", help="batch: Dask scheduler address tcp://HOST:PORT")

    demo = command("demo", _cmd_demo, "run the embedded default job (needs no input)")
    demo.add_argument("-o", "--output", default="out/demo", help="output folder")
    demo.set_defaults(verify=True)

    study = command("study", _cmd_study, "robustness study of a scenario's plan over cable and "
                    "pose tolerances (its study section)")
    study.add_argument("scenario")
    study.add_argument("--samples", type=int, help="override the number of samples")
    study.add_argument("--seed", type=int, help="override the seed")
    study.add_argument("--workers", type=int, default=1, help="local worker processes")
    study.add_argument("--scheduler", help="Dask scheduler address tcp://HOST:PORT")
    study.add_argument("--csv", action="store_true", help="CSV instead of Parquet")
    study.add_argument("--overwrite", action="store_true", help="start over, do not resume")
    study.add_argument("-o", "--output", default="out/study", help="study folder")

    simulate = command("simulate", _cmd_simulate, "run a plan's timed trajectory through the "
                       "dynamic simulator and tabulate the shape errors (thesis Table 7.2)")
    simulate.add_argument("file", help="plan.json, or a scenario file (planned first)")
    simulate.add_argument("--damping", choices=["relative", "absolute"], default="relative",
                          help="relative: dashpots between neighbours; absolute: the thesis' "
                          "drag -k_d v (eq. 3.3)")
    simulate.add_argument("--torsion", action="store_true",
                          help="simulate with twist (the gripper frames set the material frames)")
    simulate.add_argument("--modulus-cap", type=float,
                          help="fictitious modulus [Pa] for the time step (thesis Fig. 6.5): "
                          "larger steps for stiff cables")
    simulate.add_argument("-o", "--output", help="folder for the figures")

    cables = command("cables", _cmd_cables, "print the model constants of the thesis' cables")
    cables.add_argument("--links", type=int, default=10, help="number of links n")
    command("schema", _cmd_schema, "print the JSON Schema of scenario files")
    check = command("check", _cmd_check, "check a scenario without planning (target stability, "
                    "clip reach, obstacles at start and target)")
    check.add_argument("scenario", help="scenario file (.yaml or .json)")

    identify = command("identify", _cmd_identify, "identify the Young's modulus from a "
                       "measured manipulation (thesis 6.1)")
    identify.add_argument("experiment", help="identification file (.yaml/.json) or a scenario "
                          "with an identify section")
    identify.add_argument("-o", "--output", help="folder for the cost-vs-E figure")

    export = command("export", _cmd_export, "export a plan as JSON, CSV, ROS 2 trajectory or "
                     "ABB RAPID")
    export.add_argument("plan", help="plan file written by dloplan plan (plan.json)")
    export.add_argument("--format", choices=["json", "csv", "ros", "rapid"], required=True)
    export.add_argument("-o", "--output", required=True,
                        help="output file (a folder for rapid: one module per arm)")
    export.add_argument("--rate", type=float, help="sampling rate [Hz] for csv/ros")
    export.add_argument("--speed", type=float, help="re-time with this TCP speed [m/s]")
    export.add_argument("--angular-speed", type=float, help="re-time: angular limit [rad/s]")
    export.add_argument("--tool-left", default="tool_clip_l", help="RAPID tooldata, left arm")
    export.add_argument("--tool-right", default="tool_clip_r", help="RAPID tooldata, right arm")
    export.add_argument("--wobj", default="wobj0", help="RAPID work object")

    verify = command("verify", _cmd_verify, "verify a plan: elastic stability, snap-through, "
                     "dynamic replay (exit 2 when a check fails)")
    verify.add_argument("plan", help="plan.json")
    verify.add_argument("--no-snap", action="store_true", help="skip the snap-through check")
    verify.add_argument("--no-replay", action="store_true", help="skip the dynamic replay")
    verify.add_argument("--no-robot", action="store_true", help="skip the YuMi reachability")
    verify.add_argument("--place", action="store_true",
                        help="search an offset of the whole job on the table where every pose "
                        "is reachable")
    verify.add_argument("--tensile-limit", type=float, help="largest axial force [N]")
    verify.add_argument("--tolerance", type=float, default=0.01,
                        help="largest replay deviation accepted [m]")

    compare = command("compare", _cmd_compare, "compare a plan with registered shapes "
                      "(thesis Table 7.2)")
    compare.add_argument("plan", help="plan.json")
    compare.add_argument("shapes", nargs="+", help="registered shape files, one per trial")
    compare.add_argument("--stabilized", action="store_true",
                         help="compare with the stabilized shapes (what the thesis does)")
    compare.add_argument("--end-order", choices=["detect", "keep"], default="detect")
    compare.add_argument("--plane", choices=["xy", "xz", "yz"], default="xy")
    compare.add_argument("-o", "--output", help="folder for the figures")

    correct = command("correct", _cmd_correct, "correct the rest of a plan from the shape "
                      "measured at shape K (closed loop, docs/correction.md)")
    correct.add_argument("plan", help="plan.json")
    correct.add_argument("--at", type=int, required=True, help="K, the shape just reached")
    correct.add_argument("--measured", required=True, help="measured shape (.csv or .json)")
    correct.add_argument("-o", "--output", default="out/correct", help="output folder")
    correct.add_argument("--mode", choices=["target", "all"], default="target")
    correct.add_argument("--reference", choices=["stabilized", "planned"], default="stabilized")
    correct.add_argument("--modulus-steps", type=int, default=3,
                         help="Gauss-Newton steps of the E update (0: keep E)")
    correct.add_argument("--no-robot", action="store_true",
                         help="skip the YuMi reachability of the corrected poses")

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
    register.add_argument("--hsv", required=True, help="colour range H,S,V:H,S,V (OpenCV HSV)")
    register.add_argument("--links", type=int, default=10, help="n: shapes get n + 1 points")
    register.add_argument("--height", type=float, default=0.0, help="plane height z [m]")
    register.add_argument("-o", "--output", required=True, help="shapes .csv or .json")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, ArithmeticError, OSError) as exc:
        print(f"dloplan: error: {exc}", file=sys.stderr)
        return EXIT_FAILURE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
