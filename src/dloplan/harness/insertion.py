"""Insertion into the fixtures and tensioning against the pegs (thesis 7.3, Figs. 7.33/7.44).

**The cable section.** Once the cable is in the slots, the fixtures hold it: a slot keeps the
cable on its axis and lets it slide along it. What the tensioning changes is how much cable
lies between the two fixtures: the grippers, holding the cable outside the slots, pull it
through them. So the simulated object is the **section between the fixtures**, a cable of the
same material held by two clips at the fixtures (u-axes along the fixture axes) whose length
between the clip points is ``L - l - 2 d`` for a pull-apart offset ``d`` per arm (``L - l`` is
the cable between the grippers' clip points, which grip the middle of the end links). The
section is discretized with its own, finer ``n_links`` so that a peg thinner than a planning
link is still met by mass points (contact acts on points only, :mod:`dloplan.physics.contact`).
The gripper (TCP) positions follow: the approach points, the slots, then the slots minus
``d`` along each fixture axis.

**Insertion** is :func:`dloplan.sim.statics.continuation` with gravity and the board's contacts
(pegs, plates, obstacles, table), from the phase-2 shape settled at the approach poses down to
the slots in ``substeps`` equilibria: the cable comes to rest on the plates.

**Tensioning**: the smallest offset ``d`` at which the pegs push on the cable with the force
``contact_force`` (the norm of the net contact force of each peg's cylinder, summed over the
pegs) **and** every inner link of the section (all but the two held end links) carries at
least ``min_tension`` > 0, found by simulation: ``d`` grows in steps from 0, each equilibrium
warm-started from the previous one, until both hold (a bracket), then Brent's method on the
smaller of the two relative excesses within the bracket, each evaluation started from the
bracket's lower shape. It fails, with a message giving the forces, when the largest link
tension exceeds ``max_axial_force`` first (already in the slots, at ``d = 0``, where the
fixtures stretch the section over the pegs), or the offset would exceed ``max_offset``.

**Mechanism.** A peg can push on the cable for two reasons: the cable is pulled taut around it
(tension), or a stiff cable, bent between the fixtures, presses on it while its section is
in compression (bending). The second is what a stiff hose gives at small offsets (the PU hose
of the examples: 0.2 N on the peg while every link is compressed by 0.35-0.75 N); it is not a
tensioned harness, so the search asks for tension along the whole section too, and the result
names the mechanism (:attr:`TensionState.mechanism`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from ..cable import GRAVITY, Cable
from ..geometry import as_shape, resample_by_arc_length
from ..obstacles import check_shape
from ..physics.chain import SpringChain, link_tensions
from ..physics.contact import contact_gradient
from ..sim.clips import clip_poses_from_shape
from ..sim.statics import Equilibrium, continuation, equilibrium
from .board import Board, check_board
from .phases import fixture_clips
from .section import section_cable, section_shape

GROW_STEPS = 16
"""The offset grows by ``max_offset / GROW_STEPS`` per step while bracketing."""


def peg_forces(section: Cable, shape: np.ndarray, board: Board, gravity=GRAVITY) -> np.ndarray:
    """(n_pegs,) norm of the net force each peg's cylinder exerts on the cable [N]."""
    stiffness = SpringChain.from_cable(section, gravity, board.contacts()).contact_stiffness
    return np.array([
        float(np.linalg.norm(-contact_gradient(shape, [peg.cylinder()], section.diameter / 2,
                                               stiffness).sum(axis=0)))
        for peg in board.pegs
    ])


