"""The arm angle of a YuMi arm: RobotWare's redundancy parameter, a robtarget's ``eax_a``.

From RobotWare 6 on, the IRB 14000 controller reads a robtarget's first external axis value as
the **arm angle** psi, the shoulder-elbow-wrist (SEW) angle of the arm, not as the joint value
of ABB axis 7. Its definition (Elias & Wen, "Redundancy Parameterization of the ABB YuMi Robot
Arm", 2025, the SEW angle with the shoulder-elbow direction taken along the elbow's axis;
public code and RobotStudio comparison in rpiRobotics/yumi-ik)::

    psi = atan2(-e_r . [e]x^2 h,  e_r . [e]x h)          [e]x v = e x v

with

- ``e = (W - S) / |W - S|`` the shoulder-to-wrist direction, S the **shoulder point** (the
  point of axis 1 nearest axis 2) and W the **wrist point** (the point of the last axis, ABB
  axis 6, nearest ABB axis 5),
- ``h`` the axis of ABB axis 3 (the elbow; the 4th joint in physical order),
- ``e_r`` the reference direction (the controller's "Arm-Angle Reference Direction"), a unit
  vector fixed in the robot's base frame (:attr:`dloplan.robot.yumi.Arm.arm_angle_reference`).

psi is the angle, about e, from the direction ``-[e]x^2 e_r`` (e_r's part normal to e) to the
elbow axis' part normal to e, turned by 90 deg. It is undefined where e is parallel to e_r or
to h (the algorithmic singularities of the parameterization).

The same definition with this chain reproduces RobotStudio's arm angles of 10 joint vectors
for both reference directions of rpiRobotics/yumi-ik's ``unit_tests/compare_to_robotstudio.m``
to 0.005 deg (tests/test_robot_armangle.py; the data in tests/data).
"""

from __future__ import annotations

import numpy as np

from .chain import CellArm
from .ik_compiled import STALL_FLOOR
from .kinematics import (
    LENGTH_SCALE,
    STALL_RATIO,
    STALL_WINDOW,
    jacobian,
    link_frames,
    rotation_log,
)

ELBOW_JOINT = 3
"""Physical index of ABB axis 3, whose axis is the elbow direction h."""


