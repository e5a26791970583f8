"""The correction on a plant that is not dloplan's model: dismech-newton's discrete elastic rod
(issue 35).

Optional: skipped with the reason when ``dismech-newton`` is not installed (``pip install
dloplan[plants]``; ``make test`` installs it). The plant (``tests/plants.py``) is a discrete
elastic rod (Bergou et al. 2008) of 100 edges solved by dismech-newton on the CPU (NVIDIA Warp
kernels, float32 positions), each gripper prescribing its clamped edges with their twist, a
static solve at every clip pose; nothing of dloplan's physics is in it. The import takes about
3 s of CPU (its Warp kernels compile once, minutes, then load from ``~/.cache/warp``): one
module-scoped fixture.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import level_clips, sagging_guess
from plants import DismechPlant, assert_demo_corrected, import_dismech

from dloplan.cable import Cable, catalogue_cable
from dloplan.correct import Plant

# one worker imports dismech-newton and runs its Warp kernels (make test: --dist loadgroup): on a
# machine whose ~/.cache/warp is empty (a new CI machine) both workers compiled every kernel at
# the same moment, about 30 s of CPU each at load 6 (docs/performance.md, branch testtime5)
pytestmark = pytest.mark.xdist_group("test_dismech_plant")


@pytest.fixture(scope="module")
def dismech_plant():
    """The plant class, dismech-newton imported once (skipped when it is missing)."""
    pytest.importorskip("warp", reason="the dismech plant needs pip install dloplan[plants]")
    try:
        import_dismech()
    except ImportError as exc:  # pragma: no cover - the extra is installed by make test
        pytest.skip(f"the dismech plant needs pip install dloplan[plants]: {exc}")
    return DismechPlant


@pytest.mark.parametrize("clamped", [1, 3])
def test_the_rod_clamped_at_both_ends_sags_as_euler_bernoulli(dismech_plant, clamped):
    """A closed form for the plant itself: a stiff rod (E 2.2 GPa, d 5 mm, 0.3 m, 10 g) held
    level by clamps of 1 and 3 edges sags w S^4 / (384 EI) at mid-span, S the span between the
    continuum clamps (half an edge inside the last clamped node: the curvature of a node is
    spread over the half edges on either side). Within 0.3 %: the discretization error at
    h = 3 mm is O(h^2 / S^2) ~ 1e-4, the rod stretching under its sag of 0.1 mm (0.08 of its
    radius of gyration) stiffens it by < 1e-3, float32 positions resolve 1e-8 m of 1e-4 m."""
    cable = Cable(length=0.3, diameter=0.005, mass=0.01, youngs_modulus=2.2e9, n_links=100)
    h = cable.rest_link_length
    distance = cable.length - clamped * h  # the clamps centred on the clips
    plant = dismech_plant(cable, clamp=clamped * h, tolerance=1e-8)
    rest, ok, message = plant.hold(sagging_guess(cable, distance, -1e-4),
                                   level_clips(distance, 0.0))
    assert ok, message
    span = cable.length - 2 * (clamped - 0.5) * h
    exact = cable.weight_per_length * span**4 / (
        384 * cable.youngs_modulus * cable.second_moment)
    assert -rest[:, 2].min() == pytest.approx(exact, rel=3e-3)


def test_the_rod_at_rest_is_the_models_equilibrium_at_fine_n(dismech_plant):
    """Against our model at fine n: the Ethernet cable (E_a = E, as the model's default) hanging
    11 cm between level clips 0.4 m apart, each clamping 25 mm, is the chain's equilibrium at the
    same 100 links to 0.05 mm mean (measured 0.009 mm): both discretize the same extensible
    elastica at h = 5 mm, their O(h^2) errors (different curvature and mass lumping) are
    micrometres; the rod's Newton tolerance is 0.01 mm."""
    cable = catalogue_cable("ethernet", n_links=100)
    clips = level_clips(0.40, 0.3)
    guess = sagging_guess(cable, 0.40, -0.05) + [0.0, 0.0, 0.3]
    rest, ok, message = dismech_plant(cable, clamp=0.025).hold(guess, clips)
    assert ok, message
    model, stable, _ = Plant(cable, clamp=0.025).hold(guess, clips)
    assert stable
    distance = np.linalg.norm(rest - model, axis=1)
    assert np.mean(distance) < 5e-5
    assert np.max(distance) < 1e-4
    assert rest[:, 2].min() < 0.3 - 0.1  # a large sag, not a small-load case


def test_a_correction_on_the_rod_is_verified_and_its_interval_holds(dismech_plant, tmp_path):
    """The sagging demo at its own n (12) run on the rod at E x2 (100 edges, each gripper
    clamping one model link, 8 edges): one correction at mid-path at least halves the final
    error, its prediction interval holds the plant's, and the corrected plan passes every check
    `dloplan verify` runs, or is refused naming the check."""
    assert_demo_corrected(tmp_path, lambda cable: dismech_plant(
        cable.with_links(100).with_modulus(2 * cable.youngs_modulus), noise=1e-3,
        n_measured=200, seed=1, clamp=cable.rest_link_length))
