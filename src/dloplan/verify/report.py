"""The verification table of a plan: one row per stabilized shape, every check in one place.

:func:`verify_path` runs the checks of this package on a planned path and assembles them:

* elastic stability of every shape (:mod:`dloplan.verify.stability`);
* snap-through along every segment (:mod:`dloplan.verify.snap`); a segment's events are shown
  on the row of the shape it leads *to* (the first row has none);
* robot reachability, when per-pose results are given (``reachability``: one item per shape with
  ``reachable_left``, ``reachable_right`` and ``joint_margin`` [rad], as attributes or mapping
  keys; the robot kinematics module computes them, this module only tabulates them);
* dynamic replay at real speed, when the shapes' times (or a timed trajectory) are given
  (:mod:`dloplan.verify.replay`).

A check that was not run shows ``None`` in its column and does not fail the plan.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field

from ..cable import GRAVITY, Cable
from ..geometry import as_path
from ..sim.clips import ClipPoses
from ._inputs import as_clip_sequence
from .replay import Replay, replay
from .snap import SnapCheck, check_snap_through
from .stability import Stability, path_stability


@dataclass(frozen=True)
class Reachability:
    """Robot feasibility of one planned pose (computed by the robot kinematics module).

    Attributes
    ----------
    reachable_left, reachable_right : bool
        Each arm reaches its TCP pose within its joint limits.
    joint_margin : float or None
        Smallest distance of a joint to its limit over both arms [rad].
    message : str
        Why not, when not.
    """

    reachable_left: bool
    reachable_right: bool
    joint_margin: float | None = None
    message: str = ""


def as_reachability(item) -> Reachability:
    """A :class:`Reachability` from one, a mapping, or an object with the same attribute names."""
    if isinstance(item, Reachability):
        return item
    names = ("reachable_left", "reachable_right", "joint_margin", "message")
    if isinstance(item, Mapping):
        values = {k: item[k] for k in names if k in item}
    else:
        values = {k: getattr(item, k) for k in names if hasattr(item, k)}
    if "reachable_left" not in values or "reachable_right" not in values:
        raise ValueError(
            f"reachability: got {type(item).__name__} without reachable_left/reachable_right"
        )
    margin = values.get("joint_margin")
    return Reachability(bool(values["reachable_left"]), bool(values["reachable_right"]),
                        None if margin is None else float(margin), str(values.get("message", "")))


@dataclass(frozen=True)
class ShapeRow:
    """One row of the verification table.

    Attributes
    ----------
    index : int
        Shape index (0 = start, S + 1 = target).
    stable : bool
        Elastic stability of the stabilized shape.
    smallest_eigenvalue : float
        Smallest free-DOF Hessian eigenvalue [N/m].
    relative_eigenvalue : float
        The same over the stiffness scale lambda_ref (dimensionless).
    snap : bool or None
        A snap-through (jump, instability or other branch) on the way to this shape; None for
        the first shape or when not checked.
    straying : float or None
        How far the quasi-static motion into this shape strays from the straight
        interpolation [m].
    reachable_left, reachable_right : bool or None
        Robot reachability (None when not checked).
    joint_margin : float or None
        Smallest joint-limit distance [rad] (None when not checked).
    replay_deviation : float or None
        Dynamic replay deviation at this shape's time [m] (None when not run).
    """

    index: int
    stable: bool
    smallest_eigenvalue: float
    relative_eigenvalue: float
    snap: bool | None = None
    straying: float | None = None
    reachable_left: bool | None = None
    reachable_right: bool | None = None
    joint_margin: float | None = None
    replay_deviation: float | None = None


@dataclass(frozen=True, eq=False)
class Verification:
    """Result of :func:`verify_path`.

    Attributes
    ----------
    rows : tuple of ShapeRow
        One per shape.
    ok : bool
        Every check that was run passed.
    messages : tuple of str
        What failed (or a one-line confirmation).
    timings : dict
        Wall time of each check [s], keyed ``"stability"``, ``"snap"``, ``"replay"``.
    stability : tuple of Stability
        Per-shape eigen-analysis.
    snap : SnapCheck or None
        The continuation (None when not run).
    replay : Replay or None
        The dynamic replay (None when not run).
    """

    rows: tuple[ShapeRow, ...]
    ok: bool
    messages: tuple[str, ...]
    timings: dict[str, float] = field(default_factory=dict)
    stability: tuple[Stability, ...] = ()
    snap: SnapCheck | None = None
    replay: Replay | None = None

    @property
    def success(self) -> bool:
        """Same as ``ok``."""
        return self.ok

    @property
    def warnings(self) -> tuple[str, ...]:
        """None: each check of a shape passes or fails (a harness plan's phases may warn,
        :class:`dloplan.harness.verification.HarnessVerification`)."""
        return ()

    def table(self) -> str:
        """The table as fixed-width text, one line per shape (lengths in mm)."""
        header = (f"{'shape':>5} {'stable':>6} {'lambda_1 [N/m]':>14} {'lambda_1/ref':>12} "
                  f"{'snap':>5} {'stray [mm]':>10} {'left':>5} {'right':>5} "
                  f"{'margin [rad]':>12} {'replay [mm]':>11}")
        lines = [header]
        for r in self.rows:
            lines.append(
                f"{r.index:>5} {_flag(r.stable):>6} {r.smallest_eigenvalue:>14.4g} "
                f"{r.relative_eigenvalue:>12.4g} {_event(r.snap):>5} {_mm(r.straying):>10} "
                f"{_flag(r.reachable_left):>5} {_flag(r.reachable_right):>5} "
                f"{_num(r.joint_margin, '.3f'):>12} {_mm(r.replay_deviation):>11}"
            )
        lines.append("verdict: " + ("ok" if self.ok else "FAILED") + " -- "
                     + "; ".join(self.messages))
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """JSON-ready summary: rows, verdict, messages, timings (SI units, None = not run)."""
        return {
            "ok": self.ok,
            "messages": list(self.messages),
            "timings_s": dict(self.timings),
            "rows": [{k: _json_number(v) for k, v in asdict(r).items()} for r in self.rows],
        }


def _event(value: bool | None) -> str:
    """A flag where True is the bad outcome (a snap): shown as SNAP, its absence as no."""
    return "-" if value is None else ("SNAP" if value else "no")


def _flag(value: bool | None) -> str:
    return "-" if value is None else ("yes" if value else "NO")


def _num(value: float | None, fmt: str) -> str:
    return "-" if value is None else format(value, fmt)


def _mm(value: float | None) -> str:
    return _num(None if value is None else 1e3 * value, ".2f")


def _json_number(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None if math.isnan(value) else str(value)
    return value


def verify_path(
    cable: Cable,
    stabilized_shapes,
    clip_poses: Sequence[ClipPoses] | None = None,
    *,
    times=None,
    trajectory=None,
    reachability: Sequence | None = None,
    gravity=GRAVITY,
    snap: bool = True,
    stability_options: Mapping | None = None,
    snap_options: Mapping | None = None,
    replay_options: Mapping | None = None,
    progress=lambda text: None,
    physics: Verification | None = None,
) -> Verification:
    """Verify a planned path: stability, snap-through, reachability (given), dynamic replay.

    Parameters
    ----------
    cable : Cable
        The cable.
    stabilized_shapes : array_like
        (S + 2, n + 1, 3) stabilized shapes of the plan [m].
    clip_poses : sequence of ClipPoses, optional
        The planned clip poses of each shape; default: read off the shapes' end links.
    times : array_like, optional
        (S + 2,) time of each shape on the timed trajectory [s]; enables the replay.
    trajectory : optional
        The timed clip motion driving the replay (:func:`dloplan.verify.replay.as_clip_trajectory`);
        default: ``(times, clip_poses)``, linear between the shapes.
    reachability : sequence, optional
        Per-shape robot results (see :func:`as_reachability`), length S + 2.
    gravity : array_like
        Gravity [m/s^2].
    snap : bool
        Run the snap-through continuation.
    stability_options, snap_options, replay_options : mapping, optional
        Keyword options of :func:`~dloplan.verify.stability.elastic_stability`,
        :func:`~dloplan.verify.snap.check_snap_through`, :func:`~dloplan.verify.replay.replay`.
    progress : callable
        Called with a line of text before each check (the long ones say how long they take).
    physics : Verification, optional
        A verification of the same physics (the same path moved rigidly about the vertical:
        :func:`dloplan.pipeline.reuse.moved_rigidly`): its stability, snap-through and replay
        are taken instead of run (their timings are not recorded), only the reachability is
        new. The caller vouches for the sameness; the shapes those results hold (the
        continuation's, the replay's records) stay in the frame of the plan they were run on.

    Returns
    -------
    Verification
        The table, verdict, messages and per-check timings.
    """
    path = as_path(stabilized_shapes, cable.n_points, "stabilized_shapes")
    poses = as_clip_sequence(clip_poses, path)
    reach = None
    if reachability is not None:
        reach = [as_reachability(item) for item in reachability]
        if len(reach) != len(path):
            raise ValueError(
                f"reachability: {len(reach)} results given, expected {len(path)} (one per shape)"
            )
    if trajectory is not None and times is None:
        raise ValueError("times: required with a trajectory (the time of each shape [s])")
    timings: dict[str, float] = {}
    messages: list[str] = []

    if physics is None:
        stability, snap_check, run = _physics(cable, path, poses, times, trajectory, gravity,
                                              snap, stability_options, snap_options,
                                              replay_options, progress, timings)
    else:
        progress("verification: stability, snap-through and replay of the plan before its "
                 "rigid move reused")
        stability, snap_check, run = physics.stability, physics.snap, physics.replay
        if len(stability) != len(path) or (snap_check is not None) != (
                snap and len(path) > 1) or (run is None) != (times is None):
            raise ValueError("physics: a verification of another path or of other checks")
    messages += [f"shape {k}: {s.message}" for k, s in enumerate(stability) if not s.stable]
    messages += [] if snap_check is None else [e.message for e in snap_check.events]
    if run is not None and not run.ok:
        messages.append(f"replay: {run.message}")

    rows = []
    for k, s in enumerate(stability):
        seg = snap_check.segments[k - 1] if snap_check is not None and k > 0 else None
        robot = reach[k] if reach is not None else None
        if robot is not None and not (robot.reachable_left and robot.reachable_right):
            arms = [a for a, r in (("left", robot.reachable_left),
                                   ("right", robot.reachable_right)) if not r]
            messages.append(f"shape {k}: not reachable by the {' and '.join(arms)} arm"
                            + (f" ({robot.message})" if robot.message else ""))
        rows.append(ShapeRow(
            index=k,
            stable=s.stable,
            smallest_eigenvalue=s.smallest,
            relative_eigenvalue=s.relative,
            snap=None if seg is None else bool(seg.events),
            straying=None if seg is None else seg.straying,
            reachable_left=None if robot is None else robot.reachable_left,
            reachable_right=None if robot is None else robot.reachable_right,
            joint_margin=None if robot is None else robot.joint_margin,
            replay_deviation=None if run is None else float(run.deviations[k]),
        ))
    ok = not messages
    if ok:
        checks = ["stability"] + (["snap-through"] if snap_check else []) + (
            ["reachability"] if reach else []) + (["replay"] if run else [])
        messages.append(f"{len(path)} shapes pass: {', '.join(checks)}")
    return Verification(tuple(rows), ok, tuple(messages), timings, stability, snap_check, run)


def _physics(cable, path, poses, times, trajectory, gravity, snap, stability_options,
             snap_options, replay_options, progress, timings):
    """Stability, snap-through (or None) and replay (or None) of :func:`verify_path`, each
    timed into ``timings``."""
    progress(f"verification: elastic stability of {len(path)} shapes")
    start = time.perf_counter()
    stability = path_stability(cable, path, gravity=gravity, **dict(stability_options or {}))
    timings["stability"] = time.perf_counter() - start
    snap_check = run = None
    if snap and len(path) > 1:
        progress(f"verification: snap-through along {len(path) - 1} segments (continuation)")
        start = time.perf_counter()
        snap_check = check_snap_through(cable, path, poses, gravity=gravity,
                                        **dict(snap_options or {}))
        timings["snap"] = time.perf_counter() - start
    if times is not None:
        progress(f"verification: dynamic replay of {float(times[-1] - times[0]):.2f} s of motion "
                 "at real speed")
        start = time.perf_counter()
        drive = trajectory if trajectory is not None else (times, poses)
        run = replay(cable, path, drive, knot_times=times, gravity=gravity,
                     **dict(replay_options or {}))
        timings["replay"] = time.perf_counter() - start
    return stability, snap_check, run
