"""The reach repair's frame sets, each made only as far as it is tried.

The reach repair (:mod:`.loop`, ``fix_reach``) tries every set of gripper frames -- the plan's,
the other gripper methods', each with its grasps rolled (:func:`~.frames.grasp_rolled`) -- at
every turn of the job about the vertical (:data:`~.placement.YAWS`), first where the job lies,
then shifted. A set that twists the cable is not tried (its twist is judged when it is made:
:func:`~.failures.frame_twist_failures`, for a rolled set the torsion model's solve along the
path, :class:`~.frames.RolledTwists`), and most of the others never get past the placement
search's pre-check, which reads the frames alone (the targets within the arms' reach spheres,
IK at the targets, :func:`~.placement.placements`). So a :class:`FrameSet` is its frames and
its twist, and its document -- the plan turned (:func:`~.placement.moved_document`: the
trajectory timed again), the frames rolled (:func:`~.rebuild.with_grippers`: the trajectory
timed again, the clip wrenches, the twist section) -- is made when a place is found for it.
The documents made are those made before for every set: the same functions of the same
inputs.
"""

from __future__ import annotations

from functools import cached_property

from .failures import frame_twist_failures
from .placement import TableMove, moved_document, moved_grippers, moved_job, within_spheres
from .rebuild import stabilized_wrenches, with_grippers


class Place:
    """One base frame set of the reach repair at one turn of the job: its job and frames, and,
    made on demand, its document, shapes and clip wrenches (shared by the sets rolled from it).

    Parameters
    ----------
    turn : TableMove
        The turn about the vertical (no offset).
    job : Job
        The job of the base frame set, not turned.
    doc : PlanDocument
        Its document (no robot program), not turned.
    """

    def __init__(self, turn: TableMove, job, doc) -> None:
        self.turn, self.base = turn, doc
        self.job = moved_job(job, turn) if turn.yaw else job
        self.grippers = moved_grippers(doc.grippers, turn) if turn.yaw else doc.grippers
        self._doc = None if turn.yaw else doc
        self._shapes = self._wrenches = None

    @property
    def document(self):
        """The base document turned (:func:`~.placement.moved_document`, no program)."""
        if self._doc is None:
            self._doc = moved_document(self.job, self.base, self.turn, program=False)
        return self._doc

    @property
    def shapes(self):
        """(S + 2, n + 1, 3) [m] the planned shapes turned (those of :attr:`document`)."""
        if self._doc is not None:
            return self._doc.shapes
        if self._shapes is None:
            self._shapes = self.turn.points(self.base.shapes)
        return self._shapes

    @property
    def wrenches(self):
        """(S + 2, 2, 6) the clip wrenches of the turned stabilized shapes."""
        if self._wrenches is None:
            stabilized = self.document.stabilized if self._doc is not None else \
                self.turn.points(self.base.stabilized)
            self._wrenches = stabilized_wrenches(self.job.cable, stabilized)
        return self._wrenches


class FrameSet:
    """A set of gripper frames the reach repair may try: a place's own frames (``rolls``
    None) or its grasps rolled by ``rolls`` (2,) [rad].

    Parameters
    ----------
    place : Place
    frames : GripperPath
        The frames (turned).
    rolls : numpy.ndarray or None
    base : int
        Which base frame set (the name of its twists in ``twists``).
    twists : RolledTwists
        The torsion model's solves of the rolled sets, shared by every turn.
    plan : bool
        The frames are the plan's own, where it lies: tried whatever their twist (the plan as
        it is).
    """

    def __init__(self, place: Place, frames, rolls, base: int, twists, plan: bool) -> None:
        self.place, self.frames, self.rolls = place, frames, rolls
        self.base, self.twists, self.plan = base, twists, plan
        self._left = self._doc = None

    @property
    def job(self):
        """The job of these frames (the base's method, turned)."""
        return self.place.job

    @cached_property
    def within_spheres(self) -> bool:
        """The search where the job lies may place these frames: their targets are within
        the arms' reach spheres (:func:`~.placement.within_spheres`)."""
        return within_spheres(self.frames, self.job.robot)

    @property
    def put_off(self) -> bool:
        """Its twist is judged only when it matters (the reach repair's ``turned_frames``):
        not the plan's own frames, and out of the arms' reach spheres where the job lies."""
        return not (self.plan or self.within_spheres)

    def put_off_twist(self) -> None:
        """Claim the torsion model's solve of these frames without making it
        (:meth:`~.frames.RolledTwists.claim`): :meth:`twist_failures` makes it when it is
        needed, on the frames of the first turn that claimed it."""
        if self.rolls is not None:
            self.twists.claim(self.base, self.rolls, self.place.shapes, self.frames)

    def twist_failures(self) -> list:
        """The twist check of these frames (:func:`~.failures.twist_failures` of their
        document; none for the plan's own frames, tried whatever their twist)."""
        if self._left is None:
            if self.plan:
                self._left = []
            elif self.rolls is None:
                twist = self.place.base.twist
                self._left = frame_twist_failures(self.frames,
                                                  None if twist is None else twist.twist)
            else:
                self._left = frame_twist_failures(self.frames, self._report().twist)
        return self._left

    @property
    def document(self):
        """The plan document with these frames (no robot program)."""
        if self._doc is None:
            self._doc = self.place.document if self.rolls is None else with_grippers(
                self.place.job, self.place.document, self.frames, program=False,
                twist=self._report(), wrenches=self.place.wrenches)
        return self._doc

    def _report(self):
        return self.twists(self.base, self.rolls, self.place.shapes, self.frames)
