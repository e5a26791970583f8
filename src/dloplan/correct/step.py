"""One correction of a running plan from a measured shape (thesis 8.1, done here).

The plan says which shapes x_j the cable takes at clip poses C_j, j = 0 .. T. After the robot
reaches shape K the cable is measured; the correction

1. **estimates the model error**: the measurement y (resampled onto the model's points,
   :mod:`.measurement`) is compared with the model's equilibrium x_K at C_K, and log E and the
   amplitude alpha of the discretization error d (:mod:`.model_error`) take Gauss-Newton steps
   on ||y - x_K(log E) - alpha d_K||^2 with the sensitivity J = d x / d log E
   (:mod:`dloplan.sim.sensitivity`) (``model_error="modulus"``: log E alone, delta = (J . r) /
   (J . J)); with ``grip="estimate"`` the clamp length's response g joins d
   (x_K(log E) + alpha d_K + beta g_K), kept when the measurement tells it; with
   ``offset="estimate"`` a rigid translation o of the measured points too (a camera's
   calibration error: y ~ x_K + alpha d_K + beta g_K + o), taken out of the comparison when the
   measurement tells it and never carried into the predictions. In statics E and the
   mass enter only as their ratio, so this absorbs a wrong mass
   as well; what is left is reported as the unexplained residual. Each step changes E by at
   most a factor 2; they stop when one changes E by less than 1 %;
2. **corrects the clips** so that the predicted stabilized shapes, bias included, match the
   reference (the plan's stabilized shapes: what the verified plan promised; or its planned
   shapes): a Levenberg-Marquardt fit of the 12 clip coordinates p (:func:`~dloplan.sim.
   sensitivity.perturbed_clips`) minimizing sum_i |x_i*(C_j + p) + alpha d_i - x_i^ref|^2, with
   the Jacobian of the equilibrium (implicit differentiation) and the damping mu diag(J^T J);
   rotation coordinates are scaled by L / 2 so that metres and radians weigh alike. Mode
   ``"target"`` fits the target only and ramps the correction in linearly over the remaining
   shapes (p_j = p_T (j - K) / (T - K): no jump at the current shape); mode ``"all"`` fits
   every remaining shape in turn, each starting from the previous one's solution;
3. **re-times** the corrected gripper path (:func:`dloplan.trajectory.trajectory_from_grippers`,
   the plan's motion limits -- speed, acceleration, jerk -- zones, arms and tool frame): the
   remaining motion first (the robot can go on), then the whole path for the record;
4. **predicts the rest** with the updated model, from its equilibrium at the measurement, open
   loop and corrected: quasi-static continuations along the planned and the corrected clip
   poses (each step started from the previous equilibrium moved by the plan's own step; in
   mode ``"target"`` the target's where the clip fit started and ended, solved already),
   reported side by side.

The correction is damped and bounded: a measured shape that disagrees wildly (:mod:`.measurement`)
or a modulus update beyond ``limits.max_modulus_factor`` raises :class:`~.measurement.
CorrectionRefused` with the reason, and nothing is applied; the clip fit is held within
``limits.max_translation`` / ``limits.max_rotation`` (its trial steps projected onto them, a
warning when it ends on them), and a correction whose predicted gain is not significant is
refused (the plan kept).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..geometry import as_path
from ..grippers import GripperPath, relative_twist
from ..least_squares import Damping, damped_minimize
from ..physics.chain import SpringChain
from ..sim import ClipPoses, equilibrium
from ..sim.sensitivity import equilibrium_sensitivity, perturbed_clips
from ..trajectory import Trajectory, trajectory_from_grippers
from .length import check_length, length_alternative, length_direction
from .measurement import MAX_DISAGREEMENT, CorrectionRefused, noise_sd, resample_measured
from .model_error import (
    MAX_GRIP,
    alpha_prior,
    clamped_equilibrium,
    fit_model_error,
    measured_offset,
    model_error_directions,
    offset_covariance,
    parameter_covariance,
    resampled,
    standard_deviations,
)

REFERENCES = ("stabilized", "planned")

MODULUS_STEP_TOLERANCE = 0.01
"""The log E steps stop once a step changes E by less than this fraction."""

MAX_LOG_STEP = math.log(2.0)
"""Largest change of log E in one Gauss-Newton step (a factor 2 in E)."""

GRIP_UNCERTAINTY = 0.25
"""The clamp length's uncertainty in model links: a gripper's jaws end within L / (4 n) of where
the model's held link ends (a 20 mm grip on 25 mm links is 0.2)."""

GRIP_LINEARITY = 0.5
"""The estimated clamp length's error beyond its statistics, relative to its change from the
model's: the response g is a half-link difference, and the fit shares the residual with E and
the discretization bias (on the chain plant a 20 mm grip on 25 mm links comes out 21-22 mm, a
third of the change short)."""

SIGNIFICANCE = 2.0
"""E is updated only when the measurement's first step is at least this many sd(ln E)."""

MAX_LOG_SD = math.log(2.0)
"""E is kept when the measurement cannot tell it within a factor 2 (sd(ln E) above this): a
shape that hardly depends on E (the U demo: sd(ln E) = 31 with the clamp length fitted too)
asks for steps that mean nothing, however many sd they are."""

COST_TOLERANCE = 1e-3
"""The clip fit stops once an iteration lowers the squared error by less than this fraction."""
OFFSET_SIGNIFICANCE = math.sqrt(7.815)
"""The measurement's offset is applied when its components, in standard deviations, have a norm
of at least this: the 95 % quantile of the chi distribution with 3 degrees of freedom (an offset
of zero passes it one time in twenty)."""

MODES = ("target", "all")
MODEL_ERRORS = ("discretization", "modulus")
MODULI = ("estimate", "known")
"""Young's modulus: estimated from the measurement when it tells it (default), or known to be the
model's (identified beforehand, ``dloplan identify``: no update, no uncertainty in the interval).
A shape that hardly depends on E -- every shape of the U demo: sd(ln E) 5-6 at mid-path, 0.9 at
the target with 1 mm of noise -- cannot tell it, while its target still depends on it."""
GRIPS = ("estimate", "model", "known")
"""The clamp length: estimated with E and the bias when the measurement tells it (default), the
model's one link with its uncertainty in the interval, or known to be the model's (a gripper
whose jaws are calibrated to end where the model's held link does: no uncertainty)."""
OFFSETS = ("estimate", "none")
"""The measurement's offset (a rigid translation of the measured shape, e.g. a camera's
calibration error): estimated with E when the measurement tells it, else its size in the
interval (default), or taken as zero."""


@dataclass(frozen=True)
class CorrectionLimits:
    """Bounds of a correction; beyond them it is refused.

    Parameters
    ----------
    max_translation : float
        Largest correction of a clip point [m] (default 30 mm).
    max_rotation : float
        Largest correction of a clip orientation [rad] (default 20 degrees).
    max_modulus_factor : float
        Largest factor the modulus update may change E by (default 10).
    max_disagreement : float
        Largest mean distance between the measured and the predicted shape, in cable lengths.
    iterations : int
        Levenberg-Marquardt iterations per fitted shape.
    gain_significance : float
        The predicted gain must be more than this many of its sd from zero, and still a gain
        with the clamp length this many sd off, else the plan is kept (default
        :data:`SIGNIFICANCE`; 0: any predicted gain will do).
    """

    max_translation: float = 0.03
    max_rotation: float = math.radians(20.0)
    max_modulus_factor: float = 10.0
    max_disagreement: float = MAX_DISAGREEMENT
    iterations: int = 12
    gain_significance: float = SIGNIFICANCE

    def __post_init__(self) -> None:
        if not (math.isfinite(self.gain_significance) and self.gain_significance >= 0):
            raise ValueError(f"limits.gain_significance: got {self.gain_significance!r}, "
                             "expected a number >= 0")
        for name in ("max_translation", "max_rotation", "max_disagreement"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"limits.{name}: got {value!r}, expected a number > 0")
        if not (math.isfinite(self.max_modulus_factor) and self.max_modulus_factor >= 1):
            raise ValueError(f"limits.max_modulus_factor: got {self.max_modulus_factor!r}, "
                             "expected a number >= 1")
        if isinstance(self.iterations, bool) or int(self.iterations) != self.iterations \
                or self.iterations < 1:
            raise ValueError(f"limits.iterations: got {self.iterations!r}, expected an integer "
                             ">= 1")


