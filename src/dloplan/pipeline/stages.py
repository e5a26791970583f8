"""The pipeline: a resolved job to a plan document, in stages every command shares.

::

    check_job       start/target reach, target stability (5.3), obstacles at the ends (5.4)
    plan_path       three-stage planner, stabilization, obstacle re-planning (ch. 4, 5)
    plan_motion     gripper frames (4.6) and the timed dual-arm trajectory
    plan_twist      every shape with torsion under the planned gripper frames
    verify_plan     stability, snap-through, robot reachability, dynamic replay

:func:`run_job` runs them in order and returns the
:class:`~dloplan.pipeline.document.PlanDocument` that every output is written from. A
wire-harness job has its own stages (:func:`dloplan.harness.run_harness`) and ends in the same
kind of document (:func:`run_harness_job`). Commands do not call these directly to make a plan:
:func:`dloplan.pipeline.make_plan` runs them, checks the plan and repairs it, and ``verify``,
``simulate``, ``export`` and ``compare`` work on the document it made.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np

from ..obstacles.collisions import check_shape
from ..obstacles.shapes import Table
from ..sim.clips import clip_poses_from_shape
from ..sim.statics import check_clip_reach, check_target, clip_wrenches, stabilize
from ..trajectory import GripperAction, plan_cycle
from .document import (
    AvoidanceSection,
    IdentificationSection,
    PlacementSection,
    PlanDocument,
    RobotSection,
    Stages,
    TargetCheckSection,
    TwistSection,
    VerificationSection,
    cell_to_dict,
    cycle_actions,
    cycle_to_dict,
    document_cell,
)
from .job import HarnessJob, Job
from .reuse import moved_rigidly

TESTED_MODULI = (1e5, 1e11)
"""Young's moduli [Pa] the solvers are tested on (tests/test_statics.py): a plan outside them
gets a warning."""


def quiet(text: str) -> None:
    """A progress callback that prints nothing."""


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


def check_job(job: Job) -> CheckReport:
    """Check a job without planning: clip span, the grippers' distance, robot reach, target
    stability, obstacles.

    Thesis 5.3 (target stability) and 5.4 (collisions of the stabilized start and target). An
    end whose clips are closer than the grippers allow (:func:`grip_distance_errors`) is an
    error, as ``dloplan plan`` refuses it before planning; no line when they are not.
    """
    cable = job.cable
    findings: list[Finding] = []
    shapes = {}
    for name, shape in (("start", job.start), ("target", job.target)):
        clips = clip_poses_from_shape(shape)
        try:
            check_clip_reach(cable, clips)
            shapes[name] = shape
            findings.append(Finding("ok", f"{name} cable span",
                                    f"clips {1e3 * clips.distance:.1f} mm apart, within the "
                                    f"{cable.length:.3g} m cable"))
        except ValueError as exc:
            findings.append(Finding("error", f"{name} cable span", str(exc)))
    findings += [Finding("error", f"{name} grip distance", message.removeprefix(f"{name}: "))
                 for name, message in grip_distance_errors(job).items() if name in shapes]
    if len(shapes) == 2:
        findings += _reach_findings(job)
    settled = {}
    for name, shape in shapes.items():
        report = check_target(shape, cable, threshold=job.target_threshold)
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


PLACEMENT_HINT = ("; dloplan plan will search where on the table to turn and shift the job so "
                  "that both arms reach, and move it there if the job allows it (repair: "
                  "{placement: true} or --allow-placement; docs/repair.md)")
"""What a reach error of :func:`check_job` adds: the plan may still succeed, moved."""


def _reach_findings(job: Job) -> list[Finding]:
    """Can the robot's arms hold the start and the target (gripper frames by the job's method)?"""
    grippers = gripper_frames(job, np.stack([job.start, job.target]))
    findings = []
    for k, (name, row) in enumerate(zip(("start", "target"), robot_rows(grippers, job.robot),
                                        strict=True)):
        arms = [arm for arm in ("left", "right") if not row[f"reachable_{arm}"]]
        if arms:
            misses = "; ".join(f"the {arm} arm cannot reach its clip at pose {k} (the {name}; "
                               f"IK position error {1e3 * row[f'error_{arm}']:.0f} mm)"
                               for arm in arms)
            findings.append(Finding("error", f"{name} robot reach", misses + PLACEMENT_HINT))
        else:
            findings.append(Finding("ok", f"{name} robot reach", "both arms reach their clips "
                                    f"(joint margin {row['joint_margin']:.2f} rad)"))
    return findings


@dataclass(frozen=True, eq=False)
class PathStage:
    """What :func:`plan_path` computed: the planner's result and the target check."""

    plan: object
    target_check: object
    timings: dict


