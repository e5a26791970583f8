"""Dynamic replay: slow replays converge to the static error, fast ones deviate more."""

import math
import sys
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dloplan.cable import catalogue_cable
from dloplan.sim.clips import ClipPoses
from dloplan.sim.dynamics import ClipTrajectory, Simulation
from dloplan.sim.statics import continuation, equilibrium
from dloplan.trajectory import MotionLimits, dual_arm_trajectory
from dloplan.verify.replay import (
    CONTACT_GAP,
    as_clip_trajectory,
    clip_motion,
    quasi_static_speed,
    replay,
)

replay_module = sys.modules["dloplan.verify.replay"]

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_verify_replay")

# A soft USB cable (E / 10, the thesis' fictitious-modulus idea): its explicit time step is about
# 3x longer, so a replay of a few seconds takes a few thousand steps.
CABLE = catalogue_cable("usb", 8).with_modulus(2.5e5)
FACING = Rotation.from_rotvec([[0, 0, 0], [0, 0, math.pi]])
POSES = [
    ClipPoses(np.array([[0, 0, 0.3], [0.4 - dx, 0.5 * dx, 0.3]]), FACING)
    for dx in (0.0, 0.05, 0.1)
]


@pytest.fixture(scope="module")
def shapes():
    guess = np.zeros((9, 3))
    guess[:, 0] = np.linspace(-0.05, 0.45, 9)
    return np.stack([e.shape for e in continuation(CABLE, guess, POSES, substeps=5)])


def test_slow_replay_tends_to_the_stabilization_error(shapes):
    # Plant a known static error: the planned middle shape is 2 mm off its equilibrium.
    planned = shapes.copy()
    planned[1, 4, 2] += 0.002
    # with the thesis' absolute damping the cable creeps after the clips (over-damped), so the
    # lag is proportional to the speed: the cleanest case to check the limit on
    runs = {T: replay(CABLE, planned, (np.linspace(0, T, 3), POSES), damping="absolute")
            for T in (1.0, 4.0)}
    for run in runs.values():
        assert run.settled and run.final_deviation < 1e-4  # the last shape is an equilibrium
        assert run.deviations[0] == 0.0  # the run starts at rest in the first shape
    # the lag is proportional to the speed, so the deviation beyond the static error shrinks
    # about 4x from T = 1 s to T = 4 s (within 30 %: the start-up transient is not linear)
    lag = {T: r.deviations[2] - r.final_deviation for T, r in runs.items()}
    assert 4 / 1.3 < lag[1.0] / lag[4.0] < 4 * 1.3
    # at the planted shape the deviation approaches the 2 mm static error
    slow = runs[4.0].deviations[1]
    assert abs(slow - 0.002) < abs(runs[1.0].deviations[1] - 0.002)
    assert abs(slow - 0.002) < 0.5 * lag[1.0]


def test_fast_replay_deviates_more_and_pulls_harder(shapes):
    fast = replay(CABLE, shapes, (np.array([0.0, 0.1, 0.2]), POSES), tolerance=0.005)
    slow = replay(CABLE, shapes, (np.array([0.0, 1.5, 3.0]), POSES), tolerance=0.005)
    assert fast.max_deviation > 3 * slow.max_deviation
    assert slow.ok and not fast.ok
    assert "deviates" in fast.message
    assert fast.peak_tension >= slow.peak_tension > 0
    # a tensile limit below the peak fails the replay and names it
    limited = replay(CABLE, shapes, (np.array([0.0, 1.5, 3.0]), POSES),
                     tensile_limit=0.5 * slow.peak_tension)
    assert not limited.ok and "exceeds the limit" in limited.message


def test_trajectory_forms_and_knot_times(shapes):
    times = np.array([2.0, 3.0, 4.0])  # a clock that does not start at zero
    as_pair = replay(CABLE, shapes, (times, POSES))
    as_object = replay(CABLE, shapes, ClipTrajectory(times, POSES))
    np.testing.assert_allclose(as_pair.deviations, as_object.deviations)
    np.testing.assert_allclose(as_pair.knot_times, [0.0, 1.0, 2.0])

    class Timed:  # the duck type of a timed dual-arm trajectory
        def __init__(self):
            self.times, self.poses = times, POSES

    assert isinstance(as_clip_trajectory(Timed()), ClipTrajectory)
    # a denser trajectory needs the knot times of the shapes
    dense = (np.linspace(2.0, 4.0, 5), [POSES[0], POSES[0], POSES[1], POSES[2], POSES[2]])
    with pytest.raises(ValueError, match="knot_times: required"):
        replay(CABLE, shapes, dense)
    run = replay(CABLE, shapes, dense, knot_times=[2.0, 3.0, 4.0])
    assert len(run.deviations) == 3


