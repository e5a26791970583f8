"""Gripper frames that do not twist the cable: the last clip rolled against the twist.

A clip holds the cable's end link; turning it about that link's axis (its u-axis, the frame's
x-axis) changes nothing for the bending of a torsion-free model but twists a real cable. The
torsion model (:func:`dloplan.sim.torsion.twist_along_path`) gives, for every shape, the total
twist tau_k [rad] the gripper frames put between the clips. :func:`untwisted` rolls the last
clip's frame at shape k by tau_k about its own u-axis and computes the twist again; a few such
fixed-point steps bring every tau_k to round-off (the twist is, to first order, the difference of
the clips' rolls). The u-axes and the clip points stay those of the shapes: the plan's
equilibria do not change.

:func:`grasp_rolled` chooses how each gripper grasps its clip instead: one roll per clip about
its u-axis, the same at every shape (the gripper takes the cable turned about the cable's own
axis, so the grasp itself twists nothing), such that the wrist stays above its clip, away
from the other clip and on the robot's side over the whole path. A gripper holds its clip with
the TCP z-axis as the approach axis (``tool.tcp_in_clip``): the wrist lies at the clip point
minus the TCP offset along that axis, and the approach and the retreat move along it
(:mod:`dloplan.robot.program`). Frames from the gripper methods only fix the u-axis; their
roll may put both wrists between the clips (arm-arm collisions at a U or an arc whose ends come
close, thesis qualitative test 2) or under the clip (the wrist at the table).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation

from ...frames import compose
from ...grippers.path import GripperPath, relative_twist
from ...sim.torsion import TwistReport
from ..stages import plan_twist

ROLL_STEPS = 4
"""Fixed-point steps of :func:`untwisted`."""

GRASP_ROLLS = np.radians(np.arange(-90.0, 90.5, 5.0))
"""Grasp rolls [rad] tried by :func:`grasp_rolled` (within a quarter turn: a half turn would
put the wrist under the clip)."""

AWAY_WEIGHT = 0.5
"""Weight of the wrist direction's horizontal components, away from the other clip and towards
the robot, against its height in :func:`grasp_scores` (the table is below: height comes
first)."""


SHARES = (0.0, 0.5, 1.0)
"""Shares of the untwisting roll given to the first clip by the twist repair (the rest goes to
the last clip): the last clip alone, both halves, the first clip alone."""


def untwisted(cable, shapes: np.ndarray, grippers: GripperPath,
              steps: int = ROLL_STEPS, share: float = 0.0) -> tuple[GripperPath, np.ndarray]:
    """The gripper frames with the clips rolled so that the torsion model's twist vanishes.

    Parameters
    ----------
    cable : Cable
    shapes : numpy.ndarray
        (S + 2, n + 1, 3) the planned shapes [m].
    grippers : GripperPath
        Their frames (any method).
    steps : int
        Fixed-point steps.
    share : float
        The part (0..1) of the roll the first clip takes; the last clip takes the rest. Both
        u-axes point from their clip into the cable, so a roll of either clip by an angle about
        its own u-axis changes the twist by minus that angle: the first clip rolled by
        ``share * tau`` and the last by ``(1 - share) * tau`` remove tau whatever the share,
        and a share of 1/2 turns each wrist half as far (the robot may reach one and not the
        other).

    Returns
    -------
    grippers : GripperPath
        Same method label, positions and u-axes; the clips' frames rolled.
    twist : numpy.ndarray
        (S + 2,) the torsion model's twist under the new frames [rad].
    """
    if not 0.0 <= share <= 1.0:
        raise ValueError(f"share: got {share!r}, expected a part of the roll in [0, 1]")
    which = {0.0: "the last clip", 1.0: "the first clip"}.get(
        share, f"both clips ({share:.0%} of the roll on the first)")
    twist = _twist(cable, shapes, grippers)
    for _ in range(steps):
        first, last = (Rotation.from_rotvec(part * twist[:, None] * np.array([1.0, 0.0, 0.0]))
                       for part in (share, 1.0 - share))
        grippers = with_rotations(grippers, grippers.rotations[0] * first,
                                  grippers.rotations[1] * last,
                                  f"{which} rolled about the u-axis against the torsion "
                                  "model's twist")
        twist = _twist(cable, shapes, grippers)
    return grippers, twist


def _twist(cable, shapes, grippers) -> np.ndarray:
    return plan_twist(cable, shapes, grippers).twist


class RolledTwists:
    """The torsion model's twist of frame sets rolled by grasp rolls, each solved once.

    The reach repair tries every frame set of the plan, as it is and with its grasps rolled
    (:func:`grasp_rolled`), at every turn of the job about the vertical
    (:data:`~.placement.YAWS`). A turn about the vertical moves the shapes and the frames
    rigidly and leaves gravity as it is, so the solve's twist, relative twist and twist energy
    (scalars per shape) do not change with it: the report of a frame set rolled by given rolls
    is solved at the first turn that asks for it and given again at the others (equal to a
    solve of the turned frames to the solver's round-off, tests/test_repair.py).

    Parameters
    ----------
    cable : Cable
        The cable (the same for every frame set).
    """

    def __init__(self, cable) -> None:
        self.cable = cable
        self.reports: dict[tuple, TwistReport] = {}
        self.inputs: dict[tuple, tuple] = {}

    def __call__(self, base, rolls: np.ndarray, shapes: np.ndarray,
                 grippers: GripperPath) -> TwistReport:
        """The report of ``grippers`` on ``shapes``: the frame set ``base`` (any hashable
        name of the unrolled frames, e.g. their index) rolled by ``rolls`` (2,) [rad], turned
        or not; solved (:func:`~dloplan.pipeline.stages.plan_twist`) the first time the pair
        is asked for, on the shapes and frames of the first turn that asked or claimed it
        (:meth:`claim`)."""
        key = self.claim(base, rolls, shapes, grippers)
        if key not in self.reports:
            self.reports[key] = plan_twist(self.cable, *self.inputs[key])
        return self.reports[key]

    def claim(self, base, rolls: np.ndarray, shapes: np.ndarray,
              grippers: GripperPath) -> tuple:
        """Ask for the pair's report without solving it yet (a frame set whose twist may
        never be needed): a later call solves it on these shapes and frames unless an earlier
        turn asked first, so the report is the same whether or not the solve was put off.
        Returns the pair's key."""
        key = (base, *(float(r) for r in rolls))
        self.inputs.setdefault(key, (shapes, grippers))
        return key


