"""plan(): the three stages end to end, the Plan result, inputs, units, tuning families."""

from __future__ import annotations

import numpy as np
import pytest
from planning_cases import arc, folding_case

import dloplan
from dloplan.geometry import resample_by_arc_length
from dloplan.planning import (
    STAGES,
    AdvancedWeights,
    BasicWeights,
    FamilyBoundaries,
    PlannerWeights,
    plan,
    planner_weights,
    stiffness_family,
)

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_planning_pipeline")


@pytest.fixture(scope="module")
def folding_plan():
    cable, start, target = folding_case()
    return plan(cable, start, target, 5)


def test_plan_reproduces_the_thesis_length_behaviour(folding_plan):
    p = folding_plan
    assert p.success, p.message
    assert p.basic.shape == p.advanced.shape == p.physical.shape == (7, 11, 3)
    rel = p.lengths / p.cable.length
    assert rel[0, 3] < 0.7  # Table 4.2 basic: mid-path 0.66 L
    assert rel[1].min() > 0.95  # Table 4.2 advanced: the thesis reached 0.90 L
    np.testing.assert_allclose(rel[2], 1.0, atol=0.03)  # after the physical stage: 3 %
    assert set(p.timings) == {"target", "basic", "advanced", "physical", "stabilize", "total"}
    assert p.stabilized.shape == p.physical.shape and p.avoidance is None
    assert p.statuses["advanced"].n_variables == 5 * 11 * 3


def test_plan_force_statistics_drop_from_geometric_to_physical(folding_plan):
    geo = folding_plan.force_statistics("advanced")
    phys = folding_plan.force_statistics("physical")
    assert geo.axial_mean.shape == (11,)
    assert phys.axial_mean.mean() < 0.03 * geo.axial_mean.mean()
    assert phys.axial_variance.mean() < 1e-3 * geo.axial_variance.mean()
    assert phys.bending_variance.mean() < geo.bending_variance.mean()
    assert phys.bending_mean.max() < geo.bending_mean.max()
    with pytest.raises(ValueError, match="stage"):
        folding_plan.force_statistics("final")


def test_plan_in_millimetres_is_the_plan_in_metres_scaled():
    # the default ("equilibrium") pipeline; the thesis-mode LM stops on a flat cost at a
    # round-off-dependent point (2e-4 L apart between the units), see docs/planner.md
    for mode in ("equilibrium",):
        p_m = plan(*folding_case(), 5, physical_mode=mode)
        p_mm = plan(*folding_case(scale=1000.0), 5, physical_mode=mode,
                    gravity=(0.0, 0.0, -9810.0))
        for stage in STAGES:
            np.testing.assert_allclose(p_mm.stage(stage) / 1000.0, p_m.stage(stage),
                                       atol=1e-6 * p_m.cable.length)


def test_planar_and_resampled_inputs_go_through_the_same_code(folding_plan):
    cable, start, target = folding_case()
    planar = plan(cable, start[:, [0, 2]], target[:, [0, 2]], 5)
    np.testing.assert_array_equal(planar.path, folding_plan.path)
    fine = arc(cable.length, np.pi, 40, origin=(0.2 * cable.length, 0.0, 0.1 * cable.length))
    resampled = plan(cable, start, fine, 5)
    np.testing.assert_allclose(resampled.proposed_target,
                               resample_by_arc_length(fine, cable.n_points), atol=1e-15)
    assert resampled.path.shape == (7, 11, 3)


def test_a_3d_problem_and_other_sizes():
    cable = dloplan.catalogue_cable("pu", n_links=20)
    start = arc(cable.length, 0.0, 20)
    target = arc(cable.length, np.pi / 2, 20, origin=(0.1, 0.0, 0.1), heading=0.3)
    rot = np.array([[1, 0, 0], [0, np.cos(0.8), -np.sin(0.8)], [0, np.sin(0.8), np.cos(0.8)]])
    p = plan(cable, start, target @ rot.T, 8)
    assert p.success, p.message
    assert np.ptp(p.path[..., 1]) > 0.05  # really 3D
    np.testing.assert_allclose(p.lengths[2] / cable.length, 1.0, atol=0.03)


