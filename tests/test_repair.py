"""Verification-guided repair (issue 25): plans that fail their checks are repaired or refused.

The expensive checks are used selectively: the qualitative-1 and the straight-to-U jobs are
verified for their physics (snap-through; replay for qualitative 1), once per module, the
straight-to-U job with its robot program too; the
robot-program repairs (grasp roll, turned placement) on qualitative test 2 with the program's
checks only (fig4_8 and qualitative 1 are repaired for their programs by tests/test_cli.py's
example test); the refusal, the replay repair and the CLI use a soft, coarse cable.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from dloplan.app import load_job, make_plan
from dloplan.app.document_file import read_plan
from dloplan.app.files import EXIT_CHECK_FAILED, plan_into
from dloplan.app.load import resolve_mapping
from dloplan.cli import main
from dloplan.grippers.path import GripperPath
from dloplan.pipeline.repair import Budget, diagnose, repair_plan, translated_job
from dloplan.pipeline.repair.frames import grasp_rolled, same_frames, untwisted
from dloplan.pipeline.repair.loop import attempts
from dloplan.pipeline.repair.placement import (
    TableMove,
    moved_document,
    moved_grippers,
    moved_job,
    translated_document,
)
from dloplan.pipeline.repair.rebuild import slowed, timed
from dloplan.pipeline.repair.routes import follow_branch, moved, rigid_motion, routes
from dloplan.pipeline.stages import program_of, run_job, verify_plan
from dloplan.sim.clips import ClipPoses, clip_poses_from_shape
from dloplan.verify.stability import elastic_stability

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_repair")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
ALONG_Y = {"euler": [0, 0, 90]}

STRAIGHT_TO_U = {  # a PA12 hose from straight (across the robot) to a U standing in the x-z plane
    "cable": {"name": "pa12", "n_links": 10},
    "start": {"kind": "straight", "placement": {"position": [0.30, -0.20, 0.15],
                                                "rotation": ALONG_Y}},
    "target": {"kind": "arc", "angle": 180,
               "placement": {"position": [0.35, -0.10, 0.30], "rotation": {"euler": [0, 90, 90]}}},
    "planner": {"n_shapes": 5},
    "table": {"height": 0.0},
    "repair": {"placement": True},  # its reach repair turns the job: allowed
}


def soft_job(position=(0.40, -0.15, 0.20), speed=0.1, angular=1.0, acceleration=1.0):
    """A soft Ethernet cable, n = 6, S = 2: every check in seconds."""
    x, y, z = position
    return {"cable": {"name": "ethernet", "n_links": 6},
            "start": {"kind": "straight", "placement": {"position": [x, y, z],
                                                        "rotation": ALONG_Y}},
            "target": {"kind": "arc", "angle": 90,
                       "placement": {"position": [x, y + 0.05, z], "rotation": ALONG_Y}},
            "planner": {"n_shapes": 2},
            "trajectory": {"tcp_speed": speed, "angular_speed": angular,
                           "acceleration": acceleration, "jerk": 100.0 * acceleration,
                           "angular_acceleration": 10.0 * angular,
                           "angular_jerk": 100.0 * angular}}


@pytest.fixture(scope="module")
def qualitative1():
    """Qualitative test 1 with its physics checks (stability, snap-through, replay); its robot
    program is left out here (see the module docstring of bench_repair.py for the placement)."""
    job = load_job(EXAMPLES / "qualitative1_curved_pa12.yaml")
    doc = run_job(job, check_robot=False)
    verification = verify_plan(doc, robot=False)
    return job, doc, verification, repair_plan(job, doc, verification)


@pytest.fixture(scope="module")
def straight_to_u():
    """The straight-to-U job with its physics checks (stability, snap-through; the replay of
    the stiff hose costs minutes and is not what fails) and its robot program's."""
    job = resolve_mapping(STRAIGHT_TO_U, "straight to U")
    doc = run_job(job)
    verification = verify_plan(doc, replay=False)
    return job, doc, verification, repair_plan(job, doc, verification)


def assert_ends_kept(job, doc, result):
    """The start is the planned one and the target within T_cf, both moved with the job."""
    move = result.move.points
    assert np.allclose(result.job.start, move(job.start), atol=1e-12)
    assert np.allclose(result.job.target, move(job.target), atol=1e-12)
    final = result.document.stabilized
    assert np.max(np.abs(final[0] - move(doc.stabilized[0]))) < 1e-9
    assert np.max(np.linalg.norm(final[-1] - move(doc.stabilized[-1]), axis=1)) \
        <= job.target_threshold


def test_qualitative1_snaps_before_repair(qualitative1):
    _, doc, verification, _ = qualitative1
    failures = diagnose(doc, verification)
    assert {f.kind for f in failures} == {"snap", "replay"}
    assert min(f.segment for f in failures if f.kind == "snap") == 4


def test_qualitative1_passes_its_physics_checks_after_repair(qualitative1):
    job, doc, _, result = qualitative1
    assert result.ok and result.refusal is None, result.refusal
    assert [r.kind for r in result.repairs] == ["snap"]
    assert "stable branch" in result.repairs[0].change
    ver = result.verification
    assert ver.snap.ok and ver.replay.ok  # the replay's deviation went with the snap
    for seg in ver.snap.segments:
        threshold = elastic_stability(result.document.cable, seg.shapes[-1], k=1).threshold
        assert np.min(seg.eigenvalues) > threshold
    assert_ends_kept(job, doc, result)


def test_a_branch_that_misses_the_target_is_not_taken(qualitative1):
    """The stable branch from shape 4 reaches the planned target; asked to end 5 cm away (more
    than T_cf) it is refused: a repair never moves the target beyond its tolerance."""
    job, doc, _, _ = qualitative1
    shapes, poses = doc.stabilized, doc.clip_poses()
    reached = follow_branch(job.cable, shapes[4], poses[4:], shapes[-1], job.target_threshold)
    assert reached.success and reached.end_error < 1e-3
    away = follow_branch(job.cable, shapes[4], poses[4:], shapes[-1] + [0.05, 0.0, 0.0],
                         job.target_threshold)
    assert not away.success and "from the planned end" in away.message


