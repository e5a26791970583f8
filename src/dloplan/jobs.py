"""Scenario-level jobs: what each ``dloplan`` command does, as library functions.

The command line stays thin: it parses arguments, loads a scenario (:mod:`dloplan.io.scenario`)
and calls one function here, which calls the pipeline (statics, planner, obstacles, grippers,
trajectory, verification) and returns a result the command prints and writes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .io.scenario import Job
from .obstacles.collisions import check_shape
from .shapes import discretize
from .sim.clips import clip_poses_from_shape
from .sim.statics import check_clip_reach, check_target, clip_wrenches, stabilize


@dataclass(frozen=True)
class Finding:
    """One result line of a check: ``level`` is "ok", "warning" or "error"."""

    level: str
    subject: str
    message: str

    def line(self) -> str:
        mark = {"ok": "ok     ", "warning": "WARNING", "error": "ERROR  "}[self.level]
        return f"{mark} {self.subject}: {self.message}"


@dataclass(frozen=True)
class CheckReport:
    """Result of :func:`check_job`."""

    findings: list[Finding] = field(default_factory=list)

    @property
    def errors(self) -> list[Finding]:
        return [f for f in self.findings if f.level == "error"]

    @property
    def warnings(self) -> list[Finding]:
        return [f for f in self.findings if f.level == "warning"]


def load_job(path, progress=lambda text: None):
    """Read and resolve a scenario; a cable with ``youngs_modulus: identify`` is identified first.

    Thesis Fig. 6.11, in one call: the scenario's ``identify:`` experiment gives E
    (:func:`dloplan.identify.identify_youngs_modulus`), which then sets the simulation's
    modulus and, through the planner, the stiffness family and its weights.

    Returns
    -------
    tuple
        ``(job, identification)``, the latter None when E was given.

    Raises
    ------
    ValueError
        For a bad scenario, or an identification that did not succeed (its message).
    """
    from .io.scenario import parse_scenario, read_mapping, resolve

    data = read_mapping(path)
    scenario = parse_scenario(data, str(path))
    if scenario.cable.youngs_modulus != "identify":
        return resolve(scenario, str(path)), None
    from .identify import identify_youngs_modulus
    from .identify.files import parse_identification

    setup = parse_identification(data, str(path))
    progress(f"identifying E of the {setup.cable.name or 'cable'} from the identify section")
    result = identify_youngs_modulus(setup.cable, setup.experiment, bounds=setup.bounds,
                                     simulator=setup.simulator)
    if not result.success:
        raise ValueError(f"{path}: identify: {result.message}")
    progress(result.message)
    return resolve(scenario, str(path), youngs_modulus=result.youngs_modulus), result


def check_job(job: Job) -> CheckReport:
    """Check a job without planning: shapes, clip reach, target stability, obstacles.

    Thesis 5.3 (target stability) and 5.4 (collisions of the stabilized start and target).
    """
    cable = job.cable
    findings: list[Finding] = []
    shapes = {}
    for name, points in (("start", job.start), ("target", job.target)):
        try:
            shapes[name] = discretize(points, cable, name)
        except ValueError as exc:
            findings.append(Finding("error", name, str(exc)))
            continue
        clips = clip_poses_from_shape(shapes[name])
        try:
            check_clip_reach(cable, clips)
            findings.append(Finding("ok", name, f"clips {1e3 * clips.distance:.1f} mm apart, "
                                    f"within reach of the {cable.length:.3g} m cable"))
        except ValueError as exc:
            findings.append(Finding("error", name, str(exc)))
            shapes.pop(name)
    threshold = job.scenario.check.lengths(job.scale)[0]
    settled = {}
    for name, shape in shapes.items():
        report = check_target(shape, cable, threshold=threshold)
        settled[name] = report.stabilized.shape
        if name == "target":
            level = "ok" if report.stable else "warning"
            findings.append(Finding(level, "target stability", report.message))
    for name, shape in settled.items():
        collision = check_shape(shape, job.obstacles, cable.diameter / 2)
        if collision.colliding:
            findings.append(Finding("error", f"{name} obstacles",
                                    f"the stabilized {name} collides: {collision.describe()}"))
        elif job.obstacles:
            findings.append(Finding("ok", f"{name} obstacles",
                                    f"clear by {1e3 * -collision.penetration:.1f} mm"))
    return CheckReport(findings)


def plan_clip_poses(doc) -> list:
    """Clip poses of every shape of a plan document: its gripper frames, or read off the shapes."""
    if doc.grippers is not None:
        return [doc.grippers.clip_poses(k) for k in range(len(doc.shapes))]
    return [clip_poses_from_shape(shape) for shape in doc.shapes]


def stabilized_shapes(doc) -> np.ndarray:
    """The plan's stabilized shapes: as stored by ``dloplan plan``, or computed now."""
    stored = doc.extra.get("stabilized")
    if stored is not None:
        return np.asarray(stored, dtype=float)
    from .obstacles.collisions import stabilized_path

    return stabilized_path(doc.cable, doc.shapes)[0]


