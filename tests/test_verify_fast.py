"""The verification's fast paths give the reference paths' verdicts (docs/performance.md, 1).

* the replay's linearly implicit Euler at 1 ms against the thesis' explicit scheme at its time
  step (docs/decisions.md: the replay's time step);
* the snap-through check's compiled continuation against its Python loop;
* the physics checks of a plan moved rigidly on the table, kept, against running them again.

Cases: a shipped example's plan (m1_sine_pu_hose, planned here; not designed for these
tests), the same plan mirrored in the plane y = 0, and its shapes replayed and continued with
another cable (the Ethernet cable: its shapes are then not equilibria, so the replay starts
with a transient and the continuation ends elsewhere).
"""

import math
from dataclasses import replace

import numpy as np
import pytest

from dloplan.app import load_job
from dloplan.cable import catalogue_cable
from dloplan.pipeline.repair.placement import TableMove, moved_document, moved_job
from dloplan.pipeline.repair.rebuild import slowed, timed
from dloplan.pipeline.reuse import moved_rigidly
from dloplan.pipeline.stages import replay_modulus_cap, run_job, settled_shapes, verify_plan
from dloplan.sim.clips import clip_poses_from_shape
from dloplan.verify.replay import replay
from dloplan.verify.snap import check_snap_through

pytestmark = pytest.mark.xdist_group("test_verify_fast")

EXAMPLE = "examples/m1_sine_pu_hose.yaml"

DEVIATION_TOLERANCE = 5e-5
"""Implicit against explicit deviations [m]: backward Euler's error is first order in dt (its
numerical damping of a mode of frequency w is about w dt / 2); on the examples the knot shapes
differ by 0.03-11 um at dt = 1 ms. 0.05 mm is 1/200 of the replay's 10 mm tolerance: a verdict
can only differ for a plan within 0.05 mm of it."""


@pytest.fixture(scope="module")
def planned():
    job = load_job(EXAMPLE)
    return job, run_job(job)


def _mirrored(path):
    return path * np.array([1.0, -1.0, 1.0])


def _cases(doc):
    """(name, cable, stabilized shapes, clip poses) of the fast/reference comparisons."""
    path = settled_shapes(doc)
    mirror = _mirrored(path)
    other = catalogue_cable("ethernet", doc.cable.n_links)
    return [("plan", doc.cable, path, doc.clip_poses()),
            ("mirrored", doc.cable, mirror, [clip_poses_from_shape(x) for x in mirror]),
            ("ethernet", other, path, doc.clip_poses())]


@pytest.mark.parametrize("case", [0, 1, 2], ids=["plan", "mirrored", "ethernet"])
def test_implicit_replay_reproduces_the_explicit_one(planned, case):
    _, doc = planned
    _, cable, path, poses = _cases(doc)[case]
    options = dict(knot_times=doc.trajectory.times, law=doc.trajectory.law,
                   youngs_modulus_cap=replay_modulus_cap(cable))
    runs = {scheme: replay(cable, path, poses, scheme=scheme, **options)
            for scheme in ("explicit", "implicit")}
    reference, fast = runs["explicit"], runs["implicit"]
    assert fast.simulation.dt == pytest.approx(1e-3)
    assert fast.simulation.steps * 5 < reference.simulation.steps  # the point of it
    assert (fast.ok, fast.settled) == (reference.ok, reference.settled)
    np.testing.assert_allclose(fast.deviations, reference.deviations,
                               atol=DEVIATION_TOLERANCE)
    # the segments' deviations are reported, not judged: where the start is not an equilibrium
    # (the Ethernet case) the first segment is a fall, a fast transient that backward Euler
    # damps a little more (0.18 mm of 11 mm)
    np.testing.assert_allclose(fast.segment_deviations, reference.segment_deviations,
                               rtol=0.02, atol=DEVIATION_TOLERANCE)
    assert abs(fast.final_deviation - reference.final_deviation) < DEVIATION_TOLERANCE
    # the default is the implicit scheme here
    auto = replay(cable, path, poses, **options)
    np.testing.assert_array_equal(auto.deviations, fast.deviations)


