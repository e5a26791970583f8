"""The robot cell: which robot, where it stands, its tools and work object, and the table.

A :class:`RobotCell` is everything the robot program needs beyond the plan: the YuMi
(IRB 14000) placed in the plan's frame (the *work frame*, which the RAPID work object carries),
the tool of each arm as RAPID ``tooldata`` (ABB's SmartGripper data by default), the work
object's name, the table height and the settings of the approach, the grip and the checks.

Frames: the plan's frame is the work frame. ``base_position`` / ``base_rotation`` place the
robot's base frame (ABB's base frame of the IRB 14000: on the body's vertical axis, 0.1 m above
the foot, x forward, y to the robot's left, z up) in it (``base_to_work``); the RAPID work
object's user frame is the inverse, the work frame seen from the robot's base (what is taught
on the controller, docs/robot.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial.transform import Rotation

from .chain import DEFAULT_TCP_IN_CLIP, as_rotation, as_vector
from .described import ARMS, DescribedCell
from .path import ReachOptions
from .yumi import (
    ARM_ANGLE_REFERENCE,
    BASE_ABOVE_FOOT,
    DEFAULT_TCP_OFFSET,
    DEFAULT_TOOL0_OFFSET,
    DEFAULT_TOOL0_ROTATION,
    Gripper,
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
        (3,) tool0-to-TCP translation [m] in the tool0 frame (``tframe.trans``).
    tcp_rotation : scipy.spatial.transform.Rotation, optional
        ``tcp_to_tool0`` (``tframe.rot``); identity by default.
    mass : float
        Tool mass [kg] (``tload.mass``).
    cog : array_like
        (3,) centre of gravity [m] in the tool0 frame (``tload.cog``).
    inertia : array_like
        (3,) moments of inertia [kg m^2] about the centre of gravity, axes of tool0
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

    def gripper(self, tool0_offset=DEFAULT_TOOL0_OFFSET,
                tool0_rotation: Rotation = DEFAULT_TOOL0_ROTATION) -> Gripper:
        """The kinematic part: TCP offset and rotation on tool0 (which sits at
        ``tool0_offset`` / ``tool0_rotation`` in the last link), clip-to-TCP mapping."""
        return Gripper(self.tcp_offset, self.tcp_rotation, self.tcp_in_clip, tool0_offset,
                       tool0_rotation)


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
    table_height : float, optional
        Height of the table top in the work frame [m] (drawn in the report); default the table
        the robot stands on, :data:`~dloplan.robot.yumi.BASE_ABOVE_FOOT` below the base frame.
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
    tool0_offset : array_like
        (3,) where ABB's ``tool0`` (the frame the tool data refer to) sits in the last link
        ``yumi_link_7`` [m]; default 7 mm along its z-axis
        (:data:`~dloplan.robot.yumi.DEFAULT_TOOL0_OFFSET`, docs/decisions.md).
    tool0_rotation : scipy.spatial.transform.Rotation
        ``tool0_to_link7``; default turned by pi about z
        (:data:`~dloplan.robot.yumi.DEFAULT_TOOL0_ROTATION`).
    arm_angle_reference : tuple of array_like
        The controller's "Arm-Angle Reference Direction" of the left and the right arm, unit
        vectors in the robot's base frame (:mod:`dloplan.robot.armangle`); default the
        controller's (:data:`~dloplan.robot.yumi.ARM_ANGLE_REFERENCE`). Written into the RAPID
        modules' header: the controller must be configured alike.
    """

    base_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    base_rotation: Rotation = field(default_factory=Rotation.identity)
    tools: tuple[Tool, Tool] = (Tool(name="dlo_tool_l"), Tool(name="dlo_tool_r"))
    wobj: str = "dlo_wobj"
    table_height: float | None = None
    approach: float = 0.05
    approach_speed: float = 0.05
    hold_force: float | None = None
    reach: ReachOptions = field(default_factory=ReachOptions)
    tool0_offset: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_TOOL0_OFFSET))
    tool0_rotation: Rotation = DEFAULT_TOOL0_ROTATION
    arm_angle_reference: tuple = (ARM_ANGLE_REFERENCE["left"], ARM_ANGLE_REFERENCE["right"])

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
        height = (float(self.base_position[2]) - BASE_ABOVE_FOOT if self.table_height is None
                  else float(self.table_height))
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
        set_(self, "tool0_offset", as_vector(self.tool0_offset, "RobotCell.tool0_offset"))
        set_(self, "tool0_rotation", as_rotation(self.tool0_rotation,
                                                 "RobotCell.tool0_rotation"))
        references = tuple(self.arm_angle_reference)
        if len(references) != 2:
            raise ValueError(f"RobotCell.arm_angle_reference: expected two directions (left, "
                             f"right), got {self.arm_angle_reference!r}")
        references = tuple(as_vector(r, f"RobotCell.arm_angle_reference ({side})")
                           for r, side in zip(references, ARMS, strict=True))
        for r, side in zip(references, ARMS, strict=True):
            if np.linalg.norm(r) < 1e-9:
                raise ValueError(f"RobotCell.arm_angle_reference ({side}): expected a nonzero "
                                 f"direction, got {r.tolist()}")
        set_(self, "arm_angle_reference", tuple(r / np.linalg.norm(r) for r in references))
        set_(self, "_robot", yumi(
            gripper=tuple(tool.gripper(self.tool0_offset, self.tool0_rotation)
                          for tool in tools),
            base_position=self.base_position, base_rotation=self.base_rotation,
            arm_angle_reference=self.arm_angle_reference, table_height=height))

    @property
    def robot(self) -> DescribedCell:
        """The YuMi placed in the work frame as a described cell (:func:`~dloplan.robot.
        yumi.yumi`), each arm with its tool's TCP, on the cell's table."""
        return self._robot

    @property
    def arms(self):
        """The YuMi's two arms (left, right): :attr:`robot`'s, as every cell's ``arms``."""
        return self._robot.arms

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


    def to_dict(self) -> dict:
        """JSON-ready data that builds the cell again (:func:`cell_from_record`; quaternions
        x-y-z-w, lengths in m)."""
        def quat(rotation: Rotation) -> list:
            return rotation.as_quat(canonical=True).tolist()

        return {
            "base_position": self.base_position.tolist(),
            "base_rotation": quat(self.base_rotation),
            "wobj": self.wobj, "table_height": self.table_height, "approach": self.approach,
            "approach_speed": self.approach_speed, "hold_force": self.hold_force,
            "tools": [{"name": t.name, "tcp_offset": t.tcp_offset.tolist(),
                       "tcp_rotation": quat(t.tcp_rotation), "mass": t.mass,
                       "cog": t.cog.tolist(), "inertia": t.inertia.tolist(),
                       "tcp_in_clip": quat(t.tcp_in_clip), "source": t.source}
                      for t in self.tools],
            "tool0_offset": self.tool0_offset.tolist(),
            "tool0_rotation": quat(self.tool0_rotation),
            "arm_angle_reference": [r.tolist() for r in self.arm_angle_reference],
            "min_margin": self.reach.min_margin,
        }