def robot_rows(grippers) -> tuple[list[dict], object]:
    """YuMi reachability of every planned gripper pose, as verification rows and the result."""
    from scipy.spatial.transform import Rotation

    from .robot import check_reachability

    reach = check_reachability(grippers.positions, Rotation.from_matrix(grippers.matrices))
    rows = [{"reachable_left": bool(reach.reachable[k, 0]),
             "reachable_right": bool(reach.reachable[k, 1]),
             "joint_margin": float(np.min(reach.joint_margin[k]))}
            for k in range(len(grippers.positions))]
    return rows, reach


def verify_document(doc, *, snap: bool = True, replay: bool = True, tensile_limit=None,
                    tolerance: float = 0.01, robot: bool = True):
    """Run :func:`dloplan.verify.verify_path` on a plan document: stability, snap-through,
    YuMi reachability (when the plan has gripper poses) and dynamic replay."""
    from .verify import verify_path

    # the replay drives the clips linearly (slerp in rotation) between the planned poses at the
    # trajectory's knot times: the same motion as the timed dual-arm trajectory
    times = doc.trajectory.times if replay and doc.trajectory is not None else None
    replay_options = {"tolerance": tolerance, "tensile_limit": tensile_limit}
    reach = robot_rows(doc.grippers)[0] if robot and doc.grippers is not None else None
    return verify_path(doc.cable, stabilized_shapes(doc), plan_clip_poses(doc), times=times,
                       snap=snap, replay_options=replay_options, reachability=reach)


@dataclass(frozen=True, eq=False)
class PlanOutcome:
    """Everything ``dloplan plan`` computes for one scenario.

    Attributes
    ----------
    job : Job
        The resolved scenario.
    plan : Plan
        The three-stage planner's result (with stabilized path and collision reports).
    grippers : GripperPath
        Both clip frames for every shape.
    trajectory : Trajectory
        The timed dual-arm motion.
    target_check : TargetCheck
        The stability check of the target (thesis 5.3).
    verification : Verification or None
        The plan verification, when asked for.
    identification : Identification or None
        How the cable's E was identified, when the scenario asked for it.
    twist : TwistReport or None
        Every shape stabilized with torsion holding the planned gripper frames: the twist
        the grippers put into the cable and its energy (:func:`dloplan.sim.twist_along_path`).
    warnings : list of str
        Everything the user should look at, from every stage.
    timings : dict
        Wall time per step [s].
    """

    job: Job
    plan: object
    grippers: object
    trajectory: object
    target_check: object
    verification: object = None
    twist: object = None
    warnings: list[str] = field(default_factory=list)
    timings: dict = field(default_factory=dict)
    identification: object = None

    @property
    def family(self) -> str:
        """The stiffness family whose weights were used: the scenario's, or the one of E."""
        chosen = self.job.scenario.planner.family
        return self.plan.family if chosen == "auto" else chosen

    @property
    def ok(self) -> bool:
        """Planned, collision-free, stable: no failure (warnings allowed)."""
        failed_avoidance = self.plan.avoidance is not None and not self.plan.avoidance.success
        failed_verify = self.verification is not None and not self.verification.ok
        return self.plan.success and not failed_avoidance and not failed_verify


def _initial_frames(spec):
    frames = spec.grippers.initial_frames
    if frames.first is None and frames.last is None:
        return None
    if frames.first is None or frames.last is None:
        raise ValueError("grippers.initial_frames: give both first and last, or neither")
    from scipy.spatial.transform import Rotation

    return Rotation.concatenate([frames.first.to_rotation(), frames.last.to_rotation()])