@dataclass(frozen=True, eq=False)
class ModelUpdate:
    """The model error seen in the measurement and the modulus update.

    Attributes
    ----------
    youngs_modulus_before, youngs_modulus : float
        E of the plan and the updated E [Pa].
    residual_before, residual_after : float
        Mean distance [m] between the measured shape and the model's at shape K: the plan's
        model, and the updated one (E and the bias alpha d: what is left is the error the
        model cannot explain, measurement noise included).
    steps : int
        Gauss-Newton steps taken.
    state : numpy.ndarray
        (n + 1, 3) the updated model's equilibrium at shape K: the start of the predictions.
    discretization : float
        alpha, the measured amplitude of the discretization error carried as a bias
        (:mod:`.model_error`; 0 when not estimated), fitted with its first-order value as the
        prior (:func:`.model_error.alpha_prior`).
    discretization_sd : float
        Its standard deviation, the prior's information included (inf when not estimated).
    correlation : float
        The correlation of ln E and alpha in the fit (:func:`.model_error.
        parameter_covariance`; 0 when either is not estimated or E is known): the gain check
        carries it to the target (:func:`_gain_sd`).
    log_prior_sd : float
        The sd of ln E the correction assumes before the measurement: E within the limit
        ``max_modulus_factor`` of the plan's at 2 sd (beyond it a correction is refused),
        ln(max_modulus_factor) / 2; combined with :attr:`log_sd` for the interval and the gain
        check (:func:`parameter_sds`), where a shape that does not tell E (the U demo,
        sd(ln E) 7) would otherwise put factors of e^14 into a linearization.
    log_sd : float
        Standard deviation of ln E the measurement gives (inf when not computed).
    note : str
        Why E was kept, or held at the limit ``max_modulus_factor`` (a measurement asking for
        E beyond it by less than 2 sd), when it was ("" otherwise).
    grip : float
        beta, the measured clamp length's change in half model links (:mod:`.model_error`: the
        grippers clamp (1 + beta / 2) L / n; 0 when not estimated).
    grip_sd : float
        Its standard deviation (inf when the clamp length was not estimated).
    grip_note : str
        The clamp length estimated, or why not.
    offset : numpy.ndarray
        (3,) the measurement's offset [m] (a rigid translation of the measured points,
        :func:`.model_error.offset_directions`): applied to the model when it is compared with
        the measurement, never to the predictions (zeros when not estimated).
    offset_sd : float
        Standard deviation of its length [m] (the root sum of the components' variances; inf
        when not fitted).
    offset_uncertainty : float
        The offset's share of the prediction's error budget [m]: the size of an offset the fit
        found but could not tell from noise (it may bias E and the bias by as much), 0 when
        it was applied or not fitted.
    offset_note : str
        The offset estimated, or why not.
    """

    youngs_modulus_before: float
    youngs_modulus: float
    residual_before: float
    residual_after: float
    steps: int
    state: np.ndarray
    discretization: float = 0.0
    log_sd: float = math.inf
    note: str = ""
    grip: float = 0.0
    grip_sd: float = math.inf
    grip_note: str = ""
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    offset_sd: float = math.inf
    offset_uncertainty: float = 0.0
    offset_note: str = "not estimated"
    discretization_sd: float = math.inf
    correlation: float = 0.0
    log_prior_sd: float = math.inf

    @property
    def offset_estimated(self) -> bool:
        """Whether the measured offset was applied."""
        return bool(np.any(self.offset != 0.0))

    @property
    def grip_estimated(self) -> bool:
        """Whether the clamp length is told: by the measurement, or known (``grip="known"``,
        sd 0); else the model's is kept with its uncertainty."""
        return math.isfinite(self.grip_sd)

    def bias(self, cable: Cable, shape: np.ndarray, clips: ClipPoses, gravity=GRAVITY
             ) -> np.ndarray:
        """The measured model error alpha d + beta g at ``clips`` (n + 1, 3) [m]
        (:func:`.model_error.model_error_directions` at the model's ``shape``)."""
        if self.discretization == 0.0 and self.grip == 0.0:
            return np.zeros_like(shape)
        d, g = model_error_directions(cable, shape, clips, grip=self.grip != 0.0,
                                      gravity=gravity)
        return self.discretization * d + (0.0 if g is None else self.grip * g)


@dataclass(frozen=True, eq=False)
class Correction:
    """Result of :func:`correct_plan`.

    Attributes
    ----------
    at : int
        The index K of the shape just reached and measured.
    measured : numpy.ndarray
        (n + 1, 3) the measurement resampled onto the model's points [m].
    model : ModelUpdate
        The model error and the modulus update.
    cable : Cable
        The updated model cable (E).
    reference : numpy.ndarray
        (T - K, n + 1, 3) the shapes the remaining motion should produce [m].
    open_loop, corrected : numpy.ndarray or None
        (T - K, n + 1, 3) the updated model's predictions of the remaining shapes with the
        planned and with the corrected clips [m], the discretization bias alpha d included:
        what the cable is expected to do.
    equilibria : numpy.ndarray or None
        (T - K, n + 1, 3) the updated model's stable equilibria at the corrected clips [m], the
        bias not included: the stabilized shapes of the corrected plan, which ``dloplan
        verify`` checks as equilibria of the model the plan states.
    uncertainty : dict
        The prediction's error budget at the target [m]: ``unexplained`` (what the updated
        model leaves at shape K: the model errors it cannot represent, a measurement offset
        not taken out, noise), ``grip`` (the estimated clamp length's 2 sd plus
        :data:`GRIP_LINEARITY` of its change, 0 when known, or, not estimated, a clamp length
        L / (4 n) off the model's, :data:`GRIP_UNCERTAINTY`), ``modulus`` (2 sd of ln E),
        ``offset`` (an offset of the measurement found but not told from noise: its size plus 2 sd,
        :attr:`ModelUpdate.offset_uncertainty`; 0 when it was taken out or not estimated),
        ``discretization`` (2 sd of alpha times d at the target);
        their sum bounds the final error's prediction interval (:attr:`prediction_interval`).
        Empty for a correction made with ``predict=False``.
    clip_corrections : numpy.ndarray
        (T - K, 12) the corrections of the remaining shapes' clip coordinates
        (:data:`dloplan.sim.sensitivity.CLIP_COORDINATES`).
    grippers : GripperPath
        The whole gripper path with the remaining shapes corrected.
    trajectory : Trajectory or None
        Its timed dual-arm trajectory (shapes 0 .. K unchanged; None with ``predict=False``).
    remaining : Trajectory
        The trajectory from shape K to the target, starting at time 0: the program to run now.
    mode, reference_kind, model_error : str
        How it was computed.
    iterations : int
        Levenberg-Marquardt iterations (all fitted shapes).
    seconds : float
        Wall time until the remaining trajectory is ready [s] (what the robot waits for).
    prediction_seconds : float
        Wall time of the whole corrected trajectory and the open-loop and corrected
        predictions afterwards [s].
    cpu_seconds : float
        CPU time of this thread until the remaining trajectory is ready [s]: ``seconds`` without
        the waiting for a shared core.
    warnings : tuple of str
    fit_links : int
        The links of the chain the clips were fitted on (:class:`FitModel`; the plan's n: its
        own chain, 0: not recorded). With more, the target's predictions (the last of
        ``open_loop`` and ``corrected``) are that chain's, as the clips were fitted; the shapes
        before it, and ``equilibria``, the plan's model's.
    """

    at: int
    measured: np.ndarray
    model: ModelUpdate
    cable: Cable
    reference: np.ndarray
    open_loop: np.ndarray | None
    corrected: np.ndarray | None
    equilibria: np.ndarray | None
    uncertainty: dict
    clip_corrections: np.ndarray
    grippers: GripperPath
    trajectory: Trajectory | None
    remaining: Trajectory
    mode: str
    reference_kind: str
    model_error: str
    iterations: int
    seconds: float
    prediction_seconds: float
    cpu_seconds: float
    warnings: tuple[str, ...] = field(default_factory=tuple)
    fit_links: int = 0

    @property
    def open_loop_error(self) -> np.ndarray:
        """(T - K,) mean point distance of the open-loop prediction to the reference [m]."""
        return _mean_distance(self.open_loop, self.reference)

    @property
    def corrected_error(self) -> np.ndarray:
        """(T - K,) mean point distance of the corrected prediction to the reference [m]."""
        return _mean_distance(self.corrected, self.reference)

    @property
    def predicted_error(self) -> float:
        """The predicted final error [m]: the corrected prediction's, but never below what the
        model could not explain at shape K (it is there at the target too)."""
        return max(float(self.corrected_error[-1]), self.uncertainty["unexplained"])

    @property
    def prediction_interval(self) -> tuple[float, float]:
        """(low, high) of the final error [m]: the corrected prediction's error plus or minus
        the sum of :attr:`uncertainty` (mean distances add at most: triangle inequality)."""
        p = float(self.corrected_error[-1])
        spread = sum(self.uncertainty.values())
        return max(0.0, p - spread), p + spread

    @property
    def message(self) -> str:
        """One line: the modulus update and the predicted final errors, open loop and
        corrected (the predictions' errors against the reference, like each other; where
        :attr:`predicted_error` is floored above the corrected one, the floor named)."""
        m = self.model
        bias = (f", discretization bias x{m.discretization:.2f}" if self.model_error ==
                "discretization" else "")
        if m.grip_estimated:
            bias += f", clamp {1e3 * (1.0 + 0.5 * m.grip) * self.cable.rest_link_length:.1f} mm"
        if m.offset_estimated:
            bias += f", measurement offset {1e3 * float(np.linalg.norm(m.offset)):.1f} mm"
        head = (f"corrected at shape {self.at}: E {m.youngs_modulus_before:.3g} -> "
                f"{m.youngs_modulus:.3g} Pa{bias} (measured vs model "
                f"{1e3 * m.residual_before:.1f} -> {1e3 * m.residual_after:.1f} mm)")
        if self.corrected is None:
            return head + "; no predictions (predict=False)"
        corrected = float(self.corrected_error[-1])
        floor = (f", not below the {1e3 * self.predicted_error:.1f} mm the model could not "
                 f"explain at shape {self.at}" if self.predicted_error > corrected else "")
        return (f"{head}; predicted final error {1e3 * self.open_loop_error[-1]:.1f} mm open loop, "
                f"{1e3 * corrected:.1f} mm corrected{floor} (interval "
                f"{1e3 * self.prediction_interval[0]:.1f} - "
                f"{1e3 * self.prediction_interval[1]:.1f} mm)")

    def report(self) -> dict:
        """The correction as JSON-ready values (SI units)."""
        m = self.model
        return {
            "at": self.at,
            "mode": self.mode,
            "reference": self.reference_kind,
            "youngs_modulus_before": m.youngs_modulus_before,
            "youngs_modulus": m.youngs_modulus,
            "measured_vs_model_before": m.residual_before,
            "measured_vs_model_after": m.residual_after,
            "modulus_steps": m.steps,
            "model_error": self.model_error,
            "discretization_alpha": m.discretization,
            "grip_beta": m.grip,
            "grip_sd": m.grip_sd if m.grip_estimated else None,
            "clamp_length": (1.0 + 0.5 * m.grip) * self.cable.rest_link_length,
            "grip_note": m.grip_note,
            "offset": m.offset.tolist(),
            "offset_sd": m.offset_sd if math.isfinite(m.offset_sd) else None,
            "offset_note": m.offset_note,
            "shapes": list(range(self.at + 1, self.at + 1 + len(self.reference))),
            **({} if self.corrected is None else {
                "open_loop_error": self.open_loop_error.tolist(),
                "corrected_error": self.corrected_error.tolist(),
                "predicted_error": self.predicted_error,
                "prediction_interval": list(self.prediction_interval),
                "uncertainty": dict(self.uncertainty)}),
            "log_modulus_sd": m.log_sd if math.isfinite(m.log_sd) else None,
            "modulus_alpha_correlation": m.correlation,
            "modulus_note": m.note,
            "clip_corrections": self.clip_corrections.tolist(),
            "fit_links": self.fit_links,
            "iterations": self.iterations,
            "seconds": self.seconds,
            "prediction_seconds": self.prediction_seconds,
            "cpu_seconds": self.cpu_seconds,
            "duration_remaining": self.remaining.duration,
            "warnings": list(self.warnings),
            "message": self.message,
        }


