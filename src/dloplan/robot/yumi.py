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

ARMS = ("left", "right")
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

DEFAULT_TCP_IN_CLIP = Rotation.from_matrix([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
"""The TCP axes expressed in the clip frame (u, v, w): TCP x = v, TCP y = u, TCP z = -w.

The YuMi gripper's fingers close along the gripper's x-axis and approach along its z-axis, so a
held cable runs along its y-axis: the held link direction u is TCP y, and with the clip's w-axis
leaning up (:func:`dloplan.frames.frame_from_axis`) the gripper approaches from above."""

HOME_DEG = {
    "right": (0.0, -130.0, -135.0, 30.0, 0.0, 40.0, 0.0),
    "left": (0.0, -130.0, 135.0, 30.0, 0.0, 40.0, 0.0),
}
"""ABB's YuMi home position [deg] in physical joint order (ABB axes 1, 2, 7, 3, 4, 5, 6 =
0, -130, -+135, 30, 0, 40, 0): arms folded in front of the body. The IK's fallback seed."""


def as_vector(value, name: str, size: int = 3) -> np.ndarray:
    """``value`` as a (size,) float array, else ValueError naming ``name``."""
    arr = np.asarray(value, dtype=float)
    if arr.shape != (size,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected {size} finite numbers, got {value!r}")
    return arr


def as_rotation(value, name: str) -> Rotation:
    """``value`` as a single scipy Rotation (None: identity), else ValueError naming ``name``."""
    if value is None:
        return Rotation.identity()
    if not isinstance(value, Rotation) or not value.single:
        raise ValueError(f"{name}: expected a single scipy Rotation, got {value!r}")
    return value


def axis_feet(origin_rot, origin_xyz, axes) -> np.ndarray:
    """Where the arm angle's shoulder and wrist points sit on their axes (the feet of the
    common normals of axes 1-2 on axis 1 and of axes 7-6 on axis 7, physical order): (s, w)
    [m] along axis 1 from joint 1's origin and along the last axis from the last joint's
    origin (:mod:`dloplan.robot.armangle`).

    The relative pose of consecutive axes is fixed by the chain, so the feet are read at
    q = 0 from the joint origins ``origin_rot`` (n, 3, 3), ``origin_xyz`` (n, 3) and the axes
    (n, 3)."""
    r, p = np.eye(3), np.zeros(3)
    z, points = [], []
    for i in range(len(axes)):
        p = p + r @ origin_xyz[i]
        r = r @ origin_rot[i]
        z.append(r @ axes[i])
        points.append(p)

    def foot(i, j):
        d = points[j] - points[i]
        b = float(z[i] @ z[j])
        if abs(1.0 - b * b) < 1e-12:
            raise ValueError(f"axes: joint axes {i + 1} and {j + 1} are parallel; the arm "
                             "angle needs them skew or intersecting")
        return float((d @ z[i] - b * (d @ z[j])) / (1.0 - b * b))

    return np.array([foot(0, 1), foot(len(axes) - 1, len(axes) - 2)])


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


@dataclass(frozen=True, eq=False)
class Arm:
    """One serial 7-DoF arm as a URDF-style chain placed in the world frame.

    Joint ``i`` turns link ``i`` about ``axes[i]`` (in the joint frame) by ``q[i]``; its frame
    sits at ``origin_xyz[i]``, turned by ``origin_rpy[i]``, in the frame of link ``i - 1``
    (link 0 is the robot body, placed in the world by ``base_to_world``). The TCP is fixed in
    the last link by ``gripper`` (tool0, then the tool's TCP).

    Parameters
    ----------
    name : str
        ``"left"`` or ``"right"``.
    origin_xyz, origin_rpy : numpy.ndarray
        (7, 3) joint origins [m] and URDF roll-pitch-yaw [rad] (fixed axes x, y, z).
    axes : numpy.ndarray
        (7, 3) unit joint axes in the joint frames.
    lower, upper : numpy.ndarray
        (7,) joint limits [rad].
    max_velocity : numpy.ndarray
        (7,) joint speed limits [rad/s].
    capsules : numpy.ndarray
        (8, 2, 3) capsule segment end points [m]: one per link 1..7 in its frame, then the
        gripper in the flange frame.
    radii : numpy.ndarray
        (8,) capsule radii [m].
    home : numpy.ndarray
        (7,) a fallback IK seed [rad] within the limits.
    gripper : Gripper
        TCP offset and clip-to-TCP mapping.
    base_position : numpy.ndarray
        (3,) position of the robot body frame in the world [m].
    base_rotation : scipy.spatial.transform.Rotation
        ``base_to_world`` rotation of the body frame.
    joint_names : tuple of str
        URDF joint names.
    arm_angle_reference : array_like
        (3,) reference direction of the arm angle (:mod:`dloplan.robot.armangle`), a vector
        in the robot's base (body) frame; default ``(0, 0, 1)``, :func:`yumi_arm` sets the
        controller's default of the arm (:data:`ARM_ANGLE_REFERENCE`).
    """

    name: str
    origin_xyz: np.ndarray
    origin_rpy: np.ndarray
    axes: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    max_velocity: np.ndarray
    capsules: np.ndarray
    radii: np.ndarray
    home: np.ndarray
    gripper: Gripper = field(default_factory=Gripper)
    base_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    base_rotation: Rotation = field(default_factory=Rotation.identity)
    joint_names: tuple[str, ...] = ()
    arm_angle_reference: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))

    def __post_init__(self) -> None:
        for key, shape in (("origin_xyz", (7, 3)), ("origin_rpy", (7, 3)), ("axes", (7, 3)),
                           ("lower", (7,)), ("upper", (7,)), ("max_velocity", (7,)),
                           ("capsules", (8, 2, 3)), ("radii", (8,)), ("home", (7,))):
            arr = np.asarray(getattr(self, key), dtype=float)
            if arr.shape != shape or not np.all(np.isfinite(arr)):
                raise ValueError(f"{key}: expected finite values of shape {shape}, got {arr.shape}")
            object.__setattr__(self, key, arr)
        if np.any(self.lower >= self.upper):
            raise ValueError(f"joint limits: lower {self.lower} must be below upper {self.upper}")
        if np.any((self.home < self.lower) | (self.home > self.upper)):
            raise ValueError(f"home: {self.home} is outside the joint limits")
        object.__setattr__(self, "axes", self.axes / np.linalg.norm(self.axes, axis=1)[:, None])
        object.__setattr__(self, "base_position", as_vector(self.base_position, "base_position"))
        object.__setattr__(self, "base_rotation", as_rotation(self.base_rotation, "base_rotation"))
        # Fixed parts of the chain, precomputed: joint 1's origin carries the world placement.
        rot = Rotation.from_euler("xyz", self.origin_rpy).as_matrix()
        xyz = self.origin_xyz.copy()
        base = self.base_rotation.as_matrix()
        rot[0] = base @ rot[0]
        xyz[0] = base @ xyz[0] + self.base_position
        object.__setattr__(self, "_origin_rot", rot)
        object.__setattr__(self, "_origin_xyz", xyz)
        tcp_xyz, tcp_rot = self.gripper.tcp_in_link
        object.__setattr__(self, "_tcp_rot", tcp_rot)
        object.__setattr__(self, "_tcp_xyz", tcp_xyz)
        object.__setattr__(self, "_angle_points", axis_feet(rot, xyz, self.axes))
        reference = as_vector(self.arm_angle_reference, "arm_angle_reference")
        if np.linalg.norm(reference) < 1e-9:
            raise ValueError(f"arm_angle_reference: expected a nonzero direction, got "
                             f"{self.arm_angle_reference!r}")
        object.__setattr__(self, "arm_angle_reference", reference / np.linalg.norm(reference))
        skew = np.zeros((7, 3, 3))
        skew[:, [2, 0, 1], [1, 2, 0]] = self.axes
        skew[:, [1, 2, 0], [2, 0, 1]] = -self.axes
        object.__setattr__(self, "_axis_skew", skew)
        object.__setattr__(self, "_axis_skew2", skew @ skew)

    @property
    def n_joints(self) -> int:
        """Number of joints (7)."""
        return 7

    @property
    def mid(self) -> np.ndarray:
        """Middle of each joint's range [rad], (7,)."""
        return 0.5 * (self.lower + self.upper)


@dataclass(frozen=True, eq=False)
class Robot:
    """A dual-arm robot: the two arms in the order of :data:`ARMS`."""

    left: Arm
    right: Arm

    @property
    def arms(self) -> tuple[Arm, Arm]:
        """``(left, right)``."""
        return (self.left, self.right)


def yumi_arm(side: str, *, gripper: Gripper | None = None, base_position=(0.0, 0.0, 0.0),
             base_rotation: Rotation | None = None, arm_angle_reference=None) -> Arm:
    """One arm of a YuMi with the URDF data of this module.

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
    if side not in ARMS:
        raise ValueError(f"side: expected one of {ARMS}, got {side!r}")
    suffix = side[0]
    xyz, rpy = _MOUNT[side]
    return Arm(
        name=side,
        origin_xyz=np.array((xyz,) + _CHAIN_XYZ),
        origin_rpy=np.array((rpy,) + _CHAIN_RPY),
        axes=np.tile([0.0, 0.0, 1.0], (7, 1)),
        lower=np.array(_LOWER),
        upper=np.array(_UPPER),
        max_velocity=np.array(_VELOCITY),
        capsules=np.array([(p0, p1) for p0, p1, _ in _CAPSULES]),
        radii=np.array([r for _, _, r in _CAPSULES]),
        home=np.array(HOME_DEG[side]) * _DEG,
        gripper=gripper if gripper is not None else Gripper(),
        base_position=base_position,
        base_rotation=base_rotation if base_rotation is not None else Rotation.identity(),
        joint_names=tuple(f"yumi_joint_{k}_{suffix}" for k in ABB_AXIS_NUMBERS),
        arm_angle_reference=ARM_ANGLE_REFERENCE[side] if arm_angle_reference is None
        else arm_angle_reference,
    )


def yumi(*, gripper: Gripper | None = None, base_position=(0.0, 0.0, 0.0),
         base_rotation: Rotation | None = None) -> Robot:
    """An ABB YuMi (IRB 14000) placed in the world frame.

    By default the world frame is the robot's base frame: origin 0.1 m above the robot's foot
    (:data:`BASE_ABOVE_FOOT`; the table is at z = -0.1 m), x forward, y to the robot's left,
    z up, so a job on the table in front of the robot has x ~ 0.3..0.5 m and z a little above
    -0.1 m.

    Parameters
    ----------
    gripper : Gripper, optional
        The same gripper on both arms.
    base_position : array_like
        (3,) the body frame's origin in the world [m].
    base_rotation : scipy.spatial.transform.Rotation, optional
        ``base_to_world`` rotation of the body frame.
    """
    kwargs = dict(gripper=gripper, base_position=base_position, base_rotation=base_rotation)
    return Robot(left=yumi_arm("left", **kwargs), right=yumi_arm("right", **kwargs))
