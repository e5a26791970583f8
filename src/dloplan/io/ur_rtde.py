"""The program of a pair of Universal Robots arms holding one cable: both streamed from a PC
over RTDE (the ``ur_rtde`` library), in lockstep.

Two folders' worth of URScript run on two controllers with two clocks: started together, they
drift apart as soon as one slows or pauses, and the cable is held by both (docs/decisions.md).
This writer puts the pair on one clock instead. It writes into its folder

- ``<stem>_ur_pair.csv``: the verified program sampled along the plan's time law at the
  controllers' rate (``rate``, 500 Hz for e-Series, 125 Hz for CB3), one row per control
  period from time 0: ``t, left_q1..6, right_q1..6`` [s, rad]; the rows hold the arms still
  while the planned gripper actions run (:class:`dloplan.robot.actions.ProgramTimeline`);
- ``<stem>_ur_pair.py``: the streamer (:mod:`dloplan.io.ur_pair_stream`, copied with its
  settings block filled in): it moves both arms to the first row, then every period sends
  both the row's joints (``servoJ``), gives the gripper commands at their instants (each
  arm's digital output, ``gripper``), and stops both arms the period either is not in the
  expected state (protective stop, safety mode, program, speed scaling, tracking).

Settings (the cell's ``robot.ur_rtde``): ``hosts`` (the controllers' addresses, else given on
the command line), ``rate`` [Hz], ``lookahead`` [s] and ``gain`` of ``servoJ``,
``start_speed`` [rad/s] of the move to the start, ``start_tolerance`` and
``tracking_tolerance`` [rad], ``gripper`` ({output, tool, closed}: the digital output that
drives each arm's gripper and the level that closes it). Setup: docs/cells.md.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from ..output_files import atomic_write_texts

DEFAULT_GRIPPER = {"output": 1, "tool": False, "closed": True}
"""The gripper on standard digital output 1, closed by a high level (output 0 is the
URScript programs' ready signal)."""

_SETTINGS = re.compile(r"# --- settings \(written by dloplan\) ---\n.*?# --- end of settings ---\n",
                       re.S)


def check_gripper(gripper) -> dict:
    """The gripper setting ``{output, tool, closed}`` checked: a standard digital output 0..7
    or a tool output 0..1, and the closing level.

    Raises
    ------
    ValueError
        Naming the key and the value.
    """
    if not isinstance(gripper, dict) or set(gripper) != set(DEFAULT_GRIPPER):
        raise ValueError(f"gripper: got {gripper!r}, expected {{output, tool, closed}}")
    tool, output = gripper["tool"], gripper["output"]
    if not isinstance(tool, bool) or not isinstance(gripper["closed"], bool):
        raise ValueError(f"gripper: tool and closed must be true or false, got {gripper!r}")
    if isinstance(output, bool) or output not in range(2 if tool else 8):
        raise ValueError(f"gripper.output: got {output!r}, expected a "
                         f"{'tool digital output 0..1' if tool else 'standard output 0..7'}")
    return dict(gripper)


def stream_samples(timeline, rate: float) -> tuple[np.ndarray, list[np.ndarray]]:
    """The rows the streamer sends: times k / rate [s] from 0 to the program's end (the last
    row at the end or the first period after it) and per arm the joints (N, 6) [rad] there."""
    from ..robot.motion import program_samples

    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"rate: got {rate!r}, expected a control rate > 0 [Hz]")
    end = timeline.clock.end
    times = np.arange(math.ceil(end * rate - 1e-9) + 1) / rate
    values = program_samples(timeline.motion, timeline.clock, np.minimum(times, end), order=0)
    return times, [v[0] for v in values]