def _mean_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.mean(np.linalg.norm(a - b, axis=-1), axis=-1)


def update_modulus(cable: Cable, measured: np.ndarray, clips: ClipPoses, *, steps: int = 3,
                   max_factor: float = 10.0, gravity=GRAVITY, guess=None,
                   discretization: bool = False, grip: bool = False,
                   offset: bool = False, measured_links: int | None = None,
                   modulus: bool = True, noise: float = 0.0) -> ModelUpdate:
    """Gauss-Newton steps in log E fitting the model's equilibrium at ``clips`` to ``measured``.

    With ``discretization``, each step fits log E and the amplitude alpha of the discretization
    error together (:func:`.model_error.fit_model_error`; alpha with its first-order value as
    the prior, :func:`.model_error.alpha_prior`): measured ~ x(E) + alpha d; with
    ``grip`` too, the clamp length's amplitude beta as well: measured ~ x(E) + alpha d + beta g
    (:func:`.model_error.model_error_directions`), kept only when the first step finds it at
    least :data:`SIGNIFICANCE` standard deviations from 0 (else the clamp length stays the
    model's and its uncertainty goes into the prediction's interval, ``ModelUpdate.grip_note``).
    With ``offset``, the measurement's offset o (a rigid translation of the measured points,
    measured ~ x(E) + alpha d + beta g + o) is first read off the held points
    (:func:`.model_error.measured_offset`) and, when it is at least :data:`OFFSET_SIGNIFICANCE`
    standard deviations from 0, taken out of the measurement before the fit (else its size goes
    into the interval, ``ModelUpdate.offset_uncertainty``); it explains the measurement, not the
    cable, so the predictions never carry it.

    E is only changed when the measurement tells it: a first step smaller than
    :data:`SIGNIFICANCE` standard deviations of ln E (:func:`.model_error.parameter_sds`, the
    scatter the fit leaves) keeps E, with the reason in ``ModelUpdate.note`` (a measurement
    equal to the plan's prediction plus noise, or a shape that hardly depends on E). A step is
    at most a factor 2 in E (a trust region); steps cut by it do not count against ``steps``, so
    the updates reach any factor up to ``max_factor`` (the last step cut to end on it); a
    measurement asking for more from there is refused when it asks for more by over
    :data:`SIGNIFICANCE` sd(ln E), else E is held at the limit (``note``).

    Parameters
    ----------
    cable : Cable
        The model cable (its E is the start).
    measured : numpy.ndarray
        (n + 1, 3) measured shape on the model's points [m].
    clips : ClipPoses
        The clip poses it was measured at.
    steps : int
        Most Gauss-Newton steps within the trust region (0: only the residual is computed);
        they stop early once a step changes E by less than 1 % (:data:`MODULUS_STEP_TOLERANCE`).
    max_factor : float
        Refuse an update that changes E by more than this factor.
    gravity : array_like
        Gravity [m/s^2].
    guess : numpy.ndarray, optional
        (n + 1, 3) start of the first equilibrium (default ``measured``; the plan's stabilized
        shape, already an equilibrium of ``cable`` on the same branch, saves the iterations).
    discretization : bool
        Also estimate the discretization error's amplitude (:mod:`.model_error`).
    grip : bool
        With ``discretization``: also estimate the clamp length when the measurement tells it.
    offset : bool
        Also estimate the measurement's offset when the measurement tells it.
    measured_links : int, optional
        The measured cable's own discretization (a simulated plant's links), the centre of the
        prior on alpha; None: a real cable, the continuum.
    modulus : bool
        Estimate E (default); False: E is known to be ``cable``'s (kept, sd(ln E) = 0), the
        bias's amplitudes (and the clamp length, the offset) are fitted at it, even with
        ``steps = 0``.
    noise : float
        The measurement's noise, sd per coordinate [m] (:func:`.measurement.noise_sd`): the
        offset's covariance carries it along the clips' axes, where the measured curve's ends
        are as uncertain as one point (:func:`.model_error.offset_covariance`; 0: the held
        points' scatter alone).

    Raises
    ------
    CorrectionRefused
        When the measurement asks for E more than ``max_factor`` times off the plan's.
    """
    log_e0 = math.log(cable.youngs_modulus)
    log_e = log_e0
    model = cable
    chain = SpringChain.from_cable(model, gravity)
    eq = _solve(model, measured if guess is None else guess, clips, gravity, chain)
    residual0 = float(np.mean(np.linalg.norm(eq.shape - measured, axis=1)))
    taken, directions, log_sd, note = 0, [], math.inf, ""
    grip = grip and discretization
    grip_sd, grip_note = math.inf, ("" if grip else "not estimated")
    shift, offset_sd, offset_spread, offset_note = np.zeros(3), math.inf, 0.0, "not estimated"
    if offset:
        offset, sds = measured_offset(measured - eq.shape)
        shift, offset_sd, offset_spread, offset_note = offset_verdict(
            offset, offset_covariance(sds, clips.u_axes, noise))
        measured = measured - shift  # what the fit explains: the cable, not the camera
    fine = _RefinedStart(eq.shape, resampled(eq.shape, 2 * cable.n_links + 1))
    prior = alpha_prior(cable.n_links, measured_links)
    alpha_sd, taken_correlation = math.inf, 0.0
    limit = math.log(max_factor)
    budget = steps + math.ceil(limit / MAX_LOG_STEP) + 1 if steps > 0 else int(not modulus)
    full = 0
    for _ in range(budget):
        sens = equilibrium_sensitivity(model, eq.shape, clips, chain=chain)
        directions = _directions(model, eq.shape, clips, discretization, grip, gravity, fine)
        residual = measured - eq.shape
        jacobian = sens.log_modulus if modulus else np.zeros_like(residual)  # known: no column
        step, amplitudes, sds, correlation = fit_with_covariance(jacobian, directions, residual,
                                                                 prior)
        if modulus and float(np.sum(sens.log_modulus**2)) <= 1e-24 * cable.length**2:
            note = "the measured shape does not depend on E here (no sag): E kept"
            break
        if taken == 0:
            if grip:
                grip, grip_sd, grip_note = _grip_verdict(amplitudes[1], sds[2], model)
                if not grip:  # the clamp length stays the model's: refit without it
                    directions = directions[:1]
                    step, amplitudes, sds, correlation = fit_with_covariance(
                        jacobian, directions, residual, prior)
            log_sd = float(sds[0])
            alpha_sd = float(sds[1]) if directions else math.inf
            taken_correlation = correlation
            if not modulus:  # known: the amplitudes below are fitted at the model's E
                break
            if log_sd > MAX_LOG_SD:
                note = (f"the measurement does not inform E: sd(ln E) = {log_sd:.3g}, more "
                        f"than a factor {math.exp(MAX_LOG_SD):g}: E kept")
                break
            if not abs(step) >= SIGNIFICANCE * log_sd:
                note = (f"the measurement does not inform E: it asks for a change of "
                        f"{100 * math.expm1(step):+.1f} % with sd(ln E) = {log_sd:.3g} (less "
                        f"than {SIGNIFICANCE:g} sd): E kept")
                break
        clipped = trust_region_step(step, log_e, log_e0, log_sd, max_factor)
        if clipped is None:  # on the limit already, asked for a little more
            note = (f"the measurement asks for E = {math.exp(log_e + step):.3g} Pa, beyond "
                    f"{max_factor:g} times the plan's by less than {SIGNIFICANCE:g} "
                    "sd(ln E): E held at the limit")
            break
        log_e += clipped
        model = cable.with_modulus(math.exp(log_e))
        chain = SpringChain.from_cable(model, gravity)
        guess = sens.predict(delta_log_modulus=clipped)
        eq = _resolve(model, guess, clips, gravity, chain) or _solve(model, guess, clips, gravity,
                                                                     chain)
        taken += 1
        full += clipped == step
        if abs(clipped) < MODULUS_STEP_TOLERANCE or full >= steps:
            break
    alpha = beta = 0.0
    if directions:  # the amplitudes at the final E (the directions barely moved with it)
        directions = _directions(model, eq.shape, clips, True, grip, gravity, fine)
        amplitudes = fit_model_error(np.zeros_like(eq.shape), directions, measured - eq.shape,
                                     prior)[1]
        alpha = float(amplitudes[0])
        beta = float(amplitudes[1]) if grip else 0.0
    bias = sum((c * d for c, d in zip(amplitudes, directions, strict=True)), 0.0) \
        if directions else 0.0
    residual = float(np.mean(np.linalg.norm(eq.shape + bias - measured, axis=1)))
    return ModelUpdate(cable.youngs_modulus, model.youngs_modulus, residual0, residual,
                       taken, eq.shape, alpha, log_sd, note, beta, grip_sd, grip_note, shift,
                       offset_sd, offset_spread, offset_note, alpha_sd,
                       taken_correlation if directions else 0.0,
                       0.5 * limit if limit > 0 else math.inf)