def check_harness_job(job: HarnessJob) -> CheckReport:
    """Check a wire-harness job without planning: its board against the cable (checked when
    the job was resolved) and the clips it holds before planning against the cell's grippers
    (:func:`dloplan.harness.held_before_planning`, :func:`held_clips_error`) and the sides
    of its ends (:func:`held_sides_error`): an error, as ``dloplan plan`` refuses it before
    planning."""
    from ..harness import held_before_planning

    errors = [held_clips_error(job.robot, job.cable, where, clips, remedy)
              for where, clips, remedy in held_before_planning(job.start, job.board)]
    findings = [Finding("error", "grip distance", error) for error in errors if error]
    sides = held_sides_error(job)
    if sides is not None:
        findings.append(Finding("error", "ends' sides", sides))
    findings.append(Finding("ok", "board", f"fixtures within reach of the "
                            f"{job.cable.length:.3g} m cable, pegs clear of the fixtures, slots "
                            "wide enough"))
    return CheckReport(findings)


def check_grip_distance(job: Job) -> None:
    """Refuse a job whose start or target holds its clips closer than the cell's two grippers
    can be (:func:`grip_distance_errors`).

    Raises
    ------
    ValueError
        Naming the end, its clips' distance and the least distance the grippers allow.
    """
    errors = grip_distance_errors(job)
    if errors:
        raise ValueError(next(iter(errors.values())))


def grip_distance_errors(job: Job) -> dict[str, str]:
    """The ends of ``job`` ("start", "target") whose clips are closer than the cell's two
    grippers can be, each with its one-line reason (:func:`held_clips_error`;
    :func:`check_grip_distance`, which ``dloplan plan`` runs before planning, and ``dloplan
    check``, which reports them)."""
    errors = {}
    for name in ("start", "target"):
        error = held_clips_error(job.robot, job.cable, name,
                                 clip_poses_from_shape(getattr(job, name)).positions,
                                 "a longer cable, or ends held farther apart")
        if error is not None:
            errors[name] = error
    return errors


def check_held_clips(cell, cable, where: str, clips, remedy: str) -> None:
    """Refuse clips held closer than the cell's two grippers can be
    (:func:`held_clips_error`): every held pose of a harness job's phases
    (:func:`run_harness_job`, ``check_held`` of :func:`dloplan.harness.run_harness`).

    Raises
    ------
    ValueError
        Naming ``where``, the clips' distance and the least distance the grippers allow.
    """
    error = held_clips_error(cell, cable, where, clips, remedy)
    if error is not None:
        raise ValueError(error)


def held_sides_error(job: HarnessJob) -> str | None:
    """Why a harness job's ends cannot be carried from its start to its fixtures without the
    arms crossing (None if they can): the cable's first end goes to ``harness.fixtures[0]``,
    so where the start holds it on the cell's one side (:func:`dloplan.robot.assign_arms`)
    and the first fixture lies on the other, every clip route swaps the ends (the taut
    approach of phase 1 moved the clips through each other: "the two clip points coincide").

    Returns
    -------
    str or None
        One line naming the start's ends and the fixtures, their sides in the cell's frame
        and what was expected.
    """
    from ..harness import fixture_clips
    from ..robot import assign_arms

    start = clip_poses_from_shape(job.start).positions
    fixtures = fixture_clips(job.board).positions
    sides = assign_arms(np.stack([start, fixtures]), job.robot)
    if sides.ok:
        return None
    y = job.robot.to_base(np.stack([start, fixtures]))[..., 1]
    names = [f"'{f.name}' (harness.fixtures[{k}])" for k, f in enumerate(job.board.fixtures)]
    where = ("left", "right")
    first, fixture = where[int(y[0, 0] < y[0, 1])], where[int(y[1, 0] < y[1, 1])]
    return (f"harness.fixtures: the start holds the cable's first end on the cell's {first} "
            f"(y {y[0, 0]:+.3f} m, its last end {y[0, 1]:+.3f} m), but it goes to fixture "
            f"{names[0]} on the {fixture} (y {y[1, 0]:+.3f} m, {names[1]} {y[1, 1]:+.3f} m): "
            "the two arms would cross carrying it there; expected the first fixture on the "
            "side of the start's first end (swap harness.fixtures, or turn the start 180 deg)")


def held_clips_error(cell, cable, where: str, clips, remedy: str) -> str | None:
    """Why clips held at ``clips`` cannot be held by the cell's two grippers (None if they
    can): their TCPs closer than the sum of the arms' :attr:`~dloplan.robot.chain.CellArm.
    tcp_depth` put the grippers' capsules into each other at any joints, orientation or
    placement on the table, so no repair makes the robot program's clearance pass (a 3 cm
    cable searched frames and placements for 30-80 s before it was refused as unreachable).

    Parameters
    ----------
    cell : RobotCell or DescribedCell
        The robot cell (its two ``arms``).
    cable : Cable
        The cable (its length is named).
    where : str
        What holds the clips there: the job's field and, for a harness job, the phase.
    clips : array_like
        (2, 3) the two clip points [m].
    remedy : str
        What would hold them farther apart, in the job's terms.

    Returns
    -------
    str or None
        One line naming ``where``, the clips' distance and the least distance the grippers
        allow.
    """
    left, right = cell.arms
    least = left.tcp_depth + right.tcp_depth
    clips = np.asarray(clips, dtype=float)
    distance = float(np.linalg.norm(clips[1] - clips[0]))
    if distance >= least:
        return None
    return (f"{where}: its clips are {1e3 * distance:.1f} mm apart (cable "
            f"{1e3 * cable.length:.1f} mm long); expected at least {1e3 * least:.1f} "
            "mm: the two grippers' collision capsules overlap when their TCPs are closer, "
            f"whatever the arms' joints ({remedy})")


