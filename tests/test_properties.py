"""Property tests (hypothesis): the chain's kernels and the scenario parser on generated inputs.

Kernels: on random shapes of random cables (straight or curved rest shape, either bending
model), the gradient is the derivative of the energy (central differences, relative 1e-5: the
differences' truncation error is O(h^2) with h = 1e-6 of the link length), and the elastic
energy is invariant under rigid motions (to 1e-9 relative: round-off). Parser: any mapping built
from the scenario's keys either resolves or raises a one-line ScenarioError (never another
exception, never a multi-line message).
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from dloplan.app.resolve import resolve_scenario
from dloplan.app.schema import parse_scenario
from dloplan.cable import Cable
from dloplan.io.scenario import ScenarioError
from dloplan.physics import SpringChain, energy, gradient
from dloplan.physics.chain import energy_terms

cables = st.builds(
    lambda n, e, bending, curved: Cable(
        length=0.5, diameter=0.005, mass=0.02, youngs_modulus=e, n_links=n, bending=bending,
        rest_shape=_arc(n, 0.5, 1.2) if curved else None),
    st.integers(4, 14), st.floats(1e5, 1e10), st.sampled_from(["rod", "thesis"]), st.booleans())


def _arc(n: int, length: float, angle: float) -> np.ndarray:
    """A discrete arc whose links are exactly L/n long."""
    theta = np.linspace(0.0, angle, n + 1)
    radius = length / n / (2.0 * np.sin(angle / n / 2.0))
    return np.stack([radius * np.sin(theta), np.zeros(n + 1), radius * (1 - np.cos(theta))], 1)


def _shape(cable: Cable, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    steps = rng.normal(size=(cable.n_links, 3)) * 0.3 + [1.0, 0.0, 0.0]
    steps *= cable.rest_link_length * rng.uniform(0.9, 1.1, (cable.n_links, 1)) / \
        np.linalg.norm(steps, axis=1, keepdims=True)
    return np.vstack([np.zeros(3), np.cumsum(steps, axis=0)])


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cables, st.integers(0, 10_000))
def test_the_gradient_is_the_energys_derivative(cable, seed):
    chain = SpringChain.from_cable(cable)
    x = _shape(cable, seed)
    g = gradient(chain, x)
    h = 1e-6 * cable.rest_link_length
    numeric = np.zeros_like(x)
    for i in range(len(x)):
        for a in range(3):
            step = np.zeros_like(x)
            step[i, a] = h
            numeric[i, a] = (energy(chain, x + step) - energy(chain, x - step)) / (2 * h)
    scale = np.abs(g).max() + 1e-12
    assert np.abs(numeric - g).max() <= 1e-5 * scale


@settings(max_examples=40, deadline=None)
@given(cables, st.integers(0, 10_000), st.integers(0, 10_000))
def test_the_elastic_energy_is_invariant_under_rigid_motions(cable, seed, motion):
    chain = SpringChain.from_cable(cable)
    x = _shape(cable, seed)
    rng = np.random.default_rng(motion)
    moved = Rotation.random(random_state=motion).apply(x) + rng.normal(size=3)

    def elastic(shape):
        terms = energy_terms(chain, shape)
        return float(terms["axial"] + terms["bending"])

    assert abs(elastic(moved) - elastic(x)) <= 1e-9 * (abs(elastic(x)) + 1e-15)


numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**6, 10**6),
                    st.text(max_size=4), st.none())
vectors = st.lists(numbers, min_size=0, max_size=4)
shapes = st.fixed_dictionaries({"kind": st.sampled_from(["straight", "arc", "sine", "points",
                                                          "spiral"])},
                               optional={"angle": numbers, "amplitude": numbers,
                                         "periods": numbers,
                                         "points": st.lists(vectors, max_size=5),
                                         "placement": st.fixed_dictionaries(
                                             {}, optional={"position": vectors})})
scenarios = st.fixed_dictionaries(
    {"cable": st.fixed_dictionaries({}, optional={
        "name": st.sampled_from(["usb", "ethernet", "pu", "pa12", "copper"]),
        "n_links": numbers, "length": numbers, "youngs_modulus": numbers}),
     "start": shapes, "target": shapes},
    optional={"units": st.sampled_from(["m", "mm", "inch"]),
              "planner": st.fixed_dictionaries({}, optional={"n_shapes": numbers}),
              "obstacles": st.lists(st.fixed_dictionaries(
                  {"type": st.sampled_from(["box", "cylinder", "sphere"])},
                  optional={"center": vectors, "size": vectors, "base": vectors,
                            "radius": numbers, "height": numbers}), max_size=2),
              "trajectory": st.fixed_dictionaries({}, optional={"tcp_speed": numbers})})


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenarios)
def test_any_scenario_resolves_or_gives_one_line(data):
    try:
        job = resolve_scenario(parse_scenario(data, "gen.yaml"), "gen.yaml")
    except ScenarioError as exc:
        message = str(exc)
        assert message.startswith("gen.yaml: ") and "\n" not in message
    else:
        assert np.all(np.isfinite(job.start)) and np.all(np.isfinite(job.target))
        assert job.motion.tcp_speed > 0 and 4 <= job.cable.n_links <= 1000
