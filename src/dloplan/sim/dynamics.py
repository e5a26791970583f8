"""The thesis' dynamic simulator: explicit time stepping of the mass-spring chain (3.3, 3.8).

Each step solves Newton's second law with the fictitious damping k_d by the semi-implicit
Euler scheme of eq. 3.24::

    a = (F(x) - k_d v) / m,    v <- v + a dt,    x <- x + v dt

with the time step dt = sqrt(m_i l / k_s) of 3.8.2 (optionally computed from a capped,
fictitious Young's modulus as in chapter 6, Fig. 6.5). The four held points follow the clip
poses, interpolated in time (linear in position, slerp in rotation). An optional ground plane
z = 0 is a one-sided contact: points are projected back onto it and lose their downward speed;
so are obstacles (pegs, plates, boxes, the table: ``contacts``,
:mod:`dloplan.physics.contact_compiled`). A cable that changes while it moves (``cable_at``: a
wire-harness section that gets shorter as the grippers pull it through the fixtures) takes its
constants at each millisecond.

``scheme="implicit"`` steps by linearly implicit Euler instead
(:func:`dloplan.sim.stepping.implicit_steps`), stable at a step set by the motion (the replay's
1 ms) while the chain's stiffness is positive definite; a point touching an obstacle is held on
it through the step by the statics' contact penalty, in the solve.

Running this to rest takes 10^4 to 10^6 steps; :mod:`dloplan.sim.statics` finds the same rest
shape directly. The simulator is kept for what only it can do: replaying a timed plan at its
real speed (inertia, overshoot) and reproducing the thesis' own stabilization.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..frames import quaternion_x_axes, slerp_quaternions
from ..geometry import as_shape
from ..physics.chain import SpringChain, energy, gradient, hessian_band
from ..physics.twist_compiled import scratch
from .clips import HELD_INDICES, ClipPoses, clip_poses_from_shape
from .newton import factor_band, free_band
from .result import Equilibrium, equilibrium_result
from .stepping import (
    DIVERGED,
    INDEFINITE,
    RUNNING,
    SETTLED,
    explicit_steps,
    held_targets,
    implicit_steps,
    twist_steps,
)

_CHUNK = 4096  # steps whose clip poses are interpolated at once

SCHEDULE_INTERVAL = 1e-3
"""Time [s] between updates of the cable's constants when it changes (``cable_at``)."""

INDEFINITE_BACKOFF = 0.1
"""Time [s] an implicit run found indefinite gives back (:attr:`IndefiniteStep.partial`): the
steps before an indefinite one may already be wrong, a chain going soft as it is compressed
(measured: a harness job's phase 2 off the explicit run's speeds 20 ms before, tensions of
30-165 N in its last 6 ms, against 1e-11 N explicit; docs/decisions.md)."""

SCHEMES = ("explicit", "implicit")
"""Time stepping schemes of :func:`simulate`: the thesis' semi-implicit Euler (eq. 3.24) and
the linearly implicit Euler of :func:`dloplan.sim.stepping.implicit_steps`."""


class IndefiniteStep(FloatingPointError):
    """An implicit step whose system M + dt k_d D + dt^2 H is not positive definite.

    Attributes
    ----------
    partial : Simulation or None
        The run up to a state at least :data:`INDEFINITE_BACKOFF` before the step that failed
        (kept at most twice that before it; the start if the run had not got that far): its
        records, that state as the last record (shape and :attr:`Simulation.velocity`), so a
        run can continue from it (``simulate(initial_velocity=)``); None when raised
        without one.
    time : float or None
        When the step that failed would have ended [s], on the run's clock.
    """

    def __init__(self, message: str, partial: Simulation | None = None,
                 time: float | None = None) -> None:
        super().__init__(message)
        self.partial = partial
        self.time = time