def test_straight_to_u_passes_after_repair_and_is_reachable(straight_to_u):
    """The minimal-rotation frames twist the hose by 172 deg (their program is fine); the
    untwisted frames are chosen by how many program targets the arms reach, and the reach
    repair then finds a turned placement with a twist-free grasp roll pair: the plan passes
    every check, its program reaches every pose, the hose is not twisted, nothing snaps."""
    job, doc, verification, result = straight_to_u
    assert [f.kind for f in diagnose(doc, verification)] == ["twist"]
    assert result.ok, result.refusal
    assert [r.kind for r in result.repairs] == ["twist", "reach"]
    new, ver = result.document, result.verification
    assert new.program.ok and ver.ok
    assert all(r.reachable_left is not False and r.reachable_right is not False
               for r in ver.rows)
    assert np.max(np.abs(new.twist.twist)) <= new.grippers.max_twist
    assert ver.snap.ok
    for seg in ver.snap.segments:
        threshold = elastic_stability(new.cable, seg.shapes[-1], k=1).threshold
        assert np.min(seg.eigenvalues) > threshold
    assert_ends_kept(job, doc, result)
    # the frames' u-axes are the (placed) shapes': only the rolls changed
    assert np.allclose(new.grippers.u_axes, result.move.vectors(doc.grippers.u_axes),
                       atol=1e-9)


def test_untwisted_frames_mirror(straight_to_u):
    """The mirrored job (y -> -y) untwists the same way: the twist is a property of the
    frames, not of the side of the robot."""
    job, doc, _, _ = straight_to_u
    mirror = np.diag([1.0, -1.0, 1.0])
    shapes = doc.shapes @ mirror
    from dloplan.grippers import gripper_path

    grippers = gripper_path(shapes, method="rigid", cable=job.cable)
    _, twist = untwisted(job.cable, shapes, grippers)
    assert np.max(np.abs(twist)) < np.radians(1.0)


def test_a_target_out_of_every_placement_is_refused_without_a_program(tmp_path):
    """0.95 m in front of the robot: no turn and no shift within 20 cm brings it in reach. The
    full search costs minutes on a loaded machine: a 60 s budget refuses it sooner, with the
    same consequence (the reason, no program)."""
    job = resolve_mapping(soft_job(position=(0.95, -0.15, 0.20)), "far away")
    doc, written = plan_into(job, tmp_path, verify=True, budget=Budget(seconds=60.0),
                             figures=False)
    assert not doc.ok
    refusal = [w for w in doc.warnings if w.startswith("repair refused")]
    assert refusal and ("no placement" in refusal[0] or "budget spent placing" in refusal[0])
    assert "unreachable" in refusal[0] or "pre-check" in refusal[0]
    assert not (tmp_path / "rapid").exists() and (tmp_path / "plan.json").exists()


def test_no_repair_keeps_todays_behaviour(tmp_path, capsys):
    path = tmp_path / "far.yaml"
    path.write_text(yaml.safe_dump(soft_job(position=(0.95, -0.15, 0.20))))
    code = main(["plan", str(path), "--verify", "--no-repair", "-o", str(tmp_path / "out"),
                 "--no-figures"])
    captured = capsys.readouterr()
    assert code == EXIT_CHECK_FAILED
    assert "repair (" not in captured.err and "repair refused" not in captured.err
    plan = read_plan(tmp_path / "out" / "plan.json")
    start = resolve_mapping(soft_job(position=(0.95, -0.15, 0.20)), "far").start
    assert np.allclose(plan.grippers.positions[0], clip_poses_from_shape(start).positions,
                       atol=1e-9)  # the job was not moved


def test_translated_job_plans_the_translated_plan():
    """The placement moves the document instead of planning again: the model is invariant
    under a horizontal translation."""
    job = resolve_mapping(soft_job(), "soft")
    offset = np.array([0.05, -0.1, 0.0])
    moved_job = translated_job(job, offset)
    moved_plan = run_job(moved_job)
    shifted = translated_document(moved_job, run_job(job), offset)
    assert np.max(np.abs(moved_plan.stabilized - shifted.stabilized)) < 1e-6
    assert np.max(np.abs(moved_plan.grippers.positions - shifted.grippers.positions)) < 1e-6
    assert np.allclose(moved_plan.program.joints, shifted.program.joints, atol=1e-4)


def test_turned_job_plans_the_turned_plan():
    """A placement may turn the job about the vertical: gravity and the table are invariant
    under it, so planning the turned job gives the turned plan (shapes and clip frames)."""
    job = resolve_mapping(soft_job(), "soft")
    move = TableMove([0.02, 0.03, 0.0], np.radians(60.0), [0.4, -0.1, 0.0])
    turned_job = moved_job(job, move)
    planned = run_job(turned_job, check_robot=False)
    moved_plan = moved_document(turned_job, run_job(job, check_robot=False), move)
    assert np.max(np.abs(planned.stabilized - moved_plan.stabilized)) < 1e-6
    assert np.max(np.abs(planned.grippers.positions - moved_plan.grippers.positions)) < 1e-6
    for a, b in zip(planned.grippers.rotations, moved_plan.grippers.rotations, strict=True):
        assert np.max((a * b.inv()).magnitude()) < 1e-6
    # clip wrenches turn with the job (a force is a vector): their magnitudes are the same
    assert np.allclose(planned.clip_wrenches, moved_plan.clip_wrenches, atol=1e-6)


