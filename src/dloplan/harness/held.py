"""The held cable of a harness job, phase by phase: the model every check runs on (thesis 7.3).

What holds the cable changes during the job, and so does what is simulated:

=============  ==============================================  ==============================
phase          holders                                         the cable simulated
=============  ==============================================  ==============================
phase1/phase2  the two grippers, at the planned clip poses     the section between them
insertion      the grippers, lowered from the fixtures'        the section between them
               approach poses into the slots
regrasp        the fixtures (the grippers open and close       the section in the slots; the
               again outside them)                             stubs beyond hang free
tensioning     the fixtures, the grippers pulling cable        the section, shorter by twice
               through them                                    the offset at the end
=============  ==============================================  ==============================

**The section.** The part of the cable between the two holders' clip points (L - l long, the
grippers holding the middles of the end links) is simulated with ``section_links`` links,
finer than the planning's (:func:`dloplan.harness.section.section_cable`): contact acts on
mass points, and a planning link of 5 cm would pass through a 12 mm peg or hang across a
plate's edge (a soft cable held at the phase-2 poses sags onto the board). The parts beyond the
clip points are the held halves of the end links, as in the planning. So every phase is the same
section, held by the grippers or the fixtures, shorter while tensioned.

**A fixture holds like a gripper.** A slot keeps the cable's axis on its own axis at its
position: point and tangent, as a clip holds a link (:mod:`dloplan.sim.clips`). So a section
held by the fixtures is a cable held by two clips at the fixtures' poses
(:func:`dloplan.harness.phases.fixture_clips`), the model the insertion simulation uses
(:mod:`dloplan.harness.insertion`): in the slots the section is the same equilibrium whether
the grippers or the fixtures hold it, and tensioning shortens it (the cable slides through the
slots; the fixtures do not let it move otherwise).

**Pegs are one-sided contacts.** Every configuration is an equilibrium with the board's
contacts (pegs, plates, obstacles, the table) as the statics compute them
(:func:`dloplan.sim.statics.equilibrium`); a peg may press on the cable, or the cable may lift
off it.

**The configurations follow the job.** With contacts a held cable has several equilibria at
the same clip poses (resting on a plate or beside it, on one side of a peg or the other), and
which one the cable is in depends on how it got there. So the configurations are found as the
cable goes: the start settled at the first knot's clip poses, then each knot's configuration
reached from the one before by a quasi-static continuation
(:func:`dloplan.sim.statics.continuation`, sub-steps of at most :data:`FOLLOW_STEP` times the
section's length of clip motion), through phase 1, phase 2, the lowering into the slots and
the tensioning (over the offset, :func:`tension_path`). ``settle_distance`` is how far they
rest from the plan's shapes at the same knots (the planner's shapes are gravity-free or do not
know the board's contacts: a soft cable sags onto the board).

**The stubs.** While the grippers regrasp, the cable's ends beyond the fixtures are held by the
slots alone: cantilevers of length l/2 - l_s/2 (from the end of the fixture's held link to the
cable's end, the grippers having held the middle of the cable's end links at the slots),
loaded by their weight. :func:`stub_sag` solves each as a cable held at one end
(:func:`dloplan.sim.statics.equilibrium` with ``held="first"``): how far below the slot's axis
the fingers find the cable's end when they close again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..frames import frame_from_axis
from ..geometry import as_path
from ..sim.clips import ClipPoses
from ..sim.statics import equilibrium
from .board import Board
from .insertion import tension_state
from .phases import fixture_clips
from .section import FOLLOW_STEP, follow_path, section_cable, section_shape

CHECKED_PHASES: tuple[str, ...] = ("phase1", "phase2", "insertion", "regrasp", "tensioning")
"""The phases the checks report on, in order: the job's motion phases with the regrasp (a
gripper action in the slots) between insertion and tensioning."""

HOLDERS = {"phase1": "grippers", "phase2": "grippers", "insertion": "grippers",
           "regrasp": "fixtures", "tensioning": "fixtures"}
"""What holds the cable's simulated part in each phase."""


@dataclass(frozen=True, eq=False)
class HeldPath:
    """The configurations of one phase of the held cable.

    Attributes
    ----------
    phase : str
        One of :data:`CHECKED_PHASES`.
    holders : str
        What holds the cable (:data:`HOLDERS`).
    cables : tuple of Cable
        The simulated section of each configuration (at its tensioning offset); all with the
        same number of links.
    shapes : numpy.ndarray
        (m, n + 1, 3) the configurations, equilibria with the board's contacts [m].
    clips : tuple of ClipPoses
        The holders' poses of each configuration.
    labels : tuple of str
        What each configuration is (``"knot 3"``, ``"in the slots"``, ...).
    knots : tuple of int
        The job's knot of each configuration (the regrasp's is the knot in the slots).
    settle_distance : float
        Largest point distance between a configuration and the plan's [m]: the section on the
        planned shape (:func:`~dloplan.harness.section.section_shape`) in phases 1 and 2, the
        plan's section simulation in the slots and tensioned.
    substeps : tuple
        Per move between consecutive configurations, the quasi-static continuation's sub-step
        equilibria and messages that reached them (:attr:`~dloplan.harness.section.Followed.
        substeps`; the snap-through check takes them, ``check_snap_through(solved=)``), or
        empty where they were not kept (the tensioning, followed over its offset).
    """

    phase: str
    holders: str
    cables: tuple[Cable, ...]
    shapes: np.ndarray
    clips: tuple[ClipPoses, ...]
    labels: tuple[str, ...]
    knots: tuple[int, ...]
    settle_distance: float = 0.0
    substeps: tuple = ()

    @property
    def cable(self) -> Cable:
        """The cable of the first configuration."""
        return self.cables[0]


