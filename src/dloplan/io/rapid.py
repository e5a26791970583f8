"""ABB RAPID program for a YuMi (IRB 14000): the modules of a verified
:class:`~dloplan.robot.program.RobotProgram` on the YuMi's cell (its targets the YuMi's
plug-in, :class:`~dloplan.robot.yumi_program.YumiTargets`).

One module per motion task, ``T_ROB_L`` (left arm) and ``T_ROB_R`` (right arm), each in its own
``.mod`` file. Each module declares everything it uses: the task list and ``syncident`` s, the
arm's ``tooldata`` (from :class:`~dloplan.robot.cell.Tool`, ABB's SmartGripper data by
default) and the ``wobjdata`` (the plan's frame seen from the robot's base), the start
``jointtarget``, one ``speeddata`` per move (the planned speeds), and one ``robtarget`` per
program target whose position, orientation, confdata and arm angle (``eax_a``, RobotWare's arm
angle of :mod:`dloplan.robot.armangle` with the cell's reference direction, named in the
header) are those the program verified. Its ``PROC main()`` runs::

    ConfL \\On;                              (stop rather than take another configuration)
    g_GripOut;                               (SmartGripper open, when the program picks the
                                              cable up: its first action is a grasp)
    MoveAbsJ dlo_start, v100, fine, tool;    (the verified joints of the first target)
    SyncMoveOn dlo_sync_on, dlo_tasks;
    MoveL dlo_p01 \\ID:=10, dlo_v01 \\T:=0.5, fine, tool \\WObj:=wobj;   (approach -> grasp;
        \\T: the planned, jerk-limited duration; fly-by shapes get a declared zonedata)
    SyncMoveOff dlo_off_01;                  (a planned gripper action at this target:)
    WaitSyncTask dlo_g01, dlo_tasks;         (both grippers start together)
    g_GripIn; WaitTime 0.5;                  (the planned grasp and its duration)
    SyncMoveOn dlo_on_01, dlo_tasks;         (both arms move on together)
    MoveL dlo_p02 \\ID:=20, dlo_v02, ...      (one MoveL per shape, same IDs in both tasks)
    ...                                      (a regrasp: g_GripOut; WaitTime t_open;
                                              WaitSyncTask; g_GripIn; WaitTime t_close)
    SyncMoveOff dlo_off_09; WaitSyncTask dlo_g03, dlo_tasks; g_GripOut; WaitTime 0.4;
    SyncMoveOn dlo_on_09, dlo_tasks;
    MoveL ... (retreat)
    SyncMoveOff dlo_sync_off;

In synchronized mode the controller starts and ends each pair of ``MoveL`` with the same
``\\ID`` together; each arm's ``speeddata`` is its planned speed in that segment (TCP mm/s and
orientation deg/s), so both arrive at the planned time. **Gripper actions**: every action of
the plan's cycle (:mod:`dloplan.robot.actions`: grasp, release, a harness job's regrasp) is
written at its target as SmartGripper calls (``g_GripIn`` closes, ``g_GripOut`` opens) each
followed by the planned ``WaitTime``; the tasks leave synchronized mode at the target (a fine
point), meet at a ``WaitSyncTask`` before every call so both grippers act together, and enter
it again before the next move. Robtargets are in millimetres in the work object, orientations
as RAPID quaternions [q1, q2, q3, q4] = [w, x, y, z] with q1 >= 0. Loading and teaching:
``docs/robot.md``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..grippers.axes import CLIP_NAMES
from ..output_files import atomic_write_texts
from ..robot.actions import default_actions, picks_up, place_actions
from ..robot.cell import check_rapid_name
from ..robot.program import RobotProgram
from ..robot.yumi_program import YumiTargets
from ..trajectory import ARMS

RAPID_FORMAT_VERSION = 3
_NOT_USED = "9E+09"


@dataclass(frozen=True)
class RapidSettings:
    """How the RAPID modules are named (what they contain comes from the program and its cell).

    Parameters
    ----------
    tasks : tuple of str
        Motion task names of the left and the right arm.
    modules : tuple of str
        Module names (also the file stems) for the left and the right arm.
    procedure : str
        Name of the generated motion procedure (``main`` calls it).
    start_speed : str
        ``speeddata`` of the first ``MoveAbsJ`` (from wherever the arm is to the start joints;
        a predefined one of the controller).
    zone : str
        ``zonedata`` of the MoveLs that stop (``fine``); fly-by shapes get their own.
    """

    tasks: tuple[str, str] = ("T_ROB_L", "T_ROB_R")
    modules: tuple[str, str] = ("DloPlanL", "DloPlanR")
    procedure: str = "dloplan_move"
    start_speed: str = "v100"
    zone: str = "fine"

    def __post_init__(self) -> None:
        for name in ("tasks", "modules"):
            value = getattr(self, name)
            if not isinstance(value, tuple | list) or len(value) != 2:
                raise ValueError(f"{name}: got {value!r}, expected a pair (left arm, right arm)")
            for arm, item in zip(ARMS, value, strict=True):
                check_rapid_name(f"{name} ({arm})", item)
        if self.tasks[0] == self.tasks[1] or self.modules[0] == self.modules[1]:
            raise ValueError("tasks/modules: the two arms need different task and module names")
        for name in ("procedure", "start_speed", "zone"):
            check_rapid_name(name, getattr(self, name))
        if self.procedure == "main":
            raise ValueError("procedure: 'main' is the module's entry point; name the motion "
                             "procedure otherwise")


def _num(value: float, decimals: int) -> str:
    text = f"{value:.{decimals}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def _array(values, decimals: int) -> str:
    return "[" + ",".join(_num(float(v), decimals) for v in values) + "]"


def _extax(arm_angle_deg: float) -> str:
    return "[" + ",".join([_num(arm_angle_deg, 6)] + [_NOT_USED] * 5) + "]"


def robtarget_text(position_m, quat_wxyz, robconf, arm_angle: float) -> str:
    """A RAPID robtarget literal: [[x,y,z] mm, [q1..q4] w-first, confdata, extax (eax_a deg)]."""
    trans = _array(np.asarray(position_m, dtype=float) * 1000.0, 6)
    rot = _array(quat_wxyz, 9)
    conf = "[" + ",".join(str(int(c)) for c in robconf) + "]"
    return f"[{trans},{rot},{conf},{_extax(arm_angle)}]"


def jointtarget_text(q) -> str:
    """A RAPID jointtarget literal of a YuMi joint vector (7,) [rad] in physical order:
    robax = ABB axes 1..6 [deg], extax = [axis 7, 9E+09 x 5]."""
    deg = np.degrees(np.asarray(q, dtype=float))
    return f"[{_array(deg[[0, 1, 3, 4, 5, 6]], 6)},{_extax(deg[2])}]"


def _pose_text(position_m, rotation) -> str:
    quat = rotation.as_quat(canonical=True, scalar_first=True)
    return f"[{_array(np.asarray(position_m) * 1000.0, 6)},{_array(quat, 9)}]"


def tooldata_text(tool) -> str:
    """The RAPID tooldata literal of a :class:`~dloplan.robot.cell.Tool` (robot-held; mm, kg,
    kg m^2)."""
    load = (f"[{_num(tool.mass, 6)},{_array(tool.cog * 1000.0, 6)},[1,0,0,0],"
            f"{','.join(_num(v, 9) for v in tool.inertia)}]")
    return f"[TRUE,{_pose_text(tool.tcp_offset, tool.tcp_rotation)},{load}]"


def wobjdata_text(cell) -> str:
    """The RAPID wobjdata literal of a cell: fixed (not robot-held), programmed user frame =
    the work frame seen from the robot's base, object frame identity."""
    position, rotation = cell.wobj_frame
    return f'[FALSE,TRUE,"",{_pose_text(position, rotation)},[[0,0,0],[1,0,0,0]]]'