@dataclass(frozen=True, eq=False)
class TensionState:
    """The section in equilibrium at one pull-apart offset.

    Attributes
    ----------
    offset : float
        Pull-apart offset per arm [m].
    section : Cable
        The section cable at that offset.
    equilibrium : Equilibrium
        Its equilibrium held at the fixtures, with gravity and the board's contacts.
    peg_forces : numpy.ndarray
        (n_pegs,) force of each peg on the cable [N].
    max_tension : float
        Largest link tension [N] (compression negative).
    min_tension : float
        Smallest tension of the inner links [N] (all but the two held end links, whose both
        points the clips place): > 0 when the whole section is taut.
    pull_forces : numpy.ndarray
        (2,) force the cable exerts on each fixture-held end along the fixture's axis, inward
        [N]: what the grippers hold against while tensioning.
    """

    offset: float
    section: Cable
    equilibrium: Equilibrium
    peg_forces: np.ndarray
    max_tension: float
    pull_forces: np.ndarray
    min_tension: float

    @property
    def mechanism(self) -> str:
        """What produces the peg force: ``"tension"`` (every inner link taut) or ``"bending"``."""
        return "tension" if self.min_tension > 0 else "bending"

    def describe(self) -> str:
        """One line with the forces and the mechanism."""
        how = ("the section is taut, smallest inner link tension "
               f"{self.min_tension:.3g} N" if self.mechanism == "tension" else
               "by bending, the section is in compression (largest link tension "
               f"{self.max_tension:.3g} N)")
        pulls = "/".join(f"{f:.3g}" for f in self.pull_forces)
        return (f"pegs push with {self.contact_force:.3g} N at offset {1e3 * self.offset:.2f} mm "
                f"per arm, {how}; fixture pulls {pulls} N")

    @property
    def contact_force(self) -> float:
        """Sum over the pegs of their force on the cable [N]."""
        return float(self.peg_forces.sum())

    @property
    def holding_forces(self) -> np.ndarray:
        """(2,) norm of the force the cable exerts on each fixture-held end [N]."""
        return np.linalg.norm(self.equilibrium.clip_wrenches[:, :3], axis=1)


def tension_state(cable: Cable, n_links: int, offset: float, guess, board: Board,
                  gravity=GRAVITY) -> TensionState:
    """The section between the fixtures in equilibrium at a pull-apart ``offset`` [m].

    Held at the fixtures' slots, with gravity and the board's contacts, started from ``guess``
    (any (k, 3) polyline between the slots, resampled; it selects the branch).
    """
    clips = fixture_clips(board, inserted=True)
    section = section_cable(cable, n_links, offset)
    eq = equilibrium(section, resample_by_arc_length(guess, section.n_points), clips,
                     gravity=gravity, contacts=board.contacts())
    chain = SpringChain.from_cable(section, gravity)
    pull = np.einsum("kj,kj->k", eq.clip_wrenches[:, :3], clips.u_axes)
    tensions = link_tensions(chain, eq.shape)
    return TensionState(float(offset), section, eq, peg_forces(section, eq.shape, board, gravity),
                        float(tensions.max()), pull, float(tensions[1:-1].min()))


def lower_into_slots(cable: Cable, shape, board: Board, n_links: int, substeps: int = 8,
                     gravity=GRAVITY, section=None) -> list[Equilibrium]:
    """The insertion: the section settled at the fixtures' approach poses, then lowered into
    the slots in ``substeps`` equilibria (module docstring).

    Parameters
    ----------
    cable : Cable
        The whole cable.
    shape : array_like
        (n + 1, 3) the whole cable at the insertion pose (the end of phase 2) [m].
    board : Board
        The board; its contacts act throughout.
    n_links : int
        Links of the section.
    substeps : int
        Equilibria solved on the way down.
    gravity : array_like
        Gravity [m/s^2].
    section : array_like, optional
        (n_links + 1, 3) the section at the approach poses as followed through phase 2 [m]
        (a settled phase 2, :func:`dloplan.harness.phases.settled_phase2`); default the
        section on ``shape``.

    Returns
    -------
    list of Equilibrium
        The section at the approach poses and in the slots.
    """
    cut = section_cable(cable, n_links, 0.0)
    start = section_shape(shape, cable, cut) if section is None else as_shape(
        section, cut.n_points, "section")
    return continuation(cut, start,
                        [fixture_clips(board), fixture_clips(board, inserted=True)],
                        substeps=substeps, gravity=gravity, contacts=board.contacts())