def test_implicit_replay_converges_to_the_explicit_one_at_first_order(planned):
    # halving the implicit step halves its distance to the explicit run (backward Euler is
    # first order; the explicit run's own error at its 30 us step is far below)
    _, doc = planned
    path, poses = settled_shapes(doc), doc.clip_poses()
    options = dict(knot_times=doc.trajectory.times, law=doc.trajectory.law,
                   youngs_modulus_cap=replay_modulus_cap(doc.cable))
    reference = replay(doc.cable, path, poses, scheme="explicit", **options).simulation
    knots = doc.trajectory.times - doc.trajectory.times[0]

    def distance(dt):
        run = replay(doc.cable, path, poses, scheme="implicit", dt=dt, **options).simulation
        return max(float(np.max(np.linalg.norm(run.at(t)[0] - reference.at(t)[0], axis=1)))
                   for t in knots)

    coarse, fine = distance(1e-3), distance(5e-4)
    assert 0 < coarse < DEVIATION_TOLERANCE
    assert 1.6 < coarse / fine < 2.5


def test_a_tensile_limit_is_checked_on_the_explicit_run(planned):
    # the implicit scheme damps the axial ringing whose peaks a tensile check judges
    _, doc = planned
    run = replay(doc.cable, settled_shapes(doc), doc.clip_poses(),
                 knot_times=doc.trajectory.times, law=doc.trajectory.law,
                 youngs_modulus_cap=replay_modulus_cap(doc.cable), tensile_limit=100.0)
    assert run.simulation.dt == pytest.approx(doc.cable.time_step(
        replay_modulus_cap(doc.cable)))
    with pytest.raises(ValueError, match="scheme"):
        replay(doc.cable, settled_shapes(doc), (doc.trajectory.times, doc.clip_poses()),
               scheme="midpoint")


@pytest.mark.parametrize("case", [0, 1, 2], ids=["plan", "mirrored", "ethernet"])
def test_compiled_continuation_is_the_python_loop(planned, case):
    _, doc = planned
    _, cable, path, poses = _cases(doc)[case]
    fast = check_snap_through(cable, path, poses)
    reference = check_snap_through(cable, path, poses, compiled=False)
    assert fast.message == reference.message
    assert [(e.kind, e.segment, e.substep) for e in fast.events] == \
        [(e.kind, e.segment, e.substep) for e in reference.events]
    for a, b in zip(fast.segments, reference.segments, strict=True):
        np.testing.assert_array_equal(a.shapes, b.shapes)  # the same kernels, same order
        # dense LAPACK against banded: round-off of an eigenvalue of a matrix of norm ~k_s
        np.testing.assert_allclose(a.eigenvalues, b.eigenvalues, rtol=1e-8,
                                   atol=1e-12 * np.max(np.abs(b.eigenvalues)))
        np.testing.assert_array_equal(a.ratios, b.ratios)
        assert a.straying == b.straying and a.end_mismatch == b.end_mismatch


def test_compiled_continuation_finds_the_arch_snaps():
    # the snap test's arch (tests/test_verify_snap.py): the same two critical points
    from test_verify_snap import ROTATION, WEIGHTLESS, arch_clips

    from dloplan.sim.statics import continuation, equilibrium

    cable = catalogue_cable("pu", 16)
    guess = np.zeros((17, 3))
    guess[:, 0] = np.linspace(-0.05, 0.45, 17)
    guess[:, 2] = 0.1 * np.sin(np.pi * np.linspace(0, 1, 17))
    start = equilibrium(cable, guess, arch_clips(0.0), gravity=WEIGHTLESS).shape
    poses = [arch_clips(0.0), arch_clips(ROTATION)]
    end = continuation(cable, start, poses, substeps=200, gravity=WEIGHTLESS)[-1].shape
    checks = [check_snap_through(cable, np.stack([start, end]), poses, gravity=WEIGHTLESS,
                                 compiled=compiled) for compiled in (True, False)]
    assert [e.kind for e in checks[0].events] == ["snap", "snap"]
    assert [e.fraction for e in checks[0].events] == pytest.approx(
        [e.fraction for e in checks[1].events], abs=1e-9)


@pytest.fixture(scope="module")
def moved(planned):
    job, doc = planned
    move = TableMove(np.array([0.08, -0.05, 0.0]), yaw=math.radians(25.0),
                     pivot=np.array([0.3, 0.0, 0.0]))
    placed_job = moved_job(job, move)
    placed = moved_document(placed_job, doc, move, program=False)
    return doc, verify_plan(doc, robot=False), placed, placed_job