def speeddata_text(v_tcp: float, v_ori: float) -> str:
    """A RAPID speeddata literal from TCP speed [m/s] and angular speed [rad/s]."""
    return _array([v_tcp * 1000.0, math.degrees(v_ori), 5000, 1000], 6)


def rapid_modules(program: RobotProgram, settings: RapidSettings | None = None,
                  notes=(), actions=None) -> dict[str, str]:
    """The RAPID module text of each task (module docstring).

    Parameters
    ----------
    program : RobotProgram
        The verified program on the YuMi (:func:`dloplan.robot.robot_program`).
    settings : RapidSettings, optional
    notes : sequence of str
        Lines of text written as comments into each module's header (where the job must be
        placed on the table when a repair moved it, docs/repair.md).
    actions : sequence of GripperAction, optional
        The plan's gripper actions (its cycle's); default a grasp at the first shape and a
        release at the last with the default durations
        (:func:`dloplan.robot.actions.default_actions`).

    Returns
    -------
    dict
        Task name -> module text, left arm first.
    """
    from .. import __version__  # at call time: dloplan/__init__ may import this module

    _check_program(program)
    s = settings or RapidSettings()
    cell, targets = program.cell, program.targets
    n = program.n_targets
    knots = program.knot_targets()
    placed = place_actions(default_actions(len(knots)) if actions is None else actions, knots,
                           targets.zones)
    width = max(2, len(str(n - 1)))
    names = [f"dlo_p{i:0{width}d}" for i in range(n)]
    speeds = [f"dlo_v{i:0{width}d}" for i in range(1, n)]
    tasks_list = "[" + ",".join(f'["{t}"]' for t in s.tasks) + "]"
    hold = "" if cell.hold_force is None else f" \\holdForce:={_num(cell.hold_force, 3)}"
    zones = _zone_names(program, s.zone)
    modules = {}
    for a, arm in enumerate(ARMS):
        tool = cell.tools[a]
        clip = CLIP_NAMES[targets.assignment.clips[a]]
        tail = f", {tool.name} \\WObj:={cell.wobj};"
        body, syncs = _procedure(program, placed, names, speeds, zones, tail, hold)
        lines = [
            f"MODULE {s.modules[a]}",
            f"    ! Generated by dloplan {__version__} (dloplan RAPID format "
            f"{RAPID_FORMAT_VERSION}): synchronized dual-arm cable manipulation.",
            f"    ! Task {s.tasks[a]}: {arm} arm, {clip} clip"
            f"{', grip turned by 180 deg about the TCP z-axis' if targets.grip_turned[a] else ''}"
            f". Task {s.tasks[1 - a]} runs module {s.modules[1 - a]} with the same move IDs.",
            f"    ! Verified by dloplan on exactly these targets: {program.message}.",
            *(f"    ! {note}" for note in notes),
            f"    ! Tool {tool.name}: {tool.source}.",
            f"    ! Work object {cell.wobj}: the plan's frame in the robot's base frame; teach "
            "it in the cell (docs/robot.md).",
            f"    ! Robtargets in mm in {cell.wobj}; quaternions [q1,q2,q3,q4] = [w,x,y,z]; "
            "confdata and eax_a (the arm angle) from the verified joint solution.",
            "    ! eax_a is RobotWare's arm angle (new arm-angle definition, RobotWare 6 and "
            "later) with the Arm-Angle Reference Direction "
            f"{_array(cell.arm_angle_reference[a], 6)} in the robot's base frame: the "
            "controller's Motion > Robot setting must be the same (docs/robot.md).",
            f"    ! {n} targets ({program.labels[0]} to {program.labels[-1]}); planned duration "
            f"{targets.path_duration:.3f} s" + (
                f" from grasp to release ({program.times[-1]:.3f} s with approach and retreat; "
                "the gripper actions' waits come on top)." if cell.approach > 0 else
                ", no approach or retreat (the gripper actions' waits come on top)."),
            f"    ! Gripper actions (plan.json cycle): {_action_summary(placed, program.labels)}.",
            f"    PERS tasks dlo_tasks{{2}} := {tasks_list};",
            *(f"    VAR syncident {name};" for name in syncs),
            f"    PERS tooldata {tool.name} := {tooldata_text(tool)};",
            f"    PERS wobjdata {cell.wobj} := {wobjdata_text(cell)};",
            f"    CONST jointtarget dlo_start := {jointtarget_text(program.joints[a][0])};",
        ]
        for m, name in enumerate(speeds):
            lines.append(f"    CONST speeddata {name} := "
                         f"{speeddata_text(*targets.speeds[m, a])};")
        for m, name in enumerate(names):
            target = robtarget_text(targets.positions[m, a], targets.quaternions[m, a],
                                    targets.confdata[m, a], targets.arm_angles[m, a])
            lines.append(f"    CONST robtarget {name} := {target};  ! {program.labels[m]}")
        for radius, name in sorted(set(zones.values()) - {(0.0, s.zone)}):
            lines.append(f"    CONST zonedata {name} := {zonedata_text(radius)};")
        lines += [
            "    PROC main()",
            f"        {s.procedure};",
            "    ENDPROC",
            f"    PROC {s.procedure}()",
            "        ConfL \\On;",
            *(["        g_GripOut;"] if picks_up(placed) else []),
            f"        MoveAbsJ dlo_start, {s.start_speed}, fine, {tool.name} \\WObj:={cell.wobj};",
            *body,
            "    ENDPROC",
            "ENDMODULE",
        ]
        modules[s.tasks[a]] = "\n".join(lines) + "\n"
    return modules


