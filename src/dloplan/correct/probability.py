"""Closed-loop success probability: many mismatched cables, open loop against corrected.

A robustness study (:mod:`dloplan.study`) samples cables around the nominal one; for each sampled
cable :func:`closed_loop_sample` runs the plan on it as a plant (:func:`~.plant.run_closed_loop`)
and returns one row, and :func:`closed_loop_success` turns the rows into the probability that
the final shape ends within a tolerance of the target, open loop and with the corrections, with
binomial confidence intervals (:func:`dloplan.study.summary.success_interval`).
:func:`closed_loop_study` does both for the samples of a study with a ``correction:`` section
(:class:`dloplan.study.spec.CorrectionSpec`): by default with the correction linearized about
the nominal plan, a chunk of samples at a time (:mod:`.linearized`, :func:`linearized_chunk`),
or with :func:`closed_loop_sample` per sample (``method: exact``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from ..cable import GRAVITY, Cable
from ..grippers import GripperPath
from ..sim import equilibrium
from ..study.backends import map_jobs
from ..study.evaluate import perturbed_cable
from ..study.sampling import Samples
from ..study.spec import CorrectionSpec, StudyError
from ..study.summary import success_interval
from .linearized import SUBSTEPS, NominalCorrection, linearized_rows, nominal_correction
from .plant import Plant, run_closed_loop

SAMPLE_COLUMNS = {
    "open_loop_error": "m",
    "closed_loop_error": "m",
    "corrections": "",
    "youngs_modulus_estimate": "Pa",
    "refusal": "",
}
"""The columns of a :func:`closed_loop_sample` row and their units."""

METHODS = ("linearized", "exact")
"""How a study's corrections are computed (:class:`dloplan.study.spec.CorrectionSpec`)."""

LINEARIZED_CHUNKS = (16, 256)
"""The default chunk of the linearized closed loop lies within these sample counts
(:func:`linearized_chunk_size`)."""


def closed_loop_sample(
    cable: Cable,
    shapes,
    grippers: GripperPath,
    plant_cable: Cable,
    checkpoints: Sequence[int],
    *,
    noise: float = 1e-3,
    n_measured: int = 200,
    seed: int = 0,
    stabilized=None,
    trajectory=None,
    gravity=GRAVITY,
    **options,
) -> dict:
    """One sampled cable run open loop and corrected at ``checkpoints``: one row. The plant
    follows the clip poses with :data:`~.linearized.SUBSTEPS` equilibria per shape, as the
    linearized method's (its open loop is this one's, bit for bit).

    Parameters
    ----------
    cable : Cable
        The plan's model cable.
    shapes, grippers, stabilized, trajectory
        The plan (see :func:`~.step.correct_plan`).
    plant_cable : Cable
        The sampled real cable.
    checkpoints : sequence of int
        Shapes after which it is measured and the plan corrected.
    noise, n_measured, seed
        The measurement (see :class:`~.plant.Plant`).
    **options
        Passed to :func:`~.step.correct_plan`.

    Returns
    -------
    dict
        :data:`SAMPLE_COLUMNS`: the final mean errors [m], the number of corrections applied,
        the last updated E [Pa] (NaN without correction) and the refusals' reasons.
    """
    run = run_closed_loop(Plant(plant_cable, noise=noise, n_measured=n_measured, seed=seed,
                                substeps=SUBSTEPS),
                          cable, shapes, grippers, checkpoints, stabilized=stabilized,
                          trajectory=trajectory, gravity=gravity, **options)
    return {
        "open_loop_error": run.open_loop_error,
        "closed_loop_error": run.closed_loop_error,
        "corrections": len(run.corrections),
        "youngs_modulus_estimate": run.corrections[-1].model.youngs_modulus
        if run.corrections else math.nan,
        "refusal": "; ".join(run.refusals),
    }


