"""Identification on shapes the model did not make (issue 19): independent elastica solutions.

The measured shapes come from a continuous, inextensible elastica, not from the chain model:
the shared reference solutions (tests/reference, a separate solve_bvp solver, see its README)
and, for moduli they do not cover (a USB cable's q L^3 / EI of about 2500), the heavy
cantilever solved here with ``scipy.integrate.solve_bvp`` (checked against the references to
1e-8). The truth is the continuum E = EI / I of the rod bending model. What must hold: the
identified E's 95 % interval covers it, or the identification says it could not (success
False): never a confident wrong value.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest
import yaml
from conftest import level_clips, load_reference
from scipy.integrate import solve_bvp
from scipy.spatial.transform import Rotation

from dloplan.app.identification import load_identification
from dloplan.cable import catalogue_cable
from dloplan.frames import frame_from_axis
from dloplan.geometry import resample_by_arc_length
from dloplan.identify import Experiment, Manipulation, identify_youngs_modulus
from dloplan.identify.report import FAILURE, exit_code
from dloplan.sim.clips import ClipPoses
from dloplan.vision.shapes_io import RegisteredShape, write_shapes

HEIGHT = 0.3


@cache
def heavy_cantilever(gamma: float, k: int = 2001) -> tuple[np.ndarray, np.ndarray]:
    """(x, z) at k points of a horizontally clamped heavy elastica, L = 1, EI = 1, q = gamma.

    theta'' = gamma (1 - s) cos(theta), theta(0) = 0, theta'(1) = 0, x' = cos, z' = sin;
    solved by continuation in gamma (doubling from 0.5).
    """
    s = np.linspace(0.0, 1.0, 2001)
    y = np.zeros((4, s.size))
    g = 0.5
    while True:
        g = min(gamma, 2 * g)
        sol = solve_bvp(
            lambda s, y, g=g: np.vstack([y[1], g * (1 - s) * np.cos(y[0]), np.cos(y[0]),
                                         np.sin(y[0])]),
            lambda a, b: np.array([a[0], b[1], a[2], a[3]]), s, y, tol=1e-8, max_nodes=200000)
        assert sol.success, sol.message
        s, y = sol.x, sol.y
        if g == gamma:
            break
    out = sol.sol(np.linspace(0.0, 1.0, k))
    return out[2], out[3]


@pytest.mark.parametrize("gamma", [1, 5, 10])
def test_the_local_elastica_solver_matches_the_references(gamma):
    ref = load_reference(f"cantilever_selfweight_gamma{gamma}")
    x, z = heavy_cantilever(float(gamma), ref["K"])
    assert np.abs(x - ref["x"]).max() < 1e-8 and np.abs(z - ref["z"]).max() < 1e-8


def cable_for(name: str, gamma: float, n: int):
    """A catalogue cable (rod model) whose E makes q L^3 / EI = gamma; and that E."""
    base = catalogue_cable(name, n_links=n)
    modulus = base.weight_per_length * base.length**3 / gamma / base.second_moment
    return base.with_modulus(modulus), modulus


def cantilever_experiment(cable, x, z, *, noise=1e-3, points=None, seed=0) -> Experiment:
    """The clip clamps the cable's end at (0, 0, HEIGHT), level, pointing along +x."""
    shape = np.stack([x * cable.length, np.zeros_like(x), HEIGHT + z * cable.length], axis=1)
    if points is not None:
        shape = resample_by_arc_length(shape, points)
    noisy = shape + np.random.default_rng(seed).normal(0.0, noise, shape.shape)
    along = frame_from_axis([1.0, 0.0, 0.0])[0]
    clips = ClipPoses(np.array([[0.0, 0.0, HEIGHT], [cable.length, 0.0, HEIGHT]]),
                      Rotation.concatenate([along, along]))
    start = [[0.0, 0.0, HEIGHT], [cable.length, 0.0, HEIGHT]]
    return Experiment(Manipulation(start, [clips], held="first"), noisy,
                      measurement_noise=max(noise, 1e-4))


def covers_or_refuses(result, truth) -> bool:
    if not result.success:
        return True
    lo, hi = result.confidence_interval
    return lo <= truth <= hi


