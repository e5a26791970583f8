"""Dynamic replay of a timed plan at its real speed (thesis eq. 3.24).

The plan's shapes are static equilibria: they say where the cable rests once the clips stop.
Moved at a finite speed the cable lags, swings and overshoots. The replay drives the thesis'
explicit simulator (:func:`dloplan.sim.dynamics.simulate`) with the timed clip trajectory, starting
at rest in the first planned shape, and reports

* the deviation at each knot: the largest point distance [m] between the simulated shape at the
  knot's time and the planned stabilized shape of that knot;
* the deviation after settling: the clips are held at the last pose and the simulation continues
  until every point is slower than ``rest_speed`` (or ``settle_duration`` has passed); as the
  speed goes to zero every knot deviation tends to the static error of the plan, which this
  final deviation measures. With ``settle_speed`` the settling is stepped only until every
  point is slower than that, while the cable may still move dynamically, and where it comes to
  rest is then the static equilibrium reached from that state with the contacts
  (:func:`dloplan.sim.statics.equilibrium`, frictionless as the statics): the creep left is
  static and is solved, not stepped (:func:`quasi_static_speed`; docs/decisions.md, "the
  harness replay's settling");
* the deviation per segment: the largest point distance, over the records between two knots,
  between the simulated cable and the planned cable at that instant (the two planned shapes
  interpolated with the same segment parameter that moves the clips, :mod:`dloplan.trajectory`),
  and at least the deviations at the segment's two knots. It includes the plan's own
  interpolation: between two planned shapes the real quasi-static cable is not their linear
  blend (for a stiff hose, several millimetres whatever the speed), so it is reported, compared
  between timings, and not checked against the tolerance;
* the peak axial link force [N] over the run and during the motion alone (tension positive),
  the first checked against an optional tensile limit [N].

**Time law.** Given the trajectory's time law (``law``, :class:`dloplan.trajectory.TimeLaw`),
the clips follow it: :func:`clip_motion` samples the clip poses at :data:`CLIP_RATE` (and at
every knot time), and the simulator interpolates linearly between the samples, so the held
points accelerate as the robot will (between 1 ms samples a jerk-limited motion departs from
its chord by a_max h^2 / 8, 0.1 um at 1 m/s^2). Without it the clips move at constant speed
between the knots (the velocity-only timing: a velocity jump, an infinite acceleration, at
every knot).

**Contacts and a changing cable.** With ``contacts`` (pegs, plates, the table) the simulator
keeps the points out of the obstacles (a hard, inelastic contact with Coulomb friction
``friction``: :mod:`dloplan.physics.contact_compiled` in the explicit step, held in the solve of
the implicit one, *Scheme* below), and the replay records, per obstacle and recorded
shape, the smallest gap between the cable's surface and the obstacle (``contact_gaps``): a
contact is closed where the gap is below :data:`CONTACT_GAP` times the cable's radius, so the
run shows where the cable lifts off a peg or comes to rest on a plate. With ``cable_at`` the
cable changes with time (a harness section pulled through its fixtures): the simulator takes its
constants as it goes, and the link tensions are those of the cable at each record's time.

**Scheme.** The thesis' explicit scheme (eq. 3.24) is stable only below a time step set by
the axial springs (3.8.2: 8.5 us for the capped PA12, a million steps for a 9 s motion). By
default (``scheme="auto"``) a replay without torsion, a changing cable or a tensile limit steps
by linearly implicit Euler instead (:func:`dloplan.sim.stepping.implicit_steps`) at
:data:`IMPLICIT_STEP`, the clip samples' spacing: stable at any step while the chain's
stiffness is positive definite, first order in dt, its knot deviations within micrometres of
the explicit run's on the examples (docs/decisions.md, "the replay's time step"). A point on an
obstacle, or reaching one within the step, is held on it in the implicit solve by a stiff
penalty and sticks or slides by Coulomb's law. A tensile limit is judged on the explicit run
(the implicit scheme damps the axial ringing whose peaks it checks), and so is a replay whose
implicit system is found indefinite, from the state the implicit run gives back to the end
(:attr:`~dloplan.sim.dynamics.IndefiniteStep.partial`, at least
:data:`~dloplan.sim.dynamics.INDEFINITE_BACKOFF` before the step that failed: the steps just
before it may already be wrong), and a changing cable (a harness section being tensioned,
its links all getting shorter: ``scheme="implicit"`` steps it with the friction on the material
through which the points move, but its peak tensions on the harness jobs do not yet agree with
the explicit ones where the section is pulled onto the peg and its plate; docs/decisions.md).
A changing cable that does not change before ``changes_at`` (the harness section through the
insertion and the regrasp's pause) steps implicitly until then and explicitly from the state it
reached (positions and velocities), so only the pull itself takes the explicit steps, with a
tensile limit too: the pull is where a section's tension peaks, and it stays explicit (from
the state given back if the fixed part is found indefinite).

The simulated shapes are recorded often enough (at least 20 records per knot interval, every step
while the run has fewer than :data:`MAX_RECORDS` steps) that the shape at a knot time is
interpolated linearly between two records and the force peak is sampled at that resolution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..geometry import as_path
from ..physics.chain import SpringChain, link_tensions
from ..physics.contact import penetrations
from ..sim.clips import ClipPoses
from ..sim.dynamics import (
    SCHEDULE_INTERVAL,
    SCHEMES,
    ClipTrajectory,
    IndefiniteStep,
    Simulation,
    simulate,
)
from ..sim.statics import equilibrium
from ..trajectory import TimeLaw, interpolate_poses, sample_times
from ._inputs import as_times

MAX_RECORDS = 100_000
"""Upper bound on the number of recorded shapes of one replay."""

CLIP_RATE = 1000.0
"""Rate [Hz] at which :func:`clip_motion` samples the clip poses along a time law."""

IMPLICIT_STEP = 1.0 / CLIP_RATE
"""Time step [s] of the implicit replay: the clip samples' spacing (docs/decisions.md)."""

