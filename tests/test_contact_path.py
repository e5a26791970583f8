"""A continuation's sub-steps with contacts in one compiled loop (dloplan.sim.contact_path)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dloplan.cable import catalogue_cable
from dloplan.obstacles import Cylinder, Table
from dloplan.physics.chain import SpringChain
from dloplan.sim.clips import ClipPoses
from dloplan.sim.contact_path import PAIRWISE_BLOCK, contact_substeps, pairwise_sum
from dloplan.sim.statics import continuation, equilibrium

TURN = Rotation.from_euler("z", [[0.0], [180.0]], degrees=True)


def _level(width: float, height: float) -> ClipPoses:
    return ClipPoses(np.array([[0.0, 0.0, height], [width, 0.0, height]]), TURN)


def _hanging(cable, contacts):
    s = np.linspace(0.0, 1.0, cable.n_points)
    guess = np.stack([np.linspace(-0.01, 0.46, cable.n_points), np.zeros_like(s),
                      0.15 - 0.1 * np.sin(np.pi * s)], axis=1)
    return equilibrium(cable, guess, _level(0.45, 0.15), contacts=contacts).shape


@pytest.mark.parametrize("name, contacts", [
    ("usb", (Cylinder((0.22, 0.03, 0.0), 0.012, 0.06, "peg"), Table(0.0))),
    ("ethernet", (Cylinder((0.22, 0.03, 0.0), 0.012, 0.06, "peg"), Table(0.0))),
    ("usb", ()),
], ids=["usb on a table past a peg", "copper axial springs", "no contacts"])
def test_the_compiled_substeps_are_the_continuations_bit_for_bit(name, contacts):
    """A cable lowered from 15 cm to 3 cm above a table, a peg beside the chord (it touches
    down on the way), in two moves of 24 sub-steps: every sub-step's shape and message is
    what ``continuation(every_substep=True)`` solves with ``equilibrium``, bit for bit (the
    same kernels in the same order, the start's energy summed as numpy sums it); without
    contacts every sub-step is ``equilibrium``'s own."""
    cable = catalogue_cable(name, 24)
    chain = SpringChain.from_cable(cable, contacts=contacts)
    x = _hanging(cable, contacts)
    touched = False
    for before, after in ((_level(0.45, 0.15), _level(0.45, 0.09)),
                          (_level(0.45, 0.09), _level(0.45, 0.03))):
        (settled,), steps = continuation(cable, x, [before, after], substeps=24,
                                         contacts=contacts, every_substep=True)
        shapes, messages = contact_substeps(cable, chain, settled.shape, before, after, 24)
        np.testing.assert_array_equal(shapes, np.stack([eq.shape for eq in steps]))
        assert messages == tuple(eq.message for eq in steps)
        touched |= bool(contacts) and np.min(shapes[..., 2]) < cable.diameter
        x = shapes[-1]
    assert touched or not contacts


def test_clips_beyond_the_reach_are_refused_as_equilibrium_refuses_them():
    """Clips pulled apart beyond the cable's reach: the compiled loop hands the sub-step back
    to ``equilibrium``, which raises its ValueError naming the distances."""
    cable = catalogue_cable("usb", 24)
    contacts = (Table(0.0),)
    chain = SpringChain.from_cable(cable, contacts=contacts)
    x = _hanging(cable, contacts)
    far = _level(1.2 * cable.length, 0.15)
    with pytest.raises(ValueError, match="out of reach"):
        contact_substeps(cable, chain, x, _level(0.45, 0.15), far, 8)


def test_the_energys_sum_is_numpys(rng):
    """:func:`pairwise_sum` adds as numpy's pairwise summation does, bit for bit, for every
    length up to :data:`PAIRWISE_BLOCK` (values spanning 16 decades, so the order shows)."""
    for n in range(1, PAIRWISE_BLOCK + 1):
        for _ in range(20):
            a = rng.normal(size=n) ** 2 * 10.0 ** rng.integers(-8, 8, size=n)
            assert pairwise_sum(a, n) == np.sum(a)