def test_table_moves_compose_and_check_their_input():
    rng = np.random.default_rng(3)
    a = TableMove(rng.normal(size=3) * [0.1, 0.1, 0.0], 0.7, rng.normal(size=3))
    b = TableMove(rng.normal(size=3) * [0.1, 0.1, 0.0], -1.9, rng.normal(size=3))
    x = rng.normal(size=(5, 3))
    assert np.allclose(a.then(b).points(x), b.points(a.points(x)), atol=1e-12)
    assert np.allclose(a.points(x)[:, 2], x[:, 2])  # horizontal: heights kept
    assert TableMove().is_identity and not a.is_identity
    with pytest.raises(ValueError, match="TableMove.offset"):
        TableMove([0.0, 0.0])
    with pytest.raises(ValueError, match="TableMove.yaw"):
        TableMove(yaw=float("nan"))


def test_qualitative2_arms_clear_each_other_after_a_grasp_roll():
    """Qualitative test 2 (thesis 7.2.3): the rigid-rotation frames put both wrists between the
    ends of the 140 deg arc, the arms collide (-23 mm at shape 6; with the robot standing on
    the table the right arm also misses shape 0). Rolling the grasps about the clips' u-axes
    fixes it (a twist-free pair at the job's own place); the shapes, clip points relative to
    each other and u-axes stay."""
    job = load_job(EXAMPLES / "qualitative2_ethernet_3d.yaml")
    doc = run_job(job)
    verification = verify_plan(doc, snap=False, replay=False)
    failures = diagnose(doc, verification)
    assert {f.kind for f in failures} == {"reach"}
    assert any("clearance" in f.message for f in failures)
    result = repair_plan(job, doc, verification)
    assert result.ok and [r.kind for r in result.repairs] == ["reach"], result.refusal
    assert "grasps rolled" in result.repairs[0].change
    assert result.move.yaw == 0.0 and np.linalg.norm(result.move.offset) <= 0.05 + 1e-12
    new = result.document
    assert new.program.ok
    assert np.allclose(new.grippers.positions, result.move.points(doc.grippers.positions),
                       atol=1e-12)
    assert np.allclose(new.grippers.u_axes, doc.grippers.u_axes, atol=1e-9)
    assert np.max(np.abs(new.twist.twist)) <= new.grippers.max_twist
    assert_ends_kept(job, doc, result)


def test_grasp_roll_lifts_the_wrists_and_mirrors():
    """Scored above and apart only, the grasp roll never lowers the lowest wrist of a path
    below the plan's grasp (height comes first: the wrist direction's height plus half its
    horizontal part away from the other clip); with either score the path mirrored in the
    robot's x-z plane (y -> -y, the robot is symmetric) gets rolls of the same size."""
    job = resolve_mapping(STRAIGHT_TO_U, "straight to U")
    from dloplan.grippers import gripper_path

    wrist = -job.robot.tools[0].tcp_in_clip.apply([0.0, 0.0, 1.0])
    shapes = resolve_mapping(STRAIGHT_TO_U, "U").target[None].repeat(2, axis=0)
    shapes[0] = job.start
    path = gripper_path(shapes, method="rigid", cable=job.cable)
    rolled, rolls = grasp_rolled(path, job.robot, towards_robot=False)
    lowest = [min(r.apply(wrist)[:, 2]) for r in rolled.rotations]
    before = [min(r.apply(wrist)[:, 2]) for r in path.rotations]
    assert all(a >= b - 1e-12 for a, b in zip(lowest, before, strict=True))
    mirror = np.diag([1.0, -1.0, 1.0])
    flipped = gripper_path(shapes @ mirror, method="rigid", cable=job.cable)
    for towards_robot in (False, True):
        _, plain = grasp_rolled(path, job.robot, towards_robot=towards_robot)
        _, mirrored = grasp_rolled(flipped, job.robot, towards_robot=towards_robot)
        assert np.allclose(np.abs(mirrored), np.abs(plain), atol=1e-12)


def test_grasp_scores_in_one_batch_equal_one_roll_at_a_time():
    """The grasp scores of every roll, computed as one batch of rotations per clip, are bit for
    bit those of the definition evaluated one roll at a time (the clip's frames composed with
    the roll, the wrist direction's height plus AWAY_WEIGHT times its horizontal parts away from
    the other clip and towards the robot, the smallest over the shapes): the rolls the reach
    repair chooses do not depend on how the scores are computed. Checked on the straight-to-U
    frames, turned about the vertical and not, with both scores."""
    from dloplan.grippers import gripper_path
    from dloplan.pipeline.repair.frames import AWAY_WEIGHT, GRASP_ROLLS, grasp_scores

    job = resolve_mapping(STRAIGHT_TO_U, "straight to U")
    wrist = -job.robot.tools[0].tcp_in_clip.apply([0.0, 0.0, 1.0])
    shapes = resolve_mapping(STRAIGHT_TO_U, "U").target[None].repeat(3, axis=0)
    shapes[0] = job.start
    shapes[1] = 0.5 * (shapes[0] + shapes[2])
    for yaw in (0.0, 0.7):
        turned = shapes @ Rotation.from_euler("z", yaw).as_matrix().T
        path = gripper_path(turned, method="minimal", cable=job.cable)
        for towards_robot in (True, False):
            expected = np.empty((2, len(GRASP_ROLLS)))
            for c in range(2):
                here, other = path.positions[:, c], path.positions[:, 1 - c]
                for i, roll in enumerate(GRASP_ROLLS):
                    w = (path.rotations[c] * Rotation.from_rotvec([roll, 0.0, 0.0])).apply(wrist)
                    score = w[:, 2]
                    aims = [here - other] + ([job.robot.base_position - here]
                                             if towards_robot else [])
                    for aim in aims:
                        aim = aim * [1.0, 1.0, 0.0]
                        aim /= np.maximum(np.linalg.norm(aim, axis=1, keepdims=True), 1e-12)
                        score = score + AWAY_WEIGHT * np.sum(w * aim, axis=1)
                    expected[c, i] = np.min(score)
            assert np.array_equal(grasp_scores(path, job.robot, towards_robot=towards_robot),
                                  expected)


