"""The damped-least-squares IK solve from one seed, compiled (numba).

:func:`solve` is the iteration of :func:`dloplan.robot.kinematics.solve_reference` for any
arm of n joints (Sugihara's Levenberg-Marquardt step, null-space motion away from the joint
limits for a redundant arm, steps limited and clipped, the polish of a solution near a limit,
a seed given up when its error stalls) and, with the arm angle held, of
:func:`dloplan.robot.armangle.solve_reference` (a square 7x7 task). Plain loops over 3x3 and
n x n arrays: the numpy versions spend about 0.4 ms per iteration in array calls on 3x3
matrices, and the placement search of a repair runs some 500 000 iterations. The chains are
passed as the arrays their arms precompute.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit

STALL_FLOOR = 1e-3
"""[m] Weighted error below which a solve is never given up as stalled (:func:`solve`)."""


@njit(cache=True)
def chain_frames(origin_rot, origin_xyz, axis_skew, axis_skew2, tcp_rot, tcp_offset, q, rots,
                 points, work):
    """World frames of the n links and the TCP into ``rots`` (n + 1, 3, 3) and ``points``
    (n + 1, 3), for joint values ``q`` (n,) [rad]; ``work`` (3, 3, 3) scratch.

    ``T_i = T_{i-1} Origin_i Rot(axis_i, q_i)``, Rodrigues' formula for the joint rotation
    (``I + sin q K + (1 - cos q) K^2``): the origins' rotations (n, 3, 3) and points (n, 3)
    (the first joint's carrying the world placement), the axes' cross-product matrices and
    their squares (n, 3, 3), the TCP's rotation (3, 3) and offset (3,) in the last link.
    """
    r, joint, nxt = work[0], work[1], work[2]
    for a in range(3):
        for b in range(3):
            r[a, b] = 1.0 if a == b else 0.0
    p0 = p1 = p2 = 0.0
    n = q.size
    for i in range(n):  # 3x3 products as loops: a BLAS call per product costs more than it
        s, c = math.sin(q[i]), math.cos(q[i])
        for a in range(3):
            for b in range(3):
                t = 0.0
                for m in range(3):  # origin rotation times the joint's turn
                    t += origin_rot[i, a, m] * ((1.0 if m == b else 0.0) + s * axis_skew[i, m, b]
                                                + (1.0 - c) * axis_skew2[i, m, b])
                joint[a, b] = t
        p0 += r[0, 0] * origin_xyz[i, 0] + r[0, 1] * origin_xyz[i, 1] + r[0, 2] * origin_xyz[i, 2]
        p1 += r[1, 0] * origin_xyz[i, 0] + r[1, 1] * origin_xyz[i, 1] + r[1, 2] * origin_xyz[i, 2]
        p2 += r[2, 0] * origin_xyz[i, 0] + r[2, 1] * origin_xyz[i, 1] + r[2, 2] * origin_xyz[i, 2]
        for a in range(3):
            for b in range(3):
                nxt[a, b] = r[a, 0] * joint[0, b] + r[a, 1] * joint[1, b] + r[a, 2] * joint[2, b]
        r[:] = nxt
        rots[i] = r
        points[i, 0], points[i, 1], points[i, 2] = p0, p1, p2
    for a in range(3):
        points[n, a] = points[n - 1, a] + r[a, 0] * tcp_offset[0] + r[a, 1] * tcp_offset[1] + \
            r[a, 2] * tcp_offset[2]
        for b in range(3):
            rots[n, a, b] = r[a, 0] * tcp_rot[0, b] + r[a, 1] * tcp_rot[1, b] + \
                r[a, 2] * tcp_rot[2, b]


@njit(cache=True)
def times_transposed(a, b, out):
    """out = a @ b.T for 3x3 matrices (the orientation error ``R* R^T``); returns ``out``."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[j, 0] + a[i, 1] * b[j, 1] + a[i, 2] * b[j, 2]
    return out


@njit(cache=True)
def weighted_jacobian(rots, points, axes, weight, free, jac):
    """The TCP's geometric Jacobian into ``jac`` (6, n): column i ``(z_i x (p_tcp - p_i),
    z_i)`` with z_i joint i's world axis (``rots[i] @ axes[i]``) through ``points[i]``, the
    TCP being frame n; rows times ``weight`` (6,), columns times ``free`` (n,)."""
    n = jac.shape[1]
    for i in range(n):
        a0, a1, a2 = axes[i, 0], axes[i, 1], axes[i, 2]
        z0 = rots[i, 0, 0] * a0 + rots[i, 0, 1] * a1 + rots[i, 0, 2] * a2
        z1 = rots[i, 1, 0] * a0 + rots[i, 1, 1] * a1 + rots[i, 1, 2] * a2
        z2 = rots[i, 2, 0] * a0 + rots[i, 2, 1] * a1 + rots[i, 2, 2] * a2
        l0, l1, l2 = points[n, 0] - points[i, 0], points[n, 1] - points[i, 1], \
            points[n, 2] - points[i, 2]
        column = (z1 * l2 - z2 * l1, z2 * l0 - z0 * l2, z0 * l1 - z1 * l0, z0, z1, z2)
        for row in range(6):
            jac[row, i] = column[row] * weight[row] * free[i]


@njit(cache=True)
def rotation_log_into(m, out):
    """Rotation vector [rad] of a rotation matrix ``m`` (3, 3) into ``out`` (3,):
    :func:`kinematics.rotation_log`; returns ``out``."""
    s0, s1, s2 = m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]
    cos = min(1.0, max(-1.0, 0.5 * (m[0, 0] + m[1, 1] + m[2, 2] - 1.0)))
    angle = math.acos(cos)
    if angle <= math.pi - 1e-3:
        factor = 0.5 if angle < 1e-6 else angle / (2.0 * math.sin(angle))
        out[0], out[1], out[2] = factor * s0, factor * s1, factor * s2
        return out
    # near pi: the axis from the largest column of (m + I) / 2 = a a^T, signed by the skew part
    k = 0
    for j in range(1, 3):
        if m[j, j] > m[k, k]:
            k = j
    for i in range(3):
        out[i] = 0.5 * (m[i, k] + (1.0 if i == k else 0.0))
    norm = math.sqrt(out[0] ** 2 + out[1] ** 2 + out[2] ** 2)
    for i in range(3):
        out[i] = out[i] / norm
    sign = 1.0 if out[0] * s0 + out[1] * s1 + out[2] * s2 >= 0.0 else -1.0
    for i in range(3):
        out[i] = sign * angle * out[i]
    return out


