"""The repair loop: a plan that fails its checks is changed until it passes, or refused.

:func:`repair_plan` sorts the failures of a verified plan (:func:`~.diagnose`) and
handles their kinds in the order of :data:`~.failures.KINDS`. For each kind the
repairs below are tried in this order; each candidate is checked at once by the check that
failed (on the part of the plan it changed), and the first that passes is kept:

``snap`` (the first failing segment s, shape s -> s + 1)
    1. follow the stable branch from shape s along the planned clip poses and take its
       equilibria as the remaining shapes (:func:`~.routes.follow_branch`; the last
       within T_cf of the target);
    2. re-route the clips of segment s: rotate first, translate first, rotate last
       (:func:`~.routes.routes`), the waypoints' equilibria inserted as shapes;
    3. plan again with twice the intermediate shapes.
    None passes: refused. When s is the last segment: "the target is reached only through a
    snap-through", with the segment.
``twist`` (the torsion model's twist above 15 deg, or a frame turning more than 45 deg
between shapes)
    1. the other gripper methods: rigid rotation, minimal rotation, auxiliary vector (thesis
       Table 4.3), on the same shapes;
    2. the clips rolled about their u-axes against the twist
       (:func:`~.frames.untwisted`; the roll on the last clip, shared, on the
       first), on the frames of the plan's method, then of the rigid rotation;
    3. (none passing) intermediate rotations: the equilibria at clip poses interpolated on the
       flipping segment inserted as shapes.
    Of the frame sets that pass, the one whose program targets the arms reach most often by
    IK at the targets (:func:`~.placement.targets_reached`) is kept; the others
    are the reach repair's frame sets.
``replay`` (the replay at real speed strays from the planned shapes)
    the motion slowed down in time by 1/2, then 1/4, then 1/8 (speeds times the factor,
    accelerations times its square, jerks times its cube: the same path, a time dilation;
    :func:`~.rebuild.slowed`), the whole program (the RAPID module has one
    speeddata per move, but the replay judges the settled knots, where a slower approach of
    every knot is what helps). A deviation on a segment that also has a snap failure waits for
    the snap repair.
``reach`` (a pose out of an arm's reach, or another failing check of the robot program)
    the job placed on the table (:class:`~.placement.TableMove`): for each turn
    about the vertical of :data:`~.placement.YAWS` (smallest first) and each set
    of gripper frames -- the plan's, the plan's with the grasps rolled for that place so that
    the wrists stay above, apart and towards the robot, per clip or as a twist-free pair
    (:func:`~.frames.grasp_rolled`), then the other gripper methods' (after a
    twist repair: its other passing frame sets) and theirs rolled, those that do not twist the
    cable -- the robot program is made and
    checked where the reachability check (approach and retreat included) passes: first with
    the job turned only, then (the plan's frames, rolled or not) shifted to the nearest such
    place within +-20 cm
    (:func:`~.placement.placements`); the first that passes is kept.
    None works: refused with everything tried. A placement whose shapes collide with the
    obstacles (fixed in the world) is not kept. On a described cell the cell's own placement
    search moves the job instead (:meth:`_Session.fix_cell_reach`).

After each round every check the plan was verified with runs again on the whole plan; the loop
ends when that passes, on a refusal, or when the :class:`Budget` is spent. Repairs never move the
start (the first shape is the planned one) and never the target beyond T_cf (thesis 5.3); a
placement moves the whole job, recorded as its :class:`~.placement.TableMove`.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from ...robot.cell import RobotCell
from ...robot.path import CHECKS
from ...robot.plugins import robot_program
from ...robot.urdf_cell import verify_on_cell
from ...sim.statics import interpolate_clips
from ...verify import check_snap_through
from ..stages import (
    completed_program,
    program_reachability,
    quiet,
    run_job,
    verify_plan,
    with_program,
    with_verification,
)
from .candidates import FrameSet, Place
from .failures import (
    KINDS,
    diagnose,
    frame_steps,
    program_failures,
    score,
    summary,
    twist_failures,
    unreachable_shapes,
)
from .frames import (
    SHARES,
    RolledTwists,
    grasp_rolled,
    grasp_scores,
    same_frames,
    untwisted,
)
from .placement import (
    SEARCHES,
    YAWS,
    TableMove,
    moved_document,
    moved_job,
    obstacle_collisions,
    placements,
    targets_reached,
)
from .rebuild import (
    slowed,
    timed_with_robot,
    with_grippers,
    with_motion,
    with_path,
    with_robot,
)
from .routes import MAX_TURN, equilibria_along, follow_branch, route_segment, routes

GRIPPER_METHODS = ("rigid", "minimal", "auxiliary")
"""Gripper methods tried by the twist and reach repairs, in this order."""

SPEED_FACTORS = (0.5, 0.25, 0.125)
"""Time dilations of the motion tried by the replay repair (speeds times the factor)."""

HERE = ((0.0, 0.05, "nearest"),)
"""The placement "search" of the job as it is (turned only): the reachability pre-check and
check at its place, before its robot program is made."""


@dataclass(frozen=True)
class Budget:
    """How much the repair loop may spend.

    Attributes
    ----------
    attempts : int
        Candidate plans checked, over all kinds.
    seconds : float
        Wall time [s] after which no new candidate is started.
    rounds : int
        Full re-verifications of the repaired plan.
    """

    attempts: int = 40
    seconds: float = 1800.0
    rounds: int = 3

    def __post_init__(self) -> None:
        for name in ("attempts", "rounds"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f"budget.{name}: got {value!r}, expected an integer >= 1")
        if not (math.isfinite(self.seconds) and self.seconds > 0):
            raise ValueError(f"budget.seconds: got {self.seconds!r}, expected a time > 0 [s]")


@dataclass(frozen=True)
class Repair:
    """One repair that was kept.

    Attributes
    ----------
    kind : str
        The failure kind it addresses (:data:`~.failures.KINDS`).
    failed : str
        What failed.
    change : str
        What was changed.
    before, after : str
        The check that failed, before and after the change.
    seconds : float
        Wall time spent on this kind, the rejected candidates included [s].
    """

    kind: str
    failed: str
    change: str
    before: str
    after: str
    seconds: float

    def line(self) -> str:
        """One line for the console and the report."""
        return f"repair ({self.kind}): {self.before} -> {self.change}; now {self.after}"

    def to_dict(self) -> dict:
        """JSON-ready fields."""
        return asdict(self)


CONSENT = "allow it with `repair: {placement: true}` in the job file or --allow-placement"
"""How a proposed placement is allowed (:class:`~dloplan.pipeline.job.RepairSettings`)."""


@dataclass(frozen=True, eq=False)
class Proposal:
    """A reach repair that changes the task, proposed instead of made: the job moved or turned
    on the table (:class:`~.placement.TableMove`) where the job does not allow it
    (:class:`~dloplan.pipeline.job.RepairSettings`).

    Attributes
    ----------
    failed : str
        What failed.
    change : str
        The move (and the gripper frames) that makes the robot program pass.
    after : str
        The robot program's verdict with the move.
    move : TableMove
        The placement proposed (the one the repair makes when the job allows it).
    """

    failed: str
    change: str
    after: str
    move: TableMove

    def line(self) -> str:
        """One line for the console, the warnings and the report."""
        return (f"placement proposed, not made: {self.change} (then {self.after}); the job "
                f"is moved only with consent: {CONSENT}")


@dataclass(frozen=True, eq=False)
class RepairResult:
    """Outcome of :func:`repair_plan`.

    Attributes
    ----------
    job : Job
        The job of the final plan (moved by ``move`` when a placement was found).
    document : PlanDocument
        The repaired plan with its verification section when ``ok``; otherwise the last plan
        that was fully verified (for inspection: no robot program should be written from it).
    verification : Verification
        The full verification of ``document``.
    repairs : tuple of Repair
        The repairs kept, in order.
    ok : bool
        The document passes every check it was verified with.
    refusal : str or None
        Why the plan is refused (no repair works, or the budget is spent).
    move : TableMove
        Placement of the job on the table (turn and translation; none when not moved).
    failures_before : tuple of Failure
        What failed before the repair.
    attempts : int
        Candidates checked.
    seconds : float
        Wall time of the repair [s].
    proposal : Proposal or None
        The placement the robot needs where the job does not allow it to be moved (then
        ``ok`` is False, ``refusal`` None and ``move`` no move).
    parts : dict
        Wall time [s] of ``seconds`` spent on no repair kind: ``"verified again"`` (each
        round's repaired plan verified with every check) and ``"program completed"`` (the
        kept program's passing round trips enumerated at the end,
        :func:`~dloplan.pipeline.stages.completed_program`).
    """

    job: object
    document: object
    verification: object
    repairs: tuple[Repair, ...]
    ok: bool
    refusal: str | None
    move: TableMove
    failures_before: tuple
    attempts: int
    seconds: float
    proposal: Proposal | None = None
    parts: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Checks:
    """Which checks a verification ran, so that the repaired plan gets the same ones."""

    snap: bool
    replay: bool
    robot: bool
    tolerance: float = 0.01
    tensile_limit: float | None = None

    @classmethod
    def of(cls, verification) -> Checks:
        run = verification.replay
        return cls(verification.snap is not None, run is not None,
                   any(r.reachable_left is not None for r in verification.rows),
                   0.01 if run is None else run.tolerance,
                   None if run is None else run.tensile_limit)

    def verify(self, doc, reuse=None, **only):
        """:func:`~dloplan.pipeline.stages.verify_plan` with these checks (``only`` turns some
        off; ``reuse``: its physics checks of the plan before a rigid move)."""
        flags = {"snap": self.snap, "replay": self.replay, "robot": self.robot}
        flags.update({k: v and flags[k] for k, v in only.items()})
        return verify_plan(doc, tolerance=self.tolerance, tensile_limit=self.tensile_limit,
                           reuse=reuse, **flags)


class Refused(Exception):
    """A failure no repair of its kind can fix (its message says why)."""


def attempts(tried: list) -> str:
    """The attempts a refusal names, in order, each once with how often it was made: the
    placement search repeats the same miss for every frame set and turn. An entry that is not
    a string stands for the entries its ``entries()`` gives (:class:`_Unplaced`)."""
    tried = [entry for item in tried
             for entry in ([item] if isinstance(item, str) else item.entries())]
    counts = Counter(tried)
    return " | ".join(t if counts[t] == 1 else f"{t} (x{counts[t]})" for t in counts)


@dataclass
class _State:
    """The plan being repaired. ``owes_program``: its robot program is still to be made (the
    snap repair's document when the reach repair follows in the same round, which makes the
    programs of its placements and drops the plan's: :meth:`_Session.program_made` makes it
    where it is needed)."""

    job: object
    doc: object
    move: TableMove = field(default_factory=TableMove)
    owes_program: bool = False


class _Session:
    """The running repair: the current plan, the checks, the budget and the records."""

    def __init__(self, job, doc, checks: Checks, budget: Budget, progress):
        self.state = _State(job, doc)
        self.asked = job.grippers.method  # the job file's gripper method (by_method)
        self.checks, self.budget, self.progress = checks, budget, progress
        self.start = time.perf_counter()
        self.attempts = 0
        self.repairs: list[Repair] = []
        self.proposal: Proposal | None = None
        self.untwisted: list = []  # (job, document) of every frame set the twist repair passed
        self.kinds: set[str] = set()  # the kinds of failure the current round repairs

    # -- budget and records -----------------------------------------------------------------
    def spent(self) -> bool:
        return (self.attempts >= self.budget.attempts
                or time.perf_counter() - self.start >= self.budget.seconds)

    def attempt(self) -> bool:
        """Count a candidate; False when the budget does not allow it."""
        if self.spent():
            return False
        self.attempts += 1
        return True

    def keep(self, kind, failures, change, after, state, since) -> None:
        repair = Repair(kind, "; ".join(f.message for f in failures), change,
                        summary(failures), after, time.perf_counter() - since)
        self.state = state
        self.repairs.append(repair)
        self.progress(repair.line())

    def program_made(self) -> None:
        """Make the robot program the current plan owes (:class:`_State`): every repair but
        the reach repair, and the round's verification, read the plan's program."""
        if self.state.owes_program:
            self.state = replace(self.state, owes_program=False, doc=with_robot(
                self.state.job, self.state.doc, always=True))

    def keep_placed(self, failures, change, after, state, move, since) -> None:
        """Keep a reach repair that places the job by ``move``: at once when it leaves the job
        where it is or the job allows it to be moved (``job.repair.placement``), else only as
        a :class:`Proposal` (the plan stays as it was)."""
        if move.is_identity or self.state.job.repair.placement:
            self.keep("reach", failures, change, after, state, since)
            return
        self.proposal = Proposal("; ".join(f.message for f in failures), change, after, move)
        self.progress(self.proposal.line())

    # -- snap ------------------------------------------------------------------------------
    def snap_check(self, doc, first: int):
        """Snap-through along the plan from shape ``first`` on: the events."""
        path = doc.stabilized[first:]
        return check_snap_through(doc.cable, path, doc.clip_poses()[first:]).events

    def fix_snap(self, failures) -> None:
        job, doc = self.state.job, self.state.doc
        since = time.perf_counter()
        segments = [f.segment for f in failures if f.segment is not None]
        if not segments:
            raise Refused(f"{failures[0].message}: the start is given, it cannot be repaired")
        s = min(segments)
        shapes, poses = doc.stabilized, doc.clip_poses()
        last = len(shapes) - 1
        tried = []
        # the reach repair follows: it makes its placements' programs and drops the plan's
        owes = "reach" in self.kinds and isinstance(job.robot, RobotCell) and (
            doc.robot is not None or doc.program is not None)
        program = False if owes else None
        if self.attempt():
            branch = follow_branch(job.cable, shapes[s], poses[s:], shapes[-1],
                                   job.target_threshold)
            tried.append(f"stable branch: {branch.message}")
            if branch.success:
                new = with_path(job, doc, np.concatenate([shapes[:s + 1], branch.shapes]),
                                program=program)
                events = self.snap_check(new, s)
                if not events:
                    self.keep("snap", failures, f"shapes {s + 1}..{last} follow the stable "
                              f"branch from shape {s} (target within "
                              f"{1e3 * branch.end_error:.1f} mm)", "no snap-through from "
                              f"shape {s} on", _State(job, new, self.state.move, owes), since)
                    return
                tried[-1] += f"; then {events[0].message}"
        end_tolerance = job.target_threshold if s + 1 == last else math.inf
        for name, waypoints in routes(poses[s], poses[s + 1], job.cable.length / 4):
            if not self.attempt():
                break
            route = route_segment(job.cable, shapes[s], poses[s], waypoints, poses[s + 1],
                                  shapes[s + 1], end_tolerance, name)
            tried.append(route.message)
            if not route.success:
                continue
            path = np.concatenate([shapes[:s + 1], route.shapes, shapes[s + 2:]])
            new = with_path(job, doc, path, program=program)
            events = self.snap_check(new, s)
            if not events:
                self.keep("snap", failures, f"segment {s} re-routed ({name}): "
                          f"{len(waypoints)} shape(s) inserted", "no snap-through from shape "
                          f"{s} on", _State(job, new, self.state.move, owes), since)
                return
            tried[-1] += f"; then {events[0].message}"
        if self.attempt():
            n = 2 * doc.n_shapes
            finer = replace(job, planner=replace(job.planner, n_shapes=n))
            new = run_job(finer)
            events = self.snap_check(new, 0)
            tried.append(f"{n} intermediate shapes: "
                         + (events[0].message if events else "no snap-through"))
            if not events:  # the state's job is already placed: nothing to move
                self.keep("snap", failures, f"planned again with {n} intermediate shapes",
                          "no snap-through", _State(finer, new, self.state.move), since)
                return
        where = ("the target is reached only through a snap-through" if s + 1 == last else
                 "no stable route found")
        raise Refused(f"segment {s} (shape {s} -> {s + 1}): {where}; tried: "
                      + attempts(tried))

    # -- twist -----------------------------------------------------------------------------
    def fix_twist(self, failures) -> None:
        self.program_made()
        job, doc = self.state.job, self.state.doc
        since = time.perf_counter()
        tried = []
        passing = []  # (job, document, change) of every frame set that does not twist
        for method in GRIPPER_METHODS:
            if method == doc.grippers.method or not self.attempt():
                continue
            try:
                other, new = by_method(job, doc, method, self.asked)
            except ValueError as exc:  # e.g. the auxiliary vector along a u-axis
                tried.append(f"{method}: {exc}")
                continue
            left = twist_failures(new)
            tried.append(f"{method}: {summary(left)}")
            if not left:
                passing.append((other, new, f"gripper frames by the {method} method "
                                f"(was {doc.grippers.method})"))
        for method in dict.fromkeys((doc.grippers.method, "rigid")):
            other, base = by_method(job, doc, method, self.asked)
            base = base.grippers
            for share in SHARES:
                if not self.attempt():
                    break
                grippers, twist = untwisted(job.cable, doc.shapes, base, share=share)
                new = with_grippers(other, doc, grippers, program=False)
                left = twist_failures(new)
                which = grippers.message.split("; ")[-1].split(" rolled")[0]
                tried.append(f"{method}, {which} rolled: {summary(left)}")
                if not left:
                    passing.append((other, new, f"gripper frames by the {method} method, "
                                    f"{which} rolled about the u-axis against the twist "
                                    f"(largest {np.degrees(np.abs(twist).max()):.1f} deg)"))
        if not passing and self.attempt():
            new = self.intermediate_rotations(job, doc)
            left = twist_failures(new)
            tried.append(f"intermediate rotations: {summary(left)}")
            if not left:
                passing.append((job, new, f"{new.n_shapes - doc.n_shapes} intermediate "
                                "rotation(s) inserted"))
        if not passing:
            raise Refused(f"{failures[0].message}; tried: " + attempts(tried))
        other, new, change = self.reachable_first(passing)
        self.untwisted = [(j, d) for j, d, _ in passing]
        if doc.robot is not None or doc.program is not None:
            new = with_robot(other, new, always=True)
        self.keep("twist", failures, change, new.twist.message,
                  _State(other, new, self.state.move), since)

    def reachable_first(self, passing):
        """The frame set of ``passing`` whose robot program targets the arms reach most often
        by IK at the targets alone (:func:`~.placement.targets_reached`; the
        first of the best), or the first when the plan has no robot program."""
        if len(passing) == 1 or not self.checks.robot and self.state.doc.program is None:
            return passing[0]
        counts = [targets_reached(doc.grippers, job.robot) for job, doc, _ in passing]
        return passing[int(np.argmax(counts))]

    def intermediate_rotations(self, job, doc):
        """Equilibria at clip poses interpolated on each segment whose frames turn more than
        :data:`~.routes.MAX_TURN`, inserted as shapes."""
        steps, poses, shapes = frame_steps(doc.grippers), doc.clip_poses(), doc.stabilized
        path = [shapes[0]]
        for s, step in enumerate(steps):
            parts = math.ceil(step / MAX_TURN)
            if parts > 1:
                between = interpolate_clips(poses[s], poses[s + 1], np.arange(1, parts) / parts)
                path += list(equilibria_along(job.cable, shapes[s], [poses[s], *between])[0])
            path.append(shapes[s + 1])
        return with_path(job, doc, np.stack(path))

    # -- replay ----------------------------------------------------------------------------
    def fix_replay(self, failures) -> None:
        self.program_made()
        doc = self.state.doc
        since = time.perf_counter()
        speed = self.state.job.motion.tcp_speed
        tried = []
        for factor in SPEED_FACTORS:
            if not self.attempt():
                break
            slower = slowed(self.state.job, factor)
            new = timed_with_robot(slower, doc)
            run = self.checks.verify(new, snap=False, robot=False).replay
            tried.append(f"x{factor:g} ({1e3 * factor * speed:.0f} mm/s): {run.message}")
            if run.ok:
                self.keep("replay", failures, f"motion slowed by {factor:g} (TCP speed "
                          f"{1e3 * speed:.0f} -> {1e3 * factor * speed:.0f} mm/s, "
                          f"accelerations x{factor ** 2:g}, jerks x{factor ** 3:g})",
                          run.message, replace(self.state, job=slower, doc=new), since)
                return
        raise Refused(f"{failures[0].message}; tried: " + attempts(tried))

    # -- reach -----------------------------------------------------------------------------
    def fix_reach(self, failures) -> None:
        job, doc = self.state.job, self.state.doc
        since = time.perf_counter()
        if doc.program is not None and not self.program_verdict(doc.program, len(doc.shapes)):
            # ``failures`` are the round's: a repair before this one in the round (the twist
            # repair's frames) made a program that passes, so there is nothing to place
            return
        if not isinstance(job.robot, RobotCell):
            self.fix_cell_reach(failures)
            return
        tried = []
        best = []  # (the attempt, what it failed): attempts that reach every pose
        pivot = doc.grippers.positions.reshape(-1, 3).mean(axis=0) * [1.0, 1.0, 0.0]
        turned = _Made(self.turned_frames(job, doc, pivot, tried))
        seen = set()
        for searches in (HERE, SEARCHES):  # first every turn as it is, then shifted too
            for candidate in turned:
                # a set that twists is not tried (one out of the arms' reach spheres where the
                # job lies is judged here only when it matters: turned_frames)
                if self.spent() and not candidate.twist_failures():
                    raise Refused("repair budget spent placing the job; tried: "
                                  + attempts(tried))
                if searches is SEARCHES and candidate.job.grippers.method != \
                        job.grippers.method:
                    continue  # the searches shift the plan's own frames (rolled or not) only
                if candidate.put_off and (searches is HERE or candidate.twist_failures()):
                    continue  # not placeable where it lies: its entry of `tried` is _Unplaced
                for found in placements(candidate.frames, yaws=(0.0,), cell=candidate.job.robot,
                                        searches=searches):
                    key = (id(candidate), *np.round(found.move.offset, 6))
                    if not found.success or key in seen or (candidate.plan and
                                                            found.move.is_identity):
                        if not found.success:
                            tried.append(_missed(candidate.frames, found))
                            if found.failed != "reach":
                                best.append((tried[-1], found.failed))
                        continue  # (the plan as it is failed already)
                    seen.add(key)
                    if not self.attempt():
                        raise Refused("repair budget spent placing the job; tried: "
                                      + attempts(tried))
                    move = candidate.place.turn.then(found.move)
                    new = candidate.document  # made now: most frame sets are never placed
                    placed_job = moved_job(candidate.job, found.move)
                    placed = moved_document(placed_job, new, found.move, program=False)
                    collides = obstacle_collisions(placed)
                    if collides is None:
                        program = robot_program(placed.grippers, placed.trajectory,
                                                placed_job.robot, verdict_only=True)
                        left = self.program_verdict(program, len(placed.shapes))
                        if not left:
                            placed = with_program(placed, program)
                        failed = failed_check(program.failures, left)
                    else:
                        left, failed = [collides], "the obstacles"
                    tried.append(f"{_frames_name(candidate.frames)}, job {move.describe()}: "
                                 + (left[0] if left else "passes"))
                    if left and failed != "reach":
                        best.append((tried[-1], failed))
                    if left:
                        self.progress(f"placement rejected: {tried[-1]}")
                        continue
                    change = f"job {move.describe()}" + (
                        "" if candidate.plan else f", gripper frames: {new.grippers.message}")
                    self.keep_placed(failures, change, placed.program.message,
                                     _State(placed_job, placed, self.state.move.then(move)),
                                     move, since)
                    return
        raise Refused(f"{no_placement(*best[0] if best else (None, 'reach'))}; tried: "
                      + attempts(tried))

    def program_verdict(self, program, n_shapes: int) -> list[str]:
        """The reach failures a placement's robot program leaves, as the repair prints them:
        :func:`~.failures.reach_failures` of the placed plan verified for its program (the
        failing program rows other than reach, then the shapes an arm cannot reach when the
        plan's checks include the robot's), without the physics checks, which it does not
        read. ``program`` may be a verdict (``verdict_only``,
        :func:`~dloplan.robot.yumi_program.yumi_program`): its first failure other than reach
        is the complete program's."""
        rows = program_reachability(program, n_shapes) if self.checks.robot else ()
        return [f.message for f in program_failures(program) + unreachable_shapes(
            (k, row["reachable_left"], row["reachable_right"]) for k, row in enumerate(rows))]

    def fix_cell_reach(self, failures) -> None:
        """A described cell: the job shifted to where the cell's own placement search
        (:func:`dloplan.robot.placement.search_cell_placement`, along the timed trajectory)
        puts it, then its program checked there."""
        job, doc = self.state.job, self.state.doc
        since = time.perf_counter()
        if not self.attempt():
            raise Refused("repair budget spent before placing the job on the cell")
        found = verify_on_cell(job.robot, doc.trajectory, place=True)
        move = TableMove(found.offset)
        where = f"{job.robot.name}'s placement search, job {move.describe()}"
        if not found.verdict.ok or move.is_identity:
            failed = failed_check(found.verdict.rows) if not found.verdict.ok else "reach"
            raise Refused(f"{no_placement(None, failed)}; {where}: {found.verdict.message}")
        placed_job = moved_job(job, move)
        placed = moved_document(placed_job, doc, move, program=False)
        collides = obstacle_collisions(placed)
        if collides is not None:
            raise Refused(f"{where}: {collides}")
        placed = with_robot(placed_job, placed, always=True)
        rows = self.checks.verify(placed, snap=False, replay=False)
        left = [f.message for f in diagnose(placed, rows) if f.kind == "reach"]
        if left:
            raise Refused(f"{where}: {left[0]}")
        self.keep_placed(failures, f"job {move.describe()} (the {job.robot.name} cell's "
                         "placement search)", placed.program.message,
                         _State(placed_job, placed, self.state.move.then(move)), move, since)

    def turned_frames(self, job, doc, pivot, tried):
        """A :class:`~.candidates.FrameSet` for every turn of :data:`YAWS` about the vertical
        through ``pivot`` and every set of gripper frames, made on demand: the plan's, its grasps
        rolled for the turned place (:func:`~.frames.grasp_rolled`), then the other gripper
        methods' (and theirs rolled) -- those that do not twist the cable and differ from the
        earlier ones.

        What a frame set costs is paid only for those tried: a rolled set is compared with the
        earlier ones before its twist is solved, and its document (the trajectory timed again,
        the clip wrenches) is made only when it is placed (:mod:`.candidates`); the rolled sets
        of one place share their clip wrenches (the same shapes), and the torsion model's solve
        of a set rolled by the same rolls is shared by every turn
        (:class:`~.frames.RolledTwists`). A set whose targets are out of the arms' reach
        spheres where the job lies (:func:`~.placement.within_spheres`: the search there finds
        nothing without IK) is yielded with its twist not judged (claimed, not solved): it is
        judged when the searches that shift the job try it, or when a refusal lists what was
        tried (its entry of ``tried`` is an :class:`_Unplaced`, in the place its twist failure
        or its search's miss had)."""
        untwisted = [(j, d) for j, d in self.untwisted if np.array_equal(d.shapes, doc.shapes)]
        if untwisted:  # the twist repair's other frame sets (the other methods twist)
            bases = _Made([(job, doc), *untwisted])
        else:
            others = [m for m in GRIPPER_METHODS if m != doc.grippers.method]
            bases = _Made(self.method_frames(job, doc, others, tried, self.asked))
        twists = RolledTwists(job.cable)  # the same at every turn
        for yaw in YAWS:
            turn = TableMove(yaw=yaw, pivot=pivot)
            kept = []
            for base, (other, new) in enumerate(bases):
                place = Place(turn, other, new)
                for frames, rolls in _grasps(place.grippers, place.job.robot):
                    if any(same_frames(frames, made) for made in kept):
                        continue  # e.g. rigid = minimal rotation for a planar bend
                    kept.append(frames)
                    candidate = FrameSet(place, frames, rolls, base, twists,
                                         plan=new is doc and not yaw and rolls is None)
                    if candidate.put_off:
                        candidate.put_off_twist()
                        tried.append(_Unplaced(candidate))
                        yield candidate
                        continue
                    left = candidate.twist_failures()
                    if left and not candidate.plan:
                        tried.append(_twisted(frames, left))
                    else:
                        yield candidate

    @staticmethod
    def method_frames(job, doc, methods, tried, asked):
        """The plan, then the plan with the frames of each of ``methods`` (no program; ``asked``
        the job file's method, :func:`by_method`)."""
        yield job, doc
        for method in methods:
            try:
                yield by_method(job, doc, method, asked)
            except ValueError as exc:  # e.g. the auxiliary vector along a u-axis
                tried.append(f"{method}: {exc}")


