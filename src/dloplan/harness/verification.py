"""Every check on the held cable of a harness job, with a verdict per phase (thesis 7.3).

The checks of :mod:`dloplan.verify` run on the model of :mod:`dloplan.harness.held`, phase by
phase (:data:`~dloplan.harness.held.CHECKED_PHASES`):

* **stability** of each configuration: the smallest eigenvalue of the constrained Hessian (the
  holders' points removed, the board's contacts acting with their exact stiffness,
  :func:`dloplan.verify.stability.elastic_stability`); each contact's state (pressing with a
  force, clear by a gap, sliding in the softest mode) is reported;
* **snap-through** along the phases that move: the continuation of
  :func:`dloplan.verify.snap.check_snap_through` between the configurations with the contacts
  (they may open and close; a jump with a contact's change names the obstacle); the tensioning
  is followed over the offset (the section getting shorter between the fixtures);
* **dynamic replay** of the timed trajectory in the simulator with the board's contacts
  (:func:`dloplan.verify.replay.replay`), in two runs: phase 1 and phase 2 (the section held by
  the grippers, along the trajectory's time law, to rest at the approach poses), then the
  insertion, the regrasp (the clips held for the regrasp's duration while the fixtures hold the
  cable) and the tensioning (the section shortened as the grippers' offset grows along the time
  law; the second run steps implicitly until the pull starts and explicitly through the pull,
  ``replay(changes_at=)``, and settles by the statics once the tensioned cable moves
  quasi-statically, ``replay(settle_speed=)``: no explicit steps for its creep to rest). Per
  phase: the largest deviation at its knots from the
  configurations [m], the peak link tension [N] (against the cable's rated load when given)
  and each contact opening or closing (a lift-off from a peg shows here);
* **the robot program**: its check rows of the phase's targets;
* **the regrasp**: the stubs beyond the fixtures sag while the grippers open
  (:func:`dloplan.harness.held.stub_sag`); more than the cable's diameter is a warning (the
  fingers, closing where they let go, are no longer centred on the cable).

A phase **fails** on an unstable configuration (or one that is not an equilibrium, or did not
converge), a snap-through event, a replay deviation above the tolerance (or a cable not at rest
after the motion), a link tension above the rated load (planned or replayed), a failing robot
check, or, in the tensioning, a peg that the tensioned cable does not press on (the board's
pegs are what the cable is tensioned against: :class:`~dloplan.harness.board.Peg`), the lift-off
named. Contacts that open or close elsewhere are reported, not failed.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

import numpy as np

from ..physics.chain import SpringChain, link_tensions
from ..sim.dynamics import ClipTrajectory
from ..trajectory import TimeLaw
from ..verify.replay import Replay, clip_motion, quasi_static_speed, replay
from ..verify.snap import SnapCheck, check_snap_through
from ..verify.stability import Stability, elastic_stabilities, quickest_method
from .held import CHECKED_PHASES, HeldModel, HeldPath, held_model
from .phases import fixture_clips
from .section import section_cable

MOVING = ("phase1", "phase2", "insertion", "tensioning")
"""The phases whose holders move (the snap-through continuation runs along them)."""

REPLAY_TOLERANCE = 0.01
"""Largest replay deviation accepted [m]: the thesis' T_cf (5.3), as for every plan."""

RECORD_INTERVAL = 1e-3
"""Time between the replay's recorded shapes [s] (its peaks and contact changes are sampled at
that resolution)."""

BOARD_FRICTION = 0.3
"""Coulomb friction coefficient of the board (pegs, plates, table) in the replay: PVC or
rubber cable sheaths on metal or wood are 0.3-0.5 (docs/decisions.md); the statics are
frictionless."""


