"""What failed in a verified plan, sorted into the kinds the repairs address.

:func:`diagnose` reads a plan document and its :class:`~dloplan.verify.Verification` and returns
one :class:`Failure` per problem, of one of the kinds of :data:`KINDS`, in the order the repair
loop handles them:

``snap``
    A snap-through, a loss of stability or a planned shape that is not the equilibrium the
    quasi-static motion reaches, on segment s (shape s -> s + 1); also a planned shape that is
    not a stable equilibrium (on the segment that leads to it).
``twist``
    The gripper frames twist the cable (the torsion model's twist above the gripper path's
    ``max_twist``, thesis 4.6) or a clip frame flips (turns by more than ``max_step`` between
    two shapes).
``replay``
    The dynamic replay at real speed deviates from the planned shapes (at a knot: the segment
    that leads to it) or does not settle.
``reach``
    A planned pose that an arm of the robot cannot reach, or another failing check of the
    plan's robot program (joint limits, arm-arm clearance, continuity).

A failed verification none of these explains (a check this module does not know) is one failure
of kind ``other``, which no repair addresses.

The shapes come first (a new path needs new gripper frames), then the frames (they do not change
the physics of a torsion-free cable), the speed (it times the final path) and the placement last
(the robot's reach depends on the frames; nothing physical depends on where the job lies).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from ...grippers.path import DEFAULT_MAX_STEP

KINDS = ("snap", "twist", "replay", "reach")
"""Failure kinds, in the order the repair loop handles them."""


@dataclass(frozen=True)
class Failure:
    """One problem of a plan.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    segment : int or None
        The segment s (motion from shape s to shape s + 1) it belongs to, when it has one.
    shapes : tuple of int
        The shapes involved.
    message : str
        The check's own words.
    """

    kind: str
    segment: int | None
    shapes: tuple[int, ...]
    message: str


def frame_steps(grippers) -> np.ndarray:
    """(S + 1,) largest rotation of either clip frame between consecutive shapes [rad]."""
    steps = [(r[:-1].inv() * r[1:]).magnitude() for r in grippers.rotations]
    return np.max(steps, axis=0) if grippers.n_shapes > 1 else np.zeros(0)


def twist_failures(doc, max_step: float = DEFAULT_MAX_STEP) -> list[Failure]:
    """Excessive twist and frame flips of a plan's gripper frames.

    The twist is the torsion model's (the document's ``twist`` section: every shape stabilized
    with torsion under the frames), checked against the gripper path's ``max_twist``; only
    without it the frames' relative twist. The relative twist of the frames alone is singular
    where the last clip's u-axis turns by 180 deg relative to the first (a planar U): there it
    may read 180 deg for a cable the torsion model finds untwisted.
    """
    return frame_twist_failures(doc.grippers, None if doc.twist is None else doc.twist.twist,
                                max_step)


def frame_twist_failures(grippers, twist=None,
                         max_step: float = DEFAULT_MAX_STEP) -> list[Failure]:
    """:func:`twist_failures` of gripper frames ``grippers`` and the torsion model's ``twist``
    (S + 2,) [rad] under them (None: the frames' own relative twist), without a document (the
    reach repair judges a frame set before it makes its document)."""
    twist = grippers.twist if twist is None else twist
    failures = []
    worst = int(np.argmax(np.abs(twist)))
    if abs(twist[worst]) > grippers.max_twist:
        failures.append(Failure("twist", None, (worst,), f"twist {np.degrees(twist[worst]):.1f} "
                                f"deg at shape {worst} (more than "
                                f"{np.degrees(grippers.max_twist):.0f})"))
    steps = frame_steps(grippers)
    for s in np.flatnonzero(steps > max_step):
        s = int(s)
        failures.append(Failure("twist", s, (s, s + 1), f"a clip frame turns "
                                f"{np.degrees(steps[s]):.0f} deg from shape {s} "
                                f"to {s + 1} (more than {np.degrees(max_step):.0f})"))
    return failures


def snap_failures(verification) -> list[Failure]:
    """Snap-through events of the continuation, and planned shapes that are not stable."""
    failures = []
    if verification.snap is not None:
        for event in verification.snap.events:
            s = event.segment
            failures.append(Failure("snap", s, (s, s + 1), event.message))
    for row in verification.rows:
        if not row.stable:
            k = row.index
            failures.append(Failure("snap", k - 1 if k > 0 else None, (k,),
                                    f"shape {k} is not a stable equilibrium (smallest "
                                    f"eigenvalue {row.smallest_eigenvalue:.3g} N/m)"))
    return failures


def replay_failures(verification) -> list[Failure]:
    """Knots where the replay at real speed strays beyond its tolerance, or no settling."""
    run = verification.replay
    if run is None or run.ok:
        return []
    far = [int(k) for k in np.flatnonzero(run.deviations > run.tolerance)]
    failures = [Failure("replay", k - 1 if k > 0 else None, (k,),
                        f"replay {1e3 * run.deviations[k]:.1f} mm from shape {k} (tolerance "
                        f"{1e3 * run.tolerance:.1f} mm)") for k in far]
    return failures or [Failure("replay", None, (), f"replay: {run.message}")]


def reach_failures(verification, doc=None) -> list[Failure]:
    """Planned poses an arm cannot reach, and every other failing check of the plan's robot
    program (joint limits, arm-arm clearance, continuity, ...)."""
    return program_failures(getattr(doc, "program", None)) + unreachable_shapes(
        (row.index, row.reachable_left, row.reachable_right) for row in verification.rows)


def program_failures(program) -> list[Failure]:
    """The failing checks of a robot program other than ``reach`` (None: no program), in the
    order of its rows: the first of :func:`reach_failures`."""
    if program is None:
        return []
    return [Failure("reach", None, (row.shape,), f"robot program, {row.label}, {row.arm} arm: "
                    f"{row.check} {row.value:.4g} {row.unit} {row.note}".rstrip())
            for row in program.failures if row.check != "reach"]


def unreachable_shapes(rows) -> list[Failure]:
    """The planned poses an arm cannot reach: ``rows`` (index, reachable by the left arm, by
    the right arm) per shape, as a verification's rows give them
    (:func:`dloplan.pipeline.stages.program_reachability`; None: not checked)."""
    failures = []
    for index, left, right in rows:
        arms = [a for a, ok in (("left", left), ("right", right)) if ok is False]
        if arms:
            failures.append(Failure("reach", None, (index,), f"shape {index}: not "
                                    f"reachable by the {' and '.join(arms)} arm"))
    return failures


def diagnose(doc, verification) -> list[Failure]:
    """Every failure of a verified plan, in the order of :data:`KINDS`.

    Parameters
    ----------
    doc : PlanDocument
        The plan (its gripper frames give the twist failures).
    verification : Verification
        :func:`dloplan.pipeline.stages.verify_plan` of ``doc``.
    """
    twist = twist_failures(doc) if doc.grippers is not None else []
    found = (snap_failures(verification) + twist + replay_failures(verification)
             + reach_failures(verification, doc))
    if not verification.ok and not any(f.kind != "twist" for f in found):
        found.append(Failure("other", None, (), "; ".join(verification.messages)))
    return found


def score(failures) -> tuple[int, ...]:
    """Failures counted per kind, in the order of :data:`KINDS` (compared lexicographically:
    a repair is kept when it lowers this, fixing a kind without adding failures of an earlier
    one)."""
    counts = Counter(f.kind for f in failures)
    return tuple(counts[kind] for kind in (*KINDS, "other"))


def summary(failures) -> str:
    """One line: the number of failures per kind, or "passes"."""
    counts = Counter(f.kind for f in failures)
    return ", ".join(f"{counts[k]} {k}" for k in (*KINDS, "other") if counts[k]) or "passes"
