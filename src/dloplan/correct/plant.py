"""Closed loop in simulation: a plan run on a mismatched cable, measured and corrected.

The **plant** stands for the real cable: another discretization n, another E, mass or rest
shape than the plan's model. It is moved quasi-statically through the plan's clip poses (each
shape the equilibrium under the clips, a continuation like :func:`dloplan.sim.continuation`
warm-started from the secant prediction of the two before, :func:`continuation_guess`), so it
follows the branch a slowly moved real cable would. At the
checkpoints its shape is measured -- resampled to ``n_measured`` points along the cable with
Gaussian noise of ``noise`` [m] per coordinate -- and :func:`~dloplan.correct.correct_plan`
corrects the rest of the plan, which the plant then follows.

A gripper clamps a length of cable: the model represents it by its held end link (the clip
grips the middle of the end link, thesis Fig. 4.5), so a model with n links clamps L / n at each
end. The plant clamps ``clamp`` [m] at each end -- by default the model's link, the same
physical grip -- as the nearest whole number of its own links, held straight along the clip's
u-axis and centred on the clip point (:func:`~.model_error.clamped_equilibrium`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import least_squares

from ..cable import GRAVITY, Cable
from ..geometry import as_path, resample_by_arc_length
from ..grippers import GripperPath
from ..sim import ClipPoses, continuation, interpolate_clips
from ..sim.sensitivity import perturbed_clips
from .measurement import CorrectionRefused
from .model_error import clamped_equilibrium
from .step import Correction, CorrectionLimits, correct_plan

CHAIN_RESOLUTION = 1e-9
"""[m] the resolution of the chain plant's rest states (:attr:`Plant.resolution`): an upper
bound; its Newton solve stops at forces of 1e-10 of the cable's scale."""

DIFFERENCE_STEPS = 100.0
"""The floor's finite-difference step in units of the plant's resolution: the derivative's
round-off error is then 1 % of a unit response (a clip moved by h moves the shape by about h)."""


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
    offset : array_like
        (3,) the measurement's offset [m]: every measured point is translated by it (a camera's
        calibration error), the cable is not.
    """

    cable: Cable
    noise: float = 0.0
    n_measured: int = 50
    seed: int = 0
    substeps: int = 2
    clamp: float | None = None
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        offset = np.asarray(self.offset, dtype=float)
        if offset.shape != (3,) or not np.all(np.isfinite(offset)):
            raise ValueError(f"plant.offset: got {self.offset!r}, expected three finite "
                             "distances [m]")
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
    def resolution(self) -> float:
        """[m] how closely a rest state is resolved: the chain's Newton solve converges to
        forces of 1e-10 of its scale, far below a nanometre (:data:`CHAIN_RESOLUTION`); another
        simulator's plant states its own (a tolerance of its solve)."""
        return CHAIN_RESOLUTION

    @property
    def clamp_links(self) -> int:
        """Links of the plant held by each gripper (>= 1)."""
        if self.clamp is None:
            return 1
        return max(1, round(self.clamp / self.cable.rest_link_length))

    def hold(self, shape: np.ndarray, clips: ClipPoses, gravity=GRAVITY,
             rtol: float | None = None):
        """The plant's equilibrium held by ``clips`` from the guess ``shape``.

        Returns
        -------
        tuple
            ``(shape (n + 1, 3), success, message)``: success is a converged, stable
            equilibrium.
        """
        return clamped_equilibrium(self.cable, shape, clips, self.clamp_links, gravity=gravity,
                                   rtol=rtol)

    def measure(self, shape: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The noisy measurement of a plant shape, offset, (n_measured, 3) [m]."""
        points = resample_by_arc_length(shape, self.n_measured) + np.asarray(self.offset)
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
        Mean distance [m] of the plant's final shape to the reference, compared as curves at
        equal arc length (:func:`shape_error`).
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


def continuation_guess(previous: np.ndarray, before: np.ndarray) -> np.ndarray:
    """Where the plant's continuation starts a stop's Newton loop from the equilibria of the
    two stops before it, ``previous`` and ``before`` (n + 1, 3) [m]: the secant prediction
    2 x_(s-1) - x_(s-2) [m] (the held points are laid at the stop's clips by
    :meth:`Plant.hold`, whatever the guess holds there).

    The stops are the substeps of a smooth clip path, so the shape moves on by about as much
    as it did: on the study example the plants' stops took 33 % fewer Newton iterations (44 %
    fewer factorizations) than from x_(s-1), to the same equilibria within 1e-9 m
    (docs/performance.md, branch cl1k)."""
    return 2.0 * previous - before


def _drive(plant: Plant, start: np.ndarray, grippers: GripperPath, first: int, last: int,
           gravity, before: np.ndarray | None = None) -> tuple[list[np.ndarray], np.ndarray | None]:
    """The plant's shapes at clip poses first .. last, from ``start`` (at pose first - 1), and
    the stop's equilibrium before the last one: the continuation goes on from there. Each stop
    starts from the :func:`continuation_guess` of the two before it (``before`` the one before
    ``start``; None: the first stop from ``start`` itself)."""
    shapes = []
    x = start
    for j in range(first, last + 1):
        stops = interpolate_clips(grippers.clip_poses(j - 1), grippers.clip_poses(j),
                                  np.arange(1, plant.substeps + 1) / plant.substeps)
        for stop in stops:
            guess = x if before is None else continuation_guess(x, before)
            before = x
            x, ok, message = plant.hold(guess, stop, gravity)
            if not ok:
                raise RuntimeError(f"plant: the quasi-static simulation failed at shape {j}: "
                                   f"{message}")
        shapes.append(x)
    return shapes, before


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
        Passed to :func:`correct_plan` (reference, mode, modulus_steps, limits, ...);
        ``measured_links`` defaults to the plant's links (the prior on the discretization bias,
        :func:`~.model_error.alpha_prior`).
    """
    options.setdefault("measured_links", plant.cable.n_links)
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
    open_loop = np.stack([settled, *_drive(plant, settled, grippers, 1, last, gravity)[0]])
    closed = [settled]
    before = None  # the continuation's stop before closed[-1]: it goes on across corrections
    corrections: list[Correction] = []
    refusals: list[str] = []
    current = grippers
    stable = stabilized
    done = 0
    for k in [*checks, last]:
        part, before = _drive(plant, closed[-1], current, done + 1, k, gravity, before)
        closed += part
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
    closed_loop = np.stack(closed)
    return ClosedLoopRun(open_loop, closed_loop, reference,
                         shape_error(open_loop[-1], reference),
                         shape_error(closed_loop[-1], reference), tuple(corrections),
                         tuple(refusals))