class SampledPoses(Sequence):
    """K clip poses kept as arrays, a :class:`ClipPoses` made per item when asked for.

    Parameters
    ----------
    positions : array_like
        (K, 2, 3) clip points [m].
    quaternions : array_like
        (K, 2, 4) ``clip_to_world`` quaternions (x, y, z, w), normalized here as
        ``Rotation.from_quat`` does.
    """

    def __init__(self, positions, quaternions) -> None:
        pos = np.array(positions, dtype=float)
        quats = np.asarray(quaternions, dtype=float)
        if pos.ndim != 3 or pos.shape[1:] != (2, 3) or quats.shape != (len(pos), 2, 4):
            raise ValueError(f"sampled poses: expected positions (K, 2, 3) and quaternions "
                             f"(K, 2, 4), got {pos.shape} and {quats.shape}")
        if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(quats))):
            raise ValueError("sampled poses: non-finite position or quaternion (NaN or inf)")
        self.positions = pos
        self.quaternions = np.stack([Rotation.from_quat(quats[:, c]).as_quat()
                                     for c in (0, 1)], axis=1)

    def __len__(self) -> int:
        return len(self.positions)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[j] for j in range(*k.indices(len(self)))]
        return ClipPoses(self.positions[k], Rotation.from_quat(self.quaternions[k]))


