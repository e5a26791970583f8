"""Kinematics of any serial arm read from a description, placed in the world with a tool:
forward kinematics, the geometric Jacobian, seeded damped-least-squares IK, joint margins and
the world capsules of its links.

Plain numpy, batched over joint vectors: the link frames are ``T_i = T_{i-1} O_i R(a_i, q_i)``
(:class:`~dloplan.robot.description.ArmDescription`), the first origin carrying the arm's base
pose in the world, the TCP fixed in the tip frame. For the YuMi the result equals
:func:`dloplan.robot.kinematics.forward` (tested to 1e-9); :mod:`dloplan.robot.kinematics`
stays the YuMi-specific solver (wrist flips, arm-angle handling).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from . import ik_compiled
from .description import ArmDescription
from .kinematics import LENGTH_SCALE, NULL_FADE, IKOptions, IKResult
from .yumi import DEFAULT_TCP_IN_CLIP, as_vector

STALL_WINDOW = 10
"""Iterations over which a solve must make progress ..."""

STALL_RATIO = 0.99
"""... shrinking the weighted error (position + 0.1 m/rad x angle) below this fraction of its
value STALL_WINDOW iterations before; else the seed is given up (stuck at a limit or in a
local minimum: the next seed is tried rather than spending the remaining iterations)."""


@dataclass(frozen=True, eq=False)
class CellArm:
    """An arm of a cell: its description, where its base stands and its tool.

    Parameters
    ----------
    name : str
        ``"left"`` or ``"right"`` (the arm's place in the cell's per-arm arrays).
    description : ArmDescription
    base_position : array_like
        (3,) the base link's origin in the world [m].
    base_rotation : scipy.spatial.transform.Rotation
        ``base_to_world``.
    tcp_offset : array_like
        (3,) tip(flange)-to-TCP translation [m] in the tip frame.
    tcp_rotation : scipy.spatial.transform.Rotation
        ``tcp_to_tip``.
    tool_radius : float
        Radius [m] of a capsule from the tip to the TCP standing for the tool in the clearance
        checks; 0: the description's own geometry covers the tool.
    home : array_like, optional
        (n,) fallback IK seed [rad]; default the middle of the joint ranges.
    tcp_in_clip : scipy.spatial.transform.Rotation
        The TCP axes in the clip frame (u, v, w): how the tool holds a clip
        (default :data:`~dloplan.robot.yumi.DEFAULT_TCP_IN_CLIP`: approach from above, the cable
        along TCP y, for fingers closing along TCP x).
    max_acceleration : array_like, optional
        (n,) published joint acceleration limits [rad/s^2]; default none (inf): the program's
        ``joint acceleration`` check applies where a limit is given.
    """

    name: str
    description: ArmDescription
    base_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    base_rotation: Rotation = field(default_factory=Rotation.identity)
    tcp_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tcp_rotation: Rotation = field(default_factory=Rotation.identity)
    tool_radius: float = 0.0
    home: np.ndarray | None = None
    tcp_in_clip: Rotation = DEFAULT_TCP_IN_CLIP
    max_acceleration: np.ndarray | None = None

    def __post_init__(self) -> None:
        d = self.description
        n = d.n_joints
        accel = np.full(n, np.inf) if self.max_acceleration is None else \
            np.asarray(self.max_acceleration, dtype=float)
        if accel.shape != (n,) or np.any(~(accel > 0)):
            raise ValueError(f"{self.name}.max_acceleration: expected {n} limits > 0 "
                             f"[rad/s^2], got {self.max_acceleration!r}")
        object.__setattr__(self, "max_acceleration", accel)
        object.__setattr__(self, "base_position",
                           as_vector(self.base_position, f"{self.name}.base_position", 3))
        object.__setattr__(self, "tcp_offset",
                           as_vector(self.tcp_offset, f"{self.name}.tcp_offset", 3))
        for key in ("base_rotation", "tcp_rotation", "tcp_in_clip"):
            value = getattr(self, key)
            if not isinstance(value, Rotation) or not value.single:
                raise ValueError(f"{self.name}.{key}: expected a single scipy Rotation, got "
                                 f"{value!r}")
        if not (np.isfinite(self.tool_radius) and self.tool_radius >= 0):
            raise ValueError(f"{self.name}.tool_radius: expected a number >= 0 [m], got "
                             f"{self.tool_radius!r}")
        home = 0.5 * (d.lower + d.upper) if self.home is None else as_vector(
            self.home, f"{self.name}.home", n)
        if np.any((home < d.lower) | (home > d.upper)):
            raise ValueError(f"{self.name}.home: {home} is outside the joint limits")
        object.__setattr__(self, "home", home)
        base = self.base_rotation.as_matrix()
        rot = d.origin_rot.copy()
        xyz = d.origin_xyz.copy()
        rot[0] = base @ rot[0]
        xyz[0] = base @ xyz[0] + self.base_position
        object.__setattr__(self, "_rot", rot)
        object.__setattr__(self, "_xyz", xyz)
        object.__setattr__(self, "_tcp_rot", d.tip_rot @ self.tcp_rotation.as_matrix())
        skew = np.zeros((n, 3, 3))
        skew[:, [2, 0, 1], [1, 2, 0]] = d.axes
        skew[:, [1, 2, 0], [2, 0, 1]] = -d.axes
        object.__setattr__(self, "_skew", skew)
        object.__setattr__(self, "_skew2", skew @ skew)
        object.__setattr__(self, "_tcp_xyz", d.tip_xyz + d.tip_rot @ self.tcp_offset)
        # Capsules: the description's, then the tool's (tip to TCP, in the last link frame).
        caps, links, radii = d.capsules, d.capsule_link, d.radii
        if self.tool_radius > 0:
            tool = np.array([[d.tip_xyz, self._tcp_xyz]])
            caps = np.concatenate([caps, tool])
            links = np.append(links, n - 1)
            radii = np.append(radii, self.tool_radius)
        object.__setattr__(self, "_caps", caps)
        object.__setattr__(self, "_cap_link", links)
        object.__setattr__(self, "_radii", radii)

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self.description.n_joints

    @property
    def lower(self) -> np.ndarray:
        """(n,) lower joint limits [rad]."""
        return self.description.lower

    @property
    def upper(self) -> np.ndarray:
        """(n,) upper joint limits [rad]."""
        return self.description.upper

    @property
    def max_velocity(self) -> np.ndarray:
        """(n,) joint speed limits [rad/s] (the description's)."""
        return self.description.max_velocity

    @property
    def joint_names(self) -> tuple[str, ...]:
        """(n,) URDF joint names."""
        return self.description.joint_names

    @property
    def shoulder(self) -> np.ndarray:
        """(3,) world origin of the first joint [m]."""
        return self._xyz[0]

    @property
    def reach(self) -> float:
        """Upper bound of the shoulder-to-TCP distance [m]: the sum of the chain's offsets."""
        return float(np.linalg.norm(self._xyz[1:], axis=1).sum()
                     + np.linalg.norm(self._tcp_xyz))


def in_base_frame(arm: CellArm, positions, rotations: Rotation) -> tuple[np.ndarray, np.ndarray]:
    """World TCP poses expressed in the arm's base frame (what a controller is given).

    Parameters
    ----------
    positions : array_like
        (..., 3) [m] in the world.
    rotations : scipy.spatial.transform.Rotation
        ``tcp_to_world``, of the batch shape of ``positions``.

    Returns
    -------
    positions : numpy.ndarray
        (..., 3) [m] in the base frame.
    rotvecs : numpy.ndarray
        (..., 3) ``tcp_to_base`` as rotation vectors [rad] (axis-angle, as URScript's poses).
    """
    inv = arm.base_rotation.inv()
    pos = inv.apply(np.asarray(positions, dtype=float).reshape(-1, 3) - arm.base_position)
    rot = (inv * Rotation.from_matrix(rotations.as_matrix().reshape(-1, 3, 3))).as_rotvec()
    shape = np.shape(positions)
    return pos.reshape(shape), rot.reshape(shape)


def link_frames(arm: CellArm, q) -> tuple[np.ndarray, np.ndarray]:
    """World frames of the n links and the TCP.

    Parameters
    ----------
    arm : CellArm
    q : array_like
        (..., n) joint values [rad].

    Returns
    -------
    rotations : numpy.ndarray
        (..., n + 1, 3, 3) ``link_to_world`` of links 0..n-1, then the TCP.
    positions : numpy.ndarray
        (..., n + 1, 3) link origins [m] (on the joint axes), then the TCP point.
    """
    q = np.asarray(q, dtype=float)
    n = arm.n_joints
    if q.ndim < 1 or q.shape[-1] != n:
        raise ValueError(f"q: expected joint values of shape (..., {n}) for {arm.name}, got "
                         f"{q.shape}")
    batch = q.shape[:-1]
    # Rodrigues: R(a, q) = I + sin q K + (1 - cos q) K^2 with K the cross-product matrix of a.
    sin, cos = np.sin(q)[..., None, None], np.cos(q)[..., None, None]
    turn = np.eye(3) + sin * arm._skew + (1.0 - cos) * arm._skew2
    rot = np.empty(batch + (n + 1, 3, 3))
    pos = np.empty(batch + (n + 1, 3))
    r = np.eye(3)
    p = np.zeros(3)
    for i in range(n):
        p = p + r @ arm._xyz[i]
        r = r @ arm._rot[i] @ turn[..., i, :, :]
        rot[..., i, :, :] = r
        pos[..., i, :] = p
    rot[..., n, :, :] = r @ arm._tcp_rot
    pos[..., n, :] = p + r @ arm._tcp_xyz
    return rot, pos


def forward(arm: CellArm, q) -> tuple[np.ndarray, Rotation]:
    """TCP pose in the world: (..., 3) position [m] and ``tcp_to_world`` rotation."""
    rot, pos = link_frames(arm, q)
    return pos[..., -1, :], Rotation.from_matrix(rot[..., -1, :, :])


def jacobian(arm: CellArm, q) -> np.ndarray:
    """Geometric Jacobian of the TCP in the world, (..., 6, n): column i is
    ``(z_i x (p_tcp - p_i), z_i)`` with z_i joint i's world axis through p_i."""
    return _jacobian(arm, *link_frames(arm, q))


def _jacobian(arm: CellArm, rot: np.ndarray, pos: np.ndarray) -> np.ndarray:
    z = np.einsum("...kij,kj->...ki", rot[..., :-1, :, :], arm.description.axes)
    lever = pos[..., -1:, :] - pos[..., :-1, :]
    return np.concatenate([np.cross(z, lever), z], axis=-1).swapaxes(-1, -2)


def joint_margin(arm: CellArm, q) -> np.ndarray:
    """Distance of the nearest joint to its nearest limit [rad], (...,); negative outside."""
    q = np.asarray(q, dtype=float)
    return np.min(np.minimum(q - arm.lower, arm.upper - q), axis=-1)


def capsules(arm: CellArm, q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World capsules of the arm (description's, then the tool's).

    Parameters
    ----------
    q : array_like
        (..., n) joint values [rad].

    Returns
    -------
    segments : numpy.ndarray
        (..., m, 2, 3) end points [m].
    radii : numpy.ndarray
        (m,) [m].
    links : numpy.ndarray
        (m,) int link index of each capsule (-1: the base link, which does not move).
    """
    rot, pos = link_frames(arm, q)
    links = arm._cap_link
    base_rot = arm.base_rotation.as_matrix()
    # Link -1 (base): world = base pose.
    r = np.where((links < 0)[:, None, None], base_rot, rot[..., np.maximum(links, 0), :, :])
    p = np.where((links < 0)[:, None], arm.base_position, pos[..., np.maximum(links, 0), :])
    ends = np.einsum("...lij,lej->...lei", r, arm._caps) + p[..., None, :]
    return ends, arm._radii, links


def inverse(arm: CellArm, position, rotation: Rotation, seed=None,
            options: IKOptions | None = None, rng: np.random.Generator | None = None) -> IKResult:
    """Joint values placing the TCP at a world pose: damped least squares from a seed.

    The step of Sugihara (2011), ``(J^T J + (E + damping) I) dq = J^T e`` with the error
    ``e = (p* - p, L rotvec(R* R^T))`` (L = :data:`~dloplan.robot.kinematics.LENGTH_SCALE`),
    plus for a redundant arm (n > 6) the null-space pull of the joints toward the middle of
    their ranges (faded out near the target); the step is capped at ``max_step`` and q clipped
    to the limits. Seeds: ``seed``, the arm's home, then ``options.restarts`` random vectors;
    the first converged solution at least ``min_margin`` from the limits is returned (else the
    converged one with the largest margin, else the closest with ``success=False``).

    Parameters
    ----------
    arm : CellArm
    position : array_like
        (3,) target TCP position [m].
    rotation : scipy.spatial.transform.Rotation
        Target ``tcp_to_world``.
    seed : array_like, optional
        (n,) [rad]; default the home pose.
    options : IKOptions, optional
    rng : numpy.random.Generator, optional
        For the restarts; default seeded with 0.
    """
    position = as_vector(position, "position", 3)
    if not isinstance(rotation, Rotation) or not rotation.single:
        raise ValueError(f"rotation: expected a single scipy Rotation, got {rotation!r}")
    seed = arm.home if seed is None else as_vector(seed, "seed", arm.n_joints)
    opts = options if options is not None else IKOptions()
    target = rotation.as_matrix()
    shoulder = float(np.linalg.norm(position - arm.shoulder))
    if shoulder > arm.reach:
        q = np.clip(seed, arm.lower, arm.upper)
        p, r = forward(arm, q)
        return IKResult(q, False, float(np.linalg.norm(position - p)),
                        float((Rotation.from_matrix(target) * r.inv()).magnitude()), 0, 0,
                        f"out of reach: TCP target {shoulder:.3f} m from the shoulder, the arm "
                        f"reaches at most {arm.reach:.3f} m")
    rng = rng if rng is not None else np.random.default_rng(0)
    solves = []  # (q, position error, angle error, iterations, converged, margin)
    for tried in range(2 + opts.restarts):
        start = (seed, arm.home)[tried] if tried < 2 else rng.uniform(arm.lower, arm.upper)
        solves.append((*solve_from(arm, position, target, start, opts), 0.0))
        q, ok = solves[-1][0], solves[-1][4]
        if ok:
            solves[-1] = solves[-1][:5] + (float(joint_margin(arm, q)),)
            if solves[-1][5] >= opts.min_margin:
                break
    total = sum(s[3] for s in solves)
    good = [s for s in solves if s[4]]
    if good:
        q, perr, aerr, _, _, margin = max(good, key=lambda s: s[5])
        note = "converged" if margin >= opts.min_margin else (
            f"converged, {np.degrees(margin):.1f} deg from a joint limit")
        return IKResult(q, True, perr, aerr, total, len(solves), note)
    q, perr, aerr, *_ = min(solves, key=lambda s: s[1] + LENGTH_SCALE * s[2])
    return IKResult(q, False, perr, aerr, total, len(solves),
                    f"not converged from {len(solves)} seeds: position error "
                    f"{perr * 1e3:.2f} mm, orientation error {np.degrees(aerr):.2f} deg")


def rotation_vector(matrix: np.ndarray) -> np.ndarray:
    """Rotation vector [rad] of one 3x3 rotation matrix (the log map), via its unit quaternion
    (Shepperd's method: the largest of w, x, y, z computed first, stable up to pi)."""
    m = matrix
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    k = int(np.argmax([trace, m[0, 0], m[1, 1], m[2, 2]]))
    if k == 0:
        w = 0.5 * np.sqrt(1.0 + trace)
        v = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]]) / (4.0 * w)
    else:
        i = k - 1
        j, l = (i + 1) % 3, (i + 2) % 3
        v = np.empty(3)
        v[i] = 0.5 * np.sqrt(max(1.0 + m[i, i] - m[j, j] - m[l, l], 0.0))
        w = (m[l, j] - m[j, l]) / (4.0 * v[i])
        v[j] = (m[j, i] + m[i, j]) / (4.0 * v[i])
        v[l] = (m[l, i] + m[i, l]) / (4.0 * v[i])
    if w < 0:
        w, v = -w, -v
    norm = float(np.linalg.norm(v))
    if norm < 1e-15:
        return 2.0 * v
    return (2.0 * np.arctan2(norm, w) / norm) * v