@dataclass(frozen=True)
class PhaseRow:
    """One row of the harness verification table.

    Attributes
    ----------
    phase : str
        One of :data:`~dloplan.harness.held.CHECKED_PHASES`.
    holders : str
        What holds the cable.
    configurations : int
        Configurations checked for stability.
    stable : bool
        Every configuration is a stable equilibrium, with friction at its pressing contacts
        where it needs it (:attr:`~dloplan.verify.stability.Stability.stable_with_friction`;
        a configuration held by friction is a warning).
    smallest_eigenvalue : float
        Smallest eigenvalue of the constrained Hessian over the configurations [N/m].
    relative_eigenvalue : float
        The same over the section's stiffness scale lambda_ref.
    contacts : str
        The contacts at the phase's last configuration, and the changes along it.
    snap : bool or None
        A snap-through event along the phase (None: the phase does not move).
    replay_deviation : float or None
        Largest replay deviation at the phase's knots [m] (None: not replayed).
    peak_tension : float or None
        Largest link tension in the phase: the replay's when replayed, else the
        configurations' [N].
    rated_load : float or None
        The cable's rated load [N], when given.
    robot : bool or None
        The robot program's checks of the phase's targets pass (None: no program checked).
    verdict : str
        ``"ok"``, ``"warning"`` or ``"FAILED"``.
    notes : tuple of str
        What failed or warns, one line each.
    """

    phase: str
    holders: str
    configurations: int
    stable: bool
    smallest_eigenvalue: float
    relative_eigenvalue: float
    contacts: str
    snap: bool | None
    replay_deviation: float | None
    peak_tension: float | None
    rated_load: float | None
    robot: bool | None
    verdict: str
    notes: tuple[str, ...] = ()

    @property
    def failed(self) -> bool:
        """The phase fails its checks."""
        return self.verdict == "FAILED"


@dataclass(frozen=True, eq=False)
class HarnessVerification:
    """Result of :func:`verify_harness`.

    Attributes
    ----------
    rows : tuple of PhaseRow
        One per phase.
    ok : bool
        No phase failed.
    messages : tuple of str
        Every failure and warning, or one confirmation line.
    timings : dict
        Wall time per check [s].
    stability : dict
        Phase -> tuple of :class:`~dloplan.verify.stability.Stability` per configuration.
    snap : dict
        Phase -> :class:`~dloplan.verify.snap.SnapCheck` (the moving phases).
    replays : dict
        Phase -> :class:`PhaseReplay`: its part of one of the two runs (phases 1-2; insertion,
        regrasp, tensioning); empty when not replayed.
    model : HeldModel
        The model checked.
    """

    rows: tuple[PhaseRow, ...]
    ok: bool
    messages: tuple[str, ...]
    timings: dict = field(default_factory=dict)
    stability: dict = field(default_factory=dict)
    snap: dict = field(default_factory=dict)
    replays: dict = field(default_factory=dict)
    model: HeldModel | None = None

    @property
    def success(self) -> bool:
        """Same as ``ok``."""
        return self.ok

    def row(self, phase: str) -> PhaseRow:
        """The row of a phase."""
        for row in self.rows:
            if row.phase == phase:
                return row
        raise KeyError(phase)

    def table(self) -> str:
        """The table as fixed-width text (lengths in mm, forces in N)."""
        return phase_table(self.rows, self.ok, self.messages)

    @property
    def warnings(self) -> tuple[str, ...]:
        """The notes of the phases that warn (the plan passes with them)."""
        return tuple(f"{r.phase}: {note}" for r in self.rows if r.verdict == "warning"
                     for note in r.notes)

    def to_dict(self) -> dict:
        """JSON-ready: verdict, messages, warnings, timings and the rows per phase (SI units,
        None = not run)."""
        return {"ok": self.ok, "messages": list(self.messages), "warnings": list(self.warnings),
                "timings_s": dict(self.timings), "phases": [_json_row(row) for row in self.rows]}


def _json_row(row: PhaseRow) -> dict:
    out = {}
    for key, value in asdict(row).items():
        if isinstance(value, float) and not math.isfinite(value):
            value = None if math.isnan(value) else str(value)
        out[key] = list(value) if isinstance(value, tuple) else value
    return out


def phase_table(rows: Sequence[PhaseRow], ok: bool, messages: Sequence[str]) -> str:
    """The verdict table per phase as fixed-width text, with the verdict and its messages."""
    header = (f"{'phase':<10} {'held by':<8} {'conf':>4} {'stable':>6} {'lambda_1 [N/m]':>14} "
              f"{'snap':>5} {'replay [mm]':>11} {'peak [N]':>9} {'rated [N]':>9} {'robot':>5} "
              f"{'verdict':>7}  contacts")
    lines = [header]
    for r in rows:
        lines.append(
            f"{r.phase:<10} {r.holders:<8} {r.configurations:>4} {_flag(r.stable):>6} "
            f"{r.smallest_eigenvalue:>14.4g} {_event(r.snap):>5} "
            f"{_num(None if r.replay_deviation is None else 1e3 * r.replay_deviation, '.2f'):>11} "
            f"{_num(r.peak_tension, '.3g'):>9} {_num(r.rated_load, '.3g'):>9} "
            f"{_flag(r.robot):>5} {r.verdict:>7}  {r.contacts}")
    lines.append("verdict: " + ("ok" if ok else "FAILED") + " -- " + "; ".join(messages))
    return "\n".join(lines)