def test_bad_inputs(shapes):
    with pytest.raises(ValueError, match="trajectory"):
        replay(CABLE, shapes, "fast")
    with pytest.raises(ValueError, match="tensile_limit"):
        replay(CABLE, shapes, ([0, 1, 2], POSES), tensile_limit=-1.0)
    with pytest.raises(ValueError, match="knot_times"):
        replay(CABLE, shapes, ([0, 1, 2], POSES), knot_times=[0, 2, 1])
    with pytest.raises(ValueError, match="outside"):
        replay(CABLE, shapes, ([0, 1, 2], POSES), knot_times=[0, 1, 3])


def test_relative_damping_does_not_drag_the_cable_behind(shapes):
    # the thesis' absolute damping resists the motion as a whole; dashpots between neighbours
    # do not, so at the same speed the cable follows its plan more closely
    times = (np.linspace(0, 1.0, 3), POSES)
    drag = replay(CABLE, shapes, times, damping="absolute")
    dashpots = replay(CABLE, shapes, times)
    assert dashpots.deviations.max() < drag.deviations.max()


def _timed(limits=None, **options):
    """The jerk-limited dual-arm trajectory of POSES (TCP = clip frame, left arm = clip 0)."""
    positions = np.stack([p.positions for p in POSES])
    rotations = tuple(Rotation.concatenate([p.rotations[c] for p in POSES]) for c in (0, 1))
    return dual_arm_trajectory(positions, rotations, limits=limits, **options)


