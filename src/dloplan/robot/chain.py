"""One arm of a cell: any serial arm from a description, placed in the world with a tool.

:class:`CellArm` is the one arm type of :mod:`dloplan.robot`: the YuMi's arms
(:func:`dloplan.robot.yumi.yumi_arm`, with the arm-angle plug-in), the UR5e's and the Panda's
(:mod:`dloplan.robot.urdf_cell`) and any arm read from URDF. It holds the chain as the arrays
the kinematics needs (:mod:`dloplan.robot.kinematics`: forward kinematics, Jacobian, IK), its
base pose, tool, limits and collision capsules (:func:`capsules`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from ..geometry import segment_distance
from .description import ArmDescription
from .kinematics import link_frames

DEFAULT_TCP_IN_CLIP = Rotation.from_matrix([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
"""The TCP axes expressed in the clip frame (u, v, w): TCP x = v, TCP y = u, TCP z = -w.

The YuMi gripper's fingers close along the gripper's x-axis and approach along its z-axis, so a
held cable runs along its y-axis: the held link direction u is TCP y, and with the clip's w-axis
leaning up (:func:`dloplan.frames.frame_from_axis`) the gripper approaches from above."""


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
    common normals of axes 1-2 on axis 1 and of the last two axes on the last one): (s, w)
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
class CellArm:
    """An arm of a cell: its description, where its base stands and its tool.

    Parameters
    ----------
    name : str
        ``"left"`` or ``"right"`` (the arm's place in the cell's per-arm arrays).
    description : ArmDescription
    base_position : array_like
        (3,) the base link's origin in the world [m].
    base_rotation : scipy.spatial.transform.Rotation
        ``base_to_world``.
    tcp_offset : array_like
        (3,) tip(flange)-to-TCP translation [m] in the tip frame.
    tcp_rotation : scipy.spatial.transform.Rotation
        ``tcp_to_tip``.
    tool_radius : float
        Radius [m] of a capsule from the tip to the TCP standing for the tool in the clearance
        checks; 0: the description's own geometry covers the tool.
    home : array_like, optional
        (n,) fallback IK seed [rad]; default the middle of the joint ranges.
    tcp_in_clip : scipy.spatial.transform.Rotation
        The TCP axes in the clip frame (u, v, w): how the tool holds a clip
        (default :data:`~dloplan.robot.yumi.DEFAULT_TCP_IN_CLIP`: approach from above, the cable
        along TCP y, for fingers closing along TCP x).
    max_acceleration : array_like, optional
        (n,) published joint acceleration limits [rad/s^2]; default none (inf): the program's
        ``joint acceleration`` check applies where a limit is given.
    arm_angle_reference : array_like, optional
        (3,) reference direction (a vector in the base frame) of the arm angle of a 7-joint
        arm parameterized like the YuMi's (:mod:`dloplan.robot.armangle`: the IK can hold it,
        the robot program writes it); None: the arm has none.
    """

    name: str
    description: ArmDescription
    base_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    base_rotation: Rotation = field(default_factory=Rotation.identity)
    tcp_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tcp_rotation: Rotation = field(default_factory=Rotation.identity)
    tool_radius: float = 0.0
    home: np.ndarray | None = None
    tcp_in_clip: Rotation = DEFAULT_TCP_IN_CLIP
    max_acceleration: np.ndarray | None = None
    arm_angle_reference: np.ndarray | None = None

    def __post_init__(self) -> None:
        d = self.description
        n = d.n_joints
        accel = np.full(n, np.inf) if self.max_acceleration is None else \
            np.asarray(self.max_acceleration, dtype=float)
        if accel.shape != (n,) or np.any(~(accel > 0)):
            raise ValueError(f"{self.name}.max_acceleration: expected {n} limits > 0 "
                             f"[rad/s^2], got {self.max_acceleration!r}")
        object.__setattr__(self, "max_acceleration", accel)
        object.__setattr__(self, "base_position",
                           as_vector(self.base_position, f"{self.name}.base_position", 3))
        object.__setattr__(self, "tcp_offset",
                           as_vector(self.tcp_offset, f"{self.name}.tcp_offset", 3))
        for key in ("base_rotation", "tcp_rotation", "tcp_in_clip"):
            value = getattr(self, key)
            if not isinstance(value, Rotation) or not value.single:
                raise ValueError(f"{self.name}.{key}: expected a single scipy Rotation, got "
                                 f"{value!r}")
        if not (np.isfinite(self.tool_radius) and self.tool_radius >= 0):
            raise ValueError(f"{self.name}.tool_radius: expected a number >= 0 [m], got "
                             f"{self.tool_radius!r}")
        home = 0.5 * (d.lower + d.upper) if self.home is None else as_vector(
            self.home, f"{self.name}.home", n)
        if np.any((home < d.lower) | (home > d.upper)):
            raise ValueError(f"{self.name}.home: {np.round(home, 4).tolist()} rad, expected "
                             "joints within the joint limits "
                             f"{np.round(d.lower, 4).tolist()}..{np.round(d.upper, 4).tolist()}")
        object.__setattr__(self, "home", home)
        base = self.base_rotation.as_matrix()
        rot = d.origin_rot.copy()
        xyz = d.origin_xyz.copy()
        rot[0] = base @ rot[0]
        xyz[0] = base @ xyz[0] + self.base_position
        object.__setattr__(self, "_rot", rot)
        object.__setattr__(self, "_xyz", xyz)
        object.__setattr__(self, "_tcp_rot", d.tip_rot @ self.tcp_rotation.as_matrix())
        skew = np.zeros((n, 3, 3))
        skew[:, [2, 0, 1], [1, 2, 0]] = d.axes
        skew[:, [1, 2, 0], [2, 0, 1]] = -d.axes
        object.__setattr__(self, "_skew", skew)
        object.__setattr__(self, "_skew2", skew @ skew)
        object.__setattr__(self, "_tcp_xyz", d.tip_xyz + d.tip_rot @ self.tcp_offset)
        object.__setattr__(self, "_reach", float(np.linalg.norm(xyz[1:], axis=1).sum()
                                                 + np.linalg.norm(self._tcp_xyz)))
        # Capsules: the description's, then the tool's (tip to TCP, in the last link frame).
        caps, links, radii = d.capsules, d.capsule_link, d.radii
        if self.tool_radius > 0:
            tool = np.array([[d.tip_xyz, self._tcp_xyz]])
            caps = np.concatenate([caps, tool])
            links = np.append(links, n - 1)
            radii = np.append(radii, self.tool_radius)
        object.__setattr__(self, "_caps", caps)
        object.__setattr__(self, "_cap_link", links)
        object.__setattr__(self, "_radii", radii)
        if self.arm_angle_reference is not None:
            reference = as_vector(self.arm_angle_reference, f"{self.name}.arm_angle_reference")
            if n != 7 or np.linalg.norm(reference) < 1e-9:
                raise ValueError(f"{self.name}.arm_angle_reference: expected a nonzero direction "
                                 f"on a 7-joint arm, got {self.arm_angle_reference!r} ({n} "
                                 "joints)")
            object.__setattr__(self, "arm_angle_reference", reference / np.linalg.norm(reference))
            object.__setattr__(self, "_angle_points", axis_feet(d.origin_rot, d.origin_xyz,
                                                                d.axes))
            object.__setattr__(self, "_angle_reference",
                               self.base_rotation.apply(self.arm_angle_reference))

    @property
    def world_arm_angle_reference(self) -> np.ndarray:
        """(3,) the arm angle's reference direction in the world (``base_rotation`` applied
        to :attr:`arm_angle_reference`), computed once: every IK solve holding the arm angle
        reads it.

        Raises
        ------
        ValueError
            The arm has no arm angle.
        """
        if self.arm_angle_reference is None:
            raise ValueError(f"{self.name}: the arm has no arm angle (arm_angle_reference)")
        return self._angle_reference

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return self.description.n_joints

    @property
    def tcp_depth(self) -> float:
        """Radius [m] of the largest ball about the TCP inside the capsules of the last link
        (its gripper's): the largest r - e over them, e the TCP's distance from a capsule's
        axis segment; 0 when the TCP lies in none. The ball is inside the capsule whatever the
        joints (``|x - q| <= |x - TCP| + e < r``, q the axis point nearest the TCP), so two
        arms whose TCPs are closer than the sum of their depths overlap: no program holds two
        clips that close (:func:`dloplan.pipeline.stages.check_grip_distance`)."""
        last = self._cap_link == self.n_joints - 1
        if not np.any(last):
            return 0.0
        depth = self._radii[last] - segment_distance(self._caps[last, 0], self._caps[last, 1],
                                                     self._tcp_xyz, self._tcp_xyz)
        return max(float(np.max(depth)), 0.0)

    @property
    def lower(self) -> np.ndarray:
        """(n,) lower joint limits [rad]."""
        return self.description.lower

    @property
    def upper(self) -> np.ndarray:
        """(n,) upper joint limits [rad]."""
        return self.description.upper

    @property
    def axes(self) -> np.ndarray:
        """(n, 3) unit joint axes in the joint frames."""
        return self.description.axes

    @property
    def mid(self) -> np.ndarray:
        """(n,) middle of each joint's range [rad]."""
        return 0.5 * (self.lower + self.upper)

    @property
    def max_velocity(self) -> np.ndarray:
        """(n,) joint speed limits [rad/s] (the description's)."""
        return self.description.max_velocity

    @property
    def joint_names(self) -> tuple[str, ...]:
        """(n,) URDF joint names."""
        return self.description.joint_names

    @property
    def shoulder(self) -> np.ndarray:
        """(3,) world origin of the first joint [m]."""
        return self._xyz[0]

    @property
    def reach(self) -> float:
        """Upper bound of the shoulder-to-TCP distance [m]: the sum of the chain's offsets
        (computed once: every IK call reads it)."""
        return self._reach


def in_base_frame(arm: CellArm, positions, rotations: Rotation) -> tuple[np.ndarray, np.ndarray]:
    """World TCP poses expressed in the arm's base frame (what a controller is given).

    Parameters
    ----------
    positions : array_like
        (..., 3) [m] in the world.
    rotations : scipy.spatial.transform.Rotation
        ``tcp_to_world``, of the batch shape of ``positions``.

    Returns
    -------
    positions : numpy.ndarray
        (..., 3) [m] in the base frame.
    rotvecs : numpy.ndarray
        (..., 3) ``tcp_to_base`` as rotation vectors [rad] (axis-angle, as URScript's poses).
    """
    inv = arm.base_rotation.inv()
    pos = inv.apply(np.asarray(positions, dtype=float).reshape(-1, 3) - arm.base_position)
    rot = (inv * Rotation.from_matrix(rotations.as_matrix().reshape(-1, 3, 3))).as_rotvec()
    shape = np.shape(positions)
    return pos.reshape(shape), rot.reshape(shape)


def capsules(arm: CellArm, q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World capsules of the arm (description's, then the tool's).

    Parameters
    ----------
    q : array_like
        (..., n) joint values [rad].

    Returns
    -------
    segments : numpy.ndarray
        (..., m, 2, 3) end points [m].
    radii : numpy.ndarray
        (m,) [m].
    links : numpy.ndarray
        (m,) int link index of each capsule (-1: the base link, which does not move).
    """
    frames = link_frames(arm, q)
    rot, pos = frames.rotations, frames.positions
    links = arm._cap_link
    base_rot = arm.base_rotation.as_matrix()
    # Link -1 (base): world = base pose.
    r = np.where((links < 0)[:, None, None], base_rot, rot[..., np.maximum(links, 0), :, :])
    p = np.where((links < 0)[:, None], arm.base_position, pos[..., np.maximum(links, 0), :])
    ends = np.einsum("...lij,lej->...lei", r, arm._caps) + p[..., None, :]
    return ends, arm._radii, links