def test_rolled_twists_are_solved_once_and_shared_by_turns():
    """The reach repair's twist memo (RolledTwists): a frame set rolled by given rolls is solved
    once; asked again for the same set turned about the vertical (gravity unchanged) it gives
    the same report, which equals a solve of the turned frames to the solver's round-off
    (1e-9 rad and J: the turn moves every coordinate, the solve's tolerance is far below);
    other rolls, or another frame set, are solved anew and equal their own solve exactly."""
    from dloplan.grippers import gripper_path
    from dloplan.pipeline.repair.frames import RolledTwists
    from dloplan.pipeline.stages import plan_twist

    job = resolve_mapping(STRAIGHT_TO_U, "straight to U")
    shapes = resolve_mapping(STRAIGHT_TO_U, "U").target[None].repeat(3, axis=0)
    shapes[0] = job.start
    shapes[1] = 0.5 * (shapes[0] + shapes[2])
    path = gripper_path(shapes, method="rigid", cable=job.cable)
    rolled, rolls = grasp_rolled(path, job.robot, towards_robot=False)
    assert rolls.all()
    turn = TableMove(yaw=np.radians(30.0), pivot=np.array([0.3, -0.1, 0.0]))
    turned_shapes = turn.points(shapes)
    twists = RolledTwists(job.cable)
    first = twists(0, rolls, shapes, rolled)
    again = twists(0, rolls, turned_shapes, moved_grippers(rolled, turn))
    assert again is first and len(twists.reports) == 1
    solved = plan_twist(job.cable, turned_shapes, moved_grippers(rolled, turn))
    for name in ("twist", "relative_twist", "twist_energy"):
        assert np.allclose(getattr(first, name), getattr(solved, name), rtol=0, atol=1e-9)
    assert np.array_equal(first.twist, plan_twist(job.cable, shapes, rolled).twist)
    other_rolls = rolls + np.radians([5.0, 0.0])
    other = twists(0, other_rolls, shapes, replace(rolled, rotations=(
        rolled.rotations[0] * Rotation.from_rotvec([np.radians(5.0), 0.0, 0.0]),
        rolled.rotations[1])))
    assert other is not first and len(twists.reports) == 2
    assert not np.allclose(other.twist, first.twist)
    assert twists(1, rolls, shapes, path) is not first and len(twists.reports) == 3


def test_a_frame_set_is_made_when_it_is_placed_and_equals_the_one_made_in_full(monkeypatch):
    """The reach repair's frame sets (candidates.FrameSet): the frames of a place (the plan
    turned about the vertical) and their grasps rolled are judged for their twist without any
    document; the document is made when it is asked for (a place is found), once per place and
    frame set, and it is the document made in full before (the turned plan, then the frames
    rolled on it: every array bit for bit, the same warnings and twist verdict)."""
    from dloplan.pipeline.repair import candidates
    from dloplan.pipeline.repair.failures import twist_failures
    from dloplan.pipeline.repair.frames import RolledTwists
    from dloplan.pipeline.repair.rebuild import stabilized_wrenches, with_grippers

    made = {"moved_document": 0, "with_grippers": 0}
    for name in made:
        function = getattr(candidates, name)

        def counted(*args, _function=function, _name=name, **kwargs):
            made[_name] += 1
            return _function(*args, **kwargs)

        monkeypatch.setattr(candidates, name, counted)
    job = resolve_mapping(soft_job(), "soft")
    doc = run_job(job, check_robot=False)
    turn = TableMove(yaw=np.radians(30.0), pivot=np.array([0.4, -0.1, 0.0]))
    place = candidates.Place(turn, job, doc)
    frames, rolls = grasp_rolled(place.grippers, job.robot)  # -10 and 5 deg at this turn
    assert rolls.all()
    twists = RolledTwists(job.cable)
    own = candidates.FrameSet(place, place.grippers, None, 0, twists, plan=False)
    rolled = candidates.FrameSet(place, frames, rolls, 0, twists, plan=False)
    turned_job = moved_job(job, turn)
    turned = moved_document(turned_job, doc, turn, program=False)
    full = with_grippers(turned_job, turned, frames, program=False)
    for candidate, expected in ((own, turned), (rolled, full)):
        assert [f.message for f in candidate.twist_failures()] == \
            [f.message for f in twist_failures(expected)]
    assert made == {"moved_document": 0, "with_grippers": 0}  # judged without a document
    assert np.array_equal(place.wrenches, stabilized_wrenches(job.cable, turned.stabilized))
    for candidate, expected in ((own, turned), (rolled, full)):
        got = candidate.document
        assert candidate.document is got and candidate.job.start.tolist() == \
            turned_job.start.tolist()
        for name in ("shapes", "stabilized", "clip_wrenches"):
            assert np.array_equal(getattr(got, name), getattr(expected, name)), name
        assert np.array_equal(got.grippers.positions, expected.grippers.positions)
        for a, b in zip(got.grippers.rotations, expected.grippers.rotations, strict=True):
            assert np.array_equal(a.as_matrix(), b.as_matrix())
        for name in ("times", "positions"):
            assert np.array_equal(getattr(got.trajectory, name),
                                  getattr(expected.trajectory, name)), name
        for name in ("twist", "relative_twist", "twist_energy"):
            assert np.array_equal(getattr(got.twist, name), getattr(expected.twist, name)), name
        assert got.warnings == expected.warnings and got.program is None
    assert made == {"moved_document": 1, "with_grippers": 1}  # the place's, shared


