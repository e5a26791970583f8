"""The time stepping of eq. 3.24 (and its implicit variant), compiled: a chunk of steps in one call.

One step of the semi-implicit Euler scheme (thesis 3.8) with the fictitious damping k_d::

    a = (F(x) - k_d D(v)) / m,    v <- v + a dt,    x <- x + v dt

with D(v) = v (the thesis' absolute damping) or the graph Laplacian of v (relative damping:
dashpots between neighbouring points); then the four held points are put where the clips hold
them (their velocity is the clips'), an optional ground plane z = 0 and obstacles (pegs, plates,
boxes, the table: :func:`dloplan.physics.contact_compiled.push_out`) are one-sided. The force
F = -dU/dx comes from :func:`dloplan.physics.compiled.chain_gradient`, plus an optional external
gradient held fixed over the call. With torsion, :func:`twist_steps` relaxes the quasi-static
twist angles before every step (:class:`dloplan.sim.torsion.QuasiStaticTwist`) and adds their
twisting force, also without Python per step.

:func:`explicit_steps` runs the steps of one chunk of clip targets (the held points at each
step, :func:`held_targets`), records shapes at the recording interval, and stops early at rest
or when the state diverges: no Python per step.
:func:`implicit_steps` does the same by linearly implicit Euler (a banded solve per step; the
contacts held through the step by the statics' penalty). :func:`dloplan.sim.dynamics.simulate`
drives them.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from ..physics.compiled import chain_derivatives, chain_gradient
from ..physics.contact_compiled import point_distance, push_out
from ..physics.twist_compiled import carry_directors, link_tangents, twist_load, twist_stencils
from .contact_newton import add_penalty
from .newton import cholesky_band, cholesky_solve

RUNNING, SETTLED, DIVERGED, INDEFINITE = 0, 1, 2, 3

FREE, SLIDE, STICK = 0, 1, 2
"""States of a point's contact in an implicit step (:func:`implicit_steps`)."""

HOLD_MARGIN = 1e-9
"""A free point closer to an obstacle than the cable's radius times (1 + this) at the start of
an implicit step is in contact through the step (:func:`implicit_steps`); the explicit scheme's
hard contact leaves a pressing point exactly at the radius."""

LOOK_AHEAD = 2.0
"""A free point within this many times its own step, dt (|v| + dt |g|), of an obstacle at the
start of an implicit step may reach it during the step: it is held in the solve unless the
contact would pull (:func:`implicit_steps`)."""

HOLD_STIFFNESS = 1e4
"""The implicit step's contact stiffness k_c in units of the stiffer of a point's inertia over
the step, max m_i / dt^2, and the axial springs k_s: a pressing point moves into the obstacle
by 1e-4 of what it would move free (and the hard contact puts it back), whatever the step and
the (fictitious) modulus; the statics' penalty of :mod:`dloplan.physics.contact`, 100 E A / l,
would be softer than the inertia of a capped cable's point at 1 ms."""


@njit(cache=True, inline="always")
def _record(x, v, accel, step, dt, record_every, rest_speed, clips_stop, times, shapes, speeds,
            n_records):
    """Record the state of ``step``; returns ``(n_records, at rest)``: the clips have stopped
    and every point is slower than ``rest_speed`` and not about to speed up within a record
    interval (its acceleration times the interval)."""
    n_points = x.shape[0]
    speed = 0.0
    for i in range(n_points):
        speed = max(speed, math.sqrt(v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2))
    times[n_records] = step * dt
    shapes[n_records] = x
    speeds[n_records] = speed
    pull = 0.0
    for i in range(2, n_points - 2):
        pull = max(pull, math.sqrt(accel[i, 0] ** 2 + accel[i, 1] ** 2 + accel[i, 2] ** 2))
    pull *= record_every * dt
    at_rest = rest_speed >= 0.0 and step * dt >= clips_stop and max(speed, pull) < rest_speed
    return n_records + 1, at_rest


