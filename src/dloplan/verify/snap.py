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
jump
    A sub-step whose ratio exceeds ``jump_ratio`` (default 5) is a candidate. It is localized by
    bisection of its fraction interval (``refinements`` halvings, each solved from the last shape
    still on the old branch; a solution is still on the old branch when it moved less than half
    the distance across the bracket). It is confirmed as a jump when the ratio over the final
    bracket is at least :data:`GROWTH` times the candidate's ratio: a smooth but steep change
    scales with the step and keeps its ratio; a snap does not. Steep but smooth sub-steps are
    reported (``max_ratio``) but not flagged.
unstable
    A sub-step whose equilibrium is not a stable minimum (solver not converged, or smallest
    eigenvalue not above the threshold of :func:`dloplan.verify.stability.elastic_stability`):
    the smallest eigenvalue has crossed zero.
branch
    The continuation ends farther than ``branch_tolerance`` (default 1 mm) from the planned
    stabilized shape of the segment's end: the plan's shape is not the one the motion produces.

Each segment starts from the planned stabilized shape at its start, so one event does not hide
the next. Per segment the *straying* is the largest distance of a quasi-static shape from the
straight interpolation (1 - t) A + t B of the two planned stabilized shapes A, B [m]: how far the
cable departs from what a viewer of the plan would assume between two frames.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..cable import GRAVITY, Cable
from ..physics.chain import SpringChain
from ..sim.clips import ClipPoses
from ..sim.statics import equilibrium, interpolate_clips
from ._inputs import as_clip_sequence, as_path, max_distance
from .stability import STABILITY_RTOL, elastic_stability

GROWTH = 4.0
"""Factor by which a candidate's ratio must grow under bisection to be confirmed as a jump (a
jump grows as 2^refinements, a square-root branch as 2^(refinements/2), a smooth change as 1)."""


@dataclass(frozen=True, eq=False)
class SnapEvent:
    """A flagged event of the continuation.

    Attributes
    ----------
    segment : int
        Segment index s (motion from shape s to shape s + 1).
    substep : int
        Sub-step (1-based) of the segment in which it happens (0 for a ``"branch"`` event).
    fraction : float
        Where in the segment, as a fraction of the clip interpolation in [0, 1] (localized by
        bisection for a jump).
    kind : str
        ``"jump"``, ``"unstable"`` or ``"branch"`` (see the module docstring).
    distance : float
        Largest point displacement across the event [m].
    ratio : float
        Shape change over clip motion across the event (localized bracket for a jump).
    eigenvalue : float
        Smallest eigenvalue of the last shape on the old branch [N/m].
    message : str
        The event in words.
    """

    segment: int
    substep: int
    fraction: float
    kind: str
    distance: float
    ratio: float
    eigenvalue: float
    message: str


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
    """

    segment: int
    fractions: np.ndarray
    shapes: np.ndarray
    eigenvalues: np.ndarray
    ratios: np.ndarray
    straying: float
    end_mismatch: float
    events: tuple[SnapEvent, ...]

    @property
    def max_ratio(self) -> float:
        """Largest sub-step ratio."""
        return float(np.max(self.ratios)) if len(self.ratios) else 0.0

    @property
    def snapped(self) -> bool:
        """True when a jump or an instability was flagged."""
        return any(e.kind in ("jump", "unstable") for e in self.events)


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


def clip_motion(a: ClipPoses, b: ClipPoses, reach: float) -> float:
    """Largest over the two clips of |dp| + reach * (angle between the u-axes) [m]."""
    shift = np.linalg.norm(b.positions - a.positions, axis=1)
    cos = np.clip(np.einsum("ij,ij->i", a.u_axes, b.u_axes), -1.0, 1.0)
    return float(np.max(shift + reach * np.arccos(cos)))


class _Segment:
    """The solver state shared by the sub-steps and the bisection of one segment."""

    def __init__(self, cable, chain, start: ClipPoses, end: ClipPoses, gravity, rtol):
        self.cable, self.chain, self.gravity, self.rtol = cable, chain, gravity, rtol
        self.start, self.end = start, end
        self._clips: dict[float, ClipPoses] = {}

    def prepare(self, fractions: np.ndarray) -> None:
        """Interpolate the clips at all sub-step fractions at once (Rotation calls are slow)."""
        self._clips.update(zip(fractions.tolist(), interpolate_clips(self.start, self.end,
                                                                     fractions), strict=True))

    def clips(self, t: float) -> ClipPoses:
        t = float(t)
        if t not in self._clips:
            self._clips[t] = interpolate_clips(self.start, self.end, [t])[0]
        return self._clips[t]

    def solve(self, guess: np.ndarray, t: float):
        eq = equilibrium(self.cable, guess, self.clips(t), gravity=self.gravity, chain=self.chain)
        stab = elastic_stability(self.cable, eq.shape, gravity=self.gravity, k=1, rtol=self.rtol)
        return eq, stab

    def ratio(self, x0, t0, x1, t1) -> float:
        motion = clip_motion(self.clips(t0), self.clips(t1), self.cable.length)
        return max_distance(x0, x1) / motion if motion > 0 else math.inf

    def localize(self, x_lo, t_lo, x_hi, t_hi, refinements):
        """Bisect [t_lo, t_hi] keeping x_lo on the old branch; returns the final bracket."""
        lam_lo = math.nan
        for _ in range(refinements):
            t_mid = 0.5 * (t_lo + t_hi)
            eq, stab = self.solve(x_lo, t_mid)
            if max_distance(eq.shape, x_lo) <= 0.5 * max_distance(x_hi, x_lo):
                x_lo, t_lo, lam_lo = eq.shape, t_mid, stab.smallest
            else:
                x_hi, t_hi = eq.shape, t_mid
        return x_lo, t_lo, x_hi, t_hi, lam_lo


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
        Shape change over clip motion above which a sub-step is a jump candidate.
    refinements : int
        Bisection halvings localizing a candidate (0: no localization, every candidate is
        flagged).
    branch_tolerance : float
        Largest distance [m] accepted between the continuation's end and the planned shape.
    rtol : float
        Relative eigenvalue tolerance of the stability test.

    Returns
    -------
    SnapCheck
        Per-segment continuation, events, verdict.
    """
    path = as_path(stabilized_shapes, cable.n_points, "stabilized_shapes")
    poses = as_clip_sequence(clip_poses, path)
    for name, value in (("max_clip_step", max_clip_step), ("jump_ratio", jump_ratio),
                        ("branch_tolerance", branch_tolerance)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}: got {value!r}, expected a number > 0")
    if substeps is not None and (int(substeps) != substeps or substeps < 1):
        raise ValueError(f"substeps: got {substeps!r}, expected an integer >= 1 or None")
    if int(refinements) != refinements or refinements < 0:
        raise ValueError(f"refinements: got {refinements!r}, expected an integer >= 0")
    chain = SpringChain.from_cable(cable, gravity)
    segments = []
    for s in range(len(path) - 1):
        seg = _Segment(cable, chain, poses[s], poses[s + 1], gravity, rtol)
        if substeps is None:
            total = clip_motion(poses[s], poses[s + 1], cable.length)
            m = max(1, math.ceil(total / (max_clip_step * cable.length)))
        else:
            m = int(substeps)
        segments.append(_continue_segment(seg, s, path[s], path[s + 1], m, jump_ratio,
                                          int(refinements), branch_tolerance))
    events = tuple(e for seg in segments for e in seg.events)
    if events:
        message = f"{len(events)} event(s): " + "; ".join(e.message for e in events)
    else:
        message = f"no snap-through in {len(segments)} segment(s)"
    return SnapCheck(tuple(segments), events, not events, message)