def _procedure(program: RobotProgram, placed, names, speeds, zones, tail: str,
               hold: str) -> tuple[list[str], list[str]]:
    """The motion procedure's lines after the first ``MoveAbsJ`` (module docstring) and the
    ``syncident`` s they use, in order."""
    n = program.n_targets
    at = {m: [p for p in placed if p.target == m] for m in range(n)}
    width = len(str(n - 1))
    body: list[str] = []
    syncs = ["dlo_sync_on"]
    count = 0

    def act(m: int) -> None:
        nonlocal count
        for p in at[m]:
            for command, wait in p.action.commands():
                count += 1
                syncs.append(f"dlo_g{count:02d}")
                call = f"g_GripIn{hold}" if command == "close" else "g_GripOut"
                body.extend([f"        WaitSyncTask {syncs[-1]}, dlo_tasks;",
                             f"        {call};  ! {p.action.name}",
                             f"        WaitTime {_num(wait, 4)};"])

    act(0)
    body.append("        SyncMoveOn dlo_sync_on, dlo_tasks;")
    for m in range(1, n):
        body.append(f"        MoveL {names[m]} \\ID:={10 * m}, {speeds[m - 1]} "
                    f"\\T:={_num(program.targets.durations[m - 1], 4)}, {zones[m][1]}{tail}")
        if at[m]:
            syncs.append(f"dlo_off_{m:0{width}d}")
            body.append(f"        SyncMoveOff {syncs[-1]};")
            act(m)
            if m < n - 1:
                syncs.append(f"dlo_on_{m:0{width}d}")
                body.append(f"        SyncMoveOn {syncs[-1]}, dlo_tasks;")
    if not at[n - 1]:
        syncs.append("dlo_sync_off")
        body.append("        SyncMoveOff dlo_sync_off;")
    return body, syncs


