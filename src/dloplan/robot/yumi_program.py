"""The YuMi's plug-in of the robot program: the exact TCP targets written to RAPID, their
verified joint solutions (arm-angle IK, confdata), and the checks run on exactly those targets.

:func:`yumi_program` turns a plan's clip poses (:class:`~dloplan.grippers.GripperPath`) and
its timing (:class:`~dloplan.trajectory.Trajectory`) into the one
:class:`~dloplan.robot.program.RobotProgram` for a :class:`~dloplan.robot.cell.RobotCell`,
whose ``targets`` are a :class:`YumiTargets` (what RAPID is given, :mod:`dloplan.io.rapid`):

1. **Arm assignment** once per plan from the geometry (:func:`~dloplan.robot.assignment.
   assign_arms`): the clip on the robot's left goes to the left arm.
2. **Targets**: per arm, an approach pose (``cell.approach`` back along the TCP z-axis), the
   TCP pose at every shape (``clip_to_work * tool.tcp_in_clip``, at the clip point, possibly
   turned by pi about TCP z for a symmetric gripper) and a retreat pose, in the work frame,
   rounded to what RAPID is given (1e-6 mm, quaternions [w, x, y, z] to 1e-9).
3. **Joint solutions**: per arm, candidate solutions with a constant arm angle (ABB axis 7)
   around the first target's free solution, each tracked along the path in sub-steps; the
   (left, right) pair ranked best on reach, smoothness, clearance and joint margin is kept
   (:mod:`dloplan.robot.solutions`).
   Every target is re-solved with the arm angle held at the value written as ``eax_a``;
   confdata from that solution.
4. **Checks on exactly those targets**, each as :class:`CheckRow` s:

   - ``assignment``: per shape, the y-separation of the two arms' clips (negative: crossed);
   - ``reach``: the IK reaches the written target (error of FK of the written solution);
   - ``round trip``: the written robtarget (pose, ``eax_a``, confdata) solved by the
     controller-semantics IK (:mod:`dloplan.robot.robtarget`) gives the verified joints
     (0.05 deg) among its solutions with that confdata (180 deg when none has it); where
     another solution shares the confdata (the 7-joint arm has up to 16 per pose and arm
     angle; confdata separates fewer), the MoveL into the target follows the path from the
     previous one, which the ``continuity`` replay checks ends on the verified joints;
   - ``joint limits``: distance of the nearest joint to its limit, at least the cell's
     ``reach.min_margin`` (5 deg by default: the model's uncertainty, flange and calibration,
     is larger than a fraction of a degree);
   - ``clearance``: smallest arm-arm capsule distance at the target and along the move into it;
   - ``continuity``: the controller's MoveL into the target, replayed: TCP linear, orientation
     slerp, arm angle linear between the written values, each sub-step's IK seeded from the
     previous one (:mod:`dloplan.robot.replay`). Ok when every sub-step converges, no joint
     moves more than ``reach.max_joint_step`` in one sub-step (one that does is replayed in
     finer steps: fast motion near a singularity passes, a jump does not), and the move ends
     on the target's own solution (so the controller with ``ConfL \\On`` reaches the
     programmed configuration);
   - ``joint speed``: the peak joint speed of that replay along the move's time law (the
     trajectory's jerk-limited law, :mod:`dloplan.robot.peaks`), as a fraction of the joint's
     speed limit (ABB's product specification of the IRB 14000).

The joint solutions are tried best ranked first (up to :data:`MAX_TRIES`), each judged on its
replayed motion (reach, continuity, clearance) before the controller's round trip and the time
law are computed for it: a pair passed over costs its replay only; when the side rule's
program fails on clearance or continuity the swapped assignment is tried the same way and
taken only when it passes every check.

A program over a joint speed limit is slowed (:func:`~dloplan.robot.program.slowed`,
shared with every cell): each such segment's speed scale of the time law
(:meth:`dloplan.trajectory.Trajectory.with_speed_scale`) brings it to 98 % of the limit, up to
:data:`~dloplan.robot.checks.SLOW_ROUNDS` times, re-timing the program (its targets, joints and
replayed motion do not depend on the timing, so they are not solved again); the program keeps
the trajectory it was verified with (``RobotProgram.trajectory``). The program is ``ok``
when every row is. Everything computed is kept (``RobotProgram.checks``, ``summary()``,
``to_dict()``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial

import numpy as np
from scipy.spatial.transform import Rotation

from .armangle import arm_angle
from .assignment import ArmAssignment, assign_arms
from .cell import RobotCell
from .checks import CheckRow
from .collision import arm_clearance
from .confdata import confdata
from .kinematics import forward, solve_from
from .path import HELD_TOLERANCE, TURN_Z
from .program import HeldArms, RobotProgram, slowed
from .replay import replay_moves
from .robtarget import ROUND_TRIP_TOLERANCE, RobtargetSolution, own_solution, solve_robtarget
from .solutions import ranked_solutions
from .yumi import ABB_AXIS_NUMBERS, ARMS

MIN_SPEED = 1e-4
"""[m/s] Smallest TCP speed written (an arm that does not move in a synchronized segment)."""

MIN_ANGULAR_SPEED = float(np.radians(0.1))
"""[rad/s] Smallest TCP angular speed written."""

END_TOLERANCE = 1e-3
"""[rad] A replayed MoveL ends on the target's solution when every joint is this close."""