def trust_region_step(step: float, log_e: float, log_e0: float, log_sd: float,
                      max_factor: float) -> float | None:
    """The log E step :func:`update_modulus` takes from ln E = ``log_e`` when the fit asks for
    ``step``: at most :data:`MAX_LOG_STEP` (a trust region, E x2 per step), and cut to end on
    the limit ``max_factor`` times the plan's E (ln E = ``log_e0``) when it would leave it.

    Returns
    -------
    float or None
        The step, or None when E is on the limit already and the measurement asks for more by
        less than :data:`SIGNIFICANCE` sd(ln E) (E held there).

    Raises
    ------
    CorrectionRefused
        When E is on the limit and the measurement asks for more by over :data:`SIGNIFICANCE`
        sd(ln E).
    """
    limit = math.log(max_factor)
    clipped = max(-MAX_LOG_STEP, min(MAX_LOG_STEP, step))
    room = limit - math.copysign(1.0, clipped) * (log_e - log_e0)  # to the limit, this side
    if abs(clipped) <= room:
        return clipped
    if room > MODULUS_STEP_TOLERANCE:  # the step would leave the limit: stop on it
        return math.copysign(room, clipped)
    if abs(log_e + step - log_e0) - limit > SIGNIFICANCE * log_sd:
        raise CorrectionRefused(
            f"modulus: the measurement asks for E = {math.exp(log_e + step):.3g} Pa, more than "
            f"{max_factor:g} times off the plan's {math.exp(log_e0):.3g} Pa by over "
            f"{SIGNIFICANCE:g} sd(ln E) = {SIGNIFICANCE * log_sd:.2g} (limit "
            "max_modulus_factor)")
    return None


def fit_with_covariance(jacobian, directions, residual, prior):
    """(delta log E, amplitudes, sds, correlation): the fit (:func:`.model_error.
    fit_model_error`, alpha's ``prior``), the sds of (delta, amplitudes) from the scatter it
    leaves and the correlation of ln E and alpha (:func:`.model_error.parameter_covariance`;
    0 without alpha, or where either sd is 0 or infinite)."""
    step, amplitudes = fit_model_error(jacobian, directions, residual, prior)
    covariance = parameter_covariance(
        jacobian, directions, _left(residual, jacobian, step, directions, amplitudes), prior)
    sds = standard_deviations(covariance)
    correlation = 0.0
    if len(sds) > 1 and all(0.0 < sds[k] < math.inf for k in (0, 1)):
        correlation = float(np.clip(covariance[0, 1] / (sds[0] * sds[1]), -1.0, 1.0))
    return step, amplitudes, sds, correlation


def offset_verdict(offset, covariance) -> tuple[np.ndarray, float, float, str]:
    """The offset applied (zeros when the measurement does not tell it), the sd of its length,
    its share of the interval and a note; its score is sqrt(o^T C^-1 o) with the covariance C
    (:func:`.model_error.offset_covariance`)."""
    size, sd = float(np.linalg.norm(offset)), math.sqrt(float(np.trace(covariance)))
    try:
        score = math.sqrt(float(offset @ np.linalg.solve(covariance, offset)))
    except np.linalg.LinAlgError:  # no scatter, no noise: any offset is told
        score = math.inf
    shown = ", ".join(f"{1e3 * v:+.1f}" for v in offset)
    if score >= OFFSET_SIGNIFICANCE:
        return offset, sd, 0.0, (f"measured shape offset by ({shown}) mm, sd {1e3 * sd:.1f} "
                                 "mm: taken out of the measurement")
    return np.zeros(3), sd, size + 2.0 * sd, (
        f"the measurement does not tell an offset (({shown}) mm with sd {1e3 * sd:.1f} mm): "
        f"not applied, its size and 2 sd, {1e3 * (size + 2.0 * sd):.1f} mm, in the interval")


@dataclass(eq=False)
class _RefinedStart:
    """Where the modulus fit's refined solves start (:func:`update_modulus`): the refined
    chain's last equilibrium (clamped over 2 links, ``fine`` (2 n + 1, 3) [m], kept up to date
    by :func:`.model_error.model_error_directions`) and the model's equilibrium it was solved
    at, ``shape`` (n + 1, 3) [m].

    The next solve, at the next E, starts from it moved as the model's points moved (both
    resampled onto the refined points): the departure R[x_2n] - R[x_n] carried over, not the
    previous E's sag (from that, 18 Newton iterations after the first step of E x1.5 at
    n = 100 instead of 4).
    """

    shape: np.ndarray
    fine: np.ndarray

    def at(self, shape: np.ndarray) -> np.ndarray:
        """The start for the model's equilibrium ``shape`` (n + 1, 3) [m], (2 n + 1, 3)."""
        if shape is not self.shape:
            self.fine += resampled(shape, len(self.fine)) - resampled(self.shape, len(self.fine))
            self.shape = shape
        return self.fine


def _directions(cable, shape, clips, discretization, grip, gravity, fine: _RefinedStart
                ) -> list:
    """The error directions fitted with E: none, [d] or [d, g] (:mod:`.model_error`), the
    refined solves started from ``fine``."""
    if not discretization:
        return []
    d, g = model_error_directions(cable, shape, clips, grip=grip, gravity=gravity,
                                  fine_guess=fine.at(shape))
    return [d] if g is None else [d, g]


def _left(residual, jacobian, step, directions, amplitudes) -> np.ndarray:
    """What the fit (delta log E, amplitudes) leaves of ``residual``."""
    return residual - step * jacobian - sum(
        (c * d for c, d in zip(amplitudes, directions, strict=True)), np.zeros_like(residual))


def _grip_verdict(beta: float, sd: float, cable: Cable) -> tuple[bool, float, str]:
    """Whether the measurement tells the clamp length: ``(estimated, sd(beta), note)``."""
    clamp = 1e3 * cable.rest_link_length
    if abs(beta) >= SIGNIFICANCE * sd and abs(beta) < MAX_GRIP:
        return True, sd, (f"clamp length {clamp * (1 + beta / 2):.1f} mm (the model's "
                          f"{clamp:.1f} mm, sd {clamp * sd / 2:.1f} mm)")
    why = (f"at the bound of half a link ({beta:+.2f})" if abs(beta) >= MAX_GRIP else
           f"{clamp * beta / 2:+.1f} mm from the model's with sd {clamp * sd / 2:.1f} mm")
    return False, math.inf, (f"the measurement does not tell the clamp length ({why}): the "
                             f"model's {clamp:.1f} mm kept, its uncertainty in the interval")


@dataclass(frozen=True, eq=False)
class Held:
    """A stable equilibrium of the model: its shape (n + 1, 3) [m] and the clip poses."""

    shape: np.ndarray
    clips: ClipPoses


FIT_LINKS = 60
"""About this many links of the chain the clips are fitted on (:class:`FitModel`): the multiple
k n of the plan's n nearest to it (60 at n = 12 and 20; n itself for n > 40). The plan's
n = 20 chain plus the measured bias predicts a 100-link cable's target to 0.02-0.04 mm, which
decides the last tens of a percent where the floor is a tenth of a millimetre (the U demo, E
told, seeds 1-6: 1.17 times the floor on average on the plan's chain, 1.08 on 60 links, 1.04 on
100 -- the chain plant's own discretization, so not the choice; docs/correction.md). The warm
correction stays under 20 ms (11.8 ms at n = 20, 10.2 on the plan's chain)."""


def fit_links_for(n_links: int, fit_links: int | None = None) -> int:
    """The links of the chain the clips are fitted on, a multiple of the plan's ``n_links``.

    Parameters
    ----------
    n_links : int
        The plan's n.
    fit_links : int, optional
        Asked for: a multiple of n (n: the plan's own chain); None: the multiple nearest to
        :data:`FIT_LINKS` (at least n).

    Raises
    ------
    ValueError
        For a ``fit_links`` that is not a positive multiple of n (named).
    """
    if fit_links is None:
        return n_links * max(1, round(FIT_LINKS / n_links))
    if isinstance(fit_links, bool) or int(fit_links) != fit_links or fit_links < n_links \
            or int(fit_links) % n_links:
        raise ValueError(f"fit_links: got {fit_links!r}, expected a multiple of the plan's "
                         f"n = {n_links} (n: fit on the plan's own chain)")
    return int(fit_links)


@dataclass(frozen=True, eq=False)
class FitModel:
    """The chain the clips are fitted on: the (updated) model cable on k n links, each gripper
    clamping k of them -- the plan's grip, L / n, straight along the clip's axis.

    The chain converges to the rod at first order in 1 / n (:mod:`.model_error`), so the finer
    chain resolves the share alpha_k = 2 (1 - 1 / k) of the plan's discretization error d
    (:func:`.model_error.alpha_prior` of n against k n links), and only alpha - alpha_k of the
    measured amplitude is left to carry as a bias: its second-order error, which decides where
    the floor is a tenth of the noise, shrinks with it.

    Attributes
    ----------
    cable : Cable
        The model cable on k n links.
    chain : SpringChain
        Its chain under gravity.
    clamp_links : int
        k, links held by each gripper (1: the plan's own chain, the bias carried whole).
    share : float
        alpha_k, the first-order share of d the chain resolves (0 for k = 1).
    """

    cable: Cable
    chain: SpringChain
    clamp_links: int
    share: float

    @classmethod
    def of(cls, model: Cable, links: int, gravity=GRAVITY) -> FitModel:
        """The fit model of ``model`` (n links) on ``links`` = k n links."""
        fine = model.with_links(links)
        return cls(fine, SpringChain.from_cable(fine, gravity), links // model.n_links,
                   alpha_prior(model.n_links, links)[0])

    def hold(self, shape: np.ndarray, clips: ClipPoses, gravity=GRAVITY) -> Held:
        """Its equilibrium at ``clips`` from the plan's model's ``shape`` (n + 1, 3), whose
        points are every k-th of the refined chain's (the links between interpolated)."""
        n_links = len(shape) - 1
        index = np.arange(self.cable.n_points) / self.clamp_links
        guess = np.stack([np.interp(index, np.arange(n_links + 1), shape[:, i])
                          for i in range(3)], axis=1)
        held = _resolve(self.cable, guess, clips, gravity, self.chain, self.clamp_links)
        if held is None:
            raise CorrectionRefused(f"model: the clip fit's chain (n = {self.cable.n_links}, "
                                    f"clamping {self.clamp_links} links) finds no stable "
                                    "equilibrium at these clip poses")
        return held

    def bias(self, update: ModelUpdate, cable: Cable, shape: np.ndarray, clips: ClipPoses,
             gravity=GRAVITY) -> np.ndarray:
        """What this chain leaves of the measured model error: (alpha - alpha_k) d + beta g at
        ``clips`` (n + 1, 3) [m] (:meth:`ModelUpdate.bias` of the plan's ``cable`` at its
        equilibrium ``shape``, less the share the chain resolves)."""
        left = replace(update, discretization=update.discretization - self.share)
        return left.bias(cable, shape, clips, gravity)

    def predict(self, update: ModelUpdate, cable: Cable, shape: np.ndarray, clips: ClipPoses,
                gravity=GRAVITY) -> np.ndarray:
        """The cable's predicted shape at ``clips`` (n + 1, 3) [m]: the chain's equilibrium at
        the plan's model's points plus :meth:`bias` (``shape``: the plan's model's equilibrium
        there)."""
        held = self.hold(shape, clips, gravity)
        return held.shape[:: self.clamp_links] + self.bias(update, cable, shape, clips, gravity)