def write_ur_rtde(folder, timeline, *, hosts=("", ""), rate: float = 500.0,
                  lookahead: float = 0.1, gain: float = 300.0, start_speed: float = 0.5,
                  start_tolerance: float = 0.01, tracking_tolerance: float = 0.05,
                  gripper=None, stem: str = "dloplan", notes=()) -> list[Path]:
    """Write the streamer and its samples (module docstring), atomically.

    Parameters
    ----------
    folder : str or pathlib.Path
    timeline : ProgramTimeline
        The verified program of two 6-joint arms with the plan's gripper actions.
    hosts : pair of str
        The left and right controllers' addresses ("" : given on the command line).
    rate : float
        [Hz] Control rate of the controllers.
    lookahead, gain : float
        ``servoJ``'s lookahead time [s] (0.03..0.2) and gain (100..2000).
    start_speed : float
        [rad/s] Joint speed of the moves to the start.
    start_tolerance, tracking_tolerance : float
        [rad] How far an arm may be from the start joints, and during the motion from the
        joints commanded one lookahead earlier.
    gripper : dict, optional
        ``{output, tool, closed}`` (default :data:`DEFAULT_GRIPPER`).
    stem : str
    notes : sequence of str
        Comment lines for the header (where the job must be placed, docs/repair.md).

    Returns
    -------
    list of pathlib.Path
        The program and the samples.
    """
    grip = check_gripper(DEFAULT_GRIPPER if gripper is None else gripper)
    for name, value, low, high in (("lookahead", lookahead, 0.03, 0.2),
                                   ("gain", gain, 100.0, 2000.0)):
        if not low <= value <= high:
            raise ValueError(f"{name}: got {value!r}, expected {low}..{high} (servoJ)")
    for name, value in (("start_speed", start_speed), ("start_tolerance", start_tolerance),
                        ("tracking_tolerance", tracking_tolerance)):
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name}: got {value!r}, expected a positive number")
    if len(hosts) != 2 or not all(isinstance(h, str) for h in hosts):
        raise ValueError(f"hosts: got {hosts!r}, expected the (left, right) addresses")
    times, joints = stream_samples(timeline, rate)
    if any(q.shape[1] != 6 for q in joints):
        raise ValueError("timeline: the RTDE streamer drives two 6-joint UR arms")
    folder = Path(folder)
    name = f"{stem}_ur_pair"
    header = ["t"] + [f"{arm}_q{j}" for arm in ("left", "right") for j in range(1, 7)]
    lines = [f"# {note}" for note in notes] + [",".join(header)]
    lines += [",".join(f"{v:.9f}" for v in (t, *q_l, *q_r))
              for t, q_l, q_r in zip(times, *joints, strict=True)]
    actions = [(round(c.time, 9), c.command, c.action, round(c.wait, 9))
               for c in timeline.commands]
    settings = "\n".join([
        "# --- settings (written by dloplan) ---",
        *(f"# {note}" for note in notes),
        f"SAMPLES = {name + '.csv'!r}",
        f"RATE = {float(rate)!r}",
        f"HOSTS = {{'left': {hosts[0]!r}, 'right': {hosts[1]!r}}}",
        f"LOOKAHEAD = {float(lookahead)!r}",
        f"GAIN = {float(gain)!r}",
        f"START_SPEED = {float(start_speed)!r}",
        f"START_TOLERANCE = {float(start_tolerance)!r}",
        f"TRACKING_TOLERANCE = {float(tracking_tolerance)!r}",
        "STOP_DECELERATION = 10.0",
        "WATCHDOG = 10.0",
        f"GRIPPER = {grip!r}",
        f"OPEN_FIRST = {timeline.picks_up!r}",
        "# (time [s], command, planned action, wait [s]) of every gripper command",
        f"ACTIONS: list = {actions!r}",
        "# --- end of settings ---",
        ""])
    template = Path(__file__).with_name("ur_pair_stream.py").read_text(encoding="utf-8")
    program = _SETTINGS.sub(lambda _: settings, template, count=1)
    targets = {folder / f"{name}.py": program, folder / f"{name}.csv": "\n".join(lines) + "\n"}
    atomic_write_texts(targets)
    return list(targets)
