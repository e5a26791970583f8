"""Kinematic data of the ABB YuMi (IRB 14000): two 7-DoF arms on one body, and its gripper.

Source of the joint chain
-------------------------
The joint origins, axes and limits are copied verbatim from the URDF ``yumi.urdf`` of the
``yumi_description`` package (Robert Krug and Todor Stoyanov, AASS Research Center, Orebro
University, 2016, BSD-2-Clause), as shipped in the PyPI package ``rtb-data`` 1.0.1 (the data
package of the Robotics Toolbox for Python, path ``rtbdata/xacro/yumi_description/urdf``).
The BSD-2-Clause notice of that package::

    Copyright (c) 2016, Robert Krug & Todor Stoyanov, AASS Research Center, Orebro University,
    Sweden. All rights reserved. Redistribution and use in source and binary forms, with or
    without modification, are permitted provided that the following conditions are met:
    1. Redistributions of source code must retain the above copyright notice, this list of
    conditions and the following disclaimer. 2. Redistributions in binary form must reproduce
    the above copyright notice, this list of conditions and the following disclaimer in the
    documentation and/or other materials provided with the distribution. THIS SOFTWARE IS
    PROVIDED BY THE COPYRIGHT HOLDERS AND CONTRIBUTORS "AS IS" AND ANY EXPRESS OR IMPLIED
    WARRANTIES ... ARE DISCLAIMED.

The joint limits of that URDF equal ABB's product specification of the IRB 14000 (axis 1
+-168.5 deg, axis 2 -143.5..+43.5 deg, axis 7 +-168.5 deg, axis 3 -123.5..+80 deg, axis 4
+-290 deg, axis 5 -88..+138 deg, axis 6 +-229 deg). The joints are listed in physical order
from the body outward, which in ABB's numbering is 1, 2, 7, 3, 4, 5, 6 (the redundant "arm
angle" axis 7 sits third).

Frames: the body frame ``yumi_body`` (= ``yumi_base_link``) is ABB's base frame of the robot,
0.1 m above its foot (:data:`BASE_ABOVE_FOOT`), x forward (toward the workspace), y to the
robot's left, z up. ABB's ``tool0`` is the last link frame ``yumi_link_7_*`` turned by pi about
its z-axis and 7 mm out (:data:`DEFAULT_TOOL0_OFFSET`).

Collision capsules: one capsule per link enclosing every vertex of that link's coarse collision
mesh (``meshes/coarse/link_*.stl`` of the same package; gripper: ``gripper/coarse/base.stl``
plus both fingers, closed), found by fitting the tightest capsule around the mesh's principal
axis and rounding the radius up to the next millimetre. They over-approximate the arm.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from .chain import DEFAULT_TCP_IN_CLIP, CellArm, as_rotation, as_vector
from .described import ARMS, DescribedCell
from .description import ArmDescription

"""Order of the two arms in every per-arm array of this subpackage."""

ABB_AXIS_NUMBERS = (1, 2, 7, 3, 4, 5, 6)
"""ABB's axis number of each joint, in the physical order used here."""

_DEG = np.pi / 180.0

# URDF <joint> data, physical order; rows: xyz [m], rpy [rad] (URDF fixed-axis roll-pitch-yaw).
# Only joint 1 (the arm's mount on the body) differs between the arms. Where ABB's controller
# data differ from the description, ABB's are used (docs/decisions.md, "YuMi kinematics"):
#  - the mount's rotation is the arm base frame of a real controller's configuration turned by
#    pi about its z-axis: ROBOT -gravity_alpha/-gravity_beta/-gamma_rotation (rad) of ROB_R /
#    ROB_L in SYSPAR/MOC.cfg of the RobotWare 6.06 backup in BerkeleyAutomation/yumipy
#    (intrinsic x-y-z angles; the description's rpy agree to 0.07 / 0.16 deg);
#  - the mount's position: RobotStudio's home robtargets of both arms (tool0 at
#    [-9.578368507, -182.609892723, 198.627808149] mm for the right arm; tests/data) solved for
#    it (the description's differs by 0.2 mm);
#  - ABB axis 3's origin: 40.5 mm off axis 7 and 251.5 mm from axis 2 (the description has
#    41.88 and 251.56 mm), fitted to RobotStudio's 10 tool0 poses to 0.005 mm (tests/data).
_GRAVITY_ANGLES = {"right": (0.629233, 0.950657, 0.184266),
                   "left": (-0.629233, 0.950657, -0.184266)}