def plan_path(job: Job, progress=quiet) -> PathStage:
    """The three-stage planner with stabilization and obstacle re-planning (ch. 4, 5).

    Raises
    ------
    ValueError
        When the stabilized start or target collides with an obstacle (thesis 5.4.3: an end that
        collides cannot be planned around).
    """
    from ..planning import plan

    cable, settings = job.cable, job.planner
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    target_check = check_target(job.target, cable, threshold=job.target_threshold)
    if job.obstacles:
        ends = {"start": stabilize(job.start, cable).shape,
                "target": target_check.stabilized.shape}
        for name, shape in ends.items():
            collision = check_shape(shape, job.obstacles, cable.diameter / 2)
            if collision.colliding:
                raise ValueError(f"{name}: the stabilized {name} collides: "
                                 f"{collision.describe()}; expected it clear of every obstacle "
                                 "(an end that collides cannot be planned around, thesis "
                                 f"5.4.3): lift it by {1e3 * collision.z_depth:.1f} mm or more, "
                                 "or move it")
    timings["target check"] = time.perf_counter() - t0
    progress(target_check.message)

    t0 = time.perf_counter()
    result = plan(cable, job.start, job.target, settings.n_shapes, weights=settings.weights,
                  physical_mode=settings.physical_mode, obstacles=list(job.obstacles),
                  z_safety=settings.z_safety, max_rounds=settings.max_rounds,
                  preprocess=not settings.keep_target)
    timings["plan"] = time.perf_counter() - t0
    stage_times = ", ".join(f"{k} {v:.2f} s" for k, v in result.timings.items() if k != "total")
    weights = (f"{settings.family} cable weights" if settings.weights_used else
               f"{settings.family} cable, every shape an equilibrium")
    progress(f"planned {result.n_shapes} shapes ({weights}): {stage_times}")
    if result.avoidance is not None:
        progress(f"obstacles: {result.avoidance.message}")
    return PathStage(result, target_check, timings)


def timed_trajectory(grippers, motion, cell):
    """The jerk-limited dual-arm trajectory of a gripper path under the job's motion settings,
    the arm on the robot's left holding the clip on its left (docs/robot.md): the trajectory's
    arm order is the robot program's, so its CSV and ROS columns name the right arms."""
    from ..robot import assign_arms
    from ..trajectory import trajectory_from_grippers

    left_clip = assign_arms(grippers.positions, cell).left_clip
    return trajectory_from_grippers(grippers, left_clip=left_clip, limits=motion.limits,
                                    zone=motion.zone)


GRIPPER_FIELDS = {"aux": "grippers.auxiliary_vector", "initial": "grippers.initial_frames"}
"""The job file's fields of :func:`dloplan.grippers.gripper_path`'s parameters, which its
errors and warnings name."""


def _gripper_field(text: str) -> str:
    """``text`` ("aux: ...") naming the job file's field instead of the parameter."""
    name, colon, rest = text.partition(": ")
    return f"{GRIPPER_FIELDS[name]}: {rest}" if colon and name in GRIPPER_FIELDS else text


def gripper_frames(job: Job, path: np.ndarray):
    """Both clip frames for every shape of ``path`` by the job's method (thesis 4.6); its
    errors and warnings name the job file's fields (``grippers.auxiliary_vector``, not the
    parameter ``aux``)."""
    from ..grippers import gripper_path

    settings = job.grippers
    try:
        frames = gripper_path(path, method=settings.method, cable=job.cable,
                              initial=settings.initial, aux=settings.auxiliary_vector)
    except ValueError as exc:
        raise ValueError(_gripper_field(str(exc))) from exc
    return replace(frames, warnings=tuple(_gripper_field(w) for w in frames.warnings))


def plan_motion(job: Job, path: np.ndarray, progress=quiet):
    """Gripper frames for every shape (thesis 4.6) and the timed dual-arm trajectory."""
    grippers = gripper_frames(job, path)
    motion = job.motion
    trajectory = timed_trajectory(grippers, motion, job.robot)
    zones = "stops at every shape" if motion.zone == 0 else \
        f"fly-by zones of {1e3 * motion.zone:.0f} mm"
    progress(f"gripper frames ({grippers.method}), jerk-limited trajectory "
             f"{trajectory.duration:.2f} s at up to {1e3 * motion.tcp_speed:.0f} mm/s, {zones}")
    return grippers, trajectory