def cell_from_record(data: dict) -> RobotCell:
    """The cell of :meth:`RobotCell.to_dict`'s data (a plan document's ``robot.cell``); a record
    written before ``tool0_*``, ``arm_angle_reference`` and ``min_margin`` were recorded gets
    their defaults.

    Raises
    ------
    ValueError
        A missing or malformed field (KeyError, TypeError and ValueError are re-raised as
        ValueError naming it).
    """
    try:
        tools = tuple(Tool(name=t["name"], tcp_offset=np.asarray(t["tcp_offset"], float),
                           tcp_rotation=Rotation.from_quat(t["tcp_rotation"]), mass=t["mass"],
                           cog=np.asarray(t["cog"], float),
                           inertia=np.asarray(t["inertia"], float),
                           tcp_in_clip=Rotation.from_quat(t["tcp_in_clip"]), source=t["source"])
                      for t in data["tools"])
        defaults = RobotCell.__dataclass_fields__
        return RobotCell(
            base_position=np.asarray(data["base_position"], float),
            base_rotation=Rotation.from_quat(data["base_rotation"]), tools=tools,
            wobj=data["wobj"], table_height=data["table_height"], approach=data["approach"],
            approach_speed=data["approach_speed"], hold_force=data["hold_force"],
            tool0_offset=np.asarray(data.get("tool0_offset", DEFAULT_TOOL0_OFFSET), float),
            tool0_rotation=Rotation.from_quat(data["tool0_rotation"])
            if "tool0_rotation" in data else DEFAULT_TOOL0_ROTATION,
            arm_angle_reference=tuple(data.get("arm_angle_reference",
                                               defaults["arm_angle_reference"].default)),
            reach=ReachOptions(min_margin=float(data.get("min_margin",
                                                         ReachOptions().min_margin))))
    except KeyError as exc:
        raise ValueError(f"missing field {exc}") from None
    except (TypeError, ValueError) as exc:
        raise ValueError(str(exc)) from None
