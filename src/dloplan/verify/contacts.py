"""One-sided contacts of a held cable: which obstacle touches it, how hard, how far clear.

The statics treat pegs, plates, the table and other obstacles as one-sided contacts of the mass
points by a stiff penalty (:mod:`dloplan.physics.contact`): a point of the cable (radius r)
presses on an obstacle when its signed distance phi to the surface is below r, with the force
k_c (r - phi) along the outward normal. A contact is **active** when a point presses; else it
is **inactive**, the cable clear of the obstacle by the smallest gap phi - r. The model is
frictionless, so an active contact holds the cable only along its normals: the cable may slide
along the surface (a wrap around a peg) and lift off it. :func:`contact_states` reports each
obstacle's state; :func:`contact_changes` compares two states of the same obstacles (a lift-off
or a touch-down).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..cable import Cable
from ..geometry import as_shape
from ..physics.chain import SpringChain


@dataclass(frozen=True)
class ContactState:
    """The contact of one obstacle with a cable's shape.

    Attributes
    ----------
    name : str
        The obstacle's name.
    active : bool
        At least one point presses on it.
    force : float
        Norm of the net force the obstacle exerts on the cable [N] (0 when inactive).
    points : int
        Number of points pressing on it.
    gap : float
        Smallest clearance between the cable's surface and the obstacle at a point [m]
        (negative: the penalty's penetration, F / k_c at a pressing point).
    slides : bool
        Active, and the lowest stability mode moves the pressing points along the surface
        (the frictionless contact does not resist it); set by the stability check.
    """

    name: str
    active: bool
    force: float
    points: int
    gap: float
    slides: bool = False

    def describe(self) -> str:
        """One phrase: ``"peg: 0.2 N on 3 points"`` or ``"peg: clear by 4.2 mm"``."""
        if not self.active:
            return f"{self.name}: clear by {1e3 * self.gap:.1f} mm"
        sliding = ", the softest mode slides along it" if self.slides else ""
        return f"{self.name}: {self.force:.3g} N on {self.points} point(s){sliding}"


def contact_stiffness(cable: Cable) -> float:
    """The penalty stiffness k_c the statics use for ``cable`` [N/m]
    (:meth:`~dloplan.physics.chain.SpringChain.from_cable`)."""
    return SpringChain.from_cable(cable).contact_stiffness


def contact_states(cable: Cable, shape, contacts, *, stiffness: float | None = None,
                   ) -> tuple[ContactState, ...]:
    """Each obstacle's contact with a shape (module docstring).

    Parameters
    ----------
    cable : Cable
        The cable (its radius meets the obstacles).
    shape : array_like
        (n + 1, 3) shape [m].
    contacts : sequence
        Obstacles with ``signed_distance`` and ``name`` (:mod:`dloplan.obstacles`).
    stiffness : float, optional
        Penalty stiffness k_c [N/m]; default the statics' (:func:`contact_stiffness`).

    Returns
    -------
    tuple of ContactState
        One per obstacle, in the given order.
    """
    x = as_shape(shape, cable.n_points, "shape")
    radius = cable.diameter / 2
    k_c = contact_stiffness(cable) if stiffness is None else float(stiffness)
    states = []
    for obstacle in contacts:
        phi, normal = obstacle.signed_distance(x)
        depth = radius - phi
        pressing = depth > 0
        force = k_c * np.sum(np.where(pressing, depth, 0.0)[:, None] * normal, axis=0)
        states.append(ContactState(str(getattr(obstacle, "name", type(obstacle).__name__)),
                                   bool(pressing.any()), float(np.linalg.norm(force)),
                                   int(pressing.sum()), float(np.min(-depth))))
    return tuple(states)


def sliding_states(states, shape, mode, contacts, radius: float,
                   share: float = 0.5) -> tuple[ContactState, ...]:
    """The states with ``slides`` set where a mode moves the pressing points along the surface.

    Parameters
    ----------
    states : sequence of ContactState
        The states of ``contacts`` at ``shape``.
    shape : numpy.ndarray
        (n + 1, 3) shape [m].
    mode : numpy.ndarray
        (n + 1, 3) a stability mode (point displacements, unit norm).
    contacts : sequence
        The obstacles of ``states``.
    radius : float
        The cable's radius [m].
    share : float
        A contact slides when the tangential displacement of one of its pressing points is at
        least this share of the mode's largest point displacement.
    """
    largest = float(np.max(np.linalg.norm(mode, axis=1)))
    out = []
    for state, obstacle in zip(states, contacts, strict=True):
        if not state.active or largest == 0.0:
            out.append(state)
            continue
        phi, normal = obstacle.signed_distance(shape)
        pressing = radius - phi > 0
        along = mode - np.sum(mode * normal, axis=1)[:, None] * normal
        slip = float(np.max(np.linalg.norm(along[pressing], axis=1)))
        out.append(replace(state, slides=slip >= share * largest))
    return tuple(out)


def contact_changes(before, after) -> list[tuple[str, str]]:
    """(name, ``"lift-off"`` or ``"touch-down"``) for each obstacle whose contact opened or
    closed between two state tuples of the same obstacles."""
    changes = []
    for a, b in zip(before, after, strict=True):
        if a.active and not b.active:
            changes.append((a.name, "lift-off"))
        elif b.active and not a.active:
            changes.append((a.name, "touch-down"))
    return changes


__all__ = ["ContactState", "contact_changes", "contact_states", "contact_stiffness",
           "sliding_states"]
