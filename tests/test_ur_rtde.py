"""The UR pair's RTDE streamer, run offline against a fake RTDE interface.

The written program (``dloplan.io.ur_rtde``) is imported from its file and driven with fake
``RTDEControlInterface`` / ``RTDEReceiveInterface`` / ``RTDEIOInterface`` objects whose robot
follows the commanded joints one lookahead late: both arms get the same instant of the plan in
every period, the gripper commands at their instants, and a fault of either arm (protective
stop, speed scaling, an arm that stops following) stops both at once. The fakes call nothing the
real ``ur_rtde`` library lacks (checked against its bindings' signatures when it is installed).
"""

from __future__ import annotations

import importlib.util
import re
import sys
import types

import numpy as np
import pytest
from program_readers import read_samples, stream_settings

from dloplan.io.ur_rtde import write_ur_rtde
from dloplan.robot.actions import ProgramTimeline, action_clock, place_actions
from dloplan.robot.motion import JointMotion
from dloplan.trajectory import GripperAction
from dloplan.trajectory.timelaw import Profile


def _timeline() -> ProgramTimeline:
    """Two 6-joint arms through 3 targets (two jerk-limited moves), a grasp at the first, a
    regrasp at the second and a release at the last."""
    rng = np.random.default_rng(7)
    targets = rng.uniform(-1.0, 1.0, (2, 3, 6))
    paths = tuple(tuple(np.linspace(q[m], q[m + 1], 5) + 0.02 * np.sin(
        np.linspace(0, np.pi, 5))[:, None] for m in range(2)) for q in targets)
    law = Profile.jerk_limited(2.0, 10.0, 100.0)
    motion = JointMotion(paths, (law, law), np.array([0.0, law.duration]),
                         np.array([0.0, law.duration, 2 * law.duration]))
    actions = (GripperAction("grasp", 0, 0.5), GripperAction.regrasp_at(1, 0.4, 0.5),
               GripperAction("release", 2, 0.4))
    placed = place_actions(actions, np.arange(3))
    return ProgramTimeline(motion, action_clock(motion.arrivals, placed), placed)


class FakeRobot:
    """A controller whose arm reaches the commanded joints ``lag`` periods later."""

    def __init__(self, q, lag: int):
        self.actual = list(q)
        self.queue: list = []
        self.lag = lag
        self.servo: list = []
        self.stopped_at = None
        self.outputs: list = []
        self.protective = False
        self.scaling = 1.0
        self.frozen = False
        self.period = 0


class FakeControl:
    def __init__(self, robot: FakeRobot):
        self.robot = robot

    def initPeriod(self):  # noqa: N802 - ur_rtde's names
        return self.robot.period

    def waitPeriod(self, start):  # noqa: N802
        for robot in ROBOTS:
            robot.period += 1

    def servoJ(self, q, speed, acceleration, time, lookahead, gain):  # noqa: N802
        assert self.robot.stopped_at is None, "servoJ after servoStop"
        assert 0.03 <= lookahead <= 0.2 and 100 <= gain <= 2000
        self.robot.servo.append((self.robot.period, list(q)))
        self.robot.queue.append(list(q))
        if len(self.robot.queue) > self.robot.lag and not self.robot.frozen:
            self.robot.actual = self.robot.queue[-1 - self.robot.lag]
        return True

    def moveJ(self, q, speed, acceleration, asynchronous):  # noqa: N802
        assert speed > 0 and not asynchronous
        self.robot.actual = list(q)
        return True

    def isProgramRunning(self):  # noqa: N802
        return True

    def servoStop(self, a):  # noqa: N802
        self.robot.stopped_at = self.robot.period
        return True

    def setWatchdog(self, min_frequency):  # noqa: N802
        return True

    def kickWatchdog(self):  # noqa: N802
        return True


class FakeReceive:
    def __init__(self, robot: FakeRobot):
        self.robot = robot

    def getActualQ(self):  # noqa: N802
        return list(self.robot.actual)

    def isEmergencyStopped(self):  # noqa: N802
        return False

    def isProtectiveStopped(self):  # noqa: N802
        return self.robot.protective

    def getSafetyMode(self):  # noqa: N802
        return 3 if self.robot.protective else 1

    def getRobotMode(self):  # noqa: N802
        return 7

    def getSpeedScalingCombined(self):  # noqa: N802
        return self.robot.scaling


