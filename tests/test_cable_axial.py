"""The cable's axial modulus of its own (issues 19, 35): k_s = E_a A / l; the composite catalogue
cables (USB, Ethernet) have their copper's (COMPOSITE_AXIAL_MODULI) by default, the thesis'
E_a = E is an option."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from conftest import level_clips, sagging_guess

from dloplan.app.resolve import build_cable
from dloplan.cable import COMPOSITE_AXIAL_MODULI, STIFF_AXIAL_RATIO, Cable, catalogue_cable
from dloplan.geometry import link_lengths
from dloplan.identify import bending_manipulation, identify_youngs_modulus, synthetic_experiment
from dloplan.io.scenario import CableSpec
from dloplan.physics.chain import SpringChain
from dloplan.pipeline.document import cable_to_dict
from dloplan.sim.statics import equilibrium


def test_composite_catalogue_cables_stretch_with_their_copper_by_default():
    assert catalogue_cable("usb").axial_modulus == COMPOSITE_AXIAL_MODULI["usb"]
    assert catalogue_cable("ethernet").axial_modulus == COMPOSITE_AXIAL_MODULI["ethernet"]
    assert catalogue_cable("pa12").axial_modulus is None  # a hose: one material, E_a = E
    assert catalogue_cable("pu").axial_modulus is None
    # the thesis' one modulus for bending and stretching stays an option, three ways
    assert catalogue_cable("usb", axial_modulus=None).axial_modulus is None
    assert catalogue_cable("usb").thesis_model().axial_modulus is None
    assert build_cable(CableSpec(name="usb", axial_modulus="thesis"), 1.0, None
                       ).axial_modulus is None
    assert build_cable(CableSpec(name="usb"), 1.0, None).axial_modulus == 2e9
    assert build_cable(CableSpec(name="ethernet", axial_modulus=1e9), 1.0, None
                       ).axial_modulus == 1e9
    # a new E (given or identified) keeps the copper
    assert build_cable(CableSpec(name="usb", youngs_modulus=3e6), 1.0, None
                       ).axial_modulus == 2e9
    # a cable of its own (no catalogue name) is one material unless told otherwise
    assert build_cable(CableSpec(length=0.5, diameter=0.004, mass=0.01, youngs_modulus=5e6),
                       1.0, None).axial_modulus is None
    with pytest.raises(ValueError, match="axial_modulus"):
        CableSpec(name="usb", axial_modulus="copper")


def test_only_stiff_axial_springs_get_the_solvers_link_length_correction():
    """The static solvers' second-order correction is for E_a >= 10 E (docs/decisions.md): the
    thesis' E_a = E and a modulus just below the ratio take the plain Newton steps."""
    usb = catalogue_cable("usb", n_links=10, axial_modulus=None)
    e = usb.youngs_modulus
    assert not usb.stiff_axial and not SpringChain.from_cable(usb).stiff_axial
    assert not catalogue_cable("usb", axial_modulus=0.99 * STIFF_AXIAL_RATIO * e).stiff_axial
    assert catalogue_cable("usb", axial_modulus=STIFF_AXIAL_RATIO * e).stiff_axial
    copper = catalogue_cable("usb", n_links=10)
    assert copper.stiff_axial and SpringChain.from_cable(copper).stiff_axial
    assert not copper.with_modulus(COMPOSITE_AXIAL_MODULI["usb"]).stiff_axial  # E_a = E again


def test_the_thesis_damping_and_time_step_with_copper_axial_springs():
    """k_d keeps the thesis' E A / l (its drag, every mode decaying at k_d / 2 m_i); the time
    step is the copper springs' own, also under a fictitious modulus for E (thesis Fig. 6.5),
    which would make it sqrt(800) times too long for them."""
    copper = catalogue_cable("usb", n_links=8)
    thesis = replace(copper, axial_modulus=None)
    assert copper.k_damping == thesis.k_damping
    assert copper.k_damping == pytest.approx(
        2 * 0.05 * math.sqrt(copper.mass / 9 * 2.5e6 * copper.area / copper.rest_link_length))
    assert copper.time_step(1e6) == copper.time_step()
    assert thesis.time_step(1e6) == pytest.approx(thesis.time_step() * math.sqrt(2.5))
    with pytest.raises(ValueError, match="youngs_modulus_cap"):
        copper.time_step(-1.0)


