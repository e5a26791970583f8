"""Snap-through: an arch snaps at the angle a fine continuation finds; smooth motions do not."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dloplan.cable import catalogue_cable
from dloplan.sim.clips import ClipPoses
from dloplan.sim.statics import continuation, equilibrium
from dloplan.verify.snap import check_snap_through, clip_motion

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_verify_snap")

WEIGHTLESS = (0.0, 0.0, 0.0)
TILT = math.radians(20.0)
ROTATION = math.radians(-60.0)

# The arch is weightless and its clips point 20 degrees above the chord. Why: the model has no
# twist stiffness, so a shape may turn rigidly about the line through the two clip points as
# long as the held links lie on that line. With level clips, gravity would make an arch swing
# down around the chord (an inverted pendulum, not a snap); weightless with level clips, that
# rotation costs nothing (a zero eigenvalue: neutral). Tilted clips forbid the rotation, so the
# arch is a strict minimum and the only way to lose it is by bending.


def arch_clips(phi: float) -> ClipPoses:
    """Clips 0.4 m apart, both u-axes tilted up by TILT; the last one turned by phi about y."""
    first = Rotation.from_rotvec([0, -TILT, 0])
    last = Rotation.from_rotvec([0, TILT + phi, 0]) * Rotation.from_rotvec([0, 0, math.pi])
    return ClipPoses(np.array([[0, 0, 0], [0.4, 0, 0.0]]), Rotation.concatenate([first, last]))


@pytest.fixture(scope="module")
def arch():
    cable = catalogue_cable("pu", 16)
    guess = np.zeros((17, 3))
    guess[:, 0] = np.linspace(-0.05, 0.45, 17)
    guess[:, 2] = 0.1 * np.sin(np.pi * np.linspace(0, 1, 17))
    start = equilibrium(cable, guess, arch_clips(0.0), gravity=WEIGHTLESS).shape
    poses = [arch_clips(0.0), arch_clips(ROTATION)]
    end = continuation(cable, start, poses, substeps=200, gravity=WEIGHTLESS)[-1].shape
    return cable, np.stack([start, end]), poses


def test_arch_snap_is_flagged_where_a_fine_continuation_finds_it(arch):
    # Turning the last clip down, the planar arch loses stability where lambda_1 reaches zero:
    # without twist stiffness it escapes out of its plane (a symmetric bifurcation, the side
    # chosen by round-off), rolls under and rejoins the plane as the inverted arch at a second
    # critical point. Both are flagged, at the same angles with default and fine sub-steps.
    cable, path, poses = arch
    default = check_snap_through(cable, path, poses, gravity=WEIGHTLESS)  # 0.29 deg sub-steps
    fine = check_snap_through(cable, path, poses, gravity=WEIGHTLESS, substeps=400)  # 0.15 deg
    angles = []
    for check in (default, fine):
        assert not check.ok
        assert [e.kind for e in check.events] == ["snap", "snap"]
        assert all(e.segment == 0 for e in check.events)
        angles.append([math.degrees(ROTATION) * e.fraction for e in check.events])
    # localized to 2^-10 of a window: both agree far within the fine sub-step
    np.testing.assert_allclose(angles[0], angles[1], atol=0.01)
    assert -40 < angles[0][0] < -20 and angles[0][0] > angles[0][1] > -60
    # the reported sub-step is at (or next to) the localized fraction
    seg = default.segments[0]
    event = default.events[0]
    step = seg.fractions[1]
    assert seg.fractions[event.substep - 1] - step <= event.fraction
    assert event.fraction <= seg.fractions[event.substep] + step
    # independent check: before the first event, the fine continuation's smallest eigenvalue
    # falls linearly (a symmetric bifurcation); its extrapolation reaches zero at the flag
    fseg = fine.segments[0]
    before = np.flatnonzero(fseg.fractions < fine.events[0].fraction)[-6:-1]
    phi = math.degrees(ROTATION) * fseg.fractions[before]
    slope, offset = np.polyfit(phi, fseg.eigenvalues[before], 1)
    assert abs(-offset / slope - angles[1][0]) < 0.05
    # at the flagged point the eigenvalue is zero compared with the arch's at the start
    assert abs(event.eigenvalue) < 1e-3 * seg.eigenvalues[0]
    assert "snap-through" in default.message


def test_rigid_translation_follows_the_straight_interpolation():
    cable = catalogue_cable("usb", 10)
    clips = ClipPoses(np.array([[0, 0, 0.3], [0.35, 0, 0.3]]),
                      Rotation.from_rotvec([[0, 0, 0], [0, 0, math.pi]]))
    guess = np.zeros((11, 3))
    guess[:, 0] = np.linspace(-0.05, 0.45, 11)
    a = equilibrium(cable, guess, clips).shape
    shift = np.array([0.05, -0.03, 0.04])
    path = np.stack([a, a + shift])
    check = check_snap_through(cable, path, [clips, clips.moved(shift)])
    assert check.ok and not check.events
    seg = check.segments[0]
    assert seg.straying < 1e-8  # a translated equilibrium is the same equilibrium, translated
    assert seg.end_mismatch < 1e-8
    assert len(seg.fractions) - 1 == math.ceil(np.linalg.norm(shift) / (0.005 * cable.length))


def test_sagging_cable_moved_smoothly_has_no_event_and_strays():
    cable = catalogue_cable("usb", 10)
    clips = ClipPoses(np.array([[0, 0, 0.3], [0.35, 0, 0.3]]),
                      Rotation.from_rotvec([[0, 0, 0], [0, 0, math.pi]]))
    turned = ClipPoses(np.array([[0, 0, 0.3], [0.2, 0.2, 0.35]]),
                       Rotation.from_rotvec([[0, 0, 0], [0, 0, 0.75 * math.pi]]))
    guess = np.zeros((11, 3))
    guess[:, 0] = np.linspace(-0.05, 0.45, 11)
    shapes = [e.shape for e in continuation(cable, guess, [clips, turned], substeps=20)]
    check = check_snap_through(cable, np.stack(shapes), [clips, turned])
    assert check.ok, check.message
    seg = check.segments[0]
    assert 1e-4 < seg.straying < 0.1  # the sag swings: not a straight blend of the two shapes
    assert np.all(seg.eigenvalues > 0)


def test_planned_shape_that_the_motion_does_not_reach_is_flagged():
    cable = catalogue_cable("usb", 10)
    clips = ClipPoses(np.array([[0, 0, 0.3], [0.35, 0, 0.3]]),
                      Rotation.from_rotvec([[0, 0, 0], [0, 0, math.pi]]))
    moved = clips.moved((0.0, 0.02, 0.0))
    guess = np.zeros((11, 3))
    guess[:, 0] = np.linspace(-0.05, 0.45, 11)
    a, b = (e.shape for e in continuation(cable, guess, [clips, moved], substeps=4))
    wrong = b.copy()
    wrong[2:-2, 2] += 0.005  # a "stabilized" shape 5 mm off its equilibrium
    good = check_snap_through(cable, np.stack([a, b]), [clips, moved])
    bad = check_snap_through(cable, np.stack([a, wrong]), [clips, moved])
    assert good.ok and good.segments[0].end_mismatch < 1e-6
    assert [e.kind for e in bad.events] == ["branch"] and not bad.ok
    assert bad.segments[0].end_mismatch == pytest.approx(0.005, rel=1e-6)


def test_clip_motion_and_bad_inputs():
    a = arch_clips(0.0)
    b = arch_clips(math.radians(10.0))
    assert clip_motion(a, b, 0.5) == pytest.approx(0.5 * math.radians(10.0), rel=1e-9)
    assert clip_motion(a, a.moved((0.01, 0, 0)), 0.5) == pytest.approx(0.01)
    cable = catalogue_cable("pu", 12)
    path = np.zeros((2, 13, 3))
    path[:, :, 0] = np.linspace(0, 0.5, 13)
    with pytest.raises(ValueError, match="jump_ratio"):
        check_snap_through(cable, path, jump_ratio=0)
    with pytest.raises(ValueError, match="substeps"):
        check_snap_through(cable, path, substeps=0)
    with pytest.raises(ValueError, match="clip_poses"):
        check_snap_through(cable, path, [a])
    with pytest.raises(ValueError, match="stabilized_shapes"):
        check_snap_through(cable, path[:, :5])


def test_interpolated_clips_are_the_slerp_at_each_fraction():
    """interpolate_clips evaluates both slerps at all fractions at once (one array slerp): the
    poses are those of scipy's Slerp per clip and fraction (the former loop) to round-off, the
    positions bit for bit, and the end poses are a and b."""
    from scipy.spatial.transform import Slerp

    from dloplan.sim.statics import interpolate_clips

    a = ClipPoses(np.array([[0.0, 0.0, 0.3], [0.4, 0.0, 0.3]]),
                  Rotation.from_rotvec([[0.1, 0.2, 0.3], [0.0, 0.0, math.pi]]))
    b = ClipPoses(np.array([[0.05, 0.1, 0.35], [0.3, 0.1, 0.25]]),
                  Rotation.from_rotvec([[-0.4, 0.2, 1.3], [0.3, -0.2, 2.0]]))
    fractions = np.r_[0.0, np.random.default_rng(3).random(40), 1.0]
    poses = interpolate_clips(a, b, fractions)
    slerps = [Slerp([0.0, 1.0], Rotation.concatenate([a.rotations[k], b.rotations[k]]))
              for k in range(2)]
    for t, pose in zip(fractions, poses, strict=True):
        np.testing.assert_array_equal(pose.positions, (1.0 - t) * a.positions + t * b.positions)
        expected = Rotation.concatenate([slerps[k](t) for k in range(2)])
        assert np.all((pose.rotations * expected.inv()).magnitude() < 1e-14)
        np.testing.assert_allclose(np.linalg.norm(pose.rotations.as_quat(), axis=1), 1.0,
                                   rtol=0, atol=1e-15)
    for pose, end in ((poses[0], a), (poses[-1], b)):
        np.testing.assert_allclose(pose.positions, end.positions, rtol=0, atol=1e-15)
        assert np.all((pose.rotations * end.rotations.inv()).magnitude() < 1e-12)
    assert interpolate_clips(a, b, []) == []


def _lowered_onto_the_table(cable):
    """Level clips 0.45 m apart lowered from 15 cm to 3 cm above a table, a peg beside the
    chord: the sagging cable touches down on the table on the way."""
    from dloplan.obstacles import Cylinder, Table

    contacts = (Cylinder((0.22, 0.03, 0.0), 0.012, 0.06, "peg"), Table(0.0))
    turn = Rotation.from_euler("z", [[0.0], [180.0]], degrees=True)

    def clips(h):
        return ClipPoses(np.array([[0.0, 0.0, h], [0.45, 0.0, h]]), turn)

    s = np.linspace(0.0, 1.0, cable.n_points)
    guess = np.stack([np.linspace(-0.01, 0.46, cable.n_points), np.zeros_like(s),
                      0.15 - 0.1 * np.sin(np.pi * s)], axis=1)
    poses = [clips(0.15), clips(0.09), clips(0.03)]
    start = equilibrium(cable, guess, poses[0], contacts=contacts).shape
    path = [start] + [eq.shape for eq in continuation(cable, start, poses[1:], substeps=24,
                                                      contacts=contacts)]
    return np.stack(path), poses, contacts


@pytest.mark.parametrize("changing", [False, True], ids=["one cable", "shortened"])
def test_the_continuation_with_contacts_is_the_reference_loop(changing):
    """With contacts the sub-steps' equilibria are solved first and their stability tested
    together (``compiled=True``, the obstacles' distances evaluated once for all sub-steps,
    each sub-step's smallest eigenpairs followed from the one before): the same shapes,
    contact states (and their sliding flags), contact changes and events as the reference
    loop, sub-step by sub-step, number for number (the same kernels and formulas, elementwise
    on more points at once), the eigenvalues to the followed eigenvalue's certified tolerance
    (:func:`dloplan.verify.lowest.eigenvalue_tolerance`, the round-off floor of an eigenvalue of
    the Hessian: LAPACK's eigenvalues of this nearly constant stiffness scatter by 4e-10 of it
    from one sub-step to the next). ``shortened``: the cable 1 % shorter at the last shape (a
    tensioning's changing cable, its constants per sub-step)."""
    from dataclasses import replace

    from dloplan.verify.lowest import eigenvalue_tolerance
    from dloplan.verify.stability import (
        ROUNDOFF_FACTOR,
        band_norm,
        constrained_hessian,
        stiffness_scale,
    )

    cable = catalogue_cable("usb", 24)
    path, poses, contacts = _lowered_onto_the_table(cable)
    cables = None
    if changing:
        short = replace(cable, length=0.99 * cable.length, mass=0.99 * cable.mass)
        cables = [cable, cable, short]
    checks = [check_snap_through(cable, path, poses, contacts=contacts, cables=cables,
                                 compiled=compiled) for compiled in (True, False)]
    fast, reference = checks
    assert any(c.change == "touch-down" for c in reference.contact_changes)
    assert fast.message == reference.message
    assert [(e.kind, e.segment, e.substep) for e in fast.events] == \
        [(e.kind, e.segment, e.substep) for e in reference.events]
    assert [c.describe() for c in fast.contact_changes] == \
        [c.describe() for c in reference.contact_changes]
    for a, b in zip(fast.segments, reference.segments, strict=True):
        np.testing.assert_array_equal(a.shapes, b.shapes)
        norms = [band_norm(constrained_hessian(cable, x, contacts=contacts)[1]) for x in a.shapes]
        tolerance = [eigenvalue_tolerance(value, stiffness_scale(cable), norm, ROUNDOFF_FACTOR)
                     for value, norm in zip(b.eigenvalues, norms, strict=True)]
        assert np.all(np.abs(a.eigenvalues - b.eigenvalues) <= tolerance)
        assert a.contacts == b.contacts


def test_stabilities_of_many_shapes_are_each_shapes_own():
    """:func:`elastic_stabilities` of a path with contacts (the obstacles evaluated once for
    all shapes, each cable's chain built once) against :func:`elastic_stability` shape by
    shape: the same eigenvalues, modes, verdicts, messages and contact states, exactly (with
    the deterministic banded eigen-solver; ARPACK's random start vector differs between two
    calls on the same shape by round-off)."""
    from dloplan.verify.stability import elastic_stabilities, elastic_stability

    cable = catalogue_cable("usb", 24)
    path, _, contacts = _lowered_onto_the_table(cable)
    together = elastic_stabilities([cable] * len(path), path, contacts=contacts, method="band")
    for x, stab in zip(path, together, strict=True):
        alone = elastic_stability(cable, x, contacts=contacts, method="band")
        np.testing.assert_array_equal(stab.eigenvalues, alone.eigenvalues)
        np.testing.assert_array_equal(stab.modes, alone.modes)
        assert (stab.message, stab.contacts, stab.sticking, stab.residual) == \
            (alone.message, alone.contacts, alone.sticking, alone.residual)
    assert any(state.active for stab in together for state in stab.contacts)
    with pytest.raises(ValueError, match="cables"):
        elastic_stabilities([cable], path, contacts=contacts)


def test_the_sticking_eigenvalue_is_the_reduced_hessians_smallest():
    """``Stability.sticking`` (the band with the pressing points' coordinates cleared and their
    diagonal put above the spectrum) against numpy's dense solve of the free Hessian with those
    coordinates removed, on the lowered cable's shapes that press on the table: equal to
    round-off of the Hessian's norm (1e-12 of it: both are backward-stable solves of matrices of
    that norm)."""
    from dloplan.physics.chain import band_to_sparse
    from dloplan.verify.stability import constrained_hessian, elastic_stability

    cable = catalogue_cable("usb", 24)
    path, _, contacts = _lowered_onto_the_table(cable)
    checked = 0
    for x in path:
        stab = elastic_stability(cable, x, contacts=contacts, k=1, method="band")
        pressing = np.zeros(len(x), dtype=bool)
        for obstacle in contacts:
            pressing |= obstacle.signed_distance(x)[0] < cable.diameter / 2
        if not pressing[2:-2].any():
            continue
        hessian = band_to_sparse(constrained_hessian(cable, x, contacts=contacts)[1]).toarray()
        keep = np.repeat(~pressing[2:-2], 3)
        reduced = np.linalg.eigvalsh(hessian[np.ix_(keep, keep)])[0]
        norm = np.abs(hessian).sum(axis=1).max()
        assert abs(stab.sticking - reduced) < 1e-12 * norm
        assert stab.sticking >= stab.smallest - 1e-12 * norm  # Cauchy's interlacing
        checked += 1
    assert checked