CHECKS = ("assignment", "reach", "round trip", "joint limits", "clearance", "continuity",
          "joint speed")
"""The checks of a program, in the order of its rows."""

MAX_TRIES = 2
"""Joint solutions (best ranked first) replayed before the program settles for the first."""



@dataclass(frozen=True, eq=False)
class YumiTargets:
    """The YuMi's plug-in of a :class:`~dloplan.robot.program.RobotProgram`: its targets as
    RAPID is given them, their timing, and the replayed controller motion.

    Arrays are indexed ``[target, arm]`` with the arms in the order ``("left", "right")``; the
    M targets are the approach (when ``cell.approach > 0``), one per shape, and the retreat.

    Attributes
    ----------
    assignment : ArmAssignment
    grip_turned : tuple of bool
        Per arm: the TCP holds its clip turned by pi about TCP z.
    labels : tuple of str
        (M,) ``"approach"``, ``"shape k"``, ``"retreat"``.
    shapes : numpy.ndarray
        (M,) int: the shape each target belongs to.
    grasp, release : int
        Target indices where the grippers close (``g_GripIn``) and open (``g_GripOut``).
    positions : numpy.ndarray
        (M, 2, 3) TCP positions [m] in the work frame, exactly as written.
    quaternions : numpy.ndarray
        (M, 2, 4) TCP orientations [w, x, y, z] in the work frame, exactly as written.
    confdata : numpy.ndarray
        (M, 2, 4) int ``[cf1, cf4, cf6, cfx]`` of the verified joints.
    arm_angles : numpy.ndarray
        (M, 2) ``eax_a`` [deg] as written (ABB axis 7 of the verified joints).
    motion_joints : numpy.ndarray
        (N, 2, 7) joint values [rad] of the replayed controller motion (every sub-step, the
        first target's joints first).
    move_substeps : numpy.ndarray
        (M - 1,) int: the replayed sub-steps of each move in ``motion_joints`` (after its
        first row, the first target).
    times : numpy.ndarray or None
        (M,) time [s] each target is reached, from the approach target, on the motion's clock
        (the gripper actions' waits come on top: :mod:`dloplan.robot.actions`).
    durations : numpy.ndarray or None
        (M - 1,) planned duration [s] of each move.
    speeds : numpy.ndarray or None
        (M - 1, 2, 2) per move and arm: TCP speed [m/s] and angular speed [rad/s] written.
    motion_times : numpy.ndarray or None
        (N,) times [s] of ``motion_joints``.
    zones : numpy.ndarray or None
        (M,) fly-by zone radius [m] at each target (the trajectory's zones at the shapes; 0,
        a fine point, at the approach, the grasp, the release and the retreat).
    """

    assignment: ArmAssignment
    grip_turned: tuple[bool, bool]
    labels: tuple[str, ...]
    shapes: np.ndarray
    grasp: int
    release: int
    positions: np.ndarray
    quaternions: np.ndarray
    confdata: np.ndarray
    arm_angles: np.ndarray
    motion_joints: np.ndarray
    move_substeps: np.ndarray
    times: np.ndarray | None = None
    durations: np.ndarray | None = None
    speeds: np.ndarray | None = None
    motion_times: np.ndarray | None = None
    zones: np.ndarray | None = None

    CHECKS = CHECKS
    formats = ("rapid", "ros_joints")
    """The program formats written from it (:mod:`dloplan.app.writers`): RAPID for the YuMi's
    controller and the ROS 2 joint trajectories."""

    @property
    def move_segments(self) -> np.ndarray:
        """(M - 1,) int: the trajectory segment each move is (-1: the approach and the
        retreat, at the cell's approach speed, are not the trajectory's)."""
        outside = len(self.labels) - 1 - self.release
        return np.concatenate([np.full(self.grasp, -1), np.arange(self.release - self.grasp),
                               np.full(outside, -1)]).astype(np.intp)

    @staticmethod
    def axis_name(joint: int) -> str:
        """A joint (physical order) by its ABB axis number."""
        return f"ABB axis {ABB_AXIS_NUMBERS[joint]}"

    def knot_targets(self) -> np.ndarray:
        """(S + 2,) int: the target of each plan knot (shape): the targets between the
        approach and the retreat."""
        return np.arange(self.grasp, self.release + 1)

    @property
    def path_duration(self) -> float:
        """Planned time [s] from the grasp to the release target (the trajectory's
        duration)."""
        return float(self.times[self.release] - self.times[self.grasp])

    def move_timing(self, cell: RobotCell, trajectory) -> tuple:
        """The profiles, starts [s] and arrivals [s] of the moves
        (:class:`~dloplan.robot.motion.JointMotion`): between the shapes the moves of
        ``trajectory``'s law, the approach and the retreat by the jerk-limited rest-to-rest
        law at ``cell.approach_speed`` under the trajectory's limits."""
        law = trajectory.law
        profiles, starts, arrivals = list(law.profiles), law.starts, law.knot_times
        if cell.approach > 0:
            approach = approach_profile(cell, law)
            d = approach.duration
            profiles = [approach, *profiles, approach]
            starts = np.r_[0.0, starts + d, law.duration + d]
            arrivals = np.r_[0.0, arrivals + d, law.duration + 2 * d]
        return tuple(profiles), np.asarray(starts, float), np.asarray(arrivals, float)

    def timed(self, cell: RobotCell, trajectory) -> YumiTargets:
        """The same targets timed by ``trajectory``: move durations, written speeds and zones,
        the replay's sub-step times."""
        durations, speeds = _timing(trajectory, cell, self.assignment, cell.approach > 0)
        times = np.cumsum(np.r_[0.0, durations])
        motion_times = np.concatenate([times[:1]] + [
            times[m] - durations[m - 1] * (1.0 - np.arange(1, n + 1) / n)
            for m, n in enumerate(self.move_substeps, start=1)])
        zones = np.zeros(len(self.labels))
        knots = slice(1, -1) if cell.approach > 0 else slice(None)
        zones[knots] = trajectory.zones
        zones[[0, self.grasp, self.release, -1]] = 0.0
        return replace(self, times=times, durations=durations, speeds=speeds,
                       motion_times=motion_times, zones=zones)

    def message(self, program) -> str:
        """One line: passed with the key numbers, or the first failure of every failing
        check."""
        summary = {line["check"]: line for line in program.summary()}
        if program.ok:
            return (f"robot program ok: {len(self.labels)} targets per arm; min clearance "
                    f"{summary['clearance']['worst']:.1f} mm, min joint margin "
                    f"{summary['joint limits']['worst']:.1f} deg, largest joint step "
                    f"{summary['continuity']['worst']:.1f} deg, joint speed up to "
                    f"{100 * summary['joint speed']['worst']:.0f} % of the limit")
        return "robot program FAILS: " + program.failure_text()

    def record(self, program) -> dict:
        """The assignment, the tools and work object, the targets as written (position,
        quaternion, confdata, arm angle) and their verified joints."""
        cell = program.cell
        return {
            "assignment": {"left_clip": self.assignment.left_clip, "rule": self.assignment.rule,
                           "crossings": list(self.assignment.crossings),
                           "message": self.assignment.message},
            "grip_turned": list(self.grip_turned),
            "tools": [tool.name for tool in cell.tools],
            "wobj": cell.wobj,
            "targets": [{"label": label, "shape": int(self.shapes[m]),
                         "time": float(self.times[m]),
                         "arms": {arm: {"position": self.positions[m, a].tolist(),
                                        "quaternion_wxyz": self.quaternions[m, a].tolist(),
                                        "joints_deg": np.degrees(
                                            program.joints[a][m]).tolist(),
                                        "confdata": self.confdata[m, a].tolist(),
                                        "arm_angle_deg": float(self.arm_angles[m, a])}
                                  for a, arm in enumerate(ARMS)}}
                        for m, label in enumerate(self.labels)],
        }

    def writer_arguments(self, program, name: str) -> dict:
        """The ROS 2 writer's keyword arguments: the joint names (physical order)."""
        if name != "ros_joints":
            raise ValueError(f"{name}: the YuMi's program takes {', '.join(self.formats)}")
        return {"joint_names": [arm.joint_names for arm in program.cell.arms]}

    def report_arms(self, program) -> dict:
        """Both arms at every shape (the verified joints, (S + 2, 2, 7) [rad]) and along the
        replayed motion."""
        shape_joints = np.stack(program.joints, axis=1)[self.grasp:self.release + 1]
        return {"arm_joints": shape_joints, "robot": program.cell.robot,
                "arm_motion": (self.motion_times, self.motion_joints,
                               self.times[self.grasp:self.release + 1])}


