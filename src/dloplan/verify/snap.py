"""Snap-through along a planned path: quasi-static continuation between consecutive clip poses.

The planner gives stabilized shapes at the planned clip poses only. Between two of them the
robot moves the clips continuously (linear in position, slerp in rotation,
:func:`dloplan.sim.statics.interpolate_clips`), and a slowly moved cable follows its equilibrium
branch, warm start after warm start (:func:`dloplan.sim.statics.equilibrium`). That branch may
end at a fold, or lose stability at a bifurcation: the cable then *snaps*, jumping to another
equilibrium far from the one it left, with a velocity no robot controls. This module follows the
branch in small sub-steps and flags such events.

Definitions
-----------
clip motion
    Between two clip poses, the largest over the two clips of |dp| + L dtheta [m]: the
    translation of the clip point plus the rotation angle of its u-axis times the cable length L
    (how far a rigid cable of length L swung by the clip would move). Roll about u is not
    counted: it does not move a torsion-free cable.
sub-steps
    A segment is split into sub-steps whose clip motion is at most ``max_clip_step`` times L
    (default 0.5 %), so that smooth motions change the shape by small amounts.
ratio
    Shape change of one sub-step (largest point displacement [m]) over its clip motion [m]. Along
    a smooth branch it is bounded and independent of the step size; at a fold or a bifurcation
    it is unbounded (a finite jump over a vanishing clip motion, or a square-root branch).
snap (critical point)
    Along a branch, the rate of shape change is about (clip forcing) / lambda_1: it is unbounded
    exactly where the smallest eigenvalue lambda_1 of the followed equilibrium reaches zero, at a
    fold (the branch ends: a finite jump) or at a bifurcation (the branch loses stability and the
    cable leaves it along a square-root branch, in a direction decided by imperfections). A run
    of sub-steps is a *candidate window* when a ratio exceeds ``jump_ratio`` (default 5) or when
    the sampled lambda_1 has a local minimum below :data:`DIP` times its larger neighbour. In
    the window (widened by one sub-step on each side) lambda_1 is minimized over the fraction t
    by Brent's bounded method (``scipy.optimize.minimize_scalar``), each equilibrium solved from
    the last shape before the window, to 2^-``refinements`` of the window's width. The window
    is a snap when that minimum is below :data:`CRITICAL` times lambda_1 at the window's ends: a
    steep but smooth change keeps lambda_1 away from zero and is only reported (``max_ratio``).
unstable
    A sub-step whose equilibrium is not a stable minimum (solver not converged, or smallest
    eigenvalue not above the threshold of :func:`dloplan.verify.stability.elastic_stability`):
    the smallest eigenvalue has crossed zero. With contacts the eigenvalue followed is the one
    with the pressing points sticking (``Stability.sticking``): a slack cable that the
    frictionless model lets slide along a plate is held there by friction, which the
    continuation reports through its contact states rather than as a snap.
branch
    The continuation ends farther than ``branch_tolerance`` (default 1 mm) from the planned
    stabilized shape of the segment's end: the plan's shape is not the one the motion produces.

contacts
    With ``contacts`` (pegs, plates, the table) every equilibrium and stability test includes
    them as one-sided contacts (:mod:`dloplan.verify.contacts`); a contact may open or close
    along the way. Each opening (``"lift-off"``) and closing (``"touch-down"``) is recorded with
    its sub-step (:class:`ContactChange`); it is not an event by itself. A snap whose window
    holds a change names the obstacle, and a sub-step whose shape jumps (ratio above
    ``jump_ratio``) while a contact changes is an event of its own (``"contact"``): the contact's
    state jumped, the cable with it.
changing cable
    With ``cables`` (one :class:`~dloplan.cable.Cable` per shape, the same discretization) the
    cable itself changes along the path: between shapes s and s + 1 its length and mass are
    interpolated linearly. A wire-harness section being tensioned is such a path: held at the
    fixtures, it gets shorter as the grippers pull the cable through them. The forcing of a
    sub-step is then its clip motion plus the change of the cable's length between its clip
    points (L - l) [m].

Each segment starts from the planned stabilized shape at its start, so one event does not hide
the next. Per segment the *straying* is the largest distance of a quasi-static shape from the
straight interpolation (1 - t) A + t B of the two planned stabilized shapes A, B [m]: how far the
cable departs from what a viewer of the plan would assume between two frames.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields, replace

import numpy as np

from ..cable import GRAVITY, Cable
from ..frames import quaternion_x_axes, slerp_quaternions
from ..geometry import as_path
from ..physics.chain import SpringChain
from ..sim.batch import continue_held
from ..sim.clips import ClipPoses
from ..sim.result import DEFAULT_RTOL, ROUNDOFF, force_scale, stiffest
from ..sim.statics import equilibrium, interpolate_clips
from ._inputs import as_clip_sequence, max_distance
from .contacts import contact_changes
from .stability import (
    EQUILIBRIUM_RTOL,
    ROUNDOFF_FACTOR,
    STABILITY_RTOL,
    elastic_stabilities,
    elastic_stability,
    quickest_method,
    stiffness_scale,
)

CRITICAL = 0.1
"""A candidate is a critical point when the smallest eigenvalue found in its window is below this
fraction of the values at the window's ends."""

