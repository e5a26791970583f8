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
from functools import cached_property

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


@dataclass(frozen=True, eq=False)
class BoardContacts:
    """The obstacles' penalty at every point of M shapes, evaluated once.

    The stability test of a shape needs each obstacle's signed distance phi, normal and
    curvature at its points four times (the penalty's gradient and exact Hessian blocks, the
    contact states, the sliding test, the pressing points); the snap-through continuation
    judges hundreds of shapes against the same obstacles. Here each obstacle's
    ``signed_distance`` and ``distance_hessian`` run once on all points of all shapes.

    Attributes
    ----------
    names : tuple of str
        (K,) the obstacles' names.
    depths : numpy.ndarray
        (K, M, n + 1) r - phi per obstacle and point [m] (> 0: the point presses).
    normals : numpy.ndarray
        (K, M, n + 1, 3) outward unit normals.
    stiffness : numpy.ndarray
        (M,) the penalty stiffness k_c of each shape's cable [N/m].
    gradient : numpy.ndarray
        (M, n + 1, 3) the penalty's gradient, -k_c d n summed over the pressing points' obstacles
        [N] (:func:`dloplan.physics.contact.contact_gradient`).
    blocks : numpy.ndarray
        (M, n + 1, 3, 3) its exact Hessian blocks k_c (n n^T - d grad^2 phi) [N/m]
        (:func:`dloplan.physics.contact.contact_hessian_blocks`).
    """

    names: tuple[str, ...]
    depths: np.ndarray
    normals: np.ndarray
    stiffness: np.ndarray
    gradient: np.ndarray
    blocks: np.ndarray

    @classmethod
    def at(cls, shapes, contacts, radius: float, stiffness) -> BoardContacts:
        """The penalty of ``contacts`` (obstacles with ``signed_distance``,
        ``distance_hessian`` and ``name``) at shapes (M, n + 1, 3) [m] of a cable of radius
        ``radius`` [m], with penalty stiffness ``stiffness`` [N/m] (a number, or one per shape)."""
        x = np.asarray(shapes, dtype=float)
        k_c = np.broadcast_to(np.asarray(stiffness, dtype=float), x.shape[:1])
        gradient = np.zeros(x.shape)
        blocks = np.zeros(x.shape + (3,))
        depths, normals = [], []
        for obstacle in contacts:
            phi, normal = obstacle.signed_distance(x)
            depth = radius - phi
            gradient -= k_c[:, None, None] * np.maximum(depth, 0.0)[..., None] * normal
            pressing = depth > 0  # the blocks of the pressing points alone: the others are 0
            if pressing.any():
                n, d = normal[pressing], depth[pressing][:, None, None]
                blocks[pressing] += np.broadcast_to(k_c[:, None], pressing.shape)[pressing][
                    :, None, None] * (n[:, :, None] * n[:, None, :]
                                      - d * obstacle.distance_hessian(x[pressing]))
            depths.append(depth)
            normals.append(normal)
        names = tuple(str(getattr(c, "name", type(c).__name__)) for c in contacts)
        shape = (0,) + x.shape[:2]
        return cls(names, np.stack(depths) if depths else np.zeros(shape),
                   np.stack(normals) if normals else np.zeros(shape + (3,)),
                   np.array(k_c), gradient, blocks)

    def pressing(self, b: int) -> np.ndarray:
        """(n + 1,) bool: the points of shape b that press on an obstacle."""
        return np.any(self.depths[:, b] > 0, axis=0)

    @cached_property
    def _summary(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per obstacle and shape (K, M): pressing, the penalty's force (K, M, 3) [N], the
        pressing points and the smallest gap [m], for every shape at once."""
        pressing = self.depths > 0
        force = self.stiffness[None, :, None] * np.sum(
            np.where(pressing, self.depths, 0.0)[..., None] * self.normals, axis=2)
        return (pressing.any(axis=2), force, pressing.sum(axis=2),
                np.min(-self.depths, axis=2))

    def states(self, b: int) -> tuple[ContactState, ...]:
        """Each obstacle's contact with shape b (module docstring), in the given order."""
        active, force, count, gap = self._summary
        return tuple(ContactState(name, bool(active[k, b]), float(np.linalg.norm(force[k, b])),
                                  int(count[k, b]), float(gap[k, b]))
                     for k, name in enumerate(self.names))

    def sliding(self, b: int, states, mode, share: float = 0.5) -> tuple[ContactState, ...]:
        """``states`` of shape b with ``slides`` set where ``mode`` (n + 1, 3), a stability
        mode (point displacements), moves the pressing points along the surface: the tangential
        displacement of one of them is at least ``share`` of the mode's largest point
        displacement."""
        largest = float(np.max(np.linalg.norm(mode, axis=1)))
        out = []
        for state, depth, normal in zip(states, self.depths[:, b], self.normals[:, b],
                                        strict=True):
            if not state.active or largest == 0.0:
                out.append(state)
                continue
            along = mode - np.sum(mode * normal, axis=1)[:, None] * normal
            slip = float(np.max(np.linalg.norm(along[depth > 0], axis=1)))
            out.append(replace(state, slides=slip >= share * largest))
        return tuple(out)


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
    k_c = contact_stiffness(cable) if stiffness is None else float(stiffness)
    return BoardContacts.at(x[None], contacts, cable.diameter / 2, k_c).states(0)


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


__all__ = ["BoardContacts", "ContactState", "contact_changes", "contact_states",
           "contact_stiffness"]
