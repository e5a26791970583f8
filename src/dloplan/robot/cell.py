"""The robot cell: which robot, where it stands, its tools and work object, and the table.

A :class:`RobotCell` is everything the robot program needs beyond the plan: the YuMi
(IRB 14000) placed in the plan's frame (the *work frame*, which the RAPID work object carries),
the tool of each arm as RAPID ``tooldata`` (ABB's SmartGripper data by default), the work
object's name, the table height and the settings of the approach, the grip and the checks.

Frames: the plan's frame is the work frame. ``base_position`` / ``base_rotation`` place the
robot's base frame (ABB's base frame of the IRB 14000: bottom centre of the body, x forward,
y to the robot's left, z up) in it (``base_to_work``); the RAPID work object's user frame is
the inverse, the work frame seen from the robot's base (what is taught on the controller).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial.transform import Rotation

from .reachability import ReachOptions
from .yumi import (
    DEFAULT_TCP_IN_CLIP,
    DEFAULT_TCP_OFFSET,
    Gripper,
    Robot,
    as_rotation,
    as_vector,
    yumi,
)

SMARTGRIPPER_SOURCE = (
    "ABB, Product manual - Grippers for IRB 14000 (SmartGripper), tool data of the gripper "
    "with the servo module only: TCP [0, 0, 114.2] mm, mass 0.215 kg, centre of gravity "
    "[8.7, 12.3, 49.2] mm, inertia 0.00021, 0.00024, 0.00009 kg m^2"
)
"""Where the default tool data comes from (quoted in lsurobotics/duplo, js/toolConstants.js)."""

RAPID_NAME = r"^[A-Za-z][A-Za-z0-9_]{0,31}$"
"""A RAPID identifier: a letter, then up to 31 letters, digits or underscores."""


def check_rapid_name(name: str, value) -> str:
    """``value`` if it is a RAPID identifier, else ValueError naming ``name``."""
    import re

    if not isinstance(value, str) or not re.match(RAPID_NAME, value):
        raise ValueError(f"{name}: got {value!r}, expected a RAPID identifier (a letter, then "
                         "up to 31 letters, digits or underscores)")
    return value


def _positive(name: str, value, allow_zero: bool = False) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = float("nan")
    if not np.isfinite(number) or number < 0 or (number == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name}: got {value!r}, expected a finite number {bound}")
    return number


@dataclass(frozen=True, eq=False)
class Tool:
    """One arm's tool as RAPID ``tooldata`` (robot-held), and how it holds a clip.

    Parameters
    ----------
    name : str
        The ``tooldata`` name in the program (a RAPID identifier).
    tcp_offset : array_like
        (3,) flange-to-TCP translation [m] in the flange frame (``tframe.trans``).
    tcp_rotation : scipy.spatial.transform.Rotation, optional
        Flange-to-TCP rotation (``tframe.rot``); identity by default.
    mass : float
        Tool mass [kg] (``tload.mass``).
    cog : array_like
        (3,) centre of gravity [m] in the flange frame (``tload.cog``).
    inertia : array_like
        (3,) moments of inertia [kg m^2] about the centre of gravity, axes of the flange
        (``tload.ix, iy, iz``; ``tload.aom`` identity).
    tcp_in_clip : scipy.spatial.transform.Rotation
        ``tcp_to_clip``: the TCP axes in the clip frame (u, v, w); see
        :data:`~dloplan.robot.yumi.DEFAULT_TCP_IN_CLIP`.
    source : str
        Where the numbers come from (written into the program as a comment).
    """

    name: str = "dlo_tool"
    tcp_offset: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_TCP_OFFSET))
    tcp_rotation: Rotation = field(default_factory=Rotation.identity)
    mass: float = 0.215
    cog: np.ndarray = field(default_factory=lambda: np.array([0.0087, 0.0123, 0.0492]))
    inertia: np.ndarray = field(default_factory=lambda: np.array([0.00021, 0.00024, 0.00009]))
    tcp_in_clip: Rotation = DEFAULT_TCP_IN_CLIP
    source: str = SMARTGRIPPER_SOURCE

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        check_rapid_name("Tool.name", self.name)
        set_(self, "tcp_offset", as_vector(self.tcp_offset, "Tool.tcp_offset"))
        set_(self, "tcp_rotation", as_rotation(self.tcp_rotation, "Tool.tcp_rotation"))
        set_(self, "tcp_in_clip", as_rotation(self.tcp_in_clip, "Tool.tcp_in_clip"))
        set_(self, "mass", _positive("Tool.mass", self.mass))
        set_(self, "cog", as_vector(self.cog, "Tool.cog"))
        inertia = as_vector(self.inertia, "Tool.inertia")
        if np.any(inertia < 0):
            raise ValueError(f"Tool.inertia: expected moments >= 0 [kg m^2], got {self.inertia!r}")
        set_(self, "inertia", inertia)

    @property
    def gripper(self) -> Gripper:
        """The kinematic part: TCP offset and rotation, clip-to-TCP mapping."""
        return Gripper(self.tcp_offset, self.tcp_rotation, self.tcp_in_clip)


@dataclass(frozen=True, eq=False)
class RobotCell:
    """The robot cell a plan is executed in (module docstring).

    Parameters
    ----------
    base_position : array_like
        (3,) origin of the robot's base frame in the work frame [m].
    base_rotation : scipy.spatial.transform.Rotation, optional
        ``base_to_work`` rotation; identity (robot axes = work axes) by default.
    tools : tuple of Tool
        The tool of the left and of the right arm.
    wobj : str
        The ``wobjdata`` name the targets are written in.
    table_height : float
        Height of the table top in the work frame [m] (drawn in the report).
    approach : float
        Distance [m] the gripper comes from (and leaves to) along its approach axis (TCP z)
        before grasping and after releasing; 0 grasps directly.
    approach_speed : float
        TCP speed [m/s] of the approach and the retreat.
    hold_force : float, optional
        SmartGripper holding force [N] (0..20) for ``g_GripIn \\holdForce``; None uses the
        gripper's configured default.
    reach : ReachOptions
        Tolerances and limits of the checks (IK tolerances, sub-step lengths, largest joint
        step, wanted joint margin, smallest arm-arm clearance, symmetric grip).
    """

    base_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    base_rotation: Rotation = field(default_factory=Rotation.identity)
    tools: tuple[Tool, Tool] = (Tool(name="dlo_tool_l"), Tool(name="dlo_tool_r"))
    wobj: str = "dlo_wobj"
    table_height: float = 0.0
    approach: float = 0.05
    approach_speed: float = 0.05
    hold_force: float | None = None
    reach: ReachOptions = field(default_factory=ReachOptions)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "base_position", as_vector(self.base_position, "RobotCell.base_position"))
        set_(self, "base_rotation", as_rotation(self.base_rotation, "RobotCell.base_rotation"))
        tools = tuple(self.tools)
        if len(tools) != 2 or not all(isinstance(t, Tool) for t in tools):
            raise ValueError(f"RobotCell.tools: expected two Tool (left, right), got "
                             f"{self.tools!r}")
        set_(self, "tools", tools)
        check_rapid_name("RobotCell.wobj", self.wobj)
        height = float(self.table_height)
        if not np.isfinite(height):
            raise ValueError(f"RobotCell.table_height: expected a finite height [m], got "
                             f"{self.table_height!r}")
        set_(self, "table_height", height)
        set_(self, "approach", _positive("RobotCell.approach", self.approach, allow_zero=True))
        set_(self, "approach_speed", _positive("RobotCell.approach_speed", self.approach_speed))
        if self.hold_force is not None:
            force = _positive("RobotCell.hold_force", self.hold_force)
            if force > 20.0:
                raise ValueError(f"RobotCell.hold_force: got {self.hold_force!r}, expected at "
                                 "most 20 N (SmartGripper)")
            set_(self, "hold_force", force)
        if not isinstance(self.reach, ReachOptions):
            raise ValueError(f"RobotCell.reach: expected ReachOptions, got {self.reach!r}")
        arms = [yumi(gripper=tool.gripper, base_position=self.base_position,
                     base_rotation=self.base_rotation).arms[a]
                for a, tool in enumerate(tools)]
        set_(self, "_robot", Robot(*arms))

    @property
    def robot(self) -> Robot:
        """The YuMi placed in the work frame, each arm with its tool's TCP."""
        return self._robot

    def to_base(self, positions) -> np.ndarray:
        """Work-frame points [m], (..., 3), in the robot's base frame."""
        return (np.asarray(positions, dtype=float) - self.base_position) @ \
            self.base_rotation.as_matrix()

    @property
    def wobj_frame(self) -> tuple[np.ndarray, Rotation]:
        """The work object's user frame in the robot's base frame: position [m], rotation
        (``work_to_base``), the inverse of the base placement."""
        inv = self.base_rotation.inv()
        return -inv.apply(self.base_position), inv

    def with_names(self, tools: tuple[str, str] | None = None, wobj: str | None = None):
        """The same cell with other ``tooldata`` / ``wobjdata`` names."""
        new_tools = self.tools if tools is None else tuple(
            replace(tool, name=name) for tool, name in zip(self.tools, tools, strict=True))
        return replace(self, tools=new_tools, wobj=self.wobj if wobj is None else wobj)