@njit(cache=True, inline="always")
def _keep_out(x, v, accel, ground, obstacles, radius, friction):
    """The one-sided contacts after a step: the free points of x, v, accel (n + 1, 3) put out
    of the obstacle rows (:func:`dloplan.physics.contact_compiled.push_out`, which passes over
    the obstacles out of the points' reach, and the points out of an obstacle's) and, with
    ``ground``, above the plane z = 0 with no downward speed."""
    n_points = x.shape[0]
    if obstacles.shape[0] > 0:
        push_out(x, v, accel, obstacles, radius, friction, np.int64(2), n_points - 2)
    if ground:
        for i in range(n_points):
            if x[i, 2] < 0.0:
                x[i, 2] = 0.0
                v[i, 2] = max(v[i, 2], 0.0)


@njit(cache=True)
def held_targets(key_times, key_positions, key_quaternions, times, link_length, out):
    """The four held points at the steps of a chunk: ``out`` (M, 4, 3) [m] at ``times`` (M,)
    [s], non-decreasing.

    The clip poses at the keys, ``key_times`` (K,) [s] strictly increasing, ``key_positions``
    (K, 2, 3) [m] and ``key_quaternions`` (K, 2, 4) unit ``clip_to_world`` quaternions (x, y,
    z, w), interpolated as :meth:`dloplan.sim.dynamics.ClipTrajectory.poses_at` does (linear
    in position, :func:`dloplan.frames.slerp_quaternions` in rotation, held before the first
    key and after the last), and the held points of
    :func:`dloplan.sim.dynamics.held_points_at` (the middles of end links of length
    ``link_length`` [m] at the clip points, along the clips' x-axes): the same arithmetic in
    the same order, point by point, without the arrays numpy makes per chunk of steps.
    """
    last = key_times.shape[0] - 1
    half = 0.5 * link_length
    k = 0
    f = 0.0
    for m in range(times.shape[0]):
        t = min(max(times[m], key_times[0]), key_times[last])
        if last > 0:  # the key at or before t (the last but one at the end)
            while k < last - 1 and key_times[k + 1] <= t:
                k += 1
            f = (t - key_times[k]) / (key_times[k + 1] - key_times[k])
        for c in range(2):
            if last == 0:
                p = (key_positions[0, c, 0], key_positions[0, c, 1], key_positions[0, c, 2])
                q = (key_quaternions[0, c, 0], key_quaternions[0, c, 1],
                     key_quaternions[0, c, 2], key_quaternions[0, c, 3])
            else:
                p = ((1.0 - f) * key_positions[k, c, 0] + f * key_positions[k + 1, c, 0],
                     (1.0 - f) * key_positions[k, c, 1] + f * key_positions[k + 1, c, 1],
                     (1.0 - f) * key_positions[k, c, 2] + f * key_positions[k + 1, c, 2])
                q = _slerp(key_quaternions[k, c], key_quaternions[k + 1, c], f)
            x, y, z, w = q
            u = (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + z * w), 2.0 * (x * z - y * w))
            for a in range(3):  # clip 0 holds points 0 and 1, clip 1 points 3 and 2
                out[m, 3 * c, a] = p[a] - half * u[a]
                out[m, 1 + c, a] = p[a] + half * u[a]


@njit(cache=True, inline="always")
def _slerp(q0, q1, f):
    """The unit quaternion (a 4-tuple) a fraction ``f`` of the shorter arc from q0 to q1 (4,),
    as :func:`dloplan.frames.slerp_quaternions`."""
    cos = q0[0] * q1[0] + q0[1] * q1[1] + q0[2] * q1[2] + q0[3] * q1[3]
    sign = -1.0 if cos < 0.0 else 1.0  # q and -q are one rotation
    angle = math.acos(min(abs(cos), 1.0))
    sin = math.sin(angle)
    if sin < 1e-12:  # (nearly) equal keys: linear weights
        w0, w1 = 1.0 - f, f
    else:
        w0, w1 = math.sin((1.0 - f) * angle) / sin, math.sin(f * angle) / sin
    q = (w0 * q0[0] + w1 * (sign * q1[0]), w0 * q0[1] + w1 * (sign * q1[1]),
         w0 * q0[2] + w1 * (sign * q1[2]), w0 * q0[3] + w1 * (sign * q1[3]))
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm


@njit(cache=True)
def explicit_steps(x, v, previous_held, targets, extra, first_step, n_steps, dt, k_d, relative,
                   ground, obstacles, radius, friction, record_every, rest_speed, clips_stop, k_s,
                   rest_lengths, k_b, rest_angles, masses, gravity, times, shapes, speeds,
                   n_records):
    """Advance x, v (n + 1, 3) in place through the clip targets of one chunk.

    Parameters
    ----------
    x, v : numpy.ndarray
        (n + 1, 3) positions [m] and velocities [m/s], updated in place.
    previous_held : numpy.ndarray
        (4, 3) held points of the step before [m] (updated).
    targets : numpy.ndarray
        (K, 4, 3) held points at steps ``first_step + 1 .. first_step + K`` [m].
    extra : numpy.ndarray
        (n + 1, 3) gradient added to dU/dx at every step [N] (zeros for none).
    first_step, n_steps : int
        Steps done before this chunk, and the run's total.
    dt, k_d : float
        Time step [s] and damping constant [N s/m].
    relative, ground : bool
        Relative damping; the one-sided plane z = 0.
    obstacles : numpy.ndarray
        (K, 8) obstacle rows the free points cannot enter (``contact_row()``,
        :mod:`dloplan.physics.contact_compiled`; K = 0: none).
    radius : float
        The cable's radius for the obstacles [m].
    friction : float
        Coulomb friction coefficient of the obstacles (0: frictionless).
    record_every : int
        Record every this many steps (and the last one).
    rest_speed : float
        Stop once ``step * dt >= clips_stop`` and every point is slower than this, and not about
        to speed up within a record interval [m/s]; negative: never.
    clips_stop : float
        Time at which the clips stop moving [s].
    k_s, rest_lengths, k_b, rest_angles, masses, gravity
        The chain's constants.
    times, shapes, speeds : numpy.ndarray
        Record buffers (R,), (R, n + 1, 3), (R,); ``n_records`` entries are in use.

    Returns
    -------
    tuple
        ``(step, n_records, status)`` with status :data:`RUNNING` (chunk done), :data:`SETTLED`
        or :data:`DIVERGED`.
    """
    return _explicit_chunk(x, v, previous_held, targets, extra, first_step, n_steps, dt, k_d,
                           relative, ground, obstacles, radius, friction, record_every, rest_speed,
                           clips_stop, k_s, rest_lengths, k_b, rest_angles, masses, gravity,
                           times, shapes, speeds, n_records, np.empty_like(x),
                           np.empty_like(x), np.empty_like(x))


@njit(cache=True)
def _explicit_chunk(x, v, previous_held, targets, extra, first_step, n_steps, dt, k_d, relative,
                    ground, obstacles, radius, friction, record_every, rest_speed, clips_stop, k_s,
                    rest_lengths, k_b, rest_angles, masses, gravity, times, shapes, speeds,
                    n_records, grad, drag, accel):
    """:func:`explicit_steps` with its work arrays (n + 1, 3) given (:func:`twist_steps` calls
    it once per step)."""
    n_points = x.shape[0]
    held = (0, 1, n_points - 2, n_points - 1)
    step = first_step
    for k in range(targets.shape[0]):
        step = first_step + k + 1
        for i in range(n_points):
            for a in range(3):
                if relative:  # sum over the neighbours of the velocity relative to them
                    d = 0.0
                    if i > 0:
                        d += v[i, a] - v[i - 1, a]
                    if i < n_points - 1:
                        d += v[i, a] - v[i + 1, a]
                    drag[i, a] = d
                else:
                    drag[i, a] = v[i, a]
        chain_gradient(x, k_s, rest_lengths, k_b, rest_angles, masses, gravity, grad)
        for i in range(n_points):
            for a in range(3):
                accel[i, a] = (-(grad[i, a] + extra[i, a]) - k_d * drag[i, a]) / masses[i]
                v[i, a] += accel[i, a] * dt
                x[i, a] += v[i, a] * dt
        for h in range(4):
            for a in range(3):
                v[held[h], a] = (targets[k, h, a] - previous_held[h, a]) / dt
                x[held[h], a] = targets[k, h, a]
                previous_held[h, a] = targets[k, h, a]
        _keep_out(x, v, accel, ground, obstacles, radius, friction)
        if step % record_every == 0 or step == n_steps:
            n_records, at_rest = _record(x, v, accel, step, dt, record_every, rest_speed,
                                         clips_stop, times, shapes, speeds, n_records)
            if at_rest:
                return step, n_records, SETTLED
        if not (math.isfinite(x[2, 0]) and math.isfinite(x[2, 1]) and math.isfinite(x[2, 2])):
            return step, n_records, DIVERGED
    return step, n_records, RUNNING