def grasp_scores(grippers: GripperPath, cell, *, towards_robot: bool = True) -> np.ndarray:
    """How well each clip's gripper is placed along the path, for each grasp roll of
    :data:`GRASP_ROLLS`: the smallest, over the shapes, of the wrist direction's height plus
    :data:`AWAY_WEIGHT` times its horizontal components away from the other clip and towards
    the robot (the arm comes from its base: a wrist on the far side of the clip makes the arm
    reach around it).

    The wrist direction is minus the TCP z-axis (``cell.tools[0].tcp_in_clip``) in the clip's
    frame rolled about its u-axis by the roll. All rolls and shapes of a clip are one batch of
    rotations: element by element the same arithmetic as one roll at a time.

    Parameters
    ----------
    grippers : GripperPath
        The plan's frames (any method), K shapes.
    cell : RobotCell
        The robot cell: its base position and its tools' ``tcp_in_clip``.
    towards_robot : bool
        Score the wrist towards the robot's base too (:func:`grasp_rolled`); False leaves that
        term out.

    Returns
    -------
    numpy.ndarray
        (2, len(GRASP_ROLLS)) the scores, clip by clip.
    """
    wrist_in_clip = -cell.tools[0].tcp_in_clip.apply([0.0, 0.0, 1.0])
    base = np.asarray(cell.base_position, dtype=float) if towards_robot else None
    pos = grippers.positions
    k, a = len(pos), len(GRASP_ROLLS)
    rolls = Rotation.from_rotvec(np.outer(GRASP_ROLLS, [1.0, 0.0, 0.0]))[np.repeat(range(a), k)]
    scores = np.empty((2, a))
    for c in range(2):
        frames = grippers.rotations[c][np.tile(range(k), a)]
        wrist = compose(frames, rolls).apply(wrist_in_clip).reshape(a, k, 3)  # (rolls, shapes, 3)
        score = wrist[..., 2]
        for towards in (pos[:, c] - pos[:, 1 - c], *(() if base is None else (base - pos[:, c],))):
            towards = towards * [1.0, 1.0, 0.0]
            towards /= np.maximum(np.linalg.norm(towards, axis=1, keepdims=True), 1e-12)
            score = score + AWAY_WEIGHT * np.sum(wrist * towards, axis=2)
        scores[c] = np.min(score, axis=1)
    return scores


