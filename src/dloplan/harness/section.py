"""The cable between the two holders of a harness job, finer than the planning's (thesis 7.3).

Contact acts on mass points (:mod:`dloplan.physics.contact`): a planning link of 5 cm would pass
through a 12 mm peg or hang across a plate's edge. So what rests on the board is simulated as
the **section**: the part of the cable between the holders' clip points, ``L - l - 2 d`` long
for a pull-apart offset ``d`` per arm (the grippers hold the middles of the end links), with
its own, finer links (:func:`section_cable`). :func:`section_shape` puts it on a planned shape
of the whole cable, :func:`whole_shape` brings a section back to the planning's links, and
:func:`follow_path` finds the section's equilibria as its holders move, each reached from the one
before (with contacts a held cable has several equilibria at the same clip poses, and which
one it is in depends on how it got there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..cable import Cable
from ..geometry import arc_length, as_shape, resample_by_arc_length
from ..physics.chain import SpringChain
from ..sim.clips import ClipPoses, clip_poses_from_shape
from ..sim.contact_path import contact_substeps
from ..sim.statics import equilibrium
from ..verify.snap import clip_motion

FOLLOW_STEP = 0.005
"""Largest clip motion (and change of the held length) of one sub-step when the section's
equilibria are followed, as a fraction of the section's length: the snap-through
continuation's default (:func:`dloplan.verify.snap.check_snap_through`), so that it follows
the same path."""


def section_cable(cable: Cable, n_links: int, offset: float = 0.0) -> Cable:
    """The cable between the fixtures after pulling ``offset`` [m] through each one.

    Same material and diameter, mass in proportion to the length, ``n_links`` links; its clip
    points (middles of its end links) are ``L - l - 2 offset`` apart along it.
    """
    if isinstance(n_links, bool) or int(n_links) != n_links or n_links < 4:
        raise ValueError(f"n_links: got {n_links!r}, expected an integer >= 4")
    between = cable.length - cable.rest_link_length - 2.0 * offset
    if not (math.isfinite(offset) and offset >= 0 and between > 0):
        largest = (cable.length - cable.rest_link_length) / 2
        raise ValueError(f"offset: got {offset!r}, expected 0 <= offset < {largest:.4g} m")
    length = between * n_links / (n_links - 1)
    return replace(cable, length=length, mass=cable.mass * length / cable.length,
                   n_links=int(n_links), rest_shape=None)


def section_shape(shape, cable: Cable, section: Cable) -> np.ndarray:
    """The section's points (n_s + 1, 3) [m] on a planned shape of the whole cable.

    The part of the shape between its clip points, extended by half a section link along
    each clip's axis, resampled by arc length: the section's clips then sit at the shape's.
    """
    x = as_shape(shape, cable.n_points, "shape")
    clips = clip_poses_from_shape(x)
    half = 0.5 * section.rest_link_length * clips.u_axes
    polyline = np.vstack([clips.positions[0] - half[0], x[1:-1], clips.positions[1] - half[1]])
    polyline[1] = clips.positions[0] + 0.5 * cable.rest_link_length * clips.u_axes[0]
    polyline[-2] = clips.positions[1] + 0.5 * cable.rest_link_length * clips.u_axes[1]
    return resample_by_arc_length(polyline, section.n_points)


def whole_shape(cable: Cable, section: np.ndarray, clips: ClipPoses) -> np.ndarray:
    """The whole cable (n + 1, 3) [m] on the planning's links from a section (n_s + 1, 3) held
    at ``clips``: the end links exactly on the clips (their middles at the clip points, along
    the u-axes, which point into the cable: the shape's clip poses are ``clips``'), the n - 2
    inner links resampled by arc length from the section between the inner ends of the end
    links."""
    x = np.asarray(section, dtype=float)
    half = 0.5 * cable.rest_link_length * clips.u_axes
    ends = clips.positions + half  # both u-axes point into the cable
    s = arc_length(x)
    # the section's clip points are half a section link from its ends; the inner ends of the
    # whole cable's end links are half a planning link further in
    inner = 0.5 * (s[1] - s[0]) + 0.5 * cable.rest_link_length
    cut = np.linspace(inner, s[-1] - 0.5 * (s[-1] - s[-2]) - 0.5 * cable.rest_link_length,
                      cable.n_links - 1)
    middle = np.stack([np.interp(cut, s, x[:, j]) for j in range(3)], axis=1)
    middle[0], middle[-1] = ends
    return np.vstack([clips.positions[0] - half[0], middle, clips.positions[1] - half[1]])


@dataclass(frozen=True, eq=False)
class Followed:
    """The section followed through clip poses (:func:`follow_path`).

    Attributes
    ----------
    shapes : numpy.ndarray
        (m, n_s + 1, 3) the equilibria at the m clip poses [m].
    substeps : tuple
        Per move from pose k to pose k + 1, ``(shapes, messages)``: the equilibria
        (s_k + 1, n_s + 1, 3) [m] at the sub-step fractions
        :func:`~dloplan.verify.snap.substep_fractions` (s_k), the first the equilibrium at pose
        k solved again from the configuration there, and the solver's message of each (the
        first ""): the continuation the snap-through check follows between the same poses
        (``check_snap_through(solved=)``) when that first shape is the configuration itself.
    """

    shapes: np.ndarray
    substeps: tuple[tuple[np.ndarray, tuple[str, ...]], ...]


def follow_path(section: Cable, start, clips, contacts, gravity) -> Followed:
    """The section's equilibria at every clip pose of ``clips``: the first settled from
    ``start``, each next one reached from the one before by a quasi-static continuation
    (:func:`dloplan.sim.statics.continuation`'s, its sub-steps kept, solved in one compiled
    loop per move: :func:`dloplan.sim.contact_path.contact_substeps`) in sub-steps of at most
    :data:`FOLLOW_STEP` times the section's length of clip motion, started from the
    equilibrium at the move's first pose solved again (where Newton stalled short of its
    tolerance at a contact's kink, this moves it)."""
    poses = list(clips)
    chain = SpringChain.from_cable(section, gravity, contacts)
    x = equilibrium(section, as_shape(start, section.n_points, "start"), poses[0],
                    gravity=gravity, chain=chain).shape
    shapes, moves = [x], []
    for before, pose in zip(poses[:-1], poses[1:], strict=True):
        motion = clip_motion(before, pose, section.length)
        count = max(1, math.ceil(motion / (FOLLOW_STEP * section.length)))
        settled = equilibrium(section, x, before, gravity=gravity, chain=chain).shape
        steps, messages = contact_substeps(section, chain, settled, before, pose, count)
        x = steps[-1]
        shapes.append(x)
        moves.append((np.concatenate([settled[None], steps]), ("", *messages)))
    return Followed(np.stack(shapes), tuple(moves))


__all__ = ["FOLLOW_STEP", "Followed", "follow_path", "section_cable", "section_shape",
           "whole_shape"]