def _resolve(cable: Cable, guess: np.ndarray, clips: ClipPoses, gravity,
             chain: SpringChain, clamp_links: int = 1) -> Held | None:
    """The equilibrium from a warm start already fitting ``clips`` (a linear prediction).

    The Newton solve alone (:func:`.model_error.clamped_equilibrium`, each gripper clamping
    ``clamp_links`` links), without the guess conforming and the clip reactions of
    :func:`dloplan.sim.equilibrium`; None when it does not converge or the clips are out of
    the cable's reach.
    """
    k = clamp_links
    x, converged, _ = clamped_equilibrium(cable, guess, clips, k, gravity=gravity, chain=chain)
    reach = (cable.n_links - 2 * k) * cable.rest_link_length
    if not converged or np.linalg.norm(x[-k - 1] - x[k]) > reach:
        return None
    return Held(x, clips)


def _solve(cable: Cable, guess, clips: ClipPoses, gravity, chain=None):
    eq = equilibrium(cable, guess, clips, gravity=gravity, chain=chain)
    if not eq.success:
        raise CorrectionRefused(f"model: no stable equilibrium of the cable (E = "
                                f"{cable.youngs_modulus:.3g} Pa) at these clip poses "
                                f"({eq.message})")
    return eq


def fit_clips(cable: Cable, clips: ClipPoses, reference: np.ndarray, guess: np.ndarray, *,
              start=None, limits: CorrectionLimits = CorrectionLimits(), gravity=GRAVITY,
              chain: SpringChain | None = None):
    """Levenberg-Marquardt on the 12 clip coordinates: the equilibrium closest to ``reference``.

    Parameters
    ----------
    cable : Cable
        The (updated) model cable.
    clips : ClipPoses
        The planned clip poses of this shape.
    reference : numpy.ndarray
        (n + 1, 3) the shape wanted [m].
    guess : numpy.ndarray
        (n + 1, 3) a starting shape on the right branch [m].
    start : array_like, optional
        (12,) initial correction (default zero).
    limits : CorrectionLimits
        Iterations and bounds: the correction is held within them (each trial projected onto
        them).

    Returns
    -------
    tuple
        ``(correction (12,), equilibrium, iterations)``.
    """
    if chain is None:
        chain = SpringChain.from_cable(cable, gravity)
    p = np.zeros(12) if start is None else np.asarray(start, dtype=float).copy()
    eq = _solve(cable, guess, perturbed_clips(clips, p), gravity, chain)
    return _levenberg_marquardt(cable, clips, reference, eq, p, limits, gravity, chain)


CLIP_DAMPING = Damping(initial=1e-3, start=1e-9, increase=8.0, decrease=4.0, minimum=1e-9,
                       good=0.0, poor=0.0)
"""The clip fit's damping (:class:`dloplan.least_squares.Damping`): mu diag(J^T J) from 1e-3,
four times smaller after every accepted step (down to 1e-9), eight times larger after a
rejected one."""

MAX_TRIALS = 10
"""Trials per Levenberg-Marquardt iteration of the clip fit before it stops."""


@dataclass(frozen=True, eq=False)
class _ClipSystem:
    """One Levenberg-Marquardt iteration of the clip fit: J^T J, J^T r in the scaled
    coordinates z = scale p, and the sensitivity for the trials' warm start."""

    a: np.ndarray
    b: np.ndarray
    scale: np.ndarray
    sens: object

    def solve(self, shift: float) -> np.ndarray:
        damped = self.a + shift * np.diag(np.diag(self.a)) + 1e-12 * np.trace(self.a) * np.eye(12)
        return -np.linalg.solve(damped, self.b) / self.scale

    def predicted(self, step, shift: float) -> None:
        return None  # every trial is an exact equilibrium: accepted when the cost does not rise


def _levenberg_marquardt(cable: Cable, clips: ClipPoses, reference: np.ndarray, eq, p: np.ndarray,
                         limits: CorrectionLimits, gravity, chain: SpringChain,
                         clamp_links: int = 1):
    """:func:`fit_clips` from ``eq``, the equilibrium already solved at ``clips`` + ``p``, by
    the shared damped least-squares loop (:func:`dloplan.least_squares.damped_minimize`): the
    system is J^T J with the Jacobian of the equilibrium, each trial an exact equilibrium
    warm-started from the linear prediction. On a refined chain (each gripper clamping
    ``clamp_links`` = k links, :class:`FitModel`) its every k-th point, the material point of
    the reference's, is compared with ``reference``."""
    scale = np.tile(np.r_[np.ones(3), np.full(3, 0.5 * cable.length)], 2)  # z = scale * p
    k = clamp_links

    def residual(held):
        return (held.shape[::k] - reference).ravel()

    def linearize(state):
        held, _ = state
        sens = equilibrium_sensitivity(cable, held.shape, held.clips, chain=chain,
                                       clamp_links=k)
        jz = sens.clips[::k].reshape(-1, 12) / scale
        return _ClipSystem(jz.T @ jz, jz.T @ residual(held), scale, sens)

    def evaluate(state, step, system):
        held, p_now = state
        step = within_limits(p_now + step, limits) - p_now  # projected onto the limits
        trial = _resolve(cable, system.sens.predict(step), perturbed_clips(clips, p_now + step),
                         gravity, chain, k)
        if trial is None:
            return None
        r = residual(trial)
        return (trial, p_now + step), float(r @ r)

    r = residual(eq)
    run = damped_minimize((eq, p), float(r @ r), linearize, evaluate, CLIP_DAMPING,
                          max_iterations=limits.iterations, max_trials=MAX_TRIALS,
                          stop_gain=COST_TOLERANCE)
    eq, p = run.state
    return p, eq, run.iterations


def within_limits(p: np.ndarray, limits: CorrectionLimits) -> np.ndarray:
    """The clip correction p (12,) with each clip's translation and rotation vector shortened
    to ``limits.max_translation`` / ``max_rotation`` (the projection onto the limits)."""
    out = np.array(p, dtype=float)
    for start, bound in ((0, limits.max_translation), (3, limits.max_rotation),
                         (6, limits.max_translation), (9, limits.max_rotation)):
        norm = float(np.linalg.norm(out[start : start + 3]))
        if norm > bound:
            out[start : start + 3] *= bound / norm
    return out


def _held_at_limits(p: np.ndarray, limits: CorrectionLimits) -> str:
    """A warning when a clip's correction is on the limits (the fit asked for more), else ""."""
    held = []
    for clip, name in enumerate(("first", "last")):
        move = float(np.linalg.norm(p[6 * clip : 6 * clip + 3]))
        turn = float(np.linalg.norm(p[6 * clip + 3 : 6 * clip + 6]))
        if move >= (1 - 1e-6) * limits.max_translation or \
                turn >= (1 - 1e-6) * limits.max_rotation:
            held.append(f"the {name} clip's ({1e3 * move:.1f} mm, "
                        f"{math.degrees(turn):.1f} degrees)")
    if not held:
        return ""
    return (f"correction: {' and '.join(held)} held at the limits "
            f"{1e3 * limits.max_translation:.0f} mm / {math.degrees(limits.max_rotation):.0f} "
            "degrees (limits.max_translation / max_rotation): the fit asks for more, the best "
            "correction within them is used")


