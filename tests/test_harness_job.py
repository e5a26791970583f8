"""Harness jobs: phases, insertion and tensioning, the single trajectory (thesis 7.3)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from harness_boards import demo_board, demo_start

from dloplan.cable import catalogue_cable
from dloplan.geometry import link_lengths, shape_length
from dloplan.harness import (
    HarnessSettings,
    approach_shape,
    harness_summary,
    insert_and_tension,
    insertion_pose,
    run_harness,
    section_cable,
    section_shape,
    tension_state,
    whole_shape,
)
from dloplan.harness.held import held_model
from dloplan.physics.chain import SpringChain, link_tensions
from dloplan.sim.clips import clip_poses_from_shape
from dloplan.trajectory import trajectory_from_grippers

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_harness_job")

N_LINKS = 10
SETTINGS = HarnessSettings(n_shapes=(3, 3), section_links=30)


HELD: dict[str, list] = {}
"""Per job of the module's fixtures: (where, clip distance [m]) of every ``check_held`` call."""


def _job(name: str):
    cable = catalogue_cable(name, n_links=N_LINKS)
    board = demo_board(cable)
    held = HELD.setdefault(name, [])
    return run_harness(cable, demo_start(cable), board, SETTINGS,
                       check_held=lambda where, clips, remedy: held.append(
                           (where, float(np.linalg.norm(clips[1] - clips[0])))))


@pytest.fixture(scope="module")
def usb():
    return _job("usb")


@pytest.fixture(scope="module")
def pu():
    return _job("pu")


def test_the_usb_job_runs_end_to_end(usb):
    assert usb.success, usb.message
    # carried taut (the cable cannot carry the arc), the USB cable clears the demo board's wall
    assert usb.phases.approach_kind == "taut"
    assert usb.phases.avoidance.status == "clear" and usb.phases.avoidance.success
    k = 3 + 2
    assert len(usb.phases.path1) == k
    assert usb.shapes.shape == (k + (k - 1) + 2, N_LINKS + 1, 3)
    assert usb.trajectory.n_knots == len(usb.shapes) == usb.grippers.n_shapes
    # the knots of the phases follow each other; the phases share their boundary knot
    bounds = list(usb.knots.values())
    assert bounds[0][0] == 0 and bounds[-1][1] == len(usb.shapes) - 1
    assert all(a[1] == b[0] for a, b in zip(bounds, bounds[1:], strict=False))
    summary = harness_summary(usb)
    json.dumps(summary, allow_nan=False)
    # the cycle: the jerk-limited motion, longer than the velocity-only timing of the same
    # knots (a stop costs v / a + a / j = 0.2 s at the defaults when the move cruises, up to
    # 0.3 s for moves too short to), plus the three actions
    velocity_only = trajectory_from_grippers(usb.grippers, left_clip=usb.trajectory.arm_clips[0],
                                             law="constant-speed").duration
    stops = usb.trajectory.n_knots - 1
    assert velocity_only + 0.1 * stops < usb.motion_time < velocity_only + 0.3 * stops
    actions = SETTINGS.grasp_time + (SETTINGS.release_time + SETTINGS.grasp_time) \
        + SETTINGS.release_time
    assert summary["cycle_time"] == pytest.approx(usb.motion_time + actions, rel=1e-12)
    assert [p.name for p in usb.cycle.phases] == ["grasp", "phase1", "phase2", "insertion",
                                                  "regrasp", "tensioning", "release"]
    assert "thesis" not in usb.message  # no comparison with a time of other ingredients


def test_the_transition_between_the_phases_is_continuous(usb, pu):
    phases = usb.phases
    assert np.array_equal(phases.path2[0], phases.path1[-1])
    assert np.array_equal(pu.phases.path1[0], pu.phases.plan1.path[0])
    # a settled phase 1 starts where the planned one does (the start settled at its clips)
    start, planned = clip_poses_from_shape(phases.path1[0]), clip_poses_from_shape(
        phases.plan1.path[0])
    assert np.allclose(start.positions, planned.positions, atol=1e-12)
    assert np.allclose(start.u_axes, planned.u_axes, atol=1e-12)
    # the gripper frames too: phase 2's first frames are phase 1's last
    k = usb.knots["phase1"][1]
    assert np.array_equal(usb.shapes[k], phases.path1[-1])
    assert np.array_equal(usb.shapes[k + 1], phases.path2[1])


