"""The harness board of the examples, built in code for the harness tests."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from dloplan.harness import Board, Fixture, Peg
from dloplan.obstacles import Box, Table
from dloplan.shapes import place, straight_shape

DIAGONAL = np.sqrt(0.5)


def demo_board(cable, *, fixture_y: float = 0.15, peg_y: float = 0.0, peg_x: float = 0.38,
               obstacles: bool = True) -> Board:
    """Fixtures at x = 0.5 m, +-fixture_y, slots 45 degrees toward the robot, the cable axis at
    the plate's height (3 cm); one peg with a plate inside the loop; a wall before the board."""
    z = 0.03 + cable.diameter / 2
    fixtures = (
        Fixture((0.50, -fixture_y, z), (-DIAGONAL, DIAGONAL, 0.0), name="fixture_right"),
        Fixture((0.50, fixture_y, z), (-DIAGONAL, -DIAGONAL, 0.0), name="fixture_left"),
    )
    peg = Peg((peg_x, peg_y, 0.0), 0.012, 0.06, plate_height=0.03, plate_size=(0.08, 0.12))
    wall = (Box((0.30, 0.0, 0.03), (0.03, 0.16, 0.06), name="wall"),) if obstacles else ()
    return Board(fixtures, (peg,), wall, Table(0.0))


def demo_start(cable) -> np.ndarray:
    """The cable straight along y in front of the robot, held 5 cm above the table."""
    return place(straight_shape(cable.length, cable.n_links), (0.22, -cable.length / 2, 0.05),
                 Rotation.from_euler("z", 90, degrees=True))
