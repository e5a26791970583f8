"""URScript programs for a pair of Universal Robots arms: one script per arm, synchronized start.

Each arm gets ``<stem>_<arm>.script``, one ``def ... end`` program that

1. sets the tool (``set_tcp``) from the cell's TCP offset, when given;
2. defines the gripper hooks ``dloplan_grip_close()`` and ``dloplan_grip_open()``: each sets
   the gripper's digital output (the cell's ``gripper`` setting: the output, standard or tool,
   and the level that closes); replace their bodies for a gripper driven otherwise (a URCap's
   functions, say), the rest of the program calls only them;
3. opens the gripper (when the program picks the cable up: its first action is a grasp) and
   moves with ``movej`` to the verified start joints (so the controller
   is on the verified configuration branch before any Cartesian move);
4. raises its *ready* standard digital output and waits until its *start* standard digital
   input is high: wire both inputs to one start signal (a PLC output, a push button, or one
   robot's ready output to the other's input) so both arms leave together;
5. runs the motion, one line per waypoint, either

   - ``mode="movej"`` (default): ``movej(q, t=dt, r=blend)`` to every verified joint vector
     with the planned segment duration ``dt`` [s]: with ``t`` given the controller times each
     move to exactly ``dt``; or
   - ``mode="movel"``: ``movel(p[x, y, z, rx, ry, rz], a, v, r=blend)`` to every TCP pose in the
     arm's base frame [m, axis-angle rad] at the planned TCP speed ``v`` [m/s]; the controller
     solves its own IK, continuing from the verified start configuration;

   and at every waypoint where the plan has a gripper action (grasp, release, regrasp;
   :mod:`dloplan.robot.actions`), its commands: ``dloplan_grip_close()`` or
   ``dloplan_grip_open()`` each followed by ``sleep(wait)`` with the planned wait. A blend
   radius ``r`` is written at a waypoint only up to half of the TCP segments on either side of
   it (:func:`blend_radii`): UR's controller does not blend across overlapping radii (its
   manual: "blends cannot overlap"); where the blend is reduced the header says so. A blend
   leaves the verified path by up to ``r`` at the corner;
6. lowers the ready output.

**Not synchronized past the start**: each controller runs its own clock, so the arms drift
apart as soon as one slows or pauses (speed slider, a protective stop). Where both arms hold
the cable, run the ``ur_rtde`` program instead (:mod:`dloplan.io.ur_rtde`: both arms streamed
from one PC in lockstep, both stopped when either faults; docs/decisions.md). The user sets up
in the cell: the robot's base frame as installed (the scripts' poses are in each arm's base
frame, i.e. the controller's ``base``), the tool's mass and centre of gravity
(``set_payload``, not written), the wiring of the start signal and of the gripper, and a speed
slider of 100 % for the timing to hold. Numbers are written with 9 decimals (rad, m, s): well
below the 0.1 mm / 0.05 deg verification tolerance.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..output_files import atomic_write_texts
from ..robot.actions import picks_up
from .ur_rtde import DEFAULT_GRIPPER, check_gripper

MODES = ("movej", "movel")
"""Motion commands a script can be written with."""

MIN_SPEED = 1e-4
"""[m/s] Smallest ``movel`` speed written."""

DIGITS = 9
"""Decimals of every number written."""


def _number(value: float) -> str:
    text = f"{float(value):.{DIGITS}f}"
    return "0.000000000" if text.startswith("-") and float(text) == 0.0 else text


def _list(values) -> str:
    return "[" + ", ".join(_number(v) for v in values) + "]"


def _check(name: str, value, shape: tuple) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != shape or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite values of shape {shape}, got {arr.shape}")
    return arr


def _action_lines(placed) -> list[str]:
    """The script lines of the gripper actions at one waypoint: hook call and planned wait."""
    return [line for p in placed for command, wait in p.action.commands()
            for line in (f"  dloplan_grip_{command}()  # {p.action.name}",
                         f"  sleep({_number(wait)})")]


def _action_summary(actions) -> str:
    """One line: every gripper action at its waypoint with its commands' waits."""
    if not actions:
        return "none"
    return "; ".join(f"{p.action.name} at waypoint {p.target} ("
                     + " + ".join(f"{c} {w:g} s" for c, w in p.action.commands()) + ")"
                     for p in actions)