DIP = 0.5
"""A sampled local minimum of the smallest eigenvalue below this fraction of its larger neighbour
makes its sub-steps candidates (a critical point may fall between samples)."""

SAME_START = 1e-9
"""Largest distance [m] between a segment's start shape and the first shape of a continuation
already solved (``check_snap_through(solved=)``) for the two to be the same equilibrium: an
equilibrium solved again at its own clip poses moves by the Newton solver's accuracy (up to
3.3e-10 m on the harness jobs' held sections)."""

NEWTON_ITERATIONS = 500
"""Newton iterations of a sub-step's equilibrium (:func:`dloplan.sim.statics.equilibrium`'s
default), in the compiled loop and the reference loop alike."""


@dataclass(frozen=True, eq=False)
class SnapEvent:
    """A flagged event of the continuation.

    Attributes
    ----------
    segment : int
        Segment index s (motion from shape s to shape s + 1).
    substep : int
        Sub-step (1-based) of the segment in which it happens: the one with the largest shape
        change of a snap's window (0 for a ``"branch"`` event).
    fraction : float
        Where in the segment, as a fraction of the clip interpolation in [0, 1] (localized to
        the smallest eigenvalue for a snap).
    kind : str
        ``"snap"``, ``"unstable"``, ``"contact"`` or ``"branch"`` (see the module docstring).
    distance : float
        Largest point displacement of one sub-step at the event [m].
    ratio : float
        That displacement over the sub-step's clip motion.
    eigenvalue : float
        Smallest eigenvalue at the event [N/m] (the minimum found for a snap).
    message : str
        The event in words.
    contacts : tuple of str
        The obstacles whose contact opened or closed at the event (empty: none).
    """

    segment: int
    substep: int
    fraction: float
    kind: str
    distance: float
    ratio: float
    eigenvalue: float
    message: str
    contacts: tuple[str, ...] = ()


@dataclass(frozen=True)
class ContactChange:
    """A contact that opened or closed in a sub-step of the continuation.

    Attributes
    ----------
    segment : int
        Segment index s.
    substep : int
        Sub-step (1-based) at whose end the contact's state differs from its start.
    fraction : float
        The sub-step's end, as a fraction of the segment.
    name : str
        The obstacle.
    change : str
        ``"lift-off"`` (the contact opened) or ``"touch-down"`` (it closed).
    """

    segment: int
    substep: int
    fraction: float
    name: str
    change: str

    def describe(self) -> str:
        """One phrase."""
        return f"{self.name}: {self.change} in segment {self.segment} at t = {self.fraction:.3f}"