def test_clip_axes_match_the_fixture_axes_at_insertion(usb):
    k = usb.knots["insertion"][0]
    axes = np.array([f.axis for f in usb.board.fixtures])
    angles = np.degrees(np.arccos(np.clip(np.sum(usb.grippers.u_axes[k] * axes, -1), -1, 1)))
    assert np.all(angles < 1.0)  # [deg] thesis 7.3.1, the tolerance
    assert np.all(np.degrees(usb.fixture_alignment) < 1.0)
    # the clips are at the approach points, then in the slots, then pulled along the axes
    approach = np.array([f.approach for f in usb.board.fixtures])
    slots = np.array([f.position for f in usb.board.fixtures])
    assert np.allclose(usb.grippers.positions[k], approach, atol=1e-9)
    assert np.allclose(usb.grippers.positions[k + 1], slots, atol=1e-9)
    pulled = slots - usb.offset * axes
    assert np.allclose(usb.grippers.positions[k + 2], pulled, atol=1e-9)


def test_the_tensioned_cable_touches_the_peg_without_entering_it(usb):
    ins = usb.insertion
    assert ins.success, ins.message
    # touching: a point is (slightly) inside the peg's surface, by less than 0.1 mm
    assert 0.0 < ins.peg_penetration[0] < 1e-4
    assert ins.penetration < 1e-4
    # with the wanted force (Brent's tolerance on the offset is 1e-6 m)
    assert ins.tensioned.contact_force == pytest.approx(SETTINGS.contact_force, rel=0.02)
    assert ins.tensioned.max_tension < SETTINGS.max_axial_force
    # a link cuts the peg by at most the sagitta of a chord of its length on the peg's circle
    rho = usb.board.pegs[0].radius + usb.cable.diameter / 2
    l_s = ins.tensioned.section.rest_link_length
    assert ins.link_penetration <= rho - math.sqrt(rho**2 - l_s**2 / 4) + 1e-4


def test_the_offset_is_the_smallest_that_reaches_the_force(usb):
    ins, cable, board = usb.insertion, usb.cable, usb.board
    n = ins.tensioned.section.n_links
    less = tension_state(cable, n, ins.offset - 0.5e-3, ins.inserted.shape, board)
    assert less.equilibrium.success
    assert less.contact_force < 0.8 * SETTINGS.contact_force  # 0.5 mm less pull, less force
    assert ins.offset > 0


def test_the_tensioned_section_is_in_force_balance(usb):
    state = usb.insertion.tensioned
    eq = state.equilibrium
    # forces on the cable: clip reactions (-wrench), contacts and gravity sum to zero
    gravity = state.section.point_masses.sum() * np.array([0.0, 0.0, -9.81])
    net = -eq.clip_wrenches[:, :3].sum(axis=0) + eq.forces.contact.sum(axis=0) + gravity
    scale = state.section.mass * 9.81 + state.contact_force
    assert np.linalg.norm(net) < 1e-6 * scale
    # the plate carries part of the weight: an upward contact force somewhere
    assert eq.forces.contact[:, 2].max() > 0


def test_the_trajectory_respects_the_limits_throughout(usb):
    traj = usb.trajectory
    limits = traj.limits
    # finite differences of the motion sampled at 1 ms, within 1 % (the check)
    t = np.arange(0.0, traj.duration, 1e-3)
    s = traj.at(t)
    for k, limit in enumerate((limits.speed, limits.acceleration, limits.jerk), start=1):
        chord = np.linalg.norm(np.diff(s.positions, k, axis=0), axis=-1) / 1e-3**k
        assert chord.max() <= limit * 1.01
    turn = np.stack([(r[:-1].inv() * r[1:]).magnitude() for r in s.rotations], 1) / 1e-3
    assert turn.max() <= limits.angular_speed * 1.01
    # the arms stop where the cable must settle: end of phase 1, above and in the slots
    k1, k2 = usb.knots["phase1"][1], usb.knots["insertion"][0]
    assert np.all(traj.zones[[k1, k2, k2 + 1]] == 0.0)
    kin = traj.kinematics(traj.times[[k1, k2, k2 + 1]])
    assert np.all(kin.speed < 1e-12)
    # the long segments cruise at the speed limit (time-optimal), none exceeds it
    peak, _ = traj.segment_peak_speeds()
    assert peak.max() <= limits.speed * (1 + 1e-9)
    longest = np.argmax(traj.segment_distances()[0].max(axis=1))
    assert peak[longest].max() == pytest.approx(limits.speed, rel=1e-9)