def grasp_rolled(grippers: GripperPath, cell, *, towards_robot: bool = True,
                 paired: bool = False, scores: np.ndarray | None = None,
                 ) -> tuple[GripperPath, np.ndarray]:
    """The gripper frames with each clip rolled about its u-axis by the grasp roll of
    :data:`GRASP_ROLLS` that maximizes its score (:func:`grasp_scores`, module docstring).

    Parameters
    ----------
    grippers : GripperPath
        The plan's frames (any method).
    cell : RobotCell
        The robot cell: its base position and its tools' ``tcp_in_clip``.
    towards_robot : bool
        Score the wrist towards the robot's base too (the arm reaching around its clip: the
        jobs beside the robot's centre line need it), or only above and apart (an arc whose
        ends come close in front of the robot, qualitative test 2, needs this one).
    paired : bool
        One roll r for the first clip and -r for the last, the r that maximizes the smaller of
        the two clips' scores: the cable turned about its own axis at both ends alike, which
        leaves the torsion model's twist as it is (both u-axes point into the cable; rolls of
        the same sign would twist it by their sum). Frames already untwisted stay untwisted.
    scores : numpy.ndarray, optional
        (2, len(GRASP_ROLLS)) :func:`grasp_scores` of ``grippers``, ``cell`` and
        ``towards_robot`` when already computed (the paired and the per-clip choice read the
        same scores); computed when None.

    Returns
    -------
    grippers : GripperPath
        Same positions and u-axes, each clip's frames rolled by its grasp roll (the frames'
        relative twist computed again); ``grippers`` itself when neither clip is rolled.
    rolls : numpy.ndarray
        (2,) the grasp roll of each clip [rad] (0 when the plan's own grasp scores best).
    """
    if scores is None:
        scores = grasp_scores(grippers, cell, towards_robot=towards_robot)
    plain = int(np.argmin(np.abs(GRASP_ROLLS)))  # the roll 0: the plan's own grasp
    rolls = np.zeros(2)
    if paired:  # the last clip's scores at -r: GRASP_ROLLS is symmetric about 0
        both = np.minimum(scores[0], scores[1, ::-1])
        best = int(np.argmax(both))
        if both[best] > both[plain]:
            rolls[:] = GRASP_ROLLS[best], -GRASP_ROLLS[best]
    else:
        for c in range(2):
            best = int(np.argmax(scores[c]))
            if scores[c, best] > scores[c, plain]:
                rolls[c] = GRASP_ROLLS[best]
    if not rolls.any():
        return grippers, rolls
    first, last = (r * Rotation.from_rotvec([a, 0.0, 0.0])
                   for r, a in zip(grippers.rotations, rolls, strict=True))
    rolled = with_rotations(grippers, first, last, f"grasps rolled by "
                            f"{np.degrees(rolls[0]):.0f} and {np.degrees(rolls[1]):.0f} deg "
                            "about the clips' u-axes (wrists above, apart"
                            + (", towards the robot" if towards_robot else "")
                            + ("; the cable turned about its axis)" if paired else ")"))
    return rolled, rolls


def with_rotations(grippers: GripperPath, first: Rotation, last: Rotation,
                   note: str) -> GripperPath:
    """``grippers`` with new clip frames of the same u-axes: their relative twist computed
    again, ``note`` appended to the method's message."""
    frames = relative_twist(first, last)
    return replace(
        grippers, rotations=(first, last), twist=frames,
        success=bool(np.max(np.abs(frames)) <= grippers.max_twist),
        warnings=tuple(w for w in grippers.warnings if not w.startswith("relative twist")),
        message=f"{grippers.message.split(';')[0]}; {note}")


def same_frames(a: GripperPath, b: GripperPath, tolerance: float = 1e-6) -> bool:
    """Two gripper paths whose clip frames agree to ``tolerance`` [rad] at every shape: the
    largest angle of the rotation from one clip frame to the other (scipy's ``magnitude``)
    below ``tolerance``.

    Frames that differ by more than ``2 * tolerance`` in an entry of their matrices are told
    apart from the matrices alone: for rotations P, Q at an angle theta apart,
    ``|P_ij - Q_ij| <= ||P - Q||_F = 2 sqrt(2) sin(theta / 2) <= sqrt(2) theta``, so such a
    pair is more than ``sqrt(2) * tolerance`` apart and the answer is False either way (the
    reach repair compares every new frame set with the earlier ones: most pairs differ by
    degrees, and the matrices cost a fraction of the rotations' composition).

    Parameters
    ----------
    a, b : GripperPath
        Frames of the same shapes (S + 2 each).
    tolerance : float
        Largest angle [rad] between two frames called the same.

    Returns
    -------
    bool
        Every clip frame of ``a`` within ``tolerance`` of ``b``'s.
    """
    pairs = tuple(zip(a.rotations, b.rotations, strict=True))
    if any(np.abs(p.as_matrix() - q.as_matrix()).max() > 2.0 * tolerance for p, q in pairs):
        return False
    return all(np.max((p * q.inv()).magnitude()) < tolerance for p, q in pairs)