def by_method(job, doc, method: str, asked: str):
    """``job`` with the gripper ``method`` and ``doc`` with its frames (no program).

    ``asked`` is the method of the job file (``"auto"`` included): when the repair takes
    another, the frames' message says so instead of calling ``method`` the one asked for.

    Raises
    ------
    ValueError
        The method cannot make the frames (e.g. the auxiliary vector along a u-axis).
    """
    other = replace(job, grippers=replace(job.grippers, method=method))
    new = with_motion(other, doc, program=False)
    if method != asked:
        grippers = new.grippers
        message = grippers.message.replace(
            f"method {method!r} as asked",
            f"method {method!r} chosen by the repair (the job asked for {asked!r})", 1)
        new = replace(new, grippers=replace(grippers, message=message))
    return other, new


def _twisted(frames, left) -> str:
    """The entry of the reach repair's ``tried`` for a frame set that twists the cable (its
    twist failures ``left``): it is not tried."""
    return f"{frames.message}: {summary(left)}"


def failed_check(rows, left=()) -> str:
    """The first robot check a placement fails, in the programs' order of checks
    (:data:`dloplan.robot.path.CHECKS`): ``"reach"`` when a pose is not reached (a ``reach``
    row among the failing ``rows``, or a shape ``left`` as unreachable by
    :meth:`_Session.program_verdict`), else the first failing row's check; ``"reach"`` when no
    row fails."""
    checks = {row.check for row in rows if not row.ok}
    if "reach" in checks or any("not reachable by the" in line for line in left):
        return "reach"
    return next((name for name in CHECKS if name in checks), next(iter(sorted(checks)), "reach"))


