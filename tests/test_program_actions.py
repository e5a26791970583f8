"""Every planned gripper action is in every program: the cycle's actions (grasp, release, a
harness job's regrasp with its opening part) survive the plan document and are written at their
targets with the planned waits. The programs are parsed back (tests/program_readers.py); every
example is checked end to end in tests/test_cli.py."""

from __future__ import annotations

import numpy as np
import pytest
from program_readers import rapid_commands
from robot_plans import ON_ONE_WORKER, harness_plan

from dloplan.io.rapid import rapid_modules
from dloplan.pipeline.document import cycle_actions, cycle_to_dict
from dloplan.robot import robot_program
from dloplan.robot.actions import action_clock, gripper_commands, place_actions
from dloplan.trajectory import GripperAction

pytestmark = ON_ONE_WORKER


def test_a_regrasp_opens_for_its_opening_part_and_closes_for_the_rest():
    regrasp = GripperAction.regrasp_at(7, release=0.4, grasp=0.5)
    assert regrasp.duration == pytest.approx(0.9) and regrasp.opening == pytest.approx(0.4)
    assert regrasp.commands() == (("open", 0.4), ("close", pytest.approx(0.5)))
    assert GripperAction("grasp", 0, 0.5).commands() == (("close", 0.5),)
    assert GripperAction("release", 3, 0.4).commands() == (("open", 0.4),)
    with pytest.raises(ValueError, match="regrasp.opening"):
        GripperAction("regrasp", 2, 0.9)
    with pytest.raises(ValueError, match="regrasp.opening"):
        GripperAction("regrasp", 2, 0.9, 0.9)
    with pytest.raises(ValueError, match="grasp.opening"):
        GripperAction("grasp", 0, 0.5, 0.2)


def test_the_harness_cycle_round_trips_through_the_document():
    result = harness_plan()
    section = cycle_to_dict(result.cycle)
    actions = cycle_actions(section)
    assert actions == result.cycle.actions
    assert [a.name for a in actions] == ["grasp", "regrasp", "release"]
    # an older document (no action list): grasp and release from its phases, a regrasp refused
    old = {k: v for k, v in section.items() if k != "actions"}
    with pytest.raises(ValueError, match="plan.cycle.actions"):
        cycle_actions(old)
    plain = {"phases": [p for p in old["phases"] if p["name"] != "regrasp"]}
    assert [a.name for a in cycle_actions(plain)] == ["grasp", "release"]


def test_the_harness_rapid_has_the_planned_regrasp_and_waits():
    """The issue's case: the modules held only g_GripOut, g_GripIn, g_GripOut and waited 0.5 s
    on release; now the cycle's grasp (0.5 s), regrasp (open 0.4 s, close 0.5 s) in the slots
    and release (0.4 s), each at its shape."""
    result = harness_plan()
    program = robot_program(result.grippers, result.trajectory)
    k_slots = result.knots["insertion"][1]
    last = result.trajectory.n_knots - 1
    expected = [("shape 0", "close", 0.5), (f"shape {k_slots}", "open", 0.4),
                (f"shape {k_slots}", "close", 0.5), (f"shape {last}", "open", 0.4)]
    for text in rapid_modules(program, actions=result.cycle.actions).values():
        assert rapid_commands(text) == expected
        assert "regrasp at shape" in text  # the header lists the actions
    # without the plan's actions only the default grasp and release are written
    for text in rapid_modules(program).values():
        assert [c for _, c, _ in rapid_commands(text)] == ["close", "open"]


def test_actions_are_placed_at_their_targets_and_timed_on_the_programs_clock():
    actions = (GripperAction("grasp", 0, 0.5), GripperAction.regrasp_at(2, 0.4, 0.5),
               GripperAction("release", 3, 0.4))
    targets = np.array([1, 2, 3, 4])  # an approach target before the first knot
    placed = place_actions(actions, targets, zones=np.zeros(6))
    assert [p.target for p in placed] == [1, 3, 4]
    clock = action_clock(np.array([0.0, 0.2, 1.0, 2.0, 3.0, 3.2]), placed)
    assert np.allclose(clock.arrive, [0.0, 0.2, 1.5, 2.5, 4.4, 5.0])
    commands = gripper_commands(placed, clock)
    assert [c.command for c in commands] == ["close", "open", "close", "open"]
    assert np.allclose([(c.time, c.wait) for c in commands],
                       [(0.2, 0.5), (2.5, 0.4), (2.9, 0.5), (4.4, 0.4)])
    with pytest.raises(ValueError, match="release.knot"):
        place_actions((GripperAction("release", 4, 0.4),), targets)
    with pytest.raises(ValueError, match="flies by target 3"):
        place_actions(actions, targets, zones=np.array([0, 0, 0, 0.01, 0, 0]))