def _flag(value: bool | None) -> str:
    return "-" if value is None else ("yes" if value else "NO")


def _event(value: bool | None) -> str:
    return "-" if value is None else ("SNAP" if value else "no")


def _num(value, fmt: str) -> str:
    return "-" if value is None else format(value, fmt)


# -- the replay's two runs ------------------------------------------------------------------------
def _window(motion: ClipTrajectory, start: float, end: float) -> tuple:
    """The samples of a clip motion in [start, end] [s] (both included): times, positions,
    quaternions."""
    inside = motion.times[(motion.times > start) & (motion.times < end)]
    times = np.concatenate([[start], inside, [end]])
    positions, quaternions = motion.poses_at(times)
    return times, positions, quaternions


def _section_offset(motion: ClipTrajectory, slots, times: np.ndarray) -> np.ndarray:
    """Mean pull-apart offset of the two grippers from the slots along the fixture axes [m]."""
    positions, _ = motion.poses_at(times)
    pulled = np.einsum("tcj,cj->tc", slots.positions[None] - positions, slots.u_axes)
    return np.maximum(pulled.mean(axis=1), 0.0)


@dataclass(frozen=True, eq=False)
class PhaseReplay:
    """A phase's part of a replay run: the run, the phase's window on the run's clock [s] and
    the run's knots in the phase."""

    run: Replay
    start: float
    end: float
    knots: tuple[int, ...]


def _replays(model: HeldModel, times: np.ndarray, law: TimeLaw | None, clips: list,
             knots: dict, regrasp_time: float, options: dict) -> dict:
    """Run A (phases 1 and 2) and run B (insertion, regrasp, tensioning), module docstring:
    phase -> :class:`PhaseReplay`."""
    motion = clip_motion(law, clips) if law is not None else ClipTrajectory(times, clips)
    paths = model.paths
    k2 = knots["phase2"][1]
    first = np.concatenate([paths["phase1"].shapes, paths["phase2"].shapes[1:]])
    window = _window(motion, times[0], times[k2])
    run_a = replay(paths["phase1"].cable, first, ClipTrajectory.sampled(*window),
                   knot_times=times[: k2 + 1], contacts=model.contacts, **options)
    out = {}
    for phase in ("phase1", "phase2"):
        a, b = knots[phase]
        end = run_a.knot_times[b] if phase == "phase1" else float(run_a.simulation.times[-1])
        out[phase] = PhaseReplay(run_a, float(run_a.knot_times[a]), float(end),
                                 tuple(range(a, b + 1)))
    # run B on its own clock: the insertion, the regrasp's pause, the tensioning
    k_slots, k_end = knots["insertion"][1], knots["tensioning"][1]
    slots = fixture_clips(model.board, inserted=True)
    t_in, p_in, q_in = _window(motion, times[k2], times[k_slots])
    inserted = times[k_slots] > times[k2]  # no time: fixtures of depth 0, laid in, not pushed
    if not inserted:  # one instant: the slots' knot, where run B starts
        t_in, p_in, q_in = t_in[:1], p_in[:1], q_in[:1]
    t_pull = _window(motion, times[k_slots], times[k_end])[0]
    pulled_apart = times[k_end] > times[k_slots]  # no time: a cable taut in the slots already
    if not pulled_apart:  # one instant: the regrasp's end is the tensioning's
        t_pull = t_pull[:1]
    pause = float(regrasp_time)
    start_pull = times[k_slots] + pause
    held = np.concatenate([[start_pull], t_pull[1:] + pause] if pause > 0 else [t_pull[1:]])
    t_b = np.concatenate([t_in, held])
    p_b = np.concatenate([p_in, np.broadcast_to(slots.positions, (len(held), 2, 3))])
    q_b = np.concatenate([q_in, np.broadcast_to(slots.rotations.as_quat(), (len(held), 2, 4))])
    offsets = _section_offset(motion, slots, t_pull)
    pulled = t_pull - times[k_slots]
    cable, n_links = model.cable, model.section_links

    sections: dict[float, object] = {}  # one cable per offset: the simulator reuses its chain

    def cable_at(t: float):
        d = float(np.interp(t - start_pull, pulled, offsets)) if t > start_pull else 0.0
        if d not in sections:
            sections[d] = section_cable(cable, n_links, d)
        return sections[d]

    insertion, tensioning = paths["insertion"], paths["tensioning"]
    paused = pause > 0 and pulled_apart  # a knot of its own between the regrasp and the pull
    shapes = list(insertion.shapes[0 if inserted else 1:2]) + (
        [insertion.shapes[1]] if paused else []) + [tensioning.shapes[-1]]
    knot_times = ([times[k2]] if inserted else []) + [times[k_slots]] + (
        [start_pull] if paused else []) + [times[k_end] + pause]
    run_b = replay(insertion.cable, np.stack(shapes), ClipTrajectory.sampled(t_b, p_b, q_b),
                   knot_times=np.array(knot_times), contacts=model.contacts, cable_at=cable_at,
                   changes_at=start_pull,
                   settle_speed=quasi_static_speed(insertion.cable, model.gravity), **options)
    kb, k = run_b.knot_times, int(inserted)  # run B's knot of the cable in the slots
    out["insertion"] = PhaseReplay(run_b, float(kb[0]), float(kb[k]), tuple(range(k + 1)))
    out["regrasp"] = PhaseReplay(run_b, float(kb[k]), float(kb[-2]), (len(kb) - 2,))
    out["tensioning"] = PhaseReplay(run_b, float(kb[-2]), float(run_b.simulation.times[-1]),
                                    (len(kb) - 1,))
    return out