def no_placement(best: str | None, failed: str) -> str:
    """The lead of the reach repair's refusal: what the best placements failed on.

    Parameters
    ----------
    best : str or None
        The best attempt as the refusal lists it (the first, in the repair's order, whose
        poses are all reached), or None (a cell's placement search: its own line follows).
    failed : str
        What it failed: a robot check's name, "the obstacles", or "reach" (kept as it was:
        no placement makes every pose reachable).
    """
    if failed == "reach":
        return "no placement of the job on the table makes every pose reachable"
    lead = ("no placement of the job on the table makes every robot check pass: the best fails "
            + failed)
    return lead if best is None else f"{lead} ({best})"


def _missed(frames, found) -> str:
    """The entry of the reach repair's ``tried`` for a placement search that found nothing
    (``found``, a :class:`~.placement.PlacementRepair`) for ``frames``."""
    return f"{_frames_name(frames)}: {found.message}"


class _Unplaced:
    """The entries of the reach repair's ``tried`` for a frame set that the search where the
    job lies cannot place (out of the arms' reach spheres, :func:`~.placement.within_spheres`),
    made when a refusal lists them: its twist failures when it twists (it is not tried), else
    that search's miss -- what judging its twist, then trying it there, would have added in
    this place."""

    def __init__(self, candidate: FrameSet) -> None:
        self.candidate = candidate

    def entries(self) -> list[str]:
        """The entries (strings) this stands for."""
        candidate = self.candidate
        left = candidate.twist_failures()
        if left:
            return [_twisted(candidate.frames, left)]
        return [_missed(candidate.frames, found)
                for found in placements(candidate.frames, yaws=(0.0,), cell=candidate.job.robot,
                                        searches=HERE) if not found.success]