class FakeIO:
    def __init__(self, robot: FakeRobot):
        self.robot = robot

    def setStandardDigitalOut(self, output, level):  # noqa: N802
        self.robot.outputs.append((self.robot.period, "standard", output, level))
        return True

    def setToolDigitalOut(self, output, level):  # noqa: N802
        self.robot.outputs.append((self.robot.period, "tool", output, level))
        return True


ROBOTS: list[FakeRobot] = []


@pytest.fixture
def streamer(tmp_path):
    """The written program imported from its file, its settings and samples."""
    written = write_ur_rtde(tmp_path, _timeline(), rate=125.0,
                            gripper={"output": 3, "tool": False, "closed": True},
                            notes=("a note",))
    spec = importlib.util.spec_from_file_location("dlo_stream_test", written[0])
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module, stream_settings(written[0]), read_samples(written[1])


def _arms(module, lag):
    ROBOTS[:] = [FakeRobot(np.zeros(6), lag) for _ in range(2)]
    return [module.Arm(name, FakeControl(r), FakeReceive(r), FakeIO(r))
            for name, r in zip(("left", "right"), ROBOTS, strict=True)]


def test_both_arms_get_every_sample_in_the_same_period(streamer):
    module, settings, (times, left, right) = streamer
    samples = module.load_samples(module.Path(module.__file__).with_name(module.SAMPLES))
    assert len(samples) == len(times) and settings["RATE"] == 125.0
    arms = _arms(module, module.LAG)
    module.move_to_start(arms, samples)
    module.stream(arms, samples)
    for robot, expected in zip(ROBOTS, (left, right), strict=True):
        periods = [p for p, _ in robot.servo]
        assert periods == list(range(len(times)))  # one servoJ per period, none skipped
        assert np.allclose([q for _, q in robot.servo], expected, atol=0)
        assert robot.stopped_at == len(times)  # servo mode ended after the last sample
    # the gripper: opened before the start, then every planned command at its instant
    timeline = _timeline()
    expected = [("open", 0)] + [(c.command, int(np.ceil(c.time * 125.0 - 1e-9)))
                                for c in timeline.commands]
    for robot in ROBOTS:
        got = [("close" if level else "open", period) for period, kind, output, level
               in robot.outputs]
        assert all(kind == "standard" and output == 3 for _, kind, output, _ in robot.outputs)
        assert got == expected


def test_samples_hold_the_arms_while_the_gripper_acts(streamer):
    module, settings, (times, left, right) = streamer
    timeline = _timeline()
    for c in timeline.commands:
        inside = (times >= c.time) & (times <= c.time + c.wait)
        for a, q in enumerate((left, right)):
            target = timeline.motion.paths[a][min(c.target, 1)][0 if c.target < 2 else -1]
            assert np.abs(q[inside] - target).max() < 1e-8
    assert times[-1] == pytest.approx(timeline.clock.end, abs=1 / 125.0)


@pytest.mark.parametrize("fault", ["protective", "scaling", "frozen"])
def test_a_fault_of_one_arm_stops_both_in_the_same_period(streamer, fault):
    module, _, (times, _, _) = streamer
    samples = module.load_samples(module.Path(module.__file__).with_name(module.SAMPLES))
    arms = _arms(module, module.LAG)
    module.move_to_start(arms, samples)
    at = len(times) // 2
    original = FakeControl.waitPeriod

    def wait(self, start):
        original(self, start)
        if ROBOTS[1].period == at:
            if fault == "protective":
                ROBOTS[1].protective = True
            elif fault == "scaling":
                ROBOTS[1].scaling = 0.5
            else:
                ROBOTS[1].frozen = True  # the arm stops following: tracking error grows

    FakeControl.waitPeriod = wait
    try:
        with pytest.raises(module.Fault, match="right arm"):
            module.stream(arms, samples)
    finally:
        FakeControl.waitPeriod = original
    left, right = ROBOTS
    assert left.stopped_at == right.stopped_at  # both stopped in the same period
    assert at <= left.stopped_at < len(times) - 1
    assert len(left.servo) == len(right.servo) == left.stopped_at


