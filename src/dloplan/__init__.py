"""dloplan: model-based offline planning for dual-arm manipulation of deformable linear objects.

The pipeline, top to bottom: a :class:`Cable` and its mass-spring model (``physics``), static
equilibrium and simulation (``sim``), the three-stage planner (``planning``), obstacles, gripper
frames, timed dual-arm trajectories, verification, and exports.
"""

from .cable import CATALOGUE_NAMES, GRAVITY, Cable, catalogue_cable

__all__ = ["CATALOGUE_NAMES", "GRAVITY", "Cable", "catalogue_cable"]
__version__ = "0.1.0"