@dataclass(frozen=True, eq=False)
class Insertion:
    """Result of :func:`insert_and_tension`.

    Attributes
    ----------
    inserted : Equilibrium
        The section in the slots before tensioning (offset 0).
    lowering : list of Equilibrium
        The section at the approach poses and at the slots (the continuation's two stops).
    tensioned : TensionState
        The state at the found offset (or the last one tried, on failure).
    offset : float
        The pull-apart offset per arm [m] (nan on failure).
    gripper_moves : numpy.ndarray
        (2, 2, 3) translation of both clips [m]: the insertion (down into the slots) and the
        tensioning (apart along the fixture axes), in that order.
    penetration : float
        Deepest penetration of a mass point into any contact volume [m], tensioned state.
    peg_penetration : numpy.ndarray
        (n_pegs,) deepest penetration of a mass point into each peg [m] (<= 0: clear by that
        much), tensioned state.
    link_penetration : float
        Deepest penetration of a link (a capsule of the cable's radius) into any contact
        volume [m], tensioned state: a link can cut a peg's corner that its points clear.
    evaluations : int
        Equilibria solved by the search.
    success : bool
        The force was reached within the offset and tension limits, every solve converged.
    message : str
        One line.
    """

    inserted: Equilibrium
    lowering: list
    tensioned: TensionState
    offset: float
    gripper_moves: np.ndarray
    penetration: float
    peg_penetration: np.ndarray
    link_penetration: float
    evaluations: int
    success: bool
    message: str


