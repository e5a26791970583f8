"""The implicit replay step on a cable whose section shortens (a harness tensioning), as physics.

The section's links all get shorter (``simulate(cable_at=...)``), so its mass points move
through the material: point i's material coordinate is (i - n/2) l(t). Friction acts on the
material (sim.stepping.implicit_steps, the ALE drift):

* a cable lying on a table while its section shortens and its clips follow the material (so
  the material does not move): friction has nothing to hold, the run with friction is the
  frictionless run, the links carry no tension and the points end where their material is.
  Without the correction the sticking points held the mesh, not the material: 0.3 mm off and
  0.25 N in the links (measured);
* a cable lying on a table in an arc while its section is pulled through fixed clips (the
  material slides on the table with friction): the peak tension converges as dt is halved
  (2, 1, 0.5 ms) to the explicit scheme's, and the settled shapes agree to 0.1 mm.
"""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dloplan.cable import GRAVITY, catalogue_cable
from dloplan.harness.section import section_cable
from dloplan.obstacles import Table
from dloplan.physics.chain import SpringChain, link_tensions
from dloplan.sim.clips import ClipPoses, clip_poses_from_shape
from dloplan.sim.dynamics import ClipTrajectory, simulate

# one worker (make test: --dist loadgroup): its module-scoped runs are made once
pytestmark = pytest.mark.xdist_group("test_implicit_section")

WHOLE = catalogue_cable("usb", 8)  # the USB cable with its copper's axial modulus
RADIUS = WHOLE.diameter / 2
N_LINKS = 16
FACING = Rotation.from_rotvec([[0, 0, 0], [0, 0, math.pi]])


def _shortening(pull: float, duration: float):
    """``cable_at`` of a section pulled ``pull`` [m] through each fixture over ``duration``
    [s] (:func:`_pulled`), one cable object per offset."""
    made = {}

    def cable_at(t: float):
        d = _pulled(pull, min(t, duration) / duration)
        if d not in made:
            made[d] = section_cable(WHOLE, N_LINKS, d)
        return made[d]

    return cable_at


def _pulled(pull: float, u: float) -> float:
    """The offset [m] pulled through each fixture at the fraction u of the pull's duration,
    along a smoothstep (no jump in the material's speed)."""
    return pull * u * u * (3.0 - 2.0 * u)


def _tensions(run, cable_at) -> np.ndarray:
    """(R, n) link tensions [N] of the recorded shapes, each with the cable of its time."""
    return np.array([link_tensions(SpringChain.from_cable(cable_at(t), GRAVITY), x)
                     for t, x in zip(run.times, run.shapes, strict=True)])


@pytest.mark.parametrize("friction", [0.5, 5.0])
def test_friction_holds_the_material_not_the_mesh_of_a_shortening_section(friction):
    pull, duration = 0.02, 1.0
    cable_at = _shortening(pull, duration)
    start = cable_at(0.0)
    x = np.zeros((N_LINKS + 1, 3))
    x[:, 0] = (np.arange(N_LINKS + 1) - N_LINKS / 2) * start.rest_link_length
    x[:, 2] = RADIUS

    def clips_at(d):  # the clip points (middles of the end links) on the same material
        half = 0.5 * (WHOLE.length - WHOLE.rest_link_length) - d
        return ClipPoses(np.array([[-half, 0, RADIUS], [half, 0, RADIUS]]), FACING)

    times = np.linspace(0.0, duration, 1001)
    clips = ClipTrajectory(times, [clips_at(_pulled(pull, t / duration)) for t in times])
    run = simulate(start, x, clips, duration=duration + 0.2, dt=1e-3, contacts=[Table()],
                   friction=friction, damping="relative", scheme="implicit", cable_at=cable_at)
    end = cable_at(duration)
    material = np.zeros_like(x)  # the points' material, which has not moved
    material[:, 0] = (np.arange(N_LINKS + 1) - N_LINKS / 2) * end.rest_link_length
    material[:, 2] = RADIUS
    np.testing.assert_allclose(run.shapes[-1], material, atol=1e-9)
    # no tangential contact force, so no tension in the links: 1.5e-6 N measured; friction on
    # the mesh points loads them to its capacity, 0.0095 N for mu = 0.5 and 0.094 N for 5
    assert np.max(np.abs(_tensions(run, cable_at))) < 1e-4


@pytest.fixture(scope="module")
def arc_runs():
    """A section lying on a table in an arc (3 cm longer than its chord) between fixed clips,
    pulled 1 cm through each over 1 s (smoothstep), friction 0.5: implicit at 2, 1 and 0.5 ms
    and the explicit reference at its own step."""
    cable_at = _shortening(0.01, 1.0)
    start = cable_at(0.0)
    half_angle = math.sqrt(6.0 * 0.03 / start.length)
    r = start.length / (2.0 * half_angle)
    angle = (np.arange(N_LINKS + 1) - N_LINKS / 2) * 2.0 * math.asin(
        start.rest_link_length / (2.0 * r))  # chords of the rest length: unstretched
    x = np.stack([r * np.sin(angle), r * (np.cos(angle) - math.cos(half_angle)),
                  np.full_like(angle, RADIUS)], axis=1)
    runs = {}
    for dt in (2e-3, 1e-3, 5e-4, None):
        run = simulate(start, x, clip_poses_from_shape(x), duration=1.5, dt=dt,
                       contacts=[Table()], friction=0.5, damping="relative",
                       scheme="explicit" if dt is None else "implicit", cable_at=cable_at,
                       record_interval=1e-3)
        runs[dt] = run, float(np.max(_tensions(run, cable_at)))
    return runs


def test_the_peak_tension_of_a_section_pulled_over_a_table_converges_with_dt(arc_runs):
    # measured: 2.3785, 2.3780, 2.3780 N at 2, 1, 0.5 ms; explicit 2.3773 N (the links' tension
    # at the end of the pull; the arc's sag went from 73 mm to 15.7 mm). The old step held the
    # mesh points, not the material: its peaks grew as 1/dt on the harness tensioning
    peaks = [arc_runs[dt][1] for dt in (2e-3, 1e-3, 5e-4)]
    explicit = arc_runs[None][1]
    assert abs(peaks[2] - peaks[1]) < 0.5 * abs(peaks[1] - peaks[0])  # converging
    assert peaks == pytest.approx([explicit] * 3, rel=1e-3)
    # the settled shapes: 0.033, 0.019, 0.038 mm from the explicit one (the two friction
    # models differ where the cable comes to rest, tests/test_implicit_contacts.py)
    reference = arc_runs[None][0].shapes[-1]
    for dt in (2e-3, 1e-3, 5e-4):
        assert np.max(np.linalg.norm(arc_runs[dt][0].shapes[-1] - reference, axis=1)) < 1e-4