_MOUNT_XYZ = {"right": (0.0537106, -0.0725734, 0.4150099),
              "left": (0.0537106, 0.0725734, 0.4150099)}


def _mount_rpy(side: str) -> tuple[float, float, float]:
    """URDF rpy of the mount: the controller's arm base frame turned by pi about its z-axis."""
    base = Rotation.from_euler("XYZ", _GRAVITY_ANGLES[side])
    return tuple((base * Rotation.from_rotvec([0.0, 0.0, np.pi])).as_euler("xyz"))


_MOUNT = {side: (_MOUNT_XYZ[side], _mount_rpy(side)) for side in ("right", "left")}
_HALF_PI = 1.57079632679
_CHAIN_XYZ = (
    (0.03, 0.0, 0.1),
    (-0.03, 0.17283, 0.0),
    (-0.0405, 0.0, 0.07867),
    (0.0405, 0.16461, 0.0),
    (-0.027, 0.0, 0.10039),
    (0.027, 0.029, 0.0),
)
_CHAIN_RPY = (
    (_HALF_PI, 0.0, 0.0),
    (-_HALF_PI, 0.0, 0.0),
    (_HALF_PI, -_HALF_PI, 0.0),
    (-_HALF_PI, 0.0, 0.0),
    (_HALF_PI, 0.0, 0.0),
    (-_HALF_PI, 0.0, 0.0),
)
_LOWER = (-2.94087978961, -2.50454747661, -2.94087978961, -2.15548162621, -5.06145483078,
          -1.53588974176, -3.99680398707)
_UPPER = (2.94087978961, 0.759218224618, 2.94087978961, 1.3962634016, 5.06145483078,
          2.40855436775, 3.99680398707)
_VELOCITY = (3.14159265359, 3.14159265359, 3.14159265359, 3.14159265359, 6.98131700798,
             6.98131700798, 6.98131700798)

# Capsules (p0, p1 [m] in the frame of link 1..7, then the gripper in the link-7 frame; radius
# [m]), derived from the coarse meshes as described in the module docstring.
_CAPSULES = (
    ((0.0258, -0.0468, 0.0906), (-0.0010, 0.0001, 0.0300), 0.070),
    ((-0.0278, 0.1370, -0.0056), (0.0000, 0.0012, -0.0277), 0.064),
    ((-0.0016, -0.0002, 0.0345), (-0.0385, -0.0318, 0.0741), 0.057),
    ((0.0424, 0.1365, 0.0097), (0.0029, 0.0002, -0.0281), 0.058),
    ((0.0045, -0.0024, 0.0038), (-0.0262, -0.0550, 0.0908), 0.047),
    ((0.0022, -0.0142, -0.0181), (0.0236, -0.0103, -0.0059), 0.058),
    ((-0.0006, 0.0, 0.0034), (-0.0006, 0.0, 0.0034), 0.033),
    ((-0.0011, -0.0038, 0.0279), (-0.0009, -0.0043, 0.1002), 0.044),
)

DEFAULT_TCP_OFFSET = (0.0, 0.0, 0.1142)
"""tool0-to-TCP translation [m] of ABB's SmartGripper tool data (servo module only; ABB,
Product manual - Grippers for IRB 14000): TCP 114.2 mm along tool0's z-axis, orientation
unchanged. The fingertips of the URDF gripper end 136 mm beyond tool0. The full tool data (mass,
centre of gravity, inertia) is :class:`dloplan.robot.cell.Tool`'s default."""

DEFAULT_TOOL0_OFFSET = (0.0, 0.0, 0.007)
"""Origin [m] of ABB's ``tool0`` (the flange frame RAPID's tool data refer to) in the last
link frame ``yumi_link_7``: 7 mm along its z-axis (the description's ``gripper_*_base``
joint). Fitted: RobotStudio's tool0 poses of 10 joint vectors agree to 0.005 mm
(docs/decisions.md, "YuMi tool0")."""

DEFAULT_TOOL0_ROTATION = Rotation.from_rotvec([0.0, 0.0, np.pi])
"""``tool0_to_link7``: tool0 is ``yumi_link_7`` turned by pi about its z-axis (RobotStudio's
tool0 orientation of the same 10 joint vectors agrees to 0.005 deg)."""