def yumi_program(grippers, trajectory, cell: RobotCell | None = None, *,
                 verdict_only: bool = False,
                 round_trips_on_demand: bool = False,
                 held: HeldArms | None = None) -> RobotProgram:
    """The verified robot program of a plan on the YuMi (module docstring).

    Parameters
    ----------
    grippers : GripperPath
        Clip poses at every shape (S + 2), work frame.
    trajectory : Trajectory
        The timing of the same path: knot times and per-segment speeds are taken from it; its
        knots must be the clip points of ``grippers`` (in any arm order).
    cell : RobotCell, optional
        Default :class:`RobotCell` (YuMi at the work frame's origin, SmartGripper tools).
    verdict_only : bool
        Only the verdict and the first failure are wanted (the reach repair, which tries
        placements until one passes): a program that fails a check other than ``reach`` may
        come back untimed (``trajectory`` None: no ``joint speed`` rows, never to be written),
        its rows ending with the first target at which such a check fails (the controller's
        round trip of the later targets not computed) or with the motion's rows. Its rows
        up to there have the complete program's verdicts and its failing rows are the
        complete program's, so its first failure other than ``reach`` is the complete
        program's; a passing round trip is judged from the verified joints' own solution
        (its value that solution's deviation, its note saying so: the controller's other
        solutions are not enumerated). A program that passes, whose only failures are
        ``reach`` rows, or that would try the swapped assignment, has all its rows and is
        timed; its passing round trips are enumerated by
        :meth:`~dloplan.robot.program.RobotProgram.completed` (the reach repair's kept
        placement: when the repair returns, after the plan's figures were started).
    round_trips_on_demand : bool
        The program is wanted complete only when it is written or printed (the plan's own
        program in :func:`dloplan.pipeline.make_plan`: the reach repair replaces it when it
        fails, and the figures of a plan whose program passes are started before it is
        complete): its rows are all made, with every verdict and failing row of the complete
        program, but its passing round trips are judged from the verified joints' own
        solutions (as a verdict's) and enumerated by
        :meth:`~dloplan.robot.program.RobotProgram.completed`.
    held : HeldArms, optional
        The arms already hold the cable at the first target: their assignment is kept (rule
        ``"held"``, never swapped) and the joint solution is the one tracked from their joints
        with each arm's arm angle (:func:`~dloplan.robot.solutions.ranked_solutions`); give it
        a cell without approach (``cell.approach`` 0: the cable is held, nothing to approach).

    Returns
    -------
    RobotProgram
        Never raises for an infeasible plan: its checks say what fails and where. When the side
        rule's program fails on arm-arm clearance or continuity, the swapped assignment is tried
        and taken if it passes every check.

    Raises
    ------
    ValueError
        Inputs that do not belong together (shape counts, knots that are not the clip points;
        held joints that do not hold the first target, or with an approach).
    """
    cell = cell if cell is not None else RobotCell()
    if not isinstance(cell, RobotCell):
        raise ValueError(f"cell: expected a RobotCell, got {type(cell).__name__}")
    _check_inputs(grippers, trajectory)
    assignment = assign_arms(grippers.positions, cell)
    if held is not None:
        if cell.approach > 0:
            raise ValueError(f"cell.approach: got {cell.approach} m with held arms, expected 0 "
                             "(the cable is held: nothing to approach)")
        if assignment.left_clip != held.left_clip:
            assignment = assignment.swapped()
        assignment = replace(assignment, rule="held")
    program = _build(grippers, trajectory, cell, assignment, verdict_only=verdict_only,
                     on_demand=round_trips_on_demand, held=held)
    if program is None:
        raise ValueError("held: the arms' joints are not at the first target's TCP poses "
                         f"(within {HELD_TOLERANCE} m + rad); expected the joints holding the "
                         "cable there")
    if held is None and not program.ok and assignment.ok:
        failed = {r.check for r in program.failures}
        if failed & {"clearance", "continuity"} and "reach" not in failed:
            other = _build(grippers, trajectory, cell, assignment.swapped(), passing=True)
            if other is not None and other.ok:
                program = other
    return program if program.trajectory is None else slowed(program)