def correct_plan(
    cable: Cable,
    shapes,
    grippers: GripperPath,
    at: int,
    measured,
    *,
    stabilized=None,
    trajectory: Trajectory | None = None,
    reference: str = "stabilized",
    mode: str = "target",
    modulus_steps: int = 3,
    model_error: str = "discretization",
    grip: str = "estimate",
    offset: str = "estimate",
    modulus: str = "estimate",
    limits: CorrectionLimits = CorrectionLimits(),
    gravity=GRAVITY,
    predict: bool = True,
    measured_links: int | None = None,
    fit_links: int | None = None,
) -> Correction:
    """Correct the rest of a plan from the shape measured at shape ``at`` (module docstring).

    Parameters
    ----------
    cable : Cable
        The plan's model cable.
    shapes : array_like
        (T + 1, n + 1, 3) planned shapes [m].
    grippers : GripperPath
        The plan's clip poses, one per shape.
    at : int
        K, the index of the shape just reached (0 <= K < T).
    measured : array_like
        (k, 3) measured points along the cable, first clip's end first, in the plan's frame [m].
    stabilized : array_like, optional
        (T + 1, n + 1, 3) the plan's stabilized shapes [m]; computed when not given (each
        planned shape settled under its clips).
    trajectory : Trajectory, optional
        The plan's trajectory: its speed limits, arm assignment and tool frame are kept.
    reference : {"stabilized", "planned"}
        What the remaining shapes should look like: the plan's stabilized shapes (default, what
        the verified plan promised) or its planned shapes.
    mode : {"target", "all"}
        Fit the target's clips and ramp the correction in (default), or fit every remaining
        shape.
    modulus_steps : int
        Gauss-Newton steps of the log E update (0: keep E).
    model_error : {"discretization", "modulus"}
        What the measurement identifies: E and the amplitude of the discretization error,
        carried as a bias onto the remaining shapes (default, :mod:`.model_error`), or E only.
    grip : {"estimate", "model", "known"}
        With ``model_error="discretization"``: estimate the clamp length (where the gripper's
        jaws end on the cable) with E and the bias when the measurement tells it, else keep the
        model's with its uncertainty in the interval (default); or always keep the model's,
        with its uncertainty (``model``) or as known exactly (``known``: the gripper clamps
        the model's L / n, calibrated).
    offset : {"estimate", "none"}
        The measurement's offset (a rigid translation of the measured points, e.g. a camera's
        calibration error): estimated with E when the measurement tells it and taken out of
        the comparison, else its size in the interval (default); or taken as zero.
    modulus : {"estimate", "known"}
        Young's modulus: estimated when the measurement tells it (default), or known to be the
        plan's (identified beforehand: kept, no uncertainty in the interval; the bias, clamp
        length and offset are still estimated), :data:`MODULI`.
    limits : CorrectionLimits
        Bounds beyond which the correction is refused.
    gravity : array_like
        Gravity [m/s^2].
    predict : bool
        Also time the whole corrected path and predict the remaining shapes open loop and
        corrected, with the interval (default); False stops when the remaining motion is ready
        (a correction service's fast answer, without the gain check below).
    measured_links : int, optional
        The measured cable's own discretization (a simulated plant's links or edges): the
        centre of the prior on the discretization bias (:func:`.model_error.alpha_prior`);
        None (default): a real cable, the continuum.
    fit_links : int, optional
        The links of the chain the clips are fitted on (:class:`FitModel`): a multiple k n of
        the plan's n, each gripper clamping k of them, the bias's share that chain resolves
        taken off (n: the plan's own chain); None (default): the multiple nearest to
        :data:`FIT_LINKS`. The corrected plan's shapes stay the plan's model's equilibria.
        With ``model_error="modulus"`` the clips are fitted on the plan's chain (E alone
        stands for its discretization error there).

    Raises
    ------
    CorrectionRefused
        For a measurement that disagrees wildly or a correction beyond the limits (the reason),
        and, with ``predict``, for a correction whose predicted gain (open loop minus
        corrected final error) is within :data:`SIGNIFICANCE` sd of zero, linearized in the
        sds of E, the discretization bias and the clamp length (:func:`_gain_sd`), or is lost
        with the clamp length :data:`SIGNIFICANCE` sd off, evaluated
        (:func:`_gain_at_clamp_bounds`): the plan is kept.
    ValueError
        For inconsistent inputs (named).
    """
    t0, cpu0 = time.perf_counter(), time.thread_time()
    path = as_path(shapes, cable.n_points, "shapes")
    last = len(path) - 1
    if not isinstance(grippers, GripperPath) or grippers.n_shapes != len(path):
        raise ValueError(f"grippers: expected a GripperPath of {len(path)} shapes (one per shape)")
    if isinstance(at, bool) or int(at) != at or not 0 <= at < last:
        raise ValueError(f"at: got {at!r}, expected the index of a shape 0 .. {last - 1} "
                         "(not the target: nothing is left to correct there)")
    at = int(at)
    if reference not in REFERENCES:
        raise ValueError(f"reference: got {reference!r}, expected one of {REFERENCES}")
    if mode not in MODES:
        raise ValueError(f"mode: got {mode!r}, expected one of {MODES}")
    if model_error not in MODEL_ERRORS:
        raise ValueError(f"model_error: got {model_error!r}, expected one of {MODEL_ERRORS}")
    if grip not in GRIPS:
        raise ValueError(f"grip: got {grip!r}, expected one of {GRIPS}")
    if offset not in OFFSETS:
        raise ValueError(f"offset: got {offset!r}, expected one of {OFFSETS}")
    if modulus not in MODULI:
        raise ValueError(f"modulus: got {modulus!r}, expected one of {MODULI}")
    if isinstance(modulus_steps, bool) or int(modulus_steps) != modulus_steps or modulus_steps < 0:
        raise ValueError(f"modulus_steps: got {modulus_steps!r}, expected an integer >= 0")
    fit_links = fit_links_for(cable.n_links, fit_links)
    clips = [grippers.clip_poses(j) if j >= at else None  # shapes 0 .. K - 1 have run
             for j in range(len(path))]
    chain = SpringChain.from_cable(cable, gravity)
    if stabilized is None:
        settled = {j: _solve(cable, path[j], clips[j], gravity, chain).shape
                   for j in range(at, len(path))}
        stable = np.stack([settled.get(j, path[j]) for j in range(len(path))])
    else:
        stable = as_path(stabilized, cable.n_points, "stabilized")
        if len(stable) != len(path):
            raise ValueError(f"stabilized: {len(stable)} shapes, expected {len(path)}")
    wanted = (stable if reference == "stabilized" else path)[at + 1 :]
    y = resample_measured(measured, stable[at], cable.length,
                          max_disagreement=limits.max_disagreement)
    noise = noise_sd(measured, y) if offset == "estimate" else 0.0
    update = update_modulus(cable, y, clips[at], steps=modulus_steps,
                            max_factor=limits.max_modulus_factor, gravity=gravity,
                            guess=stable[at], discretization=model_error == "discretization",
                            grip=grip == "estimate", offset=offset == "estimate",
                            measured_links=measured_links, modulus=modulus == "estimate",
                            noise=noise)
    if grip == "known":
        update = replace(update, grip_sd=0.0, grip_note=(
            f"clamp length known: the model's {1e3 * cable.rest_link_length:.1f} mm"))
    model = cable.with_modulus(update.youngs_modulus)
    model_chain = SpringChain.from_cable(model, gravity)
    fit = (FitModel.of(model, fit_links, gravity)
           if fit_links > cable.n_links and model_error == "discretization" else None)
    # the plan's stabilized target carried to the updated E to first order: the fit's start
    try:
        target_guess = equilibrium_sensitivity(cable, stable[-1], clips[-1], chain=chain).predict(
            delta_log_modulus=math.log(update.youngs_modulus / cable.youngs_modulus))
    except ValueError:  # not a stable equilibrium of the model: start from it as it is
        target_guess = stable[-1]
    remaining = clips[at + 1 :]
    iterations = 0
    if mode == "target":  # fit the target from the plan's stabilized target, ramp it in
        target_fit = _fit_with_bias(model, remaining[-1], wanted[-1], target_guess, update,
                                    limits=limits, gravity=gravity, chain=model_chain, fit=fit,
                                    state=False)
        iterations = target_fit.iterations
        ramp = np.arange(1, len(remaining) + 1) / len(remaining)
        corrections = ramp[:, None] * target_fit.correction[None, :]
    else:  # fit every remaining shape, each from the previous one
        corrections, fitted = [], []
        x, p = update.state, np.zeros(12)
        for c, ref in zip(remaining, wanted, strict=True):
            target_fit = _fit_with_bias(model, c, ref, x, update, start=p, limits=limits,
                                        gravity=gravity, chain=model_chain, fit=fit)  # last: T's
            p, x = target_fit.correction, target_fit.state.shape
            iterations += target_fit.iterations
            corrections.append(p)
            fitted.append(x)
        corrections = np.array(corrections)
    corrected_clips = [perturbed_clips(c, p) for c, p in zip(remaining, corrections, strict=True)]
    new_grippers = _corrected_grippers(grippers, at, corrected_clips)
    timing = _timing(trajectory, grippers)
    now = trajectory_from_grippers(sliced_grippers(new_grippers, at), **timing)
    seconds = time.perf_counter() - t0  # the robot can go on: the rest is for the record
    cpu_seconds = time.thread_time() - cpu0
    warnings = [f"modulus: {update.note}"] if update.note else []
    held = _held_at_limits(np.asarray(corrections)[-1] if mode == "target" else
                           np.asarray(corrections)[np.argmax(np.abs(corrections).sum(axis=1))],
                           limits)
    if held:
        warnings.append(held)
    if update.residual_after > 0.5 * update.residual_before and update.residual_before > 0:
        what, other = (("E and the discretization bias", "rest shape, grip, measurement noise")
                       if model_error == "discretization" else
                       ("E", "rest shape, grip, discretization, measurement noise"))
        warnings.append(
            f"model: {what} explain little of the measured error "
            f"({1e3 * update.residual_before:.1f} -> {1e3 * update.residual_after:.1f} mm): "
            f"another cause ({other}) dominates"
        )
    common = dict(at=at, measured=y, model=update, cable=model, reference=np.asarray(wanted),
                  clip_corrections=np.asarray(corrections), grippers=new_grippers,
                  remaining=now, mode=mode, reference_kind=reference, model_error=model_error,
                  iterations=iterations, seconds=seconds, cpu_seconds=cpu_seconds,
                  warnings=tuple(warnings),
                  fit_links=cable.n_links if fit is None else fit.cable.n_links)
    if not predict:
        return Correction(open_loop=None, corrected=None, equilibria=None, uncertainty={},
                          trajectory=None, prediction_seconds=0.0, **common)
    new_trajectory = trajectory_from_grippers(new_grippers, **timing)
    # the predictions of the updated model from the measured state: planned vs corrected clips;
    # the open loop's target is where mode "target"'s clip fit started (the planned clips), the
    # corrected target's equilibrium where it ended (its clips are p_T's, exactly; on the plan's
    # chain its state, on a refined one the fit chain's, held)
    if mode == "target":
        open_states = _continue(model, update.state, remaining[:-1], gravity, model_chain,
                                stable[at:-1])
        open_target = target_fit.start
        ended = [] if target_fit.state is None else [target_fit.state.shape]
        equilibria = np.concatenate([
            _continue(model, update.state, corrected_clips[: len(corrected_clips) - len(ended)],
                      gravity, model_chain, stable[at : len(stable) - len(ended)]),
            np.reshape(ended, (-1, *update.state.shape))])
    else:
        open_states = _continue(model, update.state, remaining, gravity, model_chain,
                                stable[at:])
        x, c = open_states[-1], remaining[-1]
        open_target = (x + update.bias(model, x, c, gravity) if fit is None else
                       fit.predict(update, model, x, c, gravity))
        open_states, equilibria = open_states[:-1], np.stack(fitted)
    open_loop = np.stack([*_biased(model, open_states, remaining[:-1], gravity, update),
                          open_target])
    corrected, directions = _corrected_target(model, equilibria[-1], corrected_clips[-1],
                                              gravity, update, fit, model_chain,
                                              target_fit.held)
    corrected = np.stack([*_biased(model, equilibria[:-1], corrected_clips[:-1], gravity,
                                   update), corrected])
    uncertainty = _uncertainty(directions, update)
    spread = check_gain(open_loop[-1], corrected[-1], wanted[-1], directions, update,
                        limits.gain_significance)
    if model_error == "discretization":
        _check_length(model, update, y, (clips[at], clips[-1]), target_guess,
                      (open_loop[-1], corrected[-1], wanted[-1]), directions,
                      alpha_prior(cable.n_links, measured_links), gravity,
                      limits.gain_significance * spread)
    return Correction(open_loop=open_loop, corrected=corrected, equilibria=equilibria,
                      uncertainty=uncertainty, trajectory=new_trajectory,
                      prediction_seconds=time.perf_counter() - t0 - seconds, **common)