BASE_ABOVE_FOOT = 0.1
"""[m] Height of the YuMi's base frame (``yumi_body`` = ``yumi_base_link``, ABB's base frame)
above the robot's foot, the table it stands on: the description's body mesh spans z = -0.100
to +0.471 m (the robot is 571 mm tall), and a real robot's logged tool0 positions (yumipy's
joint/pose pairs) put the base frame at yumi_body within 2 mm (tests/test_robot_armangle.py).
A table under the robot is at z = -0.1 m in the base frame."""

ARM_ANGLE_REFERENCE = {"left": (0.0, -1.0, 0.0), "right": (0.0, 1.0, 0.0)}
"""Default reference direction (unit vector in the robot's base frame) of each arm's arm angle
(RobotWare's "Arm-Angle Reference Direction"): the arm angles these give reproduce the
``eax_a`` of RobotStudio's home robtargets, -101.964427132 deg (right) and +101.964427132
deg (left), to 1e-6 deg (docs/decisions.md, "YuMi arm angle")."""

HOME_DEG = {
    "right": (0.0, -130.0, -135.0, 30.0, 0.0, 40.0, 0.0),
    "left": (0.0, -130.0, 135.0, 30.0, 0.0, 40.0, 0.0),
}
"""ABB's YuMi home position [deg] in physical joint order (ABB axes 1, 2, 7, 3, 4, 5, 6 =
0, -130, -+135, 30, 0, 40, 0): arms folded in front of the body. The IK's fallback seed."""


@dataclass(frozen=True, eq=False)
class Gripper:
    """Where tool0 sits on the last link, the tool centre point on tool0, and how a clip frame
    maps onto the TCP.

    Parameters
    ----------
    tcp_offset : array_like
        (3,) tool0-to-TCP translation [m] in the tool0 frame (RAPID ``tframe.trans``).
    tcp_rotation : scipy.spatial.transform.Rotation, optional
        ``tcp_to_tool0`` (RAPID ``tframe.rot``); identity by default.
    tcp_in_clip : scipy.spatial.transform.Rotation, optional
        ``tcp_to_clip``: the TCP axes expressed in the clip frame (u, v, w); the TCP pose that
        holds a clip at ``clip_to_world`` is ``clip_to_world * tcp_in_clip`` at the clip point.
        Default :data:`DEFAULT_TCP_IN_CLIP`.
    tool0_offset : array_like, optional
        (3,) tool0's origin [m] in the last link frame (:data:`DEFAULT_TOOL0_OFFSET`).
    tool0_rotation : scipy.spatial.transform.Rotation, optional
        ``tool0_to_link7`` (:data:`DEFAULT_TOOL0_ROTATION`).
    """

    tcp_offset: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_TCP_OFFSET))
    tcp_rotation: Rotation = field(default_factory=Rotation.identity)
    tcp_in_clip: Rotation = DEFAULT_TCP_IN_CLIP
    tool0_offset: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_TOOL0_OFFSET))
    tool0_rotation: Rotation = DEFAULT_TOOL0_ROTATION

    def __post_init__(self) -> None:
        object.__setattr__(self, "tcp_offset", as_vector(self.tcp_offset, "tcp_offset"))
        object.__setattr__(self, "tcp_rotation", as_rotation(self.tcp_rotation, "tcp_rotation"))
        object.__setattr__(self, "tcp_in_clip", as_rotation(self.tcp_in_clip, "tcp_in_clip"))
        object.__setattr__(self, "tool0_offset", as_vector(self.tool0_offset, "tool0_offset"))
        object.__setattr__(self, "tool0_rotation",
                           as_rotation(self.tool0_rotation, "tool0_rotation"))

    @property
    def tcp_in_link(self) -> tuple[np.ndarray, np.ndarray]:
        """The TCP in the last link frame: position (3,) [m] and ``tcp_to_link7`` (3, 3)."""
        tool0 = self.tool0_rotation.as_matrix()
        return (self.tool0_offset + tool0 @ self.tcp_offset,
                tool0 @ self.tcp_rotation.as_matrix())