def _frames_name(grippers) -> str:
    """"<method> frames", "rolled" when their grasps were rolled."""
    rolled = ", grasps rolled" if "grasps rolled" in grippers.message else ""
    return f"{grippers.method} frames{rolled}"


def _grasps(grippers, cell):
    """(frames, rolls) for ``grippers`` as they are (rolls None), then with their grasps rolled
    (:func:`~.frames.grasp_rolled`, per clip then paired, towards the robot then not) where a
    roll helps; made on demand, each table of scores once."""
    yield grippers, None
    scores = {}
    for paired in (False, True):
        for towards_robot in (True, False):
            if towards_robot not in scores:
                scores[towards_robot] = grasp_scores(grippers, cell, towards_robot=towards_robot)
            frames, rolls = grasp_rolled(grippers, cell, towards_robot=towards_robot,
                                         paired=paired, scores=scores[towards_robot])
            if rolls.any():
                yield frames, rolls


class _Made:
    """An iterable made once from a generator and replayed (the frame sets of the reach repair
    are made on demand at the first turn and tried again at every later one)."""

    def __init__(self, items):
        self.items, self.made = items, []

    def __iter__(self):
        yield from list(self.made)
        for item in self.items:
            self.made.append(item)
            yield item


FIXES = {"snap": _Session.fix_snap, "twist": _Session.fix_twist,
         "replay": _Session.fix_replay, "reach": _Session.fix_reach}