def _check_inputs(grippers, trajectory) -> None:
    from ..trajectory import Trajectory

    positions = getattr(grippers, "positions", None)
    rotations = getattr(grippers, "rotations", None)
    if positions is None or rotations is None:
        raise ValueError(f"grippers: expected a GripperPath, got {type(grippers).__name__}")
    if not isinstance(trajectory, Trajectory):
        raise ValueError(f"trajectory: expected a Trajectory, got {type(trajectory).__name__}")
    if trajectory.n_knots != len(positions):
        raise ValueError(f"trajectory: {trajectory.n_knots} knots, expected one per shape of the "
                         f"gripper path ({len(positions)})")
    knots = positions[:, list(trajectory.arm_clips)]
    gap = float(np.max(np.abs(knots - trajectory.positions)))
    if gap > 1e-6:
        raise ValueError(f"trajectory: its knots are up to {gap * 1e3:.3f} mm from the gripper "
                         "path's clip points; expected the trajectory of the same plan")


def _build(grippers, trajectory, cell: RobotCell, assignment: ArmAssignment,
           passing: bool = False, verdict_only: bool = False,
           on_demand: bool = False, held: HeldArms | None = None) -> RobotProgram | None:
    """The program of an arm assignment: its targets, then the ranked joint solutions tried
    in order (up to :data:`MAX_TRIES`): the first whose motion neither collides nor loses
    continuity, or the first with a target no solution reaches, else the best ranked.
    A try is judged on its motion (reach, continuity, clearance) before the controller's
    round trip and the time law are computed: a try that is passed over costs its replay
    only. With ``passing`` only a program whose motion passes is wanted (None otherwise:
    the swapped assignment, taken only when it passes every check); ``verdict_only`` and
    ``on_demand`` (``round_trips_on_demand``) and ``held`` as for :func:`yumi_program`
    (:func:`_finish`; None when the held joints are not at the first target)."""
    robot, opts = cell.robot, cell.reach
    clips = list(assignment.clips)
    n_shapes = len(grippers.positions)
    clip_pos = grippers.positions[:, clips]
    clip_rot = np.stack([grippers.rotations[c].as_matrix() for c in clips], axis=1)
    tcp_in = np.stack([tool.tcp_in_clip.as_matrix() for tool in cell.tools])
    grips = [clip_rot @ tcp_in]
    if opts.symmetric_grip:
        grips.append(grips[0] @ TURN_Z)
    # targets: approach, shapes, retreat (TCP z is the same for both grips)
    approach = cell.approach > 0
    pos = clip_pos
    if approach:
        pos = np.concatenate([clip_pos[:1] - cell.approach * grips[0][:1, :, :, 2], clip_pos,
                              clip_pos[-1:] - cell.approach * grips[0][-1:, :, :, 2]])
        grips = [np.concatenate([g[:1], g, g[-1:]]) for g in grips]
    labels = tuple((["approach"] if approach else []) + [f"shape {k}" for k in range(n_shapes)]
                   + (["retreat"] if approach else []))
    shapes = np.array(([0] if approach else []) + list(range(n_shapes))
                      + ([n_shapes - 1] if approach else []))
    grasp, release = (1, n_shapes) if approach else (0, n_shapes - 1)
    # exactly what RAPID is given
    pos = np.round(pos * 1e3, 6) / 1e3
    quats = [np.round(Rotation.from_matrix(g.reshape(-1, 3, 3)).as_quat(
        canonical=True, scalar_first=True), 9).reshape(g.shape[:2] + (4,)) for g in grips]
    rots = [Rotation.from_quat(q.reshape(-1, 4), scalar_first=True).as_matrix().reshape(
        q.shape[:2] + (3, 3)) for q in quats]
    targets = (labels, shapes, grasp, release, pos, quats, rots)
    first = None
    for left, right in ranked_solutions(robot, pos, rots, opts, None if held is None
                                        else held.joints)[:MAX_TRIES]:
        motion = _motion(cell, targets, (left, right))
        reached = bool(motion["solved"].all())
        moves = all(r.ok for r in motion["rows"])
        if passing and not (reached and moves):
            if not reached:
                return None  # a target no solution reaches: no other pair helps
            continue
        if first is None and not passing:
            first = motion
        if moves or not reached:  # yumi_program does not try the swapped assignment then
            return _finish(trajectory, cell, assignment, targets, motion, verdict_only,
                           on_demand)
    return _finish(trajectory, cell, assignment, targets, first, on_demand=on_demand) \
        if first is not None else None