def shape_error(shape: np.ndarray, reference: np.ndarray) -> float:
    """Mean distance [m] between two curves compared at equal arc length.

    Both polylines (any numbers of points) are resampled at ``len(reference)`` points equally
    spaced in arc length and the distances of corresponding points averaged: a plant of n = 100
    is compared with a model target of n = 20 as curves, not as point sets.
    """
    n_points = len(reference)
    a = resample_by_arc_length(shape, n_points)
    b = resample_by_arc_length(reference, n_points)
    return float(np.mean(np.linalg.norm(a - b, axis=1)))


def reachable_error(plant: Plant, clips: ClipPoses, reference: np.ndarray, guess: np.ndarray, *,
                    limits: CorrectionLimits | None = None, gravity=GRAVITY,
                    max_evaluations: int = 200) -> float:
    """The floor: the least final error [m] any correction of ``clips`` within ``limits`` leaves.

    A bounded least-squares fit (:func:`scipy.optimize.least_squares`, forward differences on
    the plant itself, no noise, no model) of the 12 clip coordinates minimizing the plant's
    :func:`shape_error` to ``reference``: what a perfect correction could reach. A cable of
    another stiffness sags differently; two clips cannot always give it the planned shape.
    (The fit minimizes the squared point distances, the floor is their mean at its optimum: the
    least mean distance itself is lower, by 6-15 % on the U demo's plants.)

    The differences take an absolute step of :data:`DIFFERENCE_STEPS` times the plant's
    :attr:`~Plant.resolution` (the clip coordinates in metres, rotations times L / 2: 1e-7 m on
    the chain, 1 mm on a plant resolved to 1e-5 m); SciPy's relative ``diff_step`` is a step
    times |x|, 1.5e-8 at x = 0, below another simulator's solver tolerance, where the fit
    would stop at its first point.

    Parameters
    ----------
    plant : Plant
        The real cable (its clamp set).
    clips : ClipPoses
        The planned clip poses of the shape.
    reference : numpy.ndarray
        (m, 3) the shape wanted [m].
    guess : numpy.ndarray
        (n_plant + 1, 3) the plant's shape at ``clips`` (selects the branch) [m].
    limits : CorrectionLimits, optional
        The bounds of the correction (default :class:`~.step.CorrectionLimits`).
    gravity : array_like
        Gravity [m/s^2].
    max_evaluations : int
        Evaluations of the cost at most (each Jacobian costs 12 plant solves more; a slow
        plant, another simulator, gets fewer).
    """
    box = _ClipBox.of(plant.cable.length, limits)
    h = DIFFERENCE_STEPS * plant.resolution

    wanted = resample_by_arc_length(reference, len(reference))

    @_last_value
    def residual(z):
        return box.residual(plant, clips, wanted, guess, z, gravity).ravel()

    fit = least_squares(residual, np.zeros(12),
                        jac=lambda z: box.differences(residual, z, residual(z), h),
                        bounds=(-box.bound, box.bound),
                        x_scale=box.bound, max_nfev=max_evaluations)
    x, _, _ = plant.hold(guess, perturbed_clips(clips, fit.x / box.scale), gravity)
    return shape_error(x, reference)