def plan_job(job: Job, *, verify: bool = False, progress=lambda text: None,
             identification=None) -> PlanOutcome:
    """Plan a scenario end to end: planner, stabilization and obstacles, grippers, timing.

    Parameters
    ----------
    job : Job
        A resolved scenario (:func:`load_job`).
    verify : bool
        Also run the plan verification (stability, snap-through, dynamic replay).
    progress : callable
        Called with a line of text after each step.
    identification : Identification, optional
        The identification the cable's E came from (:func:`load_job`), kept in the outcome.
    """
    import time

    from .grippers import gripper_path
    from .planning import plan
    from .sim.torsion import twist_along_path
    from .trajectory import trajectory_from_grippers

    spec = job.scenario
    cable = job.cable
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    start = discretize(job.start, cable, "start")
    target = discretize(job.target, cable, "target")
    threshold, z_safety = spec.check.lengths(job.scale)
    target_check = check_target(target, cable, threshold=threshold)
    if job.obstacles:  # an end that collides cannot be planned around (thesis 5.4.3)
        ends = {"start": stabilize(start, cable).shape, "target": target_check.stabilized.shape}
        for name, shape in ends.items():
            collision = check_shape(shape, job.obstacles, cable.diameter / 2)
            if collision.colliding:
                raise ValueError(f"{name}: the stabilized {name} collides: "
                                 f"{collision.describe()}")
    timings["target check"] = time.perf_counter() - t0
    progress(target_check.message)

    t0 = time.perf_counter()
    from .planning.tuning import planner_weights

    family = None if spec.planner.family == "auto" else spec.planner.family
    options = {"weights": planner_weights(cable, family=family,
                                          overrides=spec.planner.weights or None)}
    if spec.planner.physical_mode is not None:
        options["physical_mode"] = spec.planner.physical_mode
    result = plan(cable, start, target, spec.planner.n_shapes, obstacles=job.obstacles,
                  z_safety=z_safety, max_rounds=spec.check.max_rounds,
                  **options)
    timings["plan"] = time.perf_counter() - t0
    stage_times = ", ".join(f"{k} {v:.2f} s" for k, v in result.timings.items() if k != "total")
    progress(f"planned {result.n_shapes} shapes ({family or result.family} cable weights): "
             f"{stage_times}")
    if result.avoidance is not None:
        progress(f"obstacles: {result.avoidance.message}")

    t0 = time.perf_counter()
    grippers = gripper_path(result.path, method=spec.grippers.method, cable=cable,
                            initial=_initial_frames(spec), aux=spec.grippers.auxiliary_vector)
    trajectory = trajectory_from_grippers(grippers, max_speed=spec.trajectory.tcp_speed,
                                          max_angular_speed=spec.trajectory.angular_speed)
    timings["grippers"] = time.perf_counter() - t0
    progress(f"gripper frames ({grippers.method}), trajectory {trajectory.duration:.2f} s at "
             f"{1e3 * spec.trajectory.tcp_speed:.0f} mm/s")

    warnings = list(result.warnings)
    if not target_check.stable:
        warnings.append(target_check.message)
    warnings += list(grippers.warnings)
    if not grippers.success:
        warnings.append(f"grippers: {grippers.message}")

    t0 = time.perf_counter()
    poses = [grippers.clip_poses(k) for k in range(len(result.path))]
    twist = twist_along_path(cable, result.path, poses)
    timings["twist"] = time.perf_counter() - t0
    progress(f"twist along the path: largest {np.degrees(np.abs(twist.twist).max()):.1f} deg, "
             f"energy up to {twist.twist_energy.max():.3g} J")
    if not twist.success:
        warnings.append(f"twist: {twist.message}")

    verification = None
    if verify:
        t0 = time.perf_counter()
        from .verify import verify_path

        verification = verify_path(cable, result.stabilized, poses, times=trajectory.times,
                                   reachability=robot_rows(grippers)[0])
        timings["verify"] = time.perf_counter() - t0
        progress(f"verification: {'passed' if verification.ok else 'FAILED'}")
        warnings += [m for m in verification.messages if not verification.ok]
    return PlanOutcome(job, result, grippers, trajectory, target_check, verification, twist,
                       warnings, timings, identification)


def _collision_rows(reports) -> list[dict]:
    return [{"shape": r.shape_index, "colliding": r.colliding, "obstacles": list(r.obstacles),
             "links": r.links.tolist(), "z_depth": r.z_depth, "penetration": r.penetration}
            for r in reports]