def retimed(doc: PlanDocument, speed: float | None = None,
            angular_speed: float | None = None) -> PlanDocument:
    """The document with its trajectory re-timed with a new TCP speed [m/s] and angular speed
    [rad/s] limit: the arms, the other limits and the zones stay the plan's; the cycle and the
    robot program (when the plan has one) are made again for the new timing."""
    from ..trajectory import MotionLimits, trajectory_from_grippers

    if doc.grippers is None or doc.trajectory is None:
        raise ValueError("plan: no gripper poses and trajectory to time again")
    old = doc.trajectory
    limits = old.law.limits if old.law is not None and old.law.limits is not None else \
        MotionLimits()
    limits = replace(limits, speed=limits.speed if speed is None else speed,
                     angular_speed=limits.angular_speed if angular_speed is None
                     else angular_speed)
    zone = float(np.max(old.zones)) if old.law is not None else 0.0
    trajectory = trajectory_from_grippers(doc.grippers, left_clip=old.arm_clips[0],
                                          limits=limits, zone=zone)
    new = replace(with_trajectory(doc, trajectory), robot=None, program=None,
                  warnings=tuple(w for w in doc.warnings
                                 if doc.robot is None or w != doc.robot.message))
    if doc.robot is None:
        return new
    return with_program(new, plan_program(document_cell(doc), doc.grippers,
                                          trajectory))


def with_trajectory(doc: PlanDocument, trajectory) -> PlanDocument:
    """The document with another ``trajectory`` of its knots: its cycle section timed again
    to it (the same gripper actions, :func:`retimed_cycle`), a harness job's timing with it
    (:func:`retimed_harness`), its verification cleared. Every change of a document's
    trajectory goes through here, so that the cycle it reports is the motion it carries."""
    if doc.cycle is None:
        return replace(doc, trajectory=trajectory, verification=None)
    cycle = retimed_cycle(doc.cycle, trajectory)
    harness = None if doc.harness is None else retimed_harness(doc.harness, cycle, trajectory)
    return replace(doc, trajectory=trajectory, cycle=cycle_to_dict(cycle), harness=harness,
                   verification=None)


def retimed_cycle(cycle: dict, trajectory):
    """The :class:`~dloplan.trajectory.Cycle` of a document's cycle section with the same
    gripper actions (:func:`cycle_actions`) and motion phases on another timing of the same
    knots."""
    phases: dict = {}
    for p in cycle["phases"]:
        if p["kind"] == "motion":
            first, _ = phases.get(p["name"], p["knots"])
            phases[p["name"]] = (first, p["knots"][1])
    return plan_cycle(trajectory, cycle_actions(cycle), phases or None)


HARNESS_CYCLE_LINE = re.compile(r"cycle \S+ s = motion .*? at \S+ mm/s")
"""The cycle's part of a harness section's message (``dloplan.harness.run_harness``): its
:meth:`~dloplan.trajectory.Cycle.describe` and the TCP speed."""


def retimed_harness(section: dict, cycle, trajectory) -> dict:
    """A harness job's section on another timing of its knots: its cycle, motion and action
    times, cycle breakdown, phase times and the message's cycle line those of ``cycle`` (a
    :class:`~dloplan.trajectory.Cycle`) and ``trajectory`` (its TCP speed limit); the
    insertion's and tensioning's numbers kept (the same knots: ``export --speed`` re-times the
    motion, not the tensioning's offset)."""
    times, law = trajectory.times, trajectory.law
    message = section.get("message", "")
    line = HARNESS_CYCLE_LINE.search(message)
    if line is not None:
        old = line.group(0)
        speed = old[old.rfind(" at "):] if law is None or law.limits is None else \
            f" at {1e3 * law.limits.speed:g} mm/s"
        message = message.replace(old, cycle.describe() + speed)
    return {**section, "message": message, "cycle_time": cycle.cycle_time,
            "motion_time": trajectory.duration, "action_time": cycle.action_time,
            "cycle": cycle.breakdown(),
            "phase_times": {name: (float(times[a]), float(times[b]))
                            for name, (a, b) in section["knots"].items()}}


def default_cycle(trajectory, durations: dict):
    """The cycle of a plan: grasp before the motion, release after it (``durations`` [s] by
    action name)."""
    return plan_cycle(trajectory, [GripperAction("grasp", 0, durations["grasp"]),
                                   GripperAction("release", trajectory.n_knots - 1,
                                                 durations["release"])])


def plan_twist(cable, path: np.ndarray, grippers, progress=quiet):
    """Every shape stabilized with torsion under the planned gripper frames."""
    from ..sim.torsion import twist_along_path

    poses = [grippers.clip_poses(k) for k in range(len(path))]
    twist = twist_along_path(cable, path, poses)
    progress(f"twist along the path: largest {np.degrees(np.abs(twist.twist).max()):.1f} deg, "
             f"energy up to {twist.twist_energy.max():.3g} J")
    return twist