def yumi_description(side: str) -> ArmDescription:
    """The chain of one YuMi arm from the body frame ``yumi_body`` to ``yumi_link_7_*``: the
    data of this module (the vendored ``yumi.urdf`` holds the same), its collision capsules (7
    links, then the gripper on link 7)."""
    if side not in ARMS:
        raise ValueError(f"side: expected one of {ARMS}, got {side!r}")
    xyz, rpy = _MOUNT[side]
    suffix = side[0]
    return ArmDescription(
        name=f"yumi_{side}",
        joint_names=tuple(f"yumi_joint_{k}_{suffix}" for k in ABB_AXIS_NUMBERS),
        origin_xyz=np.array((xyz,) + _CHAIN_XYZ),
        origin_rot=Rotation.from_euler("xyz", np.array((rpy,) + _CHAIN_RPY)).as_matrix(),
        axes=np.tile([0.0, 0.0, 1.0], (7, 1)),
        lower=np.array(_LOWER), upper=np.array(_UPPER), max_velocity=np.array(_VELOCITY),
        tip_xyz=np.zeros(3), tip_rot=np.eye(3),
        capsules=np.array([(p0, p1) for p0, p1, _ in _CAPSULES]),
        capsule_link=np.array([0, 1, 2, 3, 4, 5, 6, 6]),
        radii=np.array([r for _, _, r in _CAPSULES]),
        base_link="yumi_body", tip_link=f"yumi_link_7_{suffix}", source="dloplan.robot.yumi")


def yumi_arm(side: str, *, gripper: Gripper | None = None, base_position=(0.0, 0.0, 0.0),
             base_rotation: Rotation | None = None, arm_angle_reference=None) -> CellArm:
    """One arm of a YuMi: a :class:`~dloplan.robot.chain.CellArm` of :func:`yumi_description`
    with the YuMi's plug-in data (the arm angle's reference direction).

    Parameters
    ----------
    side : str
        ``"left"`` or ``"right"``.
    gripper : Gripper, optional
        Default: ABB SmartGripper TCP (:data:`DEFAULT_TCP_OFFSET`) on tool0,
        :data:`DEFAULT_TCP_IN_CLIP`.
    base_position, base_rotation
        Placement ``base_to_world`` of the robot body frame [m].
    arm_angle_reference : array_like, optional
        (3,) the arm angle's reference direction in the base frame (default
        :data:`ARM_ANGLE_REFERENCE` of the side).
    """
    description = yumi_description(side)
    gripper = gripper if gripper is not None else Gripper()
    tcp_xyz, tcp_rot = gripper.tcp_in_link
    return CellArm(
        side, description, base_position=base_position,
        base_rotation=base_rotation if base_rotation is not None else Rotation.identity(),
        tcp_offset=tcp_xyz, tcp_rotation=Rotation.from_matrix(tcp_rot),
        home=np.array(HOME_DEG[side]) * _DEG, tcp_in_clip=gripper.tcp_in_clip,
        arm_angle_reference=ARM_ANGLE_REFERENCE[side] if arm_angle_reference is None
        else arm_angle_reference)


def yumi(*, gripper: Gripper | None = None, base_position=(0.0, 0.0, 0.0),
         base_rotation: Rotation | None = None, arm_angle_reference=(None, None),
         table_height: float | None = None) -> DescribedCell:
    """An ABB YuMi (IRB 14000) placed in the world frame: a described cell of both arms on one
    body (:func:`yumi_arm`, each with the arm angle's plug-in data).

    By default the world frame is the robot's base frame: origin 0.1 m above the robot's foot
    (:data:`BASE_ABOVE_FOOT`; the table is at z = -0.1 m), x forward, y to the robot's left,
    z up, so a job on the table in front of the robot has x ~ 0.3..0.5 m and z a little above
    -0.1 m.

    Parameters
    ----------
    gripper : Gripper or tuple of Gripper, optional
        The same gripper on both arms, or one per arm (left, right).
    base_position : array_like
        (3,) the body frame's origin in the world [m].
    base_rotation : scipy.spatial.transform.Rotation, optional
        ``base_to_world`` rotation of the body frame.
    arm_angle_reference : tuple
        Per arm (left, right) the arm angle's reference direction in the base frame, or None
        for :data:`ARM_ANGLE_REFERENCE`.
    table_height : float, optional
        z of the table top in the world [m]; default the robot's foot,
        :data:`BASE_ABOVE_FOOT` below the body frame.
    """
    grippers = gripper if isinstance(gripper, tuple) else (gripper, gripper)
    arms = [yumi_arm(side, gripper=g, base_position=base_position, base_rotation=base_rotation,
                     arm_angle_reference=reference)
            for side, g, reference in zip(ARMS, grippers, arm_angle_reference, strict=True)]
    height = (float(np.asarray(base_position, dtype=float)[2]) - BASE_ABOVE_FOOT
              if table_height is None else table_height)
    return DescribedCell("yumi", *arms, table_height=height, shared_base=True)