@njit(cache=True)
def null_projector(jac, eye):
    """I - J^+ J (n, n) for J (6, n), J^+ = J^T (J J^T)^-1 (J has full row rank away from
    singularities; pinv's truncation where it has not)."""
    try:
        return eye - jac.T @ np.linalg.solve(jac @ jac.T, jac)
    except Exception:  # singular J J^T
        return eye - np.linalg.pinv(jac, rcond=1e-8) @ jac


@njit(cache=True)
def cross3(a, b, out):
    """out = a x b for 3-vectors; returns ``out``."""
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]
    return out


@njit(cache=True)
def arm_angle_row(rots, points, axes, shoulder, wrist, reference, elbow, row, work):
    """The arm angle psi [rad] of the chain's frames and its gradient d psi / dq into ``row``
    (n,): :func:`dloplan.robot.armangle.arm_angle` and ``arm_angle_jacobian`` compiled.

    ``shoulder`` and ``wrist`` are the distances [m] of S along axis 1 from joint 1's origin
    and of W along the last axis from the last joint's origin; ``reference`` the world
    reference direction (3,); ``elbow`` the index of the joint whose axis is h; ``work``
    (n + 8, 3) scratch."""
    n = row.size
    z = work[:n]
    for i in range(n):
        for a in range(3):
            z[i, a] = rots[i, a, 0] * axes[i, 0] + rots[i, a, 1] * axes[i, 1] + \
                rots[i, a, 2] * axes[i, 2]
    w_pt, e, h, tmp, d_w, d_e, d_h, lever = work[n], work[n + 1], work[n + 2], work[n + 3], \
        work[n + 4], work[n + 5], work[n + 6], work[n + 7]
    for a in range(3):  # e = (W - S) / |W - S| in e until normalized
        w_pt[a] = points[n - 1, a] + wrist * z[n - 1, a]
        e[a] = w_pt[a] - (points[0, a] + shoulder * z[0, a])
        h[a] = z[elbow, a]
    length = math.sqrt(e[0] ** 2 + e[1] ** 2 + e[2] ** 2)
    for a in range(3):
        e[a] = e[a] / length
    eh = e[0] * h[0] + e[1] * h[1] + e[2] * h[2]
    er_e = e[0] * reference[0] + e[1] * reference[1] + e[2] * reference[2]
    cross3(e, h, tmp)
    x = tmp[0] * reference[0] + tmp[1] * reference[1] + tmp[2] * reference[2]
    y = h[0] * reference[0] + h[1] * reference[1] + h[2] * reference[2] - er_e * eh
    norm2 = x * x + y * y
    for i in range(n):
        for a in range(3):
            lever[a] = w_pt[a] - points[i, a]
        cross3(z[i], lever, d_w)
        dwe = d_w[0] * e[0] + d_w[1] * e[1] + d_w[2] * e[2]
        for a in range(3):
            d_e[a] = (d_w[a] - dwe * e[a]) / length
        if i < elbow:
            cross3(z[i], h, d_h)
        else:
            d_h[:] = 0.0
        cross3(d_e, h, tmp)
        dx = tmp[0] * reference[0] + tmp[1] * reference[1] + tmp[2] * reference[2]
        cross3(e, d_h, tmp)
        dx += tmp[0] * reference[0] + tmp[1] * reference[1] + tmp[2] * reference[2]
        dy = (d_h[0] * reference[0] + d_h[1] * reference[1] + d_h[2] * reference[2]
              - (d_e[0] * reference[0] + d_e[1] * reference[1] + d_e[2] * reference[2]) * eh
              - er_e * (d_e[0] * h[0] + d_e[1] * h[1] + d_e[2] * h[2]
                        + d_h[0] * e[0] + d_h[1] * e[1] + d_h[2] * e[2]))
        row[i] = (x * dy - y * dx) / norm2 if norm2 > 0.0 else 0.0
    return math.atan2(y, x)