def test_a_placement_keeps_the_physics_checks(moved):
    doc, before, placed, _ = moved
    assert moved_rigidly(doc, placed)
    again = verify_plan(placed, robot=False)  # the reference: everything run again
    kept = verify_plan(placed, robot=False, reuse=(doc, before))
    assert kept.replay is before.replay and kept.snap is before.snap
    assert "replay" not in kept.timings and "replay" in again.timings
    # the physics does not see a turn about the vertical and a shift: the same verdicts, and
    # numbers to round-off (amplified by the continuation's and the replay's steps)
    assert kept.ok == again.ok and kept.messages == again.messages
    for a, b in zip(kept.rows, again.rows, strict=True):
        assert (a.stable, a.snap) == (b.stable, b.snap)
        assert a.smallest_eigenvalue == pytest.approx(b.smallest_eigenvalue, rel=1e-6)
        assert a.replay_deviation == pytest.approx(b.replay_deviation, abs=1e-7)
        assert a.straying == pytest.approx(b.straying, abs=1e-7)


def test_what_is_not_a_rigid_move_is_verified_again(moved):
    doc, before, placed, placed_job = moved
    nudged = placed.stabilized.copy()
    nudged[2, 3, 2] += 1e-6  # one point of one shape, 1 um
    others = [replace(placed, stabilized=nudged), timed(slowed(placed_job, 0.5), placed),
              replace(placed, cable=catalogue_cable("ethernet", doc.cable.n_links))]
    for other in others:
        assert not moved_rigidly(doc, other)
    kept = verify_plan(others[0], robot=False, reuse=(doc, before))
    assert "replay" in kept.timings and kept.replay is not before.replay
    # other checks asked for than were run: not reused either
    fewer = verify_plan(placed, robot=False, snap=False, reuse=(doc, before))
    assert fewer.snap is None and "replay" in fewer.timings


@pytest.mark.parametrize("damping", ["absolute", "relative"])
def test_implicit_step_is_the_backward_euler_system_solved_densely(damping):
    # (M + dt k_d D + dt^2 H) v+ = M v + dt F over the free points, the held points' v+ the
    # clips', written out with the numpy gradient and the sparse Hessian: the same steps to
    # round-off (dt = 5 ms: 150 explicit steps each; a stiff PU hose, compressed and moved)
    from scipy.spatial.transform import Rotation

    from dloplan.physics.chain import SpringChain, gradient, hessian
    from dloplan.sim.clips import ClipPoses
    from dloplan.sim.dynamics import ClipTrajectory, simulate
    from dloplan.sim.statics import equilibrium

    cable = catalogue_cable("pu", 8)
    facing = Rotation.from_rotvec([[0, 0, 0], [0, 0, math.pi]])
    first = ClipPoses(np.array([[0, 0, 0.3], [0.4, 0, 0.3]]), facing)
    last = ClipPoses(np.array([[0, 0, 0.3], [0.3, 0.05, 0.32]]), facing)
    guess = np.zeros((9, 3))
    guess[:, 0] = np.linspace(-0.05, 0.45, 9)
    start = equilibrium(cable, guess, first).shape
    trajectory = ClipTrajectory(np.array([0.0, 0.1]), [first, last])
    dt, steps = 5e-3, 40
    run = simulate(cable, start, trajectory, duration=steps * dt, dt=dt, damping=damping,
                   record_interval=dt, scheme="implicit")
    chain = SpringChain.from_cable(cable)
    n_dof = 3 * cable.n_points
    laplacian = np.diag(np.r_[1.0, 2.0 * np.ones(cable.n_points - 2), 1.0]) - \
        np.eye(cable.n_points, k=1) - np.eye(cable.n_points, k=-1)
    damper = np.kron(laplacian if damping == "relative" else np.eye(cable.n_points), np.eye(3))
    mass = np.repeat(cable.point_masses, 3)
    held = np.r_[0:6, n_dof - 6:n_dof]
    free = np.r_[6:n_dof - 6]
    x, v = start.ravel().copy(), np.zeros(n_dof)
    previous = trajectory.held_points(np.array([0.0]), cable.rest_link_length)[0].ravel()
    x[held] = previous
    for step in range(1, steps + 1):
        shape = x.reshape(-1, 3)
        system = np.diag(mass) + dt * cable.k_damping * damper + \
            dt**2 * hessian(chain, shape).toarray()
        target = trajectory.held_points(np.array([step * dt]), cable.rest_link_length)[0]
        new = np.zeros(n_dof)
        new[held] = (target.ravel() - previous) / dt
        rhs = mass * v - dt * gradient(chain, shape).ravel() - system @ new
        new[free] = np.linalg.solve(system[np.ix_(free, free)], rhs[free])
        v, x = new, x + dt * new
        x[held] = previous = target.ravel()
        assert np.max(np.abs(run.shapes[step] - x.reshape(-1, 3))) < 1e-11
    assert run.steps == steps
    with pytest.raises(ValueError, match="implicit"):
        simulate(cable, start, trajectory, duration=0.1, scheme="implicit")  # no dt
