"""Which arm holds which clip, decided once per plan from the geometry: the one rule of every
cell (the YuMi, the described cells, the reachability check, the placement repair).

A cell's left arm stands on its +y side, its right arm on the -y side, in the cell's own frame
(``cell.to_base``: the YuMi's base frame, however the robot is turned and placed in the plan's
frame; a described cell's frame from its right base to its left one); arms that reach across
each other collide. So the clip that stays on the cell's left (larger y in that frame) goes to
the left arm. The rule is applied to the whole path at once: the side of the two clips is the
sign of the y-difference summed over all shapes, and every shape where the clips are the
other way round is named (the arms would have to cross there). The program built on the
assignment then confirms it by IK and arm-arm clearance
(:func:`dloplan.robot.plugins.robot_program`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SIDE_TOLERANCE = 1e-3
"""[m] Clips closer than this in the robot's y are not counted as having changed sides."""


@dataclass(frozen=True)
class ArmAssignment:
    """The clip each arm holds.

    Attributes
    ----------
    left_clip : int
        Clip held by the left arm: 0 (the cable's first link) or 1 (its last).
    crossings : tuple of int
        Shapes where the left arm's clip lies to the right of the other one by more than
        :data:`SIDE_TOLERANCE` (empty for a path whose clips keep their sides).
    separation : tuple of float
        Per shape: y of the left arm's clip minus y of the right arm's clip, robot base frame [m].
    rule : str
        ``"geometry"`` (the side rule), ``"swapped"`` (the other assignment, taken because
        the side rule's program failed a check the swapped one passes) or ``"held"`` (the arms
        already hold the cable: a corrected plan's remaining motion keeps the plan's).
    """

    left_clip: int
    crossings: tuple[int, ...]
    separation: tuple[float, ...]
    rule: str = "geometry"

    @property
    def clips(self) -> tuple[int, int]:
        """Clip held by (left arm, right arm)."""
        return (self.left_clip, 1 - self.left_clip)

    @property
    def ok(self) -> bool:
        """The clips keep their sides over the whole path."""
        return not self.crossings

    @property
    def message(self) -> str:
        """One line: the assignment and, when they cross, where."""
        clips = ("first", "last")
        text = (f"left arm holds the {clips[self.left_clip]} clip, right arm the "
                f"{clips[1 - self.left_clip]} ({self.rule})")
        if self.crossings:
            shapes = ", ".join(str(k) for k in self.crossings)
            text += (f"; the clips change sides at shape{'s' if len(self.crossings) > 1 else ''} "
                     f"{shapes}: the arms would cross")
        return text

    def swapped(self) -> ArmAssignment:
        """The other assignment (rule ``"swapped"``)."""
        separation = tuple(-d for d in self.separation)
        crossings = tuple(k for k, d in enumerate(separation) if d < -SIDE_TOLERANCE)
        return ArmAssignment(1 - self.left_clip, crossings, separation, "swapped")


def assign_arms(clip_positions, cell) -> ArmAssignment:
    """The side rule (module docstring) on a path's clip points.

    Parameters
    ----------
    clip_positions : array_like
        (K, 2, 3) clip points [m] in the plan's (work) frame, clip 0 then clip 1.
    cell : RobotCell, DescribedCell or Robot
        Anything with ``to_base(positions)``: where the robot stands.

    Returns
    -------
    ArmAssignment
    """
    pos = np.asarray(clip_positions, dtype=float)
    if pos.ndim != 3 or pos.shape[1:] != (2, 3) or len(pos) == 0 or not np.all(np.isfinite(pos)):
        raise ValueError(f"clip_positions: expected finite (K, 2, 3) points [m], got shape "
                         f"{pos.shape}")
    y = cell.to_base(pos)[..., 1]
    dy = y[:, 0] - y[:, 1]
    left_clip = 0 if dy.sum() >= 0 else 1
    separation = dy if left_clip == 0 else -dy
    crossings = tuple(int(k) for k in np.flatnonzero(separation < -SIDE_TOLERANCE))
    return ArmAssignment(left_clip, crossings, tuple(float(d) for d in separation))
