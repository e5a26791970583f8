"""Per-sample parameter draws: a design in the unit cube, mapped to the varied parameters.

The design is an (N, d) array of numbers in (0, 1), one column per varied scalar (a clip error
is 6 scalars: 3 axes of 2 clips; an obstacle error 3 per obstacle). It depends on the seed and
the sample count only, never on chunking or on the backend, so every backend evaluates the same
samples:

* ``"lhs"`` (default): a scrambled Latin hypercube, ``scipy.stats.qmc.LatinHypercube(d,
  seed=seed)``, drawn once for all N samples (each of the N strata of every parameter holds
  exactly one sample, which is what makes LHS better than random draws at small N);
* ``"random"``: row i drawn from its own generator ``SeedSequence(seed, spawn_key=(i,))``: any
  subset of samples can be regenerated alone, and the first N of a larger study are the N of a
  smaller one.

A column u becomes a parameter value by the inverse CDF of its distribution (spread s in SI):

* relative parameters (E, m/L, L): a factor f times the nominal value, with f = exp(sigma z),
  sigma = sqrt(ln(1 + s^2)) (``lognormal``: median 1, coefficient of variation s), f = 1 + s z
  (``normal``), f = 1 + s (2u - 1) (``uniform``), z = Phi^-1(u);
* offsets (clip position [m], clip orientation [rad], obstacle position [m]): s z or s (2u - 1).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation
from scipy.special import ndtri

from ..cable import Cable
from ..frames import table_frame
from ..obstacles.shapes import Table
from .spec import PARAMETERS, RELATIVE, StudySpec

U_EPS = 1e-12
"""Design values are clipped to [U_EPS, 1 - U_EPS] so the normal inverse CDF stays finite."""

AXES = ("x", "y", "z")

UNITS = {"youngs_modulus": "Pa", "mass_per_length": "kg/m", "length": "m",
         "clip_position_error": "m", "clip_orientation_error": "rad",
         "obstacle_position_error": "m"}
"""Units of the scalar parameter columns; offset columns are m (``_d*``) or rad (``_r*``)."""


def parameter_columns(n_obstacles: int) -> dict[str, str]:
    """Every parameter column of a study table with its unit, in table order."""
    columns = {name: UNITS[name] for name in RELATIVE}
    for k in range(2):
        columns.update({f"clip{k}_d{a}": "m" for a in AXES})
    for k in range(2):
        columns.update({f"clip{k}_r{a}": "rad" for a in AXES})
    for k in range(n_obstacles):
        columns.update({f"obstacle{k}_d{a}": "m" for a in AXES})
    for name in ("clip_position_error", "clip_orientation_error", "obstacle_position_error"):
        columns[name] = UNITS[name]
    return columns


def _dimensions(spec: StudySpec, n_obstacles: int) -> list[tuple[str, list[str]]]:
    """(parameter, its columns) for every varied parameter, in the fixed order of PARAMETERS."""
    out = []
    for name in PARAMETERS:
        if name not in spec.parameters:
            continue
        if name in RELATIVE:
            cols = [name]
        elif name == "clip_position":
            cols = [f"clip{k}_d{a}" for k in range(2) for a in AXES]
        elif name == "clip_orientation":
            cols = [f"clip{k}_r{a}" for k in range(2) for a in AXES]
        else:
            cols = [f"obstacle{k}_d{a}" for k in range(n_obstacles) for a in AXES]
        if cols:
            out.append((name, cols))
    return out


def design(spec: StudySpec, dimension: int) -> np.ndarray:
    """The (N, d) design in (0, 1) of a study (see the module docstring)."""
    n = spec.samples
    if dimension == 0:
        return np.empty((n, 0))
    if spec.sampler == "lhs":
        from scipy.stats import qmc  # scipy.stats costs ~1 s to import: only when sampling

        u = qmc.LatinHypercube(dimension, seed=np.random.default_rng(spec.seed)).random(n)
    else:
        u = np.stack([
            np.random.default_rng(np.random.SeedSequence(spec.seed, spawn_key=(i,))).random(
                dimension)
            for i in range(n)
        ])
    return np.clip(u, U_EPS, 1.0 - U_EPS)


def _transform(u: np.ndarray, distribution: str, spread: float, relative: bool) -> np.ndarray:
    if distribution == "uniform":
        value = spread * (2.0 * u - 1.0)
    elif distribution == "normal":
        value = spread * ndtri(u)
    else:  # lognormal (relative parameters only: the spec guarantees it)
        return np.exp(math.sqrt(math.log1p(spread**2)) * ndtri(u))
    return 1.0 + value if relative else value


@dataclass(frozen=True, eq=False)
class Samples:
    """The parameter values of every sample, SI units (see :func:`parameter_columns`).

    Attributes
    ----------
    columns : dict of str to numpy.ndarray
        Column name -> (N,) values; E [Pa], m/L [kg/m], L [m], clip offsets [m] and rotation
        vectors [rad], obstacle offsets [m], and the error magnitudes.
    """

    columns: dict

    def __len__(self) -> int:
        return len(self.columns["youngs_modulus"])

    def take(self, indices) -> dict:
        """The columns restricted to the given sample indices (a chunk's parameters)."""
        idx = np.asarray(indices, dtype=int)
        return {name: values[idx] for name, values in self.columns.items()}


def _check_positive(spec: StudySpec, name: str, values: np.ndarray) -> None:
    """Refuse a relative parameter's draws that are not a cable: a mass, length or E <= 0."""
    bad = np.flatnonzero(values <= 0.0)
    if bad.size:
        raise ValueError(
            f"study.parameters.{name}: a {spec.distribution(name)} spread of "
            f"{spec.parameters[name].spread:g} % draws {bad.size} of {len(values)} samples at or "
            f"below zero (sample {bad[0]}: {values[bad[0]]:.3g} {UNITS[name]}); expected a "
            "spread that keeps every sample positive (lognormal keeps it positive at any "
            "spread)")


def draw_samples(spec: StudySpec, cable: Cable, obstacles: Sequence = (),
                 job_to_world: Rotation | None = None) -> Samples:
    """Parameter values of the N samples of a study on ``cable`` among ``obstacles``.

    The clip and obstacle offsets are drawn in the job's frame on the table
    (:func:`dloplan.frames.table_frame`, ``job_to_world``) and recorded in the world frame,
    where they are applied: the same job turned on the table gets the same samples, turned
    with it (each sample's verdicts and metrics the same).

    Parameters
    ----------
    spec : StudySpec
        Sample count, seed, sampler and the varied parameters.
    cable : Cable
        The nominal cable (E [Pa], m/L [kg/m], L [m]).
    obstacles : sequence
        The nominal obstacles; a :class:`~dloplan.obstacles.Table` only moves along z.
    job_to_world : Rotation, optional
        The job's frame on the table (a turn about z; :func:`study_frame`); default the
        world frame.

    Returns
    -------
    Samples
        N values of every column, the same for the same spec whatever evaluates them.

    Raises
    ------
    ValueError
        Naming the parameter when a normal or uniform spread draws an E, m/L or L <= 0.
    """
    n = spec.samples
    nominal = {"youngs_modulus": cable.youngs_modulus,
               "mass_per_length": cable.mass / cable.length, "length": cable.length}
    columns = {name: np.full(n, 0.0) for name in parameter_columns(len(obstacles))}
    for name, value in nominal.items():
        columns[name][:] = value
    dims = _dimensions(spec, len(obstacles))
    u = design(spec, sum(len(cols) for _, cols in dims))
    start = 0
    for name, cols in dims:
        values = _transform(u[:, start:start + len(cols)], spec.distribution(name),
                            spec.spread_si(name), name in RELATIVE)
        start += len(cols)
        for j, col in enumerate(cols):
            columns[col] = nominal[name] * values[:, j] if name in RELATIVE else values[:, j]
        if name in RELATIVE:
            _check_positive(spec, name, columns[name])
    if job_to_world is not None:
        for prefix, count in (("clip", 2), ("obstacle", len(obstacles))):
            for k in range(count):
                names = [f"{prefix}{k}_d{a}" for a in AXES]
                turned = job_to_world.apply(np.stack([columns[c] for c in names], axis=-1))
                for j, name in enumerate(names):
                    columns[name] = np.ascontiguousarray(turned[:, j])
    for k, obstacle in enumerate(obstacles):
        if isinstance(obstacle, Table):  # a plane moves along its normal only
            columns[f"obstacle{k}_dx"][:] = 0.0
            columns[f"obstacle{k}_dy"][:] = 0.0

    columns["clip_position_error"] = _largest_norm(columns, "clip", "d", 2)
    columns["clip_orientation_error"] = _largest_norm(columns, "clip", "r", 2)
    columns["obstacle_position_error"] = _largest_norm(columns, "obstacle", "d", len(obstacles))
    return Samples(columns)


def study_frame(start_clips) -> Rotation:
    """The job's frame on the table of a study (:func:`dloplan.frames.table_frame`): y along
    the start's chord from clip 0 to clip 1, else along the first clip's axes.

    Parameters
    ----------
    start_clips : ClipPoses
        The clip poses of the start shape.
    """
    chord = start_clips.positions[1] - start_clips.positions[0]
    return table_frame(np.vstack([chord, start_clips.rotations[0].as_matrix().T]))


def _largest_norm(columns: dict, prefix: str, kind: str, count: int) -> np.ndarray:
    """Largest norm over ``count`` vectors stored as columns ``{prefix}{k}_{kind}{axis}``."""
    n = len(columns["youngs_modulus"])
    if count == 0:
        return np.zeros(n)
    vectors = np.stack([[columns[f"{prefix}{k}_{kind}{a}"] for a in AXES] for k in range(count)])
    return np.linalg.norm(vectors, axis=1).max(axis=0)