# -- hoses: the shared references as measured shapes -------------------------------------------
@pytest.mark.parametrize("name,gamma", [("pa12", 1), ("pu", 5), ("ethernet", 10)])
@pytest.mark.parametrize("n", [16, 40])
def test_reference_cantilevers_are_identified_within_their_interval(name, gamma, n):
    ref = load_reference(f"cantilever_selfweight_gamma{gamma}")
    cable, truth = cable_for(name, float(gamma), n)
    experiment = cantilever_experiment(cable, np.asarray(ref["x"]), np.asarray(ref["z"]),
                                       seed=gamma)
    result = identify_youngs_modulus(cable.with_modulus(1e7), experiment)
    assert result.success, result.message
    lo, hi = result.confidence_interval
    assert lo <= truth <= hi
    # the interval is the discretization's (first order in 1/n), not a blanket one
    assert math.log(hi / lo) < (0.45 if n == 16 else 0.2)


@pytest.mark.parametrize("variant", ["n40", "limit"])
def test_clamped_ethernet_reference_is_identified(variant):
    # the dual-arm hold: clips level, 0.4 m apart; n40 is the continuum solution of the very
    # set-up the 40-link model describes (half links outside the clips), limit the cable
    # clamped at its ends. The references are inextensible, as the catalogue Ethernet with its
    # copper axial modulus (the default) is.
    ref = load_reference(f"clamped_ethernet_D0.4_{variant}")
    cable, truth = cable_for("ethernet", ref["q"] * 0.5**3 / ref["EI"], 40)
    assert cable.stiff_axial
    shape = np.stack([ref["x"], np.zeros(ref["K"]), HEIGHT + np.asarray(ref["z"])], axis=1)
    noisy = shape + np.random.default_rng(1).normal(0.0, 1e-3, shape.shape)
    manipulation = Manipulation(shape, [level_clips(0.4, HEIGHT)], held="both")
    result = identify_youngs_modulus(cable, Experiment(manipulation, noisy))
    assert covers_or_refuses(result, truth)
    if variant == "n40":
        # the sag hardly depends on E here (95 % interval a factor 35 wide): 1 mm of noise moves
        # the estimate by 10 % (seeds 1-4: -10.0, -4.3, -4.6, -3.5 %, the same with E_a = E);
        # without noise the 40-link chain is 4.4 % off the continuum it discretizes
        assert result.success
        clean = identify_youngs_modulus(cable, Experiment(manipulation, shape,
                                                          measurement_noise=1e-4))
        assert clean.success and clean.youngs_modulus == pytest.approx(truth, rel=0.06)


def test_clamped_pu_hose_reference_is_refused_as_uninformative():
    ref = load_reference("clamped_pu_D0.4_n40")
    cable, _ = cable_for("pu", ref["q"] * 0.5**3 / ref["EI"], 40)
    shape = np.stack([ref["x"], np.zeros(ref["K"]), HEIGHT + np.asarray(ref["z"])], axis=1)
    noisy = shape + np.random.default_rng(2).normal(0.0, 1e-3, shape.shape)
    manipulation = Manipulation(shape, [level_clips(0.4, HEIGHT)], held="both")
    result = identify_youngs_modulus(cable, Experiment(manipulation, noisy))
    assert not result.success and exit_code(result) == FAILURE


# -- the soft-cable cases ---------------------------------------------------------------
USB_GAMMA = 2466.0  # q L^3 / EI of the catalogue USB cable (rod model, E = 2.5 MPa)
ETHERNET_GAMMA = 106.6


def test_usb_cantilever_markers_at_n16_are_not_silently_wrong():
    # issue 19: 92 % low with success=True, even without noise (31 mm links, a ~10 mm bend)
    cable, truth = cable_for("usb", USB_GAMMA, 16)
    x, z = heavy_cantilever(USB_GAMMA)
    for noise in (0.0, 1e-3):
        experiment = cantilever_experiment(cable, x, z, noise=noise, points=cable.n_points)
        result = identify_youngs_modulus(cable.with_modulus(1e7), experiment)
        assert covers_or_refuses(result, truth), result.message


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_usb_cantilever_at_n50_interval_covers_the_truth(seed):
    # issue 19: 5 % high with a +-2.4 % interval that missed the truth in 3 of 3 seeds
    cable, truth = cable_for("usb", USB_GAMMA, 50)
    x, z = heavy_cantilever(USB_GAMMA)
    experiment = cantilever_experiment(cable, x, z, points=51, seed=seed)
    result = identify_youngs_modulus(cable.with_modulus(1e7), experiment)
    assert covers_or_refuses(result, truth), result.message


