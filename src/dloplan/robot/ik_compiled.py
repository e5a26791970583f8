"""The damped-least-squares IK of one 7-joint arm from one seed, compiled (numba).

The same iteration as :func:`dloplan.robot.kinematics.solve_reference` (Sugihara's
Levenberg-Marquardt step, null-space motion away from the joint limits, steps limited and
clipped, the polish of a solution near a limit), in plain loops over 3x3 and 7x7 arrays: the
numpy version spends about 0.4 ms per iteration in array calls on 3x3 matrices, and the
placement search of the repair loop runs some 500 000 iterations. The chain is passed as the
arrays :class:`~dloplan.robot.yumi.Arm` precomputes.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit


@njit(cache=True)
def chain_frames(origin_rot, origin_xyz, axis_skew, axis_skew2, tcp_rot, tcp_offset, q, rots,
                 points):
    """World frames of links 1..7 and the TCP into ``rots`` (8, 3, 3) and ``points`` (8, 3).

    ``T_i = T_{i-1} Origin_i Rot(axis_i, q_i)``, Rodrigues' formula for the joint rotation
    (``I + sin q K + (1 - cos q) K^2``): the origins' rotations (7, 3, 3) and points (7, 3)
    (joint 1's carrying the world placement), the axes' cross-product matrices and their
    squares (7, 3, 3), the TCP's rotation (3, 3) and offset (3,) in the flange.
    """
    r = np.eye(3)
    p = np.zeros(3)
    turn = np.empty((3, 3))
    for i in range(7):
        s, c = math.sin(q[i]), math.cos(q[i])
        for a in range(3):
            for b in range(3):
                turn[a, b] = (1.0 if a == b else 0.0) + s * axis_skew[i, a, b] + \
                    (1.0 - c) * axis_skew2[i, a, b]
        p = p + r @ origin_xyz[i]
        r = r @ (origin_rot[i] @ turn)
        rots[i] = r
        points[i] = p
    rots[7] = r @ tcp_rot
    points[7] = p + r @ tcp_offset


@njit(cache=True)
def rotation_log(m):
    """Rotation vector [rad] (3,) of a rotation matrix (3, 3): :func:`kinematics.rotation_log`."""
    skew = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
    cos = min(1.0, max(-1.0, 0.5 * (m[0, 0] + m[1, 1] + m[2, 2] - 1.0)))
    angle = math.acos(cos)
    if angle < 1e-6:
        return 0.5 * skew
    if angle <= math.pi - 1e-3:
        return angle / (2.0 * math.sin(angle)) * skew
    # near pi: the axis from the largest column of (m + I) / 2 = a a^T, signed by the skew part
    k = 0
    for j in range(1, 3):
        if m[j, j] > m[k, k]:
            k = j
    column = np.empty(3)
    for i in range(3):
        column[i] = 0.5 * (m[i, k] + (1.0 if i == k else 0.0))
    axis = column / math.sqrt(column[0] ** 2 + column[1] ** 2 + column[2] ** 2)
    sign = 1.0 if axis[0] * skew[0] + axis[1] * skew[1] + axis[2] * skew[2] >= 0.0 else -1.0
    return sign * angle * axis


@njit(cache=True)
def solve(origin_rot, origin_xyz, axis_skew, axis_skew2, tcp_rot, tcp_offset, axes, lower,
          upper, position, target_rot, seed, held_joint, held_value, max_iterations,
          position_tolerance, angle_tolerance, damping, max_step, null_gain, min_margin, polish,
          length_scale, null_fade):
    """Damped least squares from one seed: (q (7,), position error [m], angle error [rad],
    iterations, converged).

    ``held_joint`` >= 0 holds that joint at ``held_value`` (its column and step are zero);
    ``polish`` null-space steps at most once converged closer than ``min_margin`` to a limit.
    """
    q = np.minimum(np.maximum(seed, lower), upper)
    free = np.ones(7)
    if held_joint >= 0:
        q[held_joint] = held_value
        free[held_joint] = 0.0
    half = 0.5 * (upper - lower)
    mid = 0.5 * (lower + upper)
    eye = np.eye(7)
    scale = np.array([1.0, 1.0, 1.0, length_scale, length_scale, length_scale])
    rots = np.empty((8, 3, 3))
    points = np.empty((8, 3))
    jac = np.empty((6, 7))
    err = np.empty(6)
    done_q = q.copy()
    done_perr = done_aerr = 0.0
    done_it = -1
    perr = aerr = 0.0
    it = 0
    for it in range(max_iterations + 1):
        chain_frames(origin_rot, origin_xyz, axis_skew, axis_skew2, tcp_rot, tcp_offset, q,
                     rots, points)
        dp = position - points[7]
        dtheta = rotation_log(target_rot @ rots[7].T)
        perr = math.sqrt(dp[0] ** 2 + dp[1] ** 2 + dp[2] ** 2)
        aerr = math.sqrt(dtheta[0] ** 2 + dtheta[1] ** 2 + dtheta[2] ** 2)
        converged = perr <= position_tolerance and aerr <= angle_tolerance
        if converged:
            done_q[:] = q
            done_perr, done_aerr, done_it = perr, aerr, it
            if polish == 0 or np.min(np.minimum(q - lower, upper - q)) >= min_margin:
                break
        if it == max_iterations:
            break
        for i in range(7):  # the geometric Jacobian, angular rows scaled, held joint zeroed
            z = rots[i] @ axes[i]
            lever = points[7] - points[i]
            column = (z[1] * lever[2] - z[2] * lever[1], z[2] * lever[0] - z[0] * lever[2],
                      z[0] * lever[1] - z[1] * lever[0], z[0], z[1], z[2])
            for row in range(6):
                jac[row, i] = column[row] * scale[row] * free[i]
        for row in range(3):
            err[row] = dp[row]
            err[row + 3] = length_scale * dtheta[row]
        energy = 0.5 * (err @ err)
        grad = (q - mid) / half**2
        try:
            null = eye - jac.T @ np.linalg.solve(jac @ jac.T, jac)
        except Exception:  # singular J J^T: pinv's truncation
            null = eye - np.linalg.pinv(jac, rcond=1e-8) @ jac
        if converged:  # polish: a pure self-motion step away from the limits
            polish -= 1
            dq = -null_gain * (null @ grad)
        else:
            dq = np.linalg.solve(jac.T @ jac + (energy + damping) * eye, jac.T @ err)
            fade = min(1.0, math.sqrt(2.0 * energy) / null_fade)
            dq -= null_gain * fade * (null @ grad)
        dq *= free
        largest = np.max(np.abs(dq))
        if largest > max_step:
            dq *= max_step / largest
        q = np.minimum(np.maximum(q + dq, lower), upper)
    if done_it >= 0:
        return done_q, done_perr, done_aerr, it, True
    return q, perr, aerr, it, False