@dataclass(frozen=True)
class ClosedLoopSuccess:
    """Success probabilities of :func:`closed_loop_success`.

    Attributes
    ----------
    tolerance : float
        Largest final mean error counted as a success [m].
    trials : int
        Samples.
    open_loop, closed_loop : tuple of float
        (probability, low, high) with the confidence interval.
    refused : int
        Samples whose corrections were all refused (they ran open loop).
    method : str
        How the corrections were computed: ``"exact"`` (:func:`~.step.correct_plan` per
        sample) or ``"linearized"`` (:mod:`.linearized`: derivatives frozen at the nominal
        plan), :data:`METHODS`.
    """

    tolerance: float
    trials: int
    open_loop: tuple[float, float, float]
    closed_loop: tuple[float, float, float]
    refused: int
    method: str = "exact"

    def to_dict(self) -> dict:
        """JSON-ready values (SI units)."""
        return {"tolerance": self.tolerance, "trials": self.trials,
                "open_loop": list(self.open_loop), "closed_loop": list(self.closed_loop),
                "refused": self.refused, "method": self.method, "message": self.message}

    @property
    def message(self) -> str:
        """One line."""
        o, c = self.open_loop, self.closed_loop
        how = " (linearized correction)" if self.method == "linearized" else ""
        return (f"final error <= {1e3 * self.tolerance:.1f} mm: open loop {100 * o[0]:.0f} % "
                f"[{100 * o[1]:.0f}, {100 * o[2]:.0f}], closed loop{how} {100 * c[0]:.0f} % "
                f"[{100 * c[1]:.0f}, {100 * c[2]:.0f}] of {self.trials} samples"
                + (f" ({self.refused} corrections refused)" if self.refused else ""))


def closed_loop_success(rows: Sequence[dict], tolerance: float, *,
                        confidence: float = 0.95, method: str = "exact") -> ClosedLoopSuccess:
    """Probability that the final shape is within ``tolerance`` [m], open and closed loop."""
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"tolerance: got {tolerance!r}, expected a distance > 0 [m]")
    if len(rows) == 0:
        raise ValueError("rows: empty, expected closed_loop_sample rows")

    def estimate(column: str) -> tuple[float, float, float]:
        hits = sum(1 for row in rows if row[column] <= tolerance)
        low, high = success_interval(hits, len(rows), confidence)
        return hits / len(rows), low, high

    refused = sum(1 for row in rows if row["corrections"] == 0 and row["refusal"])
    return ClosedLoopSuccess(float(tolerance), len(rows), estimate("open_loop_error"),
                             estimate("closed_loop_error"), refused, method)


def closed_loop_study(cable: Cable, shapes, grippers: GripperPath, samples: Samples,
                      spec: CorrectionSpec, *, stabilized=None, trajectory=None,
                      confidence: float = 0.95, gravity=GRAVITY, backend=None,
                      chunk_size: int | None = None) -> tuple[list[dict], ClosedLoopSuccess]:
    """Closed-loop success of a study's sampled cables (the ``correction:`` section).

    Parameters
    ----------
    cable, shapes, grippers, stabilized, trajectory
        The plan's model cable and the plan, as for :func:`closed_loop_sample`.
    samples : Samples
        The study's samples (:func:`dloplan.study.draw_samples`): each sample's E, mass per
        length and length make its plant cable (on ``spec.plant_links`` links).
    spec : CorrectionSpec
        Checkpoint, noise [mm], measured points, tolerance [mm], plant links, sample count.
    confidence : float
        Level of the success intervals.
    backend : dloplan.study.Backend, optional
        Where the samples run (the plan is sent once per worker); default this process. A row
        depends only on its sample (its noise is seeded by its index), so every backend gives
        the same rows.
    chunk_size : int, optional
        Samples per task of the linearized method (``spec.method``; the exact one runs a
        sample per task); default :func:`linearized_chunk_size` of the sample count.

    Returns
    -------
    tuple
        ``(rows, success)``: one :func:`closed_loop_sample` row per sample (with its
        ``sample`` index), in sample order, and :func:`closed_loop_success` of them at
        ``spec.tolerance``.

    Raises
    ------
    StudyError
        ``study.correction.at`` not a shape before the target.
    """
    last = len(shapes) - 1
    if spec.at >= last:
        raise StudyError(f"study.correction.at: got {spec.at}, expected a shape 0 .. {last - 1} "
                         f"(the plan has {last + 1} shapes; the target cannot be corrected)")
    count = len(samples) if spec.samples is None else min(spec.samples, len(samples))
    columns = samples.take(range(count))
    items = [(i, columns["youngs_modulus"][i], columns["mass_per_length"][i],
              columns["length"][i]) for i in range(count)]
    if spec.method == "linearized":
        if stabilized is None:
            stabilized = [equilibrium(cable, shape, grippers.clip_poses(j), gravity=gravity).shape
                          for j, shape in enumerate(shapes)]
        plan = LinearizedPlan(nominal_correction(
            cable, shapes, grippers, spec.at, stabilized=stabilized, gravity=gravity,
            plant_links=spec.plant_links), 1e-3 * spec.noise, spec.n_measured)
        if chunk_size is None:
            chunk_size = linearized_chunk_size(count)
        chunks = [items[k : k + chunk_size] for k in range(0, count, chunk_size)]
        done = sorted(map_jobs(linearized_chunk, chunks, backend, shared=plan),
                      key=lambda pair: pair[0])
        rows = [row for _, part in done for row in part]
    else:
        plan = ClosedLoopPlan(cable, shapes, grippers, spec, stabilized, trajectory, gravity)
        rows = [row for _, row in sorted(map_jobs(closed_loop_row, items, backend, shared=plan),
                                         key=lambda pair: pair[0])]
    return rows, closed_loop_success(rows, 1e-3 * spec.tolerance, confidence=confidence,
                                     method=spec.method)