def test_a_snap_repair_followed_by_a_proposed_placement_keeps_its_program():
    """Qualitative test 1 without consent to move the job: its snap repair is kept, its reach
    repair finds a placement and only proposes it. The snap repair's plan leaves its robot
    program to be made after the reach repair (which makes its placements' own programs); here
    the plan is kept where it lies, so it carries the program of its frames and trajectory, as
    if made at once: the program rebuilt from the document is the one it records, its message
    is the robot section's and among the warnings once."""
    from dloplan.pipeline import make_plan

    job = load_job(EXAMPLES / "qualitative1_curved_pa12.yaml")
    job = replace(job, repair=replace(job.repair, placement=False))
    doc = make_plan(job, verify=True)
    assert [r["kind"] for r in doc.repairs] == ["snap"]
    assert doc.placement is not None and not doc.placement.applied
    assert doc.program is not None and doc.robot.message == doc.program.message
    rebuilt = program_of(replace(doc, program=None))  # raises if the targets differ
    assert rebuilt.message == doc.program.message and rebuilt.ok == doc.program.ok
    assert doc.warnings.count(doc.program.message) == (0 if doc.program.ok else 1)


def test_a_twist_repair_that_makes_the_program_pass_leaves_nothing_to_place():
    """M2 (PA12) with its grippers' initial frames rolled 90 deg about the cable (sweep round
    8): the plan twists 180 deg and its program fails at the approach. The twist repair's
    frames make a program that passes, but the reach repair of the same round still searched
    a placement for the round's old failures and proposed one: "placement proposed, not made:
    job turned 30 deg ..." among the warnings (exit 1) of a plan whose program passes where it
    lies. Now the reach repair finds nothing left to place."""
    from dloplan.pipeline import make_plan

    data = yaml.safe_load((EXAMPLES / "m2_uniform_curvature_pa12.yaml").read_text())
    along_y = Rotation.from_euler("z", 90, degrees=True)
    roll = Rotation.from_euler("x", 90, degrees=True)
    data["grippers"] = {"method": "minimal", "initial_frames": {
        "first": {"quaternion": (along_y * roll).as_quat().tolist()},
        "last": {"quaternion": (along_y * Rotation.from_euler("z", 180, degrees=True) * roll)
                 .as_quat().tolist()}}}
    doc = make_plan(resolve_mapping(data, "rolled.yaml"))
    assert [r["kind"] for r in doc.repairs] == ["twist"]
    assert doc.program.ok, doc.program.message
    assert doc.placement is None or doc.placement.applied
    assert not any("placement proposed" in w for w in doc.warnings), doc.warnings


def test_a_proposed_placement_writes_the_plans_own_program_complete():
    """Qualitative test 1 without consent and without ``--verify``: the reach repair proposes
    a placement, so the plan keeps its own failing program, made with its passing round trips
    left to complete (``make_plan``: the repair replaces it when it places the job). What
    ``make_plan`` returns is complete: the program and the plan document's robot section are
    those of a program made complete at once."""
    from dloplan.pipeline import make_plan

    job = load_job(EXAMPLES / "qualitative1_curved_pa12.yaml")
    job = replace(job, repair=replace(job.repair, placement=False))
    doc = make_plan(job)
    assert doc.placement is not None and not doc.placement.applied
    eager = run_job(job)  # every round trip enumerated
    assert not eager.program.ok and doc.program.completion is None
    assert doc.program.checks == eager.program.checks
    assert doc.robot == eager.robot
    assert any(r.check == "round trip" and r.ok and "solutions of the pose" in r.note
               for r in doc.program.checks)


def test_a_replay_that_strays_at_speed_is_repaired_by_slowing_down():
    """A soft cable moved fast (0.5 m/s, 5 rad/s) rings after each stop: the replay's deviation
    at the knots falls as the motion is slowed (measured: 3.8 -> 1.4 mm at half speed). With a
    2 mm tolerance the plan fails the replay and the repair slows it by half; the path is the
    same, only the time law changed."""
    job = resolve_mapping(soft_job(speed=0.5, angular=5.0, acceleration=1.0), "fast")
    doc = run_job(job, check_robot=False)
    deviation = [verify_plan(timed(slowed(job, f), doc), snap=False, robot=False)
                 .replay.deviations.max() for f in (1.0, 0.5, 0.25)]
    assert deviation[0] > deviation[1] > deviation[2]  # grows with speed
    tolerance = 0.5 * (deviation[0] + deviation[1])
    verification = verify_plan(doc, snap=False, robot=False, tolerance=tolerance)
    assert [f.kind for f in diagnose(doc, verification)][:1] == ["replay"]
    result = repair_plan(job, doc, verification, Budget(attempts=4))
    assert result.ok and [r.kind for r in result.repairs] == ["replay"], result.refusal
    assert result.verification.replay.deviations.max() <= tolerance
    assert result.job.motion.tcp_speed == pytest.approx(0.25)
    assert result.document.trajectory.duration > doc.trajectory.duration
    assert np.array_equal(result.document.shapes, doc.shapes)


def test_slowed_is_a_time_dilation():
    job = resolve_mapping(soft_job(speed=0.5, angular=5.0, acceleration=1.0), "fast")
    half = slowed(job, 0.5).motion.limits
    full = job.motion.limits
    assert half.speed == pytest.approx(0.5 * full.speed)
    assert half.angular_acceleration == pytest.approx(0.25 * full.angular_acceleration)
    assert half.jerk == pytest.approx(0.125 * full.jerk)
    with pytest.raises(ValueError, match="factor"):
        slowed(job, 1.5)


def test_rigid_motion_is_recovered_and_routes_end_where_they_should():
    rng = np.random.default_rng(7)
    a = ClipPoses(rng.normal(size=(2, 3)) * 0.1, Rotation.random(2, random_state=1))
    turn = Rotation.from_rotvec([0.3, -0.8, 0.5])
    centre = a.positions.mean(axis=0)
    b = moved(a, turn, centre, centre + [0.1, 0.2, -0.05])
    rotation, ca, cb = rigid_motion(a, b, 0.25)
    assert (rotation * turn.inv()).magnitude() < 1e-9
    back = moved(a, rotation, ca, cb)
    assert np.allclose(back.positions, b.positions, atol=1e-12)
    for name, waypoints in routes(a, b, 0.25):
        steps = [(p.rotations * q.rotations.inv()).magnitude().max()
                 for p, q in zip([a, *waypoints], [*waypoints, b], strict=True)]
        assert max(steps) <= np.radians(30.0) + 1e-9, name