def _last_value(function):
    """``function`` of a point z (12,) remembering its last point and value (a copy is
    returned): :func:`scipy.optimize.least_squares` asks for the residual at a point and then
    for its Jacobian there, whose forward differences start from that value, and every value is
    a solve of each plant."""
    last = []

    def remembered(z):
        if not last or not np.array_equal(last[0], z):
            last[:] = [np.array(z, dtype=float), function(z)]
        return last[1].copy()

    return remembered


@dataclass(frozen=True, eq=False)
class _ClipBox:
    """The floors' clip coordinates z = scale p (metres, rotations times L / 2) and their
    bounds: each coordinate within limits / sqrt(3), a box inside the limits' balls."""

    scale: np.ndarray
    bound: np.ndarray

    @classmethod
    def of(cls, length: float, limits: CorrectionLimits | None) -> _ClipBox:
        limits = CorrectionLimits() if limits is None else limits
        scale = np.tile(np.r_[np.ones(3), np.full(3, 0.5 * length)], 2)
        bound = np.tile(np.r_[np.full(3, limits.max_translation),
                              np.full(3, limits.max_rotation)], 2) * scale / np.sqrt(3.0)
        return cls(scale, bound)

    def residual(self, plant: Plant, clips: ClipPoses, wanted: np.ndarray,
                 guess: np.ndarray, z: np.ndarray, gravity) -> np.ndarray:
        """(m, 3) the plant's shape at ``clips`` corrected by z, resampled at equal arc length
        onto m points, minus ``wanted`` (the shape wanted, resampled so once by the caller) [m]."""
        x, _, _ = plant.hold(guess, perturbed_clips(clips, z / self.scale), gravity)
        return resample_by_arc_length(x, len(wanted)) - wanted

    def differences(self, residual, z: np.ndarray, f0: np.ndarray, step: float) -> np.ndarray:
        """(N, 12) the Jacobian of ``residual`` (z (12,) -> (N,), ``f0`` its value at z) by
        forward differences of ``step`` [m] in each coordinate, backwards where forwards would
        leave the box."""
        steps = np.where(z + step <= self.bound, step, -step)
        columns = []
        for k in range(len(z)):
            moved = z.copy()
            moved[k] += steps[k]
            columns.append((residual(moved) - f0) / steps[k])
        return np.stack(columns, axis=1)


