"""A dual-arm cell: two arms from descriptions on a table, the one cell type of every robot.

A :class:`DescribedCell` is two :class:`~dloplan.robot.chain.CellArm` s (any serial arms, each
with its base pose, tool and joint limits) and the table they stand on: the UR5e and Panda pairs
read from URDF (:mod:`dloplan.robot.urdf_cell`), and the ABB YuMi (:func:`dloplan.robot.yumi.
yumi`, whose arms carry the arm angle's plug-in data; its RAPID cell,
:class:`~dloplan.robot.cell.RobotCell`, holds one). The kinematics
(:mod:`dloplan.robot.kinematics`), the arm assignment (:mod:`dloplan.robot.assignment`), the
path checks (:mod:`dloplan.robot.path`) and the placement searches
(:mod:`dloplan.robot.placement`) take it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .chain import CellArm, capsules
from .collision import arm_clearance

ARMS = ("left", "right")
"""The arms of a cell, in the order of every per-arm array."""

MIN_MARGIN = float(np.radians(5.0))
"""[rad] Default smallest joint margin of a cell's program (:attr:`DescribedCell.min_margin`)."""


@dataclass(frozen=True, eq=False)
class DescribedCell:
    """Two arms from descriptions on a table.

    Parameters
    ----------
    name : str
    left, right : CellArm
        The arms (``name`` ``"left"`` and ``"right"``): the world frame is the plan's frame.
    table_height : float
        z of the table top in the world [m]; every moving capsule must stay above it.
    shared_base : bool
        Both arms hang on one body (one description with two chains, e.g. the YuMi): the base
        link's capsules are not checked against each other.
    place : bool
        A plan is verified where the placement search puts it (:func:`search_cell_placement`);
        False: where it was planned.
    writers : dict
        Per program format (``urscript``, ``ros_joints``) the writer's keyword settings (the
        scenario's ``robot.urscript`` / ``robot.ros_joints``: the cell's wiring and controller
        names).
    source : dict, optional
        The mapping that builds the cell again (:func:`cell_from_mapping`, lengths in m, URDF
        paths absolute); the presets record theirs.
    min_margin : float
        Smallest distance [rad] of every joint from its limits at every pose: a program closer
        fails its ``joint limits`` check (default :data:`MIN_MARGIN`, 5 deg).
    """

    name: str
    left: CellArm
    right: CellArm
    table_height: float = 0.0
    shared_base: bool = False
    place: bool = True
    writers: dict = field(default_factory=dict)
    source: dict | None = None
    min_margin: float = MIN_MARGIN

    def __post_init__(self) -> None:
        if (self.left.name, self.right.name) != ARMS:
            raise ValueError(f"arms: expected names {ARMS}, got ({self.left.name!r}, "
                             f"{self.right.name!r})")
        if not np.isfinite(self.table_height):
            raise ValueError(f"table_height: expected a finite number [m], got "
                             f"{self.table_height!r}")
        if not (np.isfinite(self.min_margin) and self.min_margin >= 0):
            raise ValueError(f"min_margin: expected a joint margin >= 0 [rad], got "
                             f"{self.min_margin!r}")

    @property
    def arms(self) -> tuple[CellArm, CellArm]:
        """``(left, right)``."""
        return (self.left, self.right)

    def to_base(self, positions) -> np.ndarray:
        """World points [m], (..., 3), in the cell's frame: origin between the two bases, y
        from the right base to the left one (horizontal), z up; the arms' base frame when both
        share a base (one body, e.g. the YuMi, however it is turned). The clip with the larger
        y goes to the left arm (:func:`~dloplan.robot.assignment.assign_arms`)."""
        pos = np.asarray(positions, dtype=float)
        across = self.left.base_position - self.right.base_position
        across[2] = 0.0
        if np.linalg.norm(across) < 1e-9:
            return self.left.base_rotation.inv().apply(
                pos.reshape(-1, 3) - self.left.base_position).reshape(pos.shape)
        y = across / np.linalg.norm(across)
        axes = np.stack([np.cross(y, [0.0, 0.0, 1.0]), y, [0.0, 0.0, 1.0]], 1)
        middle = 0.5 * (self.left.base_position + self.right.base_position)
        return (pos - middle) @ axes

    def to_dict(self) -> dict:
        """JSON-ready data that builds the cell again (:func:`cell_from_dict`)."""
        if self.source is None:
            raise ValueError(f"cell {self.name!r}: built without a mapping, cannot be recorded "
                             "(build it with cell_from_mapping or a preset)")
        return {"kind": "described", **self.source, "place": self.place,
                "writers": self.writers, "min_margin": self.min_margin}


def pair_clearance(cell: DescribedCell, q_left, q_right) -> np.ndarray:
    """Smallest arm-arm capsule clearance [m], (...,), negative when they overlap
    (:func:`~dloplan.robot.collision.arm_clearance`; the base links of arms on one body not
    against each other).

    Parameters
    ----------
    q_left, q_right : array_like
        (..., n_arm) joint values [rad] of each arm, same batch shape.
    """
    return arm_clearance(cell.left, q_left, cell.right, q_right,
                         shared_base=cell.shared_base)[0]


def table_clearance(cell: DescribedCell, arm: CellArm, q) -> np.ndarray:
    """(...,) lowest surface of the arm's moving capsules above the table [m].

    Parameters
    ----------
    cell : DescribedCell
    arm : CellArm
        One of ``cell.arms``.
    q : array_like
        (..., n_arm) joint values [rad].
    """
    seg, rad, link = capsules(arm, q)
    low = seg[..., 2].min(axis=-1) - rad - cell.table_height
    return np.where(link >= 0, low, np.inf).min(axis=-1)
