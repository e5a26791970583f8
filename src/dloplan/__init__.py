"""dloplan: model-based offline planning for dual-arm manipulation of deformable linear objects.

The pipeline, top to bottom: a :class:`Cable` and its mass-spring model (``physics``), static
equilibrium and simulation (``sim``), the three-stage planner (``planning``), obstacles,
gripper frames (``grippers``), timed dual-arm trajectories (``trajectory``), verification
(``verify``, ``robot``), exports (``io``); around it identification (``identify``), studies
(``study``), the wire-harness job (``harness``) and experiment tooling (``vision``).

Heavy optional dependencies (OpenCV, Dask, pyarrow) and matplotlib are imported only by the
functions that need them.
"""

from importlib import import_module

__version__ = "0.1.0"
"""The package's version: the one place it is written (pyproject.toml reads it), so the
command line needs no package metadata lookup at its start."""

_EXPORTS = {
    "cable": ("CATALOGUE_NAMES", "GRAVITY", "Cable", "catalogue_cable"),
    "grippers": ("GripperPath", "gripper_path"),
    "identify": ("Identification", "identify_youngs_modulus"),
    "obstacles": ("Box", "Cylinder", "Table", "avoid_obstacles", "check_path"),
    "planning": ("Plan", "plan"),
    "sim": ("ClipPoses", "Equilibrium", "check_target", "continuation", "equilibrium",
            "simulate", "stabilize"),
    "sim.torsion": ("equilibrium_with_twist", "twist_along_path"),
    "trajectory": ("Trajectory", "dual_arm_trajectory", "trajectory_from_grippers"),
    "verify": ("Verification", "verify_path"),
}
_HOME = {name: module for module, names in _EXPORTS.items() for name in names}


def __getattr__(name: str):
    """The public names and subpackages, imported on first use (PEP 562): ``import dloplan``
    and the command line's start stay fast, as numba, scipy and the planner load only when
    needed."""
    if name in _HOME:
        value = getattr(import_module(f".{_HOME[name]}", __name__), name)
    else:
        try:
            value = import_module(f".{name}", __name__)
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


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
