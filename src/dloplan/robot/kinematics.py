"""Forward kinematics, Jacobian and damped-least-squares inverse kinematics of one arm: the
one kinematics API of every cell's arms (the YuMi's, the UR5e's, the Panda's, any from URDF).

Plain numpy on the chain of a :class:`~dloplan.robot.chain.CellArm` with n joints: the pose of
link i is ``T_i = T_{i-1} Origin_i Rot(axis_i, q_i)`` (4x4 homogeneous transforms kept as a
rotation matrix and a translation), the first origin carrying the arm's base pose in the world,
the TCP fixed in the last link. All poses are in the WORLD frame. Rotations go through
:class:`scipy.spatial.transform.Rotation`. The IK's solve from one seed runs compiled
(:mod:`dloplan.robot.ik_compiled`; :func:`solve_reference` is its numpy original, which the
tests compare it with): a placement search runs it some 10^4 times. An arm with an arm angle
(the YuMi, :mod:`dloplan.robot.armangle`) can have it held by the IK as a 7th task row.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from . import ik_compiled

LENGTH_SCALE = 0.1
"""Length [m] that weighs an orientation error against a position error in the IK: 1 rad of
orientation error counts like 0.1 m of position error."""

NULL_FADE = 0.01
"""Weighted task error [m] below which the null-space motion fades out linearly."""


@dataclass(frozen=True, eq=False)
class Frames:
    """Link frames of an arm for a batch of joint vectors.

    Attributes
    ----------
    rotations : numpy.ndarray
        (..., n + 1, 3, 3) ``link_to_world`` rotation matrices of links 1..n and of the TCP.
    positions : numpy.ndarray
        (..., n + 1, 3) origins [m] of links 1..n (on the joint axes) and the TCP point.
    """

    rotations: np.ndarray
    positions: np.ndarray


def link_frames(arm, q) -> Frames:
    """World frames of every link and of the TCP.

    Parameters
    ----------
    arm : CellArm
    q : array_like
        (..., n) joint values [rad] (not checked against the limits).
    """
    q = np.asarray(q, dtype=float)
    n = arm.n_joints
    if q.ndim < 1 or q.shape[-1] != n:
        raise ValueError(f"q: expected joint values of shape (..., {n}) for {arm.name}, got "
                         f"{q.shape}")
    batch = q.shape[:-1]
    # Rodrigues: R = I + sin(q) K + (1 - cos(q)) K^2 with K the axis' cross-product matrix
    c, s = np.cos(q)[..., None, None], np.sin(q)[..., None, None]
    turn = np.eye(3) + s * arm._skew + (1.0 - c) * arm._skew2
    if not batch:  # the IK's case: one joint vector, a plain loop over 3x3 products
        joint = arm._rot @ turn
        rots, points = [], []
        r, p = np.eye(3), np.zeros(3)
        for i in range(n):
            p = p + r @ arm._xyz[i]
            r = r @ joint[i]
            rots.append(r)
            points.append(p)
        rots.append(r @ arm._tcp_rot)
        points.append(p + r @ arm._tcp_xyz)
        return Frames(np.array(rots), np.array(points))
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
    return Frames(rot, pos)


def forward(arm, q) -> tuple[np.ndarray, Rotation]:
    """TCP pose in the world frame.

    Parameters
    ----------
    arm : CellArm
    q : array_like
        (..., n) joint values [rad].

    Returns
    -------
    position : numpy.ndarray
        (..., 3) TCP position [m].
    rotation : scipy.spatial.transform.Rotation
        ``tcp_to_world``, of the batch shape of ``q``.
    """
    q = _as_joints(q, "q", arm.n_joints)
    frames = link_frames(arm, q)
    return frames.positions[..., -1, :], Rotation.from_matrix(frames.rotations[..., -1, :, :])


def jacobian(arm, q) -> np.ndarray:
    """Geometric Jacobian of the TCP, world frame.

    Column i is ``(z_i x (p_tcp - p_i), z_i)`` for the revolute joint i with world axis z_i
    through the point p_i.

    Parameters
    ----------
    arm : CellArm
    q : array_like
        (..., n) joint values [rad].

    Returns
    -------
    numpy.ndarray
        (..., 6, n): rows 0-2 TCP linear velocity [m/rad], rows 3-5 angular velocity [1].
    """
    frames = link_frames(arm, np.asarray(q, dtype=float))
    return _jacobian(arm, frames)


def _jacobian(arm, frames: Frames) -> np.ndarray:
    n = arm.n_joints
    z = (frames.rotations[..., :n, :, :] @ arm.axes[:, :, None])[..., 0]
    lever = frames.positions[..., n:n + 1, :] - frames.positions[..., :n, :]
    cross = z[..., [1, 2, 0]] * lever[..., [2, 0, 1]] - z[..., [2, 0, 1]] * lever[..., [1, 2, 0]]
    return np.concatenate([cross, z], axis=-1).swapaxes(-1, -2)


def manipulability(arm, q) -> np.ndarray:
    """Yoshikawa's manipulability sqrt(det(J J^T)) of the full 6 x n Jacobian.

    Zero at a singularity. Mixed units (three rows in metres, three dimensionless) make it
    [m^3]; compare values of the same arm, not across robots.

    Parameters
    ----------
    q : array_like
        (..., n) joint values [rad].
    """
    j = jacobian(arm, q)
    det = np.linalg.det(j @ j.swapaxes(-1, -2))
    return np.sqrt(np.maximum(det, 0.0))


def joint_margin(arm, q) -> np.ndarray:
    """Distance of the nearest joint to its nearest limit [rad], (...,); negative outside."""
    q = np.asarray(q, dtype=float)
    return np.min(np.minimum(q - arm.lower, arm.upper - q), axis=-1)


@dataclass(frozen=True, eq=False)
class IKOptions:
    """Settings of :func:`inverse`.

    Parameters
    ----------
    position_tolerance : float
        Converged when the TCP is this close to the target [m].
    angle_tolerance : float
        ... and its orientation this close [rad].
    max_iterations : int
        Iterations per seed.
    damping : float
        Floor of the Levenberg-Marquardt damping [m^2] (Sugihara's W_N = E + damping).
    max_step : float
        Largest joint change per iteration [rad].
    null_gain : float
        Gain [rad^2] of the null-space motion that pulls the joints toward the middle of their
        ranges (moves only the redundant self-motion, i.e. the elbow).
    restarts : int
        Random seeds tried after the given seed, the home pose and their wrist flips.
    min_margin : float
        A converged solution closer than this to a joint limit [rad] is first polished (up to
        ``polish`` null-space steps, each re-converged), then sends the search on to the next
        seed; the converged solution with the largest margin is returned.
    polish : int
        Null-space steps allowed per solve to move a converged solution off a limit.
    """

    position_tolerance: float = 1e-5
    angle_tolerance: float = 1e-5
    max_iterations: int = 100
    damping: float = 1e-6
    max_step: float = 0.4
    null_gain: float = 0.05
    restarts: int = 4
    min_margin: float = 0.0
    polish: int = 20

    def __post_init__(self) -> None:
        if not (np.isfinite(self.min_margin) and self.min_margin >= 0):
            raise ValueError(f"IKOptions.min_margin: expected >= 0, got {self.min_margin!r}")
        for key in ("position_tolerance", "angle_tolerance", "damping", "max_step"):
            value = getattr(self, key)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"IKOptions.{key}: expected a positive number, got {value!r}")
        if not (np.isfinite(self.null_gain) and self.null_gain >= 0):
            raise ValueError(f"IKOptions.null_gain: expected >= 0, got {self.null_gain!r}")
        if int(self.max_iterations) < 1 or int(self.restarts) < 0 or int(self.polish) < 0:
            raise ValueError(
                f"IKOptions: max_iterations >= 1, restarts >= 0, polish >= 0 expected, got "
                f"{self.max_iterations!r}, {self.restarts!r}, {self.polish!r}"
            )


@dataclass(frozen=True, eq=False)
class IKResult:
    """Outcome of :func:`inverse`.

    Attributes
    ----------
    q : numpy.ndarray
        (n,) joint values [rad], always within the limits (the best found if not converged).
    success : bool
        Converged within the tolerances.
    position_error : float
        Remaining TCP position error [m].
    angle_error : float
        Remaining TCP orientation error [rad].
    iterations : int
        Iterations over all seeds tried.
    seeds_tried : int
        1 when the given seed converged.
    message : str
    """

    q: np.ndarray
    success: bool
    position_error: float
    angle_error: float
    iterations: int
    seeds_tried: int
    message: str


def inverse(arm, position, rotation: Rotation | np.ndarray, seed=None,
            options: IKOptions | None = None, rng: np.random.Generator | None = None,
            arm_angle: float | None = None) -> IKResult:
    """Joint values placing the TCP at a world pose: damped least squares from a seed.

    Each iteration solves the Levenberg-Marquardt step of Sugihara (2011)
    ``(J^T J + (E + damping) I) dq = J^T e`` with ``e = (p* - p, L * rotvec(R* R^T))``,
    ``E = |e|^2 / 2`` and J the Jacobian with its angular rows scaled by L (:data:`LENGTH_SCALE`),
    adds the null-space motion ``-null_gain (I - J^+ J) grad H`` of
    ``H = 1/2 sum ((q - mid) / half_range)^2`` (keeps the redundant elbow away from its
    limits), limits the step to ``max_step`` and clips q into the joint limits. The damping grows
    with the error, so far from the target the step is a short gradient step and close to it a
    Gauss-Newton step (quadratic convergence). When the seed does not converge (or converges
    closer than ``min_margin`` to a limit), its wrist flip, the home pose, its wrist flip and then
    ``restarts`` random joint vectors are tried; an unreachable pose returns the result with the
    smallest error and ``success=False``, never an exception.

    Parameters
    ----------
    arm : CellArm
    position : array_like
        (3,) target TCP position in the world [m].
    rotation : scipy.spatial.transform.Rotation or numpy.ndarray
        Target ``tcp_to_world`` (single), or its (3, 3) matrix, used as given (a loop over
        many targets takes the matrices of one batch ``Rotation``: ``as_matrix()`` of the
        batch is row for row that of each single one, without a ``Rotation`` per target).
    seed : array_like, optional
        (n,) start [rad] (clipped into the limits); default the arm's home pose.
    options : IKOptions, optional
    rng : numpy.random.Generator, optional
        For the random restarts; default a generator seeded with 0 (deterministic).
    arm_angle : float, optional
        Hold the arm angle psi (:mod:`dloplan.robot.armangle`, the controller's ``eax_a``) at
        this value [rad], as the controller does with a robtarget: psi is a 7th task row, the
        7x7 task has finitely many solutions, so from a seed on the right branch the IK returns
        that branch's solution (no null-space motion).
    """
    position = np.asarray(position, dtype=float)
    if position.shape != (3,) or not np.all(np.isfinite(position)):
        raise ValueError(f"position: expected 3 finite numbers [m], got {position!r}")
    if isinstance(rotation, Rotation) and rotation.single:
        matrix = rotation.as_matrix()
    elif isinstance(rotation, np.ndarray) and rotation.shape == (3, 3) and \
            np.all(np.isfinite(rotation)):
        matrix = rotation
    else:
        raise ValueError(f"rotation: expected a single scipy Rotation or a (3, 3) rotation "
                         f"matrix, got {rotation!r}")
    seed = arm.home if seed is None else _as_joints(seed, "seed", arm.n_joints)
    if seed.ndim != 1:
        raise ValueError(f"seed: expected {arm.n_joints} joint values [rad], got shape "
                         f"{seed.shape}")
    opts = options if options is not None else IKOptions()
    if arm_angle is not None and not np.isfinite(arm_angle):
        raise ValueError(f"arm_angle: expected a finite angle [rad], got {arm_angle!r}")
    if arm_angle is not None and arm.arm_angle_reference is None:
        raise ValueError(f"arm_angle: the {arm.name} arm has no arm angle (only a 7-joint arm "
                         "with an arm_angle_reference)")
    return _inverse(arm, position, matrix, seed, opts, rng, arm_angle)


def solve_from(arm, position, rotation_matrix, seed, options: IKOptions,
               arm_angle: float | None = None) -> IKResult:
    """One damped-least-squares solve from one seed, no fallback seeds and no input checks:
    the step of a tracking loop (each sub-step seeded with the previous solution).

    Parameters
    ----------
    arm : CellArm
    position : numpy.ndarray
        (3,) target TCP position [m].
    rotation_matrix : numpy.ndarray
        (3, 3) target ``tcp_to_world``.
    seed : numpy.ndarray
        (n,) start [rad].
    options : IKOptions
    arm_angle : float, optional
        Hold the arm angle psi at this value [rad] (see :func:`inverse`).
    """
    q, perr, aerr, its, ok = _solve(arm, position, rotation_matrix, seed, options, arm_angle)
    return IKResult(q, ok, perr, aerr, its, 1, "converged" if ok else
                    f"not converged: position error {perr * 1e3:.2f} mm, orientation error "
                    f"{np.degrees(aerr):.2f} deg")


STALL_WINDOW = 10
"""Iterations over which a solve must make progress (every solve of :func:`inverse` and
:func:`solve_from`; :func:`solve_many` with ``give_up``) ..."""

STALL_RATIO = 0.99
"""... shrinking the weighted error (position + 0.1 m/rad x angle) below this fraction of its
value STALL_WINDOW iterations before, unless it is already below
:data:`~dloplan.robot.ik_compiled.STALL_FLOOR`; else the seed is given up (stuck at a limit or
in a local minimum: the next seed is tried)."""


def solve_many(arm, positions, rotation_matrices, seeds, options: IKOptions,
               arm_angles=None, give_up: bool = False, cholesky: bool = False
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Many independent damped-least-squares solves at once, each from its own seed.

    The step of :func:`inverse` (Levenberg-Marquardt with Sugihara's damping, steps limited to
    ``max_step``, joints clipped into the limits) for N problems, each stopping when it
    converges (compiled: :func:`dloplan.robot.ik_compiled.solve_batch`); no null-space motion
    and no fallback seeds. Meant for tracking with the arm angle held (then the task has no
    redundancy left), e.g. many candidate arm angles or many moves advanced by one sub-step
    together.

    Parameters
    ----------
    arm : CellArm
    positions : numpy.ndarray
        (N, 3) target TCP positions [m].
    rotation_matrices : numpy.ndarray
        (N, 3, 3) target ``tcp_to_world``.
    seeds : numpy.ndarray
        (N, n) starts [rad].
    options : IKOptions
    arm_angles : numpy.ndarray, optional
        (N,) hold the arm angle psi at these values [rad] (see :func:`inverse`).
    give_up : bool
        Stop a solve whose error stalls (:data:`STALL_WINDOW`, :data:`STALL_RATIO`): for
        enumerating solutions from many seeds, most of which lead nowhere.
    cholesky : bool
        Each step by a hand-written Cholesky solve of the damped normal equations
        (:func:`dloplan.robot.ik_compiled.damped_step`) instead of LAPACK: about a third less
        time per iteration, the same steps to rounding (not bitwise): for finding which
        solutions there are (:mod:`dloplan.robot.robtarget`).

    Returns
    -------
    q : numpy.ndarray
        (N, n) joint values [rad].
    success : numpy.ndarray
        (N,) bool, converged within the tolerances.
    position_error, angle_error : numpy.ndarray
        (N,) remaining TCP errors [m], [rad].
    """
    positions = np.ascontiguousarray(positions, dtype=float)
    n = len(positions)
    held = np.zeros(n) if arm_angles is None else np.broadcast_to(
        np.asarray(arm_angles, dtype=float), (n,)).copy()
    return ik_compiled.solve_batch(
        *_compiled_chain(arm), positions, np.ascontiguousarray(rotation_matrices, dtype=float),
        np.ascontiguousarray(seeds, dtype=float), arm_angles is not None, held,
        *_angle_geometry(arm), options.max_iterations, options.position_tolerance,
        options.angle_tolerance, options.damping, options.max_step, LENGTH_SCALE,
        STALL_WINDOW if give_up else 0, STALL_RATIO, cholesky)


def _compiled_chain(arm) -> tuple:
    """The arm's chain as :mod:`dloplan.robot.ik_compiled` takes it: origin rotations and
    points, the axes' cross-product matrices and their squares, the TCP rotation and offset in
    the last link, the unit axes and the joint limits."""
    return (arm._rot, arm._xyz, arm._skew, arm._skew2, arm._tcp_rot, arm._tcp_xyz, arm.axes,
            arm.lower, arm.upper)


def _angle_geometry(arm) -> tuple[np.ndarray, np.ndarray]:
    """What the compiled solve needs of the arm angle: the feet (s, w) [m] of its shoulder and
    wrist points and the reference direction in the world (:mod:`dloplan.robot.armangle`);
    zeros for an arm without one (never held)."""
    if arm.arm_angle_reference is None:
        return np.zeros(2), np.array([0.0, 0.0, 1.0])
    return arm._angle_points, arm.world_arm_angle_reference


FIXED_SEEDS = 4
"""The seeds :func:`inverse` tries before its random restarts: the given one, its wrist flip
(:func:`wrist_flip`), the home pose and its wrist flip."""


def _inverse(arm, position: np.ndarray, target_rot: np.ndarray, seed: np.ndarray,
             opts: IKOptions, rng: np.random.Generator | None,
             arm_angle: float | None = None) -> IKResult:
    """:func:`inverse` without input checks (target rotation as a matrix)."""
    distance = float(np.linalg.norm(position - arm.shoulder))
    if distance > arm.reach:
        q = np.clip(seed, arm.lower, arm.upper)
        frames = link_frames(arm, q)
        perr = float(np.linalg.norm(position - frames.positions[-1]))
        aerr = float(Rotation.from_matrix(target_rot @ frames.rotations[-1].T).magnitude())
        return IKResult(q, False, perr, aerr, 0, 0,
                        f"out of reach: TCP target {distance:.3f} m from the shoulder, the arm "
                        f"reaches at most {arm.reach:.3f} m")
    best = converged = None
    total = tried = 0
    start = seed
    while tried < FIXED_SEEDS + opts.restarts:
        if tried < FIXED_SEEDS:  # a wrist flip made only when the seed before it is not enough
            start = (seed, arm.home)[tried // 2] if tried % 2 == 0 else wrist_flip(arm, start)
        else:
            rng = rng if rng is not None else np.random.default_rng(0)
            start = rng.uniform(arm.lower, arm.upper)
        tried += 1
        q, perr, aerr, its, ok = _solve(arm, position, target_rot, start, opts, arm_angle)
        total += its
        if ok:
            margin = float(joint_margin(arm, q))
            if converged is None or margin > converged[0]:
                converged = (margin, q, perr, aerr)
            if margin >= opts.min_margin:
                break
        elif converged is None:
            score = perr + LENGTH_SCALE * aerr
            if best is None or score < best[0]:
                best = (score, q, perr, aerr)
    if converged is not None:
        margin, q, perr, aerr = converged
        message = "converged" if margin >= opts.min_margin else (
            f"converged, but {np.degrees(margin):.1f} deg from a joint limit "
            f"(wanted {np.degrees(opts.min_margin):.1f})")
        return IKResult(q, True, perr, aerr, total, tried, message)
    _, q, perr, aerr = best
    message = (f"not converged from {tried} seeds: position error {perr * 1e3:.2f} mm, "
               f"orientation error {np.degrees(aerr):.2f} deg")
    return IKResult(q, False, perr, aerr, total, tried, message)


def wrist_flip(arm, q) -> np.ndarray:
    """The other wrist configuration as a seed: the last three joints' first and last turned by
    pi, the middle one negated (the YuMi's ABB axes 4, 6 and 5; a UR's wrists 1, 3 and 2).

    Exact for a spherical wrist; the YuMi's wrist has small offsets, so it is a seed for the IK,
    not a solution. Turns go the way that stays within the limits; the result is clipped.
    """
    flipped = np.array(q, dtype=float)
    n = len(flipped)
    for i in (n - 3, n - 1):
        flipped[i] += np.pi if flipped[i] + np.pi <= arm.upper[i] else -np.pi
    flipped[n - 2] = -flipped[n - 2]
    return np.clip(flipped, arm.lower, arm.upper)


def _solve(arm, position, target_rot, seed, opts: IKOptions,
           arm_angle: float | None = None):
    """Damped least squares from one seed: (q, position error, angle error, iterations, ok).

    :func:`solve_reference`'s iteration compiled (:func:`dloplan.robot.ik_compiled.solve`).
    """
    redundant = arm.n_joints > 6 and arm_angle is None
    polish = opts.polish if opts.min_margin > 0 and redundant else 0
    q, perr, aerr, it, ok = ik_compiled.solve(  # contiguous: one compiled overload
        *_compiled_chain(arm), np.ascontiguousarray(position, dtype=float),
        np.ascontiguousarray(target_rot, dtype=float),
        np.ascontiguousarray(seed, dtype=float), arm_angle is not None,
        0.0 if arm_angle is None else float(arm_angle), *_angle_geometry(arm),
        opts.max_iterations, opts.position_tolerance, opts.angle_tolerance, opts.damping,
        opts.max_step, opts.null_gain if redundant else 0.0, opts.min_margin, polish,
        LENGTH_SCALE, NULL_FADE, STALL_WINDOW, STALL_RATIO, False)  # cholesky: as the batch's
    return q, float(perr), float(aerr), int(it), bool(ok)


def solve_reference(arm, position, target_rot, seed, opts: IKOptions, give_up: bool = True):
    """Damped least squares from one seed in numpy: (q, position error, angle error,
    iterations, ok); the readable reference of the compiled solve the IK uses (with the arm
    angle held: :func:`dloplan.robot.armangle.solve_reference`).

    For a redundant arm (n > 6) the null-space motion pulls the joints toward the middle of
    their ranges, and once converged closer than ``min_margin`` to a limit, up to ``polish``
    null-space steps (each followed by re-convergence) move the redundant elbow away; the last
    converged q is returned. With ``give_up`` (as in :func:`solve_from`; not in
    :func:`solve_many`'s tracking) the seed is given up when its error stalls
    (:data:`STALL_WINDOW`, :data:`STALL_RATIO`).
    """
    n = arm.n_joints
    redundant = n > 6
    q = np.clip(seed, arm.lower, arm.upper)
    half = 0.5 * (arm.upper - arm.lower)
    eye = np.eye(n)
    scale = np.array([1.0, 1.0, 1.0, LENGTH_SCALE, LENGTH_SCALE, LENGTH_SCALE])
    polish = opts.polish if opts.min_margin > 0 and redundant else 0
    null_gain = opts.null_gain if redundant else 0.0
    done = None
    history = []
    for it in range(opts.max_iterations + 1):
        frames = link_frames(arm, q)
        dp = position - frames.positions[-1]
        dtheta = rotation_log(target_rot @ frames.rotations[-1].T)
        perr, aerr = float(np.linalg.norm(dp)), float(np.linalg.norm(dtheta))
        converged = perr <= opts.position_tolerance and aerr <= opts.angle_tolerance
        if converged:
            done = (q, perr, aerr, it)
            if polish == 0 or joint_margin(arm, q) >= opts.min_margin:
                break
        history.append(perr + LENGTH_SCALE * aerr)
        if it == opts.max_iterations or (
                give_up and it >= STALL_WINDOW and history[-1] > ik_compiled.STALL_FLOOR
                and history[-1] > STALL_RATIO * history[-1 - STALL_WINDOW]):
            break
        jac = _jacobian(arm, frames) * scale[:, None]
        err = np.concatenate([dp, LENGTH_SCALE * dtheta])
        energy = 0.5 * float(err @ err)
        grad = (q - arm.mid) / half**2
        # null-space projector I - J^+ J, J^+ = J^T (J J^T)^-1 (J has full row rank away
        # from singularities; pinv's truncation where it has not)
        try:
            null = eye - jac.T @ np.linalg.solve(jac @ jac.T, jac)
        except np.linalg.LinAlgError:
            null = eye - np.linalg.pinv(jac, rcond=1e-8) @ jac
        if converged:  # polish: a pure self-motion step away from the limits
            polish -= 1
            dq = -null_gain * (null @ grad)
        else:
            dq = np.linalg.solve(jac.T @ jac + (energy + opts.damping) * eye, jac.T @ err)
            if null_gain:
                # Faded out as the task error vanishes: its second-order effect on the TCP
                # must not keep the task from converging to the tolerance.
                fade = min(1.0, np.sqrt(2.0 * energy) / NULL_FADE)
                dq -= null_gain * fade * (null @ grad)
        largest = np.max(np.abs(dq))
        if largest > opts.max_step:
            dq *= opts.max_step / largest
        q = np.clip(q + dq, arm.lower, arm.upper)
    if done is not None:
        return done[0], done[1], done[2], it, True
    return q, perr, aerr, it, False


def rotation_log(m) -> np.ndarray:
    """Rotation vectors [rad] of rotation matrices (the logarithm map), (..., 3, 3) -> (..., 3).

    Closed form, robust at 0 and pi: ``theta = arccos((tr m - 1) / 2)``; the axis from the
    skew part of m, or near pi (where the skew part vanishes) from the largest column of
    ``(m + I) / 2 = a a^T``, signed by the skew part. The result of scipy's ``as_rotvec``
    without its per-call overhead (the IK calls it every iteration).
    """
    m = np.asarray(m, dtype=float)
    if m.ndim == 2:  # the single-solve case: plain floats, no array overhead
        skew = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
        angle = float(np.arccos(min(1.0, max(-1.0, 0.5 * (m[0, 0] + m[1, 1] + m[2, 2] - 1.0)))))
        if angle < 1e-6:
            return 0.5 * skew
        if angle <= np.pi - 1e-3:
            return angle / (2.0 * np.sin(angle)) * skew
    skew = np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0],
                     m[..., 1, 0] - m[..., 0, 1]], axis=-1)
    cos = np.clip(0.5 * (m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2] - 1.0), -1.0, 1.0)
    angle = np.arccos(cos)
    small = angle < 1e-6
    near_pi = angle > np.pi - 1e-3
    sin = np.where(small | near_pi, 1.0, np.sin(angle))
    out = np.where(small, 0.5, angle / (2.0 * sin))[..., None] * skew
    for index in map(tuple, np.argwhere(near_pi)):
        outer = 0.5 * (m[index] + np.eye(3))
        k = int(np.argmax(np.diag(outer)))
        axis = outer[:, k] / np.linalg.norm(outer[:, k])
        out[index] = angle[index] * (axis if axis @ skew[index] >= 0 else -axis)
    return out


def _as_joints(q, name: str, n: int) -> np.ndarray:
    arr = np.asarray(q, dtype=float)
    if arr.ndim < 1 or arr.shape[-1] != n or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite joint values of shape (..., {n}), got {q!r}")
    return arr