@njit(cache=True)
def damped_step(jac, err, mu, normal, step):
    """The Levenberg-Marquardt step ``(J^T J + mu I)^-1 J^T e`` (n,) into ``step`` for J
    (rows, n), e (rows,), mu > 0 [m^2], by Cholesky's factorization of the symmetric positive
    definite ``J^T J + mu I`` (into ``normal`` (n, n), lower triangle) and two triangular
    solves: plain loops, no LAPACK call (whose overhead is most of a 7x7 solve). Equal to
    ``np.linalg.solve`` to rounding (cond(J^T J + mu I) <= (|J|^2 + mu) / mu). Returns
    ``step``."""
    rows, n = jac.shape
    for i in range(n):
        for j in range(i + 1):
            t = 0.0
            for r in range(rows):
                t += jac[r, i] * jac[r, j]
            normal[i, j] = t + mu if i == j else t
        t = 0.0
        for r in range(rows):
            t += jac[r, i] * err[r]
        step[i] = t
    for j in range(n):  # normal = L L^T, L in the lower triangle
        d = normal[j, j]
        for k in range(j):
            d -= normal[j, k] * normal[j, k]
        d = math.sqrt(d)
        normal[j, j] = d
        for i in range(j + 1, n):
            t = normal[i, j]
            for k in range(j):
                t -= normal[i, k] * normal[j, k]
            normal[i, j] = t / d
    for i in range(n):  # L y = b
        t = step[i]
        for k in range(i):
            t -= normal[i, k] * step[k]
        step[i] = t / normal[i, i]
    for i in range(n - 1, -1, -1):  # L^T x = y
        t = step[i]
        for k in range(i + 1, n):
            t -= normal[k, i] * step[k]
        step[i] = t / normal[i, i]
    return step


