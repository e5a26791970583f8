"""Static equilibrium: closed forms, elastica references, robustness, honest failures."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import level_clips, load_reference, sagging_guess
from scipy.spatial.transform import Rotation

from dloplan import Cable, catalogue_cable
from dloplan.physics import SpringChain
from dloplan.sim import (
    ClipPoses,
    check_target,
    clip_poses_from_shape,
    continuation,
    equilibrium,
    interpolate_clips,
    stabilize,
)


def cantilever(n: int, load: float, clip_at_origin: bool, EI: float = 1.0, L: float = 1.0):
    """A horizontal cantilever held by its first link with a dead vertical tip load [N].

    ``clip_at_origin``: the chain is made l/2 longer so the elastic part beyond the clip point
    (the clamp) is exactly L; otherwise the cable is L long and the clamp sits l/2 inside it.
    """
    length = L * n / (n - 0.5) if clip_at_origin else L
    d = 0.01
    cable = Cable(length=length, diameter=d, mass=1.0, n_links=n,
                  youngs_modulus=EI / (np.pi * d**4 / 64), bending="rod")
    l = cable.rest_link_length
    loads = np.zeros(n + 1)
    loads[-1] = load / 9.81
    chain = replace(SpringChain.from_cable(cable), point_masses=loads)
    clips = ClipPoses(np.array([[0.0, 0, 0], [1.0, 0, 0]]), Rotation.identity(2))
    guess = np.stack([np.arange(n + 1) * l - l / 2, np.zeros(n + 1), np.zeros(n + 1)], 1)
    eq = equilibrium(cable, guess, clips, chain=chain, held="first")
    assert eq.converged, eq.message
    return eq


@pytest.mark.parametrize("n, bound", [(40, 0.05), (200, 0.01)])
def test_small_tip_load_deflects_like_euler_bernoulli(n, bound):
    P = 1e-4  # [N] on EI = 1 N m^2, L = 1 m: linear regime
    eq = cantilever(n, P, clip_at_origin=False)
    deflection = -eq.shape[-1, 2]
    assert abs(deflection / (P / 3) - 1) < bound  # P L^3 / (3 E I)


@pytest.mark.parametrize("alpha, tip, draw_in", [(1.0, 0.30172, 0.05643), (2.0, 0.49346, 0.16064)])
def test_large_tip_load_matches_the_published_elastica(alpha, tip, draw_in):
    # Bisshopp & Drucker (1945), via shared/reference/cantilever_tipload_alpha*.json
    ref = load_reference(f"cantilever_tipload_alpha{alpha:g}")
    eq = cantilever(100, alpha, clip_at_origin=True)
    assert -eq.shape[-1, 2] == pytest.approx(tip, abs=1e-3)
    assert 1.0 - eq.shape[-1, 0] == pytest.approx(draw_in, abs=1e-3)
    assert eq.shape[-1, [0, 2]] == pytest.approx([ref["tip"]["x"], ref["tip"]["z"]], abs=1e-3)


@pytest.mark.parametrize("name", ["ethernet", "pu"])
def test_clamped_heavy_cable_matches_the_elastica_and_converges(name):
    errors = {}
    for n in (40, 80):
        ref = load_reference(f"clamped_{name}_D0.4_n{n}")
        cable = catalogue_cable(name, n_links=n, bending="rod")
        assert cable.youngs_modulus * cable.second_moment == pytest.approx(ref["EI"], rel=1e-6)
        eq = equilibrium(cable, sagging_guess(cable, 0.4), level_clips(0.4))
        assert eq.success, eq.message
        distance = np.hypot(eq.shape[:, 0] - ref["x"], eq.shape[:, 2] - ref["z"])
        errors[n] = float(distance.max())
        # the force each gripper receives, without the overhang weight the reference omits
        overhang = cable.mass * 9.81 * ref["overhang"] / cable.length
        fx, fz = ref["force_on_left_gripper"]
        assert eq.clip_wrenches[0, 0] == pytest.approx(fx, rel=0.02)
        assert eq.clip_wrenches[0, 2] + overhang == pytest.approx(fz, rel=0.02)
    assert errors[40] < 0.005 * 0.5  # within 0.5 % of L at n = 40
    assert errors[80] < errors[40]


def test_gravity_matters_as_in_thesis_5_3():
    moved = {}
    for name in ("pu", "usb"):
        cable = catalogue_cable(name, n_links=40)
        clips = level_clips(0.4)
        weightless = equilibrium(cable, sagging_guess(cable, 0.4, -0.05), clips,
                                 gravity=(0, 0, 0))
        settled = stabilize(weightless.shape, cable)
        assert weightless.success and settled.success
        moved[name] = np.linalg.norm(settled.shape - weightless.shape, axis=1).max()
    assert moved["pu"] < 1e-3
    assert 0.015 < moved["usb"] < 0.035


@pytest.mark.parametrize("modulus", [1e5, 1e7, 1e9, 1e11])
@pytest.mark.parametrize("n", [5, 50, 200])
def test_converges_without_tuning_across_stiffness_and_resolution(modulus, n):
    cable = catalogue_cable("ethernet", n_links=n, youngs_modulus=modulus)
    eq = equilibrium(cable, sagging_guess(cable, 0.4), level_clips(0.4))
    assert eq.success, eq.message
    rounding = 1e-12 * np.abs(eq.energy_history).max()  # accepted steps within float noise
    assert np.all(np.diff(eq.energy_history) <= rounding)
    assert eq.residual <= eq.tolerance


def test_energy_decreases_monotonically_from_a_poor_guess():
    cable = catalogue_cable("usb", n_links=30)
    guess = sagging_guess(cable, 0.3, depth=0.2)  # upside down and too short
    eq = equilibrium(cable, guess, level_clips(0.3))
    assert eq.success
    assert np.all(np.diff(eq.energy_history) <= 1e-15)
    assert len(eq.energy_history) == eq.iterations + 1


def test_non_convergence_is_reported_not_hidden():
    cable = catalogue_cable("usb", n_links=30)
    eq = equilibrium(cable, sagging_guess(cable, 0.3, depth=0.2), level_clips(0.3),
                     max_iterations=2)
    assert not eq.converged and not eq.success
    assert "no convergence" in eq.message
    assert eq.residual > eq.tolerance


def test_mirrored_problem_gives_mirrored_answer():
    cable = catalogue_cable("ethernet", n_links=20)
    clips = ClipPoses(np.array([[0, 0, 0.0], [0.35, 0.1, 0.05]]),
                      Rotation.from_euler("zy", [[20, -10], [200, 30]], degrees=True))
    guess = sagging_guess(cable, 0.35)
    eq = equilibrium(cable, guess, clips)
    mirror = np.diag([-1.0, 1.0, 1.0])  # x -> -x, and swap the two clips
    flip_v = np.diag([1.0, -1.0, 1.0])  # keeps each mirrored frame right-handed, u = M u
    mirrored_clips = ClipPoses(
        clips.positions[::-1] @ mirror,
        Rotation.from_matrix(mirror @ clips.rotations[::-1].as_matrix() @ flip_v),
    )
    eq_m = equilibrium(cable, (eq.shape @ mirror)[::-1], mirrored_clips)
    assert np.allclose((eq_m.shape @ mirror)[::-1], eq.shape, atol=1e-9)


def test_clip_poses_read_back_from_an_equilibrium():
    cable = catalogue_cable("pu", n_links=12)
    clips = level_clips(0.42, z=0.1)
    eq = equilibrium(cable, sagging_guess(cable, 0.42), clips)
    read = clip_poses_from_shape(eq.shape)
    assert np.allclose(read.positions, clips.positions, atol=1e-12)
    assert np.allclose(read.u_axes, clips.u_axes, atol=1e-12)


def test_clip_poses_keep_c_ordered_positions_of_a_transposed_array():
    """ClipPoses copies its positions C-ordered: a transposed (Fortran-ordered) array does not
    compile a second overload of the kernels that take them (held points, clip wrenches)."""
    clips = level_clips(0.42, z=0.1)
    given = np.asfortranarray(clips.positions)
    copied = ClipPoses(given, clips.rotations)
    assert copied.positions.flags.c_contiguous and copied.positions is not given
    assert np.array_equal(copied.held_points(0.01), clips.held_points(0.01))


def test_continuation_follows_the_clips():
    cable = catalogue_cable("ethernet", n_links=16)
    start = equilibrium(cable, sagging_guess(cable, 0.45), level_clips(0.45)).shape
    sequence = [level_clips(d) for d in (0.4, 0.3, 0.2)]
    path = continuation(cable, start, sequence, substeps=2)
    assert [eq.success for eq in path] == [True] * 3
    for eq, clips in zip(path, sequence, strict=True):
        assert np.allclose(eq.clips.positions, clips.positions)
    sags = [eq.shape[:, 2].min() for eq in path]
    assert sags[0] > sags[1] > sags[2]  # closer clips, deeper sag


def test_continuation_returns_every_substep_on_request():
    """``every_substep``: per clip pose the equilibria solved on the way to it, each warm-started
    from the one before at the interpolated clips; the last of each is the pose's equilibrium
    of the plain call, bit for bit."""
    cable = catalogue_cable("ethernet", n_links=16)
    start = sagging_guess(cable, 0.45)
    sequence = [level_clips(d) for d in (0.45, 0.4, 0.3)]
    plain = continuation(cable, start, sequence, substeps=3)
    grouped = continuation(cable, start, sequence, substeps=3, every_substep=True)
    assert [len(g) for g in grouped] == [1, 3, 3]
    for eqs, eq in zip(grouped, plain, strict=True):
        assert np.array_equal(eqs[-1].shape, eq.shape)
    x = grouped[1][-1].shape  # the sub-steps of the last move, solved one by one
    stops = interpolate_clips(sequence[1], sequence[2], np.arange(1, 4) / 3)
    for eq, stop in zip(grouped[2], stops, strict=True):
        x = equilibrium(cable, x, stop).shape
        assert np.array_equal(eq.shape, x)


def test_check_target_flags_a_soft_cable_and_accepts_a_stiff_one():
    for name, expect_stable in (("pa12", True), ("usb", False)):
        cable = catalogue_cable(name, n_links=20)
        weightless = equilibrium(cable, sagging_guess(cable, 0.4, -0.05), level_clips(0.4),
                                 gravity=(0, 0, 0))
        report = check_target(weightless.shape, cable, threshold=0.005)
        assert report.stable is expect_stable, report.message
        assert report.max_displacement == pytest.approx(report.displacements.max())
        if not expect_stable:
            assert "not stable" in report.message


@pytest.mark.parametrize(
    "clips, fragment",
    [
        (level_clips(0.6), "out of reach"),
        (level_clips(0.0), "coincide"),
    ],
)
def test_impossible_clips_give_a_clear_error(clips, fragment):
    cable = catalogue_cable("usb", n_links=10)
    with pytest.raises(ValueError, match=fragment):
        equilibrium(cable, sagging_guess(cable, 0.4), clips)


def test_nan_clip_poses_and_guesses_are_rejected():
    cable = catalogue_cable("usb", n_links=10)
    with pytest.raises(ValueError, match="clips.positions"):
        ClipPoses(np.array([[0, 0, np.nan], [0.4, 0, 0]]), Rotation.identity(2))
    bad = sagging_guess(cable, 0.4)
    bad[4, 0] = np.nan
    with pytest.raises(ValueError, match="guess: point 4"):
        equilibrium(cable, bad, level_clips(0.4))
    with pytest.raises(ValueError, match="guess: 10 points given, expected 11"):
        equilibrium(cable, bad[:10], level_clips(0.4))


def test_a_cable_rests_on_the_table_without_entering_it():
    from dloplan.obstacles import Table

    cable = catalogue_cable("usb", n_links=30)
    clips = level_clips(0.4, z=0.05)
    eq = equilibrium(cable, sagging_guess(cable, 0.4, -0.05) + [0, 0, 0.05], clips,
                     contacts=[Table(0.0)])
    assert eq.success, eq.message
    assert eq.penetration < 1e-4  # [m]: under 0.1 mm
    assert eq.shape[:, 2].min() >= cable.diameter / 2 - 1e-4
    # the table carries the weight of the points lying on it
    lying = eq.shape[:, 2] < cable.diameter / 2 + 1e-6
    assert lying.sum() >= 3
    weight_on_table = cable.point_masses[lying].sum() * 9.81
    assert eq.forces.contact[:, 2].sum() == pytest.approx(weight_on_table, rel=0.35)
    assert np.all(eq.forces.contact[:, :2] == 0)


def test_a_plate_holds_the_cable_up():
    from dloplan.obstacles import Box

    cable = catalogue_cable("ethernet", n_links=30)
    # a plate wider than the part of the cable that comes to rest on it: point contacts do not
    # see a link crossing a plate's edge, and without torsion a cable held by level clips can
    # swing about the chord at no cost, so a narrow plate would let it roll off sideways
    plate = Box.from_corners((0.08, -0.2, 0.0), (0.32, 0.2, 0.02), name="plate")
    free = equilibrium(cable, sagging_guess(cable, 0.4), level_clips(0.4, z=0.1))
    # lower the cable onto the plate: hanging clear above it, then the clips come down
    above = equilibrium(cable, sagging_guess(cable, 0.4), level_clips(0.4, z=0.3)).shape
    lowering = [level_clips(0.4, z=z) for z in np.linspace(0.3, 0.1, 5)]
    held = continuation(cable, above, lowering, substeps=10, contacts=[plate])[-1]
    assert held.success and held.penetration < 1e-4
    mid = held.shape[cable.n_links // 2]
    assert mid[2] == pytest.approx(0.02 + cable.diameter / 2, abs=2e-4)
    assert free.shape[:, 2].min() < 0.0


def test_clip_wrenches_of_a_stabilized_shape_match_the_equilibrium():
    from dloplan.sim import clip_wrenches

    cable = catalogue_cable("ethernet", n_links=20)
    eq = equilibrium(cable, sagging_guess(cable, 0.4), level_clips(0.4))
    wrenches = clip_wrenches(cable, eq.shape)
    assert np.allclose(wrenches, eq.clip_wrenches, atol=1e-9)
    # the clips carry the whole weight between them
    assert wrenches[:, 2].sum() == pytest.approx(-cable.mass * 9.81, rel=1e-6)