def wrap(angle):
    """Angles [rad] wrapped into (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(angle, dtype=float), 2.0 * np.pi)


def _parts(arm: CellArm, frames):
    """S, W, h, e_r in the world from link frames (..., 8, ...)."""
    s, w = arm._angle_points  # the feet of S and W on their axes (yumi.axis_feet)
    z = np.einsum("...kij,kj->...ki", frames.rotations[..., :7, :, :], arm.axes)
    shoulder = frames.positions[..., 0, :] + s * z[..., 0, :]
    wrist = frames.positions[..., 6, :] + w * z[..., 6, :]
    reference = arm.world_arm_angle_reference
    return shoulder, wrist, z, reference


def arm_angle(arm: CellArm, q) -> np.ndarray:
    """The arm angle psi [rad] in (-pi, pi] of joint vectors (module docstring).

    Parameters
    ----------
    arm : CellArm
    q : array_like
        (..., 7) joint values [rad], physical order (ABB 1, 2, 7, 3, 4, 5, 6).

    Returns
    -------
    numpy.ndarray
        (...,) psi [rad].
    """
    frames = link_frames(arm, np.asarray(q, dtype=float))
    shoulder, wrist, z, e_r = _parts(arm, frames)
    e = wrist - shoulder
    e = e / np.linalg.norm(e, axis=-1, keepdims=True)
    h = z[..., ELBOW_JOINT, :]
    x = np.einsum("...i,...i", np.cross(e, h), e_r)
    y = h @ e_r - (e @ e_r) * np.einsum("...i,...i", e, h)
    return np.arctan2(y, x)


def arm_angle_jacobian(arm: CellArm, q) -> np.ndarray:
    """d psi / d q [1], (7,), of one joint vector: the derivative of the module docstring's
    formula with ``dW/dq_i = z_i x (W - p_i)``, ``dh/dq_i = z_i x h`` (joints before the
    elbow) and ``de = (I - e e^T) dW / |W - S|`` (S lies on axis 1 and does not move)."""
    frames = link_frames(arm, np.asarray(q, dtype=float))
    shoulder, wrist, z, e_r = _parts(arm, frames)
    length = float(np.linalg.norm(wrist - shoulder))
    e = (wrist - shoulder) / length
    h = z[ELBOW_JOINT]
    x = float(np.cross(e, h) @ e_r)
    y = float(h @ e_r - (e @ e_r) * (e @ h))
    d_wrist = np.cross(z, wrist - frames.positions[:7])  # (7, 3)
    d_e = (d_wrist - np.outer(d_wrist @ e, e)) / length
    d_h = np.zeros((7, 3))
    d_h[:ELBOW_JOINT] = np.cross(z[:ELBOW_JOINT], h)
    dx = np.cross(d_e, h) @ e_r + np.cross(e, d_h) @ e_r
    dy = d_h @ e_r - (d_e @ e_r) * (e @ h) - (e @ e_r) * (d_e @ h + d_h @ e)
    return (x * dy - y * dx) / (x * x + y * y)


def solve_reference(arm: CellArm, position, target_rot, seed, opts, psi: float,
                    give_up: bool = True):
    """Damped least squares from one seed with the arm angle held at ``psi`` [rad], in numpy:
    (q, position error [m], angle error [rad], iterations, ok); the readable reference of the
    compiled solve (:func:`dloplan.robot.ik_compiled.solve` with ``hold_angle``).

    The task is 7-D, ``e = (p* - p, L log(R* R^T), L wrap(psi - psi(q)))`` with L =
    :data:`~dloplan.robot.kinematics.LENGTH_SCALE`, its 7x7 Jacobian the TCP's (angular rows
    times L) over L d psi / dq; Sugihara's step ``(J^T J + (E + damping) I) dq = J^T e``
    limited to ``max_step`` and clipped into the limits. The angle error is the larger of the
    orientation and the arm angle error. With ``give_up`` the seed is given up when its error
    stalls, as :func:`dloplan.robot.kinematics.solve_reference`.
    """
    q = np.clip(np.asarray(seed, dtype=float), arm.lower, arm.upper)
    scale = np.array([1.0, 1.0, 1.0] + [LENGTH_SCALE] * 4)
    perr = aerr = 0.0
    it = 0
    history = []
    for it in range(opts.max_iterations + 1):
        frames = link_frames(arm, q)
        dp = position - frames.positions[7]
        dtheta = rotation_log(target_rot @ frames.rotations[7].T)
        dpsi = float(wrap(psi - arm_angle(arm, q)))
        perr = float(np.linalg.norm(dp))
        aerr = max(float(np.linalg.norm(dtheta)), abs(dpsi))
        if perr <= opts.position_tolerance and aerr <= opts.angle_tolerance:
            return q, perr, aerr, it, True
        history.append(perr + LENGTH_SCALE * aerr)
        if it == opts.max_iterations or (
                give_up and it >= STALL_WINDOW and history[-1] > STALL_FLOOR
                and history[-1] > STALL_RATIO * history[-1 - STALL_WINDOW]):
            break
        jac = np.vstack([jacobian(arm, q), arm_angle_jacobian(arm, q)]) * scale[:, None]
        err = np.concatenate([dp, dtheta, [dpsi]]) * scale
        energy = 0.5 * float(err @ err)
        dq = np.linalg.solve(jac.T @ jac + (energy + opts.damping) * np.eye(7), jac.T @ err)
        largest = np.max(np.abs(dq))
        if largest > opts.max_step:
            dq *= opts.max_step / largest
        q = np.clip(q + dq, arm.lower, arm.upper)
    return q, perr, aerr, it, False