def test_the_stiffer_hose_needs_higher_forces_than_the_usb_cable(usb, pu):
    # thesis 7.3.2-7.3.3: for the same board, higher bending and axial forces for stiffer DLOs
    assert pu.success, pu.message
    for phase in ("phase1", "phase2"):
        assert pu.forces[phase].bending_mean.mean() > 10 * usb.forces[phase].bending_mean.mean()
    # and the fixtures (and the grippers) must hold more to keep the tensioned hose on the peg
    assert pu.insertion.tensioned.holding_forces.min() > \
        2 * usb.insertion.tensioned.holding_forces.max()


def test_the_force_statistics_are_the_planners_for_phase_2(pu):
    planned = pu.phases.plan2.force_statistics()
    ours = pu.forces["phase2"]
    for key in ("axial_mean", "axial_variance", "bending_mean", "bending_variance"):
        assert np.allclose(getattr(ours, key), getattr(planned, key), rtol=1e-12, atol=0)


def test_phase_2_imposes_more_curvature_than_phase_1(usb):
    # thesis Fig. 7.31 vs 7.29 (the USB cable's phase 2 settled on the board's pegs)
    assert usb.forces["phase2"].bending_mean.max() > usb.forces["phase1"].bending_mean.max()


def test_a_soft_cable_is_carried_taut_and_its_phase_2_settled_on_the_board(usb, pu):
    # the hose carries the arc (planned as the thesis does); the USB cable sags off it by more
    # than the target tolerance, so it is carried taut and its phase 2 is its equilibria
    assert (pu.phases.approach_kind, pu.phases.phase2_kind) == ("arc", "planned")
    assert usb.phases.approach_kind == "taut"
    assert usb.phases.phase2_kind.startswith("settled")
    line = usb.phases.approach
    assert np.allclose(link_lengths(line), usb.cable.rest_link_length, rtol=1e-12)
    assert np.ptp(line[:, 2]) < 1e-12  # level
    assert np.linalg.norm(line[-1] - line[0]) == pytest.approx(usb.cable.length, rel=1e-12)
    # the seam: the insertion starts from the section phase 2 reached, which is already an
    # equilibrium at the approach poses (the lowering's first stop does not move it)
    assert np.max(np.linalg.norm(usb.insertion.lowering[0].shape - usb.phases.section,
                                 axis=1)) < 1e-3
    # and phase 2 ends with the clips exactly at the fixtures' approach poses
    end = clip_poses_from_shape(usb.phases.path2[-1])
    assert np.allclose(end.positions, [f.approach for f in usb.board.fixtures], atol=1e-12)
    assert np.allclose(end.u_axes, [f.axis for f in usb.board.fixtures], atol=1e-9)
    summary = harness_summary(usb)
    assert (summary["approach"], summary["phase2"]) == ("taut", usb.phases.phase2_kind)


def test_the_checks_follow_the_settled_phases_the_plan_wrote():
    # the seam: the held model the checks run on follows the cable from the plan's shapes and
    # clip poses as the settled phases did, so it rests where the plan says it does; within the
    # resampling of the section onto the planning's 10 links (a few mm), not the centimetres a
    # gravity-free phase 2 was off
    cable = catalogue_cable("ethernet", n_links=N_LINKS)
    result = run_harness(cable, demo_start(cable), demo_board(cable), SETTINGS)
    assert result.phases.phase2_kind.startswith("settled")
    ins = result.insertion
    clips = [result.grippers.clip_poses(k) for k in range(len(result.shapes))]
    sections = np.stack([ins.lowering[0].shape, ins.inserted.shape,
                         ins.tensioned.equilibrium.shape])
    model = held_model(cable, result.board, result.shapes, clips, result.knots, ins.offset,
                       ins.tensioned.section.n_links, sections)
    for phase, path in model.paths.items():
        assert path.settle_distance < 5e-3, phase


def test_insertion_pose_keeps_the_clearance_and_lines_up_with_the_fixtures():
    cable = catalogue_cable("ethernet", n_links=12)
    board = demo_board(cable, peg_x=0.36)  # close enough that the free shape would touch it
    eq = insertion_pose(cable, board, clearance=0.005)
    assert eq.success, eq.message
    clips = clip_poses_from_shape(eq.shape)
    assert np.allclose(clips.positions, [f.approach for f in board.fixtures], atol=1e-12)
    assert np.allclose(clips.u_axes, [f.axis for f in board.fixtures], atol=1e-12)
    peg = board.pegs[0]
    radial = np.hypot(*(eq.shape[:, :2] - np.asarray(peg.base[:2])).T)
    gap = radial.min() - peg.radius - cable.diameter / 2
    assert gap == pytest.approx(0.005, abs=1e-4)  # touches the grown peg: the peg bent it
    assert np.allclose(link_lengths(eq.shape), cable.rest_link_length, rtol=1e-3)