@dataclass(frozen=True, eq=False)
class SegmentContinuation:
    """Quasi-static continuation of one segment.

    Attributes
    ----------
    segment : int
        Segment index s.
    fractions : numpy.ndarray
        (m + 1,) fractions of the clip interpolation, 0 to 1.
    shapes : numpy.ndarray
        (m + 1, n + 1, 3) quasi-static shapes [m] (the first is the planned shape s).
    eigenvalues : numpy.ndarray
        (m + 1,) smallest eigenvalue of each [N/m].
    ratios : numpy.ndarray
        (m,) shape change over clip motion of each sub-step.
    straying : float
        Largest distance of a shape from the straight interpolation of the planned shapes [m].
    end_mismatch : float
        Largest distance between the last shape and the planned shape s + 1 [m].
    events : tuple of SnapEvent
        Events flagged in this segment.
    contact_changes : tuple of ContactChange
        Contacts that opened or closed along the segment (empty without contacts).
    contacts : tuple
        (m + 1) tuples of :class:`~dloplan.verify.contacts.ContactState`, one per shape (empty
        without contacts).
    """

    segment: int
    fractions: np.ndarray
    shapes: np.ndarray
    eigenvalues: np.ndarray
    ratios: np.ndarray
    straying: float
    end_mismatch: float
    events: tuple[SnapEvent, ...]
    contact_changes: tuple[ContactChange, ...] = ()
    contacts: tuple = ()

    @property
    def max_ratio(self) -> float:
        """Largest sub-step ratio."""
        return float(np.max(self.ratios)) if len(self.ratios) else 0.0


@dataclass(frozen=True, eq=False)
class SnapCheck:
    """Result of :func:`check_snap_through`.

    Attributes
    ----------
    segments : tuple of SegmentContinuation
        One per segment (n_shapes - 1).
    events : tuple of SnapEvent
        All events, in path order.
    ok : bool
        No event.
    message : str
        Summary.
    """

    segments: tuple[SegmentContinuation, ...]
    events: tuple[SnapEvent, ...]
    ok: bool
    message: str

    @property
    def success(self) -> bool:
        """Same as ``ok``."""
        return self.ok

    @property
    def contact_changes(self) -> tuple[ContactChange, ...]:
        """Every contact that opened or closed, in path order."""
        return tuple(c for seg in self.segments for c in seg.contact_changes)


def clip_motion(a: ClipPoses, b: ClipPoses, reach: float) -> float:
    """Largest over the two clips of |dp| + reach * (angle between the u-axes) [m]."""
    shift = np.linalg.norm(b.positions - a.positions, axis=1)
    cos = np.clip(np.einsum("ij,ij->i", a.u_axes, b.u_axes), -1.0, 1.0)
    return float(np.max(shift + reach * np.arccos(cos)))


def interpolate_cable(a: Cable, b: Cable, t: float) -> Cable:
    """The cable at fraction t between two cables that differ in length and mass only.

    Length and mass linear in t (the rest of ``a``'s fields kept); ``a`` itself at t = 0, ``b``
    at t = 1.
    """
    if a is b or t == 0.0:
        return a
    if t == 1.0:
        return b
    return replace(a, length=(1.0 - t) * a.length + t * b.length,
                   mass=(1.0 - t) * a.mass + t * b.mass)


def _check_cables(cables, count: int, cable: Cable) -> list[Cable]:
    """One cable per shape, differing from ``cable`` in length and mass only."""
    if cables is None:
        return [cable] * count
    items = list(cables)
    if len(items) != count:
        raise ValueError(f"cables: {len(items)} given, expected {count} (one per shape)")
    fixed = [f.name for f in fields(Cable) if f.name not in ("length", "mass")]
    for k, item in enumerate(items):
        if not isinstance(item, Cable):
            raise ValueError(f"cables[{k}]: got {type(item).__name__}, expected a Cable")
        differing = [name for name in fixed if not _same(getattr(item, name),
                                                        getattr(cable, name))]
        if differing:
            raise ValueError(f"cables[{k}]: differs from the cable in {', '.join(differing)}; "
                             "expected the same cable with another length and mass")
    return items


def _same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return a is b or (a is not None and b is not None and np.array_equal(a, b))
    return a == b


