"""The study's closed loop linearized about the nominal plan: a chunk of samples at once.

:func:`~.probability.closed_loop_sample` runs :func:`~.step.correct_plan` per sample: every
Gauss-Newton step of the model update and every Levenberg-Marquardt iteration of the clip fit
recomputes the shape's sensitivities and the discretization directions (solves on 2 n links)
at the current estimate, the corrected path is re-timed twice and the predictions are
continuations; 17-70 ms of CPU per sample, most of it Python around small solves. A study asks
the same question of thousands of cables that differ from the nominal one by tolerances, so
here the derivatives are computed **once per study** at the plan's clips, tabulated along ln E
(:class:`DerivativeTable`) and interpolated at each estimate, and only the equilibria, which
decide where every estimate ends, are solved per sample, exactly:

* the plant (the sampled cable) is driven through the plan's clip poses by
  :func:`.plant_batch.drive_plants`, bit for bit :meth:`~.plant.Plant.hold`, so the open-loop
  column is the exact method's, bit for bit;
* the measurement is the exact method's (the same points and noise draws, bit for bit, and
  :func:`.measurement.resample_measured`, its refusals, to round-off: the chunk's at once,
  :mod:`.measurement_batch`), and so is its offset's verdict (read off the held points,
  its covariance with the measurement's noise along the clips' axes, :func:`.model_error.
  offset_covariance`, judged by :func:`~.step.offset_verdict` itself);
* the model update is :func:`~.step.update_modulus`'s algorithm -- the fit of ln E, alpha and
  beta with alpha's prior, the clamp length's and E's significance tests, steps of at most a
  factor 2 within the limit ``max_modulus_factor`` (:func:`~.step.trust_region_step`) -- with
  d x / d ln E, d and g at shape K from the table at the current E (at the plan's clips, not
  re-solved on 2 n links), each step's equilibrium exact; the first fits of a chunk are one
  batch of normal equations (:func:`fit_amplitudes`);
* the clip fit is the target's Levenberg-Marquardt fit (:data:`~.step.CLIP_DAMPING`, the
  limits' projection, ramped in over the remaining shapes) on the chain
  :func:`~.step.correct_plan` fits the clips on (:class:`~.step.FitModel`: the updated model on
  k n links, :func:`~.step.fit_links_for`, each gripper clamping k; its every k-th point plus
  the bias less the share alpha_k the chain resolves), with that chain's clip Jacobian of the
  planned target at the updated E, frozen over the fit (a chord method,
  :data:`CHORD_TRIALS`), and the bias directions there, each trial an exact equilibrium of the
  updated model's fit chain;
* the gain checks are :func:`~.step.check_gain` itself (the predicted gain against 2 sd of it,
  sd(ln E) with its prior :attr:`~.step.ModelUpdate.log_prior_sd`, and evaluated with the
  clamp length 2 sd off) on the fit chain's exact equilibria at the target plus the bias, with
  the table's directions;
* the corrected plan is scored by driving the plant through the corrected clip poses, exact.

Not done here (they do not change a row): the re-timing and the intermediate predictions. The
rows differ from the exact method's by what the derivatives taken at the plan's clips change
(and the clip fit's one pass with the bias at the planned clips, where the exact fit re-evaluates
it at the corrected clips and fits again);
the agreement is tested on samples it was not tuned on (E x0.05 .. x20, other seeds,
``tests/test_study_closed_loop.py``) and quoted in docs/study.md.

Every sample's equilibria of one round -- the model at the updated E, a trial of the clip fit
-- are solved in two compiled calls (:func:`.plant_batch.hold_chains` at shape K,
:func:`.plant_batch.drive_chains` on the fit chain at the target), on chains made once per E
and chunk (:func:`_chains`): each sample's
correction is a generator that yields the equilibria it needs and receives them
(:func:`_correction`).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Generator, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import Cable
from ..frames import slerp_quaternions
from ..geometry import as_path, resample_by_arc_length
from ..grippers import GripperPath
from ..physics.chain import SpringChain
from ..sim import ClipPoses, equilibrium, interpolate_clips
from ..sim.sensitivity import equilibrium_sensitivity
from ..study.evaluate import perturbed_cable
from .clip_batch import fit_clips_batch
from .gain_batch import NAMES as GAINS
from .gain_batch import judged_gains
from .length import check_length, clear_lengths, length_alternative, length_direction
from .measurement import CorrectionRefused, resample_measured
from .measurement_batch import (
    measured_points,
    noise_sds,
    resample_measured_batch,
    resample_polylines,
    told_offsets,
)
from .model_error import (
    MAX_GRIP,
    alpha_prior,
    clamped_equilibrium,
    measured_offset,
    model_error_directions,
    offset_covariance,
)
from .normal_fits import columns_of, fit_amplitudes, fit_estimate, fit_estimates
from .plant_batch import PlantChains, drive_chains, hold_chains
from .step import (
    CLIP_DAMPING,
    COST_TOLERANCE,
    MAX_LOG_SD,
    MAX_LOG_STEP,
    MODULUS_STEP_TOLERANCE,
    SIGNIFICANCE,
    CorrectionLimits,
    FitModel,
    ModelUpdate,
    check_gain,
    fit_links_for,
    offset_verdict,
    parameter_sds,
    trust_region_step,
    within_limits,
)

MODULUS_STEPS = 3
"""Gauss-Newton steps of the model update (:func:`~.step.correct_plan`'s default)."""

SUBSTEPS = 1
"""Plant equilibria between consecutive clip poses in a study's closed loop, both methods (the
exact one passes it to its :class:`~.plant.Plant`, :func:`~.probability.closed_loop_sample`):
one, the planned shape's own, where :class:`~.plant.Plant` takes two by default. The
continuation reaches the same equilibria to the solver's tolerance (on the study example's
1024 and three more studies of 512 samples: open-loop errors within 1.2e-10 m of two
sub-steps', closed-loop errors within 8.7e-10 m, every decision and refusal text the same) in
60 % of the plants' Newton iterations (docs/performance.md and docs/decisions.md, branch
cl8)."""

CHORD_TRIALS = 1
"""Trials per iteration of the clip fit with its Jacobian frozen (a chord method), against
:data:`~.step.MAX_TRIALS` with the Jacobian updated: once a step from the frozen Jacobian raises
the cost, more damping only shortens it towards the point already reached, and the fit ends
there. The damping after a rejection is still small (about 5e-4 of diag(J^T J) after two
accepted steps), so a second trial would be the same step to a few parts in 1e4: on the bench's
1024 samples of the study example one was accepted once (that sample's closed-loop error 0.2 um
apart), and the fits made 3.0 trials instead of 3.5 (with 10 trials, 7 more equilibria a
sample: docs/performance.md, branches studycl and cl1k)."""


TABLE_STEP = math.log(2.0) / 4.0
"""Spacing of the derivatives' table in ln E (:class:`DerivativeTable`): a factor 2^(1/4)."""


@dataclass(eq=False)
class TableNodes:
    """The nodes a :class:`DerivativeTable` made so far, by index (0 at the plan's E, +-k
    k steps of :data:`TABLE_STEP` up or down), kept sorted by ln E as they are added.

    Attributes
    ----------
    rows : dict
        Index -> the node's values (:class:`DerivativeTable`).
    logs : dict
        Index -> the node's ln E [ln Pa].
    last : dict
        Per side (1 up, -1 down) the index (k >= 0) of the last node made.
    ended : dict
        Per side: no node is made beyond its last (the range's end, or no stable equilibrium).
    ordered : list of dict
        The rows in increasing ln E.
    ordered_logs : list of float
        Their ln E [ln Pa].
    log_moduli : numpy.ndarray
        (k,) the same as an array.
    """

    rows: dict = field(default_factory=dict)
    logs: dict = field(default_factory=dict)
    last: dict = field(default_factory=lambda: {1: 0, -1: 0})
    ended: dict = field(default_factory=lambda: {1: False, -1: False})
    ordered: list = field(default_factory=list)
    ordered_logs: list = field(default_factory=list)
    log_moduli: np.ndarray = field(default_factory=lambda: np.empty(0))

    def add(self, index: int, node: dict) -> None:
        """Keep ``node`` under ``index`` and sort the rows again."""
        self.rows[index], self.logs[index] = node, _log_modulus(node)
        keys = sorted(self.rows)
        self.ordered = [self.rows[k] for k in keys]
        self.ordered_logs = [self.logs[k] for k in keys]
        self.log_moduli = np.array(self.ordered_logs)


@dataclass(frozen=True, eq=False)
class DerivativeTable:
    """The model's equilibria and their derivatives at shape K and at the target, at the
    planned clips, tabulated along ln E and interpolated linearly between its nodes.

    The nodes lie every :data:`TABLE_STEP` in ln E within ``half_width`` of the plan's E, each
    continued from its neighbour towards the ends; a side ends where the model loses its stable
    equilibrium, on its own chain or on the clip fit's of ``fit_links`` links
    (:class:`~.step.FitModel`). They are made when first needed: :meth:`at` extends the side
    of the ln E it is asked for up to it, each node from the one before as the whole table
    would make it, so every value is the same whichever estimates ask first and in which
    process (a study's estimates seldom go beyond a fraction of the factor-10 range: on the
    study example 13 of 29 nodes, docs/performance.md, branch cl3).

    A node's values, by name: ``youngs_modulus`` [Pa]; ``state`` and ``target`` (n + 1, 3)
    the equilibria at K and at the target [m]; ``modulus_k``, ``modulus_t`` d x / d ln E there
    [m]; ``d_k``, ``g_k``, ``d_t``, ``g_t`` the discretization and clamp directions
    (:func:`.model_error.model_error_directions`) [m]; ``d_clips``, ``g_clips`` (3 (n + 1), 12)
    d d / d p and d g / d p at the target (the clip sensitivities of the 2 n-link equilibria
    they are differences of, at their every other point: R_n to first order; scaled as
    ``clips``) [m]; ``fine`` (k n + 1, 3) the equilibrium at the target of the chain the clips
    are fitted on (:class:`~.step.FitModel`: k n links, each gripper clamping k) [m],
    ``fine_modulus`` its d x / d ln E (for :meth:`Interpolated.hermite`) [m],
    ``fine_clips`` (3 (k n + 1), 12) its d x / d p and ``clips`` (3 (n + 1), 12) the same at
    its every k-th point (the plan's model's material points), rotation columns divided by
    L / 2 (the clip fit's scaled coordinates).

    Attributes
    ----------
    cable : Cable
        The plan's model cable (its E the node 0).
    clips : tuple of ClipPoses
        The planned clips of shape K and of the target.
    scale : numpy.ndarray
        (12,) the clip coordinates' scale (1 for metres, L / 2 for radians).
    half_width : float
        The range either way of the plan's ln E.
    gravity : numpy.ndarray
        (3,) [m/s^2].
    fit_links : int
        Links of the clip fit's chain.
    nodes : TableNodes
        The nodes made so far (filled by :meth:`start` and :meth:`at`).
    """

    cable: Cable
    clips: tuple
    scale: np.ndarray
    half_width: float
    gravity: np.ndarray
    fit_links: int
    nodes: TableNodes = field(default_factory=TableNodes, repr=False)

    @property
    def log_moduli(self) -> np.ndarray:
        """(k,) the ln E [ln Pa] of the nodes made so far, increasing."""
        return self.nodes.log_moduli

    def at(self, log_modulus: float) -> Interpolated:
        """The values at ln E (linear between the nodes, the end node's beyond them), each
        interpolated when it is asked for."""
        nodes = self.nodes
        side = 1 if log_modulus > nodes.logs[0] else -1
        if side * (nodes.logs[side * nodes.last[side]] - log_modulus) < 0:
            self._extend(side, log_modulus)
        logs, rows = nodes.ordered_logs, nodes.ordered
        if len(logs) == 1:
            return Interpolated(rows[0], rows[0], 0.0)
        k = min(max(bisect.bisect_left(logs, log_modulus) - 1, 0), len(logs) - 2)
        w = min(max((log_modulus - logs[k]) / (logs[k + 1] - logs[k]), 0.0), 1.0)
        return Interpolated(rows[k], rows[k + 1], w)

    def start(self, guesses: tuple) -> None:
        """Make node 0, at the plan's E, from the ``guesses`` (n + 1, 3) at the two clips [m].

        Raises
        ------
        CorrectionRefused
            When the plan's own E has no stable equilibrium there.
        """
        node = _node(self.cable, self.clips, guesses, self.gravity, self.scale, self.fit_links)
        if node is None:
            raise CorrectionRefused("model: no stable equilibrium of the plan's cable at the "
                                    "measured shape's or the target's clips")
        self.nodes.add(0, node)

    def _extend(self, side: int, log_modulus: float) -> None:
        """Make the nodes of ``side`` up to the first at or beyond ``log_modulus``, or to the
        side's end."""
        nodes = self.nodes
        log_e0 = math.log(self.cable.youngs_modulus)
        count = int(math.ceil(self.half_width / TABLE_STEP - 1e-9))
        while (not nodes.ended[side]
               and side * (nodes.logs[side * nodes.last[side]] - log_modulus) < 0):
            k = nodes.last[side] + 1
            if k > count:
                nodes.ended[side] = True
                break
            previous = nodes.rows[side * nodes.last[side]]
            log_e = log_e0 + side * min(k * TABLE_STEP, self.half_width)
            step = log_e - math.log(previous["youngs_modulus"])
            guesses = (previous["state"] + step * previous["modulus_k"],
                       previous["target"] + step * previous["modulus_t"])
            node = _node(self.cable.with_modulus(math.exp(log_e)), self.clips, guesses,
                         self.gravity, self.scale, self.fit_links)
            if node is None:
                nodes.ended[side] = True
                break
            nodes.add(side * k, node)
            nodes.last[side] = k


def _log_modulus(node: dict) -> float:
    """ln E of a table's node [ln Pa] (numpy's log, as of the table's array of them)."""
    return float(np.log(node["youngs_modulus"]))


@dataclass(frozen=True, eq=False)
class Interpolated:
    """:meth:`DerivativeTable.at`: ``self[name]`` is ``(1 - w) low[name] + w high[name]``
    of two neighbouring nodes (a node's own array at w = 0 or 1), computed once."""

    low: dict
    high: dict
    w: float
    made: dict = field(default_factory=dict, repr=False)

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self.made:
            if self.w == 0.0:
                self.made[name] = self.low[name]
            elif self.w == 1.0:
                self.made[name] = self.high[name]
            else:
                self.made[name] = (1.0 - self.w) * self.low[name] + self.w * self.high[name]
        return self.made[name]

    def hermite(self, name: str, slope: str) -> np.ndarray:
        """``name`` interpolated as a cubic in ln E that also matches its derivative
        d / d ln E, ``slope``, at both nodes (a node's own array at w = 0 or 1).

        Between nodes TABLE_STEP apart the linear interpolant of an equilibrium is off by
        about h^2 / 8 of its second derivative; the cubic Hermite by h^4 / 384 of its fourth:
        the start of the clip fit's first solve at an updated E (:func:`_prepared`).

        Parameters
        ----------
        name, slope : str
            A node's value (array [m]) and its derivative d / d ln E (same shape) [m].

        Returns
        -------
        numpy.ndarray
            The interpolated value, shaped as the nodes' [m].
        """
        w = self.w
        if w in (0.0, 1.0):
            return self[name]
        h = _log_modulus(self.high) - _log_modulus(self.low)
        w2, w3 = w * w, w * w * w
        return ((2.0 * w3 - 3.0 * w2 + 1.0) * self.low[name]
                + (w3 - 2.0 * w2 + w) * h * self.low[slope]
                + (3.0 * w2 - 2.0 * w3) * self.high[name]
                + (w3 - w2) * h * self.high[slope])


@dataclass(frozen=True, eq=False)
class NominalCorrection:
    """What every sample's linearized correction shares: computed once per study.

    Attributes
    ----------
    cable : Cable
        The plan's model cable (n links).
    at : int
        K, the shape after which the plant is measured.
    plant_links : int
        Links of the plants.
    table : DerivativeTable
        The model's equilibria and derivatives at K and at the target along ln E.
    clamp_links : int
        k: the clips are fitted on the model cable as a chain of k n links, each gripper
        clamping k of them (:func:`~.step.fit_links_for`, :class:`~.step.FitModel`).
    share : float
        alpha_k, the discretization bias's first-order share that chain resolves
        (:attr:`~.step.FitModel.share`), taken off alpha in the clip fit and the predictions.
    u_axes : numpy.ndarray
        (2, 3) the clips' u-axes at shape K (the measured offset's covariance,
        :func:`.model_error.offset_covariance`).
    reference : numpy.ndarray
        (n + 1, 3) the plan's stabilized target: what the corrections aim at and the errors
        are measured against [m].
    scale : numpy.ndarray
        (12,) the scale of the clip coordinates (1 for metres, L / 2 for radians).
    stops : tuple of numpy.ndarray
        Positions (M, 2, 3) [m] and quaternions (M, 2, 4) of the plant's stops along the
        planned path: the start's clips, then :data:`SUBSTEPS` per shape.
    poses : tuple of numpy.ndarray
        Positions (T + 1, 2, 3) and quaternions (T + 1, 2, 4) of the planned clip poses.
    plant_start : numpy.ndarray
        (n_plant + 1, 3) the planned start resampled onto the plant's points [m].
    gravity : numpy.ndarray
    limits : CorrectionLimits
    """

    cable: Cable
    at: int
    plant_links: int
    table: DerivativeTable
    clamp_links: int
    share: float
    u_axes: np.ndarray
    reference: np.ndarray
    scale: np.ndarray
    stops: tuple
    poses: tuple
    plant_start: np.ndarray
    gravity: np.ndarray
    limits: CorrectionLimits

    @property
    def n_shapes(self) -> int:
        """T + 1."""
        return len(self.poses[0])

    @cached_property
    def fit_cable(self) -> Cable:
        """The model cable on the clip fit's k n links (:class:`~.step.FitModel`), at the
        plan's E."""
        return self.cable.with_links(self.clamp_links * self.cable.n_links)

    @cached_property
    def resampled_reference(self) -> np.ndarray:
        """:attr:`reference` resampled by arc length onto its own n + 1 points, as
        :func:`~.plant.shape_error` compares it [m]."""
        return resample_by_arc_length(self.reference, len(self.reference))


def nominal_correction(cable: Cable, shapes, grippers: GripperPath, at: int, *, stabilized,
                       gravity, plant_links: int | None = None,
                       limits: CorrectionLimits | None = None) -> NominalCorrection:
    """The derivatives and clip poses every linearized correction of a study shares.

    Parameters
    ----------
    cable, shapes, grippers
        The plan's model cable, its planned shapes (T + 1, n + 1, 3) [m] and clip poses.
    at : int
        K (0 <= K < T).
    stabilized : array_like
        (T + 1, n + 1, 3) the plan's stabilized shapes [m].
    gravity : array_like
    plant_links : int, optional
        The plants' links (default the model's).
    limits : CorrectionLimits, optional

    Raises
    ------
    CorrectionRefused
        When the model has no stable equilibrium at shape K or at the target.
    """
    path = as_path(shapes, cable.n_points, "shapes")
    stable = as_path(stabilized, cable.n_points, "stabilized")
    limits = CorrectionLimits() if limits is None else limits
    gravity = np.asarray(gravity, dtype=float)
    clips = [grippers.clip_poses(j) for j in range(len(path))]
    scale = np.tile(np.r_[np.ones(3), np.full(3, 0.5 * cable.length)], 2)
    fit_links = fit_links_for(cable.n_links)  # correct_plan's default
    table = derivative_table(cable, (clips[at], clips[-1]), (stable[at], stable[-1]), scale,
                             math.log(limits.max_modulus_factor), gravity, fit_links)
    fit = FitModel.of(cable, fit_links, gravity)
    stops = [clips[0]]
    fractions = np.arange(1, SUBSTEPS + 1) / SUBSTEPS
    for j in range(1, len(path)):
        stops += interpolate_clips(clips[j - 1], clips[j], fractions)
    links = cable.n_links if plant_links is None else int(plant_links)
    return NominalCorrection(cable, int(at), links, table, fit.clamp_links, fit.share,
                             clips[at].u_axes, stable[-1], scale, _arrays(stops),
                             _arrays(clips), resample_by_arc_length(path[0], links + 1),
                             gravity, limits)


def derivative_table(cable: Cable, clips: tuple, guesses: tuple, scale: np.ndarray,
                     half_width: float, gravity, fit_links: int) -> DerivativeTable:
    """:class:`DerivativeTable` at the clips of shape K and of the target (``clips``, from the
    ``guesses``) within ``half_width`` of the plan's ln E, the clip fit's chain of
    ``fit_links`` links: its node 0 made (the others when needed).

    Raises
    ------
    CorrectionRefused
        When the plan's own E has no stable equilibrium there.
    """
    table = DerivativeTable(cable, clips, scale, half_width, np.asarray(gravity, dtype=float),
                            fit_links)
    table.start(guesses)
    return table


def _node(cable: Cable, clips: tuple, guesses: tuple, gravity, scale,
          fit_links: int) -> dict | None:
    """One node of :func:`derivative_table`, None without a stable equilibrium."""
    node = {"youngs_modulus": cable.youngs_modulus}
    for suffix, c, guess in zip(("k", "t"), clips, guesses, strict=True):
        eq = equilibrium(cable, guess, c, gravity=gravity)
        if not eq.success:
            return None
        sens = equilibrium_sensitivity(cable, eq.shape, c, gravity=gravity)
        fine = cable.with_links(2 * cable.n_links)
        chain = SpringChain.from_cable(fine, gravity)
        refined = resample_by_arc_length(eq.shape, fine.n_points)
        try:
            d, g = model_error_directions(cable, eq.shape, c, grip=True, gravity=gravity,
                                          fine_chain=chain, fine_guess=refined)
            length = length_direction(cable, eq.shape, c, gravity)
        except CorrectionRefused:
            return None
        node.update({"state" if suffix == "k" else "target": eq.shape,
                     f"modulus_{suffix}": sens.log_modulus, f"d_{suffix}": d, f"g_{suffix}": g,
                     f"l_{suffix}": length})
        if suffix == "t":  # how d and g move with the clips: the clip fit's bias
            clamped3, stable, _ = clamped_equilibrium(fine, refined, c, 3, gravity=gravity,
                                                      chain=chain)
            if not stable:
                return None
            two, three = (equilibrium_sensitivity(fine, x, c, chain=chain, clamp_links=links)
                          .clips[::2] for x, links in ((refined, 2), (clamped3, 3)))
            node.update({"d_clips": (two - sens.clips).reshape(-1, 12) / scale,
                         "g_clips": (three - two).reshape(-1, 12) / scale})
    fit = FitModel.of(cable, fit_links, gravity)
    try:
        held = fit.hold(node["target"], clips[1], gravity)
    except CorrectionRefused:
        return None
    sens = equilibrium_sensitivity(fit.cable, held.shape, clips[1], chain=fit.chain,
                                   clamp_links=fit.clamp_links)
    node.update({"fine": held.shape, "fine_modulus": sens.log_modulus,
                 "fine_clips": sens.clips.reshape(-1, 12) / scale,
                 "clips": sens.clips[:: fit.clamp_links].reshape(-1, 12) / scale})
    return node


def _arrays(clips: Sequence[ClipPoses]) -> tuple[np.ndarray, np.ndarray]:
    return (np.array([c.positions for c in clips]),
            np.array([c.rotations.as_quat() for c in clips]))


def linearized_rows(nominal: NominalCorrection, items: Sequence[tuple], *, noise: float,
                    n_measured: int, batched: bool = True) -> list[dict]:
    """The closed-loop rows of a chunk of samples, linearized about the nominal plan.

    Parameters
    ----------
    nominal : NominalCorrection
    items : sequence of tuple
        ``(index, E [Pa], mass per length [kg/m], length [m])`` per sample; the index seeds
        its measurement's noise.
    noise : float
        Measurement noise per coordinate [m].
    n_measured : int
        Measured points.
    batched : bool
        True: the chunk's clip fits in lockstep, one batch of arrays per round
        (:func:`.clip_batch.fit_clips_batch`; what it cannot fit, per sample); False: every
        sample's per sample (:func:`_correction`; the same rows to solver tolerance).

    Returns
    -------
    list of dict
        One row per item (:data:`~.probability.SAMPLE_COLUMNS` and ``sample``), in order.
    """
    cable, at = nominal.cable, nominal.at
    plants = [perturbed_cable(cable, e, m, length) for _, e, m, length in items]
    if nominal.plant_links != cable.n_links:
        plants = [plant.with_links(nominal.plant_links) for plant in plants]
    clamps = [max(1, round(cable.rest_link_length / p.rest_link_length)) for p in plants]
    count = len(items)
    positions, quaternions = (np.broadcast_to(a, (count,) + a.shape) for a in nominal.stops)
    chains = PlantChains.of(plants, nominal.gravity)
    # stop 0 settles the start; run_closed_loop's continuation from it predicts from its second
    # stop on (:func:`.plant.continuation_guess`), the drive's stop 2
    drive = drive_chains(chains, clamps, np.broadcast_to(nominal.plant_start, (count,) +
                                                         nominal.plant_start.shape),
                         positions, quaternions, gravity=nominal.gravity, predict_from=2)
    rows = [_plant_failure(nominal, drive.failed[b], drive.messages[b])
            for b in range(count)]
    open_error = np.full(count, math.nan)
    corrections: list = [None] * count
    held = [b for b in range(count) if rows[b] is None]
    results: list = [None] * count
    measured = {}
    if held:
        open_error[held] = _shape_errors(drive.shapes[held, -1], nominal.resampled_reference)
        points = measured_points(drive.shapes[held, SUBSTEPS * at], [items[b][0] for b in held],
                                 noise, n_measured)
        for b, y in zip(held, _resampled(nominal, points, batched), strict=True):
            if isinstance(y, str):
                results[b] = y
            else:
                measured[b] = y
    fitted = [b for b in held if results[b] is None]
    prior = alpha_prior(cable.n_links, nominal.plant_links)
    if fitted:
        first = _first_fits(nominal, np.array([measured[b] for b in fitted]), prior)
        step = _prepared if batched else _correction
        for b, fits in zip(fitted, first, strict=True):
            corrections[b] = step(nominal, measured[b], fits, prior)
    cables: dict = {}
    _run(nominal, corrections, results, cables, batched=batched)
    if batched:
        _fit_and_check(nominal, results, cables)
    accepted = [b for b in range(count) if isinstance(results[b], _Corrected)]
    closed_error = open_error.copy()
    if accepted:
        closed = _closed_loop(nominal, chains.take(accepted),
                              [clamps[b] for b in accepted],
                              drive.shapes[accepted, max(SUBSTEPS * at - 1, 0) : SUBSTEPS * at + 1],
                              np.array([results[b].clips for b in accepted]))
        errors = np.full(len(accepted), math.nan)
        ran = np.flatnonzero(closed.failed < 0)
        if len(ran):
            errors[ran] = _shape_errors(closed.shapes[ran, -1], nominal.resampled_reference)
        for k, b in enumerate(accepted):
            if closed.failed[k] >= 0:  # a failed run, as the exact method's (no errors)
                shape = at + 1 + closed.failed[k] // SUBSTEPS
                rows[b] = {**_failed_row(), "refusal": f"plant: the quasi-static simulation "
                                                       f"failed at shape {shape}: "
                                                       f"{closed.messages[k]}"}
                continue
            closed_error[b] = errors[k]
    out = []
    for b, (index, *_) in enumerate(items):
        row = rows[b]
        if row is None:
            result = results[b]
            done = isinstance(result, _Corrected)
            row = {"open_loop_error": float(open_error[b]),
                   "closed_loop_error": float(closed_error[b]), "corrections": int(done),
                   "youngs_modulus_estimate": result.youngs_modulus if done else math.nan,
                   "refusal": "" if done else f"shape {at}: {result}"}
        out.append({"sample": index, **row})
    return out


def _failed_row() -> dict:
    return {"open_loop_error": math.nan, "closed_loop_error": math.nan, "corrections": 0,
            "youngs_modulus_estimate": math.nan, "refusal": ""}


def _plant_failure(nominal: NominalCorrection, stop: int, message: str) -> dict | None:
    """The row of a plant that lost its equilibrium at ``stop`` (None: it did not), with
    :func:`~.plant.run_closed_loop`'s reason."""
    if stop < 0:
        return None
    if stop == 0:
        return {**_failed_row(), "refusal": f"plant: the start does not settle: {message}"}
    shape = (stop - 1) // SUBSTEPS + 1
    return {**_failed_row(), "refusal": f"plant: the quasi-static simulation failed at shape "
                                        f"{shape}: {message}"}


def _shape_errors(shapes: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """:func:`~.plant.shape_error` of B shapes (B, n + 1, 3) to ``reference``, already
    resampled by arc length, (B,) [m], bit for bit (:func:`.measurement_batch.
    resample_polylines`)."""
    a = resample_polylines(shapes, len(reference))
    return np.array([np.mean(np.linalg.norm(x - reference, axis=1)) for x in a])


@dataclass(frozen=True)
class _Corrected:
    youngs_modulus: float
    clips: np.ndarray  # (12,) the target's clip correction


@dataclass(frozen=True, eq=False)
class _Fit:
    """A model-error fit a sample's correction needs (:func:`.normal_fits.fit_estimate`'s
    arguments): J (n + 1, 3) or None, the directions d (and g), the residual (n + 1, 3) [m]
    and alpha's prior (alpha_0, sd)."""

    jacobian: np.ndarray | None
    directions: tuple
    residual: np.ndarray
    prior: tuple


@dataclass(frozen=True)
class _Request:
    """An equilibrium a sample's correction needs: its E [Pa], the clip correction p (12,)
    of shape K (``at_target`` False: the model's chain, guess (n + 1, 3) [m]) or of the
    target (the clip fit's chain, :class:`~.step.FitModel`, guess (k n + 1, 3) [m])."""

    youngs_modulus: float
    clips: np.ndarray
    at_target: bool
    guess: np.ndarray


def _run(nominal: NominalCorrection, corrections: list, results: list, cables: dict, *,
         batched: bool = True) -> None:
    """Drive every sample's generator (None: none: :func:`_correction`, :func:`_prepared`
    or :func:`_fit_clips`), each round's equilibria solved in one compiled call and its
    model-error fits in one batch per kind (:func:`_fits`; ``batched`` False: each alone),
    into ``results`` (what it returns, or the refusal's reason, per sample); ``cables`` as
    :func:`_solve` takes it."""
    pending: dict[int, _Request | _Fit] = {}
    for b, gen in enumerate(corrections):
        if gen is not None:
            _advance(gen, None, b, pending, results)
    while pending:
        order = list(pending)
        requests = [pending.pop(b) for b in order]
        answers: list = [None] * len(requests)
        solved = [j for j, r in enumerate(requests) if isinstance(r, _Request)]
        for j, shape in zip(solved, _solve(nominal, [requests[j] for j in solved], cables)
                            if solved else [], strict=True):
            answers[j] = shape
        fitted = [j for j, r in enumerate(requests) if isinstance(r, _Fit)]
        for j, value in zip(fitted, _fits([requests[j] for j in fitted], batched),
                            strict=True):
            answers[j] = value
        for b, answer in zip(order, answers, strict=True):
            _advance(corrections[b], answer, b, pending, results)


def _fits(requests: list, batched: bool) -> list:
    """The estimates of the model-error fits ``requests`` (:class:`_Fit`), those of a kind
    (with or without J, the directions, the prior) in one :func:`.normal_fits.fit_estimates`,
    what it hands back, or all with ``batched`` False, by :func:`.normal_fits.fit_estimate`."""
    out: list = [None] * len(requests)
    kinds: dict[tuple, list] = {}
    for j, r in enumerate(requests):
        kinds.setdefault((r.jacobian is None, len(r.directions), r.prior), []).append(j)
    for (held, _, prior), index in kinds.items():
        values, final = None, np.zeros(len(index), dtype=bool)
        if batched:
            values, final = fit_estimates(
                np.array([columns_of(requests[j].jacobian, requests[j].directions)
                          for j in index]),
                np.array([requests[j].residual.ravel() for j in index]), int(not held),
                prior)
        for k, j in enumerate(index):
            r = requests[j]
            out[j] = values[k] if final[k] else fit_estimate(r.jacobian, list(r.directions),
                                                             r.residual, r.prior)
    return out


def _fit_and_check(nominal: NominalCorrection, results: list, cables: dict) -> None:
    """The clip fits of every sample :func:`_prepared` got ready (a :class:`_Case` in
    ``results``) in one :func:`.clip_batch.fit_clips_batch`, those it cannot fit by
    :func:`_fit_clips`, then their gain checks: each such result replaced by its
    :class:`_Corrected` or the refusal's reason."""
    index = [b for b, case in enumerate(results) if isinstance(case, _Case)]
    if not index:
        return
    cases = [results[b] for b in index]

    chains = _chains(nominal, [case.update.youngs_modulus for case in cases], cables, True)

    def solve(which, p, guesses):
        return _solve(nominal, [_Request(cases[j].update.youngs_modulus, p[i], True,
                                         guesses[i]) for i, j in enumerate(which)], cables,
                      chains.take(which))

    p, x, fitted = fit_clips_batch(
        np.array([c.jacobian for c in cases]), np.array([c.at["fine_clips"] for c in cases]),
        np.array([c.moves for c in cases]), np.array([c.open_loop for c in cases]),
        np.array([c.bias for c in cases]), nominal.reference, nominal.scale, nominal.limits,
        nominal.clamp_links, CHORD_TRIALS, solve)
    fits: list = [(p[j], x[j]) if fitted[j] else None for j in range(len(cases))]
    alone = [j for j in range(len(cases)) if not fitted[j]]
    if alone:
        _run(nominal, [_fit_clips(nominal, cases[j]) if j in alone else None
                       for j in range(len(cases))], fits, cables)
    judged = [_predictions(nominal, case, *fit) for case, fit in zip(cases, fits, strict=True)]
    sds = [parameter_sds(case.update) for case in cases]
    clear, refusals, spreads = judged_gains(
        np.array([j[0] for j in judged]), np.array([j[1] for j in judged]), nominal.reference,
        {name: np.array([j[2][name] for j in judged]) for name in GAINS},
        np.array([[sd[name] for name in GAINS] for sd in sds]),
        np.array([case.update.correlation for case in cases]), nominal.limits.gain_significance)
    passed = []
    for j, b in enumerate(index):
        if refusals[j] is not None:  # refused by more than round-off: check_gain's reason
            results[b] = refusals[j]
            continue
        try:
            if not clear[j]:  # near a threshold: check_gain's verdict itself
                spreads[j] = check_gain(judged[j][0], judged[j][1], nominal.reference,
                                        judged[j][2], cases[j].update,
                                        nominal.limits.gain_significance)
            passed.append(j)
        except CorrectionRefused as exc:
            results[b] = str(exc)
    for j, reason in zip(passed, _lengths_checked(nominal, [cases[j] for j in passed],
                                                  [judged[j] for j in passed],
                                                  spreads[passed]), strict=True):
        results[index[j]] = (_Corrected(cases[j].update.youngs_modulus, fits[j][0])
                             if reason is None else reason)


def _lengths_checked(nominal: NominalCorrection, cases: list, judged: list,
                     spreads: np.ndarray) -> list:
    """The length checks (:func:`.length.check_length`) of the corrections whose gain checks
    passed, with their predictions and directions ``judged`` (:func:`_predictions`) and their
    gains' sds ``spreads`` [m]: the chunk's at once (:func:`.length.clear_lengths`), those it
    does not clear each by :func:`_check_length`. Per case None (kept) or the refusal's
    reason."""
    if not cases:
        return []
    fitted = np.array(_length_fits(cases))

    def stacked(name: str) -> np.ndarray:
        return np.array([c.at[name] for c in cases])

    needed = nominal.limits.gain_significance * spreads
    clear = clear_lengths(
        np.array([c.residual for c in cases]), (stacked("d_k"), stacked("g_k"), stacked("l_k")),
        np.array([(c.update.discretization, c.update.grip) for c in cases]), fitted,
        (np.array([j[0] for j in judged]), np.array([j[1] for j in judged])),
        (stacked("d_t"), stacked("g_t"), np.array([j[2]["discretization"] for j in judged]),
         np.array([j[2]["grip"] for j in judged]), stacked("l_t")), nominal.reference, needed)
    out: list = [None] * len(cases)
    for j in np.flatnonzero(~clear):
        try:
            _check_length(nominal, cases[j], judged[j], spreads[j], fitted[j])
        except CorrectionRefused as exc:
            out[j] = str(exc)
    return out


def _length_fits(cases: list) -> list:
    """The length alternative's (alpha', lambda) of each case (:func:`.length.
    length_alternative`), the model-error fit of its residual at K on [d, l] with alpha's
    prior, all on their stacked normal equations (:func:`.normal_fits.fit_estimates`; what
    they cannot fit, by :func:`.normal_fits.fit_estimate`)."""
    if not cases:
        return []
    values, final = fit_estimates(
        np.array([columns_of(None, (c.at["d_k"], c.at["l_k"])) for c in cases]),
        np.array([c.residual.ravel() for c in cases]), 0, cases[0].prior)
    return [values[j] if final[j] else
            fit_estimate(None, (c.at["d_k"], c.at["l_k"]), c.residual, c.prior)
            for j, c in enumerate(cases)]


def _chains(nominal: NominalCorrection, moduli, cables: dict, fit: bool) -> PlantChains:
    """The model's chains at the ``moduli`` [Pa], in order: the plan's model (n links, held by
    one link at each clip), or with ``fit`` the clip fit's (:class:`~.step.FitModel`: k n
    links, also when k is 1). Rows of one pool per kind for the chunk (``cables["chains",
    fit]``), each E's made once (those of a call in one :meth:`.plant_batch.PlantChains.
    at_moduli`), its row kept in ``cables`` under (E, fit)."""
    missing = list(dict.fromkeys(float(e) for e in moduli if (float(e), fit) not in cables))
    if missing:
        made = PlantChains.at_moduli(nominal.fit_cable if fit else nominal.cable, missing,
                                     nominal.gravity)
        pool = cables.get(("chains", fit))
        start = 0 if pool is None else len(pool)
        cables["chains", fit] = made if pool is None else PlantChains.join([pool, made])
        for row, e in enumerate(missing, start=start):
            cables[e, fit] = row
    return cables["chains", fit].take([cables[float(e), fit] for e in moduli])


def _advance(gen: Generator, value, b: int, pending: dict, results: list) -> None:
    try:
        pending[b] = gen.send(value)
    except StopIteration as stop:
        results[b] = stop.value
    except CorrectionRefused as exc:
        results[b] = str(exc)


def _solve(nominal: NominalCorrection, requests: list, cables: dict,
           fit_chains: PlantChains | None = None) -> list:
    """The equilibria of ``requests``: those at shape K on the model's chain in one
    :func:`.plant_batch.hold_chains` call (:func:`dloplan.sim.batch.held_equilibria`, bit for
    bit), those at the target on the clip fit's chain in one
    :func:`.plant_batch.drive_chains` call (one stop each: the clamped equilibrium of
    :class:`~.step.FitModel` to the solver's tolerance, its Newton loop unshifted again after
    every very successful step, ``restart``; and its reach check); shapes, None where there
    is no stable equilibrium. ``cables`` holds the chains made so far per E and kind
    (:func:`_chains`: the model's and the clip fit's); ``fit_chains``, when given, are
    the fit chains of the requests at the target, in order (made by :func:`_chains`)."""
    positions, quaternions = nominal.poses
    p = np.array([r.clips for r in requests]).reshape(-1, 2, 2, 3)
    index = [nominal.n_shapes - 1 if r.at_target else nominal.at for r in requests]
    moved = positions[index] + p[:, :, 0]
    turns = Rotation.from_rotvec(p[:, :, 1].reshape(-1, 3))
    rotations = turns * Rotation.from_quat(quaternions[index].reshape(-1, 4))
    quats = rotations.as_quat().reshape(-1, 2, 4)
    out: list = [None] * len(requests)
    shape_k = [b for b, r in enumerate(requests) if not r.at_target]
    if shape_k:
        shapes = hold_chains(_chains(nominal, [requests[b].youngs_modulus for b in shape_k],
                                     cables, False),
                             [requests[b].guess for b in shape_k], moved[shape_k],
                             quats[shape_k], gravity=nominal.gravity)
        for b, shape in zip(shape_k, shapes, strict=True):
            out[b] = shape
    target = [b for b, r in enumerate(requests) if r.at_target]
    if target:
        k = nominal.clamp_links
        fine = fit_chains if fit_chains is not None else _chains(
            nominal, [requests[b].youngs_modulus for b in target], cables, True)
        drive = drive_chains(fine, [k] * len(target), [requests[b].guess for b in target],
                             moved[target][:, None], quats[target][:, None],
                             gravity=nominal.gravity,
                             restart=True)
        reach = (fine.cables[0].n_links - 2 * k) * fine.link[0]
        for j, b in enumerate(target):
            x = drive.shapes[j, 0]
            if drive.failed[j] < 0 and np.linalg.norm(x[-k - 1] - x[k]) <= reach:
                out[b] = x
    return out


def _resampled(nominal: NominalCorrection, points: np.ndarray, batched: bool) -> list:
    """The measured ``points`` (B, k, 3) [m] resampled onto the model's points
    (:func:`.measurement.resample_measured`, its checks: :func:`.measurement_batch.
    resample_measured_batch` and the function itself on what the batch hands back), the
    measurement's offset taken out when it tells one (:func:`~.step.update_modulus`: the held
    points' scatter and the measurement's noise along the clips' axes, :func:`~.step.
    offset_verdict`; decided for the chunk at once, :func:`.measurement_batch.told_offsets`,
    unless ``batched`` is False): per sample (n + 1, 3) [m], or the refusal's reason."""
    x = nominal.table.at(math.log(nominal.cable.youngs_modulus))["state"]
    length, limit = nominal.cable.length, nominal.limits.max_disagreement
    shapes, done = resample_measured_batch(points, x, length, limit)
    out: list = list(shapes)
    for b in np.flatnonzero(~done):
        try:
            out[b] = resample_measured(points[b], x, length, max_disagreement=limit)
        except CorrectionRefused as exc:
            out[b] = str(exc)
    kept = [b for b, y in enumerate(out) if not isinstance(y, str)]
    if kept:
        sds = noise_sds(points[kept], np.array([out[b] for b in kept]))
        applied, clear = told_offsets(np.array([out[b] for b in kept]) - x, nominal.u_axes,
                                      sds)
        clear &= batched
        for b, sd, offset, decided in zip(kept, sds, applied, clear, strict=True):
            if not decided:  # too near the threshold for the batch: the verdict itself
                offset, scatter = measured_offset(out[b] - x)
                covariance = offset_covariance(scatter, nominal.u_axes, float(sd))
                offset = offset_verdict(offset, covariance)[0]
            out[b] = out[b] - offset  # the camera's
    return out


def _first_fits(nominal: NominalCorrection, measured: np.ndarray, prior) -> list[dict]:
    """The fits every sample's :func:`_update_modulus` starts with, at the plan's E, each in
    one :func:`fit_amplitudes` of the chunk's resampled measurements (B, n + 1, 3) [m]: ln E
    with the bias and the clamp length, kept when the measurement tells the clamp length, else
    ln E with the bias; where E is then kept, the amplitudes alone at the plan's E.

    Returns
    -------
    list of dict
        Per sample: ``fit`` (the :func:`fit_amplitudes` tuple), ``grip`` (the clamp length
        told), ``informed`` (E to be updated) and ``held`` (the amplitudes at the plan's E,
        None where E is updated).
    """
    cable = nominal.cable
    at = nominal.table.at(math.log(cable.youngs_modulus))
    jacobian = at["modulus_k"]
    residuals = measured - at["state"]
    with_grip = fit_amplitudes(jacobian, [at["d_k"], at["g_k"]], residuals, prior)
    plain = fit_amplitudes(jacobian, [at["d_k"]], residuals, prior)
    sag = float(np.sum(jacobian**2)) > 1e-24 * cable.length**2
    out = []
    for fit, other in zip(with_grip, plain, strict=True):
        beta, sd = fit[1][1], fit[2][2]
        grip = bool(abs(beta) >= SIGNIFICANCE * sd and abs(beta) < MAX_GRIP)
        chosen = fit if grip else other
        step, log_sd = chosen[0], float(chosen[2][0])
        informed = sag and log_sd <= MAX_LOG_SD and abs(step) >= SIGNIFICANCE * log_sd
        out.append({"fit": chosen, "grip": grip, "informed": bool(informed), "held": None})
    for grip in (True, False):  # the amplitudes alone where E is kept
        kept = [b for b, f in enumerate(out) if f["grip"] == grip and not f["informed"]]
        if kept:
            names = ("d_k", "g_k") if grip else ("d_k",)
            fits = fit_amplitudes(None, [at[d] for d in names], residuals[kept], prior)
            for b, fit in zip(kept, fits, strict=True):
                out[b]["held"] = fit[1]
    return out


def _correction(nominal: NominalCorrection, y: np.ndarray, first: dict, prior) -> Generator:
    """One sample's linearized correction (module docstring) from its resampled measurement
    ``y`` (n + 1, 3) [m] and its :func:`_first_fits`, per sample: yields :class:`_Request`,
    receives their equilibria (None: none), returns a :class:`_Corrected` or raises
    :class:`CorrectionRefused`. (:func:`linearized_rows` runs its parts with the chunk's clip
    fits in one batch: :func:`_prepared`, :func:`.clip_batch.fit_clips_batch`,
    :func:`_checked`.)"""
    case = yield from _prepared(nominal, y, first, prior)
    p, corrected = yield from _fit_clips(nominal, case)
    return _checked(nominal, case, p, corrected)


@dataclass(frozen=True, eq=False)
class _Case:
    """A sample's model update and what its clip fit starts from (:func:`_prepared`)."""

    update: ModelUpdate
    at: Interpolated  # the derivatives at the target, at the updated E
    bias: np.ndarray  # (n + 1, 3) what the clip fit's chain leaves of the bias [m]
    moves: np.ndarray  # (3 (n + 1), 12) how it moves with the clips (scaled coordinates)
    open_loop: np.ndarray  # (k n + 1, 3) the fit chain's equilibrium at the planned clips
    residual: np.ndarray  # (n + 1, 3) the measurement at K less the updated model's [m]
    prior: tuple  # alpha's (:func:`.model_error.alpha_prior`)

    @property
    def jacobian(self) -> np.ndarray:
        """(3 (n + 1), 12) the clip fit's frozen Jacobian (scaled coordinates) [m]."""
        return self.at["clips"] + self.moves


def _prepared(nominal: NominalCorrection, y: np.ndarray, first: dict, prior) -> Generator:
    """The model update of a sample's correction (:func:`_update_modulus`) and the fit
    chain's equilibrium at the planned clips at the updated E: yields :class:`_Request`,
    returns its :class:`_Case` or raises :class:`CorrectionRefused`."""
    update = yield from _update_modulus(nominal, y, first, prior)
    modulus = update.youngs_modulus
    at = nominal.table.at(math.log(modulus))  # the derivatives at the target, at this E
    # what the clip fit's chain leaves of the bias (:meth:`~.step.FitModel.bias`), and how it
    # moves with the clips (scaled coordinates)
    left = update.discretization - nominal.share
    bias = left * at["d_t"] + update.grip * at["g_t"]
    moves = left * at["d_clips"] + update.grip * at["g_clips"]
    open_loop = at["fine"]  # E kept: the table's node is the fit chain's equilibrium there
    if modulus != nominal.cable.youngs_modulus:
        open_loop = yield _Request(modulus, np.zeros(12), True,
                                   at.hermite("fine", "fine_modulus"))
    if open_loop is None:
        raise CorrectionRefused(
            f"model: the clip fit's chain (n = {len(at['fine']) - 1}, clamping "
            f"{nominal.clamp_links} links, E = {modulus:.3g} Pa) finds no stable equilibrium "
            "at the target's clip poses")
    return _Case(update, at, bias, moves, open_loop, y - update.state, prior)


def _checked(nominal: NominalCorrection, case: _Case, p: np.ndarray,
             corrected: np.ndarray) -> _Corrected:
    """The gain checks (:func:`~.step.check_gain`) of a sample's clip correction ``p`` (12,)
    and the fit chain's equilibrium ``corrected`` there: its :class:`_Corrected`, or raises
    :class:`CorrectionRefused`."""
    open_loop, prediction, directions = _predictions(nominal, case, p, corrected)
    spread = check_gain(open_loop, prediction, nominal.reference, directions, case.update,
                        nominal.limits.gain_significance)
    at = case.at
    _check_length(nominal, case, (open_loop, prediction, directions), spread,
                  fit_estimate(None, (at["d_k"], at["l_k"]), case.residual, case.prior))
    return _Corrected(case.update.youngs_modulus, p)


def _check_length(nominal: NominalCorrection, case: _Case, judged: tuple, spread: float,
                  fitted) -> None:
    """:func:`.length.check_length` of a sample's correction whose gain checks passed, from
    its predictions and directions (``judged``, :func:`_predictions`), its gain's sd
    ``spread`` [m], the alternative's (alpha', lambda) ``fitted`` (:func:`_length_fits`) and
    the table's d, g and l at K and at the target's planned clips, at its E."""
    at, update = case.at, case.update
    open_loop, corrected, directions = judged
    alternative = length_alternative(case.residual, at["d_k"], at["g_k"], at["l_k"],
                                     update.discretization, update.grip, fitted)
    check_length(open_loop, corrected, nominal.reference, (at["d_t"], at["g_t"]), directions,
                 update.discretization, update.grip, alternative, at["l_t"],
                 nominal.cable.length, nominal.limits.gain_significance * spread)


def _predictions(nominal: NominalCorrection, case: _Case, p: np.ndarray,
                 corrected: np.ndarray) -> tuple:
    """What the gain checks judge: the target's predictions at the planned and the corrected
    clips, the bias included, (n + 1, 3) each, and the target's responses to ln E, alpha and
    beta at the corrected clips (d and g to first order) [m]."""
    at, bias, moves = case.at, case.bias, case.moves
    k, z = nominal.clamp_links, p * nominal.scale
    directions = {"modulus": at["modulus_t"],
                  "discretization": at["d_t"] + (at["d_clips"] @ z).reshape(bias.shape),
                  "grip": at["g_t"] + (at["g_clips"] @ z).reshape(bias.shape)}
    return (case.open_loop[::k] + bias,
            corrected[::k] + bias + (moves @ z).reshape(bias.shape), directions)


def _update_modulus(nominal: NominalCorrection, measured: np.ndarray, first: dict, prior
                    ) -> Generator:
    """:func:`~.step.update_modulus` (discretization bias, clamp length and offset estimated)
    with d x / d ln E, d and g at shape K taken from the table at the current E (the plan's
    clips), from the sample's :func:`_first_fits` at the plan's E; each step's equilibrium
    exact (a yielded :class:`_Request`). Returns its :class:`~.step.ModelUpdate` (the
    residuals before and after, which no row reports, NaN)."""
    cable, limits, table = nominal.cable, nominal.limits, nominal.table
    log_e0 = math.log(cable.youngs_modulus)
    log_e = log_e0
    at = table.at(log_e)
    jacobian, x = at["modulus_k"], at["state"]
    step, amplitudes, sds, correlation = first["fit"]
    grip = first["grip"]
    grip_sd = float(sds[2]) if grip else math.inf
    names = ("d_k", "g_k") if grip else ("d_k",)  # else the model's clamp length
    log_sd, alpha_sd = float(sds[0]), float(sds[1])
    informed = first["informed"]
    budget = MODULUS_STEPS + math.ceil(math.log(limits.max_modulus_factor) / MAX_LOG_STEP) + 1
    full = taken = 0
    for _ in range(budget if informed else 0):
        clipped = trust_region_step(step, log_e, log_e0, log_sd, limits.max_modulus_factor)
        if clipped is None:  # held on the limit
            break
        log_e += clipped
        x_new = yield _Request(math.exp(log_e), np.zeros(12), False, x + clipped * jacobian)
        if x_new is None:
            raise CorrectionRefused(f"model: no stable equilibrium of the cable (E = "
                                    f"{math.exp(log_e):.3g} Pa) at shape {nominal.at}'s clips")
        x = x_new
        taken += 1
        full += clipped == step
        if abs(clipped) < MODULUS_STEP_TOLERANCE or full >= MODULUS_STEPS:
            break
        at = table.at(log_e)
        jacobian = at["modulus_k"]
        step = float((yield _Fit(jacobian, tuple(at[name] for name in names), measured - x,
                                 prior))[0])
    if not informed:  # E kept: the amplitudes at the plan's E, fitted already
        amplitudes = first["held"]
    else:
        at = table.at(log_e)
        amplitudes = yield _Fit(None, tuple(at[name] for name in names), measured - x, prior)
    beta = float(amplitudes[1]) if grip else 0.0
    modulus = cable.youngs_modulus if log_e == log_e0 else math.exp(log_e)
    return ModelUpdate(cable.youngs_modulus, modulus, math.nan, math.nan, taken, x,
                       discretization=float(amplitudes[0]), log_sd=log_sd, grip=beta,
                       grip_sd=grip_sd, discretization_sd=alpha_sd, correlation=correlation,
                       log_prior_sd=0.5 * math.log(limits.max_modulus_factor))


def _fit_clips(nominal: NominalCorrection, case: _Case) -> Generator:
    """The target's Levenberg-Marquardt clip fit (:func:`~.step.fit_clips`' damping and stop,
    :data:`CHORD_TRIALS` trials per iteration) on the clip fit's chain (k n links,
    :class:`~.step.FitModel`), its every k-th point plus the sample's bias (n + 1, 3) fitted
    to the reference, from its equilibrium (k n + 1, 3) [m] at the planned clips, with the
    clip Jacobian of the planned target at the updated E (the table's, :meth:`DerivativeTable.
    at`), frozen: every trial an exact equilibrium of the updated model's fit chain. The bias
    moves with the clips, to first order by the case's ``moves`` (3 (n + 1), 12, scaled):
    where :func:`~.step.correct_plan` re-evaluates it at the clips of a first fit and fits
    again. Per sample (:func:`.clip_batch.fit_clips_batch` is the chunk's in one batch).
    Returns ``(p (12,), equilibrium (k n + 1, 3))``."""
    scale, limits, k = nominal.scale, nominal.limits, nominal.clamp_links
    modulus, bias, moves = case.update.youngs_modulus, case.bias, case.moves
    jz, fine = case.jacobian, case.at["fine_clips"]

    def residual(x, p):
        return (x[::k] + bias - nominal.reference).ravel() + moves @ (p * scale)

    normal = jz.T @ jz
    diagonal = np.diag(np.diag(normal))  # the damping's shape, mu diag(J^T J)
    normal = normal + 1e-12 * np.trace(normal) * np.eye(12)  # the fit's floor
    damping = CLIP_DAMPING
    x, p = case.open_loop, np.zeros(12)
    r = residual(x, p)
    cost, mu = float(r @ r), damping.initial
    for _ in range(limits.iterations):
        b = jz.T @ r
        accepted = False
        for _ in range(CHORD_TRIALS):
            trial_p = within_limits(p - np.linalg.solve(normal + mu * diagonal, b) / scale,
                                    limits)
            guess = x + (fine @ ((trial_p - p) * scale)).reshape(x.shape)
            trial = yield _Request(modulus, trial_p, True, guess)
            if trial is not None:
                r_trial = residual(trial, trial_p)
                trial_cost = float(r_trial @ r_trial)
                if trial_cost <= cost:
                    accepted = True
                    break
            mu *= damping.increase
        if not accepted:
            break
        gain = (cost - trial_cost) / cost if cost > 0 else 0.0
        x, p, r, cost = trial, trial_p, r_trial, trial_cost
        mu = max(mu / damping.decrease, damping.minimum)
        if gain < COST_TOLERANCE:
            break
    return p, x


def _closed_loop(nominal: NominalCorrection, plants: PlantChains, clamps: list,
                 states: np.ndarray, corrections: np.ndarray):
    """The plants driven from their shapes at K through the corrected clip poses (each
    sample's target correction ramped in, p_j = p_T (j - K) / (T - K)), their continuation
    going on as :func:`.plant.run_closed_loop`'s does after a correction (``states`` (B, 2,
    n + 1, 3): the stop before K's last and that one [m]; at K = 0 (B, 1, n + 1, 3) the
    settled start alone, the first stop then not predicted): a :class:`.plant_batch.PlantDrive`
    of :data:`SUBSTEPS` stops per remaining shape."""
    at, last = nominal.at, nominal.n_shapes - 1
    positions, quaternions = nominal.poses
    ramp = np.arange(0, last - at + 1) / (last - at)  # shape K (0) .. T (1)
    count = len(plants)
    p = (ramp[None, :, None] * corrections[:, None, :]).reshape(count, -1, 2, 2, 3)
    moved = positions[None, at:] + p[:, :, :, 0]  # (B, T - K + 1, 2, 3)
    turns = Rotation.from_rotvec(p[:, :, :, 1].reshape(-1, 3))
    keys = (turns * Rotation.from_quat(
        np.broadcast_to(quaternions[at:], moved.shape[:2] + (2, 4)).reshape(-1, 4))).as_quat()
    keys = keys.reshape(moved.shape[:2] + (2, 4))
    fractions = np.arange(1, SUBSTEPS + 1) / SUBSTEPS
    pairs = np.stack([keys[:, :-1], keys[:, 1:]])  # (2, B, T - K, 2, 4)
    stops_q = slerp_quaternions(np.array([0.0, 1.0]), pairs, fractions)  # (S, B, T - K, 2, 4)
    stops_q = np.moveaxis(stops_q, 0, 2).reshape(count, -1, 2, 4)
    w = fractions[None, None, :, None, None]
    stops_p = ((1.0 - w) * moved[:, :-1, None] + w * moved[:, 1:, None]).reshape(
        count, -1, 2, 3)
    return drive_chains(plants, clamps, states[:, -1], stops_p, stops_q,
                        gravity=nominal.gravity, predict_from=0 if at > 0 else 1,
                        previous=states[:, 0])