def _motion(cell: RobotCell, targets, chosen) -> dict:
    """The motion of one joint solution per arm (``chosen``, candidates of
    :func:`~dloplan.robot.solutions.ranked_solutions`): the written arm angles, every target
    re-solved with its arm angle held, the controller's MoveL replayed into every target, and
    the rows judged on that motion alone (``clearance`` and ``continuity``)."""
    robot, opts = cell.robot, cell.reach
    labels, shapes, _, _, pos, quats, rots = targets
    rot = np.stack([rots[c.grip][:, a] for a, c in enumerate(chosen)], axis=1)
    q0 = np.stack([c.joints for c in chosen], axis=1)
    eax = np.round(np.degrees(np.stack([arm_angle(arm, q0[:, a])
                                        for a, arm in enumerate(robot.arms)], axis=1)), 6)
    joints = np.empty_like(q0)
    solved = np.zeros(eax.shape, dtype=bool)
    for m in range(len(pos)):
        for a, arm in enumerate(robot.arms):
            res = solve_from(arm, pos[m, a], rot[m, a], q0[m, a], opts.ik, np.radians(eax[m, a]))
            joints[m, a], solved[m, a] = res.q, res.success and chosen[a].solved[m]
    replay = replay_moves(robot, pos, rot, eax, joints, opts)
    return {"chosen": chosen, "rot": rot, "eax": eax, "joints": joints, "solved": solved,
            "replay": replay, "rows": _motion_rows(robot, opts, labels, shapes, joints, replay)}