@njit(cache=True)
def solve(origin_rot, origin_xyz, axis_skew, axis_skew2, tcp_rot, tcp_offset, axes, lower,
          upper, position, target_rot, seed, hold_angle, angle, angle_points, reference,
          max_iterations, position_tolerance, angle_tolerance, damping, max_step, null_gain,
          min_margin, polish, length_scale, null_fade, stall_window=0, stall_ratio=1.0,
          cholesky=False):
    """Damped least squares from one seed: (q (n,), position error [m], angle error [rad],
    iterations, converged).

    ``hold_angle``: the arm angle (:func:`arm_angle_row`, ``angle_points`` = (s, w) [m],
    ``reference`` (3,) in the world) is a 7th task row held at ``angle`` [rad] (the square
    7x7 system of the controller's semantics; no null space left, no polish); its error counts
    with the orientation error. Otherwise ``polish`` null-space steps at most once converged
    closer than ``min_margin`` to a limit. ``stall_window`` > 0: the seed is given up when the
    weighted error (position + ``length_scale`` x angle) is still above :data:`STALL_FLOOR`
    and has not dropped below ``stall_ratio`` of its value ``stall_window`` iterations before
    (a solve that is close keeps going: near a singularity it converges slowly).
    ``cholesky``: the step by :func:`damped_step` instead of LAPACK's ``gesv`` (the same step
    to rounding, in a fraction of the time; :func:`solve_batch`).
    """
    n = seed.size
    q = np.minimum(np.maximum(seed, lower), upper)
    rows = 7 if hold_angle else 6
    history = np.empty(max_iterations + 1)
    half = 0.5 * (upper - lower)
    mid = 0.5 * (lower + upper)
    eye = np.eye(n)
    scale = np.array([1.0, 1.0, 1.0, length_scale, length_scale, length_scale])
    ones = np.ones(n)
    rots = np.empty((n + 1, 3, 3))
    points = np.empty((n + 1, 3))
    jac = np.empty((rows, n))
    err = np.empty(rows)
    relative = np.empty((3, 3))
    angle_row = np.empty(n)
    frame_work = np.empty((3, 3, 3))
    angle_work = np.empty((n + 8, 3))
    dp = np.empty(3)
    dtheta = np.empty(3)
    normal = np.empty((n, n))
    step = np.empty(n)
    done_q = q.copy()
    done_perr = done_aerr = 0.0
    done_it = -1
    perr = aerr = 0.0
    it = 0
    for it in range(max_iterations + 1):
        chain_frames(origin_rot, origin_xyz, axis_skew, axis_skew2, tcp_rot, tcp_offset, q,
                     rots, points, frame_work)
        for a in range(3):
            dp[a] = position[a] - points[n, a]
        rotation_log_into(times_transposed(target_rot, rots[n], relative), dtheta)
        perr = math.sqrt(dp[0] ** 2 + dp[1] ** 2 + dp[2] ** 2)
        aerr = math.sqrt(dtheta[0] ** 2 + dtheta[1] ** 2 + dtheta[2] ** 2)
        dpsi = 0.0
        if hold_angle:
            psi = arm_angle_row(rots, points, axes, angle_points[0], angle_points[1],
                                reference, np.int64(3), angle_row, angle_work)
            dpsi = angle - psi
            dpsi -= 2.0 * math.pi * math.floor((dpsi + math.pi) / (2.0 * math.pi))
            aerr = max(aerr, abs(dpsi))
        converged = perr <= position_tolerance and aerr <= angle_tolerance
        if converged:
            done_q[:] = q
            done_perr, done_aerr, done_it = perr, aerr, it
            if hold_angle or polish == 0 or \
                    np.min(np.minimum(q - lower, upper - q)) >= min_margin:
                break
        history[it] = perr + length_scale * aerr
        if it == max_iterations or (stall_window > 0 and it >= stall_window
                                    and history[it] > STALL_FLOOR
                                    and history[it] > stall_ratio * history[it - stall_window]):
            break
        weighted_jacobian(rots, points, axes, scale, ones, jac[:6])
        for row in range(3):
            err[row] = dp[row]
            err[row + 3] = length_scale * dtheta[row]
        if hold_angle:
            for col in range(n):
                jac[6, col] = length_scale * angle_row[col]
            err[6] = length_scale * dpsi
        energy = 0.5 * (err @ err)
        if converged:  # polish: a pure self-motion step away from the limits
            polish -= 1
            dq = -null_gain * (null_projector(jac, eye) @ ((q - mid) / half**2))
        else:
            if cholesky:
                dq = damped_step(jac, err, energy + damping, normal, step)
            else:
                gram = jac.T @ jac
                for col in range(n):  # + (energy + damping) I, in place
                    gram[col, col] += energy + damping
                dq = np.linalg.solve(gram, jac.T @ err)
            if null_gain != 0.0 and not hold_angle:
                fade = min(1.0, math.sqrt(2.0 * energy) / null_fade)
                dq -= null_gain * fade * (null_projector(jac, eye) @ ((q - mid) / half**2))
        largest = abs(dq[0])
        for col in range(1, n):  # np.max(np.abs(dq)), NaN propagating
            if not abs(dq[col]) <= largest:
                largest = abs(dq[col]) if not math.isnan(largest) else largest
        if largest > max_step:
            dq *= max_step / largest
        for col in range(n):
            q[col] = np.minimum(np.maximum(q[col] + dq[col], lower[col]), upper[col])
    if done_it >= 0:
        return done_q, done_perr, done_aerr, it, True
    return q, perr, aerr, it, False


@njit(cache=True)
def solve_batch(origin_rot, origin_xyz, axis_skew, axis_skew2, tcp_rot, tcp_offset, axes, lower,
                upper, positions, target_rots, seeds, hold_angle, angles, angle_points,
                reference, max_iterations, position_tolerance, angle_tolerance, damping,
                max_step, length_scale, stall_window, stall_ratio, cholesky=False):
    """N independent solves (:func:`solve` without null-space motion or polish): joints
    (N, n) [rad], converged (N,), position (N,) [m] and angle errors (N,) [rad]; ``cholesky``:
    each step by :func:`damped_step` (solutions equal to rounding, not bitwise)."""
    count = positions.shape[0]
    q = np.empty((count, seeds.shape[1]))
    success = np.empty(count, np.bool_)
    perr = np.empty(count)
    aerr = np.empty(count)
    for k in range(count):
        q[k], perr[k], aerr[k], _, success[k] = solve(
            origin_rot, origin_xyz, axis_skew, axis_skew2, tcp_rot, tcp_offset, axes, lower,
            upper, positions[k], target_rots[k], seeds[k], hold_angle, angles[k], angle_points,
            reference, max_iterations, position_tolerance, angle_tolerance, damping, max_step,
            0.0, 0.0, np.int64(0), length_scale, 1.0, stall_window, stall_ratio, cholesky)
    return q, success, perr, aerr