def solve_from(arm: CellArm, position, target, seed, opts: IKOptions):
    """Damped least squares from one seed, no fallback seeds and no input checks: (q, position
    error [m], angle error [rad], iterations, ok) for a target position (3,) and
    ``tcp_to_world`` matrix (3, 3); :func:`solve_reference`'s iteration compiled
    (:func:`dloplan.robot.ik_compiled.chain_solve`)."""
    q, perr, aerr, it, ok = ik_compiled.chain_solve(
        arm._rot, arm._xyz, arm._skew, arm._skew2, arm._tcp_rot, arm._tcp_xyz,
        arm.description.axes, arm.lower, arm.upper, np.asarray(position, dtype=float),
        np.ascontiguousarray(target, dtype=float), np.asarray(seed, dtype=float),
        opts.max_iterations, opts.position_tolerance, opts.angle_tolerance, opts.damping,
        opts.max_step, opts.null_gain, LENGTH_SCALE, NULL_FADE, STALL_WINDOW, STALL_RATIO)
    return q, float(perr), float(aerr), int(it), bool(ok)


def solve_reference(arm: CellArm, position, target, seed, opts: IKOptions):
    """Damped least squares from one seed in numpy: (q, position error, angle error,
    iterations, ok); stops when the error stalls (:data:`STALL_WINDOW`, :data:`STALL_RATIO`).
    The readable reference of the compiled solve the IK uses."""
    n = arm.n_joints
    q = np.clip(seed, arm.lower, arm.upper)
    eye = np.eye(n)
    weight = np.array([1.0, 1.0, 1.0, LENGTH_SCALE, LENGTH_SCALE, LENGTH_SCALE])
    mid = 0.5 * (arm.lower + arm.upper)
    half = np.minimum(0.5 * (arm.upper - arm.lower), np.pi)
    redundant = n > 6 and opts.null_gain > 0
    history = []
    for it in range(opts.max_iterations + 1):
        rot, pos = link_frames(arm, q)
        dp = position - pos[-1]
        dtheta = rotation_vector(target @ rot[-1].T)
        perr, aerr = float(np.linalg.norm(dp)), float(np.linalg.norm(dtheta))
        if perr <= opts.position_tolerance and aerr <= opts.angle_tolerance:
            return q, perr, aerr, it, True
        history.append(perr + LENGTH_SCALE * aerr)
        if it == opts.max_iterations or (
                it >= STALL_WINDOW and history[-1] > STALL_RATIO * history[-1 - STALL_WINDOW]):
            break
        jac = _jacobian(arm, rot, pos) * weight[:, None]
        err = np.concatenate([dp, LENGTH_SCALE * dtheta])
        energy = 0.5 * float(err @ err)
        dq = np.linalg.solve(jac.T @ jac + (energy + opts.damping) * eye, jac.T @ err)
        if redundant:
            null = eye - np.linalg.pinv(jac, rcond=1e-8) @ jac
            fade = min(1.0, np.sqrt(2.0 * energy) / NULL_FADE)
            dq -= opts.null_gain * fade * (null @ ((q - mid) / half**2))
        largest = np.max(np.abs(dq))
        if largest > opts.max_step:
            dq *= opts.max_step / largest
        q = np.clip(q + dq, arm.lower, arm.upper)
    return q, perr, aerr, it, False