ENTRY_CHUNK = 1_000_000
"""Links checked at a time by :func:`obstacle_entry` (its arrays' size: a few tens of MB)."""

CONTACT_GAP = 0.05
"""A recorded point touches an obstacle when its surface is closer than this fraction of the
cable's radius (the hard contact puts a pressing point at a gap of zero)."""


@dataclass(frozen=True, eq=False)
class Replay:
    """Result of :func:`replay`.

    Attributes
    ----------
    knot_times : numpy.ndarray
        (S + 2,) times of the planned shapes [s], from the trajectory's start.
    deviations : numpy.ndarray
        (S + 2,) largest point distance between the simulated and the planned shape at each
        knot time [m].
    final_deviation : float
        Largest point distance between the settled simulated shape and the last planned
        shape [m].
    settled : bool
        The run came to rest (every point slower than ``rest_speed``) before its time limit.
    peak_tension : float
        Largest axial link force over the run [N] (positive in tension).
    peak_time : float
        When it occurred [s].
    peak_link : int
        Which link (0-based) carried it.
    tensile_limit : float or None
        The limit it was checked against [N].
    tolerance : float
        The largest deviation accepted [m].
    ok : bool
        Every deviation within ``tolerance``, settled, and the peak tension within the limit.
    message : str
        Summary.
    simulation : Simulation
        The full recorded run.
    segment_deviations : numpy.ndarray
        (S + 1,) largest deviation over each segment [m] (module docstring).
    motion_peak_tension : float
        Largest axial link force while the clips move [N] (the settling excluded).
    law : TimeLaw
        The time law the clips followed (constant speed between the knots when none given).
    tensions : numpy.ndarray
        (R, n) axial force of each link at each recorded time [N] (positive in tension).
    contact_names : tuple of str
        The obstacles of ``contacts`` (empty without).
    contact_gaps : numpy.ndarray
        (R, K) smallest gap between the cable's surface and each obstacle at each recorded time
        [m] (module docstring).
    contact_tolerance : float
        The gap below which a contact counts as closed [m].
    rest_shape : numpy.ndarray or None
        (n + 1, 3) the settled cable [m] that ``final_deviation`` measures: the static
        equilibrium reached from the run's last state with ``settle_speed``
        (:func:`replay`), else the run's last shape.
    """

    knot_times: np.ndarray
    deviations: np.ndarray
    final_deviation: float
    settled: bool
    peak_tension: float
    peak_time: float
    peak_link: int
    tensile_limit: float | None
    tolerance: float
    ok: bool
    message: str
    simulation: Simulation
    segment_deviations: np.ndarray
    motion_peak_tension: float
    law: TimeLaw
    tensions: np.ndarray
    contact_names: tuple[str, ...] = ()
    contact_gaps: np.ndarray | None = None
    contact_tolerance: float = 0.0
    rest_shape: np.ndarray | None = None

    @property
    def max_deviation(self) -> float:
        """Largest knot deviation [m]."""
        return float(np.max(self.deviations))

    def _window(self, start: float, end: float) -> np.ndarray:
        times = self.simulation.times
        inside = (times >= start - 1e-12) & (times <= end + 1e-12)
        if not inside.any():  # a window between two records: the nearer record
            inside[int(np.argmin(np.abs(times - 0.5 * (start + end))))] = True
        return inside

    def peak_tension_between(self, start: float, end: float) -> tuple[float, float, int]:
        """Largest link tension [N] over the records in [start, end] [s] (the replay's clock),
        with its time [s] and link."""
        inside = self._window(start, end)
        tensions = self.tensions[inside]
        when, link = np.unravel_index(int(np.argmax(tensions)), tensions.shape)
        return float(tensions[when, link]), float(self.simulation.times[inside][when]), int(link)

    def contact_between(self, start: float, end: float) -> dict:
        """Per obstacle: ``(closed at start, closed at end, first time it opened, first time it
        closed)`` over the records in [start, end] [s] (None where it did not)."""
        inside = self._window(start, end)
        times = self.simulation.times[inside]
        out = {}
        for k, name in enumerate(self.contact_names):
            closed = self.contact_gaps[inside, k] < self.contact_tolerance
            opened = np.flatnonzero(closed[:-1] & ~closed[1:])
            shut = np.flatnonzero(~closed[:-1] & closed[1:])
            out[name] = (bool(closed[0]), bool(closed[-1]),
                         float(times[opened[0] + 1]) if len(opened) else None,
                         float(times[shut[0] + 1]) if len(shut) else None)
        return out

    @property
    def success(self) -> bool:
        """Same as ``ok``."""
        return self.ok