def _finish(trajectory, cell, assignment, targets, motion, verdict_only: bool = False,
            on_demand: bool = False) -> RobotProgram:
    """The program of a solved motion (:func:`_motion`): the controller's round trip of every
    written robtarget, the verdict rows and the timing. With ``verdict_only`` the rows stop
    after the first target that fails a check other than ``reach``, or after the motion's rows
    when one of them fails such a check: the program is then returned untimed
    (:func:`yumi_program`). With ``verdict_only`` or ``on_demand`` the passing round trips are
    judged from the verified joints' own solutions (:func:`_round_trip`) and a program whose
    rows are all made can enumerate them (``completion``: :func:`_enumerated`)."""
    labels, shapes, grasp, release, pos, quats, _ = targets
    chosen, eax, joints = motion["chosen"], motion["eax"], motion["joints"]
    turned = tuple(bool(c.grip) for c in chosen)
    quat = np.stack([quats[c.grip][:, a] for a, c in enumerate(chosen)], axis=1)
    rows, stopped, judged = _rows(cell, assignment, targets, motion, verdict_only,
                                  verdict_only or on_demand)
    complete = not (stopped or (verdict_only and _fails(motion["rows"])))
    completion = partial(_enumerated, cell, targets, motion, tuple(judged)) \
        if complete and judged else None
    replayed = motion["replay"]["joints"]
    record = YumiTargets(assignment, turned, labels, shapes, grasp, release, pos, quat,
                         confdata(joints), eax, np.concatenate([joints[:1]] + replayed),
                         np.array([len(q) for q in replayed]))
    moves = tuple(tuple(np.concatenate([joints[m, a][None], q[:-1, a], joints[m + 1, a][None]])
                        for m, q in enumerate(replayed)) for a in range(2))
    untimed = RobotProgram(cell, record, (joints[:, 0], joints[:, 1]), moves, tuple(rows),
                           completion=completion)
    return untimed.retimed(trajectory) if complete else untimed


def _rows(cell, assignment, targets, motion, verdict_only: bool,
          own: bool) -> tuple[list, bool, list]:
    """The verdict rows of a solved motion (:func:`_finish`), whether they stopped early
    (``verdict_only``: after the first target failing a check other than ``reach``), and the
    (target, arm) of every round trip judged from its own solution (``own``,
    :func:`_round_trip`)."""
    robot = cell.robot
    labels, shapes, _, _, pos, _, _ = targets
    rot, eax, joints = motion["rot"], motion["eax"], motion["joints"]
    rows = _assignment_rows(assignment)
    stopped = verdict_only and _fails(rows)
    judged = []
    for m in range(len(pos)):
        if stopped:
            break
        trip = [_round_trip(arm, pos[m, a], rot[m, a], eax[m, a], joints[m, a], cell.reach.ik,
                            own) for a, arm in enumerate(robot.arms)]
        judged += [(m, a) for a in range(2) if not trip[a].enumerated]
        target = _target_rows(robot, cell, m, labels[m], int(shapes[m]), pos[m], rot[m],
                              joints[m], motion["solved"][m], trip)
        rows += target
        stopped = verdict_only and _fails(target)
    if not stopped:
        rows += motion["rows"]
    return rows, stopped, judged