def test_an_arm_away_from_the_start_is_not_started(streamer):
    module, _, _ = streamer
    samples = module.load_samples(module.Path(module.__file__).with_name(module.SAMPLES))
    arms = _arms(module, module.LAG)
    arms[0].control.moveJ = lambda q, v, a, asynchronous: True  # it does not get there
    with pytest.raises(module.Fault, match="left arm: .* from the start joints"):
        module.move_to_start(arms, samples)
    assert not ROBOTS[0].servo and not ROBOTS[1].servo
    # a program that does not pick the cable up (the arms hold it) moves nothing to the start
    # and opens no gripper
    module.OPEN_FIRST = False
    arms = _arms(module, module.LAG)
    with pytest.raises(module.Fault, match="left arm: .* from the start joints"):
        module.move_to_start(arms, samples)
    assert not ROBOTS[0].outputs and ROBOTS[0].actual == [0.0] * 6


def test_the_program_runs_end_to_end_through_its_main(streamer, monkeypatch, capsys):
    module, _, (times, _, _) = streamer
    fakes = {}
    for name in ("rtde_control", "rtde_receive", "rtde_io"):
        fakes[name] = types.ModuleType(name)
        monkeypatch.setitem(sys.modules, name, fakes[name])
    ROBOTS[:] = [FakeRobot(np.zeros(6), module.LAG) for _ in range(2)]
    by_host = dict(zip(("10.0.0.1", "10.0.0.2"), ROBOTS, strict=True))
    fakes["rtde_control"].RTDEControlInterface = lambda host, rate: FakeControl(by_host[host])
    fakes["rtde_receive"].RTDEReceiveInterface = lambda host, rate: FakeReceive(by_host[host])
    fakes["rtde_io"].RTDEIOInterface = lambda host: FakeIO(by_host[host])
    assert module.main(["--left", "10.0.0.1", "--right", "10.0.0.2"]) == 0
    assert len(ROBOTS[0].servo) == len(ROBOTS[1].servo) == len(times)
    assert module.main(["--dry-run"]) == 0
    assert module.main([]) == 2  # no hosts in the settings, none given
    assert "--left and --right" in capsys.readouterr().err


def test_bad_samples_are_refused_before_connecting(streamer, tmp_path):
    module, settings, _ = streamer
    path = module.Path(module.__file__).with_name(settings["SAMPLES"])
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:5] + lines[6:]) + "\n")  # a period missing
    with pytest.raises(ValueError, match="row 4: expected time"):
        module.load_samples(path)
    assert module.main(["--dry-run"]) == 2


def test_bad_settings_are_named():
    timeline = _timeline()
    with pytest.raises(ValueError, match="gripper.output"):
        write_ur_rtde("unused", timeline, gripper={"output": 2, "tool": True, "closed": True})
    with pytest.raises(ValueError, match="lookahead"):
        write_ur_rtde("unused", timeline, lookahead=0.5)


def test_the_fakes_call_only_what_ur_rtde_offers():
    """Every method the streamer calls exists in the real library with at least the
    positional arguments given (pybind11 signatures in the docstrings)."""
    rtde_control = pytest.importorskip("rtde_control")
    rtde_receive = pytest.importorskip("rtde_receive")
    rtde_io = pytest.importorskip("rtde_io")
    for fake, real in ((FakeControl, rtde_control.RTDEControlInterface),
                       (FakeReceive, rtde_receive.RTDEReceiveInterface),
                       (FakeIO, rtde_io.RTDEIOInterface)):
        for name, method in vars(fake).items():
            if name.startswith("_"):
                continue
            assert hasattr(real, name), (real.__name__, name)
            ours = method.__code__.co_argcount - 1
            signatures = re.findall(rf"{name}\(self: [\w.]+(.*?)\) ->", real.__dict__[name].__doc__)
            counts = [len(re.findall(r", \w+: ", s)) for s in signatures]
            assert any(c >= ours for c in counts), (name, ours, signatures)
            required = [len(re.findall(r", \w+: [^,=]+(?=,|$)", s)) for s in signatures]
            assert any(r <= ours for r in required), (name, ours, signatures)
    # the constructors take the host and the rate (positionally)
    assert "hostname: str, frequency: float" in rtde_control.RTDEControlInterface.__init__.__doc__
    assert "hostname: str, frequency: float" in rtde_receive.RTDEReceiveInterface.__init__.__doc__