def check_gain(open_loop: np.ndarray, corrected: np.ndarray, reference: np.ndarray,
               directions: dict, update: ModelUpdate, significance: float) -> float:
    """The gain checks of :func:`correct_plan`: the predicted gain (the open loop's final
    error minus the corrected one's) must exceed ``significance`` sd of it (:func:`_gain_sd`)
    and stay positive with the clamp length ``significance`` sd off, evaluated
    (:func:`_gain_at_clamp_bounds`).

    Parameters
    ----------
    open_loop, corrected : numpy.ndarray
        (n + 1, 3) the target's predictions at the planned and the corrected clips, the bias
        included [m].
    reference : numpy.ndarray
        (n + 1, 3) the shape aimed at [m].
    directions : dict
        The target's responses to ln E, alpha and beta (:func:`_target_directions`), each
        (n + 1, 3) [m].
    update : ModelUpdate
        The estimates and their sds.
    significance : float
        :attr:`CorrectionLimits.gain_significance`.

    Returns
    -------
    float
        The gain's sd [m] (:func:`.length.check_length` holds the length's gain to it).

    Raises
    ------
    CorrectionRefused
        When either check fails (the gains in the message): the plan is kept.
    """
    before, after = (float(_mean_distance(x, reference)) for x in (open_loop, corrected))
    spread = _gain_sd(open_loop, corrected, reference, directions, update)
    if before - after <= significance * spread:
        raise CorrectionRefused(gain_refusal(before, after, spread, significance))
    worst, which = _gain_at_clamp_bounds(open_loop, corrected, reference, directions, update,
                                         significance)
    if worst <= 0.0:
        raise CorrectionRefused(
            f"gain: the correction's predicted gain, {1e3 * (before - after):.2f} mm (final "
            f"error {1e3 * before:.2f} -> {1e3 * after:.2f} mm), is lost with the clamp length "
            f"{which} off ({1e3 * worst:+.2f} mm: the corrected final error above the open "
            "loop's): the plan is kept")
    return spread


def _check_length(model: Cable, update: ModelUpdate, measured: np.ndarray, clips: tuple,
                  target_guess: np.ndarray, predictions: tuple, directions: dict, prior,
                  gravity, needed: float) -> None:
    """:func:`.length.check_length` of a correction (:func:`correct_plan`): the updated
    ``model``'s d, g and l at shape K (``clips`` of K and of the target), the resampled
    ``measured`` shape less the offset applied, l at the target's planned clips from
    ``target_guess``; ``predictions`` the open loop's, the corrected and the reference target
    (n + 1, 3) [m]; ``needed`` the gain the first gain check asked for [m]."""
    d, g = model_error_directions(model, update.state, clips[0], grip=True, gravity=gravity)
    target = equilibrium(model, target_guess, clips[1], gravity=gravity)
    if not target.success:
        raise CorrectionRefused(f"length: the updated model finds no stable equilibrium at "
                                f"the target's clips ({target.message})")
    residual = measured - update.offset - update.state
    l_k = length_direction(model, update.state, clips[0], gravity)
    alternative = length_alternative(
        residual, d, g, l_k, update.discretization, update.grip,
        fit_model_error(np.zeros_like(residual), [d, l_k], residual, prior)[1])
    planned = model_error_directions(model, target.shape, clips[1], grip=True, gravity=gravity)
    check_length(*predictions, planned, directions, update.discretization, update.grip,
                 alternative, length_direction(model, target.shape, clips[1], gravity),
                 model.length, needed)


def gain_refusal(before: float, after: float, spread: float, significance: float) -> str:
    """The reason :func:`check_gain` gives for a predicted gain within ``significance`` sd of
    zero: the open loop's and the corrected predicted final errors ``before``, ``after`` and
    the gain's sd ``spread`` [m], printed in mm to two decimals."""
    return (f"gain: the correction's predicted gain, {1e3 * (before - after):.2f} mm (final "
            f"error {1e3 * before:.2f} -> {1e3 * after:.2f} mm), is within {significance:g} sd "
            f"of zero ({significance:g} sd = {1e3 * significance * spread:.2f} mm, sd "
            f"{1e3 * spread:.2f} mm from E, discretization bias, clamp length as estimated): "
            "the plan is kept")


def _fit_with_bias(cable: Cable, clips: ClipPoses, reference: np.ndarray, guess: np.ndarray,
                   update: ModelUpdate, *, start=None, limits: CorrectionLimits, gravity,
                   chain: SpringChain, fit: FitModel | None = None, state: bool = True):
    """:func:`fit_clips` of x_n + alpha d + beta g (:meth:`ModelUpdate.bias`) to ``reference``,
    or, on a refined ``fit`` model (:class:`FitModel`), of R[x_kn] + (alpha - alpha_k) d + beta g.

    The bias is evaluated at the planned clips (plus ``start``), the clips fitted to reference
    - bias, then the bias re-evaluated at the corrected clips and the fit repeated from there
    (d moves with the clips: 1 mm on the demo's target for a 20 degree correction). The bias
    is always the plan's model's (d and g of its n links at its equilibrium); on the refined
    chain its first-order share of d, alpha_k = :attr:`FitModel.share`, is resolved by the
    chain itself and taken off alpha. Without ``state`` the plan's model's equilibrium at the
    corrected clips is not solved for after a fit on the refined chain (None; mode "target"
    keeps only the clips, and its predictions solve for it by continuation).

    Returns
    -------
    _ClipFit
        The correction, the plan's model's equilibrium at the corrected clips, the iterations,
        the refined chain's equilibrium there and the prediction at the clips it started from.
    """
    fine = fit is not None and fit.clamp_links > 1
    p = np.zeros(12) if start is None else np.asarray(start, dtype=float).copy()
    eq = _solve(cable, guess, perturbed_clips(clips, p), gravity, chain)
    if not fine and update.discretization == 0.0 and update.grip == 0.0:  # fit_clips
        p, fitted, iterations = _levenberg_marquardt(cable, clips, reference, eq, p, limits,
                                                     gravity, chain)
        return _ClipFit(p, fitted, iterations, None, eq.shape)
    iterations, first = 0, None
    if not fine:
        for _ in range(2):
            bias = update.bias(cable, eq.shape, eq.clips, gravity)
            first = eq.shape + bias if first is None else first
            p, eq, more = _levenberg_marquardt(cable, clips, reference - bias, eq, p, limits,
                                               gravity, chain)
            iterations += more
        return _ClipFit(p, eq, iterations, None, first)
    held = fit.hold(eq.shape, eq.clips, gravity)
    for last in (False, True):
        bias = fit.bias(update, cable, eq.shape, eq.clips, gravity)
        first = held.shape[:: fit.clamp_links] + bias if first is None else first
        p, held, more = _levenberg_marquardt(fit.cable, clips, reference - bias, held, p, limits,
                                             gravity, fit.chain, fit.clamp_links)
        iterations += more
        if last and not state:
            return _ClipFit(p, None, iterations, held, first)
        eq = _solve(cable, held.shape[:: fit.clamp_links], held.clips, gravity, chain)
    return _ClipFit(p, eq, iterations, held, first)


@dataclass(frozen=True, eq=False)
class _ClipFit:
    """What :func:`_fit_with_bias` found.

    Attributes
    ----------
    correction : numpy.ndarray
        (12,) the clip correction p.
    state : Equilibrium or Held or None
        The plan's model's equilibrium at the corrected clips (None when not solved for).
    iterations : int
        Levenberg-Marquardt iterations.
    held : Held or None
        The refined fit chain's equilibrium at the corrected clips (None without one).
    start : numpy.ndarray
        (n + 1, 3) the prediction at the clips the fit started from (the bias included, on the
        fit chain when there is one) [m]: the open loop's target prediction when it started
        from the planned clips.
    """

    correction: np.ndarray
    state: object
    iterations: int
    held: Held | None
    start: np.ndarray


def _continue(cable: Cable, state: np.ndarray, clips, gravity, chain: SpringChain,
              plan: np.ndarray) -> np.ndarray:
    """Quasi-static continuation from ``state`` along ``clips``: the equilibria
    (len(clips), n + 1, 3) [m].

    A predictor-corrector continuation whose predictor is the plan's own step: each solve
    (:func:`dloplan.sim.equilibrium`) starts from the previous equilibrium moved as the plan's
    stabilized shapes ``plan`` (len(clips) + 1, n + 1, 3; the first the state's) move between
    the two shapes, x_j-1 + (s_j - s_j-1), not from x_j-1 as it is (:func:`dloplan.sim.
    continuation`), and from the second step on by the change of the departure from the plan,
    delta_j = x_j - s_j, extrapolated linearly: s_j + delta_j-1 + (delta_j-1 - delta_j-2) (a
    secant predictor of the departure). The same equilibrium, to the solver's tolerance
    (docs/correction.md), in fewer Newton iterations (the sagging demo at n = 20: 65 instead of
    94 over its 8 steps with the plan's step; with the secant 59 -> 47 in mode "target", 49 ->
    37 at n = 100).
    """
    x, out, before = state, [], None
    for j, c in enumerate(clips):
        guess = x + (plan[j + 1] - plan[j])
        departure = x - plan[j]
        if before is not None:
            guess += departure - before
        before = departure
        eq = equilibrium(cable, guess, c, gravity=gravity, chain=chain)
        if not eq.success:
            raise CorrectionRefused(f"prediction: the model finds no stable equilibrium at the "
                                    f"remaining shape {j} ({eq.message})")
        x = eq.shape
        out.append(x)
    return np.array(out).reshape(-1, *np.shape(state))  # (0, n + 1, 3) for no clips


