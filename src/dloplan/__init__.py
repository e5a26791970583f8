"""dloplan: model-based offline planning for dual-arm manipulation of deformable linear objects.

The pipeline, top to bottom: a :class:`Cable` and its mass-spring model (``physics``), static
equilibrium and simulation (``sim``), the three-stage planner (``planning``), obstacles,
gripper frames (``grippers``), timed dual-arm trajectories (``trajectory``), verification
(``verify``, ``robot``), exports (``io``); around it identification (``identify``), studies
(``study``), the wire-harness job (``harness``) and experiment tooling (``vision``).

Heavy optional dependencies (OpenCV, Dask, pyarrow) and matplotlib are imported only by the
functions that need them.
"""

from importlib.metadata import PackageNotFoundError, version

from .cable import CATALOGUE_NAMES, GRAVITY, Cable, catalogue_cable
from .grippers import GripperPath, gripper_path
from .identify import Identification, identify_youngs_modulus
from .obstacles import Box, Cylinder, Table, avoid_obstacles, check_path
from .planning import Plan, plan
from .sim import (
    ClipPoses,
    Equilibrium,
    check_target,
    continuation,
    equilibrium,
    simulate,
    stabilize,
)
from .sim.torsion import equilibrium_with_twist, twist_along_path
from .trajectory import Trajectory, dual_arm_trajectory, trajectory_from_grippers
from .verify import Verification, verify_path

__all__ = [
    "CATALOGUE_NAMES",
    "GRAVITY",
    "Box",
    "Cable",
    "ClipPoses",
    "Cylinder",
    "Equilibrium",
    "GripperPath",
    "Identification",
    "Plan",
    "Table",
    "Trajectory",
    "Verification",
    "avoid_obstacles",
    "catalogue_cable",
    "check_path",
    "check_target",
    "continuation",
    "dual_arm_trajectory",
    "equilibrium",
    "equilibrium_with_twist",
    "gripper_path",
    "identify_youngs_modulus",
    "plan",
    "simulate",
    "stabilize",
    "trajectory_from_grippers",
    "twist_along_path",
    "verify_path",
]
try:
    __version__ = version("dloplan")
except PackageNotFoundError:  # pragma: no cover - running from a source tree without install
    __version__ = "unknown"