def _times_and_poses(trajectory) -> tuple:
    """``(times, poses)`` of a trajectory in a form :func:`as_clip_trajectory` takes, the poses
    checked, the times as given (a time law's knot times repeat across a segment where nothing
    moves: a trajectory through two equal shapes)."""
    if isinstance(trajectory, ClipTrajectory):
        return trajectory.times, trajectory.poses
    if isinstance(trajectory, tuple) and len(trajectory) == 2:
        times, poses = trajectory
    elif hasattr(trajectory, "times") and hasattr(trajectory, "poses"):
        times, poses = trajectory.times, trajectory.poses
    else:
        raise ValueError(
            f"trajectory: got {type(trajectory).__name__}, expected a ClipTrajectory, a pair "
            f"(times, list of ClipPoses) or an object with .times and .poses"
        )
    poses = list(poses)
    for k, pose in enumerate(poses):
        if not isinstance(pose, ClipPoses):
            raise ValueError(f"trajectory: pose {k} is {type(pose).__name__}, expected ClipPoses")
    return times, poses


def as_clip_trajectory(trajectory) -> ClipTrajectory:
    """A :class:`ClipTrajectory` from one, from ``(times, poses)``, or from any object with
    ``times`` (K,) [s] and ``poses`` (K ClipPoses) attributes (the timed dual-arm trajectory)."""
    if isinstance(trajectory, ClipTrajectory):
        return trajectory
    times, poses = _times_and_poses(trajectory)
    return ClipTrajectory(as_times(times, len(poses), "trajectory times"), poses)