def test_budget_rejects_bad_values():
    with pytest.raises(ValueError, match="budget.attempts"):
        Budget(attempts=0)
    with pytest.raises(ValueError, match="budget.seconds"):
        Budget(seconds=float("nan"))


def far_ur_data(placement: bool = True) -> dict:
    """The UR5e pair example verified where it lies (no placement search), its start and
    target 25 cm further from the robots: the right arm loses shape 3 (joint limits, IK). With
    ``placement`` the job allows its reach repair to move it."""
    data = yaml.safe_load((EXAMPLES / "cells" / "ur5e_pair_usb.yaml").read_text())
    data["robot"]["place"] = False
    for key in ("start", "target"):
        data[key]["placement"]["position"][0] += 0.25
    data["repair"] = {"placement": placement}
    return data


def far_ur_job():
    """:func:`far_ur_data`, resolved."""
    return resolve_mapping(far_ur_data(), "ur5e pair, far")


@pytest.fixture(scope="module")
def ur_placed(tmp_path_factory):
    """The far UR5e job planned with its robot program's checks, repaired and written."""
    folder = tmp_path_factory.mktemp("ur_far")
    job = far_ur_job()
    doc, _ = plan_into(job, folder, figures=False)
    return job, doc, folder


def test_a_described_cell_is_placed_by_its_own_search(ur_placed):
    """A reach failure on a described cell is repaired by the cell's placement search (not the
    YuMi's): the job is shifted on the table and its program passes there."""
    job, doc, _ = ur_placed
    assert doc.ok and doc.program.ok
    assert [r["kind"] for r in doc.repairs] == ["reach"]
    assert "ur5e_pair cell's placement search" in doc.repairs[0]["change"]
    as_planned = run_job(job)
    assert not as_planned.program.ok  # it failed where it lay
    shift = doc.grippers.positions - as_planned.grippers.positions
    assert np.allclose(shift, shift[0, 0], atol=1e-12)  # one translation of every clip point
    assert np.allclose(shift[0, 0, 2], 0.0) and np.linalg.norm(shift[0, 0]) > 0.05


def test_a_placed_plan_reads_back_as_one_placed_job(ur_placed):
    """plan.json after a placement repair: shapes, the planner's stages, frames, the program
    and the verification all describe the job where it was placed (the stages used to stay
    at the original place)."""
    job, doc, folder = ur_placed
    plan = read_plan(folder / "plan.json")
    assert np.allclose(plan.shapes, doc.shapes, atol=1e-9)
    assert np.allclose(plan.stages.basic[0], plan.shapes[0], atol=1e-9)  # the placed start
    assert np.allclose(plan.stages.advanced[-1], plan.shapes[-1],
                       atol=job.target_threshold)
    clips = np.stack([clip_poses_from_shape(shape).positions for shape in plan.shapes])
    assert np.allclose(plan.grippers.positions, clips, atol=1e-9)
    program = program_of(plan)
    assert program.ok
    cell_plan = program.targets.plan
    knots = plan.grippers.positions[cell_plan.shapes][:, [program.targets.left_clip,
                                                          1 - program.targets.left_clip]]
    assert np.allclose(cell_plan.positions, knots + cell_plan.offset, atol=1e-9)
    assert plan.verification is not None and plan.verification.ok


def test_a_refusal_names_each_attempt_once_with_its_count():
    """A target 3 m away: the placement search repeated 'minimal frames: turned 0 deg: no
    offset ... passed the pre-check' some 40 times in one warning line."""
    tried = ["minimal frames: no offset", "auxiliary frames: no offset",
             "minimal frames: no offset", "minimal frames: no offset"]
    assert attempts(tried) == "minimal frames: no offset (x3) | auxiliary frames: no offset"
    assert attempts([]) == ""


@pytest.mark.parametrize("shift", [0.0, 0.5])
def test_frame_sets_whose_twist_is_put_off_are_judged_as_before(shift, monkeypatch):
    """Qualitative test 1 (its robot checks): a frame set out of the arms' reach spheres where
    the job lies is not solved for its twist unless the searches that shift the job try it or
    a refusal lists it. As shipped, the reach repair keeps the same placement, frames and
    program as with every twist solved when its frame set is made (``put_off`` False, the old
    way), with fewer solves; moved 0.5 m away from the robot no placement works, and the
    refusal names each put-off set as judged, in its place (its twist failure, or the search's
    miss where it lies): the same line."""
    from dloplan.pipeline.repair import frames
    from dloplan.pipeline.repair.candidates import FrameSet

    data = yaml.safe_load((EXAMPLES / "qualitative1_curved_pa12.yaml").read_text())
    for end in ("start", "target"):
        data[end]["placement"]["position"][0] += shift
    job = resolve_mapping(data, "qualitative 1")
    doc = run_job(job)
    verification = verify_plan(doc, snap=False, replay=False)
    solved = []
    solve = frames.plan_twist
    monkeypatch.setattr(frames, "plan_twist", lambda *a: solved.append(1) or solve(*a))
    put_off = repair_plan(job, doc, verification)
    lazy = len(solved)
    monkeypatch.setattr(FrameSet, "put_off", property(lambda self: False))
    at_once = repair_plan(job, doc, verification)
    assert put_off.refusal == at_once.refusal
    assert [r.line() for r in put_off.repairs] == [r.line() for r in at_once.repairs]
    if shift:
        assert put_off.refusal.startswith("no placement of the job") and ": 1 twist" in \
            put_off.refusal and "passed the pre-check" in put_off.refusal
        assert lazy == len(solved) - lazy  # the refusal names them all
        return
    assert put_off.ok and [r.kind for r in put_off.repairs] == ["reach"]
    assert put_off.document.robot == at_once.document.robot
    for name in ("twist", "relative_twist", "twist_energy"):
        assert np.array_equal(getattr(put_off.document.twist, name),
                              getattr(at_once.document.twist, name)), name
    assert lazy < len(solved) - lazy