def plan_extra(outcome: PlanOutcome) -> dict:
    """The planner's sections of the plan document (stages, stabilized path, forces, checks)."""
    result = outcome.plan
    stats = result.force_statistics()
    extra = {
        "scenario": outcome.job.source,
        "family": outcome.family,
        "physical_mode": result.physical_mode,
        "stages": {name: result.stage(name).tolist() for name in ("basic", "advanced")},
        "stabilized": np.asarray(result.stabilized).tolist(),
        "lengths": {"basic": result.lengths[0].tolist(), "advanced": result.lengths[1].tolist(),
                    "physical": result.lengths[2].tolist()},
        "forces": {"axial_mean": stats.axial_mean.tolist(),
                   "axial_variance": stats.axial_variance.tolist(),
                   "bending_mean": stats.bending_mean.tolist(),
                   "bending_variance": stats.bending_variance.tolist()},
        "target_check": {"stable": outcome.target_check.stable,
                         "max_displacement": outcome.target_check.max_displacement,
                         "threshold": outcome.target_check.threshold,
                         "message": outcome.target_check.message},
        "timings": {**outcome.timings, **{f"plan.{k}": v for k, v in result.timings.items()}},
        "clip_wrenches": [clip_wrenches(result.cable, shape).tolist()
                          for shape in result.stabilized],
        "gripper_relative_twist": outcome.grippers.twist.tolist(),
        "twist": {"twist": outcome.twist.twist.tolist(),
                  "relative_twist": outcome.twist.relative_twist.tolist(),
                  "twist_energy": outcome.twist.twist_energy.tolist(),
                  "message": outcome.twist.message},
    }
    if result.avoidance is not None:
        extra["obstacles"] = {
            "status": result.avoidance.status, "rounds": result.avoidance.rounds,
            "message": result.avoidance.message,
            "before": _collision_rows(result.avoidance.reports_before),
            "after": _collision_rows(result.avoidance.reports_after),
        }
    if outcome.verification is not None:
        extra["verification"] = outcome.verification.to_dict()
    if outcome.identification is not None:
        ident = outcome.identification
        extra["identification"] = {
            "youngs_modulus": ident.youngs_modulus,
            "confidence_interval": list(ident.confidence_interval),
            "simulations": ident.simulations, "rms_error": ident.rms_error,
            "informative": ident.informative, "message": ident.message,
        }
    return extra


def write_outputs(outcome: PlanOutcome, folder, formats=None, progress=lambda text: None):
    """Write the plan's files into ``folder``: plan.json and the formats asked for.

    ``formats`` is a subset of ("json", "csv", "rapid", "ros", "figures", "report"); default:
    the scenario's ``outputs``. Every file is written atomically. Returns the written paths.
    """
    from pathlib import Path

    from .io.export import write_plan_json, write_ros_trajectory, write_trajectory_csv
    from .io.rapid import write_rapid
    from .robot import robot_program

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    formats = list(formats if formats is not None else outcome.job.scenario.outputs)
    result = outcome.plan
    written = [write_plan_json(folder / "plan.json", result.cable, result.path, outcome.grippers,
                               outcome.trajectory, outcome.warnings, plan_extra(outcome))]
    rate = outcome.job.scenario.trajectory.rate
    if "csv" in formats:
        written.append(write_trajectory_csv(folder / "trajectory.csv", outcome.trajectory,
                                            rate=rate))
    if "ros" in formats:
        written.append(write_ros_trajectory(folder / "trajectory.yaml", outcome.trajectory,
                                            rate=rate))
    if "rapid" in formats:
        program = robot_program(outcome.grippers, outcome.trajectory)
        if not program.ok:
            progress(f"warning: {program.message}")
        written += list(write_rapid(folder / "rapid", program, force=True).values())
    figures: list = []
    if "figures" in formats or "report" in formats:
        figures = write_figures(outcome, folder / "figures")
        written += figures
        progress(f"{len(figures)} figures in {folder / 'figures'}")
    if "report" in formats:
        written.append(write_plan_report(outcome, folder / "report.html",
                                         [p for p in figures if p.suffix == ".png"]))
    return written


