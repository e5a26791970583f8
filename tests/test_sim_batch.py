"""Batched equilibria (dloplan.sim.batch): each item bit for bit what equilibrium() returns."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import level_clips, sagging_guess
from scipy.spatial.transform import Rotation

from dloplan.cable import catalogue_cable
from dloplan.shapes import arc_shape
from dloplan.sim import ClipPoses, batch
from dloplan.sim.batch import held_equilibria
from dloplan.sim.statics import equilibrium

WEIGHTLESS = np.zeros(3)


def _solve_both(cables, cable_of, guesses, clips, **options):
    """The batch and, item by item, equilibrium(): (batch result, list of Equilibrium or the
    ValueError message)."""
    result = held_equilibria(cables, cable_of, guesses, np.stack([c.positions for c in clips]),
                             Rotation.concatenate([c.rotations for c in clips]), **options)
    singles = []
    for b, clip in enumerate(clips):
        try:
            singles.append(equilibrium(cables[cable_of[b]], guesses[b], clip, **options))
        except ValueError as exc:
            singles.append(str(exc))
    return result, singles


def _assert_items_equal(result, singles):
    for b, eq in enumerate(singles):
        if isinstance(eq, str):  # refused: clips out of reach
            assert result.refused[b] and result.messages[b] == eq
            assert np.isnan(result.shapes[b]).all()
            continue
        assert not result.refused[b]
        assert np.array_equal(result.shapes[b], eq.shape), b
        assert np.array_equal(result.clip_wrenches[b], eq.clip_wrenches), b
        assert result.iterations[b] == eq.iterations
        assert result.residuals[b] == eq.residual and result.tolerances[b] == eq.tolerance
        assert result.converged[b] == eq.converged and result.stable[b] == eq.stable
        assert result.messages[b] == eq.message


def test_every_item_is_the_equilibrium_bit_for_bit():
    base = catalogue_cable("ethernet", n_links=12)
    curved = replace(base, rest_shape=arc_shape(base.length, base.n_links, 1.5))
    cables = [base, base.with_modulus(3 * base.youngs_modulus), curved,
              replace(base, length=0.45, mass=0.009)]
    guesses, clips, cable_of = [], [], []
    for d in (0.08, 0.15, 0.30, 0.47):  # 0.47 m: beyond the reach of the 0.45 m cable
        for c, cable in enumerate(cables):
            guess = sagging_guess(cable, min(d, 0.3), -0.05)
            guess[:, 1] += 0.01 * np.sin(np.linspace(0, np.pi, cable.n_points))  # not planar
            tilt = Rotation.from_rotvec([[0.0, 0.1 * c, 0.0], [0.05, 0.0, 0.0]])
            clip = level_clips(d, 0.2)
            guesses.append(guess + [0, 0, 0.2])
            clips.append(ClipPoses(clip.positions, clip.rotations * tilt))
            cable_of.append(c)
    result, singles = _solve_both(cables, np.array(cable_of), np.stack(guesses), clips)
    assert sum(isinstance(eq, str) for eq in singles) >= 1  # a refusal is among them
    assert sum(not isinstance(eq, str) and eq.success for eq in singles) >= 12
    _assert_items_equal(result, singles)
    assert np.array_equal(result.success, result.converged & result.stable)


def test_items_out_of_iterations_keep_equilibriums_message():
    cable = catalogue_cable("ethernet", n_links=10)
    guesses = np.stack([sagging_guess(cable, d, -0.1) for d in (0.1, 0.2)])
    clips = [level_clips(d) for d in (0.1, 0.2)]
    result, singles = _solve_both([cable], np.zeros(2, dtype=int), guesses, clips,
                                  max_iterations=2)
    assert not result.converged.any() and "no convergence in 2 iterations" in result.messages[0]
    _assert_items_equal(result, singles)


def test_a_saddle_is_handed_back_to_equilibrium(monkeypatch):
    # weightless, compressed, started on the antisymmetric (S-shaped) buckling mode: by symmetry
    # Newton converges to that unstable equilibrium, a saddle the compiled loop cannot leave
    cable = catalogue_cable("ethernet", n_links=16)
    d = 0.4
    s = np.linspace(0.0, 1.0, cable.n_points)
    guess = sagging_guess(cable, d, 0.0)
    guess[:, 2] = 0.03 * np.sin(2 * np.pi * s)
    handed = []

    def counted(*args, **kwargs):
        handed.append(args)
        return equilibrium(*args, **kwargs)

    monkeypatch.setattr(batch, "equilibrium", counted)
    result, singles = _solve_both([cable], np.zeros(1, dtype=int), guess[None], [level_clips(d)],
                                  gravity=WEIGHTLESS)
    assert len(handed) == 1 and singles[0].success
    _assert_items_equal(result, singles)


@pytest.mark.parametrize("bad", ["cables", "guesses", "cable_of", "clip_positions",
                                 "clip_rotations"])
def test_bad_arguments_are_named(bad):
    cable = catalogue_cable("ethernet", n_links=10)
    args = {"cables": [cable], "cable_of": np.zeros(1, dtype=int),
            "guesses": sagging_guess(cable, 0.2)[None],
            "clip_positions": level_clips(0.2).positions[None],
            "clip_rotations": level_clips(0.2).rotations}
    args[bad] = {"cables": [cable, cable.with_links(12)], "guesses": np.zeros((1, 5, 3)),
                 "cable_of": np.ones(1, dtype=int), "clip_positions": np.zeros((1, 3, 3)),
                 "clip_rotations": Rotation.identity(3)}[bad]
    with pytest.raises(ValueError, match=bad):
        held_equilibria(**args)