def test_without_an_axial_modulus_the_thesis_model_is_unchanged():
    cable = catalogue_cable("usb", n_links=10, axial_modulus=None)
    assert cable.axial_modulus is None
    assert cable.axial_youngs_modulus == cable.youngs_modulus
    assert cable.k_axial == pytest.approx(cable.youngs_modulus * cable.area
                                          / cable.rest_link_length)  # eq. 3.10


def test_an_axial_modulus_sets_only_the_axial_springs():
    plain = catalogue_cable("usb", n_links=10, axial_modulus=None)
    cable = catalogue_cable("usb", n_links=10, axial_modulus=2e9)
    assert cable.k_axial == pytest.approx(2e9 * cable.area / cable.rest_link_length)
    assert cable.axial_stiffness == pytest.approx(2e9 * cable.area)
    assert cable.k_bending == plain.k_bending and cable.k_twist == plain.k_twist
    # the explicit time step follows the stiffest spring: sqrt(E / E_a) times shorter
    assert cable.time_step() == pytest.approx(plain.time_step() * math.sqrt(2.5e6 / 2e9))
    assert cable.constants()["E_a [Pa]"] == 2e9
    # variants keep it: identification changes E only, a new n keeps the material
    assert cable.with_modulus(5e6).axial_modulus == 2e9
    assert cable.with_links(20).axial_modulus == 2e9
    assert cable.thesis_model().axial_modulus is None  # the thesis' one modulus


@pytest.mark.parametrize("value", [0.0, -1e9, math.nan, math.inf])
def test_a_bad_axial_modulus_is_refused(value):
    with pytest.raises(ValueError, match="axial_modulus"):
        catalogue_cable("usb", axial_modulus=value)


def test_the_axial_modulus_round_trips_through_exports_and_scenarios():
    cable = catalogue_cable("ethernet", n_links=12, axial_modulus=1.5e9)
    fields = cable_to_dict(cable)
    assert fields["axial_modulus"] == 1.5e9
    assert Cable(**fields).k_axial == cable.k_axial
    assert Cable(**cable_to_dict(catalogue_cable("pu"))).axial_modulus is None
    built = build_cable(CableSpec(name="usb", axial_modulus=2e9), 1.0, None)
    assert built.axial_modulus == 2e9
    assert build_cable(CableSpec(name="usb"), 1.0, None).axial_modulus == 2e9  # the default
    assert build_cable(CableSpec(name="usb", axial_modulus="thesis"), 1.0, None
                       ).axial_modulus is None
    assert build_cable(CableSpec(name="pu"), 1.0, None).axial_modulus is None
    # a plan made with the thesis' one modulus reads back as such
    assert Cable(**cable_to_dict(catalogue_cable("usb", axial_modulus=None))).axial_modulus \
        is None


def _sag(cable, distance):
    result = equilibrium(cable, sagging_guess(cable, distance, -0.05), level_clips(distance))
    assert result.success, result.message
    return result.shape


@pytest.mark.parametrize("distance", [0.4, 0.48])
def test_usb_stretch_and_sag_with_and_without_a_copper_axial_modulus(distance):
    # the catalogue USB (rod model, E = 2.5 MPa) between level clips: with E_a = E the axial
    # springs carry the same tension (to first order) as with E_a = 2 GPa, so the strain is
    # E_a / E = 800 times larger; the stiffer cable sags less, and above ~1e8 Pa it is
    # practically inextensible (the sag no longer changes)
    tied = catalogue_cable("usb", n_links=40, axial_modulus=None)
    copper = catalogue_cable("usb", n_links=40, axial_modulus=COMPOSITE_AXIAL_MODULI["usb"])
    stiff = catalogue_cable("usb", n_links=40, axial_modulus=1e8)
    shapes = {k: _sag(c, distance) for k, c in (("tied", tied), ("copper", copper),
                                                 ("stiff", stiff))}
    strain = {k: link_lengths(x) / tied.rest_link_length - 1 for k, x in shapes.items()}
    ratio = strain["tied"].max() / strain["copper"].max()
    if distance == 0.4:
        assert ratio == pytest.approx(800, rel=0.05)
    else:  # nearly taut: the stretch itself changes the tension (2.7 mm longer: 10 % less sag)
        assert 400 < ratio < 800
    assert 1e-3 < strain["tied"].max() < 1e-2  # 0.3 to 0.6 %: the USB's own weight
    sag = {k: -x[:, 2].min() for k, x in shapes.items()}
    assert sag["tied"] > sag["copper"] + 0.5e-3
    # E_a = 1e8 vs 2e9 Pa: 0.01 mm apart at 0.4 m, 0.25 mm nearly taut (0.48 m)
    assert sag["stiff"] == pytest.approx(sag["copper"], abs=0.05e-3 if distance == 0.4 else 0.5e-3)