def test_approach_shape_carries_the_insertion_curvature_above_it():
    cable = catalogue_cable("usb", n_links=10)
    x = insertion_pose(cable, demo_board(cable)).shape
    arc = approach_shape(cable, x, 0.08)
    assert shape_length(arc) == pytest.approx(cable.length, rel=1e-12)

    def turn(shape):
        d = np.diff(shape, axis=0)
        return np.unwrap(np.arctan2(d[:, 1], d[:, 0]))

    assert turn(arc)[-1] - turn(arc)[0] == pytest.approx(turn(x)[-1] - turn(x)[0], abs=1e-12)
    assert np.allclose(arc[:, 2], x[5, 2] + 0.08)
    assert np.allclose(arc[5, :2], x[5, :2], atol=1e-12)  # same middle point (n even)
    with pytest.raises(ValueError, match="approach_height: got 0.0"):
        approach_shape(cable, x, 0.0)


def test_the_section_model_keeps_the_cable_between_the_clips():
    cable = catalogue_cable("usb", n_links=10)
    for offset in (0.0, 0.012):
        section = section_cable(cable, 30, offset)
        between = section.length - section.rest_link_length
        assert between == pytest.approx(cable.length - cable.rest_link_length - 2 * offset)
        assert section.mass / section.length == pytest.approx(cable.mass / cable.length)
    x = insertion_pose(cable, demo_board(cable)).shape
    sec = section_cable(cable, 30)
    xs = section_shape(x, cable, sec)
    a, b = clip_poses_from_shape(x), clip_poses_from_shape(xs)
    assert np.allclose(a.positions, b.positions, atol=1e-12)
    assert np.allclose(a.u_axes, b.u_axes, atol=1e-12)
    with pytest.raises(ValueError, match="offset: got 0.3"):
        section_cable(cable, 30, 0.3)


def test_a_section_comes_back_to_the_planning_links_on_its_clips():
    # whole_shape inverts section_shape up to the resampling: the end links exactly on the
    # clips (so the grippers hold what the section was held by), the shape within a fraction of
    # a planning link of the original, every link within 2 % of its rest length
    cable = catalogue_cable("ethernet", n_links=10)
    x = insertion_pose(cable, demo_board(cable)).shape
    sec = section_cable(cable, 40)
    clips = clip_poses_from_shape(x)
    back = whole_shape(cable, section_shape(x, cable, sec), clips)
    again = clip_poses_from_shape(back)
    assert np.allclose(again.positions, clips.positions, atol=1e-12)
    assert np.allclose(again.u_axes, clips.u_axes, atol=1e-12)
    assert np.max(np.linalg.norm(back - x, axis=1)) < 0.1 * cable.rest_link_length
    assert np.allclose(link_lengths(back), cable.rest_link_length, rtol=0.02)


def test_insertion_rejects_a_shape_that_is_not_at_the_fixtures():
    cable = catalogue_cable("usb", n_links=10)
    board = demo_board(cable)
    x = insertion_pose(cable, board).shape + [0.0, 0.0, 0.01]
    with pytest.raises(ValueError, match="shape: its clips are 10.00 mm"):
        insert_and_tension(cable, x, board)
    with pytest.raises(ValueError, match="contact_force: got -1"):
        insert_and_tension(cable, x - [0.0, 0.0, 0.01], board, contact_force=-1)


def test_an_unreachable_force_is_reported_not_hidden():
    cable = catalogue_cable("usb", n_links=10)
    board = demo_board(cable, obstacles=False)
    x = insertion_pose(cable, board).shape
    ins = insert_and_tension(cable, x, board, contact_force=0.2, max_axial_force=0.05,
                             n_links=24)
    assert not ins.success
    assert math.isnan(ins.offset)
    assert "link tension reaches" in ins.message and "limit 0.05 N" in ins.message


def test_a_section_over_its_force_limit_in_the_slots_is_a_failed_tensioning():
    """Fixtures 3 cm farther apart each (sweep round 10: the Ethernet example's board): laid in
    the slots the section is stretched over the peg, taut before any pull, and the search
    stopped at d = 0 without comparing its tension with ``max_axial_force`` (the example:
    23.7 N against 5 N, planned and verified, exit 0)."""
    cable = catalogue_cable("ethernet", n_links=10)
    board = demo_board(cable, fixture_y=0.18, obstacles=False)
    x = insertion_pose(cable, board).shape
    ins = insert_and_tension(cable, x, board, max_axial_force=1.0, n_links=24)
    assert ins.tensioned.offset == 0.0 and ins.tensioned.max_tension > 3.0
    assert not ins.success and math.isnan(ins.offset)
    assert "limit 1 N) with the cable laid in the slots, before any pull" in ins.message
    assert "expected a section that reaches the slots within the limit" in ins.message
    assert insert_and_tension(cable, x, board, max_axial_force=5.0, n_links=24).success