@njit(cache=True)
def implicit_steps(x, v, previous_held, targets, drift, first_step, n_steps, dt, k_d, relative,
                   ground, obstacles, radius, friction, record_every, rest_speed, clips_stop, k_s,
                   rest_lengths, k_b, rest_angles, masses, gravity, times, shapes, speeds,
                   n_records):
    """Linearly implicit Euler steps through the clip targets of one chunk, with contacts.

    Backward Euler, v+ = v + dt M^-1 (F(x+) - k_d D v+) and x+ = x + dt v+, with the force
    linearized at x, F(x+) = F(x) - dt H(x) v+ (one Newton step of the implicit equations, as
    Baraff and Witkin's cloth step): per step the banded system

        (M + dt k_d D + dt^2 (H + H^c)) v+ = M v + dt (F(x) + F^c(x))

    over the free points, the held points' v+ the clips' (target minus position over dt) and
    their columns moved to the right-hand side; H is the chain's Hessian
    (:func:`dloplan.physics.compiled.chain_derivatives`), M the lumped masses, D the damping's
    graph Laplacian (``relative``) or the identity.

    **Contacts.** A free point touching an obstacle at the step's start, or near enough to reach
    it during the step (closer than the radius times 1 + :data:`HOLD_MARGIN` plus
    :data:`LOOK_AHEAD` dt (|v| + dt |g|)), is held on its surface through the step by a penalty
    in the solve (F^c = k_c d n, H^c = k_c n n^T with d = r - phi, as the statics' penalty,
    :func:`dloplan.sim.contact_newton.add_penalty`; k_c = :data:`HOLD_STIFFNESS` (max m_i /
    dt^2 + k_s)): the solve sees the obstacle, so a cable pulled against a peg or pressed on a
    plate stays on it, and a point coming down lands on it at the step's end (inelastic), rather
    than being moved into it and put back, which would stretch its links by up to |v| dt. The
    contact is one-sided within the step, and Coulomb's: the step is solved with every such
    point sticking (held in all directions, k_c I, from where it is), and where the contact's
    normal force at the step's end, N = k_c (d - dt v+.n) (linearized as in the solve), would
    pull (a contact opening, or a point that does not reach the surface) the point is let go;
    where the force holding it along the surface, k_c dt |v+_t|, exceeds ``friction`` N it
    slides instead (normal penalty only, and the kinetic friction ``friction`` N against its
    slip); then the step is solved again with these contacts until they all hold (an active
    set: each contact changes at most twice, mostly one or two solves). A point that reaches
    an obstacle unforeseen is put back by the explicit scheme's hard, inelastic contact
    (:func:`dloplan.physics.contact_compiled.push_out`, the same function, with its impulse
    friction), and so is a held point's small penetration; the ground plane z = 0 as in
    :func:`explicit_steps`.

    **A changing cable** (a harness section whose links get shorter) moves its mass points
    through the material: ``drift`` (n + 1,) [1/s] is the rate at which point i's material
    coordinate s_i grows, in units of the material between two points at the step's start:
    (ds_i/dt) / l (for links of length l(t) shortening about the middle point, s_i = (i - n/2)
    l and ds_i/dt = (i - n/2) dl/dt), so the material at point i moves at v_i - u_i with u_i =
    drift_i (x_(i+1) - x_(i-1)) / 2 (the material's tangent dx/ds, stretch included, times
    ds_i/dt), projected onto the surfaces the point touches. Friction acts on the material (an
    arbitrary Lagrangian-Eulerian contact): a sticking point's tangential spring is at rest
    where its material point is, x + dt u (the force k_c P_t (dt u - dt v+), P_t = I - n n^T),
    and the slip that Coulomb's law judges and the kinetic friction opposes is P_t (v+ - u).
    Zero for a fixed cable.

    The step is unconditionally stable for a positive definite H (docs/decisions.md: the
    replay's time step; H^c only adds to it), so ``dt`` is set by the motion, not by the axial
    springs or the contacts. Arguments, records, rest test and the returned tuple as in
    :func:`explicit_steps` (no external gradient); status :data:`INDEFINITE` when the system is
    not positive definite (a compressed chain stiffer than M / dt^2: the caller steps
    explicitly instead).
    """
    n_points = x.shape[0]
    n_dof = 3 * n_points
    held = (0, 1, n_points - 2, n_points - 1)
    grad = np.empty_like(x)
    accel = np.empty_like(x)
    work = (np.empty((9, n_dof)), np.empty((9, n_dof - 12)), np.empty((9, n_dof - 12)),
            np.empty(n_dof))
    chain_grad = np.empty_like(x)  # the chain's gradient and band at the step's start
    chain_band = np.empty((9, n_dof))
    velocity = np.empty(n_dof)
    touching = np.zeros((obstacles.shape[0], n_points, 7))  # d [m], n, friction force [N]
    through = np.zeros_like(x)  # u: each point's velocity relative to its material [m/s]
    holding = np.zeros((obstacles.shape[0], n_points), dtype=np.int8)
    reach = radius * (1.0 + HOLD_MARGIN)
    ahead = np.empty(n_points)
    pull = math.sqrt(gravity[0] ** 2 + gravity[1] ** 2 + gravity[2] ** 2)
    stiffness = HOLD_STIFFNESS * (np.max(masses) / (dt * dt) + k_s)
    step = first_step
    for k in range(targets.shape[0]):
        step = first_step + k + 1
        for h in range(4):
            for a in range(3):
                velocity[3 * held[h] + a] = (targets[k, h, a] - previous_held[h, a]) / dt
        for i in range(n_points):  # how far a point may come within the step
            ahead[i] = LOOK_AHEAD * dt * (math.sqrt(v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2)
                                          + dt * pull)
        for r in range(obstacles.shape[0]):
            for i in range(2, n_points - 2):
                phi, n0, n1, n2 = point_distance(x[i, 0], x[i, 1], x[i, 2], obstacles[r])
                touching[r, i, 0] = reach - phi
                touching[r, i, 1] = n0
                touching[r, i, 2] = n1
                touching[r, i, 3] = n2
                holding[r, i] = FREE if phi >= reach + ahead[i] else (
                    STICK if friction > 0.0 else SLIDE)
        if obstacles.shape[0] > 0:
            _material_drift(x, drift, touching, holding, through)
        # the chain's derivatives at x, once: each solve of the active set adds its contacts
        chain_derivatives(x, k_s, rest_lengths, k_b, rest_angles, masses, gravity, chain_grad,
                          chain_band)
        for _ in range(2 * obstacles.shape[0] * n_points + 1):  # the active set
            if not _implicit_velocity(v, velocity, dt, k_d, relative, masses, chain_grad,
                                      chain_band, touching, holding, stiffness, through, grad,
                                      work):
                return step - 1, n_records, INDEFINITE
            if _contacts_settled(velocity, touching, holding, stiffness, dt, friction, through):
                break
        for i in range(n_points):
            for a in range(3):
                accel[i, a] = (velocity[3 * i + a] - v[i, a]) / dt
                v[i, a] = velocity[3 * i + a]
                x[i, a] += v[i, a] * dt
        for h in range(4):
            for a in range(3):
                x[held[h], a] = targets[k, h, a]
                previous_held[h, a] = targets[k, h, a]
        _keep_out(x, v, accel, ground, obstacles, radius, friction)
        if step % record_every == 0 or step == n_steps:
            n_records, at_rest = _record(x, v, accel, step, dt, record_every, rest_speed,
                                         clips_stop, times, shapes, speeds, n_records)
            if at_rest:
                return step, n_records, SETTLED
        if not (math.isfinite(x[2, 0]) and math.isfinite(x[2, 1]) and math.isfinite(x[2, 2])):
            return step, n_records, DIVERGED
    return step, n_records, RUNNING