def test_a_claimed_twist_is_solved_on_the_claimers_frames():
    """``RolledTwists``: a pair (base, rolls) claimed with some frames and asked for with
    others (another turn's) is solved on the claimer's shapes and frames, as if it had been
    solved when claimed."""
    from dloplan.pipeline.repair.frames import RolledTwists
    from dloplan.pipeline.stages import plan_twist

    job = load_job(EXAMPLES / "fig4_8_straight_to_bent.yaml")
    doc = run_job(job, check_robot=False)
    other = (doc.shapes, untwisted(job.cable, doc.shapes, doc.grippers, share=0.5)[0])
    twists = RolledTwists(job.cable)
    rolls = np.array([0.1, -0.2])
    assert twists.claim(0, rolls, doc.shapes, doc.grippers) == (0, 0.1, -0.2)
    assert not twists.reports
    report = twists(0, rolls, *other)
    expected = plan_twist(job.cable, doc.shapes, doc.grippers)
    assert not np.array_equal(plan_twist(job.cable, *other).twist, expected.twist)
    for name in ("twist", "relative_twist", "twist_energy"):
        assert np.array_equal(getattr(report, name), getattr(expected, name)), name
    assert twists(0, rolls, *other) is report


def test_a_placement_without_consent_is_proposed_not_made(ur_placed, tmp_path, capsys):
    """The far UR5e job whose file does not allow the job to be moved: the reach repair finds
    the same placement as with consent, but only proposes it -- exit 3 with the proposal in one
    line, the plan where the file puts it, the proposed move in plan.json's placement section,
    no robot program. ``--allow-placement`` makes it: the same plan as the file's consent, and
    the programs say where the job must be placed."""
    _, allowed, allowed_folder = ur_placed
    path = tmp_path / "far.yaml"
    path.write_text(yaml.safe_dump(far_ur_data(placement=False)))
    out = tmp_path / "out"
    assert main(["plan", str(path), "-o", str(out), "-q", "--no-figures"]) == EXIT_CHECK_FAILED
    lines = [line for line in capsys.readouterr().out.splitlines()
             if "placement proposed" in line]
    assert len(lines) == 1 and "--allow-placement" in lines[0], lines
    proposed = read_plan(out / "plan.json")
    as_planned = run_job(far_ur_job())
    assert np.array_equal(proposed.shapes, as_planned.shapes)  # not moved
    assert not proposed.robot.ok and not proposed.repairs
    section = proposed.placement
    assert section is not None and not section.applied
    made = allowed.placement
    assert made is not None and made.applied
    assert np.array_equal(section.offset, made.offset) and section.yaw == made.yaw
    assert not (out / "urscript").exists() and not (out / "ros_joints").exists()
    # simulate of the job file works on that same plan, and says that it failed a check
    assert main(["simulate", str(path), "-q", "--json"]) == EXIT_CHECK_FAILED
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "failed a check (robot program" in err[0], err

    consented = tmp_path / "consented"
    assert main(["plan", str(path), "-o", str(consented), "-q", "--allow-placement",
                 "--no-figures"]) in (0, 1)
    plan = read_plan(consented / "plan.json")
    assert np.array_equal(plan.shapes, allowed.shapes)
    assert np.array_equal(plan.placement.offset, made.offset)
    for folder in (consented, allowed_folder):
        scripts = sorted((folder / "urscript").glob("*.script"))
        assert scripts and all("Place the cable where dloplan moved the job" in f.read_text()
                               and made.message in f.read_text() for f in scripts)


def test_frames_of_another_method_name_the_method_the_job_asked_for():
    """M2(PA12) asked for the auxiliary-vector frames: the YuMi reaches none of them, and the
    reach repair takes the rigid rotation's. Before, the repaired plan's frames said
    "method 'rigid' as asked" (the unseen-case sweep, docs/scenario.md): the message of a
    method the repair chose names the one the job file asked for."""
    spec = yaml.safe_load((EXAMPLES / "m2_uniform_curvature_pa12.yaml").read_text())
    spec["grippers"] = {"method": "auxiliary"}
    job = resolve_mapping(spec, "m2 pa12, auxiliary")
    doc = run_job(job)
    result = repair_plan(job, doc, verify_plan(doc, snap=False, replay=False))
    assert result.ok and [r.kind for r in result.repairs] == ["reach"], result.refusal
    grippers = result.document.grippers
    assert grippers.method != "auxiliary"
    assert "as asked" not in grippers.message
    assert "as asked" not in result.repairs[0].change
    assert f"method {grippers.method!r} chosen by the repair (the job asked for 'auxiliary')" \
        in grippers.message


