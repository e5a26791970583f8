"""Gripper frames that do not twist the cable: the last clip rolled against the twist.

A clip holds the cable's end link; turning it about that link's axis (its u-axis, the frame's
x-axis) changes nothing for the bending of a torsion-free model but twists a real cable. The
torsion model (:func:`dloplan.sim.torsion.twist_along_path`) gives, for every shape, the total
twist tau_k [rad] the gripper frames put between the clips. :func:`untwisted` rolls the last
clip's frame at shape k by tau_k about its own u-axis and computes the twist again; a few such
fixed-point steps bring every tau_k to round-off (the twist is, to first order, the difference of
the clips' rolls). The u-axes and the clip points stay those of the shapes: the plan's
equilibria do not change.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation

from ..grippers.path import GripperPath, relative_twist
from ..sim.torsion import twist_along_path

ROLL_STEPS = 4
"""Fixed-point steps of :func:`untwisted`."""


def untwisted(cable, shapes: np.ndarray, grippers: GripperPath,
              steps: int = ROLL_STEPS) -> tuple[GripperPath, np.ndarray]:
    """The gripper frames with the last clip rolled so that the torsion model's twist vanishes.

    Parameters
    ----------
    cable : Cable
    shapes : numpy.ndarray
        (S + 2, n + 1, 3) the planned shapes [m].
    grippers : GripperPath
        Their frames (any method).
    steps : int
        Fixed-point steps.

    Returns
    -------
    grippers : GripperPath
        Same method label, positions and u-axes; the last clip's frames rolled.
    twist : numpy.ndarray
        (S + 2,) the torsion model's twist under the new frames [rad].
    """
    twist = _twist(cable, shapes, grippers)
    for _ in range(steps):
        roll = Rotation.from_rotvec(twist[:, None] * np.array([1.0, 0.0, 0.0]))
        first, last = grippers.rotations[0], grippers.rotations[1] * roll
        frames = relative_twist(first, last)
        grippers = replace(
            grippers, rotations=(first, last), twist=frames,
            success=bool(np.max(np.abs(frames)) <= grippers.max_twist),
            warnings=tuple(w for w in grippers.warnings if not w.startswith("relative twist")),
            message=f"{grippers.message.split(';')[0]}; last clip rolled about its u-axis "
            "against the torsion model's twist")
        twist = _twist(cable, shapes, grippers)
    return grippers, twist


def _twist(cable, shapes, grippers) -> np.ndarray:
    poses = [grippers.clip_poses(k) for k in range(len(shapes))]
    return twist_along_path(cable, shapes, poses).twist