def test_sampled_clip_motion_is_the_list_of_its_poses():
    """clip_motion keeps its thousands of samples as arrays (ClipTrajectory.sampled); the
    trajectory is the one built from the list of ClipPoses, frame for frame, bit for bit."""
    traj = _timed()
    motion = clip_motion(traj.law, POSES)
    poses = motion.poses
    listed = ClipTrajectory(motion.times, [poses[k] for k in range(len(poses))])
    assert len(poses) == len(motion.times) > 1000 and isinstance(poses[-1], ClipPoses)
    assert [p.positions.tolist() for p in poses[:3]] == poses.positions[:3].tolist()
    t = np.linspace(-0.1, traj.duration + 0.1, 1001)
    for a, b in zip(motion.frames(t), listed.frames(t), strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(motion.held_points(t, CABLE.rest_link_length),
                                  listed.held_points(t, CABLE.rest_link_length))
    with pytest.raises(ValueError, match=r"sampled poses: expected positions \(K, 2, 3\)"):
        ClipTrajectory.sampled([0.0, 1.0], np.zeros((2, 2, 3)), np.zeros((2, 4)))
    with pytest.raises(ValueError, match="sampled poses: non-finite"):
        ClipTrajectory.sampled([0.0], np.full((1, 2, 3), np.nan), [[[0, 0, 0, 1.0]] * 2])


def test_the_clips_follow_the_real_time_law(shapes):
    traj = _timed()
    motion = clip_motion(traj.law, POSES)
    assert np.all(np.isin(traj.times, motion.times))
    # the sampled clip motion is the trajectory's (not linear at constant speed)
    t = np.linspace(0.0, traj.duration, 777)
    clips = motion.frames(t)[0]
    np.testing.assert_allclose(clips, traj.at(t).positions, atol=2e-7)  # a h^2 / 8 at 1 ms
    run = replay(CABLE, shapes, (traj.times, POSES), law=traj.law)
    assert run.law is traj.law
    np.testing.assert_allclose(run.knot_times, traj.times)
    # the held points of the simulation accelerate within the limit (second differences of
    # the clip midpoint over the records), while the velocity-only drive jumps at the knots
    sim = run.simulation
    inside = sim.times <= traj.duration
    held = 0.5 * (sim.shapes[inside, -1] + sim.shapes[inside, -2])  # the moving clip
    dt = np.diff(sim.times[inside])
    v = np.diff(held, axis=0) / dt[:, None]
    a = np.linalg.norm(np.diff(v, axis=0), axis=-1) / dt[1:]
    # the default 1 m/s^2; 10 %: the clips run on 1 ms chords, the records are not aligned
    assert 0.5 < a.max() <= 1.0 * 1.1
    old = replay(CABLE, shapes, (traj.times, POSES))
    held_old = 0.5 * (old.simulation.shapes[:, -1] + old.simulation.shapes[:, -2])
    dt_old = np.diff(old.simulation.times)
    v_old = np.diff(held_old, axis=0) / dt_old[:, None]
    a_old = np.linalg.norm(np.diff(v_old, axis=0), axis=-1) / dt_old[1:]
    assert a_old.max() > 10.0  # a velocity step at the start: ~0.1 m/s within one record


def test_a_repeated_knot_is_replayed_as_the_motion_without_it(shapes):
    """A path that holds one shape twice (a job whose start is its target plans out and back
    through a repeated shape) has a segment of zero duration: its knot times repeat. The
    replay follows the law as the same motion without the repeated knot, its deviations the
    same at the same times (``plan --verify``, ``verify`` and ``simulate`` of such a plan were
    refused: "trajectory times: expected finite, strictly increasing times")."""
    once = _timed()
    twice = [POSES[0], POSES[1], POSES[1], POSES[2]]
    positions = np.stack([p.positions for p in twice])
    rotations = tuple(Rotation.concatenate([p.rotations[c] for p in twice]) for c in (0, 1))
    traj = dual_arm_trajectory(positions, rotations)
    assert traj.times[2] == traj.times[1]
    np.testing.assert_allclose(traj.times[[0, 1, 3]], once.times, rtol=1e-12)
    path = shapes[[0, 1, 1, 2]]
    run = replay(CABLE, path, (traj.times, twice), law=traj.law)
    reference = replay(CABLE, shapes, (once.times, POSES), law=once.law)
    np.testing.assert_allclose(run.knot_times, traj.times)
    np.testing.assert_allclose(run.deviations, reference.deviations[[0, 1, 1, 2]], atol=1e-9)
    assert run.ok == reference.ok
    with pytest.raises(ValueError, match="non-decreasing"):   # times that go back: refused
        replay(CABLE, path, (traj.times, twice), knot_times=traj.times[::-1], law=traj.law)


def test_a_cable_that_sweeps_through_an_obstacle_between_the_shapes_fails(monkeypatch):
    """obstacle_entry: a straight cable carried along x through a thin wall at x = 0.3 m. The
    planned shapes at x = 0, 0.5 and 1 m are clear of it (what the avoidance checks); the
    records in between enter it, and the first segment is named. Beside the wall's path, or
    within the contact tolerance, nothing is reported."""
    from dloplan.obstacles import Box
    from dloplan.verify.replay import obstacle_entry

    times = np.linspace(0.0, 1.0, 101)
    straight = np.stack([np.zeros(9), np.linspace(-0.2, 0.2, 9), np.full(9, 0.1)], axis=1)
    shapes = straight[None] + times[:, None, None] * np.array([1.0, 0.0, 0.0])
    run = Simulation(times, shapes, np.zeros(len(times)), 0.01, 100, True, "")
    knots = np.array([0.0, 0.5, 1.0])
    wall = Box(center=[0.3, 0.0, 0.1], size=[0.02, 0.2, 0.2], name="wall")
    radius = 0.0025
    message = obstacle_entry(run, [wall], radius, knots)
    assert message.startswith("the moving cable enters wall by 2.5 mm at t = 0.3 s "
                              "(between shapes 0 and 1;")
    beside = Box(center=[0.3, 0.5, 0.1], size=[0.02, 0.2, 0.2], name="beside")
    assert obstacle_entry(run, [beside], radius, knots) == ""
    grazed = Box(center=[0.3, 0.0, 0.1 - radius - 0.01 + 1e-4], size=[0.02, 0.2, 0.02])
    assert obstacle_entry(run, [grazed], radius, knots) == ""   # 0.1 mm: within the tolerance
    assert obstacle_entry(run, [wall], radius, np.array([0.0, 0.2])).find("settling") > 0
    monkeypatch.setattr(replay_module, "ENTRY_CHUNK", 8 * 7)   # 7 records at a time: the same
    assert obstacle_entry(run, [wall], radius, knots) == message


def test_obstacles_fail_the_replay_without_acting_on_it(shapes):
    """The replay's ``obstacles`` are checked, not simulated: the same run and deviations,
    and a table above the sagging cable's lowest point fails it naming the table."""
    from dloplan.obstacles import Table

    traj = _timed()
    free = replay(CABLE, shapes, (traj.times, POSES), law=traj.law)
    lowest = float(free.simulation.shapes[..., 2].min())
    blocked = replay(CABLE, shapes, (traj.times, POSES), law=traj.law,
                     obstacles=[Table(lowest + 0.01)])
    assert free.ok and not blocked.ok
    assert "the moving cable enters table by" in blocked.message
    np.testing.assert_array_equal(blocked.deviations, free.deviations)
    assert replay(CABLE, shapes, (traj.times, POSES), law=traj.law,
                  obstacles=[Table(lowest - 0.01)]).ok


def test_segment_deviations_and_motion_peak(shapes):
    fast = replay(CABLE, shapes, POSES, law=_timed(MotionLimits(
        speed=0.5, acceleration=20.0, jerk=1000.0)).law, tolerance=0.005)
    slow = replay(CABLE, shapes, POSES, law=_timed().law, tolerance=0.005)
    for run in (fast, slow):
        assert run.segment_deviations.shape == (2,)
        # a segment's deviation is at least its two knots'
        assert np.all(run.segment_deviations >= np.maximum(run.deviations[:-1],
                                                           run.deviations[1:]))
        assert 0 < run.motion_peak_tension <= run.peak_tension
        assert "along the segments" in run.message
    assert fast.segment_deviations.max() > 2 * slow.segment_deviations.max()
    # between the knots a fast motion lags more than at them
    assert fast.segment_deviations.max() > fast.max_deviation
    with pytest.raises(ValueError, match="poses: expected 3 ClipPoses"):
        clip_motion(slow.law, POSES[:2])
    with pytest.raises(ValueError, match="law: got tuple"):
        clip_motion((0, 1), POSES)


def test_a_capped_cable_reports_the_tension_its_springs_carry(shapes):
    """The replay of a cable with stiff axial springs (the USB's copper, 2 GPa) at the capped
    axial modulus (1e8 Pa, the pipeline's replay cap) stretches it 20x more under the same
    load; its tension is that of the springs simulated, not the real cable's springs times the
    capped stretch (which reported 20x the load: 132 N on the harness Ethernet job's phase 2).
    Slow motion, so the peak is the static load within the ringing (10 %)."""
    law = (np.array([0.0, 1.5, 3.0]), POSES)
    assert CABLE.stiff_axial and CABLE.axial_youngs_modulus > 10 * 1e8
    real = replay(CABLE, shapes, law)
    capped = replay(CABLE, shapes, law, youngs_modulus_cap=1e8)
    assert real.peak_tension > 0
    assert abs(capped.peak_tension / real.peak_tension - 1.0) < 0.1


def test_a_settling_solved_by_the_statics_ends_in_the_equilibrium(shapes, monkeypatch):
    """``settle_speed``: the settling is stepped only until every point is slower than it, and
    the settled cable is the static equilibrium reached from there (docs/decisions.md, "the
    harness replay's settling"). The plan's last shape is the equilibrium at the last clip
    poses, so the statics' rest lies on it (to the solver's accuracy), where the explicit run
    stepped to 1e-4 m/s stops short by its creep; the knots, the peak and the verdict are the
    stepped run's, in fewer steps. Where no stable equilibrium is found from there, the run is
    stepped on to rest: then the stepped run's own end, bit for bit."""
    timed = (np.array([0.0, 0.6, 1.2]), POSES)
    stepped = replay(CABLE, shapes, timed, scheme="explicit")
    solved = replay(CABLE, shapes, timed, scheme="explicit", settle_speed=1e-2)
    assert stepped.settled and solved.settled and solved.ok == stepped.ok
    assert solved.simulation.steps < stepped.simulation.steps
    assert solved.final_deviation < 1e-8 < stepped.final_deviation
    assert np.max(np.linalg.norm(solved.rest_shape - stepped.rest_shape, axis=1)) < 1e-3
    np.testing.assert_array_equal(solved.deviations, stepped.deviations)  # the knots: stepped
    assert solved.motion_peak_tension == stepped.motion_peak_tension
    clips = POSES[-1]
    rest = equilibrium(CABLE, solved.simulation.shapes[-1], clips)
    np.testing.assert_array_equal(solved.rest_shape, rest.shape)
    # no equilibrium found: stepped on to rest_speed from the state reached
    failed = replace(rest, stable=False)
    monkeypatch.setattr(replay_module, "equilibrium", lambda *args, **kwargs: failed)
    fallback = replay(CABLE, shapes, timed, scheme="explicit", settle_speed=1e-2)
    assert fallback.simulation.steps == stepped.simulation.steps
    np.testing.assert_array_equal(fallback.rest_shape, stepped.rest_shape)
    assert fallback.final_deviation == stepped.final_deviation
    with pytest.raises(ValueError, match="settle_speed"):
        replay(CABLE, shapes, timed, settle_speed=1e-5)  # not above rest_speed


def test_the_quasi_static_speed_cannot_lift_a_point_by_the_contact_tolerance():
    """sqrt(2 g h), h the contact tolerance: a point at that speed rises exactly h against
    gravity (v^2 / 2g)."""
    speed = quasi_static_speed(CABLE)
    height = speed**2 / (2 * 9.81)
    assert height == pytest.approx(CONTACT_GAP * CABLE.diameter / 2, rel=1e-3)