def frame_warnings(grippers, twist) -> list[str]:
    """The warnings a plan owes its gripper frames ``grippers`` and the torsion model's
    ``twist`` under them (:func:`plan_twist`).

    The torsion model judges the cable's twist, as the plan's twist check does
    (:func:`dloplan.pipeline.repair.failures.twist_failures`) and ``export`` with it: the
    frames' own relative twist (singular where the last clip's u-axis turns by 180 deg against
    the first's, a planar U) is no warning of its own, it stays in the summary line
    (``grippers.message``). The frames' other warnings (fallbacks, steps) are kept.
    """
    own = grippers.twist_warning
    warnings = [w for w in grippers.warnings if w != own]
    if not twist.success:
        warnings.append(f"twist: {twist.message}")
    return warnings


def robot_rows(grippers, cell=None) -> list[dict]:
    """Reachability of a gripper path's poses by the cell's arms (default the YuMi, either arm
    before an arm is assigned; :func:`dloplan.robot.plugins.reach_rows`)."""
    from ..robot.cell import RobotCell
    from ..robot.plugins import reach_rows

    return reach_rows(RobotCell() if cell is None else cell, grippers)


def plan_program(cell, grippers, trajectory, progress=quiet, *, complete: bool = True):
    """The robot program of a plan on its cell, verified
    (:func:`dloplan.robot.plugins.robot_program`): on the YuMi arm assignment, IK of every
    exported target, joint limits, arm-arm clearance, continuity and joint speeds; on a
    described cell the same checks along the tracked motion, table clearance and placement.
    ``complete`` False: the program may leave rows to complete before it is written
    (``round_trips_on_demand``; :func:`completed_program`)."""
    from ..robot.plugins import robot_program

    program = robot_program(grippers, trajectory, cell, round_trips_on_demand=not complete)
    progress(program.message)
    return program


def completed_program(doc: PlanDocument) -> PlanDocument:
    """The document with its robot program complete
    (:meth:`dloplan.robot.program.RobotProgram.completed`) and its robot section recording
    that program; ``doc`` itself when its program is complete (or it has none). The verdict,
    the message and the failures, hence the warnings and the verification, are the same."""
    program = doc.program
    if program is None or program.completion is None:
        return doc
    program = program.completed()
    return replace(doc, program=program, robot=replace(doc.robot, program=program.to_dict()))


def with_program(doc: PlanDocument, program) -> PlanDocument:
    """The document with its robot program section (and its failure among the warnings). A
    program that the cell verified with the job shifted on the table (a described cell's own
    placement search, ``robot.place``, on only when the job may be moved) records the shift as
    the document's placement: the cable must lie there for it. When the program slowed the
    trajectory down (a joint over its speed limit), the document's trajectory and cycle are
    the program's timing."""
    from ..robot.placement import format_offset
    from ..robot.plugins import cell_name

    section = RobotSection(program.ok, program.message, cell_to_dict(program.cell),
                           program.to_dict())
    failures = () if program.ok else (program.message,)
    shift = np.asarray(section.program.get("offset", np.zeros(3)), dtype=float)
    placement = doc.placement
    if np.any(shift):
        placement = PlacementSection(True, 0.0, np.zeros(3), shift, (
            f"the job file's start and target offset {format_offset(shift)} m (the "
            f"{cell_name(program.cell)} cell's placement search)"))
    if program.trajectory is not None and program.trajectory is not doc.trajectory:
        doc = with_trajectory(doc, program.trajectory)
    return replace(doc, robot=section, program=program, warnings=doc.warnings + failures,
                   placement=placement)


def program_of(doc: PlanDocument):
    """The document's robot program: the one kept from planning, or rebuilt from its cell,
    gripper path and trajectory and checked to be the verified one the document records.

    Raises
    ------
    ValueError
        A plan without gripper poses or trajectory, or a rebuilt program whose targets differ
        from the document's (a document edited by hand, or another dloplan's kinematics).
    """
    if doc.program is not None:
        return doc.program
    if doc.grippers is None or doc.trajectory is None:
        raise ValueError("plan: no gripper poses and trajectory to make a robot program from")
    from ..robot.plugins import robot_program

    program = robot_program(doc.grippers, doc.trajectory, document_cell(doc))
    if doc.robot is not None:
        recorded = _target_joints(doc.robot.program)
        rebuilt = _target_joints(program.to_dict())
        if recorded.shape != rebuilt.shape or np.abs(recorded - rebuilt).max() > 1e-6:
            raise ValueError("plan.robot: the robot program rebuilt from the plan differs from "
                             "the verified one it records; plan again")
    return program


def _target_joints(program: dict) -> np.ndarray:
    """(M, joints of both arms) the joints [deg] a program dict records per target."""
    try:
        return np.array([np.concatenate([arm["joints_deg"] for arm in target["arms"].values()])
                         for target in program["targets"]], dtype=float)
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"plan.robot.program.targets: malformed ({exc})") from None