def write_figures(outcome: PlanOutcome, folder) -> list:
    """The plan's figures as PNG and SVG (planned path with frames, stabilized, forces, lengths)."""
    from .plots.figures import (
        forces_figure,
        lengths_figure,
        path_figure,
        save_figure,
        stabilized_figure,
    )

    result = outcome.plan
    grippers = outcome.grippers
    stats = result.force_statistics()
    colliding = []
    if result.avoidance is not None:
        colliding = [r.shape_index for r in result.avoidance.reports_after if r.colliding]
    figures = [
        (path_figure(result.path, grippers.positions, grippers.matrices,
                     outcome.job.obstacles), "planned_path"),
        (stabilized_figure(result.path, result.stabilized, outcome.job.obstacles, colliding),
         "stabilized_path"),
        (forces_figure(stats.axial_mean, stats.axial_variance, stats.bending_mean,
                       stats.bending_variance), "forces"),
        (lengths_figure(dict(zip(("basic", "advanced", "physical"), result.lengths,
                                 strict=True)), result.cable.length), "lengths"),
    ]
    written = []
    for figure, name in figures:
        written += save_figure(figure, folder, name)
    return written


_VERIFY_TITLES = {
    "index": "shape", "smallest_eigenvalue": "lambda_1 [N/m]",
    "relative_eigenvalue": "lambda_1 / ref", "snap": "snap", "straying": "stray [m]",
    "reachable_left": "left arm reaches", "reachable_right": "right arm reaches",
    "joint_margin": "joint margin [rad]", "replay_deviation": "replay deviation [m]",
}


def write_plan_report(outcome: PlanOutcome, path, images=()):
    """The self-contained HTML report of a plan."""
    from .plots.report import write_report

    result = outcome.plan
    cable = result.cable
    summary = [
        f"{cable.name or 'cable'}: L {cable.length} m, d {1e3 * cable.diameter:.1f} mm, "
        f"E {cable.youngs_modulus:.3g} Pa ({outcome.family}), n = {cable.n_links}, "
        f"S = {result.n_shapes}",
        f"trajectory {outcome.trajectory.duration:.2f} s; gripper method "
        f"{outcome.grippers.method}; largest relative twist "
        f"{np.degrees(np.abs(outcome.grippers.twist).max()):.1f} deg",
        outcome.target_check.message,
    ]
    if result.avoidance is not None:
        summary.append(f"obstacles: {result.avoidance.message}")
    wrenches = [clip_wrenches(cable, shape) for shape in result.stabilized]
    tables = [("Shapes", ["shape", "length [m]", "max |F_axial| [N]", "max |F_bending| [N]",
                          "stabilization moves [mm]", "force on clips [N]",
                          "moment on clips [N m]"],
               [[k, f"{result.lengths[2][k]:.4f}",
                 f"{np.linalg.norm(result.axial_forces[2][k], axis=1).max():.3g}",
                 f"{np.linalg.norm(result.bending_forces[2][k], axis=1).max():.3g}",
                 f"{1e3 * np.linalg.norm(result.stabilized[k] - result.path[k], axis=1).max():.1f}",
                 " / ".join(f"{np.linalg.norm(w[:3]):.3g}" for w in wrenches[k]),
                 " / ".join(f"{np.linalg.norm(w[3:]):.3g}" for w in wrenches[k])]
                for k in range(len(result.path))])]
    if outcome.verification is not None:
        rows = outcome.verification.to_dict()["rows"]
        header = list(rows[0]) if rows else []

        def cell(value):
            return "-" if value is None else f"{value:.4g}" if isinstance(value, float) else value

        titles = [_VERIFY_TITLES.get(h, h) for h in header]
        tables.append(("Verification", titles, [[cell(row[h]) for h in header] for row in rows]))
    return write_report(path, title=f"dloplan plan: {outcome.job.source}", shapes=result.path,
                        stabilized=result.stabilized, clip_positions=outcome.grippers.positions,
                        clip_rotations=outcome.grippers.matrices, obstacles=outcome.job.obstacles,
                        summary=summary, warnings=outcome.warnings, tables=tables, images=images)


def load_plan_or_scenario(path, progress=lambda text: None):
    """A plan document: read from a plan file, or planned now from a scenario file."""
    from pathlib import Path

    from .io.export import PlanDocument, read_plan_json
    from .io.scenario import read_mapping

    if Path(path).suffix.lower() == ".json" and read_mapping(path).get("format") == "dloplan-plan":
        return read_plan_json(path)
    job, identification = load_job(path, progress)
    outcome = plan_job(job, progress=progress, identification=identification)
    return PlanDocument(outcome.plan.cable, outcome.plan.path, outcome.grippers,
                        outcome.trajectory, tuple(outcome.warnings), plan_extra(outcome))


