"""The job types: one immutable object in SI units and domain types, made once at load.

A :class:`Job` holds the cable, the start and target discretized to the cable's n + 1 points,
obstacles, the robot cell, and the settings of every stage with their defaults applied and their
units converted (lengths [m], speeds [m/s], angles [rad]); the planner's weights and stiffness
family are already chosen. The application's loader (:mod:`dloplan.app.load`,
:mod:`dloplan.app.resolve`) makes it from a job file; nothing here knows files, file units or
pydantic.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import Cable
from ..planning.tuning import PlannerWeights
from ..robot.cell import RobotCell
from ..robot.described import DescribedCell
from ..trajectory import MotionLimits

if TYPE_CHECKING:
    from ..harness.board import Board
    from ..harness.job import HarnessSettings


@dataclass(frozen=True)
class PlannerSettings:
    """How the three-stage planner runs (thesis chapter 4, 5.4).

    Attributes
    ----------
    n_shapes : int
        S, the number of intermediate shapes.
    weights : PlannerWeights
        The weights of every stage (Table 6.1, the Table 6.2 row of ``family``, overrides).
    family : str
        The stiffness family whose physical weights are in ``weights``.
    family_forced : bool
        True when the scenario named the family; False when it follows from E.
    physical_mode : str
        "equilibrium" or "thesis" (the physical stage, :mod:`dloplan.planning.physical`).
    z_safety : float
        Lift safety offset of the obstacle re-planning [m] (thesis 5.4.3).
    max_rounds : int
        Largest number of re-planning rounds.
    keep_target : bool
        Plan to the target as given instead of its minimal-energy shape (thesis 4.5.1).
    """

    n_shapes: int
    weights: PlannerWeights
    family: str
    family_forced: bool
    physical_mode: str
    z_safety: float
    max_rounds: int
    keep_target: bool = False

    @property
    def weights_used(self) -> bool:
        """True when the family's physical weights shape the plan ("thesis" physical mode).

        In the default "equilibrium" mode every intermediate shape is an equilibrium of the
        cable, whatever the weights; the family then only labels the cable.
        """
        return self.physical_mode == "thesis"


@dataclass(frozen=True, eq=False)
class GripperSettings:
    """Gripper orientation (thesis 4.6, Table 4.3).

    Attributes
    ----------
    method : str
        "auto", "auxiliary", "minimal" or "rigid".
    auxiliary_vector : numpy.ndarray
        (3,) the auxiliary vector of the auxiliary-vector method.
    initial : Rotation or None
        Two clip-to-world rotations (first, last) the minimal and rigid methods start from.
    """

    method: str
    auxiliary_vector: np.ndarray
    initial: Rotation | None = None


@dataclass(frozen=True)
class MotionSettings:
    """The timed dual-arm motion (:mod:`dloplan.trajectory`).

    Attributes
    ----------
    limits : MotionLimits
        Per-arm TCP speed [m/s], acceleration [m/s^2], jerk [m/s^3] and their angular
        counterparts [rad/s, rad/s^2, rad/s^3].
    zone : float
        Fly-by zone radius at the interior shapes [m]; 0 stops at every shape.
    grasp_time, release_time : float
        Gripper action durations [s].
    rate : float
        Sampling rate of the trajectory exports [Hz].
    """

    limits: MotionLimits
    zone: float
    grasp_time: float
    release_time: float
    rate: float

    @property
    def tcp_speed(self) -> float:
        """Largest TCP speed [m/s]."""
        return self.limits.speed


@dataclass(frozen=True)
class RepairSettings:
    """What a repair may change without asking (docs/repair.md, "Consent").

    Repairs that keep the job as asked (the stable branch, clip routes, the gripper frames and
    the grasp roll, the arm assignment, a slower motion within the job's own limits) are always
    made. A repair that changes the task itself is only proposed unless allowed here.

    Attributes
    ----------
    placement : bool
        Move or turn the job on the table (its start and target, where the operator puts the
        cable) so that the robot reaches it; the robot program then says where the job must be
        placed. False: such a placement is written into the plan as a proposal, and the plan
        fails its robot check.
    """

    placement: bool = False


@dataclass(frozen=True, eq=False)
class Job:
    """A scenario resolved into library objects, in SI units (see the module docstring).

    Attributes
    ----------
    source : str
        Where the job came from (a file name), for messages and reports.
    cable : Cable
    start, target : numpy.ndarray
        (n + 1, 3) start and target shapes [m], discretized to the cable's points.
    obstacles : tuple
        Obstacles (:class:`~dloplan.obstacles.Box`, ``Cylinder``, ``Table``) [m].
    planner : PlannerSettings
    grippers : GripperSettings
    motion : MotionSettings
    target_threshold : float
        T_cf [m] of the target stability check (thesis 5.3).
    outputs : tuple of str
        The files ``dloplan plan`` writes ("json", "csv", "rapid", "ros", "figures", "report").
    robot : RobotCell or DescribedCell
        The robot cell the plan is executed in: the YuMi (placement, tools, work object), or
        two arms from descriptions (``robot.cell``, docs/cells.md).
    identification : Identification or None
        How the cable's E was identified, when the scenario asked for it.
    study : StudySpec or None
        The scenario's robustness study section.
    repair : RepairSettings
        What a repair may change without asking (the placement of the job on the table).
    """

    source: str
    cable: Cable
    start: np.ndarray
    target: np.ndarray
    obstacles: tuple
    planner: PlannerSettings
    grippers: GripperSettings
    motion: MotionSettings
    target_threshold: float
    outputs: tuple[str, ...]
    robot: RobotCell | DescribedCell = field(default_factory=RobotCell)
    identification: object = None
    study: object = None
    repair: RepairSettings = field(default_factory=RepairSettings)


@dataclass(frozen=True, eq=False)
class HarnessJob:
    """A wire-harness job file resolved into library objects, in SI units (thesis 7.3).

    Attributes
    ----------
    source : str
        Where the job came from (a file name), for messages and reports.
    cable : Cable
    start : numpy.ndarray
        (n + 1, 3) start shape [m]; the target follows from the board.
    board : Board
        Fixtures, pegs, obstacles and the table (:mod:`dloplan.harness.board`), checked against
        the cable.
    settings : HarnessSettings
        Phases, insertion, tensioning and motion (:class:`dloplan.harness.job.HarnessSettings`).
    robot : RobotCell or DescribedCell
        The robot cell the program is made for (its placement search off: a board is fixed).
    outputs : tuple of str
        The files ``dloplan plan`` writes (the file's ``outputs``).
    """

    source: str
    cable: Cable
    start: np.ndarray
    board: Board
    settings: HarnessSettings
    robot: RobotCell | DescribedCell = field(default_factory=RobotCell)
    outputs: tuple[str, ...] = ("json", "rapid")