def _biased(cable: Cable, shapes, clips, gravity, update: ModelUpdate) -> list:
    """The predictions before the target: each of the equilibria ``shapes`` plus the bias at
    its ``clips`` (:meth:`ModelUpdate.bias`), (n + 1, 3) [m] each."""
    return [x + update.bias(cable, x, c, gravity) for x, c in zip(shapes, clips, strict=True)]


def _corrected_target(cable: Cable, x: np.ndarray, clips: ClipPoses, gravity,
                      update: ModelUpdate, fit: FitModel | None, chain: SpringChain,
                      held: Held | None) -> tuple[np.ndarray, dict]:
    """The corrected target's prediction (n + 1, 3) [m] as the clips were fitted -- on the
    ``fit`` model when there is one (its equilibrium at these clips, ``held``: the clip fit's
    last), less the share of d it resolves -- and the target's responses
    (:func:`_target_directions` at the model's equilibrium ``x``), which give its bias alpha d
    + beta g (the same solves)."""
    directions = _target_directions(cable, x, clips, gravity, chain)
    alpha = update.discretization - (0.0 if fit is None else fit.share)
    bias = alpha * directions["discretization"] + update.grip * directions["grip"]
    if fit is not None:
        x = held.shape[:: fit.clamp_links]
    return x + bias, directions


def _target_directions(cable: Cable, shape: np.ndarray, clips: ClipPoses, gravity,
                       chain: SpringChain) -> dict:
    """The target's responses to the estimated quantities, each (n + 1, 3) [m] per unit:
    ``modulus`` d x / d ln E, ``discretization`` d, ``grip`` g (:mod:`.model_error`)."""
    d, grip = model_error_directions(cable, shape, clips, grip=True, gravity=gravity)
    jacobian = equilibrium_sensitivity(cable, shape, clips, chain=chain).log_modulus
    return {"modulus": jacobian, "discretization": d, "grip": grip}


def parameter_sds(update: ModelUpdate) -> dict:
    """sd of ln E, alpha and beta [half links] (0 where not known: E with no sag). beta's is
    its sd plus half :data:`GRIP_LINEARITY` of its change when estimated (its 2 sd then bound
    the error of the estimate: the response g is a half-link difference), 0 when known, and
    :data:`GRIP_UNCERTAINTY` when the model's clamp is kept (its 2 sd a quarter link: 2
    GRIP_UNCERTAINTY in g's unit of half a link)."""
    if update.grip_estimated:
        grip = update.grip_sd + 0.5 * GRIP_LINEARITY * abs(update.grip)
    else:  # 2 sd: a quarter link, 2 GRIP_UNCERTAINTY half links
        grip = GRIP_UNCERTAINTY
    return {"modulus": _posterior_log_sd(update),
            "discretization": (update.discretization_sd
                               if math.isfinite(update.discretization_sd) else 0.0),
            "grip": grip}


def _posterior_log_sd(update: ModelUpdate) -> float:
    """sd(ln E) with the prior (:attr:`ModelUpdate.log_prior_sd`): 1 / sqrt(1 / sd^2 +
    1 / sd_prior^2) (0 where E is known, or the measurement did not give an sd)."""
    if not (math.isfinite(update.log_sd) and update.log_sd > 0.0):
        return 0.0
    return 1.0 / math.sqrt(update.log_sd**-2 + update.log_prior_sd**-2)


def _uncertainty(directions: dict, update: ModelUpdate) -> dict:
    """The error budget of the final prediction [m] (:attr:`Correction.uncertainty`): 2 sd of
    each estimated quantity (:func:`parameter_sds`) times its mean response at the target
    (``directions``, :func:`_target_directions`), the unexplained residual at K and the
    offset's share."""
    sds = parameter_sds(update)
    budget = {k: 2.0 * sds[k] * float(np.mean(np.linalg.norm(v, axis=1)))
              for k, v in directions.items()}
    return {"unexplained": update.residual_after, **budget,
            "offset": update.offset_uncertainty}


def _gain_sd(open_loop: np.ndarray, corrected: np.ndarray, reference: np.ndarray,
             directions: dict, update: ModelUpdate) -> float:
    """The standard deviation of the predicted gain (open loop minus corrected final error)
    [m], linearized in the estimated quantities.

    A change dq of ln E, alpha or beta moves both final predictions by about D dq (D its
    response at the target, ``directions``: the clips differ little), so the mean errors
    e = mean_i |x_i - r_i| change by mean_i (u_i . D_i) dq with u_i the unit error vectors,
    and the gain by s dq, s = mean_i((u_open,i - u_corrected,i) . D_i). With the sds of the
    quantities (:func:`parameter_sds`) the gain's variance is t^T R t, t_k = s_k sd_k and R
    their correlations: ln E and alpha as the fit found them (:attr:`ModelUpdate.correlation`;
    the measurement tells their sag-like directions jointly, -0.73 on the 3D job's shape 1, so
    the errors of the two largely cancel at the target), the clamp length's independent (its sd
    is mostly the bound :data:`GRIP_LINEARITY`, not the fit's). What moves both errors alike
    (the unexplained residual, a shift along the error) leaves the gain as it is.
    """
    def unit(x):
        e = x - reference
        return e / np.maximum(np.linalg.norm(e, axis=1, keepdims=True), 1e-300)

    du = unit(open_loop) - unit(corrected)
    sds = parameter_sds(update)
    t = {k: float(np.mean(np.sum(du * v, axis=1))) * sds[k] for k, v in directions.items()}
    variance = sum(v * v for v in t.values()) \
        + 2.0 * update.correlation * t["modulus"] * t["discretization"]
    return math.sqrt(max(variance, 0.0))


def _gain_at_clamp_bounds(open_loop: np.ndarray, corrected: np.ndarray, reference: np.ndarray,
                          directions: dict, update: ModelUpdate, significance: float
                          ) -> tuple[float, str]:
    """The least predicted gain [m] with the clamp length ``significance`` sd off either way,
    evaluated, not linearized, and the side that gives it ("+2 sd", ...).

    The clamp length's change dq moves both final predictions by g dq (as in :func:`_gain_sd`),
    and the gain is evaluated there: e(open + g dq) - e(corrected + g dq), e the mean distance to
    the reference. Its sd is a bound of a systematic error (:func:`parameter_sds`: the fit's
    statistics plus :data:`GRIP_LINEARITY` of the change) and its response the largest at the
    target (28 mm per half link on the U demo at n = 12), so the corrected prediction, fitted
    to the reference and small, is far from linear in it: on the U demo at n = 12 against a
    plant clamping 40 mm for the model's 41.7 the clamp came out 37.9 mm (the truth 1.9 sd
    off), the linearized sd (0.58 mm) let a gain of 3.60 mm stand, and the plant went 1.09 ->
    3.88 mm; at the clamp 2 sd off the gain is -1.91 mm. (E and alpha evaluated so at their
    marginal sds refused corrections that helped, 0.46 -> 0.18 mm on the same demo: the
    measurement at K constrains them jointly, which the marginal sds leave out.)
    """
    def gain_at(shift):
        return float(_mean_distance(open_loop + shift, reference)
                     - _mean_distance(corrected + shift, reference))

    bound = significance * parameter_sds(update)["grip"]
    return min((gain_at(sign * bound * directions["grip"]), f"{sign * significance:+g} sd")
               for sign in (-1.0, 1.0))


def _corrected_grippers(grippers: GripperPath, at: int, corrected_clips) -> GripperPath:
    """The gripper path with shapes ``at`` + 1 .. T held by ``corrected_clips``."""
    positions = grippers.positions.copy()
    rotations = [r.as_quat() for r in grippers.rotations]
    for j, moved in enumerate(corrected_clips, start=at + 1):
        positions[j] = moved.positions
        quaternions = moved.rotations.as_quat()  # (2, 4): both clips at once
        for k in range(2):
            rotations[k][j] = quaternions[k]
    first, last = (Rotation.from_quat(q) for q in rotations)
    twist = relative_twist(first, last)
    worst = float(np.max(np.abs(twist)))
    return GripperPath(
        positions=positions, rotations=(first, last), method=grippers.method, twist=twist,
        warnings=grippers.warnings, success=worst <= grippers.max_twist,
        message=f"{grippers.method}, corrected after shape {at}; largest relative twist "
                f"{math.degrees(worst):.1f} degrees",
        max_twist=grippers.max_twist,
    )


def sliced_grippers(grippers: GripperPath, start: int) -> GripperPath:
    """The gripper path from shape ``start`` on (its twist counted from there)."""
    return GripperPath(
        positions=grippers.positions[start:],
        rotations=tuple(r[start:] for r in grippers.rotations),
        method=grippers.method, twist=grippers.twist[start:] - grippers.twist[start],
        warnings=grippers.warnings, success=grippers.success, message=grippers.message,
        max_twist=grippers.max_twist,
    )


def _timing(planned: Trajectory | None, planned_grippers: GripperPath) -> dict:
    """The options of :func:`trajectory_from_grippers` that time a path as the plan was timed:
    its arms, tool frame, motion limits (speed, acceleration, jerk) and zones."""
    if planned is None:
        return {}
    left = planned.arm_clips[0]
    options = {"left_clip": left,
               "tcp_in_clip": planned_grippers.rotations[left][0].inv() * planned.rotations[0][0]}
    if planned.law is not None and planned.law.limits is not None:
        return {**options, "limits": planned.law.limits, "zone": float(np.max(planned.zones))}
    return {**options, "max_speed": planned.max_speed,
            "max_angular_speed": planned.max_angular_speed}