@njit(cache=True)
def _material_drift(x, drift, touching, holding, through):
    """Each inner point's velocity relative to its material, u_i = drift_i (x_(i+1) -
    x_(i-1)) / 2 [m/s], into ``through`` (n + 1, 3) (:func:`implicit_steps`), projected
    onto the surfaces the point touches (``holding`` (K, n + 1) not FREE, normals in
    ``touching`` (K, n + 1, 7)): the material slides along them. A chord tau_i crossing a
    surface (a point where the cable comes onto a peg) would otherwise ask a point sticking
    on a second surface (the peg's plate) to move into the first one."""
    basis = np.empty((3, 3))  # the touched normals, orthonormalized
    for i in range(1, x.shape[0] - 1):
        for a in range(3):
            through[i, a] = 0.5 * drift[i] * (x[i + 1, a] - x[i - 1, a])
        found = 0
        for r in range(holding.shape[0]):
            if holding[r, i] == FREE or found == 3:
                continue
            for a in range(3):
                basis[found, a] = touching[r, i, 1 + a]
            for b in range(found):
                along = (basis[found, 0] * basis[b, 0] + basis[found, 1] * basis[b, 1]
                         + basis[found, 2] * basis[b, 2])
                for a in range(3):
                    basis[found, a] -= along * basis[b, a]
            size = math.sqrt(basis[found, 0] ** 2 + basis[found, 1] ** 2 + basis[found, 2] ** 2)
            if size < 1e-9:  # within the span of the normals before
                continue
            across = 0.0
            for a in range(3):
                basis[found, a] /= size
                across += through[i, a] * basis[found, a]
            for a in range(3):
                through[i, a] -= across * basis[found, a]
            found += 1


