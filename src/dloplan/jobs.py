"""Scenario-level jobs: what each ``dloplan`` command does, as library functions.

The command line stays thin: it parses arguments, loads a scenario (:mod:`dloplan.io.scenario`)
and calls one function here, which calls the pipeline (statics, planner, obstacles, grippers,
trajectory, verification) and returns a result the command prints and writes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .cable import Cable
from .io.scenario import Job
from .obstacles.collisions import check_shape
from .physics.geometry import as_shape, resample_by_arc_length, shape_length
from .sim.clips import clip_poses_from_shape
from .sim.statics import check_clip_reach, check_target

LENGTH_TOLERANCE = 0.05
"""Relative difference between a given shape's length and the cable's accepted at the input."""


@dataclass(frozen=True)
class Finding:
    """One result line of a check: ``level`` is "ok", "warning" or "error"."""

    level: str
    subject: str
    message: str

    def line(self) -> str:
        mark = {"ok": "ok     ", "warning": "WARNING", "error": "ERROR  "}[self.level]
        return f"{mark} {self.subject}: {self.message}"


@dataclass(frozen=True)
class CheckReport:
    """Result of :func:`check_job`."""

    findings: list[Finding] = field(default_factory=list)

    @property
    def errors(self) -> list[Finding]:
        return [f for f in self.findings if f.level == "error"]

    @property
    def warnings(self) -> list[Finding]:
        return [f for f in self.findings if f.level == "warning"]


def discretize(points, cable: Cable, name: str) -> np.ndarray:
    """A given shape as n + 1 points of the cable: resampled by arc length, length checked.

    Raises ValueError when its length differs from the cable's by more than
    :data:`LENGTH_TOLERANCE`.
    """
    x = as_shape(points, name=name)
    length = float(shape_length(x))
    if abs(length / cable.length - 1.0) > LENGTH_TOLERANCE:
        hint = " (given in millimetres?)" if 500 < length / cable.length < 2000 else ""
        raise ValueError(
            f"{name}: the shape is {length:.4g} m long but the cable is {cable.length:.4g} m"
            f"{hint}; expected within {100 * LENGTH_TOLERANCE:.0f} %"
        )
    if len(x) != cable.n_points:
        x = resample_by_arc_length(x, cable.n_points)
    return x


def check_job(job: Job) -> CheckReport:
    """Check a job without planning: shapes, clip reach, target stability, obstacles.

    Thesis 5.3 (target stability) and 5.4 (collisions of the stabilized start and target).
    """
    cable = job.cable
    findings: list[Finding] = []
    shapes = {}
    for name, points in (("start", job.start), ("target", job.target)):
        try:
            shapes[name] = discretize(points, cable, name)
        except ValueError as exc:
            findings.append(Finding("error", name, str(exc)))
            continue
        clips = clip_poses_from_shape(shapes[name])
        try:
            check_clip_reach(cable, clips)
            findings.append(Finding("ok", name, f"clips {1e3 * clips.distance:.1f} mm apart, "
                                    f"within reach of the {cable.length:.3g} m cable"))
        except ValueError as exc:
            findings.append(Finding("error", name, str(exc)))
            shapes.pop(name)
    threshold = job.scenario.check.threshold * job.scale
    settled = {}
    for name, shape in shapes.items():
        report = check_target(shape, cable, threshold=threshold)
        settled[name] = report.stabilized.shape
        if name == "target":
            level = "ok" if report.stable else "warning"
            findings.append(Finding(level, "target stability", report.message))
    for name, shape in settled.items():
        collision = check_shape(shape, job.obstacles, cable.diameter / 2)
        if collision.colliding:
            findings.append(Finding("error", f"{name} obstacles",
                                    f"the stabilized {name} collides: {collision.describe()}"))
        elif job.obstacles:
            findings.append(Finding("ok", f"{name} obstacles",
                                    f"clear by {1e3 * -collision.penetration:.1f} mm"))
    return CheckReport(findings)


def plan_clip_poses(doc) -> list:
    """Clip poses of every shape of a plan document: its gripper frames, or read off the shapes."""
    if doc.grippers is not None:
        return [doc.grippers.clip_poses(k) for k in range(len(doc.shapes))]
    return [clip_poses_from_shape(shape) for shape in doc.shapes]


def stabilized_shapes(doc) -> np.ndarray:
    """The plan's stabilized shapes: as stored by ``dloplan plan``, or computed now."""
    stored = doc.extra.get("stabilized")
    if stored is not None:
        return np.asarray(stored, dtype=float)
    from .obstacles.collisions import stabilized_path

    return stabilized_path(doc.cable, doc.shapes)[0]


def verify_document(doc, *, snap: bool = True, replay: bool = True, tensile_limit=None,
                    tolerance: float = 0.01):
    """Run :func:`dloplan.verify.verify_path` on a plan document (stability, snap, replay)."""
    from .verify import verify_path

    # the replay drives the clips linearly (slerp in rotation) between the planned poses at the
    # trajectory's knot times: the same motion as the timed dual-arm trajectory
    times = doc.trajectory.times if replay and doc.trajectory is not None else None
    replay_options = {"tolerance": tolerance, "tensile_limit": tensile_limit}
    return verify_path(doc.cable, stabilized_shapes(doc), plan_clip_poses(doc), times=times,
                       snap=snap, replay_options=replay_options)