def clip_motion(law: TimeLaw, poses, rate: float = CLIP_RATE) -> ClipTrajectory:
    """The clips moving through their knot poses under a time law, sampled for the simulator.

    Parameters
    ----------
    law : TimeLaw
        The trajectory's time law (``Trajectory.law``), K knots.
    poses : sequence of ClipPoses
        The K clip poses at the knots (the planned gripper poses).
    rate : float
        Samples per second [Hz]; the knot times are always samples.
    """
    poses = list(poses)
    if not isinstance(law, TimeLaw):
        raise ValueError(f"law: got {type(law).__name__}, expected a TimeLaw")
    if len(poses) != len(law.knot_times) or not all(isinstance(p, ClipPoses) for p in poses):
        raise ValueError(f"poses: expected {len(law.knot_times)} ClipPoses, one per knot of "
                         "the time law")
    times = np.union1d(sample_times(law.duration, rate), law.knot_times)
    times = times[np.r_[True, np.diff(times) > 1e-9]]
    positions = np.stack([p.positions for p in poses])
    rotations = tuple(Rotation.concatenate([p.rotations[c] for p in poses]) for c in (0, 1))
    pos, rots = interpolate_poses(law, positions, rotations, times)
    return ClipTrajectory.sampled(times, pos, np.stack([r.as_quat() for r in rots], axis=1))


def fictitious_cable(cable: Cable, youngs_modulus_cap: float | None) -> Cable:
    """The cable the replay simulates: with a cap, its moduli (bending and axial) are lowered to
    the cap -- the thesis' fictitious modulus (Fig. 6.5), which makes a stiff cable's explicit
    time step hundreds of times larger and keeps the scheme stable (a cap on the step alone
    diverges, since the forces would still be the stiff cable's)."""
    if youngs_modulus_cap is None or cable.axial_youngs_modulus <= youngs_modulus_cap and \
            cable.youngs_modulus <= youngs_modulus_cap:
        return cable
    axial = None if cable.axial_modulus is None else min(cable.axial_modulus, youngs_modulus_cap)
    return replace(cable, youngs_modulus=min(cable.youngs_modulus, youngs_modulus_cap),
                   axial_modulus=axial)


