"""Joint solutions of a robot program's targets: candidates per arm, ranked in pairs.

The YuMi's arm is redundant by one degree of freedom, which the controller parameterizes by the
arm angle psi (:mod:`dloplan.robot.armangle`, a robtarget's ``eax_a``). Per arm and grip, the
first target is solved freely from the home pose; its arm angle and the angles around the
circle, 30 deg apart, are held constant while each candidate tracks the whole path in
sub-steps (every IK seeded from the previous sub-step; all candidates of an arm solved together
by :func:`~dloplan.robot.kinematics.solve_many`): the motion the controller's MoveL makes
between targets of one written arm angle. :func:`ranked_solutions` ranks the (left, right)
pairs: every target solved, tracked smoothly, clearance and joint margin (see
:mod:`dloplan.robot.program`, which verifies the chosen pair).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from .armangle import arm_angle, wrap
from .collision import arm_clearance
from .kinematics import inverse, joint_margin, solve_many
from .path import COMFORT_CLEARANCE, COMFORT_MARGIN, check_path, held_pose

ARM_ANGLE_STEP = float(np.radians(30.0))
"""[rad] Spacing of the constant arm angles tried for each arm."""

ARM_ANGLES = 12
"""Arm angles tried per arm and grip: the first target's free solution's and the others
:data:`ARM_ANGLE_STEP` apart around the circle."""

TRACK_ITERATIONS = 12
"""IK iterations allowed per tracking sub-step, here and in the replay (a converging solve
from the previous sub-step's solution needs a handful)."""

@dataclass(frozen=True, eq=False)
class Candidate:
    """One arm's joint solution at every target: grip (0 as mapped, 1 turned by pi about TCP z),
    (M, 7) joints [rad], (M,) solved flags, and whether its tracking converged at every
    sub-step without a joint step above ``max_joint_step``."""

    grip: int
    joints: np.ndarray
    solved: np.ndarray
    smooth: bool = True


def _held_start(arm, pos, rots, held) -> list[tuple]:
    """The one start of an arm that holds the cable at target 0 with joints ``held`` (7,)
    [rad]: its grip (the one whose target-0 rotation its forward kinematics has), its arm angle
    and its joints; none when neither grip's target is where the held joints put the TCP (the
    arm does not hold it there)."""
    fits = [held_pose(arm, pos[0], rot[0], held) for rot in rots]
    grip = int(np.argmin([fit.position_error + fit.angle_error for fit in fits]))
    if not fits[grip].success:
        return []
    return [(grip, float(arm_angle(arm, held)), np.asarray(held, dtype=float))]


def _free_starts(arm, pos, rots, opts) -> list[tuple]:
    """The starts of an arm free to choose its joints at target 0: per grip, target 0 solved
    from the home pose (its arm angle psi*), then the arm angles psi* + k *
    :data:`ARM_ANGLE_STEP` around the circle, seeded with that solution and, where that fails,
    with a solved neighbour's (a continuation in the arm angle); (grip, arm angle, joints) each."""
    first = replace(opts.ik, min_margin=opts.min_margin, restarts=0)
    track = replace(opts.ik, max_iterations=TRACK_ITERATIONS)
    steps = np.arange(ARM_ANGLES) - (ARM_ANGLES - 1) // 2
    starts = []  # (grip, theta, joints at target 0)
    for grip, rot in enumerate(rots):
        start = inverse(arm, pos[0], Rotation.from_matrix(rot[0]), None, first)
        if not start.success:
            continue
        theta = wrap(arm_angle(arm, start.q) + ARM_ANGLE_STEP * steps)
        q = np.tile(start.q, (len(theta), 1))
        done = np.zeros(len(theta), dtype=bool)
        for _ in range(3):  # continuation: the unsolved start again from a solved neighbour
            todo = np.flatnonzero(~done)
            q[todo], done[todo], _, _ = solve_many(
                arm, np.broadcast_to(pos[0], (len(todo), 3)),
                np.broadcast_to(rot[0], (len(todo), 3, 3)), q[todo], track, theta[todo])
            if done.all() or not done.any():
                break
            solved = np.flatnonzero(done)
            nearest = solved[np.abs(todo[:, None] - solved[None]).argmin(axis=1)]
            q[todo] = q[nearest]
        starts += [(grip, t, qs) for t, qs, ok in zip(theta, q, done, strict=True) if ok]
    return starts


def _arm_candidates(arm, pos, rots, n_sub, opts, held=None) -> list[Candidate]:
    """The starts at target 0 (:func:`_free_starts`; with ``held`` (7,) joints [rad] at target
    0, the arm holding the cable there, the one start from them with their arm angle:
    :func:`_held_start`); each candidate then tracks the path with its arm angle held, in
    ``n_sub[m]`` sub-steps per move, each seeded from the previous one (all candidates at
    once)."""
    track = replace(opts.ik, max_iterations=TRACK_ITERATIONS)
    starts = (_free_starts(arm, pos, rots, opts) if held is None
              else _held_start(arm, pos, rots, held))
    if not starts:
        return []
    grips = np.array([g for g, _, _ in starts])
    thetas = np.array([t for _, t, _ in starts])
    rot = np.stack(rots)[grips]  # (N, M, 3, 3)
    rel = Rotation.from_matrix(np.einsum("nmji,nmjk->nmik", rot[:, :-1], rot[:, 1:])).as_rotvec()
    q = np.stack([q for _, _, q in starts])
    joints = np.empty((len(starts), len(pos), 7))
    solved = np.zeros((len(starts), len(pos)), dtype=bool)
    joints[:, 0], solved[:, 0] = q, True
    converged = np.ones(len(starts), dtype=bool)
    largest = np.zeros(len(starts))
    for m in range(1, len(pos)):
        for i in range(1, n_sub[m - 1] + 1):
            f = i / n_sub[m - 1]
            p = np.broadcast_to(pos[m - 1] + f * (pos[m] - pos[m - 1]), (len(starts), 3))
            r = rot[:, m - 1] @ Rotation.from_rotvec(f * rel[:, m - 1]).as_matrix()
            live = np.flatnonzero(converged)  # a lost candidate stays where it was lost
            new, ok, _, _ = solve_many(arm, p[live], r[live], q[live], track, thetas[live])
            largest[live] = np.maximum(largest[live], np.abs(new - q[live]).max(axis=-1))
            q[live] = new
            converged[live] = ok
        joints[:, m], solved[:, m] = q, converged
    smooth = converged & (largest <= opts.max_joint_step)
    return [Candidate(int(g), qs, ok, bool(c))
            for g, qs, ok, c in zip(grips, joints, solved, smooth, strict=True)]


def _tracked_candidates(robot, pos, rots, opts) -> list[Candidate]:
    """The free-elbow tracking of :func:`~dloplan.robot.path.check_path` (the arm
    angle follows the null-space motion), one candidate per arm."""
    tracked = check_path(robot, pos, Rotation.from_matrix(rots[0]), options=opts,
                         alternatives=Rotation.from_matrix(rots[-1]))
    return [Candidate(int(tracked.grip_turned[a]), tracked.q[:, a], tracked.reachable[:, a],
                       bool(tracked.continuous[:, a].all())) for a in range(2)]


def ranked_solutions(robot, pos, rots, opts, held=None) -> list[tuple[Candidate, Candidate]]:
    """(left, right) joint solutions, best first: every target solved, tracked smoothly,
    clearance at the targets at least the minimum, margin at least the wanted one, then
    clearance (up to :data:`COMFORT_CLEARANCE`) and margin (up to :data:`COMFORT_MARGIN`).
    The free-elbow tracking is added when no constant arm angle tracks an arm's whole path.
    With ``held`` the arms hold the cable at target 0: one candidate per arm, from the held
    joints with their arm angle (no other start, no free-elbow tracking from home); none when
    an arm's held joints are not at its target 0.

    Parameters
    ----------
    robot : Robot
    pos : numpy.ndarray
        (M, 2, 3) TCP targets [m] of the left and right arm.
    rots : list of numpy.ndarray
        One or two (the grip turned by pi about TCP z) sets of (M, 2, 3, 3) target rotations.
    opts : ReachOptions
    held : sequence of numpy.ndarray, optional
        (left, right) (7,) joints [rad] holding the cable at target 0.

    Returns
    -------
    list of (Candidate, Candidate)
        All pairs, best first.
    """
    dist = np.linalg.norm(np.diff(pos, axis=0), axis=-1).max(axis=1)
    angle = np.max([Rotation.from_matrix(np.einsum("mji,mjk->mik", rots[0][:-1, a],
                                                   rots[0][1:, a])).magnitude()
                    for a in range(2)], axis=0)
    n_sub = np.maximum(1, np.maximum(np.ceil(dist / opts.step_length),
                                     np.ceil(angle / opts.step_angle))).astype(int)
    cands = [_arm_candidates(arm, pos[:, a], [r[:, a] for r in rots], n_sub, opts,
                             None if held is None else held[a])
             for a, arm in enumerate(robot.arms)]
    if held is not None and not all(cands):
        return []
    tracks = all(any(c.solved.all() and c.smooth for c in arm_cands) for arm_cands in cands)
    if held is None and not tracks:
        for a, c in enumerate(_tracked_candidates(robot, pos, rots, opts)):
            cands[a].append(c)
    q_left = np.stack([c.joints for c in cands[0]])  # (L, M, 7)
    q_right = np.stack([c.joints for c in cands[1]])  # (R, M, 7)
    gap, _ = arm_clearance(robot.left, q_left[:, None], robot.right, q_right[None])
    clearance = gap.min(axis=-1)  # (L, R)
    margin = [np.array([joint_margin(arm, c.joints).min() for c in arm_cands])
              for arm, arm_cands in zip(robot.arms, cands, strict=True)]
    solved = [np.array([c.solved.all() for c in arm_cands]) for arm_cands in cands]
    both_margin = np.minimum(margin[0][:, None], margin[1][None])
    keys = []
    for i in range(len(cands[0])):
        for j in range(len(cands[1])):
            keys.append(((bool(solved[0][i] and solved[1][j]),
                          cands[0][i].smooth and cands[1][j].smooth,
                          bool(clearance[i, j] >= opts.min_clearance),
                          bool(both_margin[i, j] >= opts.min_margin),
                          min(float(clearance[i, j]), COMFORT_CLEARANCE),
                          min(float(both_margin[i, j]), COMFORT_MARGIN)), i, j))
    keys.sort(key=lambda k: k[0], reverse=True)
    return [(cands[0][i], cands[1][j]) for _, i, j in keys]