# -- the checks -----------------------------------------------------------------------------------
def _stabilities(path: HeldPath, contacts, gravity) -> tuple[Stability, ...]:
    # the snap check's eigen-solver (LAPACK's banded one for a section's size): ARPACK's
    # eigenvalues to within 0.3 % of their certified accuracy (verify.lowest), in half the time
    return elastic_stabilities(path.cables, path.shapes, gravity=gravity, contacts=contacts,
                               method=quickest_method(path.cable.n_points))


def _snap(path: HeldPath, contacts, gravity) -> SnapCheck:
    return check_snap_through(path.cable, path.shapes, list(path.clips), gravity=gravity,
                              contacts=contacts, cables=path.cables,
                              solved=path.substeps or None)


def _robot(rows, knots: Sequence[int]) -> tuple[bool | None, list[str]]:
    """The robot check rows of a phase's targets: verdict and the failures."""
    if rows is None:
        return None, []
    mine = [r for r in rows if _field(r, "shape") in knots]
    failed = [r for r in mine if not _field(r, "ok")]
    notes = [f"robot: {_field(r, 'check')} fails at {_field(r, 'label')} "
             f"({_field(r, 'arm')}: {_field(r, 'value'):.4g} {_field(r, 'unit')})"
             for r in failed]
    return not failed, notes


def _field(row, name: str):
    return row[name] if isinstance(row, dict) else getattr(row, name)


def _contacts_summary(stab: Stability, changes: list[str]) -> str:
    pressing = [f"{s.name} {s.force:.3g} N" for s in stab.contacts if s.active]
    text = ", ".join(pressing) if pressing else "clear"
    return text + ("; " + ", ".join(changes) if changes else "")