@njit(cache=True)
def _contacts_settled(velocity, touching, holding, stiffness, dt, friction, through):
    """Check the contacts of one implicit step's solution ``velocity`` (3(n + 1),) against
    Coulomb's law (:func:`implicit_steps`); change those that break it and return False (solve
    again), or True when all hold. ``touching`` (K, n + 1, 7): depth d [m], normal n and the
    sliding friction force [N] (written here); ``holding`` (K, n + 1): FREE, SLIDE or STICK;
    ``through`` (n + 1, 3): each point's velocity relative to its material u [m/s], so the
    material slips at the tangential part of v+ - u."""
    settled = True
    for r in range(holding.shape[0]):
        for i in range(holding.shape[1]):
            if holding[r, i] == FREE:
                continue
            j = 3 * i
            c = touching[r, i]
            speed = velocity[j] * c[1] + velocity[j + 1] * c[2] + velocity[j + 2] * c[3]
            normal = stiffness * (c[0] - dt * speed)  # the penalty's force at the step's end
            if normal < 0.0:  # it would pull: the contact opens
                holding[r, i] = FREE
                settled = False
                continue
            if holding[r, i] == SLIDE:
                continue
            s0 = velocity[j] - through[i, 0]
            s1 = velocity[j + 1] - through[i, 1]
            s2 = velocity[j + 2] - through[i, 2]
            across = s0 * c[1] + s1 * c[2] + s2 * c[3]
            t0 = s0 - across * c[1]  # the material's slip along the surface
            t1 = s1 - across * c[2]
            t2 = s2 - across * c[3]
            along = stiffness * dt * math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)  # holding force
            if along > friction * normal:  # more than friction can hold: it slides
                scale = friction * normal / along * stiffness * dt
                c[4], c[5], c[6] = -scale * t0, -scale * t1, -scale * t2
                holding[r, i] = SLIDE
                settled = False
    return settled