def test_a_placement_is_rejected_on_its_programs_first_failure(monkeypatch):
    """fig4_8: the reach repair rejects two placements on the first failure of their robot
    programs, at the approach (the lines the complete programs gave), without solving the
    controller's round trip of their later targets (``verdict_only``), nor of a target whose
    verified joints' own solution round-trips: none for the plan's program (9 targets, 2 arms:
    its passing round trips judged from their own solutions, as it is replaced), none for the
    first rejected one (it fails its joint limits), one for the second (the left arm's round
    trip fails, the right arm's own solution passes), 18 for the one kept, when the repair
    returns (72 when the rejected programs were completed, 40 when each round trip of a
    verdict was enumerated, 37 when the plan's own program was complete). The plan's timings
    name the repair's parts no kind of repair spent: the repaired plan verified again, the
    kept program completed."""
    import dloplan.robot.yumi_program as plugin

    solved = []
    solve = plugin.solve_robtarget
    monkeypatch.setattr(plugin, "solve_robtarget",
                        lambda *args, **kwargs: solved.append(args) or solve(*args, **kwargs))
    lines = []
    doc = make_plan(load_job(EXAMPLES / "fig4_8_straight_to_bent.yaml"), progress=lines.append)
    through = "about the vertical through [0.431, 0.000, 0.000] m: robot program, approach"
    assert [line for line in lines if line.startswith("placement rejected")] == [
        f"placement rejected: auxiliary frames, grasps rolled, job turned 30 deg {through}, "
        "right arm: joint limits 0.05341 deg ABB axis 2, less than the 5 deg required",
        f"placement rejected: minimal frames, grasps rolled, job turned -30 deg {through}, "
        "left arm: round trip 180 deg 0 solutions of the pose and arm angle, 0 with confdata "
        "[-1, -1, 0, 4]"]
    assert doc.program.ok and doc.program.trajectory is not None and doc.repairs
    assert len(solved) == 0 + 0 + 1 + 18
    # the repair's time that no kind of repair spent, named (benchmarks' "repairs:" split)
    parts = [doc.timings["repair: verified again"], doc.timings["repair: program completed"]]
    assert min(parts) > 0.0 and sum(parts) + doc.repairs[0]["seconds"] <= doc.timings["repair"]


def test_same_frames_is_the_rotation_magnitude_rule_near_and_far_from_its_tolerance():
    """The reach repair's duplicate test (``same_frames``) answers as the angle of the rotation
    between the frames (scipy's ``magnitude``) does, whether the matrices' pre-check decides
    (frames degrees apart) or the angle (frames within a few tolerances)."""
    rng = np.random.default_rng(7)
    base = Rotation.random(6, random_state=3), Rotation.random(6, random_state=4)
    path = GripperPath(np.zeros((6, 2, 3)), base, "rigid", np.zeros(6))
    tolerance = 1e-6
    answers = set()
    for angle in (0.0, 0.3 * tolerance, 0.9 * tolerance, 1.1 * tolerance, 1.5 * tolerance,
                  3.0 * tolerance, 1e-3, 0.5, 3.0):
        for _ in range(5):
            axes = rng.normal(size=(6, 3))
            turn = Rotation.from_rotvec(angle * axes / np.linalg.norm(axes, axis=1)[:, None])
            clip = int(rng.integers(2))
            rotations = tuple(r * turn if c == clip else r for c, r in enumerate(base))
            other = replace(path, rotations=rotations)
            rule = all(np.max((p * q.inv()).magnitude()) < tolerance
                       for p, q in zip(other.rotations, path.rotations, strict=True))
            assert same_frames(other, path, tolerance) is rule
            answers.add(rule)
    assert answers == {True, False}


def _turned_demo(yaw_deg: float) -> dict:
    """The demo job turned by ``yaw_deg`` about the vertical through its start's centre (the
    unseen-case sweep's turned variant)."""
    data = yaml.safe_load((Path(__file__).resolve().parents[1] / "src/dloplan/data/demo.yaml")
                          .read_text())
    centre = np.asarray(data["start"]["placement"]["position"], float)
    turn = Rotation.from_euler("z", yaw_deg, degrees=True)
    for key in ("start", "target"):
        place = data[key]["placement"]
        place["position"] = (turn.apply(np.asarray(place["position"], float) - centre)
                             + centre).tolist()
        rotation = Rotation.from_euler("xyz", place.get("rotation", {}).get("euler", [0, 0, 0]),
                                       degrees=True)
        place["rotation"] = {"euler": (turn * rotation).as_euler("xyz", degrees=True).tolist()}
    for obstacle in data.get("obstacles", []):
        obstacle["center"] = (turn.apply(np.asarray(obstacle["center"], float) - centre)
                              + centre).tolist()
        obstacle["yaw"] = obstacle.get("yaw", 0.0) + yaw_deg
    return data


def test_a_placement_refusal_says_what_the_best_placement_failed():
    """Placements that fail for the arms' clearance, not reach, were refused as "no placement
    of the job on the table makes every pose reachable" (the sweep's turned jobs, the
    examples on the other cells). The refusal now names the first robot check the best
    placement fails: Fig. 4.8 on the Panda pair (the cell's own search: every pose reached,
    the arms 1.2 mm apart at shape 3 where the job lies: round 9's comfort ranking; main's,
    clearance before margin, reported [-0.2, 0] m, 0.5 mm at shape 4) and the demo turned 90 deg
    on the YuMi (its frames with the grasps rolled, where it lies: every pose reached, the arms
    colliding)."""
    data = yaml.safe_load((EXAMPLES / "fig4_8_straight_to_bent.yaml").read_text())
    panda = yaml.safe_load((EXAMPLES / "cells" / "panda_pair_ethernet.yaml").read_text())
    for arm in panda["robot"]["cell"]["arms"].values():
        arm["urdf"] = str((EXAMPLES / "cells" / arm["urdf"]).resolve())
    data.update(robot=panda["robot"], repair={"placement": True})
    doc = make_plan(resolve_mapping(data, "Fig. 4.8 on the Panda pair"))
    refusal = doc.warnings[-1]
    lead = "repair refused: no placement of the job on the table makes every robot check pass"
    assert refusal.startswith(f"{lead}: the best fails clearance; two_pandas's placement "
                              "search, job at its own place: cell FAILS: clearance at shape 3 "
                              "(both: 1.2"), refusal
    assert "reachable" not in refusal

    doc = make_plan(resolve_mapping(_turned_demo(90.0), "demo turned 90 deg"))
    refusal = doc.warnings[-1]
    assert refusal.startswith(f"{lead}: the best fails clearance (minimal frames"), refusal
    assert "works; best [0.000, 0.000, 0.000] m: 0 unreachable pose(s), 0 discontinuous " \
        "motion(s), 10 arm collision(s) over 10 poses)" in refusal.split("; tried: ")[0]