def _enumerated(cell, targets, motion, judged, program: RobotProgram) -> RobotProgram:
    """``program`` (made by :func:`_finish` from ``targets`` and ``motion``) with the round
    trips ``judged`` from their own solutions ((target, arm) pairs) enumerated
    (:func:`~dloplan.robot.robtarget.solve_robtarget`): their rows as the complete program's,
    every other row as it was (a ``completion`` of
    :class:`~dloplan.robot.program.RobotProgram`)."""
    labels, shapes, _, _, pos, _, _ = targets
    rot, eax, joints = motion["rot"], motion["eax"], motion["joints"]
    made = {}
    for m, a in judged:
        found = _round_trip(cell.robot.arms[a], pos[m, a], rot[m, a], eax[m, a], joints[m, a],
                            cell.reach.ik, False)
        made[m, ARMS[a]] = _round_trip_row(m, labels[m], int(shapes[m]), a, found,
                                           joints[m, a])
    return replace(program, checks=tuple(
        made.get((row.target, row.arm), row) if row.check == "round trip" else row
        for row in program.checks))


def _round_trip(arm, position, rotation, eax: float, joints, options,
                own: bool) -> RobtargetSolution:
    """The controller's solutions of a written robtarget (``eax`` [deg] its arm angle,
    ``joints`` (7,) its verified joints): every one found
    (:func:`~dloplan.robot.robtarget.solve_robtarget`), or with ``own`` the verified
    joints' own solution when that round-trips (:func:`~dloplan.robot.robtarget.own_solution`:
    then so does the enumeration, the same verdict for one solve instead of 99)."""
    args = (arm, position, rotation, np.radians(eax), confdata(joints))
    if own:
        solution = own_solution(*args, joints, options)
        if solution.deviation(joints) <= ROUND_TRIP_TOLERANCE:
            return solution
    return solve_robtarget(*args, seeds=[joints], options=options)


def _fails(rows) -> bool:
    """A row of ``rows`` fails a check other than ``reach`` (where a verdict may stop: the
    first such failure is the one the reach repair reports; a target no IK reaches is reported
    per shape by the verification, after the program's other failures)."""
    return any(not row.ok and row.check != "reach" for row in rows)


def approach_profile(cell: RobotCell, law):
    """The time law of the approach (and of the retreat): rest to rest over ``cell.approach``
    [m] at ``cell.approach_speed`` [m/s], jerk-limited under ``law``'s limits (the
    trajectory's, default :class:`~dloplan.trajectory.MotionLimits`), normalized to s in
    [0, 1]. Its duration [s] is both the RAPID move's ``\\T`` and the joint motion's (ROS 2,
    RTDE) time for the move: longer than approach / approach_speed by the ramps."""
    from ..trajectory import MotionLimits
    from ..trajectory.timelaw import Profile

    limits = law.limits if law is not None and law.limits is not None else MotionLimits()
    length = cell.approach
    return Profile.jerk_limited(cell.approach_speed / length, limits.acceleration / length,
                                limits.jerk / length)


def _timing(trajectory, cell: RobotCell, assignment: ArmAssignment, approach: bool):
    """Move durations [s], (M - 1,), and written speeds, (M - 1, 2, 2) [m/s, rad/s]: the
    trajectory's segments between the shapes; approach and retreat at ``cell.approach_speed``,
    each taking its jerk-limited law's duration (:func:`approach_profile`)."""
    columns = [list(trajectory.arm_clips).index(c) for c in assignment.clips]
    lin, ang = trajectory.segment_speeds()
    durations = trajectory.segment_durations
    speeds = np.stack([lin[:, columns], ang[:, columns]], axis=-1)
    if approach:
        t_move = approach_profile(cell, trajectory.law).duration
        move = np.array([[[cell.approach_speed, 0.0]] * 2])
        durations = np.concatenate([[t_move], durations, [t_move]])
        speeds = np.concatenate([move, speeds, move])
    return durations, np.maximum(speeds, [MIN_SPEED, MIN_ANGULAR_SPEED])


def _link(i: int) -> str:
    return "gripper" if i == 7 else f"link {i + 1}"


def _assignment_rows(assignment: ArmAssignment) -> list:
    """The verdict rows of the arm assignment (module docstring: ``assignment``), per shape."""
    return [CheckRow("assignment", None, f"shape {k}", k, "both", 1e3 * sep, "mm",
                     k not in assignment.crossings,
                     "" if k not in assignment.crossings else
                     "the left arm's clip is right of the right arm's clip")
            for k, sep in enumerate(assignment.separation)]