@njit(cache=True)
def _implicit_velocity(v, velocity, dt, k_d, relative, masses, chain_grad, chain_band, touching,
                       holding, stiffness, through, grad, work):
    """Solve one step's system of :func:`implicit_steps` for the free points' v+ into
    ``velocity`` (3(n + 1),), whose held entries are the clips' already; the chain's gradient
    (n + 1, 3) [N] and lower Hessian band (9, 3(n + 1)) [N/m] at the step's start in
    ``chain_grad``, ``chain_band`` (:func:`dloplan.physics.compiled.chain_derivatives`, read
    only: the active set solves again with other contacts), the contacts in ``holding``
    (K, n + 1) held as :func:`_contacts_settled` says with ``touching`` and ``through`` (a
    sticking point's spring at rest where its material is at the step's end). ``grad`` (n + 1,
    3) and ``work`` (band (9, 3(n + 1)), free band and factor (9, 3(n + 1) - 12), rhs (3(n +
    1),)) are scratch. False when the system is not positive definite."""
    band, free, factor, rhs = work
    n_points = v.shape[0]
    n_dof = 3 * n_points
    dt2 = dt * dt
    grad[:] = chain_grad
    band[:] = chain_band
    for r in range(holding.shape[0]):
        for i in range(n_points):
            c = touching[r, i]
            if holding[r, i] != FREE:
                add_penalty(i, c[0], c[1], c[2], c[3], stiffness, grad, band)
            if holding[r, i] == STICK:  # the tangential spring, at rest on the material
                across = through[i, 0] * c[1] + through[i, 1] * c[2] + through[i, 2] * c[3]
                for a in range(3):
                    grad[i, a] -= stiffness * dt * (through[i, a] - across * c[1 + a])
                    for b in range(a + 1):
                        band[a - b, 3 * i + b] += stiffness * ((a == b) - c[1 + a] * c[1 + b])
            elif holding[r, i] == SLIDE:  # the kinetic friction, against the slip
                for a in range(3):
                    grad[i, a] -= c[4 + a]
    for j in range(n_dof):  # A = M + dt k_d D + dt^2 H (lower band)
        for d in range(9):
            band[d, j] *= dt2
        i = j // 3
        band[0, j] += masses[i]
        if relative:
            band[0, j] += dt * k_d * ((i > 0) + (i < n_points - 1))
            if i < n_points - 1:
                band[3, j] -= dt * k_d
        else:
            band[0, j] += dt * k_d
    for i in range(n_points):
        for a in range(3):
            rhs[3 * i + a] = masses[i] * v[i, a] - dt * grad[i, a]
    for j in range(6, n_dof - 6):
        velocity[j] = 0.0
    for j in range(n_dof):  # rhs -= A v_held (symmetric band: both triangles)
        for d in range(9):
            if j + d >= n_dof:
                break
            if d == 0:
                rhs[j] -= band[0, j] * velocity[j]
            else:
                rhs[j + d] -= band[d, j] * velocity[j]
                rhs[j] -= band[d, j] * velocity[j + d]
    for j in range(n_dof - 12):
        for d in range(9):
            free[d, j] = band[d, j + 6]
    if not cholesky_band(free, 0.0, factor):
        return False
    cholesky_solve(factor, rhs[6 : n_dof - 6])
    for j in range(6, n_dof - 6):
        velocity[j] = rhs[j]
    return True


@njit(cache=True)
def twist_angle_factor(k_t, n, band, factor):
    """The Cholesky factor (2, n - 2) of the free angles' Hessian k_t tridiag(-1, 2, -1) of U^t
    alone (straight rest shape: the same at every state), with :func:`relax_twist`'s shift;
    ``band`` (2, n - 2) is scratch."""
    for i in range(n - 2):
        band[0, i] = 2.0 * k_t
        band[1, i] = -k_t if i < n - 3 else 0.0
    return cholesky_band(band, 1e-12 * max(2.0 * k_t, 1e-300), factor)


