"""ABB configuration data (``confdata``) of a YuMi joint solution.

A robtarget names a TCP pose; on the 7-axis IRB 14000 its arm angle (``eax_a``,
:mod:`dloplan.robot.armangle`) and ``confdata [cf1, cf4, cf6, cfx]`` name which joint solution
the controller takes for it.

- cf1, cf4, cf6: the quadrants of ABB axes 1, 4 and 6: ``floor(angle / 90 deg)`` (0 for
  0..90 deg, 1 for 90..180, -1 for -90..0, ...), as in ABB's RAPID reference (``confdata``).
- cfx: ABB's configuration number 0..7 of its 6-axis robots (4: wrist centre behind axis 1,
  2: behind the lower arm, 1: axis 5 negative), read on the YuMi as 4 * (axis 2 < 0)
  + 2 * (axis 3 < 0) + (axis 5 < 0). It gives RobotStudio's [0, 0, 0, 4] of both arms' home
  robtargets (RobotWare 6's "new arm-angle definition", tests/data); ABB's rule for the IRB
  14000 is not published, and no public robtarget decides between this reading and the
  geometric one: docs/robot.md says how to confirm it on the controller before the first run.
"""

from __future__ import annotations

import numpy as np

_ABB_AXIS = {1: 0, 2: 1, 7: 2, 3: 3, 4: 4, 5: 5, 6: 6}
"""Physical joint index of each ABB axis number."""


def abb_joint(q, axis: int) -> np.ndarray:
    """The value of ABB axis ``axis`` (1..7) in joint vectors ``q`` (..., 7) in physical order."""
    return np.asarray(q, dtype=float)[..., _ABB_AXIS[axis]]


def quadrant(angle) -> np.ndarray:
    """ABB's quadrant number of joint angles [rad]: floor(angle / 90 deg), int."""
    return np.floor(np.degrees(np.asarray(angle, dtype=float)) / 90.0).astype(int)


def confdata(q) -> np.ndarray:
    """``[cf1, cf4, cf6, cfx]`` of joint vectors (module docstring).

    Parameters
    ----------
    q : array_like
        (..., 7) joint values [rad] in physical order (ABB axes 1, 2, 7, 3, 4, 5, 6).

    Returns
    -------
    numpy.ndarray
        (..., 4) int.
    """
    q = np.asarray(q, dtype=float)
    cfx = (4 * (abb_joint(q, 2) < 0) + 2 * (abb_joint(q, 3) < 0)
           + (abb_joint(q, 5) < 0)).astype(int)
    return np.stack([quadrant(abb_joint(q, 1)), quadrant(abb_joint(q, 4)),
                     quadrant(abb_joint(q, 6)), cfx], axis=-1)
