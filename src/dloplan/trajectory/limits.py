"""Per-arm TCP motion limits with documented defaults for an ABB YuMi (IRB 14000).

The limits bound each TCP's path speed, acceleration and jerk (norms of the TCP position's
first three time derivatives) and its angular speed, acceleration and jerk (of the rotation
about its instantaneous axis). Defaults:

======================  ==============  ====================================================
limit                   default         reason
======================  ==============  ====================================================
speed                   0.1 m/s         the thesis' TCP speed (7.3, Table 7.3: 100 mm/s)
acceleration            1 m/s^2         0.1 g: the cable's inertial load stays a tenth of
                                        its weight; 9 % of the YuMi's 11 m/s^2 TCP maximum
jerk                    10 m/s^3        reaches 1 m/s^2 in 0.1 s (the controller's default
                                        ramp time order); a stop from 0.1 m/s takes 0.2 s
angular speed           1 rad/s         a point 0.1 m from the TCP (a clip's lever on a
                                        0.5 m cable) moves no faster than the TCP
angular acceleration    10 rad/s^2      the same 0.1 m lever: 1 m/s^2 at that point
angular jerk            100 rad/s^3     the same lever: 10 m/s^3 at that point
======================  ==============  ====================================================

The YuMi's own ceilings (ABB product specification IRB 14000: 1.5 m/s TCP speed, 11 m/s^2
TCP acceleration) are far above these: the defaults are set by the cable, which the plan
treats as quasi-static, not by the robot. The joint-speed limits of the arms along the path
(from the robot's inverse kinematics) enter as a per-segment speed scale
(:func:`dloplan.trajectory.dual_arm_trajectory`'s ``speed_scale``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from ..bounds import SLOWEST

DEFAULT_MAX_SPEED = 0.1
"""TCP speed limit [m/s] (thesis 7.3: 100 mm/s)."""

DEFAULT_MAX_ANGULAR_SPEED = 1.0
"""TCP angular speed limit [rad/s] (module docstring)."""

DEFAULT_MAX_ACCELERATION = 1.0
"""TCP acceleration limit [m/s^2] (module docstring)."""

DEFAULT_MAX_JERK = 10.0
"""TCP jerk limit [m/s^3] (module docstring)."""

DEFAULT_MAX_ANGULAR_ACCELERATION = 10.0
"""TCP angular acceleration limit [rad/s^2] (module docstring)."""

DEFAULT_MAX_ANGULAR_JERK = 100.0
"""TCP angular jerk limit [rad/s^3] (module docstring)."""


def positive(name: str, value) -> float:
    """``value`` as a finite float > 0, or a ValueError naming ``name``, the value and why."""
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: got {value!r}, expected a finite number > 0") from exc
    if isinstance(value, bool) or not math.isfinite(number) or number <= 0.0:
        raise ValueError(f"{name}: got {value!r}, expected a finite number > 0")
    return number


@dataclass(frozen=True)
class MotionLimits:
    """Limits on each TCP's motion (module docstring; the same for both arms).

    Parameters
    ----------
    speed : float
        Path speed [m/s].
    acceleration : float
        Norm of the TCP acceleration [m/s^2].
    jerk : float
        Norm of the TCP jerk [m/s^3].
    angular_speed : float
        Rotation rate [rad/s].
    angular_acceleration : float
        [rad/s^2].
    angular_jerk : float
        [rad/s^3].

    Raises
    ------
    ValueError
        For a limit that is not a finite number of at least :data:`SLOWEST` (a zero jerk cannot
        move anything; 1e-300 m/s would take longer than the universe has existed and leaves
        the time-optimal law's solver without a solution).
    """

    speed: float = DEFAULT_MAX_SPEED
    acceleration: float = DEFAULT_MAX_ACCELERATION
    jerk: float = DEFAULT_MAX_JERK
    angular_speed: float = DEFAULT_MAX_ANGULAR_SPEED
    angular_acceleration: float = DEFAULT_MAX_ANGULAR_ACCELERATION
    angular_jerk: float = DEFAULT_MAX_ANGULAR_JERK

    def __post_init__(self) -> None:
        for f in fields(self):
            value = positive(f.name, getattr(self, f.name))
            if value < SLOWEST:
                raise ValueError(f"{f.name}: got {value:g}, expected at least {SLOWEST:g} (SI "
                                 "units: 0.01 mm/s moves a metre in 28 hours)")
            object.__setattr__(self, f.name, value)

    def scaled(self, factor: float) -> MotionLimits:
        """The same limits with acceleration and jerk (linear and angular) times ``factor``."""
        factor = positive("factor", factor)
        return MotionLimits(self.speed, self.acceleration * factor, self.jerk * factor,
                            self.angular_speed, self.angular_acceleration * factor,
                            self.angular_jerk * factor)


__all__ = [
    "DEFAULT_MAX_ACCELERATION",
    "DEFAULT_MAX_ANGULAR_ACCELERATION",
    "DEFAULT_MAX_ANGULAR_JERK",
    "DEFAULT_MAX_ANGULAR_SPEED",
    "DEFAULT_MAX_JERK",
    "DEFAULT_MAX_SPEED",
    "MotionLimits",
    "SLOWEST",
    "positive",
]