@dataclass(frozen=True, eq=False)
class StubSag:
    """A stub of cable beyond a fixture, hanging from the slot while the grippers regrasp.

    Attributes
    ----------
    fixture : str
        The fixture's name.
    length : float
        Free length from the end of the fixture's held link to the cable's end [m].
    sag : float
        Distance of the cable's end from the slot's axis line [m].
    shape : numpy.ndarray
        (k + 1, 3) the stub in equilibrium [m] (its first link the one the fixture holds).
    converged : bool
    """

    fixture: str
    length: float
    sag: float
    shape: np.ndarray
    converged: bool


@dataclass(frozen=True, eq=False)
class HeldModel:
    """The held cable of a whole harness job (module docstring).

    Attributes
    ----------
    cable : Cable
        The whole cable.
    board : Board
    paths : dict
        Phase name -> :class:`HeldPath`, in :data:`CHECKED_PHASES` order.
    stubs : tuple of StubSag
        The two stubs during the regrasp.
    offset : float
        The tensioning offset per arm [m].
    section_links : int
        Links of the section.
    gravity : numpy.ndarray
        Gravity [m/s^2].
    """

    cable: Cable
    board: Board
    paths: dict
    stubs: tuple[StubSag, ...]
    offset: float
    section_links: int
    gravity: np.ndarray

    @property
    def contacts(self) -> tuple:
        """The board's contact volumes: pegs, plates, obstacles, table."""
        return self.board.contacts()


def _distance(shapes: np.ndarray, planned: np.ndarray, cable: Cable, section: Cable) -> float:
    """Largest point distance between configurations and the section on the planned whole
    shapes held by the grippers."""
    on_plan = np.stack([section_shape(x, cable, section) for x in planned])
    return float(np.max(np.linalg.norm(shapes - on_plan, axis=-1)))


def tension_path(cable: Cable, section_links: int, offset: float, inserted, board: Board,
                 gravity=GRAVITY):
    """The section followed from the slots (offset 0) to ``offset`` [m] per arm, each
    equilibrium warm-started from the one before (the planning brackets the offset the same
    way), in steps that shorten the section by at most :data:`FOLLOW_STEP` of its length;
    returns the last :class:`TensionState`."""
    start = section_cable(cable, section_links, 0.0)
    count = max(1, math.ceil(2.0 * offset / (FOLLOW_STEP * start.length)))
    x = np.asarray(inserted, dtype=float)
    state = tension_state(cable, section_links, 0.0, x, board, gravity) if offset == 0 else None
    for d in np.linspace(0.0, offset, count + 1)[1:]:
        state = tension_state(cable, section_links, float(d), x, board, gravity)
        x = state.equilibrium.shape
    return state


def stub_sag(cable: Cable, section: Cable, fixture, gravity=GRAVITY) -> StubSag:
    """The stub beyond a fixture as a cable held by the slot only (module docstring).

    Parameters
    ----------
    cable : Cable
        The whole cable (its end link's length l sets where its end is).
    section : Cable
        The section in the slots (its end link, of length l_s, is the one the fixture holds).
    fixture : Fixture
        The fixture: the stub leaves its slot along minus its (inward) axis.
    gravity : array_like
        Gravity [m/s^2].
    """
    held = section.rest_link_length
    free = 0.5 * (cable.rest_link_length - held)
    position = np.asarray(fixture.position)
    outward = -np.asarray(fixture.axis)
    if free <= 0:
        ends = np.stack([position - 0.5 * held * outward, position + 0.5 * held * outward])
        return StubSag(fixture.name, 0.0, 0.0, ends, True)
    # k links: the first, no longer than the section's, held by the slot with its outer end at
    # the held link's outer end; the other k - 1 links the free length
    n_links = max(4, 1 + math.ceil(free / held))
    length = free * n_links / (n_links - 1)
    stub = replace(cable, length=length, mass=cable.mass * length / cable.length,
                   n_links=n_links, rest_shape=None)
    middle = position + 0.5 * (held - stub.rest_link_length) * outward
    rotations = Rotation.concatenate([frame_from_axis(outward), frame_from_axis(-outward)])
    clips = ClipPoses(np.stack([middle, middle + free * outward]), rotations)
    guess = middle - 0.5 * stub.rest_link_length * outward + np.outer(
        np.linspace(0.0, length, stub.n_points), outward)
    eq = equilibrium(stub, guess, clips, gravity=gravity, held="first")
    tip = eq.shape[-1] - position
    sag = float(np.linalg.norm(tip - (tip @ outward) * outward))
    return StubSag(fixture.name, float(free), sag, eq.shape, bool(eq.converged))


