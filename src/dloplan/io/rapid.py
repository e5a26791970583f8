"""ABB RAPID program for a YuMi (IRB 14000) executing a dual-arm trajectory.

One module per motion task, ``T_ROB_L`` (left arm) and ``T_ROB_R`` (right arm), each in its
own ``.mod`` file, to be loaded into its task. Each module declares the shared ``tasks`` list
and two ``syncident`` s, a ``speeddata`` made from the trajectory's limits, one ``robtarget``
per planned shape, and a procedure (default ``dloplan_move``, called from the task's own
``main``) that runs

    ConfL \\Off;
    SyncMoveOn dlo_sync_on, dlo_tasks;
    MoveL dlo_p00 \\ID:=10, dlo_speed, fine, tool0 \\WObj:=wobj0;
    ...                                   (one MoveL per shape, the same IDs in both tasks)
    SyncMoveOff dlo_sync_off;
    ConfL \\On;

In synchronized mode the controller makes both arms start and finish each ``MoveL`` with the
same ``\\ID`` together, the slower one setting the time: the timing rule of
:mod:`dloplan.trajectory`. Robtargets are in millimetres in the work object, orientations as
RAPID quaternions [q1, q2, q3, q4] = [w, x, y, z] with q1 >= 0; the robot configuration
(confdata) and the YuMi arm angle (first external axis value, degrees) are settings, since
the plan does not choose them; ``ConfL \\Off`` lets the controller keep the closest
configuration during the linear moves.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..grippers.axes import CLIP_NAMES
from ..trajectory import ARMS, Trajectory
from .files import atomic_write_texts
from .poses import canonical_quaternions

RAPID_FORMAT_VERSION = 1
_IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,31}$")
_NOT_USED = "9E+09"


def _identifier(name: str, value) -> str:
    if not isinstance(value, str) or not _IDENTIFIER.match(value):
        raise ValueError(
            f"{name}: got {value!r}, expected a RAPID identifier (a letter, then up to 31 "
            "letters, digits or underscores)"
        )
    return value


@dataclass(frozen=True)
class RapidSettings:
    """How the RAPID modules are named and what they refer to.

    Parameters
    ----------
    tasks : tuple of str
        Motion task names of the left and the right arm.
    modules : tuple of str
        Module names (also the file stems) for the left and the right arm.
    tools : tuple of str
        ``tooldata`` names of the left and the right arm (declared on the controller; their TCP
        must be the clip point with the clip frame, see ``tcp_in_clip`` in
        :func:`dloplan.trajectory.trajectory_from_grippers`).
    wobj : str
        ``wobjdata`` the robtargets are expressed in (its object frame is the plan's frame).
    zone : str
        ``zonedata`` of every MoveL (``fine``: stop exactly at every planned shape).
    procedure : str
        Name of the generated procedure.
    robconf : tuple of tuple of int
        ``confdata`` [cf1, cf4, cf6, cfx] of the left and the right arm's robtargets.
    arm_angles : tuple of float
        YuMi arm angle [deg] (the robtarget's first external axis) of the left and right arm.
    """

    tasks: tuple[str, str] = ("T_ROB_L", "T_ROB_R")
    modules: tuple[str, str] = ("DloPlanL", "DloPlanR")
    tools: tuple[str, str] = ("tool0", "tool0")
    wobj: str = "wobj0"
    zone: str = "fine"
    procedure: str = "dloplan_move"
    robconf: tuple[tuple[int, int, int, int], tuple[int, int, int, int]] = (
        (0, 0, 0, 4),
        (0, 0, 0, 4),
    )
    arm_angles: tuple[float, float] = (135.0, -135.0)

    def __post_init__(self) -> None:
        for name in ("tasks", "modules", "tools", "robconf", "arm_angles"):
            value = getattr(self, name)
            if not isinstance(value, tuple | list) or len(value) != 2:
                raise ValueError(f"{name}: got {value!r}, expected a pair (left arm, right arm)")
        for name in ("tasks", "modules", "tools"):
            for arm, value in zip(ARMS, getattr(self, name), strict=True):
                _identifier(f"{name} ({arm})", value)
        if self.tasks[0] == self.tasks[1] or self.modules[0] == self.modules[1]:
            raise ValueError("tasks/modules: the two arms need different task and module names")
        for name in ("wobj", "zone", "procedure"):
            _identifier(name, getattr(self, name))
        for arm, conf in zip(ARMS, self.robconf, strict=True):
            if len(conf) != 4 or not all(isinstance(c, int | np.integer) for c in conf):
                raise ValueError(
                    f"robconf ({arm}): got {conf!r}, expected 4 integers [cf1, cf4, cf6, cfx]"
                )
        for arm, angle in zip(ARMS, self.arm_angles, strict=True):
            if not isinstance(angle, int | float) or not math.isfinite(angle):
                raise ValueError(
                    f"arm_angles ({arm}): got {angle!r}, expected a finite angle [deg]"
                )


def _num(value: float, decimals: int) -> str:
    text = f"{value:.{decimals}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def _array(values, decimals: int) -> str:
    return "[" + ",".join(_num(float(v), decimals) for v in values) + "]"


def robtarget_text(position_m, quat_wxyz, robconf, arm_angle: float) -> str:
    """A RAPID robtarget literal: [[x,y,z] mm, [q1..q4] w-first, confdata, extax]."""
    trans = _array(np.asarray(position_m, dtype=float) * 1000.0, 6)
    rot = _array(quat_wxyz, 9)
    conf = "[" + ",".join(str(int(c)) for c in robconf) + "]"
    extax = "[" + ",".join([_num(arm_angle, 6)] + [_NOT_USED] * 5) + "]"
    return f"[{trans},{rot},{conf},{extax}]"


def rapid_modules(trajectory: Trajectory, settings: RapidSettings | None = None) -> dict[str, str]:
    """The RAPID module text of each task (module docstring).

    Parameters
    ----------
    trajectory : Trajectory
        Its knots become the robtargets; its ``max_speed`` [m/s] and ``max_angular_speed``
        [rad/s] the ``speeddata`` (v_tcp [mm/s], v_ori [deg/s]).
    settings : RapidSettings, optional

    Returns
    -------
    dict
        Task name -> module text, left arm first.
    """
    from .. import __version__  # at call time: dloplan/__init__ may import this module

    if not isinstance(trajectory, Trajectory):
        raise ValueError(f"trajectory: expected a Trajectory, got {type(trajectory).__name__}")
    s = settings or RapidSettings()
    n = trajectory.n_knots
    width = max(2, len(str(n - 1)))
    names = [f"dlo_p{i:0{width}d}" for i in range(n)]
    v_ori = math.degrees(trajectory.max_angular_speed)
    speed = _array([trajectory.max_speed * 1000.0, v_ori, 5000, 1000], 6)
    tasks_list = "[" + ",".join(f'["{t}"]' for t in s.tasks) + "]"
    modules = {}
    for a, arm in enumerate(ARMS):
        quats = canonical_quaternions(trajectory.rotations[a], scalar_first=True)
        clip = CLIP_NAMES[trajectory.arm_clips[a]]
        other = s.tasks[1 - a]
        lines = [
            f"MODULE {s.modules[a]}",
            f"    ! Generated by dloplan {__version__} (dloplan RAPID format "
            f"{RAPID_FORMAT_VERSION}): synchronized dual-arm cable manipulation.",
            f"    ! Task {s.tasks[a]}: {arm} arm, {clip} clip. Task {other} runs module "
            f"{s.modules[1 - a]} with the same move IDs.",
            f"    ! Robtargets in mm in work object {s.wobj}; "
            "quaternions [q1,q2,q3,q4] = [w,x,y,z].",
            f"    ! {n} targets; planned duration {trajectory.duration:.3f} s at "
            f"{trajectory.max_speed * 1000:g} mm/s and {v_ori:.4g} deg/s.",
            f"    PERS tasks dlo_tasks{{2}} := {tasks_list};",
            "    VAR syncident dlo_sync_on;",
            "    VAR syncident dlo_sync_off;",
            f"    CONST speeddata dlo_speed := {speed};",
        ]
        for name, pos, quat in zip(names, trajectory.positions[:, a], quats, strict=True):
            target = robtarget_text(pos, quat, s.robconf[a], s.arm_angles[a])
            lines.append(f"    CONST robtarget {name} := {target};")
        lines += [
            f"    PROC {s.procedure}()",
            "        ConfL \\Off;",
            "        SyncMoveOn dlo_sync_on, dlo_tasks;",
        ]
        for i, name in enumerate(names):
            lines.append(
                f"        MoveL {name} \\ID:={10 * (i + 1)}, dlo_speed, {s.zone}, "
                f"{s.tools[a]} \\WObj:={s.wobj};"
            )
        lines += [
            "        SyncMoveOff dlo_sync_off;",
            "        ConfL \\On;",
            "    ENDPROC",
            "ENDMODULE",
        ]
        modules[s.tasks[a]] = "\n".join(lines) + "\n"
    return modules


def write_rapid(
    directory: str | os.PathLike, trajectory: Trajectory, settings: RapidSettings | None = None
) -> dict[str, Path]:
    """Write one ``<module>.mod`` file per task into ``directory``, atomically (both or none).

    Returns
    -------
    dict
        Task name -> written file.
    """
    s = settings or RapidSettings()
    texts = rapid_modules(trajectory, s)
    folder = Path(directory)
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"directory: {str(folder)!r} exists and is not a folder")
    targets = {
        task: folder / f"{module}.mod" for task, module in zip(s.tasks, s.modules, strict=True)
    }
    atomic_write_texts({targets[task]: text for task, text in texts.items()})
    return targets