def _target_rows(robot, cell, m, label, shape, pos, rot, joints, solved, trip) -> list:
    """The verdict rows of target ``m`` (module docstring: ``reach``, ``round trip``, ``joint
    limits``): ``pos`` (2, 3), ``rot`` (2, 3, 3), ``joints`` (2, 7) and ``solved`` (2,) its
    values per arm, ``trip[a]`` the controller's solutions of its robtarget for arm a
    (:func:`~dloplan.robot.robtarget.solve_robtarget`)."""
    opts = cell.reach
    rows = []
    for a, arm in enumerate(robot.arms):
        p, r = forward(arm, joints[a])
        perr = float(np.linalg.norm(p - pos[a]))
        aerr = float(Rotation.from_matrix(rot[a] @ r.as_matrix().T).magnitude())
        rows.append(CheckRow("reach", m, label, shape, ARMS[a], 1e3 * perr, "mm",
                             bool(solved[a]),
                             f"orientation error {np.degrees(aerr):.2g} deg" if
                             not solved[a] else ""))
    rows += [_round_trip_row(m, label, shape, a, trip[a], joints[a]) for a in range(2)]
    for a, arm in enumerate(robot.arms):
        gaps = np.minimum(joints[a] - arm.lower, arm.upper - joints[a])
        j = int(np.argmin(gaps))
        margin = float(np.degrees(gaps[j]))
        note = f"ABB axis {ABB_AXIS_NUMBERS[j]}"
        if margin < np.degrees(opts.min_margin):
            note += f", less than the {np.degrees(opts.min_margin):.0f} deg required"
        rows.append(CheckRow("joint limits", m, label, shape, ARMS[a], margin,
                             "deg", bool(gaps[j] >= opts.min_margin), note))
    return rows


def _round_trip_row(m, label, shape, a, found, joints) -> CheckRow:
    """The ``round trip`` row of target ``m`` for arm ``a``: ``found`` the controller's
    solutions of its robtarget (:func:`_round_trip`), ``joints`` (7,) its verified joints."""
    deviation = found.deviation(joints)
    conf = confdata(joints).tolist()
    note = (f"{len(found.solutions)} solutions of the pose and arm angle, "
            f"{len(found.matching)} with confdata {conf}")
    if not found.enumerated:
        note = (f"the verified joints' own solution, confdata {conf} (a verdict: the "
                "other solutions not enumerated)")
    elif len(found.matching) > 1:
        note += ("; the MoveL into it follows its branch (the continuity check) and "
                 "ConfL confirms the confdata")
    return CheckRow("round trip", m, label, shape, ARMS[a],
                    float(np.degrees(min(deviation, np.pi))), "deg",
                    bool(deviation <= ROUND_TRIP_TOLERANCE), note)


def _motion_rows(robot, opts, labels, shapes, joints, replay) -> list:
    """The verdict rows of the replayed motion (module docstring): ``clearance`` at each
    target and along the move into it, ``continuity`` of every move."""
    rows = []
    steps = [joints[:1]] + replay["joints"]
    for m, label in enumerate(labels):
        q = steps[m]
        gap, pair = arm_clearance(robot.left, q[:, 0], robot.right, q[:, 1])
        i = int(np.argmin(gap))
        rows.append(CheckRow("clearance", m, label, int(shapes[m]), "both", 1e3 * float(gap[i]),
                             "mm", bool(gap[i] >= opts.min_clearance),
                             f"left {_link(pair[i, 0])}, right {_link(pair[i, 1])}"))
    for m in range(1, len(labels)):
        for a in range(2):
            largest = float(replay["largest"][m - 1][a])
            end = float(replay["end_error"][m - 1][a])
            ok = (replay["converged"][m - 1][a] and largest <= opts.max_joint_step
                  and end <= END_TOLERANCE)
            axis = ABB_AXIS_NUMBERS[int(replay["worst_joint"][m - 1][a])]
            note = f"from {labels[m - 1]}; ABB axis {axis}"
            if not replay["converged"][m - 1][a]:
                note += "; the straight TCP motion is lost on the way"
            if end > END_TOLERANCE:
                note += f"; ends {np.degrees(end):.1f} deg from the target's solution"
            rows.append(CheckRow("continuity", m, labels[m], int(shapes[m]), ARMS[a],
                                 float(np.degrees(largest)), "deg", bool(ok), note))
    return rows
