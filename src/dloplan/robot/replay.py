"""The controller's MoveL into every target of a robot program, replayed joint by joint.

TCP linear, orientation slerp, arm angle (``eax_a``, :mod:`dloplan.robot.armangle`) linear
between the written values, each sub-step's IK seeded from the previous one with the arm
angle held
(:func:`~dloplan.robot.kinematics.solve_many`, all moves of an arm advanced together). What
:mod:`dloplan.robot.program` checks continuity, clearance and joint speed on.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation

from .kinematics import solve_many
from .solutions import TRACK_ITERATIONS

REFINE = 8
"""Finer steps a sub-step with a large joint step is replayed in (:func:`_replay`)."""


def replay_moves(robot, pos, rot, eax, joints, opts) -> dict:
    """The controller's MoveL into every target (module docstring, ``continuity``).

    Both arms advance through the same sub-steps of a move; all moves of an arm advance
    together (each starts from its start target's solution). A sub-step whose largest joint
    step exceeds ``max_joint_step`` is replayed again in :data:`REFINE` finer steps: a
    continuous motion that is merely fast (near a singularity) then moves each joint by about
    a REFINE-th, a jump to another branch still jumps. Returns per move m = 1..M-1 the
    sub-step joints (n_m, 2, 7) and per move and arm: converged, largest refined joint step
    [rad] and its joint, and the distance of the end from the target's solution [rad].

    Parameters
    ----------
    robot : Robot
    pos, rot : numpy.ndarray
        (M, 2, 3) TCP targets [m] and (M, 2, 3, 3) rotations, as written.
    eax : numpy.ndarray
        (M, 2) arm angles [deg], as written.
    joints : numpy.ndarray
        (M, 2, 7) the targets' solutions [rad].
    opts : ReachOptions
    """
    track = replace(opts.ik, max_iterations=TRACK_ITERATIONS)
    n_moves = len(pos) - 1
    dist = np.linalg.norm(np.diff(pos, axis=0), axis=-1)  # (M-1, 2)
    angle = np.stack([Rotation.from_matrix(np.einsum("mji,mjk->mik", rot[:-1, a], rot[1:, a]))
                      .magnitude() for a in range(2)], axis=1)
    turn = np.radians(np.abs(np.diff(eax, axis=0)))
    n_sub = np.maximum(1, np.maximum(np.ceil(dist.max(axis=1) / opts.step_length), np.ceil(
        np.maximum(angle, turn).max(axis=1) / opts.step_angle))).astype(int)
    n_max = int(n_sub.max())
    sub = np.empty((n_max, n_moves, 2, 7))
    converged = np.ones((n_moves, 2), dtype=bool)
    for a, arm in enumerate(robot.arms):
        rel = Rotation.from_matrix(np.einsum("mji,mjk->mik", rot[:-1, a], rot[1:, a])).as_rotvec()
        q = joints[:-1, a].copy()
        for i in range(n_max):
            s = np.minimum((i + 1) / n_sub, 1.0)
            live = np.flatnonzero(converged[:, a])  # a lost move stays where it was lost
            p, r, theta = _along(pos[:, a], rot[:, a], rel, eax[:, a], s)
            q[live], ok, _, _ = solve_many(arm, p[live], r[live], q[live], track, theta[live])
            converged[live, a] = ok
            sub[i, :, a] = q
    out = {"joints": [], "converged": converged, "largest": np.zeros((n_moves, 2)),
           "worst_joint": np.zeros((n_moves, 2), dtype=int), "end_error": np.zeros((n_moves, 2))}
    for m in range(n_moves):
        q_move = sub[:n_sub[m], m]
        steps = np.abs(np.diff(np.concatenate([joints[m][None], q_move]), axis=0))  # (n, 2, 7)
        for a in range(2):
            i = int(steps[:, a].max(axis=-1).argmax())
            largest, joint = float(steps[i, a].max()), int(steps[i, a].argmax())
            if largest > opts.max_joint_step:
                start = joints[m, a] if i == 0 else q_move[i - 1, a]
                largest, joint = _refined_step(robot.arms[a], pos[m:m + 2, a], rot[m:m + 2, a],
                                               eax[m:m + 2, a], (i / n_sub[m], (i + 1) / n_sub[m]),
                                               start, track)
            out["largest"][m, a], out["worst_joint"][m, a] = largest, joint
        out["end_error"][m] = np.abs(q_move[-1] - joints[m + 1]).max(axis=-1)
        out["joints"].append(q_move)
    return out


def _along(pos, rot, rel, eax, s):
    """Poses of every move m (from target m to m + 1) at fractions s (M-1,): TCP position
    linear, orientation slerp (``rel`` the (M-1, 3) rotation vectors of the moves), arm angle
    linear [rad]."""
    p = pos[:-1] + s[:, None] * (pos[1:] - pos[:-1])
    r = rot[:-1] @ Rotation.from_rotvec(s[:, None] * rel).as_matrix()
    theta = np.radians(eax[:-1] + s * (eax[1:] - eax[:-1]))
    return p, r, theta


def _refined_step(arm, pos, rot, eax, span, start, track) -> tuple[float, int]:
    """Largest joint step [rad] (and its joint) replaying the sub-step ``span`` (fractions of
    the move from ``pos[0]`` to ``pos[1]``) in :data:`REFINE` steps from ``start``."""
    rel = Rotation.from_matrix(rot[0].T @ rot[1]).as_rotvec()[None]
    fractions = np.linspace(span[0], span[1], REFINE + 1)[1:]
    q, largest, joint = start, 0.0, 0
    for s in fractions:
        p, r, theta = _along(pos, rot, rel, eax, np.array([s]))
        new = solve_many(arm, p, r, q[None], track, theta)[0][0]
        step = np.abs(new - q)
        if step.max() > largest:
            largest, joint = float(step.max()), int(step.argmax())
        q = new
    return largest, joint