def verify_harness(
    model: HeldModel,
    times,
    clips: Sequence,
    knots: dict,
    *,
    law: TimeLaw | None = None,
    regrasp_time: float = 0.0,
    rated_load: float | None = None,
    robot_rows: Sequence | None = None,
    snap: bool = True,
    replay_run: bool = True,
    tolerance: float = REPLAY_TOLERANCE,
    youngs_modulus_cap: float | None = None,
    progress=lambda text: None,
) -> HarnessVerification:
    """Check the held cable of a harness job phase by phase (module docstring).

    Parameters
    ----------
    model : HeldModel
        The held cable (:func:`dloplan.harness.held.held_model`).
    times : array_like
        (K,) the trajectory's knot times [s].
    clips : sequence of ClipPoses
        The grippers' clip poses at the K knots.
    knots : dict
        Phase name -> (first, last) knot.
    law : TimeLaw, optional
        The trajectory's time law (the clips follow it in the replay); default constant speed
        between the knots.
    regrasp_time : float
        Duration of the regrasp in the slots [s] (the replay holds the clips that long).
    rated_load : float, optional
        The largest tension the cable may carry [N].
    robot_rows : sequence, optional
        The robot program's check rows (objects or mappings with ``shape``, ``ok``, ``check``,
        ``label``, ``arm``, ``value``, ``unit``): each phase gets those of its knots.
    snap, replay_run : bool
        Run the snap-through continuation, the dynamic replay.
    tolerance : float
        Largest replay deviation accepted [m].
    youngs_modulus_cap : float, optional
        Fictitious modulus of the replay (:func:`dloplan.verify.replay.replay`).
    progress : callable
        Called with a line of text before each long check.

    Returns
    -------
    HarnessVerification
    """
    t = np.asarray(times, dtype=float)
    poses = list(clips)
    if len(poses) != len(t):
        raise ValueError(f"clips: {len(poses)} clip poses for {len(t)} knot times")
    if rated_load is not None and not (math.isfinite(rated_load) and rated_load > 0):
        raise ValueError(f"rated_load: got {rated_load!r}, expected a force > 0 [N] or None")
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"tolerance: got {tolerance!r}, expected a distance > 0 [m]")
    if not (math.isfinite(regrasp_time) and regrasp_time >= 0):
        raise ValueError(f"regrasp_time: got {regrasp_time!r}, expected a duration >= 0 [s]")
    contacts, gravity = model.contacts, model.gravity
    timings: dict[str, float] = {}

    progress("harness verification: stability of every configuration with the board's contacts")
    start = time.perf_counter()
    stability = {phase: _stabilities(path, contacts, gravity)
                 for phase, path in model.paths.items()}
    timings["stability"] = time.perf_counter() - start

    snaps: dict[str, SnapCheck] = {}
    if snap:
        progress("harness verification: snap-through along each phase (continuation with "
                 "contacts)")
        start = time.perf_counter()
        snaps = {phase: _snap(model.paths[phase], contacts, gravity) for phase in MOVING}
        timings["snap"] = time.perf_counter() - start

    runs: dict = {}
    if replay_run:
        progress("harness verification: dynamic replay with the fixtures and pegs")
        start = time.perf_counter()
        runs = _replays(model, t, law, poses, knots, regrasp_time,
                        {"tolerance": tolerance, "tensile_limit": rated_load,
                         "youngs_modulus_cap": youngs_modulus_cap,
                         "friction": BOARD_FRICTION, "record_interval": RECORD_INTERVAL})
        timings["replay"] = time.perf_counter() - start

    rows = [_phase_row(model, phase, stability[phase], snaps.get(phase), runs, knots,
                       rated_load, robot_rows, tolerance)
            for phase in CHECKED_PHASES]
    ok = not any(r.failed for r in rows)
    messages = [f"{r.phase}: {note}" for r in rows for note in r.notes]
    if not messages:
        checks = ["stability"] + (["snap-through"] if snap else []) + (
            ["replay"] if replay_run else []) + (["robot"] if robot_rows is not None else [])
        messages = [f"{len(rows)} phases pass: {', '.join(checks)}"]
    return HarnessVerification(tuple(rows), ok, tuple(messages), timings, stability, snaps,
                               runs, model)


def verify_harness_result(result, **options) -> HarnessVerification:
    """:func:`verify_harness` of a job's :class:`~dloplan.harness.job.HarnessResult`: its held
    cable (:func:`~dloplan.harness.held.held_model`), trajectory, regrasp time and rated load;
    ``options`` as :func:`verify_harness`'s (``rated_load`` overrides the result's)."""
    ins = result.insertion
    if math.isnan(ins.offset):
        raise ValueError(f"result: the tensioning failed ({ins.message}): nothing to verify")
    clips = [result.grippers.clip_poses(k) for k in range(len(result.shapes))]
    sections = np.stack([ins.lowering[0].shape, ins.inserted.shape,
                         ins.tensioned.equilibrium.shape])
    model = held_model(result.cable, result.board, result.shapes, clips, result.knots,
                       ins.offset, ins.tensioned.section.n_links, sections)
    options = {"rated_load": result.rated_load,
               "regrasp_time": result.cycle.breakdown().get("regrasp", 0.0), **options}
    return verify_harness(model, result.trajectory.times, clips, result.knots,
                          law=result.trajectory.law, **options)


