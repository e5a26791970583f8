"""The planner's result: :class:`Plan` (paths of every stage, forces, statistics, statuses)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..cable import Cable
from ..physics.chain import SpringChain, forces
from .geometric import StageStatus
from .physical import WEIGHTLESS, ShapeResult
from .tuning import PlannerWeights

STAGES: tuple[str, ...] = ("basic", "advanced", "physical")


@dataclass(frozen=True)
class ForceStatistics:
    """Mean and variance over the path of each mass point's force magnitudes [N], [N^2].

    The quantities of thesis Figs. 4.21/4.22 and 7.29; each array has shape (n + 1,).
    """

    axial_mean: np.ndarray
    axial_variance: np.ndarray
    bending_mean: np.ndarray
    bending_variance: np.ndarray


@dataclass(frozen=True, eq=False)
class Plan:
    """A planned path of cable shapes and how it was obtained (thesis 4.2-4.5).

    Attributes
    ----------
    cable : Cable
        The cable planned for.
    basic, advanced, physical : numpy.ndarray
        (S + 2, n + 1, 3) paths of the three stages [m], start and (pre-processed) target
        included; ``physical`` is the plan (also :attr:`path`).
    proposed_target : numpy.ndarray
        (n + 1, 3) the target as given (after resampling) [m], before pre-processing.
    lengths : numpy.ndarray
        (3, S + 2) polyline length of every shape of each stage [m], rows as :data:`STAGES`.
    axial_forces, bending_forces : numpy.ndarray
        (3, S + 2, n + 1, 3) per-point axial (eq. 3.17) and bending (eq. 3.18) forces [N] of the
        weightless cable in every shape of each stage.
    statuses : dict
        ``{"basic", "advanced": StageStatus}`` and ``"physical"``: a tuple of
        :class:`ShapeResult` status lines, one per intermediate shape; ``"target"``: the
        pre-processing result (or None).
    timings : dict
        Wall time per stage [s]: "target", "basic", "advanced", "physical", "total".
    warnings : tuple of str
        Everything the user should look at (target far from minimal energy, failed solves).
    weights : PlannerWeights
        The weights used.
    family : str
        The stiffness family of the cable.
    physical_mode : str
        "equilibrium" or "thesis".
    """

    cable: Cable
    basic: np.ndarray
    advanced: np.ndarray
    physical: np.ndarray
    proposed_target: np.ndarray
    lengths: np.ndarray
    axial_forces: np.ndarray
    bending_forces: np.ndarray
    statuses: dict
    timings: dict
    warnings: tuple[str, ...]
    weights: PlannerWeights
    family: str
    physical_mode: str

    @property
    def path(self) -> np.ndarray:
        """The planned path (S + 2, n + 1, 3) [m]: the physical stage's."""
        return self.physical

    @property
    def n_shapes(self) -> int:
        """S, the number of intermediate shapes."""
        return self.physical.shape[0] - 2

    @property
    def success(self) -> bool:
        """Every stage's solver succeeded."""
        shapes = self.statuses["physical"]
        target = self.statuses.get("target")
        return (self.statuses["basic"].success and self.statuses["advanced"].success
                and all(s.success for s in shapes) and (target is None or target.success))

    @property
    def message(self) -> str:
        """One line: success, or the first problem."""
        if self.success:
            return f"planned {self.n_shapes} shapes in {self.timings['total']:.3g} s"
        return self.warnings[0] if self.warnings else "a stage did not converge"

    def stage(self, name: str) -> np.ndarray:
        """The path (S + 2, n + 1, 3) of one stage: "basic", "advanced" or "physical"."""
        if name not in STAGES:
            raise ValueError(f"stage: got {name!r}, expected one of {', '.join(STAGES)}")
        return getattr(self, name)

    def force_statistics(self, stage: str = "physical") -> ForceStatistics:
        """Mean and variance across the path of |F_s| and |F_b| at each mass point (Fig. 4.21)."""
        self.stage(stage)  # validates the name
        k = STAGES.index(stage)
        axial = np.linalg.norm(self.axial_forces[k], axis=-1)
        bending = np.linalg.norm(self.bending_forces[k], axis=-1)
        return ForceStatistics(axial.mean(axis=0), axial.var(axis=0),
                               bending.mean(axis=0), bending.var(axis=0))


def stage_forces(cable: Cable, paths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Axial and bending forces [N] of a stack of paths (..., n + 1, 3), weightless cable."""
    f = forces(SpringChain.from_cable(cable, WEIGHTLESS), paths)
    return f.axial, f.bending


__all__ = ["STAGES", "ForceStatistics", "Plan", "ShapeResult", "StageStatus", "stage_forces"]
