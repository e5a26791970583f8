"""Obstacles: volumes, collision checks on stabilized shapes, lifting and re-planning (ch. 5.4)."""

from .avoidance import Avoidance, avoid_obstacles, lift_shapes
from .collisions import CollisionReport, check_path, check_shape, stabilized_path
from .shapes import Box, Cylinder, Table

__all__ = [
    "Avoidance",
    "Box",
    "CollisionReport",
    "Cylinder",
    "Table",
    "avoid_obstacles",
    "check_path",
    "check_shape",
    "lift_shapes",
    "stabilized_path",
]