def _phase_row(model: HeldModel, phase: str, stabs, snap_check, runs, knots, rated_load,
               robot_rows, tolerance) -> PhaseRow:
    path = model.paths[phase]
    notes, warnings = [], []
    for label, stab in zip(path.labels, stabs, strict=True):
        if not stab.stable_with_friction:
            notes.append(f"{label}: {stab.message}")
        elif stab.held_by_friction:
            warnings.append(f"{label}: {stab.message}")
    smallest = min(stabs, key=lambda s: s.smallest)
    changes: list[str] = []
    snap_flag = None
    if snap_check is not None:
        snap_flag = bool(snap_check.events)
        notes += [e.message for e in snap_check.events]
        changes += [f"{c.name} {c.change}" for c in snap_check.contact_changes]
    deviation = peak = None
    part = runs.get(phase)
    if part is not None:
        run = part.run
        deviation = float(np.max(run.deviations[list(part.knots)]))
        if phase in ("phase2", "tensioning"):  # the runs end settling
            deviation = max(deviation, run.final_deviation)
            if not run.settled:
                notes.append(f"replay: not at rest after the motion ({run.simulation.message})")
        if deviation > tolerance:
            notes.append(f"replay: the cable deviates {1e3 * deviation:.1f} mm from its "
                         f"configuration (tolerance {1e3 * tolerance:.1f} mm)")
        peak, when, link = run.peak_tension_between(part.start, part.end)
        for name, (closed_before, closed_after, opened, shut) in \
                run.contact_between(part.start, part.end).items():
            if opened is not None and not closed_after:
                changes.append(f"{name} lift-off (replay, t = {opened:.2f} s)")
            elif shut is not None and closed_after and not closed_before:
                changes.append(f"{name} touch-down (replay, t = {shut:.2f} s)")
        if rated_load is not None and peak > rated_load:
            notes.append(f"replay: the peak tension {peak:.3g} N exceeds the cable's rated load "
                         f"{rated_load:.3g} N (link {link}, t = {when:.2f} s)")
    statics_peak = max(float(np.max(_tensions(cable, x))) for cable, x in
                       zip(path.cables, path.shapes, strict=True))
    if rated_load is not None and statics_peak > rated_load:
        notes.append(f"the configurations carry {statics_peak:.3g} N, above the cable's rated "
                     f"load {rated_load:.3g} N: no timing avoids it")
    if peak is None:
        peak = statics_peak
    if path.settle_distance > tolerance:
        where = ("the tensioned cable ends" if phase == "tensioning" else
                 "the cable rests")
        text = (f"{where} up to {1e3 * path.settle_distance:.1f} mm from the plan's shapes "
                f"(tolerance {1e3 * tolerance:.1f} mm)")
        # the plan's offset and forces hold for its tensioned shape only
        (notes if phase == "tensioning" else warnings).append(text)
    if phase == "tensioning":
        last = stabs[-1]
        for peg in model.board.pegs:
            state = next(s for s in last.contacts if s.name == peg.name)
            if not state.active:
                was = next(s for s in stabs[0].contacts if s.name == peg.name)
                how = "lifts off it" if was.active else "does not reach it"
                notes.append(f"the tensioned cable {how} (clear of {peg.name} by "
                             f"{1e3 * state.gap:.1f} mm): the route does not press on the "
                             "peg it is tensioned against")
    if phase == "regrasp":
        for stub in model.stubs:
            if stub.sag > model.cable.diameter:
                warnings.append(f"the stub beyond {stub.fixture} sags {1e3 * stub.sag:.1f} mm "
                                f"while the grippers regrasp, more than the cable's diameter "
                                f"({1e3 * model.cable.diameter:.1f} mm)")
    robot_ok, robot_notes = _robot(robot_rows, path.knots)
    notes += robot_notes
    verdict = "FAILED" if notes else ("warning" if warnings else "ok")
    return PhaseRow(phase, path.holders, len(path.shapes),
                    all(s.stable_with_friction for s in stabs),
                    smallest.smallest, smallest.relative, _contacts_summary(stabs[-1], changes),
                    snap_flag, deviation, peak, rated_load, robot_ok, verdict,
                    tuple(notes + warnings))


def _tensions(cable, x):
    return link_tensions(SpringChain.from_cable(cable), x)


__all__ = ["BOARD_FRICTION", "MOVING", "REPLAY_TOLERANCE", "HarnessVerification", "PhaseReplay",
           "PhaseRow", "phase_table", "verify_harness", "verify_harness_result"]