def held_model(
    cable: Cable,
    board: Board,
    shapes,
    clips,
    knots: dict,
    offset: float,
    section_links: int,
    sections,
    *,
    gravity=GRAVITY,
) -> HeldModel:
    """The held cable of a planned harness job (module docstring).

    Parameters
    ----------
    cable : Cable
        The whole cable.
    board : Board
        The board.
    shapes : array_like
        (K, n + 1, 3) the whole cable at every knot of the job [m]
        (:attr:`~dloplan.harness.HarnessResult.shapes`).
    clips : sequence of ClipPoses
        The grippers' clip poses at every knot.
    knots : dict
        Phase name -> (first, last) knot, for "phase1", "phase2", "insertion", "tensioning".
    offset : float
        The planned tensioning offset per arm [m].
    section_links : int
        Links of the section (as planned).
    sections : array_like
        (3, section_links + 1, 3) the plan's section at the approach poses, in the slots and
        tensioned [m] (:class:`~dloplan.harness.insertion.Insertion`): what the insertion,
        regrasp and tensioning configurations are compared with (``settle_distance``).

    The configurations are followed through the job (module docstring); ``offset`` and
    ``section_links`` are the plan's.
    gravity : array_like
        Gravity [m/s^2].

    Raises
    ------
    ValueError
        For a knot table without the job's phases, clip poses not one per knot, or an offset
        that is not a length >= 0.
    """
    path = as_path(shapes, cable.n_points, "shapes")
    poses = list(clips)
    if len(poses) != len(path):
        raise ValueError(f"clips: {len(poses)} clip poses for {len(path)} knots, expected one "
                         "per knot")
    missing = [p for p in ("phase1", "phase2", "insertion", "tensioning") if p not in knots]
    if missing:
        raise ValueError(f"knots: no {', '.join(missing)}, expected the harness job's phases")
    if not (math.isfinite(offset) and offset >= 0):
        raise ValueError(f"offset: got {offset!r}, expected the tensioning offset >= 0 [m]")
    g = np.asarray(gravity, dtype=float)
    contacts = board.contacts()
    section = section_cable(cable, section_links, 0.0)
    paths = {}
    x = section_shape(path[0], cable, section)
    for phase in ("phase1", "phase2"):
        first, last = knots[phase]
        index = tuple(range(first, last + 1))
        run = follow_path(section, x, poses[first:last + 1], contacts, g)
        paths[phase] = HeldPath(phase, HOLDERS[phase], (section,) * len(index), run.shapes,
                                tuple(poses[first:last + 1]),
                                tuple(f"knot {k}" for k in index), index,
                                _distance(run.shapes, path[first:last + 1], cable, section),
                                run.substeps)
        x = run.shapes[-1]
    planned = as_path(sections, section_links + 1, "sections")
    if len(planned) != 3:
        raise ValueError(f"sections: got {len(planned)} shapes, expected 3 (approach, in the "
                         "slots, tensioned)")
    k2, in_slots = knots["insertion"]
    approach, slots = fixture_clips(board), fixture_clips(board, inserted=True)
    lowering = follow_path(section, x, [approach, slots], contacts, g)
    lowered = lowering.shapes
    inserted = lowered[-1]

    def distance(shapes, plan) -> float:
        return float(np.max(np.linalg.norm(shapes - plan, axis=-1)))

    paths["insertion"] = HeldPath(
        "insertion", HOLDERS["insertion"], (section, section), lowered, (approach, slots),
        ("at the approach poses", "in the slots"), (k2, in_slots),
        distance(lowered, planned[:2]), lowering.substeps)
    paths["regrasp"] = HeldPath("regrasp", HOLDERS["regrasp"], (section,), inserted[None],
                                (slots,), ("in the slots, held by the fixtures",), (in_slots,),
                                distance(inserted, planned[1]))
    tensioned = tension_path(cable, section_links, offset, inserted, board, g)
    pulled = np.stack([inserted, tensioned.equilibrium.shape])
    paths["tensioning"] = HeldPath(
        "tensioning", HOLDERS["tensioning"], (section, tensioned.section), pulled,
        (slots, slots), ("offset 0 mm", f"offset {1e3 * offset:.2f} mm"), knots["tensioning"],
        distance(pulled, planned[1:]))
    stubs = tuple(stub_sag(cable, section, fixture, g) for fixture in board.fixtures)
    return HeldModel(cable, board, paths, stubs, float(offset), int(section_links), g)


__all__ = ["CHECKED_PHASES", "HOLDERS", "HeldModel", "HeldPath", "StubSag", "held_model",
           "stub_sag", "tension_path"]
