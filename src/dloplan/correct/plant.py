"""Closed loop in simulation: a plan run on a mismatched cable, measured and corrected.

The **plant** stands for the real cable: another discretization n, another E, mass or rest
shape than the plan's model. It is moved quasi-statically through the plan's clip poses (each
shape the equilibrium under the clips, warm-started from the previous one:
:func:`dloplan.sim.continuation`), so it follows the branch a slowly moved real cable would. At the
checkpoints its shape is measured -- resampled to ``n_measured`` points along the cable with
Gaussian noise of ``noise`` [m] per coordinate -- and :func:`~dloplan.correct.correct_plan`
corrects the rest of the plan, which the plant then follows.

A gripper clamps a length of cable: the model represents it by its held end link (the clip
grips the middle of the end link, thesis Fig. 4.5), so a model with n links clamps L / n at each
end. The plant clamps ``clamp`` [m] at each end -- by default the model's link, the same
physical grip -- as the nearest whole number of its own links, held straight along the clip's
u-axis and centred on the clip point; its free points are solved by the same trust-region Newton
method as every equilibrium (:func:`dloplan.sim.statics.minimize_energy`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..cable import GRAVITY, Cable
from ..grippers import GripperPath
from ..physics.chain import SpringChain
from ..physics.geometry import as_path, resample_by_arc_length
from ..sim import ClipPoses, continuation, interpolate_clips
from ..sim.statics import force_scale, minimize_energy
from .measurement import CorrectionRefused
from .step import Correction, correct_plan


@dataclass(frozen=True)
class Plant:
    """A simulated real cable and its measurement.

    Parameters
    ----------
    cable : Cable
        The real cable (any n, E, mass, rest shape).
    noise : float
        Standard deviation of the measurement noise per coordinate [m].
    n_measured : int
        Points measured along the cable (>= 2).
    seed : int
        Seed of the noise.
    substeps : int
        Equilibria solved between consecutive clip poses.
    clamp : float, optional
        Length of cable each gripper clamps [m] (default: one plant link; :func:`run_closed_loop`
        passes the model's link length).
    """

    cable: Cable
    noise: float = 0.0
    n_measured: int = 50
    seed: int = 0
    substeps: int = 2
    clamp: float | None = None

    def __post_init__(self) -> None:
        if not (np.isfinite(self.noise) and self.noise >= 0):
            raise ValueError(f"plant.noise: got {self.noise!r}, expected a distance >= 0 [m]")
        if int(self.n_measured) != self.n_measured or self.n_measured < 2:
            raise ValueError(f"plant.n_measured: got {self.n_measured!r}, expected an integer "
                             ">= 2")
        if self.clamp is not None and not (
                np.isfinite(self.clamp) and 0 < self.clamp < 0.25 * self.cable.length):
            raise ValueError(f"plant.clamp: got {self.clamp!r}, expected a length > 0 and below "
                             "a quarter of the cable [m]")

    @property
    def clamp_links(self) -> int:
        """Links of the plant held by each gripper (>= 1)."""
        if self.clamp is None:
            return 1
        return max(1, round(self.clamp / self.cable.rest_link_length))

    def hold(self, shape: np.ndarray, clips: ClipPoses, gravity=GRAVITY, rtol: float = 1e-9):
        """The plant's equilibrium held by ``clips`` from the guess ``shape``.

        Returns
        -------
        tuple
            ``(shape (n + 1, 3), success, message)``: success is a converged, stable
            equilibrium.
        """
        cable = self.cable
        k = self.clamp_links
        offsets = (np.arange(k + 1) - 0.5 * k) * cable.rest_link_length
        u = clips.u_axes
        x = np.array(shape, dtype=float)
        x[: k + 1] = clips.positions[0] + offsets[:, None] * u[0]
        x[::-1][: k + 1] = clips.positions[1] + offsets[:, None] * u[1]
        chain = SpringChain.from_cable(cable, gravity)
        x, _, _, _, stable, _, message = minimize_energy(
            chain, x, slice(k + 1, cable.n_points - k - 1), cable.length,
            rtol * force_scale(cable, gravity))
        return x, stable, message

    def measure(self, shape: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The noisy measurement of a plant shape, (n_measured, 3) [m]."""
        points = resample_by_arc_length(shape, self.n_measured)
        return points + rng.normal(scale=self.noise, size=points.shape)


@dataclass(frozen=True, eq=False)
class ClosedLoopRun:
    """Result of :func:`run_closed_loop`.

    Attributes
    ----------
    open_loop, closed_loop : numpy.ndarray
        (T + 1, n_plant + 1, 3) the plant's shapes at every clip pose, without and with the
        corrections [m].
    reference : numpy.ndarray
        (n + 1, 3) the shape the plan promised at the target [m].
    open_loop_error, closed_loop_error : float
        Mean point distance [m] of the plant's final shape (resampled onto the model's points)
        to the reference.
    corrections : tuple of Correction
        The corrections applied, in order.
    refusals : tuple of str
        The reasons of the corrections refused (the plan then went on unchanged).
    """

    open_loop: np.ndarray
    closed_loop: np.ndarray
    reference: np.ndarray
    open_loop_error: float
    closed_loop_error: float
    corrections: tuple[Correction, ...] = field(default_factory=tuple)
    refusals: tuple[str, ...] = field(default_factory=tuple)

    @property
    def improvement(self) -> float:
        """open_loop_error / closed_loop_error."""
        return self.open_loop_error / max(self.closed_loop_error, 1e-300)


def _drive(plant: Plant, start: np.ndarray, grippers: GripperPath, first: int, last: int,
           gravity) -> list[np.ndarray]:
    """The plant's shapes at clip poses first .. last, from ``start`` (at pose first - 1)."""
    shapes = []
    x = start
    for j in range(first, last + 1):
        stops = interpolate_clips(grippers.clip_poses(j - 1), grippers.clip_poses(j),
                                  np.arange(1, plant.substeps + 1) / plant.substeps)
        for stop in stops:
            x, ok, message = plant.hold(x, stop, gravity)
            if not ok:
                raise RuntimeError(f"plant: the quasi-static simulation failed at shape {j}: "
                                   f"{message}")
        shapes.append(x)
    return shapes


def run_closed_loop(
    plant: Plant,
    cable: Cable,
    shapes,
    grippers: GripperPath,
    checkpoints=(),
    *,
    stabilized=None,
    trajectory=None,
    gravity=GRAVITY,
    **options,
) -> ClosedLoopRun:
    """Run a plan on the plant open loop and closed loop (corrected at the checkpoints).

    Parameters
    ----------
    plant : Plant
        The simulated real cable and its measurement.
    cable : Cable
        The plan's model cable.
    shapes : array_like
        (T + 1, n + 1, 3) planned shapes [m].
    grippers : GripperPath
        The plan's clip poses.
    checkpoints : sequence of int
        Shapes (0 <= K < T) after which the plant is measured and the plan corrected.
    stabilized : array_like, optional
        The plan's stabilized shapes (see :func:`correct_plan`).
    trajectory : Trajectory, optional
        The plan's trajectory.
    gravity : array_like
        Gravity [m/s^2].
    **options
        Passed to :func:`correct_plan` (reference, mode, modulus_steps, limits).
    """
    path = as_path(shapes, cable.n_points, "shapes")
    last = len(path) - 1
    checks = sorted({int(k) for k in checkpoints})
    if any(not 0 <= k < last for k in checks):
        raise ValueError(f"checkpoints: got {list(checkpoints)!r}, expected shape indices "
                         f"0 .. {last - 1}")
    rng = np.random.default_rng(plant.seed)
    if plant.clamp is None:
        plant = replace(plant, clamp=cable.rest_link_length)
    start = resample_by_arc_length(path[0], plant.cable.n_points)
    settled, ok, message = plant.hold(start, grippers.clip_poses(0), gravity)
    if not ok:
        raise RuntimeError(f"plant: the start does not settle: {message}")
    open_loop = np.stack([settled, *_drive(plant, settled, grippers, 1, last, gravity)])
    closed = [settled]
    corrections: list[Correction] = []
    refusals: list[str] = []
    current = grippers
    stable = stabilized
    done = 0
    for k in [*checks, last]:
        closed += _drive(plant, closed[-1], current, done + 1, k, gravity)
        done = k
        if k == last:
            break
        try:
            result = correct_plan(cable, path, current, k, plant.measure(closed[-1], rng),
                                  stabilized=stable, trajectory=trajectory, gravity=gravity,
                                  **options)
        except CorrectionRefused as exc:
            refusals.append(f"shape {k}: {exc}")
            continue
        corrections.append(result)
        current = result.grippers
        trajectory = result.trajectory
    if options.get("reference") == "planned":
        reference = path[-1]
    elif stabilized is not None:
        reference = as_path(stabilized, cable.n_points, "stabilized")[-1]
    else:
        reference = stabilized_target(cable, path, grippers, gravity)

    def error(shape):
        on_model = resample_by_arc_length(shape, cable.n_points)
        return float(np.mean(np.linalg.norm(on_model - reference, axis=1)))

    closed_loop = np.stack(closed)
    return ClosedLoopRun(open_loop, closed_loop, reference, error(open_loop[-1]),
                         error(closed_loop[-1]), tuple(corrections), tuple(refusals))


def stabilized_target(cable: Cable, path: np.ndarray, grippers: GripperPath, gravity) -> np.ndarray:
    """The model's stabilized target: the target settled under the target's clips."""
    return continuation(cable, path[-1], [grippers.clip_poses(len(path) - 1)],
                        gravity=gravity)[0].shape