def simulate_document(doc, *, damping: str = "relative", torsion: bool = False,
                      youngs_modulus_cap: float | None = None):
    """Run a plan's timed trajectory through the dynamic simulator (thesis 5.1, Table 7.2).

    The clips follow the trajectory at its real speed from the stabilized start; the simulated
    shape at each knot time is compared with the planned stabilized shape. Returns the replay
    (:func:`dloplan.verify.replay.replay`) and the Table 7.2 comparison
    (:func:`dloplan.vision.compare_shapes`): per shape and axis mean errors and the totals.
    """
    from .verify.replay import replay
    from .vision.compare import compare_shapes

    if doc.trajectory is None:
        raise ValueError("plan: no timed trajectory to simulate (plan it with gripper poses)")
    stabilized = stabilized_shapes(doc)
    run = replay(doc.cable, stabilized, (doc.trajectory.times, plan_clip_poses(doc)),
                 damping=damping, torsion=torsion, youngs_modulus_cap=youngs_modulus_cap)
    simulated = run.simulation.at(run.knot_times)
    comparison = compare_shapes(stabilized, list(simulated), end_order="keep")
    return run, comparison


def plan_harness_file(data: dict, source: str, folder, progress=lambda text: None):
    """The wire-harness job of a scenario with a ``harness:`` section (thesis 7.3).

    Runs both planning phases, insertion and tensioning, and writes ``plan.json`` (one knot per
    shape of the whole job, the harness summary in ``extra``), the trajectory CSV and the RAPID
    modules into ``folder``. Returns ``(result, written paths)``.
    """
    from pathlib import Path

    from .harness import harness_summary, write_harness_rapid
    from .harness.files import parse_harness, resolve_harness, run_harness_job
    from .io.export import write_plan_json, write_trajectory_csv

    job = resolve_harness(parse_harness(data, source), source)
    progress(f"harness job: {job.cable.name or 'cable'}, board checked")
    result = run_harness_job(job)
    progress(result.message)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = [write_plan_json(folder / "plan.json", job.cable, result.shapes, result.grippers,
                               result.trajectory, result.warnings,
                               {"harness": harness_summary(result)}),
               write_trajectory_csv(folder / "trajectory.csv", result.trajectory)]
    written += list(write_harness_rapid(folder / "rapid", result).values())
    written += write_harness_figures(result, folder, source)
    return result, written


def write_harness_figures(result, folder, source: str) -> list:
    """The harness job's figures (whole path with frames, forces per phase) and its report."""
    from pathlib import Path

    from .plots.figures import forces_figure, path_figure, save_figure
    from .plots.report import write_report

    folder = Path(folder)
    volumes = result.board.contacts()
    figures = save_figure(path_figure(result.shapes, result.grippers.positions,
                                      result.grippers.matrices, volumes,
                                      "Wire-harness job: shapes and gripper frames"),
                          folder / "figures", "harness_path")
    for phase, stats in result.forces.items():
        figure = forces_figure(stats.axial_mean, stats.axial_variance, stats.bending_mean,
                               stats.bending_variance, f"Forces per mass point, {phase} "
                               "(thesis Figs. 7.29/7.31)")
        figures += save_figure(figure, folder / "figures", f"forces_{phase}")
    times = result.phase_times()
    labels = [f"shape {k}" for k in range(len(result.shapes))]
    for name, (t0, t1) in times.items():
        for k, t in enumerate(result.trajectory.times):
            if t0 <= t <= t1 and labels[k] == f"shape {k}":
                labels[k] = f"shape {k} ({name})"
    report = write_report(
        folder / "report.html", title=f"dloplan harness job: {source}", shapes=result.shapes,
        clip_positions=result.grippers.positions, clip_rotations=result.grippers.matrices,
        obstacles=volumes, summary=[result.message] + [
            f"{name}: {t0:.2f} s to {t1:.2f} s" for name, (t0, t1) in times.items()],
        warnings=list(result.warnings), labels=labels,
        images=[p for p in figures if p.suffix == ".png"])
    return [*figures, report]