def _own(failures, kind):
    """The failures of ``kind``; a replay deviation on a segment that snaps waits for the snap
    repair (the replay follows the branch the snap leaves)."""
    mine = [f for f in failures if f.kind == kind]
    if kind == "replay":
        snapping = {f.segment for f in failures if f.kind == "snap"}
        mine = [f for f in mine if f.segment is None or f.segment not in snapping]
    return mine


def repair_plan(job, doc, verification, budget: Budget | None = None,
                progress=quiet, repaired=None) -> RepairResult:
    """Repair a plan that failed its checks (module docstring): keep the first plan that passes.

    Parameters
    ----------
    job : Job
        The job ``doc`` was planned from.
    doc : PlanDocument
        Its plan.
    verification : Verification
        :func:`dloplan.pipeline.stages.verify_plan` of ``doc``; the repaired plan is verified with
        the same checks (snap-through, replay, robot: those that were run).
    budget : Budget, optional
        Default :class:`Budget()`.
    progress : callable
        Called with a line of text per repair kept.
    repaired : callable, optional
        Called with each round's repaired document before it is verified again (the command
        line draws its figures meanwhile).

    Returns
    -------
    RepairResult
    """
    budget = budget if budget is not None else Budget()
    checks = Checks.of(verification)
    session = _Session(job, doc, checks, budget, progress)
    failures = diagnose(doc, verification)
    before = tuple(failures)
    verified = (job, doc, verification, TableMove())
    refusal = None
    again = 0.0  # [s] the repaired plans verified again
    for _ in range(budget.rounds):
        if not failures:
            break
        try:
            unknown = [f for f in failures if f.kind not in FIXES]
            if unknown:
                raise Refused(f"no repair for: {unknown[0].message}")
            session.kinds = {kind for kind in KINDS if _own(failures, kind)}
            for kind in KINDS:
                mine = _own(failures, kind)
                if mine:
                    FIXES[kind](session, mine)
        except Refused as exc:
            refusal = str(exc)
            break
        session.program_made()  # (a placement only proposed leaves the snap repair's plan)
        state = session.state
        changed = state.doc is not verified[1]  # not changed: a placement only proposed
        if changed and repaired is not None:
            repaired(state.doc)
        # a placement moves the plan rigidly: its physics checks are kept (pipeline.reuse)
        since = time.perf_counter()
        verification = checks.verify(state.doc, reuse=verified[1:3]) if changed else verified[2]
        again += time.perf_counter() - since
        new_failures = diagnose(state.doc, verification)
        if changed:
            progress(f"repaired plan verified: {summary(new_failures)}")
        if session.proposal is not None:  # the repairs made, the placement proposed
            verified = (state.job, state.doc, verification, state.move)
            failures = new_failures
            break
        if score(new_failures) >= score(failures) and new_failures:
            refusal = f"the repairs did not remove the failures ({summary(new_failures)})"
            verified = (state.job, state.doc, verification, state.move)
            failures = new_failures
            break
        verified = (state.job, state.doc, verification, state.move)
        failures = new_failures
        if session.spent():
            break
    if failures and refusal is None and session.proposal is None:
        refusal = (f"repair budget spent ({session.attempts} attempts, "
                   f"{time.perf_counter() - session.start:.0f} s): {summary(failures)}")
    final_job, final_doc, final_ver, move = verified
    # a kept placement's program has its passing round trips enumerated now: after the
    # repaired plan's figures were started (``repaired``) and it was verified
    since = time.perf_counter()
    final_doc = completed_program(final_doc)
    end = time.perf_counter()
    return RepairResult(final_job, with_verification(final_doc, final_ver), final_ver,
                        tuple(session.repairs), not failures, refusal, move, before,
                        session.attempts, end - session.start, session.proposal,
                        {"verified again": again, "program completed": end - since})