def blend_radii(positions, blend: float, stops) -> np.ndarray:
    """(M,) the blend radius [m] written at each waypoint of one arm: ``blend`` at most half of
    the TCP segment before and after it (so no two radii overlap), 0 at the first and last
    waypoint and where ``stops`` (a gripper acts there).

    Parameters
    ----------
    positions : array_like
        (M, 3) the arm's TCP at each waypoint [m] (any frame fixed to the arm's base).
    blend : float
        The blend radius asked [m].
    stops : sequence of bool
        (M,) whether the arm stands at each waypoint.
    """
    segments = np.linalg.norm(np.diff(np.asarray(positions, float), axis=0), axis=1)
    radii = np.zeros(len(segments) + 1)
    radii[1:-1] = np.minimum(blend, 0.5 * np.minimum(segments[:-1], segments[1:]))
    radii[np.asarray(stops, bool)] = 0.0
    return radii


def write_urscript(folder, times, joints, *, tcp_positions=None, tcp_rotvecs=None,
                   speeds=None, tcp_offsets=None, mode: str = "movej", blend: float = 0.0,
                   acceleration: float = 1.2, start_speed: float = 0.5,
                   arms=("left", "right"), start_input: int = 0, ready_output: int = 0,
                   gripper=None, actions=(), stem: str = "dloplan",
                   notes=()) -> list[Path]:
    """Write one URScript program per arm (module docstring).

    Parameters
    ----------
    folder : str or pathlib.Path
        Output folder (created).
    times : array_like
        (M,) time [s] each waypoint is reached, increasing.
    joints : sequence of array_like
        Per arm (M, 6) the verified joint values [rad] (controller order, base to wrist 3).
    tcp_positions : array_like, optional
        (M, A, 3) TCP positions [m] in each arm's base frame; required for ``movel`` and for
        a ``blend`` (its radius is kept within half of each segment).
    tcp_rotvecs : array_like, optional
        (M, A, 3) TCP orientations as rotation vectors [rad] in each arm's base frame.
    speeds : array_like, optional
        (M - 1, A) planned TCP speed [m/s] of each move; default the straight distance over
        the segment time (``movel`` only).
    tcp_offsets : array_like, optional
        (A, 6) ``set_tcp`` pose of each arm's tool [m, rad] in the flange frame.
    mode : str
        ``"movej"`` or ``"movel"``.
    blend : float
        Blend radius [m] of every intermediate waypoint, at most half of the TCP segments
        beside it (0: stop exactly at each).
    acceleration : float
        ``movel`` tool acceleration [m/s^2].
    start_speed : float
        Joint speed [rad/s] of the first ``movej`` to the start joints.
    arms : sequence of str
        Arm names (file names and program names).
    start_input, ready_output : int
        Standard digital input waited for, output raised while ready (0..7).
    gripper : dict, optional
        ``{output, tool, closed}``: the digital output of the gripper hooks and the level that
        closes (default :data:`dloplan.io.ur_rtde.DEFAULT_GRIPPER`).
    actions : sequence of ProgramAction
        The plan's gripper actions at their waypoints (:func:`dloplan.robot.actions.
        place_actions`); a blend is not written into a waypoint with an action (the arms
        stand there).
    stem : str
        File name stem.
    notes : sequence of str
        Lines of text written as comments into each script's header (where the job must be
        placed on the table when a repair moved it, docs/repair.md).

    Returns
    -------
    list of pathlib.Path
        The scripts, in the order of ``arms``.
    """
    if mode not in MODES:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or len(t) < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ValueError(f"times: expected at least 2 increasing finite times [s], got {times!r}")
    n_arms, n_points = len(arms), len(t)
    if len(joints) != n_arms:
        raise ValueError(f"joints: expected one (M, 6) array per arm of {tuple(arms)}, got "
                         f"{len(joints)}")
    q = [_check(f"joints[{a}]", joints[a], (n_points, 6)) for a in range(n_arms)]
    for name, value in (("blend", blend), ("acceleration", acceleration),
                        ("start_speed", start_speed)):
        if not (np.isfinite(value) and value >= 0) or (name != "blend" and value == 0):
            raise ValueError(f"{name}: expected a positive number, got {value!r}")
    for name, value in (("start_input", start_input), ("ready_output", ready_output)):
        if value not in range(8):
            raise ValueError(f"{name}: expected a standard digital I/O index 0..7, got {value!r}")
    if blend > 0 and tcp_positions is None:
        raise ValueError("tcp_positions: required for a blend (its radius is kept within half "
                         "of each segment)")
    if tcp_positions is not None:
        pos = _check("tcp_positions", tcp_positions, (n_points, n_arms, 3))
    if mode == "movel":
        if tcp_positions is None or tcp_rotvecs is None:
            raise ValueError("tcp_positions, tcp_rotvecs: required for mode 'movel'")
        rvec = _check("tcp_rotvecs", tcp_rotvecs, (n_points, n_arms, 3))
        if speeds is None:
            dist = np.linalg.norm(np.diff(pos, axis=0), axis=-1)
            speeds = dist / np.diff(t)[:, None]
        # An arm that stands still in a segment gets a crawl: movel needs v > 0.
        vel = np.maximum(_check("speeds", speeds, (n_points - 1, n_arms)), MIN_SPEED)
    offsets = None if tcp_offsets is None else _check("tcp_offsets", tcp_offsets, (n_arms, 6))
    grip = check_gripper(DEFAULT_GRIPPER if gripper is None else gripper)
    if not grip["tool"] and grip["output"] == ready_output:
        raise ValueError(f"gripper.output: standard digital output {ready_output} is the "
                         "ready_output; expected another one")
    at = {k: [] for k in range(n_points)}
    for placed in actions:
        if placed.target not in at:
            raise ValueError(f"actions: {placed.action.name} at waypoint {placed.target}, "
                             f"expected 0..{n_points - 1}")
        at[placed.target].append(placed)
    setter = "set_tool_digital_out" if grip["tool"] else "set_standard_digital_out"
    levels = {"close": grip["closed"], "open": not grip["closed"]}
    hooks = [line for command in ("close", "open") for line in (
        f"  def dloplan_grip_{command}():",
        f"    {setter}({grip['output']}, {levels[command]})",
        "  end")]
    stops = [bool(at[k]) for k in range(n_points)]
    radii = [blend_radii(pos[:, a], blend, stops) if blend > 0 else np.zeros(n_points)
             for a in range(n_arms)]
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    texts = {}
    for a, arm in enumerate(arms):
        name = f"{stem}_{arm}"
        reduced = [k for k in range(1, n_points - 1) if not stops[k] and radii[a][k] < blend]
        blend_note = ([f"# Blend radius {_number(blend)} m reduced at {len(reduced)} of "
                       f"{n_points - 2} waypoints to half of the TCP segments beside them (UR: "
                       f"blends cannot overlap), smallest {_number(radii[a][reduced].min())} m."]
                      if reduced else [])
        lines = [f"# {name}.script: dloplan plan for the {arm} arm ({n_points} waypoints, "
                 f"{t[-1] - t[0]:.3f} s, {mode}).",
                 "# Poses in this arm's base frame [m, rad]; joints [rad]. Setup: docs/cells.md.",
                 "# Not synchronized with the other arm past the start: for a cable held by "
                 "both, run the ur_rtde program.",
                 f"# Gripper actions: {_action_summary(actions)}; hooks dloplan_grip_close/"
                 f"open ({setter} {grip['output']}, closed = {levels['close']}).",
                 *blend_note,
                 *(f"# {note}" for note in notes),
                 f"def {name}():"]
        if offsets is not None:
            lines.append(f"  set_tcp(p{_list(offsets[a])})")
        lines += [*hooks,
                  *(["  dloplan_grip_open()"] if picks_up(actions) else []),
                  f"  movej({_list(q[a][0])}, a=1.0, v={_number(start_speed)})",
                  f"  set_standard_digital_out({ready_output}, True)",
                  f"  textmsg(\"{name}: ready, waiting for digital input {start_input}\")",
                  f"  while not get_standard_digital_in({start_input}):",
                  "    sync()",
                  "  end"]
        lines += _action_lines(at[0])
        for k in range(1, n_points):
            r = radii[a][k]
            if mode == "movej":
                lines.append(f"  movej({_list(q[a][k])}, t={_number(t[k] - t[k - 1])}, "
                             f"r={_number(r)})")
            else:
                pose = np.concatenate([pos[k, a], rvec[k, a]])
                lines.append(f"  movel(p{_list(pose)}, a={_number(acceleration)}, "
                             f"v={_number(vel[k - 1, a])}, r={_number(r)})")
            lines += _action_lines(at[k])
        lines += [f"  set_standard_digital_out({ready_output}, False)",
                  "end",
                  f"{name}()"]
        texts[folder / f"{name}.script"] = "\n".join(lines) + "\n"
    return atomic_write_texts(texts)