def test_identification_fits_the_bending_modulus_with_the_axial_one_held():
    # a USB with copper axial stiffness sagging between level clips 0.44 m apart (n = 80, the
    # n its curvature needs): identified with its axial modulus held, the interval covers E;
    # the thesis' tied model lets the cable stretch and makes up for the extra sag with a
    # stiffer bending modulus, over 10 % too high
    cable = catalogue_cable("usb", n_links=80, axial_modulus=COMPOSITE_AXIAL_MODULI["usb"])
    manipulation = bending_manipulation(cable, clip_distance=0.44, angle=0.0)
    experiment = synthetic_experiment(cable, manipulation, noise=1e-3, n_measured=300, seed=3)
    held = identify_youngs_modulus(cable.with_modulus(1e7), experiment)
    assert held.success, held.message
    assert held.n_links == 80 and held.cable.axial_modulus == cable.axial_modulus
    lo, hi = held.confidence_interval
    assert lo <= cable.youngs_modulus <= hi
    tied = identify_youngs_modulus(catalogue_cable("usb", n_links=80, axial_modulus=None),
                                   experiment)
    assert tied.success
    assert tied.youngs_modulus > 1.1 * held.youngs_modulus


@pytest.mark.parametrize("axial_modulus", [None, 2e9, 2.5e9])
@pytest.mark.parametrize("n_links", [20, 50])
def test_stiff_axial_springs_converge_wherever_the_shape_is(axial_modulus, n_links):
    """The convergence test scales with the stiffest spring (issue 35): with E_a = 1000 E the
    force residual's round-off floor (about eps k_s X, 1e-10 N for the USB at n = 20) is above
    1e-10 times the weight-and-bending force scale, so the equilibrium was reported as not
    converged after 500 iterations; moving the same job 0.3 m away raised the floor further.
    Now the tolerance is the larger of the two, and the shape moved is the moved shape."""
    from dloplan.sim.clips import ClipPoses
    from dloplan.sim.result import force_scale, residual_tolerance

    cable = catalogue_cable("usb", n_links=n_links, axial_modulus=axial_modulus)
    clips = level_clips(0.44)
    results = []
    for shift in ([0.0, 0.0, 0.0], [0.3, 0.2, 0.1]):
        moved = ClipPoses(clips.positions + shift, clips.rotations)
        guess = sagging_guess(cable, 0.44, -0.05) + shift
        eq = equilibrium(cable, guess, moved)
        assert eq.success, eq.message
        assert eq.iterations < 100
        results.append(eq.shape - shift)
        limit = residual_tolerance(cable, x=eq.shape)
        assert eq.residual <= limit
        # a tiny force still: at most a millionth of a point's weight plus k_b / l
        assert 1e-10 * force_scale(cable) <= limit < 1e-6 * force_scale(cable)
        # an explicit rtol is taken as asked
        assert residual_tolerance(cable, rtol=1e-12) == pytest.approx(1e-12 * force_scale(cable))
    # the same shape, translated (to well below a micrometre)
    assert abs(results[0] - results[1]).max() < 1e-7


def test_a_twisted_stiff_axial_cable_converges_too():
    """The torsion solver takes its tolerance from the same place (issue 35: with E_a = 1000 E
    the twist check reported success False although the shape was right)."""
    from scipy.spatial.transform import Rotation

    from dloplan.sim.clips import ClipPoses
    from dloplan.sim.torsion import equilibrium_with_twist

    cable = catalogue_cable("usb", n_links=20, axial_modulus=COMPOSITE_AXIAL_MODULI["usb"])
    clips = level_clips(0.44)
    twisted = ClipPoses(clips.positions + [0.3, 0.2, 0.1],
                        Rotation.concatenate([clips.rotations[0] * Rotation.from_euler(
                            "x", 60, degrees=True), clips.rotations[1]]))
    eq = equilibrium_with_twist(cable, sagging_guess(cable, 0.44, -0.05) + [0.3, 0.2, 0.1],
                                twisted)
    assert eq.success, eq.message