def replay(
    cable: Cable,
    stabilized_shapes,
    trajectory,
    *,
    knot_times=None,
    law: TimeLaw | None = None,
    gravity=GRAVITY,
    tensile_limit: float | None = None,
    tolerance: float = 0.01,
    rest_speed: float = 1e-4,
    settle_duration: float = 5.0,
    dt: float | None = None,
    youngs_modulus_cap: float | None = None,
    max_steps: int = 10_000_000,
    damping: str = "relative",
    torsion: bool = False,
    contacts=(),
    friction: float = 0.0,
    cable_at=None,
    record_interval: float | None = None,
    scheme: str = "auto",
    changes_at: float | None = None,
    settle_speed: float | None = None,
    obstacles=(),
) -> Replay:
    """Simulate the timed plan at its real speed and compare with the planned shapes.

    Parameters
    ----------
    cable : Cable
        The cable.
    stabilized_shapes : array_like
        (S + 2, n + 1, 3) planned stabilized shapes [m]; the run starts at rest in the first.
    trajectory : ClipTrajectory or (times, poses) or object with ``times`` and ``poses``
        Timed clip poses driving the held points [s], [ClipPoses]. With ``law``: the S + 2
        clip poses at the knots (a list, or the poses of any of these forms), moved by the
        law (:func:`clip_motion`).
    knot_times : array_like, optional
        (S + 2,) times of the planned shapes on the trajectory's clock [s]; default the
        law's, or the trajectory's own times when it has one pose per shape.
    law : TimeLaw, optional
        The time law of the timed dual-arm trajectory (``Trajectory.law``): the clips follow
        it (module docstring). Default: constant speed between the knot times.
    gravity : array_like
        Gravity [m/s^2].
    tensile_limit : float, optional
        Largest axial force the cable may carry [N].
    tolerance : float
        Largest deviation accepted [m] (default 1 cm, the thesis' T_cf of 5.3).
    rest_speed : float
        Speed below which the settling cable is at rest [m/s].
    settle_duration : float
        Longest simulated time after the last knot [s].
    dt, youngs_modulus_cap, max_steps
        Passed to :func:`dloplan.sim.dynamics.simulate`.

    damping : {"relative", "absolute"}
        Damping of the simulator (:func:`dloplan.sim.dynamics.simulate`). The default damps
        only relative motion of neighbouring points: the thesis' absolute damping is a drag
        larger than a light cable's weight at 0.1 m/s, which would make the cable lag behind
        the grippers by centimetres for no physical reason.

    torsion : bool
        Simulate with twist (quasi-static angles, :func:`dloplan.sim.dynamics.simulate`): the
        gripper frames then matter, not only the held links' directions. Slower (~2 ms/step).
    scheme : {"auto", "explicit", "implicit"}
        Time stepping (module docstring, *Scheme*): ``"explicit"`` the thesis' eq. 3.24 at
        its time step; ``"implicit"`` linearly implicit Euler at :data:`IMPLICIT_STEP` (or
        ``dt``); ``"auto"`` (default) implicit where it applies (no torsion, changing cable
        or tensile limit), explicit otherwise and, when an implicit step finds the chain's
        stiffness indefinite, from the state the implicit run gives back on.
    changes_at : float, optional
        With ``cable_at``: the time on the trajectory's clock [s] before which ``cable_at``
        gives the cable at the start (a harness section not yet pulled). ``"auto"`` then steps
        implicitly until then and explicitly from that state on, with or without a tensile
        limit (module docstring, *Scheme*).
    settle_speed : float, optional
        Speed [m/s] (above ``rest_speed``) down to which the settling is stepped; the settled
        cable is then the static equilibrium reached from the run's last state, with the
        contacts (module docstring; :func:`quasi_static_speed`). Where no converged, stable
        equilibrium is found from there, the run is stepped on to ``rest_speed``, explicitly.
        Default: stepped to ``rest_speed``.
    obstacles : sequence, optional
        Volumes (``Box``, ``Cylinder``, ``Table``) the recorded cable must stay out of, though
        the run does not feel them (unlike ``contacts``): the avoidance (thesis 5.4) checks
        the planned shapes only, and the cable moving between two of them can sweep through
        an obstacle. A record whose links enter one by more than the contact tolerance
        (:data:`CONTACT_GAP` times the radius) fails the replay (:func:`obstacle_entry`).

    Returns
    -------
    Replay
        Deviations [m], settling, peak axial force [N], verdict and the recorded run.
    """
    path = as_path(stabilized_shapes, cable.n_points, "stabilized_shapes")
    if law is not None:
        poses = trajectory if isinstance(trajectory, list) else _times_and_poses(
            trajectory)[1]
        clips = clip_motion(law, poses)
        knot_times = law.knot_times if knot_times is None else knot_times
    else:
        clips = as_clip_trajectory(trajectory)
    if knot_times is None:
        if len(clips.times) != len(path):
            raise ValueError(
                f"knot_times: required, the trajectory has {len(clips.times)} poses for "
                f"{len(path)} shapes"
            )
        knot_times = clips.times
    knots = as_times(knot_times, len(path), "knot_times", repeats=law is not None)
    start = clips.times[0]
    if knots[0] < start or knots[-1] > clips.times[-1]:
        raise ValueError(
            f"knot_times: [{knots[0]}, {knots[-1]}] s lie outside the trajectory's "
            f"[{start}, {clips.times[-1]}] s"
        )
    for name, value in (("tolerance", tolerance), ("rest_speed", rest_speed),
                        ("settle_duration", settle_duration)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}: got {value!r}, expected a number > 0")
    if settle_speed is not None and not (math.isfinite(settle_speed)
                                         and settle_speed > rest_speed):
        raise ValueError(f"settle_speed: got {settle_speed!r}, expected a speed above "
                         f"rest_speed = {rest_speed!r} [m/s] or None")
    stop = rest_speed if settle_speed is None else float(settle_speed)
    if tensile_limit is not None and not (math.isfinite(tensile_limit) and tensile_limit > 0):
        raise ValueError(f"tensile_limit: got {tensile_limit!r}, expected a force > 0 [N] or None")
    shifted = ClipTrajectory(clips.times - start, clips.poses)
    knots = knots - start
    motion = float(shifted.times[-1])
    if scheme not in ("auto", *SCHEMES):
        raise ValueError(f"scheme: got {scheme!r}, expected 'auto', 'explicit' or 'implicit'")
    model = fictitious_cable(cable, youngs_modulus_cap)
    implicit = scheme == "implicit" or (scheme == "auto" and not torsion
                                        and tensile_limit is None and cable_at is None)
    changing = None
    if cable_at is not None:
        last: list = [None, None]  # cable_at's last cable and its fictitious one

        def changing(t: float) -> Cable:
            real = cable_at(t + start)
            if real is not last[0]:  # the same object: the simulator keeps its constants
                last[:] = real, fictitious_cable(real, youngs_modulus_cap)
            return last[1]

    def explicit_step() -> float:
        if dt is not None:
            return dt
        if changing is None:
            return model.time_step()
        return min(model.time_step(), changing(motion).time_step())  # the shortest links

    step = explicit_step() if not implicit else IMPLICIT_STEP if dt is None else dt
    duration = motion + settle_duration
    spacing = np.diff(knots)
    spacing = spacing[spacing > 0]  # a repeated knot: a segment where nothing moves
    finest = float(np.min(spacing)) / 20.0 if len(spacing) else duration

    def run_with(step: float, scheme: str, begin: float = 0.0, end: float = duration,
                 state: Simulation | None = None, fixed: bool = False,
                 until: float = stop) -> Simulation:
        """The simulation from ``begin`` to ``end`` [s] on the replay's clock, from the first
        shape at rest or from the last state of ``state``, stopped when at rest (every point
        slower than ``until`` [m/s] once the clips stop); ``fixed``: with the cable
        ``changing`` gives at ``begin`` throughout (it does not change before ``end``)."""
        longest = max(step, duration / MAX_RECORDS) if record_interval is None else max(
            step, float(record_interval))
        clock = shifted if begin == 0.0 else ClipTrajectory(shifted.times - begin,
                                                            shifted.poses)
        later = None if fixed else changing if changing is None or begin == 0.0 else (
            lambda t: changing(t + begin))
        return simulate(model if changing is None or (begin == 0.0 and not fixed)
                        else changing(begin),
                        path[0] if state is None else state.shapes[-1], clock,
                        duration=end - begin, dt=step, gravity=gravity,
                        record_interval=min(longest, finest), rest_speed=until,
                        max_steps=max_steps, damping=damping, torsion=torsion,
                        contacts=contacts, friction=friction, cable_at=later, scheme=scheme,
                        initial_velocity=None if state is None else state.velocity)

    def explicit_after(first: Simulation, until: float = stop) -> Simulation:
        """``first`` continued explicitly from its last state to the end (to rest at
        ``until`` [m/s])."""
        begin = float(first.times[-1])
        return _joined(first, run_with(explicit_step(), "explicit", begin, state=first,
                                       until=until), begin)

    switch = None if changes_at is None else float(changes_at) - start
    if (scheme == "auto" and changing is not None and not torsion and switch is not None
            and IMPLICIT_STEP <= switch < motion):
        try:  # the fixed cable implicitly, up to the last whole step before it changes
            first = run_with(IMPLICIT_STEP, "implicit",
                             end=math.floor(switch / IMPLICIT_STEP) * IMPLICIT_STEP, fixed=True)
        except IndefiniteStep as stop:  # explicitly from the state it gave back
            first = stop.partial
        run = explicit_after(first)
    else:
        try:
            run = run_with(step, "implicit" if implicit else "explicit")
        except IndefiniteStep as stop:
            if scheme == "implicit":
                raise
            run = explicit_after(stop.partial)
    rest = run.shapes[-1]
    if settle_speed is not None and run.settled:
        end = float(run.times[-1])
        positions, quaternions = shifted.poses_at(np.array([end]))
        settled = equilibrium(model if changing is None else changing(end), rest,
                              ClipPoses(positions[0], Rotation.from_quat(quaternions[0])),
                              gravity=gravity, contacts=contacts)
        if settled.success:
            rest = settled.shape
        else:  # stepped on to rest, as without settle_speed
            run = explicit_after(run, rest_speed)
            rest = run.shapes[-1]
    deviations = np.array([_deviation_at(run, t, x) for t, x in zip(knots, path, strict=True)])
    final = float(np.max(np.linalg.norm(rest - path[-1], axis=1)))
    timing = law if law is not None else TimeLaw.constant_speed(knots)
    segments = _segment_deviations(run, path, timing, knots, deviations)
    tensions = _tensions(run, model, changing, gravity)
    when, link = np.unravel_index(int(np.argmax(tensions)), tensions.shape)
    peak = float(tensions[when, link])
    moving = run.times <= motion + 1e-12
    motion_peak = float(tensions[moving].max())
    within = tensile_limit is None or peak <= tensile_limit
    problems = []
    worst = int(np.argmax(deviations))
    if deviations[worst] > tolerance:
        problems.append(f"shape {worst} deviates {1e3 * deviations[worst]:.1f} mm at "
                        f"t = {knots[worst]:.3g} s (tolerance {1e3 * tolerance:.1f} mm)")
    if final > tolerance:
        problems.append(f"the settled cable ends {1e3 * final:.1f} mm from the last shape")
    if not run.settled:
        problems.append(f"not at rest {settle_duration:.3g} s after the motion ({run.message})")
    if not within:
        problems.append(f"peak tension {peak:.3g} N exceeds the limit {tensile_limit:.3g} N "
                        f"(link {link}, t = {run.times[when]:.3g} s)")
    entry = obstacle_entry(run, obstacles, cable.diameter / 2, knots)
    if entry:
        problems.append(entry)
    summary = (f"max deviation {1e3 * float(np.max(deviations)):.2f} mm at the shapes, "
               f"{1e3 * float(np.max(segments, initial=0.0)):.2f} mm along the segments, "
               f"settled {1e3 * final:.2f} mm, peak tension {motion_peak:.3g} N in motion, "
               f"{peak:.3g} N overall")
    message = "; ".join(problems) + f" ({summary})" if problems else f"replay ok: {summary}"
    gaps = np.zeros((len(run.times), 0))
    if len(contacts):  # the gap is minus the deepest penetration
        gaps = -np.stack([np.max(depth, axis=1) for depth, _ in
                          penetrations(run.shapes, contacts, cable.diameter / 2)], axis=1)
    names = tuple(str(getattr(c, "name", type(c).__name__)) for c in contacts)
    return Replay(knots, deviations, final, bool(run.settled), peak, float(run.times[when]),
                  int(link), tensile_limit, float(tolerance), not problems, message, run,
                  segments, motion_peak, timing, tensions, names, gaps,
                  CONTACT_GAP * cable.diameter / 2, rest)


