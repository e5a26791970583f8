"""A plan document rebuilt after a repair, by the pipeline's own stages.

A repair changes the shapes (:func:`with_path`), the gripper method (:func:`with_motion`), the
frames themselves (:func:`with_grippers`) or the speed (:func:`slowed`, :func:`timed`); the
gripper frames, the trajectory, the twist and the clip wrenches are then made again by
:func:`dloplan.pipeline.stages.plan_motion` and :func:`~dloplan.pipeline.stages.plan_twist`, and the
warnings of the old motion and of the old verification are replaced by the new ones. The
planner's own sections (stages, forces, target check, obstacle re-planning) stay those of the
plan that was repaired.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...sim.statics import clip_wrenches
from ..document import TwistSection
from ..stages import (
    frame_warnings,
    plan_motion,
    plan_program,
    plan_twist,
    quiet,
    timed_trajectory,
    with_program,
    with_trajectory,
)


def left_clip(grippers, cell) -> int:
    """The clip the left arm of ``cell`` holds (the side rule,
    :func:`dloplan.robot.assign_arms`; the default YuMi for None)."""
    from ...robot import RobotCell, assign_arms

    return assign_arms(grippers.positions, RobotCell() if cell is None else cell).left_clip


def slowed(job, factor: float):
    """``job`` whose motion is the same path slowed down in time by ``factor`` (0 < factor <= 1):
    every speed limit times ``factor``, accelerations times ``factor**2``, jerks times
    ``factor**3``, linear and angular (a time dilation t -> t / factor of the motion law)."""
    if not 0.0 < factor <= 1.0:
        raise ValueError(f"factor: got {factor!r}, expected a slow-down in (0, 1]")
    limits = job.motion.limits
    scaled = {name: getattr(limits, name) * factor ** power
              for power, names in ((1, ("speed", "angular_speed")),
                                   (2, ("acceleration", "angular_acceleration")),
                                   (3, ("jerk", "angular_jerk"))) for name in names}
    return replace(job, motion=replace(job.motion, limits=replace(limits, **scaled)))


def timed(job, doc):
    """``doc`` with its trajectory timed again under ``job``'s motion settings
    (:func:`dloplan.pipeline.stages.timed_trajectory`)."""
    return with_trajectory(doc, timed_trajectory(doc.grippers, job.motion, job.robot))


def timed_with_robot(job, doc, progress=quiet, always=False):
    """:func:`timed`, then the robot program made again (:func:`with_robot`)."""
    return with_robot(job, timed(job, doc), progress, always)


def motion_warnings(doc) -> set[str]:
    """The warnings a document owes to its gripper frames, twist and verification."""
    own: set[str] = set()
    if doc.grippers is not None:
        own |= set(doc.grippers.warnings) | {f"grippers: {doc.grippers.message}"}
    if doc.twist is not None:
        own.add(f"twist: {doc.twist.message}")
    if doc.verification is not None:
        own |= set(doc.verification.messages)
    if doc.robot is not None:
        own.add(doc.robot.message)
    return own


def with_robot(job, doc, progress=quiet, always=False):
    """``doc`` with its robot program made again for its frames and trajectory (when it had
    one, or ``always``): the arm assignment, IK, limits, clearance and continuity of the new
    targets."""
    if doc.robot is None and doc.program is None and not always:
        return doc
    return with_program(without_robot(doc),
                        plan_program(job.robot, doc.grippers, doc.trajectory, progress))


def without_robot(doc):
    """``doc`` without its robot program (and the program's line among its warnings)."""
    warnings = tuple(w for w in doc.warnings if doc.robot is None or w != doc.robot.message)
    return replace(doc, robot=None, program=None, warnings=warnings)


def with_motion(job, doc, shapes=None, stabilized=None, progress=quiet, program=None):
    """``doc`` with new gripper frames, trajectory and twist for ``shapes`` (default its own),
    by ``job``'s gripper and motion settings; the left arm holds the clip on its side."""
    shapes = doc.shapes if shapes is None else np.asarray(shapes, dtype=float)
    grippers, _ = plan_motion(job, shapes, progress)
    return with_grippers(job, doc, grippers, shapes, stabilized, progress, program)


def with_grippers(job, doc, grippers, shapes=None, stabilized=None, progress=quiet,
                  program=None, twist=None, wrenches=None):
    """``doc`` with the gripper frames ``grippers`` of ``shapes`` (default its own), its
    trajectory timed again, the twist computed again, the motion's warnings replaced; its robot
    program made again when ``program`` (default: when ``doc`` had one).

    ``twist`` (a :class:`~dloplan.sim.torsion.TwistReport`) and ``wrenches`` ((S + 2, 2, 6)
    clip wrenches of ``stabilized``) are used as given when the caller already has them (the
    reach repair's frame sets: the same shapes under several frames, the same frames turned
    about the vertical); both are computed when None."""
    shapes = doc.shapes if shapes is None else np.asarray(shapes, dtype=float)
    stabilized = doc.stabilized if stabilized is None else np.asarray(stabilized, dtype=float)
    if twist is None:
        twist = plan_twist(job.cable, shapes, grippers, progress)
    if wrenches is None:
        wrenches = stabilized_wrenches(job.cable, stabilized)
    warnings = [w for w in doc.warnings if w not in motion_warnings(doc)]
    warnings += frame_warnings(grippers, twist)
    trajectory = timed_trajectory(grippers, job.motion, job.robot)
    new = replace(with_trajectory(doc, trajectory), shapes=shapes, stabilized=stabilized,
                  grippers=grippers, warnings=tuple(warnings), robot=None, program=None,
                  clip_wrenches=wrenches,
                  twist=TwistSection(twist.twist, twist.relative_twist, twist.twist_energy,
                                     grippers.twist, twist.message))
    if program is None:
        program = doc.robot is not None or doc.program is not None
    return with_program(new, plan_program(job.robot, grippers, trajectory, progress)) \
        if program else new


def stabilized_wrenches(cable, stabilized: np.ndarray) -> np.ndarray:
    """The clip wrenches (:func:`dloplan.sim.statics.clip_wrenches`) of every stabilized shape
    (S + 2, n + 1, 3) [m]: (S + 2, 2, 6) [N, N m]."""
    return np.stack([clip_wrenches(cable, s) for s in stabilized])


def with_path(job, doc, shapes: np.ndarray, progress=quiet, program=None):
    """``doc`` whose shapes are ``shapes`` (S' + 2, n + 1, 3) [m], each a stabilized
    equilibrium (planned = stabilized), with motion and twist made again (its robot program
    too when ``program``; default: when ``doc`` had one)."""
    return with_motion(job, doc, shapes, shapes, progress, program)