def _continue_segment(seg: _Segment, s, start, end, m, jump_ratio, refinements, tolerance):
    fractions = np.linspace(0.0, 1.0, m + 1)
    seg.prepare(fractions)
    shapes = [start]
    eigenvalues = [elastic_stability(seg.cable, start, gravity=seg.gravity, k=1,
                                     rtol=seg.rtol).smallest]
    ratios, events = [], []
    x = start
    for j in range(1, m + 1):
        t0, t1 = fractions[j - 1], fractions[j]
        eq, stab = seg.solve(x, t1)
        ratio = seg.ratio(x, t0, eq.shape, t1)
        if not (eq.converged and stab.stable):
            events.append(SnapEvent(
                s, j, float(t1), "unstable", max_distance(eq.shape, x), ratio, stab.smallest,
                f"segment {s}, sub-step {j} (t = {t1:.4f}): no stable equilibrium "
                f"({eq.message}; {stab.message})",
            ))
        elif ratio > jump_ratio:
            event = _confirm_jump(seg, s, j, x, t0, eq.shape, t1, ratio, eigenvalues[-1],
                                  refinements)
            if event is not None:
                events.append(event)
        ratios.append(ratio)
        x = eq.shape
        shapes.append(x)
        eigenvalues.append(stab.smallest)
    shapes = np.stack(shapes)
    straight = (1.0 - fractions)[:, None, None] * start + fractions[:, None, None] * end
    straying = float(np.max(np.linalg.norm(shapes - straight, axis=-1)))
    mismatch = max_distance(shapes[-1], end)
    if mismatch > tolerance:
        events.append(SnapEvent(
            s, 0, 1.0, "branch", mismatch, math.nan, eigenvalues[-1],
            f"segment {s}: the quasi-static motion ends {1e3 * mismatch:.1f} mm from planned "
            f"shape {s + 1} (tolerance {1e3 * tolerance:.1f} mm): another equilibrium branch",
        ))
    return SegmentContinuation(s, fractions, shapes, np.asarray(eigenvalues), np.asarray(ratios),
                               straying, mismatch, tuple(events))


def _confirm_jump(seg, s, j, x0, t0, x1, t1, ratio, eigenvalue, refinements):
    x_lo, t_lo, x_hi, t_hi, lam = x0, t0, x1, t1, eigenvalue
    if refinements:
        x_lo, t_lo, x_hi, t_hi, lam_lo = seg.localize(x0, t0, x1, t1, refinements)
        lam = eigenvalue if math.isnan(lam_lo) else lam_lo
        final = seg.ratio(x_lo, t_lo, x_hi, t_hi)
        if final < GROWTH * ratio:
            return None  # steep but smooth: the change scales with the step
    else:
        final = ratio
    where = 0.5 * (t_lo + t_hi)
    distance = max_distance(x_hi, x_lo)
    return SnapEvent(
        s, j, float(where), "jump", distance, final, float(lam),
        f"segment {s}, sub-step {j}: snap-through at t = {where:.4f}, the shape jumps "
        f"{1e3 * distance:.1f} mm (ratio {final:.3g} to the clip motion; smallest eigenvalue "
        f"before {lam:.3g} N/m)",
    )