@pytest.mark.parametrize("name,gamma,tolerance", [("ethernet", ETHERNET_GAMMA, 0.03),
                                                  ("usb", USB_GAMMA, None)])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_dense_registered_points_are_not_biased_by_their_noise(name, gamma, tolerance, seed):
    # issue 19: 300 registered points with 1 mm noise, resampled by arc length, gave Ethernet
    # 2-3 % off with intervals that missed the truth, USB -9 to +16 %, all "successes"
    cable, truth = cable_for(name, gamma, 16)
    x, z = heavy_cantilever(gamma)
    experiment = cantilever_experiment(cable, x, z, points=300, seed=seed)
    result = identify_youngs_modulus(cable.with_modulus(1e7), experiment)
    assert result.success, result.message
    lo, hi = result.confidence_interval
    assert lo <= truth <= hi
    if tolerance is not None:
        assert result.youngs_modulus == pytest.approx(truth, rel=tolerance)


def test_a_registered_shape_file_feeds_the_identification(tmp_path):
    # the vision tools' CSV, named by an identification file next to it
    cable, truth = cable_for("ethernet", ETHERNET_GAMMA, 16)
    x, z = heavy_cantilever(ETHERNET_GAMMA)
    experiment = cantilever_experiment(cable, x, z, points=300, seed=5)
    write_shapes(tmp_path / "shapes.csv",
                 [RegisteredShape(experiment.measured_shape, "robot_base", "xi_f"),
                  RegisteredShape(experiment.measured_shape[::2], "robot_base", "other")])
    clip = {"position": [0.0, 0.0, HEIGHT], "u": [1, 0, 0]}
    data = {"version": 1, "units": "m",
            "cable": {"name": "ethernet", "n_links": 16, "youngs_modulus": "identify"},
            "identify": {"held": "first", "measurement_noise": 0.001,
                         "initial_shape": [[0, 0, HEIGHT], [0.5, 0, HEIGHT]],
                         "trajectory": [{"first": clip, "last": clip}],
                         "measured_file": {"path": "shapes.csv", "label": "xi_f"}}}
    (tmp_path / "ident.yaml").write_text(yaml.safe_dump(data))
    job = load_identification(tmp_path / "ident.yaml")
    assert np.allclose(job.experiment.measured_shape, experiment.measured_shape, atol=1e-9)
    result = identify_youngs_modulus(cable_for("ethernet", ETHERNET_GAMMA, 16)[0],
                                     job.experiment)
    lo, hi = result.confidence_interval
    assert result.success and lo <= truth <= hi
    data["identify"]["measured_file"] = {"path": "shapes.csv"}  # two shapes: which one?
    (tmp_path / "ident.yaml").write_text(yaml.safe_dump(data))
    with pytest.raises(ValueError, match="measured_file.label: .* holds 2 shapes"):
        load_identification(tmp_path / "ident.yaml")


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("n", [16, 24])
def test_ethernet_cantilever_markers_at_coarse_n_interval_covers_the_truth(n, seed):
    # issue 35: at n = 16 E came out 3.4-3.7 % high with 95 % intervals that missed the truth:
    # the interval's discretization term, 2 |ln E(n) - ln E(2n)|, put the first-order
    # extrapolate E(inf) on its very edge; 3 |...| leaves room for the noise and higher orders
    cable, truth = cable_for("ethernet", ETHERNET_GAMMA, n)
    x, z = heavy_cantilever(ETHERNET_GAMMA)
    experiment = cantilever_experiment(cable, x, z, points=cable.n_points, seed=seed)
    result = identify_youngs_modulus(cable.with_modulus(1e7), experiment)
    assert covers_or_refuses(result, truth), result.message