@njit(cache=True)
def relax_twist(x, d1, twist, tangents, lengths, work, tgrad, dgrad, agrad, blocks, band, factor,
                rhs, angles, extra):
    """One Newton step of the free links' angles toward the minimum of U^t + U^d at points x.

    The angles are massless (:class:`dloplan.sim.torsion.QuasiStaticTwist`): the tridiagonal
    angle Hessian of :func:`dloplan.physics.twist_compiled.twist_stencils` is factored (a
    gradient step where it is not positive definite); ``angles`` (n,) gets the step [rad] (zero
    for the held links), by which the caller turns the directors d1 (n, 3);
    ``extra`` gets d(U^t + U^d)/dx (n + 1, 3) [N] at d1 (the twisting force of eq. 3.19 is
    minus it). ``band``, ``rhs`` (n - 2,) are scratch. Without U^d (straight rest shape) the
    Hessian is constant: ``factor`` (2, n - 2) must hold :func:`twist_angle_factor`, and the
    gradient is one pass of :func:`dloplan.physics.twist_compiled.twist_load` over the links'
    unit ``tangents`` (n, 3) and ``lengths`` (n,) [m] at x (the same numbers as the stencils');
    with U^d ``factor`` is scratch and the tangents are not read.
    """
    k_t, rest_twist, k_b, rest_curvatures, directional = twist
    n = d1.shape[0]
    solved = True
    if directional:
        twist_stencils(x, d1, k_t, rest_twist, k_b, rest_curvatures, directional, work, tgrad,
                       dgrad, agrad, blocks, np.bool_(False))
        largest = 0.0
        for i in range(n - 2):  # free angle i is theta_{i+1}: stencils i (as b), i + 1 (as a)
            band[0, i] = blocks[i, 7, 7] + blocks[i + 1, 3, 3]
            band[1, i] = blocks[i + 1, 7, 3] if i < n - 3 else 0.0
            largest = max(largest, abs(band[0, i]))
        solved = cholesky_band(band, 1e-12 * max(largest, 1e-300), factor)
        for i in range(x.shape[0]):
            for a in range(3):
                extra[i, a] = tgrad[i, a] + dgrad[i, a]
    else:
        twist_load(tangents, lengths, d1, k_t, rest_twist, extra, agrad)
    if solved:
        for i in range(n - 2):
            rhs[i] = -agrad[i + 1]
        cholesky_solve(factor, rhs)
    else:  # not convex in the angles here: a gradient step
        for i in range(n - 2):
            rhs[i] = -agrad[i + 1] / max(band[0, i], 1e-300)
    angles[0] = 0.0
    angles[n - 1] = 0.0
    angles[1 : n - 1] = rhs


@njit(cache=True)
def twist_steps(x, v, previous_held, targets, held_directors, d1, twist, work, first_step,
                n_steps, dt, k_d, relative, ground, obstacles, radius, friction, record_every,
                rest_speed, clips_stop, k_s, rest_lengths, k_b, rest_angles, masses, gravity,
                times, shapes, speeds, n_records):
    """:func:`explicit_steps` with quasi-static twist: before each step the angles relax
    (:func:`relax_twist`, whose twisting force loads the step), after it the free directors d1
    (n, 3) are turned by the relaxed angles and carried to the new links by parallel transport
    in one pass (turning about a link commutes with transporting it; the links' tangents are
    computed once per step, kept for the next relaxation), and the held links take the clips'
    directors ``held_directors`` (K, 2, 3) of that step. Other arguments and the returned tuple
    as in :func:`explicit_steps`."""
    n = d1.shape[0]
    tgrad = np.empty_like(x)
    dgrad = np.empty_like(x)
    agrad = np.empty(n)
    blocks = np.empty((n - 1, 11, 11) if twist[4] else (0, 11, 11))
    band = np.empty((2, n - 2))
    factor = np.empty((2, n - 2))
    rhs = np.empty(n - 2)
    angles = np.zeros(n)
    tangents = np.empty_like(d1)
    lengths = np.empty(n)
    extra = np.empty_like(x)
    grad, drag, accel = np.empty_like(x), np.empty_like(x), np.empty_like(x)
    if not twist[4]:
        twist_angle_factor(twist[0], n, band, factor)
    link_tangents(x, tangents, lengths)
    step = first_step
    status = RUNNING
    for k in range(targets.shape[0]):
        relax_twist(x, d1, twist, tangents, lengths, work, tgrad, dgrad, agrad, blocks, band,
                    factor, rhs, angles, extra)
        step, n_records, status = _explicit_chunk(
            x, v, previous_held, targets[k : k + 1], extra, step, n_steps, dt, k_d, relative,
            ground, obstacles, radius, friction, record_every, rest_speed, clips_stop, k_s,
            rest_lengths, k_b, rest_angles, masses, gravity, times, shapes, speeds, n_records,
            grad, drag, accel)
        if not carry_directors(tangents, lengths, x, d1, angles, np.int64(1), n - 1):
            return step, n_records, DIVERGED  # a link reversed or folded back in one step
        d1[0] = held_directors[k, 0]
        d1[n - 1] = held_directors[k, 1]
        if status != RUNNING:
            break
    return step, n_records, status