def _action_summary(placed, labels) -> str:
    """One line: every planned gripper action at its target with its commands' waits."""
    if not placed:
        return "none"
    return "; ".join(
        f"{p.action.name} at {labels[p.target]} ("
        + " + ".join(f"{'close' if c == 'close' else 'open'} {_num(w, 4)} s"
                     for c, w in p.action.commands()) + ")" for p in placed)


def zonedata_text(radius: float) -> str:
    """A fly-by ``zonedata`` of TCP zone ``radius`` [m], proportioned like ABB's z-values."""
    mm = 1e3 * radius
    return f"[FALSE,{_num(mm, 2)},{_num(1.5 * mm, 2)},{_num(1.5 * mm, 2)},{_num(0.15 * mm, 3)}," \
        f"{_num(1.5 * mm, 2)},{_num(0.15 * mm, 3)}]"


def _zone_names(program: RobotProgram, fine: str) -> dict:
    """Target index -> (zone radius [m], zonedata name): ``fine`` at stops, one declared
    ``dlo_zNNN`` per fly-by radius (in tenths of a millimetre)."""
    zones = program.targets.zones
    return {m: (0.0, fine) if r <= 0 else (float(r), f"dlo_z{round(1e4 * r):03d}")
            for m, r in enumerate(zones)}


def _check_program(program) -> None:
    """ValueError unless ``program`` is a RobotProgram on the YuMi's cell."""
    if not isinstance(program, RobotProgram) or not isinstance(program.targets, YumiTargets):
        kind = type(program).__name__ if not isinstance(program, RobotProgram) else \
            f"a RobotProgram on {type(program.cell).__name__}"
        raise ValueError(f"program: expected a RobotProgram on the YuMi's RobotCell, got {kind}")


def write_rapid(directory: str | os.PathLike, program: RobotProgram,
                settings: RapidSettings | None = None, *, force: bool = False,
                notes=(), actions=None) -> dict[str, Path]:
    """Write one ``<module>.mod`` file per task into ``directory``, atomically (both or none).

    The one writer of robot programs: ``dloplan plan`` and ``dloplan export --format rapid``
    both call it with :func:`dloplan.robot.robot_program` of the plan's gripper path and
    trajectory.

    Parameters
    ----------
    directory : path
    program : RobotProgram
    settings : RapidSettings, optional
    force : bool
        Write a program that fails a check too (for inspection in RobotStudio, never to run);
        by default such a program is refused.
    notes : sequence of str
        Comment lines for the modules' headers (:func:`rapid_modules`).
    actions : sequence of GripperAction, optional
        The plan's gripper actions (:func:`rapid_modules`).

    Returns
    -------
    dict
        Task name -> written file.

    Raises
    ------
    ValueError
        A program that fails a check (without ``force``), naming the failures.
    """
    s = settings or RapidSettings()
    _check_program(program)
    if not program.ok and not force:
        raise ValueError(f"program: not written, it fails its checks: {program.message}")
    texts = rapid_modules(program, s, notes, actions)
    folder = Path(directory)
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"directory: {str(folder)!r} exists and is not a folder")
    targets = {
        task: folder / f"{module}.mod" for task, module in zip(s.tasks, s.modules, strict=True)
    }
    atomic_write_texts({targets[task]: text for task, text in texts.items()})
    return targets