class _Segment:
    """The solver state shared by the sub-steps and the localization of one segment."""

    def __init__(self, cables: tuple[Cable, Cable], start: ClipPoses, end: ClipPoses, gravity,
                 rtol, contacts=()):
        self.cables, self.gravity, self.rtol = cables, gravity, rtol
        self.contacts = tuple(contacts)
        self.start, self.end = start, end
        self._clips: dict[float, ClipPoses] = {}
        self._cables: dict[float, Cable] = {}
        self._chains: dict[int, SpringChain] = {}  # per cable object (kept in _cables)

    def prepare(self, fractions: np.ndarray) -> None:
        """Interpolate the clips at all sub-step fractions at once (Rotation calls are slow)."""
        self._clips.update(zip(fractions.tolist(), interpolate_clips(self.start, self.end,
                                                                     fractions), strict=True))

    def clips(self, t: float) -> ClipPoses:
        t = float(t)
        if t not in self._clips:
            self._clips[t] = interpolate_clips(self.start, self.end, [t])[0]
        return self._clips[t]

    def cable(self, t: float) -> Cable:
        """The cable at fraction t (one object for every t along a segment of one cable)."""
        t = float(t)
        if t not in self._cables:
            self._cables[t] = interpolate_cable(*self.cables, t)
        return self._cables[t]

    def model(self, t: float) -> tuple[Cable, SpringChain]:
        """The cable at fraction t and its chain (with the contacts), built when a sub-step is
        solved here (not for the sub-steps given solved, whose stability needs the cable only)."""
        cable = self.cable(t)
        if id(cable) not in self._chains:
            self._chains[id(cable)] = SpringChain.from_cable(cable, self.gravity, self.contacts)
        return cable, self._chains[id(cable)]

    def stability(self, x: np.ndarray, t: float):
        cable = self.cable(t)
        return elastic_stability(cable, x, gravity=self.gravity, k=1, rtol=self.rtol,
                                 method=quickest_method(cable.n_points), contacts=self.contacts)

    def equilibrium(self, guess: np.ndarray, t: float):
        """The equilibrium at fraction t reached from ``guess``."""
        cable, chain = self.model(t)
        return equilibrium(cable, guess, self.clips(t), gravity=self.gravity, chain=chain,
                           max_iterations=NEWTON_ITERATIONS)

    def solve(self, guess: np.ndarray, t: float):
        eq = self.equilibrium(guess, t)
        return eq, self.stability(eq.shape, t)

    def stabilities(self, shapes: np.ndarray, fractions: np.ndarray):
        """:meth:`stability` of the shapes (m + 1, n + 1, 3) at the fractions, the contacts'
        penalty evaluated once for all (:func:`~.stability.elastic_stabilities`), each
        sub-step's smallest eigenpairs followed from the one before where the banded solver is
        the quickest (``method="follow"``: the verdicts of the banded solve, its eigenvalues to
        round-off)."""
        cables = [self.cable(t) for t in fractions]
        method = quickest_method(cables[0].n_points)
        return elastic_stabilities(cables, shapes, gravity=self.gravity, k=1, rtol=self.rtol,
                                   method="follow" if method == "band" else method,
                                   contacts=self.contacts)

    def forcing(self, t0: float, t1: float) -> float:
        """Clip motion plus the change of the held length between fractions t0 and t1 [m]."""
        a, b = self.cable(t0), self.cable(t1)
        held = abs((b.length - b.rest_link_length) - (a.length - a.rest_link_length))
        return clip_motion(self.clips(t0), self.clips(t1), self.cables[0].length) + held

    def arrays(self, fractions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Clip points (m + 1, 2, 3) [m] and unit quaternions (m + 1, 2, 4) at the fractions,
        those of :meth:`prepare`'s clip poses, without making them."""
        w = np.asarray(fractions, dtype=float)
        positions = ((1.0 - w)[:, None, None] * self.start.positions
                     + w[:, None, None] * self.end.positions)
        keys = np.stack([self.start.rotations.as_quat(), self.end.rotations.as_quat()])
        quaternions = slerp_quaternions(np.array([0.0, 1.0]), keys, w)
        # contiguous: the compiled loop is compiled for one memory layout
        return np.ascontiguousarray(positions), np.ascontiguousarray(quaternions)

    def forcings(self, fractions: np.ndarray) -> np.ndarray:
        """(m,) :meth:`forcing` of each sub-step between consecutive fractions [m]."""
        positions, quaternions = self.arrays(fractions)
        u = quaternion_x_axes(quaternions)
        shift = np.linalg.norm(np.diff(positions, axis=0), axis=-1)
        cos = np.clip(np.einsum("kij,kij->ki", u[:-1], u[1:]), -1.0, 1.0)
        out = np.max(shift + self.cables[0].length * np.arccos(cos), axis=1)
        if self.cables[0] is not self.cables[1]:
            held = np.array([c.length - c.rest_link_length
                             for c in (self.cable(t) for t in fractions)])
            out += np.abs(np.diff(held))
        return out

    def smallest_at(self, guess: np.ndarray, t: float) -> float:
        """Smallest eigenvalue of the equilibrium at fraction t reached from ``guess`` (with
        contacts: the pressing points sticking)."""
        return self.solve(guess, t)[1].sticking


def check_snap_through(
    cable: Cable,
    stabilized_shapes,
    clip_poses: Sequence[ClipPoses] | None = None,
    *,
    gravity=GRAVITY,
    max_clip_step: float = 0.005,
    substeps: int | None = None,
    jump_ratio: float = 5.0,
    refinements: int = 10,
    branch_tolerance: float = 1e-3,
    rtol: float = STABILITY_RTOL,
    contacts=(),
    cables: Sequence[Cable] | None = None,
    compiled: bool = True,
    solved: Sequence | None = None,
) -> SnapCheck:
    """Follow the equilibrium branch between consecutive planned clip poses; flag snaps.

    Parameters
    ----------
    cable : Cable
        The cable.
    stabilized_shapes : array_like
        (S + 2, n + 1, 3) planned, stabilized shapes [m].
    clip_poses : sequence of ClipPoses, optional
        The planned clip poses of each shape; default: read off the shapes' end links.
    gravity : array_like
        Gravity [m/s^2].
    max_clip_step : float
        Largest clip motion of one sub-step, as a fraction of the cable length.
    substeps : int, optional
        A fixed number of sub-steps per segment instead of ``max_clip_step``.
    jump_ratio : float
        Shape change over clip motion above which a sub-step is a snap candidate.
    refinements : int
        Localization accuracy, 2^-refinements of a candidate window (0: no localization, the
        sampled eigenvalues decide).
    branch_tolerance : float
        Largest distance [m] accepted between the continuation's end and the planned shape.
    rtol : float
        Relative eigenvalue tolerance of the stability test.
    contacts : sequence
        Obstacles in one-sided contact with the cable (module docstring).
    cables : sequence of Cable, optional
        One cable per shape, differing from ``cable`` in length and mass only (module
        docstring: a changing cable); default ``cable`` throughout.
    compiled : bool
        Run the sub-steps of a segment in one compiled loop where it applies (no contacts, one
        cable, the banded eigen-solver's sizes: :func:`_compiled_substeps`), and with contacts
        solve a segment's equilibria first and test their stability together
        (:func:`_contact_substeps`); False: the reference loop, sub-step by sub-step in Python
        (the same shapes bit for bit, the same eigenvalues to round-off; tests compare the
        two).
    solved : sequence, optional
        Per segment, its continuation's equilibria already solved (or None): a pair
        ``(shapes, messages)``, shapes (m + 1, n + 1, 3) [m] at the fractions
        :func:`substep_fractions` (m), the first the segment's start shape, each next one
        reached from the one before with the contacts (:func:`~dloplan.sim.statics.equilibrium`
        at the interpolated clip poses, as this function solves them), and the solver's message
        of each (str). Taken with contacts where m is the segment's own number of sub-steps and
        the first shape is the segment's start shape to :data:`SAME_START` (the wire-harness
        held model follows the same path, :func:`dloplan.harness.section.follow_path`); the
        start shape itself is then sub-step 0. Otherwise solved here.

    Returns
    -------
    SnapCheck
        Per-segment continuation, events, verdict.
    """
    path = as_path(stabilized_shapes, cable.n_points, "stabilized_shapes")
    poses = as_clip_sequence(clip_poses, path)
    models = _check_cables(cables, len(path), cable)
    for name, value in (("max_clip_step", max_clip_step), ("jump_ratio", jump_ratio),
                        ("branch_tolerance", branch_tolerance)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}: got {value!r}, expected a number > 0")
    if substeps is not None and (int(substeps) != substeps or substeps < 1):
        raise ValueError(f"substeps: got {substeps!r}, expected an integer >= 1 or None")
    if int(refinements) != refinements or refinements < 0:
        raise ValueError(f"refinements: got {refinements!r}, expected an integer >= 0")
    if solved is not None and len(solved) != len(path) - 1:
        raise ValueError(f"solved: {len(solved)} segments, expected {len(path) - 1} (one per "
                         "segment, None where not solved)")
    segments = []
    for s in range(len(path) - 1):
        seg = _Segment((models[s], models[s + 1]), poses[s], poses[s + 1], gravity, rtol,
                       contacts)
        if substeps is None:
            total = seg.forcing(0.0, 1.0)
            m = max(1, math.ceil(total / (max_clip_step * cable.length)))
        else:
            m = int(substeps)
        known = None if solved is None or not compiled else solved[s]
        segments.append(_continue_segment(seg, s, path[s], path[s + 1], m, jump_ratio,
                                          int(refinements), branch_tolerance, compiled, known))
    events = tuple(e for seg in segments for e in seg.events)
    if events:
        message = f"{len(events)} event(s): " + "; ".join(e.message for e in events)
    else:
        message = f"no snap-through in {len(segments)} segment(s)"
    return SnapCheck(tuple(segments), events, not events, message)


def substep_fractions(count: int) -> np.ndarray:
    """(count + 1,) the fractions j / count, j = 0 .. count, of a segment's ``count``
    sub-steps (the quasi-static continuation's, :func:`dloplan.sim.statics.continuation`)."""
    return np.arange(count + 1) / count


def _continue_segment(seg: _Segment, s, start, end, m, jump_ratio, refinements, tolerance,
                      compiled, known=None):
    fractions = substep_fractions(m)
    if compiled and seg.contacts:
        shapes, eigenvalues, states, problems = _contact_substeps(seg, start, fractions, known)
        return _segment(seg, s, start, end, fractions, np.stack(shapes), np.asarray(eigenvalues),
                        states, problems, jump_ratio, refinements, tolerance)
    first = seg.stability(start, 0.0)
    shapes, eigenvalues, states = [start], [first.sticking], [first.contacts]
    done, unstable = (_compiled_substeps(seg, start, fractions, shapes, eigenvalues)
                      if compiled else (0, set()))
    if done < m or unstable:
        seg.prepare(fractions)
    problems = {}
    for j in range(1, m + 1):  # the reference loop: after the compiled ones, or to say why
        if j <= done and j not in unstable:
            states.append(())
            continue
        x = shapes[j - 1]
        eq, stab = seg.solve(x, fractions[j])
        # with contacts the penalty's kinks may stall Newton short of its tolerance: the
        # stability test's equilibrium tolerance decides then
        if not ((eq.converged or seg.contacts) and stab.stable_with_friction):
            problems[j] = (eq.message, stab)
        if j <= done:  # a compiled sub-step found unstable: its messages
            states.append(stab.contacts)
            continue
        shapes.append(eq.shape)
        eigenvalues.append(stab.sticking)
        states.append(stab.contacts)
    return _segment(seg, s, start, end, fractions, np.stack(shapes), np.asarray(eigenvalues),
                    states, problems, jump_ratio, refinements, tolerance)


def _contact_substeps(seg: _Segment, start, fractions,
                      known=None) -> tuple[list, list, list, dict]:
    """The sub-steps of a segment with contacts: the equilibria one after the other (or
    ``known``, :func:`check_snap_through`'s ``solved`` of the segment, when they are its
    sub-steps from ``start`` to :data:`SAME_START`), then their stability at once
    (:meth:`_Segment.stabilities`: the numbers of the reference loop's sub-step by sub-step
    solves and tests, in another order).
    Returns the shapes, the sticking eigenvalues, the contact states and the problems of
    :func:`_continue_segment`'s reference loop."""
    if known is not None and len(known[0]) == len(fractions) and \
            max_distance(known[0][0], start) <= SAME_START:
        shapes, messages = [start, *known[0][1:]], ["", *known[1][1:]]
    else:
        seg.prepare(fractions)
        shapes, messages = [start], [""]
        for t in fractions[1:]:
            eq = seg.equilibrium(shapes[-1], t)
            shapes.append(eq.shape)
            messages.append(eq.message)
    stabs = seg.stabilities(np.stack(shapes), fractions)
    # with contacts the penalty's kinks may stall Newton short of its tolerance: the stability
    # test's equilibrium tolerance decides (as in the reference loop)
    problems = {j: (messages[j], stab) for j, stab in enumerate(stabs)
                if j and not stab.stable_with_friction}
    return shapes, [stab.sticking for stab in stabs], [stab.contacts for stab in stabs], problems


def _segment(seg: _Segment, s, start, end, fractions, shapes, eigenvalues, states, problems,
             jump_ratio, refinements, tolerance) -> SegmentContinuation:
    """The segment's continuation from its sub-steps: ratios, events, contact changes."""
    m = len(fractions) - 1
    forcing = seg.forcings(fractions)
    moved = np.max(np.linalg.norm(np.diff(shapes, axis=0), axis=-1), axis=1)
    with np.errstate(divide="ignore"):
        ratios = np.where(forcing > 0, moved / np.where(forcing > 0, forcing, 1.0), math.inf)
    events, changes = [], []
    for j in range(1, m + 1):
        changes += [ContactChange(s, j, float(fractions[j]), name, kind)
                    for name, kind in contact_changes(states[j - 1], states[j])]
        if j in problems:
            message, stab = problems[j]
            events.append(SnapEvent(
                s, j, float(fractions[j]), "unstable", float(moved[j - 1]), ratios[j - 1],
                stab.sticking, f"segment {s}, sub-step {j} (t = {fractions[j]:.4f}): no stable "
                f"equilibrium ({message}; {stab.message})",
            ))
    windows = _candidate_windows(ratios, eigenvalues, jump_ratio)
    for first_step, last_step in windows:
        event = _localize(seg, s, fractions, shapes, eigenvalues, ratios, first_step, last_step,
                          refinements, changes)
        if event is not None:
            events.append(event)
    events += _contact_jumps(s, fractions, shapes, ratios, jump_ratio, changes, events)
    events.sort(key=lambda e: e.fraction)
    straight = (1.0 - fractions)[:, None, None] * start + fractions[:, None, None] * end
    straying = float(np.max(np.linalg.norm(shapes - straight, axis=-1)))
    mismatch = max_distance(shapes[-1], end)
    if mismatch > tolerance:
        events.append(SnapEvent(
            s, 0, 1.0, "branch", mismatch, math.nan, float(eigenvalues[-1]),
            f"segment {s}: the quasi-static motion ends {1e3 * mismatch:.1f} mm from planned "
            f"shape {s + 1} (tolerance {1e3 * tolerance:.1f} mm): the planned shape is not the "
            f"equilibrium the motion reaches (another branch, or not stabilized)",
        ))
    return SegmentContinuation(s, fractions, shapes, eigenvalues, ratios, straying, mismatch,
                               tuple(events), tuple(changes),
                               tuple(states) if seg.contacts else ())


def _compiled_substeps(seg: _Segment, start, fractions, shapes: list,
                       eigenvalues: list) -> tuple[int, set]:
    """The sub-steps of a segment in one compiled loop (:func:`dloplan.sim.batch.continue_held`),
    appended to ``shapes`` and ``eigenvalues``: how many were done, and which of them are not
    a converged, stable equilibrium (:func:`~.stability.elastic_stability`'s verdict from the
    loop's residual, Hessian norm and smallest eigenvalue).

    None without contacts and one cable along the segment where the stability test's quickest
    eigen-solver is the banded one (:func:`~.stability.quickest_method`): there every
    equilibrium is :func:`~dloplan.sim.statics.equilibrium`'s bit for bit and every eigenvalue
    the one :func:`~.stability.elastic_stability` finds, to round-off. The loop stops before a
    sub-step that needs the Python solver (a saddle to escape, clips at the reach's edge); the
    reference loop does the rest.
    """
    cable = seg.cables[0]
    if seg.contacts or seg.cables[1] is not cable or cable.n_points <= 4 or \
            quickest_method(cable.n_points) != "band":
        return 0, set()
    positions, quaternions = seg.arrays(fractions)
    count = len(fractions)
    out = np.empty((count, cable.n_points, 3))
    out[0] = start
    converged = np.zeros(count, dtype=bool)
    residuals, values, norms = (np.full(count, math.nan) for _ in range(3))
    scale = force_scale(cable, seg.gravity)
    done = continue_held(out, positions, quaternions, *seg.model(0.0)[1].constants,
                         cable.rest_link_length, cable.length, DEFAULT_RTOL * scale,
                         ROUNDOFF * np.finfo(float).eps, stiffest(cable), cable.stiff_axial,
                         NEWTON_ITERATIONS, converged, residuals, values, norms)
    threshold = np.maximum(seg.rtol * stiffness_scale(cable),
                           ROUNDOFF_FACTOR * np.finfo(float).eps * norms)
    ok = converged & (residuals <= EQUILIBRIUM_RTOL * scale) & (values > threshold)
    shapes += list(out[1 : done + 1])
    eigenvalues += values[1 : done + 1].tolist()
    return done, {j for j in range(1, done + 1) if not ok[j]}


def _contact_jumps(s, fractions, shapes, ratios, jump_ratio, changes, events) -> list[SnapEvent]:
    """A sub-step whose shape jumps while a contact opens or closes, not already in a snap."""
    covered = {e.substep for e in events if e.kind in ("snap", "contact")}
    out = []
    for j in sorted({c.substep for c in changes}):
        if ratios[j - 1] <= jump_ratio or j in covered:
            continue
        names = tuple(c.name for c in changes if c.substep == j)
        what = ", ".join(f"{c.change} at {c.name}" for c in changes if c.substep == j)
        distance = max_distance(shapes[j], shapes[j - 1])
        out.append(SnapEvent(
            s, j, float(fractions[j]), "contact", distance, float(ratios[j - 1]), math.nan,
            f"segment {s}, sub-step {j} (t = {fractions[j]:.4f}): the contact jumps ({what}), "
            f"the shape moves {1e3 * distance:.1f} mm in one sub-step "
            f"({ratios[j - 1]:.3g} times the forcing)", names))
    return out


def _candidate_windows(ratios, eigenvalues, jump_ratio):
    """Runs of sub-steps (first, last), 1-based, that may hide a critical point.

    A sub-step is a candidate when its ratio exceeds ``jump_ratio`` or when it ends at a sampled
    dip of the smallest eigenvalue (a local minimum below :data:`DIP` times its larger
    neighbour).
    """
    m = len(ratios)
    flagged = ratios > jump_ratio
    lam = eigenvalues
    for j in range(1, m):
        low, high = sorted((lam[j - 1], lam[j + 1]))
        if lam[j] <= low and lam[j] < DIP * high:
            flagged[j - 1] = flagged[j] = True
    windows, j = [], 0
    while j < m:
        if flagged[j]:
            k = j
            while k + 1 < m and flagged[k + 1]:
                k += 1
            windows.append((j + 1, k + 1))
            j = k + 1
        else:
            j += 1
    return windows


def _localize(seg, s, fractions, shapes, eigenvalues, ratios, first, last, refinements,
              changes=()):
    """Find the smallest eigenvalue over a candidate window; an event if it is near zero."""
    a, b = first - 1, min(last + 1, len(fractions) - 1)
    guess = shapes[a]
    t_star, lam_star = fractions[last], float(eigenvalues[last])
    if refinements:
        from scipy.optimize import minimize_scalar  # here: it costs the CLI 0.13 s to import

        width = fractions[b] - fractions[a]
        found = minimize_scalar(lambda t: seg.smallest_at(guess, t), bounds=(fractions[a],
                                fractions[b]), method="bounded",
                                options={"xatol": width * 2.0**-refinements})
        t_star, lam_star = float(found.x), float(found.fun)
    ends = min(eigenvalues[a], eigenvalues[b])
    if not lam_star < CRITICAL * ends:
        return None  # steep but smooth: the eigenvalue stays away from zero
    window = slice(first - 1, last)
    j = first + int(np.argmax(ratios[window]))
    distance = max_distance(shapes[j], shapes[j - 1])
    inside = [c for c in changes if a < c.substep <= b]
    names = tuple(dict.fromkeys(c.name for c in inside))
    at = ("; the contact changes: " + ", ".join(f"{c.change} at {c.name}" for c in inside)
          if inside else "")
    return SnapEvent(
        s, j, t_star, "snap", distance, float(np.max(ratios[window])), lam_star,
        f"segment {s}, sub-step {j}: snap-through (critical point) at t = {t_star:.4f}, the "
        f"smallest eigenvalue "
        f"falls to {lam_star:.3g} N/m (from {ends:.3g}) and the shape moves "
        f"{1e3 * distance:.1f} mm in one sub-step ({float(np.max(ratios[window])):.3g} times "
        f"the clip motion){at}", names,
    )