def shared_floor(plants, clips: ClipPoses, reference: np.ndarray, guesses, floors, *,
                 weights=None, limits: CorrectionLimits | None = None, gravity=GRAVITY,
                 max_evaluations: int = 1000) -> tuple[float, np.ndarray]:
    """What one correction can do for cables the measurement cannot tell apart: a lower bound
    of the largest ratio to its floor that any single correction of ``clips`` leaves them.

    A correction decides its clips from what the measurement tells. Plants that differ only
    where it tells nothing (the U demo's E: its shapes before the target tell ln E to sd 5-9)
    get the same correction, up to noise, and the benchmark compares each with its own floor
    f_k (:func:`reachable_error`, fitted on that plant). With r_k(p) = e_k(p) / f_k the mean
    distance ratio of plant k at the clip correction p, and weights w_k >= 0 summing to 1,

        max_k r_k(p) >= sum_k w_k r_k(p) >= min_q sum_k w_k r_k(q) =: B(w)     for every p,

    so B(w) bounds from below the largest ratio of any one correction (weak duality; the
    minimum is a local one, near the planned clips, within the limits' box, as the floor's).
    The ratios at the minimizer bound the best such correction from above (it is one).

    The minimum is found by Gauss-Newton (a trust-region fit, :func:`scipy.optimize.
    least_squares`, in the floor's box) on the objective written as a sum of squares,
    sum_k w_k r_k = sum_ki |rho_ki|^2 with rho_ki = d_ki sqrt(w_k / (m f_k |d_ki|)) and d_ki
    the plant's point i minus the wanted one. The objective is a sum of distances: where the
    minimizer brings a point onto the wanted shape (the U demo's middle point) it has a kink,
    and it is known only to the plants' resolution (each solve stops at its tolerance). Both
    defeat a quasi-Newton line search on differences of the objective (L-BFGS-B stalled at the
    kink, above the minimum, or ended in a failed line search once the plants' start moved by
    their resolution). Here the distances d(z), smooth in the clips, are differenced and the
    norm's derivative taken exactly, |d| smoothed to sqrt(|d|^2 + resolution^2) (below what
    the solves resolve), and a step lost in the solves' noise only shrinks the trust region.
    B(w) is the objective itself, unsmoothed, at the minimizer.

    Parameters
    ----------
    plants : sequence of Plant
        The cables (each its own E, links, clamp).
    clips : ClipPoses
        The planned clip poses of the target.
    reference : numpy.ndarray
        (m, 3) the shape wanted [m].
    guesses : sequence of numpy.ndarray
        Each plant's shape at ``clips`` (selects the branch) [m].
    floors : sequence of float
        Each plant's floor [m] (:func:`reachable_error`).
    weights : array_like, optional
        (len(plants),) w_k >= 0, normalized to sum 1 (default: equal).
    limits : CorrectionLimits, optional
        The bounds of the correction (default :class:`~.step.CorrectionLimits`).
    gravity : array_like
        Gravity [m/s^2].
    max_evaluations : int
        Evaluations of the objective at most (each Jacobian costs 12 solves of each plant:
        forward differences of step :data:`DIFFERENCE_STEPS` times the plants' coarsest
        resolution).

    Returns
    -------
    tuple
        ``(B(w), ratios (len(plants),) at the minimizer)``.

    Raises
    ------
    ValueError
        For weights that are not one non-negative number per plant with a positive sum, or
        floors that are not positive (named).
    RuntimeError
        When the minimization does not converge: its value would not bound anything.
    """
    count = len(plants)
    w = np.full(count, 1.0 / count) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (count,) or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"weights: got {weights!r}, expected {count} numbers >= 0 with a "
                         "positive sum (one per plant)")
    floors = np.asarray(floors, dtype=float)
    if floors.shape != (count,) or not np.all(floors > 0):
        raise ValueError(f"floors: got {floors!r}, expected {count} errors > 0 [m]")
    w = w / w.sum()
    box = _ClipBox.of(plants[0].cable.length, limits)
    resolution = max(plant.resolution for plant in plants)
    step = DIFFERENCE_STEPS * resolution  # [m]
    wanted = resample_by_arc_length(reference, len(reference))
    # the objective as a sum of squares for Gauss-Newton: sum_k w_k r_k(z) = sum_ki a_ki |d_ki|
    # = sum_ki |rho_ki|^2, rho_ki = d_ki sqrt(a_ki / |d_ki|), with |d| smoothed to
    # sqrt(|d|^2 + resolution^2) (a distance driven to zero is a kink)
    a = np.repeat(w / (len(wanted) * floors), len(wanted))

    @_last_value
    def distances(z):
        return np.concatenate([box.residual(plant, clips, wanted, guess, z, gravity)
                               for plant, guess in zip(plants, guesses, strict=True)])

    def rho(z):
        d = distances(z)
        return (d * np.sqrt(a / np.hypot(np.linalg.norm(d, axis=1), resolution))[:, None]).ravel()

    def jacobian(z):
        # d rho = sqrt(a / s) (J - d (d . J) / (2 s^2)), s = |d| smoothed; J by differences of
        # the distances, which are smooth in z (the norm's kink is taken exactly)
        d = distances(z)
        j = box.differences(lambda moved: distances(moved).ravel(), z, d.ravel(),
                            step).reshape(len(d), 3, 12)
        s = np.hypot(np.linalg.norm(d, axis=1), resolution)
        along = np.einsum("ia,iaz->iz", d, j)
        return (np.sqrt(a / s)[:, None, None] * (
            j - (0.5 / s**2)[:, None, None] * d[:, :, None] * along[:, None, :])).reshape(-1, 12)

    # the fit ends when a step gains less than 1e-8 of the objective, or when its steps are
    # lost in the solves' noise (the trust region shrunk below xtol): never on a failed line
    # search. (A valley between plants can take a few hundred steps: ftol 1e-10 took 647
    # evaluations where 1e-8 took 257, 1.2e-6 lower, on the U demo's pair at w (0.2, 0.8).)
    fit = least_squares(rho, np.zeros(12), jac=jacobian, bounds=(-box.bound, box.bound),
                        x_scale=box.bound, ftol=1e-8, xtol=1e-10, gtol=None,
                        max_nfev=max_evaluations)
    if fit.status <= 0:
        raise RuntimeError(f"shared_floor: the minimization did not converge ({fit.message}, "
                           f"{fit.nfev} evaluations): no bound")
    d = distances(fit.x).reshape(count, len(wanted), 3)
    ratios = np.mean(np.linalg.norm(d, axis=2), axis=1) / floors
    return float(w @ ratios), ratios


def stabilized_target(cable: Cable, path: np.ndarray, grippers: GripperPath, gravity) -> np.ndarray:
    """The model's stabilized target: the target settled under the target's clips."""
    return continuation(cable, path[-1], [grippers.clip_poses(len(path) - 1)],
                        gravity=gravity)[0].shape
