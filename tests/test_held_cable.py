"""The held cable as physics: contact curvature, the constrained Hessian, a wrap on a peg, the
stub a fixture holds alone, hard contacts and a changing cable in the simulator.

Each test names its reference (a finite difference, a closed form, the static solver) and why
its tolerance is what it is.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dloplan.cable import Cable
from dloplan.harness import Fixture
from dloplan.harness.held import stub_sag
from dloplan.harness.section import section_cable
from dloplan.obstacles import Box, Cylinder, Table
from dloplan.physics.chain import SpringChain, link_tensions
from dloplan.physics.contact import contact_gradient, contact_hessian_blocks
from dloplan.physics.contact_compiled import point_distance, push_out, signed_distances
from dloplan.sim.clips import ClipPoses
from dloplan.sim.dynamics import ClipTrajectory, simulate
from dloplan.sim.statics import equilibrium
from dloplan.verify.contacts import BoardContacts, contact_states
from dloplan.verify.stability import constrained_hessian, elastic_stability

OBSTACLES = (Box((0.1, 0.0, 0.05), (0.08, 0.12, 0.1), 0.4, "box"),
             Cylinder((0.0, 0.0, 0.0), 0.012, 0.06, "peg"), Table(0.0))


def _central(f, x: np.ndarray, h: float) -> np.ndarray:
    """Central differences of a per-point vector field f (m, 3) -> (m, 3): (m, 3, 3)."""
    out = np.zeros(x.shape + (3,))
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        out[..., :, j] = (f(x + e) - f(x - e)) / (2 * h)
    return out


def _away_from_kinks(obstacle, points, margin=2e-4):
    """Points whose distance is not within ``margin`` of an edge of the obstacle's distance
    field (where its second derivative jumps: face regions meeting, the inside's medial
    planes): there a central difference straddles two formulas."""
    h = 1e-6
    keep = []
    for p in points:
        hess = obstacle.distance_hessian(p[None])[0]
        probes = p + margin * np.vstack([np.eye(3), -np.eye(3)])
        same = np.allclose(obstacle.distance_hessian(probes), hess, atol=1e-3 / margin)
        keep.append(same and np.all(np.abs(obstacle.signed_distance(p[None])[0]) > h))
    return points[np.array(keep)]


@pytest.mark.parametrize("obstacle", OBSTACLES, ids=lambda o: o.name)
def test_the_distance_hessian_is_the_derivative_of_the_normal(obstacle, rng):
    """grad^2 phi against central differences of the normal (h = 1e-6 m: truncation h^2
    phi''' ~ 1e-12 / rho^3, round-off eps / h ~ 1e-10; 1e-5 relative to the largest
    curvature 1/rho ~ 1e2 1/m leaves room for both)."""
    centre = np.asarray(getattr(obstacle, "center", getattr(obstacle, "base", (0, 0, 0))))
    points = _away_from_kinks(obstacle, centre + 0.05 * rng.normal(size=(300, 3)))
    assert len(points) > 150
    exact = obstacle.distance_hessian(points)
    numeric = _central(lambda p: obstacle.signed_distance(p)[1], points, 1e-6)
    scale = max(1.0, float(np.abs(exact).max()))
    assert np.abs(exact - numeric).max() < 1e-5 * scale


def test_the_contact_blocks_are_the_derivative_of_the_contact_gradient(rng):
    """k_c (n n^T - d grad^2 phi) against central differences of the penalty's gradient, on
    points pressing on every obstacle (relative 1e-6: as above, scaled by k_c)."""
    points = np.concatenate([_away_from_kinks(o, np.asarray(c) + 0.004 * rng.normal(size=(80, 3)))
                             for o, c in zip(OBSTACLES, ((0.1, 0.065, 0.05), (0.0, 0.013, 0.03),
                                                         (0.05, 0.05, 0.001)), strict=True)])
    radius, k_c = 0.0015, 1e4
    pressing = sum((radius - o.signed_distance(points)[0] > 1e-5) for o in OBSTACLES)
    assert pressing.sum() > 50
    exact = contact_hessian_blocks(points, OBSTACLES, radius, k_c)
    numeric = _central(lambda p: contact_gradient(p, OBSTACLES, radius, k_c), points, 1e-7)
    assert np.abs(exact - numeric).max() < 1e-6 * k_c * 100


class _Counted:
    """An obstacle that records how many points its distance Hessian was asked at."""

    def __init__(self, obstacle):
        self.obstacle, self.name, self.asked = obstacle, obstacle.name, 0

    def signed_distance(self, points):
        return self.obstacle.signed_distance(points)

    def distance_hessian(self, points):
        self.asked += int(np.prod(points.shape[:-1]))
        return self.obstacle.distance_hessian(points)


def test_the_boards_penalty_of_many_shapes_is_each_shapes_own_curvature_at_pressing_points(rng):
    """BoardContacts.at of M shapes, a stiffness per shape: its blocks are
    contact_hessian_blocks of each shape bit for bit, and the obstacles' curvatures are taken at
    the pressing points only (the others' blocks are zero)."""
    radius, stiffness = 0.0015, np.array([1e4, 3e4, 2e4])
    near = [np.asarray(c) + 0.004 * rng.normal(size=(3, 12, 3))
            for c in ((0.1, 0.065, 0.05), (0.0, 0.013, 0.03), (0.05, 0.05, 0.001))]
    shapes = np.concatenate(near + [np.full((3, 4, 3), 0.5)], axis=1)  # 4 points clear
    counted = tuple(_Counted(o) for o in OBSTACLES)
    board = BoardContacts.at(shapes, counted, radius, stiffness)
    for b, x in enumerate(shapes):
        assert np.array_equal(board.blocks[b],
                              contact_hessian_blocks(x, OBSTACLES, radius, stiffness[b]))
    pressing = [(radius - o.signed_distance(shapes)[0] > 0).sum() for o in OBSTACLES]
    assert [c.asked for c in counted] == pressing
    assert 0 < sum(pressing) < len(OBSTACLES) * shapes.shape[0] * shapes.shape[1]


def test_the_compiled_distances_are_the_volumes_own(rng):
    """The simulator's contact kernel measures what ``signed_distance`` measures (round-off)."""
    points = np.ascontiguousarray(0.05 * rng.normal(size=(2000, 3)) + [0.03, 0.0, 0.03])
    rows = np.stack([o.contact_row() for o in OBSTACLES])
    phi, normals = np.empty((3, len(points))), np.empty((3, len(points), 3))
    signed_distances(points, rows, phi, normals)
    for k, obstacle in enumerate(OBSTACLES):
        own_phi, own_normal = obstacle.signed_distance(points)
        assert np.abs(phi[k] - own_phi).max() < 1e-15
        assert np.abs(normals[k] - own_normal).max() < 1e-14


@pytest.mark.parametrize("spread", [0.002, 0.05])
def test_the_hard_contact_skips_only_obstacles_it_cannot_reach(rng, spread):
    """The explicit step's hard contact (``push_out``) passes over an obstacle whose bounding
    box is farther than the radius from the points' bounding box: the points it puts back,
    and where, are those of a plain loop over every point and obstacle (exactly): a cloud of
    points a few millimetres across (most obstacles skipped) and one spread over all of them."""
    radius = 0.004
    rows = np.stack([o.contact_row() for o in OBSTACLES])
    for centre in ([0.1, 0.0, 0.05], [0.0, 0.01, 0.03], [0.03, 0.0, 0.003], [0.3, 0.3, 0.3]):
        points = np.ascontiguousarray(spread * rng.normal(size=(60, 3)) + centre)
        x, v, accel = points.copy(), np.zeros_like(points), np.zeros_like(points)
        push_out(x, v, accel, rows, radius, 0.0, 0, len(x))
        plain = points.copy()
        for k in range(len(rows)):
            phi, normals = np.empty((1, len(plain))), np.empty((1, len(plain), 3))
            signed_distances(plain, rows[k : k + 1], phi, normals)
            inside = phi[0] < radius
            plain[inside] += (radius - phi[0, inside])[:, None] * normals[0, inside]
        np.testing.assert_array_equal(x, plain)



def _pushed_out_plainly(x, v, accel, rows, radius, friction):
    """The hard contact of every point with every obstacle row, in order, as ``push_out``'s
    docstring states it: no point or obstacle passed over (the reference)."""
    x, v, accel = x.copy(), v.copy(), accel.copy()
    for row in rows:
        for i in range(len(x)):
            phi, *normal = point_distance(x[i, 0], x[i, 1], x[i, 2], row)
            if phi >= radius:
                continue
            n = np.array(normal)
            x[i] += (radius - phi) * n
            inward = v[i, 0] * n[0] + v[i, 1] * n[1] + v[i, 2] * n[2]
            if inward < 0.0:
                v[i] -= inward * n
                slip = math.sqrt(v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2)
                if friction > 0.0 and slip > 0.0:
                    v[i] *= max(0.0, 1.0 - friction * (-inward) / slip)
            pressed = accel[i, 0] * n[0] + accel[i, 1] * n[1] + accel[i, 2] * n[2]
            if pressed < 0.0:
                accel[i] -= pressed * n
                along = math.sqrt(accel[i, 0] ** 2 + accel[i, 1] ** 2 + accel[i, 2] ** 2)
                if along <= friction * (-pressed):
                    accel[i] = 0.0
    return x, v, accel


@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_the_hard_contact_passes_over_only_points_no_obstacle_reaches(rng, friction):
    """``push_out`` measures a point's distance to an obstacle only when the point lies within
    the radius of the obstacle's bounding box: its positions, velocities and accelerations
    equal a plain loop over every point and obstacle bit for bit, on a cable-like row of
    points running past the peg, over the box and down to the table (some points near each
    obstacle, most far from it), moving and pulled every way."""
    radius = 0.004
    rows = np.stack([o.contact_row() for o in OBSTACLES])
    s = np.linspace(0.0, 1.0, 80)[:, None]
    line = (1.0 - s) * [-0.05, 0.0, 0.03] + s * [0.2, 0.05, 0.003]
    for _ in range(20):
        x = np.ascontiguousarray(line + 0.01 * rng.normal(size=line.shape))
        v, accel = rng.normal(size=x.shape), rng.normal(size=x.shape)
        expected = _pushed_out_plainly(x, v, accel, rows, radius, friction)
        got = x.copy(), v.copy(), accel.copy()
        push_out(*got, rows, radius, friction, 0, len(x))
        assert np.any(got[0] != x)  # some points were put back
        for mine, plain in zip(got, expected, strict=True):
            np.testing.assert_array_equal(mine, plain)

def _string(n_links: int = 40) -> Cable:
    """A string: bending a million times softer than usual, so that tension dominates."""
    return Cable(length=0.5, diameter=0.003, mass=0.01, youngs_modulus=2.5,
                 axial_modulus=2.5e7, n_links=n_links)


def _over_a_peg(cable: Cable):
    """The cable held by two level clips on the x-axis, around a peg 5 cm off their chord:
    the route around the peg is 0.5 mm longer than the cable between the clip points, so it
    is pulled taut against it."""
    peg = Cylinder((0.0, 0.05, -0.05), 0.012, 0.1, "peg")
    reach = 0.5 * (cable.length - cable.rest_link_length) + 0.00025
    half = math.sqrt(reach ** 2 - (0.05 + 0.012 + cable.diameter / 2) ** 2)
    clips = ClipPoses(np.array([[-half, 0.0, 0.0], [half, 0.0, 0.0]]),
                      Rotation.from_euler("z", [[0.0], [180.0]], degrees=True))
    s = np.linspace(0, 1, cable.n_points)
    guess = np.stack([np.linspace(-half - cable.rest_link_length / 2,
                                  half + cable.rest_link_length / 2, cable.n_points),
                      0.09 * np.sin(np.pi * s), np.zeros_like(s)], axis=1)
    return peg, clips, guess


def test_the_constrained_hessian_is_the_derivative_of_the_gradient_over_the_free_points():
    """With a peg pressing, the constrained Hessian over points 2..n-2 against central
    differences of the energy gradient (contact curvature included; h = 1e-8 m keeps every
    pressing point pressing; relative 1e-5 of the largest entry, 100 k_s)."""
    cable = replace(_string(), youngs_modulus=2.5e5)
    peg, clips, guess = _over_a_peg(cable)
    eq = equilibrium(cable, guess, clips, gravity=np.zeros(3), contacts=(peg,))
    assert contact_states(cable, eq.shape, (peg,))[0].active
    grad, band = constrained_hessian(cable, eq.shape, gravity=np.zeros(3), contacts=(peg,))
    from dloplan.physics.chain import band_to_sparse

    exact = band_to_sparse(band).toarray()
    free = slice(2, cable.n_points - 2)
    h = 1e-8
    numeric = np.zeros_like(exact)
    x0 = eq.shape.ravel()
    for j in range(exact.shape[0]):
        dx = np.zeros_like(x0)
        dx[3 * free.start + j] = h
        up = constrained_hessian(cable, (x0 + dx).reshape(-1, 3), gravity=np.zeros(3),
                                 contacts=(peg,))[0]
        down = constrained_hessian(cable, (x0 - dx).reshape(-1, 3), gravity=np.zeros(3),
                                   contacts=(peg,))[0]
        numeric[:, j] = ((up - down)[free] / (2 * h)).ravel()
    assert np.abs(exact - numeric).max() < 1e-5 * np.abs(exact).max()
    # and the solver's residual: an equilibrium with the peg
    assert np.abs(grad[free]).max() < 1e-6


def test_a_string_wrapped_on_a_frictionless_peg_carries_one_tension_and_presses_2T_sin():
    """Frictionless wrap: the tension is the same on both sides of the peg (capstan with
    mu = 0) and the peg pushes with 2 T sin(theta / 2), theta the angle between the straight
    parts. Tolerance 1 %: the residual bending of the soft string and the penalty's
    penetration (F / k_c ~ 1e-7 m) bend the straight parts by less."""
    cable = _string()
    peg, clips, guess = _over_a_peg(cable)
    eq = equilibrium(cable, guess, clips, gravity=np.zeros(3), contacts=(peg,))
    x = eq.shape
    tensions = link_tensions(SpringChain.from_cable(cable, np.zeros(3)), x)
    inner = tensions[1:-1]
    assert inner.min() > 0 and (inner.max() - inner.min()) < 0.01 * inner.max()
    first = x[2] - x[1]
    last = x[-2] - x[-3]
    cos = first @ last / (np.linalg.norm(first) * np.linalg.norm(last))
    theta = math.acos(np.clip(cos, -1, 1))
    state = contact_states(cable, x, (peg,))[0]
    assert state.force == pytest.approx(2 * inner.mean() * math.sin(theta / 2), rel=0.01)


def test_the_sticking_eigenvalue_bounds_the_frictionless_one_from_above():
    """Holding the pressing points removes coordinates: by Cauchy's interlacing theorem the
    smallest eigenvalue can only rise."""
    cable = replace(_string(), youngs_modulus=2.5e5)
    peg, clips, guess = _over_a_peg(cable)
    eq = equilibrium(cable, guess, clips, gravity=np.zeros(3), contacts=(peg,))
    stab = elastic_stability(cable, eq.shape, gravity=np.zeros(3), contacts=(peg,))
    assert stab.contacts[0].active
    assert stab.sticking >= stab.smallest - 1e-12 * abs(stab.smallest)
    assert stab.stable_with_friction


def test_the_stub_a_fixture_holds_alone_sags_as_a_clamped_cantilever():
    """While the grippers regrasp, the cable beyond a fixture is a cantilever clamped in the
    slot: its end sags q a^4 / (8 E I) (Euler-Bernoulli, q its weight per length; small: 4 %
    of a). As everywhere in the chain the clamp acts at the held link's middle, the clip point
    (docs/verification.md, Euler buckling): a = the free length plus half the held link. The
    sag converges as 1/k^2 in the stub's links: 2 % at k ~ 13."""
    cable = Cable(length=1.0, diameter=0.003, mass=0.02, youngs_modulus=2.5e8, n_links=4)
    section = section_cable(cable, 100, 0.0)
    fixture = Fixture((0.5, 0.0, 0.03), (-1.0, 0.0, 0.0), name="fixture")
    stub = stub_sag(cable, section, fixture)
    assert stub.converged
    held = np.linalg.norm(stub.shape[1] - stub.shape[0])
    a = stub.length + held / 2
    q = cable.mass / cable.length * 9.81
    inertia = math.pi * cable.diameter ** 4 / 64
    closed = q * a ** 4 / (8 * cable.youngs_modulus * inertia)
    assert 0.001 < closed / a < 0.1
    assert stub.sag == pytest.approx(closed, rel=0.02)
    # out of the slot, away from the route (the fixture's axis points inward, to -x here)
    assert stub.shape[0, 0] == pytest.approx(fixture.position[0] - section.rest_link_length / 2)
    assert stub.shape[-1, 0] == pytest.approx(
        fixture.position[0] + section.rest_link_length / 2 + stub.length, abs=stub.sag)


def test_a_cable_settled_on_a_plate_in_the_simulator_rests_where_the_statics_put_it():
    """Hard contact with friction (the replay's) against the penalty statics: a cable held
    level and sagging onto a plate comes to rest within 1 mm of the static equilibrium (the
    friction stops the points where they touch down, within the points' approach speed times
    the contact's stop; the penalty sinks them by F / k_c ~ 1e-6 m)."""
    cable = Cable(length=0.5, diameter=0.003, mass=0.01, youngs_modulus=2.5e7, n_links=30)
    clips = ClipPoses(np.array([[0.0, 0.0, 0.0], [0.36, 0.0, 0.0]]),
                      Rotation.from_euler("z", [[0.0], [180.0]], degrees=True))
    free = equilibrium(cable, np.stack([np.linspace(-0.008, 0.368, cable.n_points),
                                        np.zeros(cable.n_points),
                                        -0.02 * np.sin(np.linspace(0, np.pi, cable.n_points))],
                                       1), clips)
    top = float(free.shape[:, 2].min()) + 0.01  # the plate lifts the middle by about 1 cm
    plate = Box((0.18, 0.0, top - 0.005), (0.1, 0.2, 0.01), name="plate")
    static = equilibrium(cable, free.shape, clips, contacts=(plate,))
    assert contact_states(cable, static.shape, (plate,))[0].active
    run = simulate(cable, free.shape, clips, duration=20.0, contacts=(plate,), friction=0.3,
                   damping="relative", rest_speed=1e-5, record_interval=0.01)
    assert run.settled
    assert np.abs(run.shapes[-1] - static.shape).max() < 1e-3


def test_a_section_shortened_slowly_in_the_simulator_ends_in_its_static_state():
    """``cable_at``: a weightless section between fixed clips gets 2 % shorter over 2 s; at
    rest it is the static equilibrium of the shorter section (quasi-static limit; 1e-4 m)."""
    cable = Cable(length=0.5, diameter=0.003, mass=0.01, youngs_modulus=2.5e7, n_links=20)
    clips = ClipPoses(np.array([[0.0, 0.0, 0.0], [0.4, 0.0, 0.0]]),
                      Rotation.from_euler("z", [[0.0], [180.0]], degrees=True))
    start = equilibrium(cable, np.stack([np.linspace(-0.0125, 0.4125, 21), np.zeros(21),
                                         -0.05 * np.sin(np.linspace(0, np.pi, 21))], 1), clips,
                        gravity=np.array([0.0, 0.0, -9.81]))
    shorter = replace(cable, length=0.49, mass=0.0098)

    def cable_at(t):
        f = min(t / 2.0, 1.0)
        return replace(cable, length=0.5 - 0.01 * f, mass=0.01 - 0.0002 * f)

    run = simulate(cable, start.shape, clips, duration=15.0, cable_at=cable_at,
                   damping="absolute", rest_speed=1e-6, dt=shorter.time_step())
    end = equilibrium(shorter, run.shapes[-1], clips)
    assert np.abs(run.shapes[-1] - end.shape).max() < 1e-4


def test_a_changing_cable_that_returns_its_cable_again_is_the_fixed_cables_run():
    """The simulator builds a changing cable's chain again only for another cable object, and
    interpolates the clips' poses per block of steps, not per millisecond chunk: a run whose
    ``cable_at`` returns the cable itself, or an equal copy every time, is the run of the fixed
    cable (4096-step chunks) step for step, bit for bit, clips moving on a plate."""
    cable = Cable(length=0.5, diameter=0.003, mass=0.01, youngs_modulus=2.5e7, n_links=20)
    turn = Rotation.from_euler("z", [[0.0], [180.0]], degrees=True)
    clips = ClipTrajectory(np.array([0.0, 0.3]), [
        ClipPoses(np.array([[0.0, 0.0, 0.05], [0.4, 0.0, 0.05]]), turn),
        ClipPoses(np.array([[0.0, 0.05, 0.02], [0.35, 0.0, 0.03]]), turn)])
    start = equilibrium(cable, np.stack([np.linspace(-0.0125, 0.4125, 21), np.zeros(21),
                                         0.05 - 0.05 * np.sin(np.linspace(0, np.pi, 21))], 1),
                        clips.poses[0], contacts=(Table(0.0),))
    options = dict(duration=0.4, damping="relative", contacts=(Table(0.0),), friction=0.3,
                   record_interval=1e-3)
    fixed = simulate(cable, start.shape, clips, **options)
    for cable_at in (lambda t: cable, lambda t: replace(cable)):
        run = simulate(cable, start.shape, clips, cable_at=cable_at, **options)
        assert run.steps == fixed.steps
        np.testing.assert_array_equal(run.shapes, fixed.shapes)
        np.testing.assert_array_equal(run.times, fixed.times)
    assert fixed.shapes[:, :, 2].min() < 0.002  # it lies on the plate


@pytest.mark.parametrize("axial", ["thesis", "copper"])
@pytest.mark.parametrize("name", ["usb", "ethernet"])
def test_the_compiled_contact_newton_loop_takes_the_generic_loops_steps(name, axial,
                                                                       monkeypatch):
    # sim.contact_newton claims the same decisions in the same order as the generic
    # trust-region loop: a section settled on the demo board (peg, plate, table) from the
    # weightless insertion pose reaches the same shape in the same number of iterations when
    # the obstacles' compiled rows are withheld (the generic loop then measures them itself),
    # step for step: with the thesis' E_a = E the plain steps, with the copper axial springs
    # (the default) both correct their steps' link lengths and land entering points just inside
    from dataclasses import replace

    from harness_boards import demo_board

    from dloplan.cable import catalogue_cable
    from dloplan.harness import fixture_clips, insertion_pose, section_shape
    from dloplan.sim import statics

    cable = catalogue_cable(name, n_links=10)
    cable = replace(cable, axial_modulus=None) if axial == "thesis" else cable
    board = demo_board(cable)
    section = section_cable(cable, 30)
    x0 = section_shape(insertion_pose(cable, board).shape, cable, section)
    compiled = equilibrium(section, x0, fixture_clips(board), contacts=board.contacts())
    monkeypatch.setattr(statics, "contact_rows", lambda obstacles: None)
    generic = equilibrium(section, x0, fixture_clips(board), contacts=board.contacts())
    assert compiled.converged and generic.converged
    assert compiled.iterations == generic.iterations
    # copper: the entry fraction's and the model's dot products summed in another order, the
    # round-off of springs of 1e6 N/m on a 0.2 m section: 3e-12 m (USB)
    assert np.max(np.abs(compiled.shape - generic.shape)) <= (1e-12 if axial == "thesis" else 1e-10)


def test_a_copper_cable_pressed_on_a_peg_converges_from_a_guess_with_stretched_end_links(
        monkeypatch):
    # The Ethernet harness' phase 2 (examples/harness_ethernet.yaml, copper axial springs
    # 2e9 Pa: k_s = 3e6 N/m, 2.7 times the contact penalty), segment 1, sub-step 10: the guess
    # is the previous sub-step's equilibrium with its end links stretched to the new clips
    # (1.26 J in the axial springs), its Newton steps carry free points into the peg and its
    # plate. Without landing them just inside (entry_fraction_rows) the compiled contact loop
    # halved its trust radius down to 1e-9 of the cable's diameter and crawled: 500 iterations,
    # residual 3.2e-3 N, and the snap check reported "no stable equilibrium" (585 iterations to
    # converge). Now 24, the generic loop's iterates exactly (its entry_fraction, the reference).
    from dloplan.sim import statics

    data = np.load(Path(__file__).parent / "data" / "harness_ethernet_phase2_substep.npz")
    cable = Cable(length=0.4632352941176471, diameter=0.005, mass=0.009264705882352942,
                  youngs_modulus=7.5e6, poisson_ratio=0.4, n_links=35, name="ethernet",
                  axial_modulus=2e9)
    clips = ClipPoses(data["clip_positions"], Rotation.from_quat(data["clip_quaternions"]))
    board = (Cylinder((0.38, 0.0, -0.012), 0.012, 0.072, "peg"),
             Box((0.38, 0.0, 0.0285), (0.08, 0.12, 0.003), 0.0, "peg plate"),
             Box((0.3, 0.0, 0.03), (0.03, 0.16, 0.06), 0.0, "wall"), Table(0.0))
    compiled = equilibrium(cable, data["guess"], clips, contacts=board)
    assert compiled.converged and compiled.stable, compiled.message
    assert compiled.iterations < 50
    assert elastic_stability(cable, compiled.shape, contacts=board).stable_with_friction
    monkeypatch.setattr(statics, "contact_rows", lambda obstacles: None)
    generic = equilibrium(cable, data["guess"], clips, contacts=board)
    assert compiled.iterations == generic.iterations
    assert np.max(np.abs(compiled.shape - generic.shape)) <= 1e-12