def program_reachability(program, n_shapes: int) -> list[dict]:
    """Per-shape reach and joint margin [rad] of a robot program, as verification rows."""
    rows = []
    for k in range(n_shapes):
        label = f"shape {k}"
        mine = [r for r in program.checks if r.label == label]
        reach = {arm: all(r.ok for r in mine if r.check == "reach" and r.arm == arm)
                 for arm in ("left", "right")}
        margins = [r.value for r in mine if r.check == "joint limits"]
        rows.append({"reachable_left": reach["left"], "reachable_right": reach["right"],
                     "joint_margin": float(np.radians(min(margins))) if margins else None})
    return rows


def settled_shapes(doc: PlanDocument) -> np.ndarray:
    """The plan's stabilized shapes: as stored in the document, or computed now (thesis 5.2)."""
    if doc.stabilized is not None:
        return doc.stabilized
    from ..obstacles.collisions import stabilized_path

    return stabilized_path(doc.cable, doc.shapes)[0]


REPLAY_MODULUS_CAP = 1e9
"""Largest E [Pa] the dynamic replay steps with: a stiffer cable is replayed with this
fictitious modulus for the explicit time step (thesis Fig. 6.5), so its replay takes at most a
few hundred thousand steps instead of tens of millions."""


REPLAY_AXIAL_CAP = 1e8
"""Largest axial modulus E_a [Pa] the dynamic replay steps with (when E is below it): a
composite cable's copper (2e9 Pa) would shrink the explicit time step 16 times (Ethernet) for
shapes within 0.01-0.25 mm of E_a = 1e8 Pa's (docs/decisions.md)."""


def replay_modulus_cap(cable, progress=quiet) -> float | None:
    """The fictitious modulus of a stiff cable's replay (None: the cable's own E and E_a)."""
    if cable.youngs_modulus <= REPLAY_MODULUS_CAP:
        cap = max(REPLAY_AXIAL_CAP, cable.youngs_modulus)
        if cable.axial_youngs_modulus <= cap:
            return None
        progress(f"replay: the axial modulus {cable.axial_youngs_modulus:.3g} Pa is stepped with "
                 f"{cap:.3g} Pa (docs/decisions.md)")
        return cap
    progress(f"replay: E = {cable.youngs_modulus:.3g} Pa is stepped with the fictitious "
             f"modulus {REPLAY_MODULUS_CAP:.0e} Pa (thesis Fig. 6.5)")
    return REPLAY_MODULUS_CAP


def verify_plan(doc: PlanDocument, *, snap: bool = True, replay: bool = True,
                robot: bool = True, tensile_limit=None, tolerance: float = 0.01,
                progress=quiet, reuse=None):
    """Verify a plan document: stability, snap-through, robot reachability, dynamic replay.

    The reachability columns are those of the robot program (:func:`program_of`): the exported
    targets, with the arm assignment and tools the program is written with. The replay drives
    the clips between the planned poses at the trajectory's knot times: the
    same motion as the timed dual-arm trajectory. Returns the
    :class:`~dloplan.verify.Verification`.

    A wire-harness plan is verified on its held cable, phase by phase
    (:func:`dloplan.pipeline.harness.verify_harness_plan`, a
    :class:`~dloplan.harness.verification.HarnessVerification`): ``tensile_limit``, when
    given, replaces the cable's rated load the plan records.

    ``reuse``, a pair (document, its verification), gives a verification of this plan before
    a rigid move on the table (a placement repair): when ``doc`` is that document turned about
    the vertical and shifted (:func:`dloplan.pipeline.reuse.moved_rigidly`) and it ran the
    same physics checks, its stability, snap-through and replay are kept and only the robot
    checks run again.
    """
    from ..verify import verify_path

    if doc.harness is not None:
        from .harness import verify_harness_plan

        rows = program_of(doc).checks if robot and doc.trajectory is not None else None
        return verify_harness_plan(doc, snap=snap, replay=replay, robot_rows=rows,
                                   rated_load=tensile_limit, tolerance=tolerance,
                                   youngs_modulus_cap=replay_modulus_cap(doc.cable, progress),
                                   progress=progress)
    times = doc.trajectory.times if replay and doc.trajectory is not None else None
    reach = None
    if robot and doc.trajectory is not None:
        reach = program_reachability(program_of(doc), len(doc.shapes))
    physics = None
    if reuse is not None and _same_checks(reuse[1], snap, times is not None, tolerance,
                                          tensile_limit) and moved_rigidly(reuse[0], doc) \
            and all(isinstance(o, Table) for o in doc.obstacles):  # obstacles stay: replay
        physics = reuse[1]
    return verify_path(doc.cable, settled_shapes(doc), doc.clip_poses(), times=times, snap=snap,
                       replay_options={"tolerance": tolerance, "tensile_limit": tensile_limit,
                                       "obstacles": doc.obstacles,
                                       "law": None if doc.trajectory is None
                                       else doc.trajectory.law,
                                       "youngs_modulus_cap": replay_modulus_cap(doc.cable,
                                                                                progress)},
                       reachability=reach, progress=progress, physics=physics)


def _same_checks(verification, snap: bool, replay: bool, tolerance: float,
                 tensile_limit) -> bool:
    """The verification ran the physics checks asked for, with the same replay settings."""
    run = verification.replay
    if (verification.snap is not None) != snap or (run is not None) != replay:
        return False
    return run is None or (run.tolerance == tolerance and run.tensile_limit == tensile_limit)