def linearized_chunk_size(count: int) -> int:
    """The linearized closed loop's samples per task by default: ``count`` / 4 rounded up,
    within :data:`LINEARIZED_CHUNKS` (two tasks for each of two workers, as large as the cap).

    A chunk's rounds (the model updates', the clip fits') cost a fixed share of Python and
    compiled calls whatever its size, about 15-30 ms of CPU a chunk on the study example at
    load 8-12 (docs/performance.md, branch cl4): 0.25-0.45 ms a sample in chunks of 64,
    0.06-0.12 in chunks of 256. The open-loop study's chunk
    (:attr:`dloplan.study.spec.StudySpec.chunk`, N / 16) is sized for its files and its whole
    sample count, not for this column's. The default does not depend on the backend: a row
    depends on its sample and, by the round-off of the chunk's batched sums (1e-16 m), on the
    chunk size, so every backend gives the same rows.
    """
    low, high = LINEARIZED_CHUNKS
    return min(high, max(low, -(-int(count) // 4)))


@dataclass(frozen=True, eq=False)
class LinearizedPlan:
    """What every chunk of the linearized closed loop shares (sent once to each worker)."""

    nominal: NominalCorrection
    noise: float
    n_measured: int


def linearized_chunk(plan: LinearizedPlan, items: list) -> list[dict]:
    """The rows of a chunk of samples (:func:`.linearized.linearized_rows`)."""
    return linearized_rows(plan.nominal, items, noise=plan.noise, n_measured=plan.n_measured)


@dataclass(frozen=True, eq=False)
class ClosedLoopPlan:
    """What every closed-loop sample of a study shares (sent once to each worker)."""

    cable: Cable
    shapes: object
    grippers: GripperPath
    spec: CorrectionSpec
    stabilized: object
    trajectory: object
    gravity: object


def closed_loop_row(plan: ClosedLoopPlan, item: tuple) -> dict:
    """The row of one sample ``(index, E [Pa], mass per length [kg/m], length [m])``: its
    plant cable run by :func:`closed_loop_sample` (noise seeded by the index); a plant that
    loses its equilibrium is a failure with the reason."""
    index, youngs_modulus, mass_per_length, length = item
    spec = plan.spec
    plant = perturbed_cable(plan.cable, youngs_modulus, mass_per_length, length)
    try:
        row = closed_loop_sample(plan.cable, plan.shapes, plan.grippers,
                                 plant.with_links(spec.plant_links or plan.cable.n_links),
                                 [spec.at], noise=1e-3 * spec.noise, n_measured=spec.n_measured,
                                 seed=index, stabilized=plan.stabilized,
                                 trajectory=plan.trajectory, gravity=plan.gravity)
    except RuntimeError as exc:  # the plant itself lost its equilibrium: a failure
        row = {"open_loop_error": math.nan, "closed_loop_error": math.nan,
               "corrections": 0, "youngs_modulus_estimate": math.nan, "refusal": str(exc)}
    return {"sample": index, **row}