def obstacle_entry(run: Simulation, obstacles, radius: float, knots: np.ndarray) -> str:
    """Where the recorded cable enters an obstacle deepest, or ``""`` when no record's links
    (capsules of ``radius`` [m]) enter one by more than :data:`CONTACT_GAP` times the radius.

    Parameters
    ----------
    run : Simulation
        The recorded run: (R, n + 1, 3) shapes [m] at (R,) times [s].
    obstacles : sequence
        Volumes with ``penetration(a, b, radius)`` (:mod:`dloplan.obstacles`).
    radius : float
        The cable's radius [m].
    knots : numpy.ndarray
        (S + 2,) the planned shapes' times on the run's clock [s], to name the segment.
    """
    shapes = run.shapes
    step = max(1, ENTRY_CHUNK // max(shapes.shape[1] - 1, 1))   # records at a time
    worst = (0.0, "", 0)
    for begin in range(0, len(shapes), step):
        chunk = shapes[begin:begin + step]
        a, b = chunk[:, :-1].reshape(-1, 3), chunk[:, 1:].reshape(-1, 3)
        middles = 0.5 * (a + b)
        half = 0.5 * np.linalg.norm(b - a, axis=1)
        for obstacle in obstacles:
            # a link can enter only where its middle is within the radius plus half its
            # length (the distance to a volume changes by at most the distance moved)
            near = np.flatnonzero(obstacle.distance(middles) - half < radius)
            depth = np.zeros(len(a))
            depth[near] = obstacle.penetration(a[near], b[near], radius)
            depth = depth.reshape(len(chunk), -1).max(axis=1)
            record = int(np.argmax(depth))
            if depth[record] > worst[0]:
                worst = (float(depth[record]), str(obstacle.name), begin + record)
    depth, name, record = worst
    if depth <= CONTACT_GAP * radius:
        return ""
    t = float(run.times[record])
    k = int(np.searchsorted(knots, t, side="right")) - 1
    where = (f"between shapes {k} and {k + 1}" if k < len(knots) - 1 else
             f"settling after shape {len(knots) - 1}")
    return (f"the moving cable enters {name} by {1e3 * depth:.1f} mm at t = {t:.3g} s ({where};"
            " the obstacle check sees the planned shapes, not the motion between them)")


def quasi_static_speed(cable: Cable, gravity=GRAVITY) -> float:
    """Speed [m/s] below which no point of a settling cable can rise by the contact tolerance
    (:data:`CONTACT_GAP` times the radius, h) on its own momentum against gravity:
    sqrt(2 |g| h). Slower, a contact no longer opens or closes by the cable's inertia, and what
    is left of the settling is its creep into the equilibrium the statics find
    (``replay(settle_speed=)``)."""
    g = float(np.linalg.norm(np.asarray(gravity, dtype=float)))
    return math.sqrt(2.0 * g * CONTACT_GAP * cable.diameter / 2)


def _joined(first: Simulation, then: Simulation, begin: float) -> Simulation:
    """Two runs as one: ``then`` continued ``first`` from its last state at ``begin`` [s]
    (its first record, that state, is dropped); the smaller time step of the two."""
    steps = first.steps + then.steps
    end = begin + float(then.times[-1])
    message = (f"at rest after {steps} steps ({end:.4g} s)" if then.settled
               else f"ran {steps} steps ({end:.4g} s)")
    return Simulation(np.concatenate([first.times, begin + then.times[1:]]),
                      np.concatenate([first.shapes, then.shapes[1:]]),
                      np.concatenate([first.max_speeds, then.max_speeds[1:]]),
                      min(first.dt, then.dt), steps,
                      then.settled, message, then.velocity)


def _tensions(run: Simulation, model: Cable, changing, gravity) -> np.ndarray:
    """(R, n) link tensions of the recorded shapes [N]: the forces of the springs the run
    simulated, of ``model`` or of the cable ``changing`` gives at each record's time (on the
    run's clock), taken per interval of :data:`~dloplan.sim.dynamics.SCHEDULE_INTERVAL` as the
    simulator takes it. A capped cable (:func:`fictitious_cable`) stretches more under the same
    load: its own springs give the load, the real cable's would give it times E_a / cap."""
    if changing is None:
        return link_tensions(SpringChain.from_cable(model, gravity), run.shapes)
    slots = np.floor(run.times / SCHEDULE_INTERVAL).astype(int)  # non-decreasing
    firsts = np.flatnonzero(np.r_[True, slots[1:] != slots[:-1]])  # each slot's first record
    out = np.empty((len(run.times), model.n_links))
    cables = [changing((slot + 0.5) * SCHEDULE_INTERVAL) for slot in slots[firsts]]
    # the records of consecutive slots with the same cable (the same chain) at once
    changes = [k for k in range(len(cables)) if k == 0 or cables[k] is not cables[k - 1]]
    for k, following in zip(changes, [*changes[1:], len(cables)], strict=True):
        rows = slice(firsts[k], firsts[following] if following < len(firsts) else len(slots))
        out[rows] = link_tensions(SpringChain.from_cable(cables[k], gravity), run.shapes[rows])
    return out


def _segment_deviations(run: Simulation, path: np.ndarray, law: TimeLaw, knots: np.ndarray,
                        at_knots: np.ndarray) -> np.ndarray:
    """(K - 1,) largest deviation over each segment from the planned cable at that instant.

    ``law`` runs on the simulation's clock (its knot times are ``knots``)."""
    if len(path) < 2:
        return np.zeros(0)
    inside = (run.times >= knots[0] - 1e-12) & (run.times <= knots[-1] + 1e-12)
    t = run.times[inside]
    planned = law.blend(path, t)[0]
    distance = np.linalg.norm(run.shapes[inside] - planned, axis=-1).max(axis=1)
    segment = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(path) - 2)
    out = np.maximum(at_knots[:-1], at_knots[1:])
    np.maximum.at(out, segment, distance)
    return out


def _deviation_at(run: Simulation, t: float, planned: np.ndarray) -> float:
    """Largest point distance between the recorded run, interpolated at time t, and a shape."""
    return float(np.max(np.linalg.norm(run.at(t)[0] - planned, axis=1)))


__all__ = ["CLIP_RATE", "CONTACT_GAP", "Replay", "as_clip_trajectory", "clip_motion",
           "quasi_static_speed", "replay"]