def with_verification(doc: PlanDocument, verification) -> PlanDocument:
    """The document with its verification section (and the failures among its warnings)."""
    data = verification.to_dict()
    section = VerificationSection(bool(data["ok"]), tuple(data["messages"]),
                                  tuple(data.get("rows", ())), dict(data["timings_s"]),
                                  tuple(data.get("phases", ())))
    failures = tuple(verification.messages) if not verification.ok else tuple(
        data.get("warnings", ()))
    return replace(doc, verification=section, warnings=doc.warnings + failures)


def collision_rows(reports) -> tuple:
    """The plan document's rows of :class:`~dloplan.obstacles.collisions.CollisionReport` s."""
    return tuple({"shape": r.shape_index, "colliding": r.colliding,
                  "obstacles": list(r.obstacles), "links": r.links.tolist(),
                  "z_depth": r.z_depth, "penetration": r.penetration} for r in reports)


def _identification_section(ident) -> IdentificationSection | None:
    if ident is None:
        return None
    return IdentificationSection(ident.youngs_modulus, tuple(ident.confidence_interval),
                                 ident.simulations, ident.rms_error, ident.informative,
                                 ident.message, ident.n_links)


def run_job(job: Job, *, verify: bool = False, check_robot: bool = True,
            progress=quiet, planned=None, complete_program: bool = True) -> PlanDocument:
    """Plan a job end to end and return its plan document.

    Parameters
    ----------
    job : Job
        A resolved scenario (:func:`dloplan.app.load_job`).
    verify : bool
        Also verify the plan's physics (:func:`verify_plan`: stability, snap-through, replay).
    check_robot : bool
        Make and check the robot program (:func:`plan_program`; fast, on by default).
    progress : callable
        Called with a line of text after each step.
    planned : callable, optional
        ``planned(doc, provisional)``: called with the planned document (shapes, gripper poses,
        trajectory) before its robot program is made, ``provisional`` True when a program is
        made (the command line starts drawing the figures no program or repair changes), and
        again with the document and its program when the program passes (``provisional``
        False: the other figures; a plan whose program fails is repaired).
    complete_program : bool
        False: the robot program may come with rows still to complete (its passing round
        trips, :func:`plan_program`): the caller completes it (:func:`completed_program`)
        unless it replaces it (:func:`dloplan.pipeline.make_plan`: after the figures of a
        program that passes were started by ``planned``; the reach repair replaces one that
        fails).
    """
    t0 = time.perf_counter()
    if check_robot:
        check_grip_distance(job)
    grip_check = time.perf_counter() - t0
    staged = plan_path(job, progress)
    result, target_check = staged.plan, staged.target_check
    timings = {"grip check": grip_check, **staged.timings}
    t0 = time.perf_counter()
    grippers, trajectory = plan_motion(job, result.path, progress)
    timings["grippers"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    twist = plan_twist(job.cable, result.path, grippers, progress)
    timings["twist"] = time.perf_counter() - t0

    warnings = [w + " (planner.keep_target: true plans the requested one)"
                if w.endswith("planned instead") else w for w in result.warnings]
    e = job.cable.youngs_modulus
    if not TESTED_MODULI[0] <= e <= TESTED_MODULI[1]:
        warnings.append(f"cable: E = {e:.3g} Pa is outside {TESTED_MODULI[0]:.0e}.."
                        f"{TESTED_MODULI[1]:.0e} Pa, the range the solvers are tested on")
    if job.identification is not None:
        from ..identify.report import plan_warnings

        warnings += [f"identification: {w}" for w in plan_warnings(job.identification, job.cable)]
    if not target_check.stable:
        warnings.append(target_check.message)
    warnings += frame_warnings(grippers, twist)
    avoidance = result.avoidance
    cycle = default_cycle(trajectory, {"grasp": job.motion.grasp_time,
                                       "release": job.motion.release_time})
    progress(cycle.describe())
    doc = PlanDocument(
        cable=job.cable, shapes=result.path, grippers=grippers, trajectory=trajectory,
        warnings=tuple(warnings), source=job.source, obstacles=job.obstacles,
        stabilized=result.stabilized,
        clip_wrenches=np.stack([clip_wrenches(job.cable, s) for s in result.stabilized]),
        stages=Stages(result.stage("basic"), result.stage("advanced"), np.asarray(result.lengths),
                      job.planner.family, job.planner.weights_used, result.physical_mode,
                      dict(result.timings)),
        forces={"physical": result.force_statistics()},
        target_check=TargetCheckSection(target_check.stable, target_check.max_displacement,
                                        target_check.threshold, target_check.message),
        twist=TwistSection(twist.twist, twist.relative_twist, twist.twist_energy,
                           grippers.twist, twist.message),
        avoidance=None if avoidance is None else AvoidanceSection(
            avoidance.status, avoidance.rounds, avoidance.message,
            collision_rows(avoidance.reports_before), collision_rows(avoidance.reports_after)),
        identification=_identification_section(job.identification),
        cycle=cycle_to_dict(cycle), timings=timings,
    )
    if planned is not None:
        planned(doc, provisional=check_robot)
    if check_robot:
        t0 = time.perf_counter()
        doc = with_program(doc, plan_program(job.robot, grippers, trajectory, progress,
                                             complete=complete_program))
        doc = replace(doc, timings={**doc.timings, "robot": time.perf_counter() - t0})
        if planned is not None and doc.program.ok:
            planned(doc, provisional=False)
    if verify:
        t0 = time.perf_counter()
        verification = verify_plan(doc, progress=progress)
        doc = with_verification(doc, verification)
        doc = replace(doc, timings={**doc.timings, "verify": time.perf_counter() - t0})
        progress(f"verification: {'passed' if verification.ok else 'FAILED'}")
    return doc


def run_harness_job(job: HarnessJob, *, check_robot: bool = True,
                    progress=quiet, planned=None) -> PlanDocument:
    """The wire-harness job (thesis 7.3) as a plan document: both phases, insertion, tensioning
    (:func:`dloplan.harness.run_harness`), and the robot program in the job's cell.

    One knot per shape of the whole job; the harness numbers in the ``harness`` section, the
    forces of each phase in ``forces``, the board's pegs and fixtures as obstacles.
    ``planned`` (optional) is called with the document before its robot program is made, not
    provisionally (the command line starts drawing all its figures then: no placement repair
    moves a harness job on its board). With ``check_robot`` every phase's held clips are
    checked against the cell's grippers as they become known (:func:`check_held_clips`: the
    start, the fixtures' approach points and slots before planning, phase 1's end before it is
    planned, the tensioned poses once the tensioning found its offset).

    Raises
    ------
    ValueError
        For clips held closer than the grippers can be, naming the phase and the job's fields.
    """
    from ..harness import harness_summary, run_harness

    progress(f"harness job: {job.cable.name or 'cable'}, board checked")
    sides = held_sides_error(job) if check_robot else None
    if sides is not None:
        raise ValueError(sides)
    held = partial(check_held_clips, job.robot, job.cable) if check_robot else None
    result = run_harness(job.cable, job.start, job.board, job.settings, check_held=held)
    progress(result.message)
    doc = PlanDocument(
        cable=job.cable, shapes=result.shapes, grippers=result.grippers,
        trajectory=result.trajectory, warnings=tuple(result.warnings), source=job.source,
        obstacles=tuple(result.board.contacts()), forces=dict(result.forces),
        harness=harness_summary(result), cycle=cycle_to_dict(result.cycle),
        timings=dict(result.timings))
    if planned is not None:
        planned(doc)
    if not check_robot:
        return doc
    t0 = time.perf_counter()
    doc = with_program(doc, plan_program(job.robot, result.grippers, result.trajectory,
                                         progress))
    return replace(doc, timings={**doc.timings, "robot": time.perf_counter() - t0})


def simulate_plan(doc: PlanDocument, *, damping: str = "relative", torsion: bool = False,
                  youngs_modulus_cap: float | None = None):
    """Run a plan's timed trajectory through the dynamic simulator (thesis 5.1).

    The clips follow the trajectory at its real speed from the stabilized start; the simulated
    shape at each knot time is compared with the planned stabilized shape. Returns the replay
    (:func:`dloplan.verify.replay.replay`) and the per-shape deviations
    (:func:`dloplan.vision.compare_shapes`, model against model: the simulated cable's length
    is a result the replay judges, not a registration to refuse, so it is compared whatever
    its stretch).

    Raises
    ------
    ValueError
        For a plan without a timed trajectory, and for a wire-harness plan: its cable is
        replayed phase by phase on the held section with the board's contacts and fixtures
        (``dloplan verify``, :func:`dloplan.pipeline.harness.verify_harness_plan`); this
        replay of the whole cable without them reported the stubs beyond the fixtures 8 cm
        inside the table of a plan that ``verify`` passes.
    """
    from ..verify.replay import replay
    from ..vision.compare import compare_shapes

    if doc.trajectory is None:
        raise ValueError("plan: no timed trajectory to simulate (plan it with gripper poses)")
    if doc.harness is not None:
        raise ValueError("plan.harness: a wire-harness plan, expected a plan of a scenario: "
                         "its replay is phase by phase on the held cable with the board's "
                         "contacts and fixtures, dloplan verify (docs/harness.md)")
    settled = settled_shapes(doc)
    run = replay(doc.cable, settled, (doc.trajectory.times, doc.clip_poses()),
                 law=doc.trajectory.law, damping=damping, torsion=torsion,
                 youngs_modulus_cap=youngs_modulus_cap, obstacles=doc.obstacles)
    simulated = run.simulation.at(run.knot_times)
    comparison = compare_shapes(settled, list(simulated), end_order="keep",
                                length_tolerance=None)
    return run, comparison