@dataclass(frozen=True, eq=False)
class ClipTrajectory:
    """Clip poses over time, interpolated linearly in position and by slerp in rotation.

    Parameters
    ----------
    times : numpy.ndarray
        (K,) strictly increasing times [s].
    poses : sequence of ClipPoses
        K clip poses; before the first time and after the last the poses are held.
    """

    times: np.ndarray
    poses: Sequence[ClipPoses]

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=float)
        if t.ndim != 1 or len(t) != len(self.poses) or len(t) == 0:
            raise ValueError(
                f"times: expected one time per clip pose, got {t.shape} for {len(self.poses)} poses"
            )
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise ValueError("times: expected finite, strictly increasing times [s]")
        object.__setattr__(self, "times", t)

    @classmethod
    def hold(cls, clips: ClipPoses) -> ClipTrajectory:
        """Clips held still."""
        return cls(np.array([0.0]), [clips])

    @classmethod
    def sampled(cls, times, positions, quaternions) -> ClipTrajectory:
        """Clip poses given as arrays (a trajectory sampled at thousands of times): the
        interpolation reads the arrays, and a :class:`ClipPoses` is made only when asked for.

        Parameters
        ----------
        times : array_like
            (K,) strictly increasing times [s].
        positions : array_like
            (K, 2, 3) clip points [m].
        quaternions : array_like
            (K, 2, 4) ``clip_to_world`` unit quaternions (x, y, z, w).
        """
        return cls(times, SampledPoses(positions, quaternions))

    def frames(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Clip positions (len(t), 2, 3) [m] and ``clip_to_world`` matrices (len(t), 2, 3, 3)."""
        pos, quats = self.poses_at(t)
        mats = np.stack([Rotation.from_quat(quats[:, c]).as_matrix() for c in (0, 1)], axis=1)
        return pos, mats

    def poses_at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Clip positions (len(t), 2, 3) [m] and ``clip_to_world`` unit quaternions (x, y, z,
        w) (len(t), 2, 4) at times ``t`` [s] (held before the first and after the last)."""
        t = np.clip(np.asarray(t, dtype=float), self.times[0], self.times[-1])
        positions, quats = self._keys
        if len(self.times) == 1:
            return (np.broadcast_to(positions[0], (len(t), 2, 3)),
                    np.broadcast_to(quats[0], (len(t), 2, 4)))
        k = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 2)
        f = ((t - self.times[k]) / (self.times[k + 1] - self.times[k]))[:, None, None]
        pos = (1.0 - f) * positions[k] + f * positions[k + 1]
        return pos, slerp_quaternions(self.times, quats, t)

    @cached_property
    def _keys(self):
        """The poses' positions (K, 2, 3) [m] and unit quaternions (K, 2, 4), gathered once."""
        if isinstance(self.poses, SampledPoses):
            return self.poses.positions, self.poses.quaternions
        return (np.stack([p.positions for p in self.poses]),
                np.stack([p.rotations.as_quat() for p in self.poses]))

    def held_points(self, t: np.ndarray, link_length: float) -> np.ndarray:
        """Positions of the four held points at times ``t`` [s], (len(t), 4, 3) [m]."""
        return held_points_at(*self.clip_axes(t), link_length)

    def clip_axes(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Clip points (len(t), 2, 3) [m] and u-axes (len(t), 2, 3) at times ``t`` [s]: what
        :meth:`held_points` needs of the poses, whatever the held link's length."""
        pos, quats = self.poses_at(t)
        return pos, quaternion_x_axes(quats)


def held_points_at(positions: np.ndarray, u_axes: np.ndarray, link_length: float) -> np.ndarray:
    """The four held points (K, 4, 3) [m] of clips at ``positions`` (K, 2, 3) [m] with u-axes
    (K, 2, 3) holding the middles of end links of length ``link_length`` [m]."""
    half = 0.5 * link_length * u_axes
    return np.stack(
        [positions[:, 0] - half[:, 0], positions[:, 0] + half[:, 0],
         positions[:, 1] + half[:, 1], positions[:, 1] - half[:, 1]],
        axis=1,
    )


@dataclass(frozen=True, eq=False)
class Simulation:
    """Recorded output of :func:`simulate`.

    Attributes
    ----------
    times : numpy.ndarray
        (K,) recording times [s].
    shapes : numpy.ndarray
        (K, n + 1, 3) shapes [m].
    max_speeds : numpy.ndarray
        (K,) largest point speed at each recorded time [m/s].
    dt : float
        Time step [s].
    steps : int
        Steps taken.
    settled : bool
        True when the run stopped because every point was slower than the rest speed.
    message : str
        What happened.
    velocity : numpy.ndarray or None
        (n + 1, 3) point velocities at the last step [m/s] (the state a run continued from
        ``shapes[-1]`` starts with, ``simulate(initial_velocity=)``).
    """

    times: np.ndarray
    shapes: np.ndarray
    max_speeds: np.ndarray
    dt: float
    steps: int
    settled: bool
    message: str
    velocity: np.ndarray | None = None

    def at(self, times) -> np.ndarray:
        """Recorded shapes linearly interpolated at ``times`` [s] (clamped), (K, n + 1, 3)."""
        t = np.clip(np.atleast_1d(np.asarray(times, dtype=float)), self.times[0], self.times[-1])
        k = np.clip(np.searchsorted(self.times, t), 1, len(self.times) - 1)
        t0, t1 = self.times[k - 1], self.times[k]
        w = np.where(t1 > t0, (t - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0)[:, None, None]
        return (1.0 - w) * self.shapes[k - 1] + w * self.shapes[k]


def simulate(
    cable: Cable,
    initial_shape,
    clips: ClipTrajectory | ClipPoses | None = None,
    *,
    duration: float,
    dt: float | None = None,
    youngs_modulus_cap: float | None = None,
    gravity=GRAVITY,
    ground: bool = False,
    record_interval: float | None = None,
    rest_speed: float | None = None,
    max_steps: int = 10_000_000,
    damping: str = "absolute",
    torsion: bool = False,
    natural_twist: float = 0.0,
    contacts=(),
    friction: float = 0.0,
    cable_at=None,
    scheme: str = "explicit",
    initial_velocity=None,
) -> Simulation:
    """Integrate eq. 3.24 from ``initial_shape`` (at rest, or moving at ``initial_velocity``)
    with the clips driving the ends.

    Parameters
    ----------
    cable : Cable
        The cable.
    initial_shape : array_like
        (n + 1, 3) shape at t = 0 [m], at rest.
    clips : ClipTrajectory or ClipPoses, optional
        Clip motion (a ``ClipPoses`` is held still); default: the initial shape's own clips.
    duration : float
        Simulated time [s] (the run may stop earlier, see ``rest_speed``).
    dt : float, optional
        Time step [s]; default the thesis' ``cable.time_step(youngs_modulus_cap)``.
    youngs_modulus_cap : float, optional
        Fictitious modulus for the default time step (thesis Fig. 6.5): it stands in for E;
        axial springs with a modulus of their own keep their step (:meth:`Cable.time_step`).
    gravity : array_like
        Gravity [m/s^2].
    ground : bool
        One-sided contact with the plane z = 0.
    record_interval : float, optional
        Time between recorded shapes [s]; default: about 200 records over ``duration``.
    rest_speed : float, optional
        Stop when the clips have stopped and every point is slower than this [m/s].
    max_steps : int
        Hard limit on steps, so no call can hang.
    damping : {"absolute", "relative"}
        ``"absolute"``: the thesis' -k_d v on every point (eq. 3.3), a drag that also resists
        rigid motion: at 0.1 m/s it exceeds the weight of a light cable, so a replay at real
        speed lags behind. ``"relative"``: -k_d (2 v_i - v_(i-1) - v_(i+1)), dashpots between
        neighbouring points that damp vibration but not motion as a whole.
    torsion : bool
        Include twist (docs/torsion.md): the twist angles are quasi-static (massless), relaxed
        by one Newton step on the angles at every time step, and their energy adds the
        twisting force (eq. 3.19) to the points. The clips' v-axes set the held links' material
        frames. About 2 ms per step: use it with a capped modulus and small n.
    natural_twist : float
        Natural twist of the cable [rad] (with ``torsion``).
    contacts : sequence
        Obstacles the free points cannot enter (each with ``contact_row()``, :mod:`dloplan.
        obstacles`): a hard, inelastic contact.
    friction : float
        Coulomb friction coefficient of the ``contacts`` (0: frictionless).
    cable_at : callable, optional
        ``cable_at(t)`` -> the cable at time t [s], with ``cable``'s number of links: its
        constants (springs, rest lengths, masses, damping, held link length) are taken every
        :data:`SCHEDULE_INTERVAL` (the chain built again only when it returns another object
        than the last time); ``cable`` is the cable at t = 0. Not with ``torsion``. Its links
        change length about the middle point (the material there stays: a harness section
        pulled equally through both fixtures), so the implicit step's friction follows the
        material, through which the other points move
        (:func:`dloplan.sim.stepping.implicit_steps`, ``drift``).
    scheme : {"explicit", "implicit"}
        ``"explicit"``: eq. 3.24, stable only below about the thesis' time step.
        ``"implicit"``: linearly implicit Euler (:func:`dloplan.sim.stepping.implicit_steps`),
        stable at any ``dt`` while the chain's stiffness is positive enough (raises
        :class:`IndefiniteStep` otherwise); its ``dt`` (required) is set by the motion. Not
        with ``torsion``.
    initial_velocity : array_like, optional
        (n + 1, 3) velocities of the points at t = 0 [m/s] (a run continued from another's
        last state, :attr:`Simulation.velocity`); default at rest. The held points' are the
        clips' from the first step on.
    """
    x = as_shape(initial_shape, cable.n_points, "initial_shape").copy()
    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration: got {duration!r}, expected a time > 0 [s]")
    if clips is None:
        clips = clip_poses_from_shape(x)
    trajectory = clips if isinstance(clips, ClipTrajectory) else ClipTrajectory.hold(clips)
    if scheme not in SCHEMES:
        raise ValueError(f"scheme: got {scheme!r}, expected one of {', '.join(SCHEMES)}")
    implicit = scheme == "implicit"
    if implicit and (torsion or dt is None):
        raise ValueError("scheme 'implicit': needs a time step dt, and steps a chain without "
                         "torsion")
    if dt is None:
        dt = cable.time_step(youngs_modulus_cap)
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt: got {dt!r}, expected a time step > 0 [s]")
    n_steps = int(math.ceil(duration / dt))
    if n_steps > max_steps:
        raise ValueError(
            f"duration: {duration} s needs {n_steps} steps of {dt:.3g} s, more than max_steps "
            f"= {max_steps}"
        )
    record_interval = record_interval or duration / 200.0
    record_every = max(1, int(round(record_interval / dt)))
    chain = SpringChain.from_cable(cable, gravity)
    if damping not in ("absolute", "relative"):
        raise ValueError(f"damping: got {damping!r}, expected 'absolute' or 'relative'")
    if not (math.isfinite(friction) and friction >= 0):
        raise ValueError(f"friction: got {friction!r}, expected a coefficient >= 0")
    if cable_at is not None and torsion:
        raise ValueError("cable_at: a changing cable is not simulated with torsion")
    rows = np.zeros((0, 8))
    if len(contacts):
        missing = [type(c).__name__ for c in contacts if not hasattr(c, "contact_row")]
        if missing:
            raise ValueError(f"contacts: {', '.join(missing)} without contact_row(), expected "
                             "obstacle volumes (Table, Cylinder, Box)")
        rows = np.stack([np.asarray(c.contact_row(), dtype=float) for c in contacts])
    n_records = n_steps // record_every + 2
    times, speeds = np.zeros(n_records), np.zeros(n_records)
    shapes = np.empty((n_records,) + x.shape)
    shapes[0] = x  # as given: the clips take hold at the first step
    v = np.zeros_like(x) if initial_velocity is None else as_shape(
        initial_velocity, cable.n_points, "initial_velocity").copy()
    previous_held = trajectory.held_points(np.array([0.0]), cable.rest_link_length)[0]
    x[list(HELD_INDICES)] = previous_held
    twist = None
    if torsion:
        from .torsion import QuasiStaticTwist, held_directors

        twist = QuasiStaticTwist(cable, x, trajectory.frames(np.array([0.0]))[1][0],
                                 natural_twist)
        chain = twist.chain_for(chain)

    def settings(model: Cable, constants: tuple) -> tuple:
        return (n_steps, dt, model.k_damping, damping == "relative", bool(ground), rows,
                cable.diameter / 2, float(friction), record_every,
                -1.0 if rest_speed is None else float(rest_speed), float(trajectory.times[-1]),
                *constants, times, shapes, speeds)

    fixed = settings(cable, chain.constants)
    chunk = _CHUNK if cable_at is None else max(1, int(math.ceil(SCHEDULE_INTERVAL / dt)))
    back = max(1, int(math.ceil(INDEFINITE_BACKOFF / dt)))  # steps an indefinite run gives back
    if implicit:
        chunk = min(chunk, back)
    key_positions, key_quaternions = (np.ascontiguousarray(k) for k in trajectory._keys)
    no_load = np.zeros_like(x)
    offsets = np.arange(cable.n_points) - 0.5 * cable.n_links  # (i - n/2): ds_i = offset dl
    drift = np.zeros(cable.n_points)  # the implicit step's (ds_i/dt) / l [1/s]
    status, step, recorded = RUNNING, 0, 1
    kept = [(0, x.copy(), v.copy(), 1)]  # an implicit run's last states: step, x, v, records
    previous = cable, fixed  # a changing cable's last model and its settings
    # a diverging run is detected in the loop and reported with its time: no float warnings
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        while step < n_steps and status == RUNNING:
            count = min(step + chunk, n_steps) - step  # the chunk's steps: step + 1 ..
            chunk_steps = np.arange(step + 1, step + count + 1)
            model, current = cable, fixed
            if cable_at is not None:
                # at the chunk's middle step, (2 step + count + 1) / 2: their mean, exactly
                model = cable_at((2 * step + count + 1) / 2 * dt)
                if model.n_links != cable.n_links:
                    raise ValueError(f"cable_at: a cable of {model.n_links} links, expected "
                                     f"{cable.n_links}")
                if implicit:
                    last = previous[0].rest_link_length  # the material between the points
                    drift = offsets * ((model.rest_link_length - last)
                                       / (last * count * dt))  # spread over the chunk
                if model is not previous[0]:  # the same cable object: the same constants
                    previous = model, settings(model,
                                               SpringChain.from_cable(model, gravity).constants)
                current = previous[1]
            targets = np.empty((count, 4, 3))  # the held points at each step
            held_targets(trajectory.times, key_positions, key_quaternions, chunk_steps * dt,
                         model.rest_link_length, targets)
            if implicit:
                if step - kept[-1][0] >= back:
                    kept = [kept[-1], (step, x.copy(), v.copy(), recorded)]
                step, recorded, status = implicit_steps(x, v, previous_held, targets, drift,
                                                        step, *current, recorded)
                continue
            if twist is None:
                step, recorded, status = explicit_steps(x, v, previous_held, targets, no_load, step,
                                                        *current, recorded)
                continue
            held = held_directors(trajectory.frames(chunk_steps * dt)[1])
            step, recorded, status = twist_steps(
                x, v, previous_held, targets, np.ascontiguousarray(held), twist.directors,
                twist.twist_chain.constants, scratch(), step, *current, recorded)
    if status == INDEFINITE:
        raise IndefiniteStep(f"implicit step at t = {(step + 1) * dt:.4g} s: the chain's "
                             f"stiffness is not positive enough for dt = {dt:.3g} s",
                             _given_back(kept, step + 1 - back, dt, times, shapes, speeds),
                             (step + 1) * dt)
    if status == DIVERGED:
        raise FloatingPointError(
            f"simulation diverged at t = {step * dt:.4g} s (dt = {dt:.3g} s too large)")
    settled = status == SETTLED
    if settled:
        message = f"at rest after {step} steps ({step * dt:.4g} s)"
    else:
        message = f"ran {step} steps ({step * dt:.4g} s)"
    return Simulation(times[:recorded].copy(), shapes[:recorded].copy(),
                      speeds[:recorded].copy(), float(dt), step, settled, message, v)


def _given_back(kept: list, latest: int, dt: float, times: np.ndarray, shapes: np.ndarray,
                speeds: np.ndarray) -> Simulation:
    """An indefinite implicit run up to the last state ``kept`` (step, x, v, records) at or
    before step ``latest`` (the first kept, the start, if none is): its records to then and
    that state as the last record (:attr:`IndefiniteStep.partial`)."""
    step, x, v, recorded = next((k for k in reversed(kept) if k[0] <= latest), kept[0])
    if times[recorded - 1] != step * dt:
        times[recorded], shapes[recorded] = step * dt, x
        speeds[recorded] = float(np.max(np.linalg.norm(v, axis=1)))
        recorded += 1
    return Simulation(times[:recorded].copy(), shapes[:recorded].copy(),
                      speeds[:recorded].copy(), float(dt), step, False,
                      f"ran {step} steps ({step * dt:.4g} s) before an indefinite step", v)


def settle(
    cable: Cable,
    shape,
    clips: ClipPoses | None = None,
    *,
    gravity=GRAVITY,
    rest_speed: float = 1e-5,
    max_duration: float = 60.0,
    dt: float | None = None,
    youngs_modulus_cap: float | None = None,
) -> Equilibrium:
    """The thesis' stabilization: hold the clips and time-step until the cable is at rest.

    Returns an :class:`~dloplan.sim.statics.Equilibrium` like the static solver, so the two can
    be swapped; ``iterations`` counts time steps, ``converged`` means the rest speed [m/s] was
    reached within ``max_duration`` [s] (``tolerance`` is NaN: no force tolerance applies).
    """
    x = as_shape(shape, cable.n_points, "shape")
    if clips is None:
        clips = clip_poses_from_shape(x)
    run = simulate(
        cable, x, clips, duration=max_duration, dt=dt, youngs_modulus_cap=youngs_modulus_cap,
        gravity=gravity, rest_speed=rest_speed, record_interval=0.01,
    )
    chain = SpringChain.from_cable(cable, gravity)
    final = run.shapes[-1]
    g = gradient(chain, final)
    residual = float(np.max(np.linalg.norm(g[2:-2], axis=1)))
    stable = factor_band(free_band(hessian_band(chain, final), slice(2, -2))) is not None
    history = np.array([float(energy(chain, final))])
    return equilibrium_result(cable, chain, final, g, clips, run.steps, run.settled, residual,
                              math.nan, stable, history, run.message)