def insert_and_tension(
    cable: Cable,
    shape,
    board: Board,
    *,
    contact_force: float = 0.2,
    min_tension: float = 0.01,
    max_axial_force: float = 5.0,
    max_offset: float = 0.05,
    n_links: int = 40,
    substeps: int = 8,
    gravity=GRAVITY,
    xtol: float = 1e-6,
    section=None,
) -> Insertion:
    """Insert the cable into the fixtures and find the tensioning offset (module docstring).

    Parameters
    ----------
    cable : Cable
        The whole cable.
    shape : array_like
        (n + 1, 3) the cable at the insertion pose (the end of phase 2) [m]: its clips at the
        fixtures' approach points, u-axes along the fixture axes.
    board : Board
        The board; its pegs, plates, obstacles and table are the contacts.
    contact_force : float
        Force the pegs should exert on the tensioned cable [N] (> 0).
    min_tension : float
        Tension every inner link of the section should carry [N] (> 0).
    max_axial_force : float
        Largest link tension allowed [N].
    max_offset : float
        Largest pull-apart offset per arm [m].
    n_links : int
        Links of the simulated section (finer than the planning's: see the module docstring).
    substeps : int
        Equilibria solved while lowering the cable into the slots.
    gravity : array_like
        Gravity [m/s^2].
    xtol : float
        Offset tolerance of the root search [m].
    section : array_like, optional
        (n_links + 1, 3) the section at the approach poses as followed through a settled phase
        2 [m] (:func:`lower_into_slots`).

    Raises
    ------
    ValueError
        For a board the cable cannot use, a shape whose clips are not at the approach poses
        (more than 1 mm or 1 degree off), or bad limits.
    """
    check_board(board, cable)
    x = as_shape(shape, cable.n_points, "shape")
    for name, value in (("contact_force", contact_force), ("min_tension", min_tension),
                        ("max_axial_force", max_axial_force),
                        ("max_offset", max_offset), ("xtol", xtol)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}: got {value!r}, expected a finite number > 0")
    if not board.pegs:
        raise ValueError("board: no pegs, nothing to tension the cable against")
    approach = fixture_clips(board)
    clips = clip_poses_from_shape(x)
    angles = np.degrees(np.arccos(np.clip(
        np.einsum("kj,kj->k", clips.u_axes, approach.u_axes), -1.0, 1.0)))
    gap = np.linalg.norm(clips.positions - approach.positions, axis=1)
    if np.any(gap > 1e-3) or np.any(angles > 1.0):
        raise ValueError(
            f"shape: its clips are {1e3 * gap.max():.2f} mm and {angles.max():.2f} degrees from "
            "the fixtures' approach poses, expected the end of phase 2 (within 1 mm, 1 degree)"
        )
    slots = fixture_clips(board, inserted=True)
    lowering = lower_into_slots(cable, x, board, n_links, substeps, gravity, section)
    inserted = lowering[-1]
    axes = slots.u_axes
    down = slots.positions - approach.positions

    def state(offset: float, guess: np.ndarray) -> TensionState:
        return tension_state(cable, n_links, offset, guess, board, gravity)

    def excess(st: TensionState) -> float:
        """< 0 until the pegs push hard enough and the section is taut."""
        return min(st.contact_force / contact_force, st.min_tension / min_tension) - 1.0

    evaluations = 0
    low = state(0.0, inserted.shape)
    evaluations += 1
    high = low
    step = max_offset / GROW_STEPS
    problem = ""
    while excess(high) < 0:
        if high.max_tension > max_axial_force:
            problem = (f"the link tension reaches {high.max_tension:.3g} N (limit "
                       f"{max_axial_force:g} N) before the pegs push with {contact_force:g} N "
                       f"on a taut section: {high.describe()}")
            break
        if high.offset >= max_offset:
            problem = (f"at the largest offset {1e3 * max_offset:.1f} mm the {high.describe()}; "
                       f"wanted {contact_force:g} N on the pegs and every link taut to "
                       f"{min_tension:g} N")
            break
        low = high
        high = state(min(low.offset + step, max_offset), low.equilibrium.shape)
        evaluations += 1
    found = high
    if not problem and high.offset > 0 and low is not high:
        cache: dict[float, TensionState] = {}

        def excess_at(d: float) -> float:
            cache[d] = state(d, low.equilibrium.shape)
            return excess(cache[d])

        root = brentq(excess_at, low.offset, high.offset, xtol=xtol)
        evaluations += len(cache)
        found = cache.get(root) or state(root, low.equilibrium.shape)
        if excess(found) < 0:  # brentq's root sits within xtol below
            found = state(min(root + xtol, high.offset), low.equilibrium.shape)
            evaluations += 1
    if not problem and found.max_tension > max_axial_force:
        where = (f"where the pegs push with {contact_force:g} N on a taut section"
                 if found.offset > 0 else
                 f"with the cable laid in the slots, before any pull: {found.describe()}; "
                 "expected a section that reaches the slots within the limit (fixtures closer "
                 "together, or a longer cable)")
        problem = (f"the link tension reaches {found.max_tension:.3g} N (limit "
                   f"{max_axial_force:g} N) {where}")
    solves = [*lowering, found.equilibrium]
    unconverged = [eq.message for eq in solves if not eq.converged]
    if unconverged and not problem:
        problem = f"an equilibrium did not converge: {unconverged[0]}"
    link_depth = check_shape(found.equilibrium.shape, board.contacts(),
                             found.section.diameter / 2).penetration
    radius = found.section.diameter / 2
    per_peg = np.array([float(np.max(radius - peg.cylinder().signed_distance(
        found.equilibrium.shape)[0])) for peg in board.pegs])
    moves = np.stack([down, -found.offset * axes])
    success = not problem
    message = found.describe() if success else problem
    return Insertion(inserted, lowering, found, found.offset if success else math.nan, moves,
                     float(found.equilibrium.penetration), per_peg, float(max(link_depth, 0.0)),
                     evaluations, success, message)