def test_stiffness_families_and_weights():
    families = {name: stiffness_family(dloplan.catalogue_cable(name).youngs_modulus)
                for name in dloplan.CATALOGUE_NAMES}
    assert families == {"usb": "soft", "ethernet": "medium", "pu": "medium", "pa12": "stiff"}
    assert stiffness_family(1e8, FamilyBoundaries(soft_below=1e6, stiff_from=5e7)) == "stiff"
    assert planner_weights(dloplan.catalogue_cable("pa12")) == planner_weights(family="stiff")
    custom = planner_weights(family="soft", overrides={"advanced": {"clip": 0.02}})
    assert custom.advanced.clip == 0.02
    assert custom.physical == planner_weights(family="soft").physical


def test_family_weights_shape_the_plan_only_in_the_thesis_physical_mode():
    """The family's Table 6.2 row weighs the thesis' physical cost; in the equilibrium mode
    every intermediate shape is an equilibrium whatever the weights (so the family only labels
    the cable, as the CLI says)."""
    cable, start, target = folding_case()
    paths = {(mode, family): plan(cable, start, target, 4, physical_mode=mode,
                                  weights=planner_weights(family=family)).path
             for mode in ("thesis", "equilibrium") for family in ("soft", "stiff")}
    assert np.abs(paths["thesis", "soft"] - paths["thesis", "stiff"]).max() > 1e-4
    assert np.abs(paths["equilibrium", "soft"] - paths["equilibrium", "stiff"]).max() < 1e-9


def test_user_weights_are_used():
    cable, start, target = folding_case()
    loose = plan(cable, start, target, 5, weights={"advanced": {"delta": 0.0, "clip": 0.0}})
    assert loose.weights.advanced.delta == 0.0
    # without the length terms the advanced stage has nothing against the basic path's shrinking
    assert loose.lengths[1, 3] < 0.75 * cable.length


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"n_shapes": 0}, "n_shapes"),
        ({"n_shapes": 2.5}, "n_shapes"),
        ({"physical_mode": "dynamic"}, "physical_mode"),
        ({"weights": 3}, "weights"),
        ({"weights": {"advanced": {"gamma": 1.0}}}, "overrides.advanced"),
        ({"weights": {"final": {}}}, "overrides"),
        ({"length_tolerance": -1.0}, "length_tolerance"),
        ({"target_tolerance": 0.0}, "target_tolerance"),
        ({"gravity": (0.0, 0.0, 0.0)}, "gravity"),
        ({"max_iterations": 0}, "max_iterations"),
    ],
)
def test_bad_arguments_name_themselves(kwargs, name):
    cable, start, target = folding_case()
    args = {"n_shapes": 5, **kwargs}
    with pytest.raises(ValueError, match=name):
        plan(cable, start, target, **args)


def test_bad_shapes_name_themselves():
    cable, start, target = folding_case()
    with pytest.raises(ValueError, match="cable"):
        plan("ethernet", start, target)
    bad = start.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="start"):
        plan(cable, bad, target)
    with pytest.raises(ValueError, match=r"target: the shape is .* long .*length_tolerance"):
        plan(cable, start, target * 0.8)
    with pytest.raises(ValueError, match="target"):
        plan(cable, start, np.zeros((11, 4)))
    doubled = start.copy()
    doubled[4] = doubled[5]
    with pytest.raises(ValueError, match="start: two consecutive points coincide"):
        plan(cable, doubled, target, length_tolerance=0.5)


def test_bad_weights_name_themselves():
    with pytest.raises(ValueError, match="weights.advanced.delta"):
        AdvancedWeights(delta=-1.0)
    with pytest.raises(ValueError, match="weights.basic.steps"):
        BasicWeights(steps=[1.0, 0.0])
    with pytest.raises(ValueError, match="weights.physical"):
        PlannerWeights(physical=3)
    with pytest.raises(ValueError, match="boundaries"):
        FamilyBoundaries(soft_below=1e9, stiff_from=1e8)
    with pytest.raises(ValueError, match="youngs_modulus"):
        stiffness_family(-1.0)
    with pytest.raises(ValueError, match="family"):
        planner_weights(family="rubber")