def test_the_pu_hose_is_pulled_taut_not_only_bent_onto_the_peg(pu):
    ins = pu.insertion
    assert ins.success, ins.message
    state = ins.tensioned
    # every inner link of the fixture-to-fixture section is in tension (the end links are
    # placed by the clips), recomputed from the equilibrium shape
    tensions = link_tensions(SpringChain.from_cable(state.section, np.array([0, 0, -9.81])),
                             state.equilibrium.shape)
    assert tensions[1:-1].min() >= SETTINGS.min_tension * (1 - 1e-3)
    assert state.mechanism == "tension" and "taut" in pu.message
    assert state.contact_force >= SETTINGS.contact_force
    assert np.all(state.pull_forces > 0)  # the cable pulls on both fixtures
    # 0.5 mm less pull: a link is (nearly) slack or compressed, the search stopped at the first
    less = tension_state(pu.cable, state.section.n_links, ins.offset - 0.5e-3, ins.inserted.shape,
                         pu.board)
    assert less.min_tension < 0.5 * state.min_tension + SETTINGS.min_tension
    assert harness_summary(pu)["peg_force_mechanism"] == "tension"


def test_a_hose_that_cannot_be_pulled_taut_says_why_with_the_forces(pu):
    """Pulled by at most 8 mm, the stiff hose presses on the peg by bending: reported."""
    shape = pu.phases.path2[-1]
    ins = insert_and_tension(pu.cable, shape, pu.board, max_offset=0.008, n_links=30)
    assert not ins.success and math.isnan(ins.offset)
    state = ins.tensioned
    assert state.mechanism == "bending" and state.max_tension < 0
    assert "by bending, the section is in compression" in ins.message
    assert f"{state.max_tension:.3g} N" in ins.message and "fixture pulls" in ins.message


def test_every_phases_held_clips_are_checked_as_they_become_known(usb):
    """``check_held`` (the robot's grippers' distance, dloplan.pipeline.stages.check_held_clips)
    sees the start, the fixtures' approach points and slots, phase 1's end and the tensioned
    poses, in that order, each named by its phase and the job's fields."""
    held = HELD["usb"]
    assert [where.split(" (")[0] for where, _ in held] == [
        "start", "harness.fixtures", "harness.fixtures", "harness.approach_height",
        "harness.tension"]
    assert ["phase 1 starts" in held[0][0], "phase 2 ends" in held[1][0],
            "the insertion ends" in held[2][0], "phase 1 ends" in held[3][0],
            "the tensioning ends" in held[4][0]] == [True] * 5
    distances = dict(zip(("start", "phase 2's end", "slots", "phase 1's end", "tensioned"),
                         (d for _, d in held), strict=True))
    clips = usb.grippers.positions  # the knots where the grippers hold those poses
    k1, k2 = usb.knots["phase1"][1], usb.knots["phase2"][1]
    for name, k in (("start", 0), ("phase 1's end", k1), ("phase 2's end", k2),
                    ("slots", k2 + 1), ("tensioned", k2 + 2)):
        assert distances[name] == pytest.approx(np.linalg.norm(clips[k, 1] - clips[k, 0]),
                                                abs=1e-9), name
    assert f"pulled {1e3 * usb.offset:.1f} mm per arm" in held[4][0]


def test_phase_1s_end_is_checked_before_phase_1_is_planned():
    """A ``check_held`` that refuses phase 1's end stops the job before anything is planned:
    the start and the fixtures were checked before it."""
    cable = catalogue_cable("pu", n_links=N_LINKS)
    seen = []

    class Refused(Exception):
        pass

    def refuse_the_approach(where, clips, remedy):
        seen.append(where.split(" (")[0])
        if where.startswith("harness.approach_height"):
            raise Refused(where)

    with pytest.raises(Refused, match=r"where phase 1 ends: the arc approach above the board"):
        run_harness(cable, demo_start(cable), demo_board(cable), SETTINGS,
                    check_held=refuse_the_approach)
    assert seen == ["start", "harness.fixtures", "harness.fixtures", "harness.approach_height"]
