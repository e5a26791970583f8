"""One sample of a study: the planned path on a perturbed cable, clips and obstacles.

For each sample the cable is rebuilt with the sampled E, mass per length and length, the clips
of every shape are moved by the sampled errors, and every shape is stabilized under gravity
(:func:`dloplan.sim.statics.equilibrium`, the same solver the planner and the verification use)
warm-started from the nominal stabilized shape, so that each sample stays on the nominal
equilibrium branch unless the perturbation really removes it. Then, per shape:

* convergence and elastic stability of the equilibrium (positive-definite Hessian);
* ``deviation``: the largest point distance from the nominal stabilized shape [m];
* ``displacement``: the largest point distance from the planned shape [m] (for the target, the
  thesis' stability check against T_cf, 5.3);
* ``sag``: how far the cable hangs below its lower clip point [m];
* collisions of the links as capsules with the perturbed obstacles
  (as :func:`dloplan.obstacles.check_shape` does) and the deepest penetration [m];
* the peak link tension [N], the largest clip force [N] and clip moment [N m]
  (:attr:`Equilibrium.clip_wrenches`).

The inputs are plain arrays (planned shapes, clip poses per shape, the nominal cable,
obstacles), so a study runs on any path: a :class:`~dloplan.planning.Plan`'s, a recorded one, or
just a start and a target.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import GRAVITY, Cable
from ..geometry import link_vectors, norms
from ..obstacles.shapes import Box, Cylinder, Table
from ..physics.chain import SpringChain, link_tensions
from ..sim.batch import held_equilibria
from ..sim.clips import ClipPoses, clip_poses_from_shape
from ..sim.statics import equilibrium
from .sampling import AXES

OUTCOME_COLUMNS: dict[str, str] = {
    "converged": "",
    "stable": "",
    "iterations": "",
    "residual": "N",
    "deviation": "m",
    "displacement": "m",
    "sag": "m",
    "collision": "",
    "penetration": "m",
    "max_tension": "N",
    "clip_force": "N",
    "clip_moment": "N m",
    "message": "",
}
"""The measured columns of a study table (one row per sample and shape) with their units."""

COLUMN_TYPES = {"sample": "int64", "shape": "int64", "converged": "bool", "stable": "bool",
                "iterations": "int64", "collision": "bool", "message": "string"}
"""Stored type of the columns that are not float64."""


@dataclass(frozen=True, eq=False)
class StudyProblem:
    """The nominal plan a study perturbs.

    Attributes
    ----------
    cable : Cable
        The nominal cable.
    planned : numpy.ndarray
        (S + 2, n + 1, 3) planned shapes [m], start and target included.
    clips : tuple of ClipPoses
        The nominal clip poses of every shape.
    nominal : numpy.ndarray
        (S + 2, n + 1, 3) the planned shapes stabilized on the nominal cable [m].
    obstacles : tuple
        Nominal obstacles (:class:`~dloplan.obstacles.Box`, ``Cylinder``, ``Table``).
    gravity : numpy.ndarray
        (3,) gravity [m/s^2].
    """

    cable: Cable
    planned: np.ndarray
    clips: tuple
    nominal: np.ndarray
    obstacles: tuple
    gravity: np.ndarray

    @property
    def n_shapes(self) -> int:
        """Number of shapes S + 2 (start and target included)."""
        return len(self.planned)


def study_problem(
    cable: Cable,
    shapes,
    clips: Sequence[ClipPoses] | None = None,
    obstacles: Sequence = (),
    *,
    gravity=GRAVITY,
) -> StudyProblem:
    """Prepare a study: check the inputs and stabilize every planned shape on the nominal cable.

    Parameters
    ----------
    cable : Cable
        The nominal cable.
    shapes : array_like
        (S + 2, n + 1, 3) planned shapes [m] (a plan's ``path``), or any k >= 1 shapes.
    clips : sequence of ClipPoses, optional
        Nominal clip poses per shape (e.g. from the gripper frames); default: read off each
        shape's end links (:func:`~dloplan.sim.clips.clip_poses_from_shape`).
    obstacles : sequence
        Obstacles checked for collisions.
    gravity : array_like
        (3,) gravity [m/s^2].

    Raises
    ------
    ValueError
        Wrong shapes, a clip count that does not match, or a shape whose nominal equilibrium
        does not converge to a stable state (the study would have no reference).
    """
    path = np.asarray(shapes, dtype=float)
    if path.ndim != 3 or path.shape[1:] != (cable.n_points, 3) or len(path) == 0:
        raise ValueError(f"shapes: got an array of shape {path.shape}, expected "
                         f"(k, {cable.n_points}, 3) for a cable of {cable.n_links} links")
    if not np.all(np.isfinite(path)):
        raise ValueError("shapes: non-finite coordinate (NaN or inf)")
    if clips is None:
        clips = [clip_poses_from_shape(shape) for shape in path]
    clips = tuple(clips)
    if len(clips) != len(path) or not all(isinstance(c, ClipPoses) for c in clips):
        raise ValueError(f"clips: expected {len(path)} ClipPoses (one per shape), got "
                         f"{len(clips)} items")
    gravity = np.asarray(gravity, dtype=float)
    if gravity.shape != (3,) or not np.all(np.isfinite(gravity)):
        raise ValueError(f"gravity: got {gravity!r}, expected 3 finite numbers [m/s^2]")
    chain = SpringChain.from_cable(cable, gravity)
    nominal = []
    for k, (shape, clip) in enumerate(zip(path, clips, strict=True)):
        eq = equilibrium(cable, shape, clip, gravity=gravity, chain=chain)
        if not eq.success:
            raise ValueError(f"shapes[{k}]: the nominal equilibrium failed ({eq.message})")
        nominal.append(eq.shape)
    return StudyProblem(cable, path, clips, np.stack(nominal), tuple(obstacles), gravity)


def perturbed_cable(cable: Cable, youngs_modulus: float, mass_per_length: float,
                    length: float) -> Cable:
    """The cable with another E [Pa], weight per length [kg/m] and length [m].

    A curved rest shape is scaled with the length (its bending angles are kept).
    """
    rest = cable.rest_shape
    if rest is not None:
        rest = rest * (length / cable.length)
    return replace(cable, youngs_modulus=youngs_modulus, length=length,
                   mass=mass_per_length * length, rest_shape=rest)


def perturbed_clips(clips: ClipPoses, offsets: np.ndarray, rotvecs) -> ClipPoses:
    """Clips moved by world-frame ``offsets`` (2, 3) [m] and turned by ``rotvecs`` (2, 3) [rad].

    The rotation error acts in the clip frame (``clip_to_world * error``): a gripper that holds
    the cable slightly askew, whatever the clip's orientation. ``rotvecs`` may also be the two
    error rotations themselves (a :class:`~scipy.spatial.transform.Rotation`), built once for
    the shapes of a sample.
    """
    errors = rotvecs if isinstance(rotvecs, Rotation) else Rotation.from_rotvec(rotvecs)
    return ClipPoses(clips.positions + offsets, clips.rotations * errors)


def perturbed_obstacle(obstacle, offset: np.ndarray):
    """An obstacle translated by ``offset`` (3,) [m]; a table only moves along z."""
    if isinstance(obstacle, Box):
        return replace(obstacle, center=tuple(np.add(obstacle.center, offset)))
    if isinstance(obstacle, Cylinder):
        return replace(obstacle, base=tuple(np.add(obstacle.base, offset)))
    if isinstance(obstacle, Table):
        return replace(obstacle, height=obstacle.height + float(offset[2]))
    raise ValueError(f"obstacles: cannot move {type(obstacle).__name__}, expected a Box, "
                     "Cylinder or Table")


def _vectors(row: dict, prefix: str, kind: str, count: int) -> np.ndarray:
    return np.array([[row[f"{prefix}{k}_{kind}{a}"] for a in AXES] for k in range(count)],
                    dtype=float).reshape(count, 3)


def evaluate_sample(problem: StudyProblem, row: dict) -> dict:
    """Evaluate one sample: the outcome columns of each of its S + 2 shapes.

    Parameters
    ----------
    problem : StudyProblem
        The nominal plan.
    row : dict
        One sample's parameter values (a row of :class:`~dloplan.study.sampling.Samples`).

    Returns
    -------
    dict
        :data:`OUTCOME_COLUMNS` -> list of S + 2 values. A sample whose cable cannot be built or
        whose clips are out of its reach is recorded as not converged, with the reason in
        ``message``; it never stops the study.
    """
    out: dict[str, list] = {name: [] for name in OUTCOME_COLUMNS}
    try:
        cable = perturbed_cable(problem.cable, row["youngs_modulus"], row["mass_per_length"],
                                row["length"])
        chain = SpringChain.from_cable(cable, problem.gravity)
        obstacles = [perturbed_obstacle(o, d) for o, d in zip(
            problem.obstacles, _vectors(row, "obstacle", "d", len(problem.obstacles)),
            strict=True)]
    except ValueError as exc:
        for _ in range(problem.n_shapes):
            _failed(out, f"sample: {exc}")
        return out
    offsets = _vectors(row, "clip", "d", 2)
    errors = Rotation.from_rotvec(_vectors(row, "clip", "r", 2))
    radius = cable.diameter / 2.0
    for k in range(problem.n_shapes):
        clips = perturbed_clips(problem.clips[k], offsets, errors)
        try:
            eq = equilibrium(cable, problem.nominal[k], clips, gravity=problem.gravity,
                             chain=chain)
        except ValueError as exc:
            _failed(out, str(exc))
            continue
        x = eq.shape
        penetration = deepest_penetration(x, obstacles, radius)
        values = {
            "converged": eq.converged,
            "stable": eq.stable,
            "iterations": eq.iterations,
            "residual": eq.residual,
            "deviation": _largest_distance(x, problem.nominal[k]),
            "displacement": _largest_distance(x, problem.planned[k]),
            "sag": float(clips.positions[:, 2].min() - x[:, 2].min()),
            "collision": penetration > 0.0,
            "penetration": penetration,
            "max_tension": float(link_tensions(chain, x).max()),
            "clip_force": float(np.linalg.norm(eq.clip_wrenches[:, :3], axis=1).max()),
            "clip_moment": float(np.linalg.norm(eq.clip_wrenches[:, 3:], axis=1).max()),
            "message": "" if eq.success else eq.message,
        }
        for name, value in values.items():
            out[name].append(value)
    return out


def deepest_penetration(shape: np.ndarray, obstacles: Sequence, radius: float) -> float:
    """How deep the links of ``shape`` (n + 1, 3), capsules of ``radius`` [m], enter the
    obstacles [m]: > 0 a collision, <= 0 the clearance, NaN without obstacles.

    The ``colliding`` and ``penetration`` of :func:`dloplan.obstacles.check_shape`, without its
    report (the lift that would clear the shape, the links hit), which a study does not keep.
    """
    a, b = shape[:-1], shape[1:]
    depths = [float(obstacle.penetration(a, b, radius).max()) for obstacle in obstacles]
    return max(depths) if depths else np.nan


def _largest_distance(x: np.ndarray, y: np.ndarray) -> float:
    """Largest point distance between two shapes (n + 1, 3) [m]."""
    d = x - y
    return math.sqrt(float(np.max(np.einsum("ij,ij->i", d, d))))


def _failed(out: dict, message: str) -> None:
    """Record a shape that could not be evaluated: not converged, measurements NaN."""
    for name in OUTCOME_COLUMNS:
        out[name].append(
            {"converged": False, "stable": False, "iterations": 0, "collision": False,
             "message": message}.get(name, np.nan))


def evaluate_chunk(problem: StudyProblem, chunk: dict) -> dict:
    """Evaluate a chunk of samples; the tidy rows (sample x shape) of the study table.

    What :func:`evaluate_sample` does for each sample, batched: the chunk's cables and clip
    poses are arrays, every (sample, shape) equilibrium is solved in one compiled loop
    (:func:`dloplan.sim.batch.held_equilibria`: each item bit for bit ``equilibrium``'s), and
    the measurements are taken on all of them at once. The rows equal :func:`evaluate_sample`'s
    (tested).

    Parameters
    ----------
    problem : StudyProblem
        The nominal plan.
    chunk : dict
        ``"sample"``: (m,) sample indices, plus every parameter column (m,).

    Returns
    -------
    dict
        Column -> (m (S + 2),) array: ``sample``, ``shape``, the parameters (repeated on the
        rows of their sample) and :data:`OUTCOME_COLUMNS`, sample-major.
    """
    s = problem.n_shapes
    samples = np.asarray(chunk["sample"], dtype=np.int64)
    params = [name for name in chunk if name != "sample"]
    values = {name: np.asarray(chunk[name], dtype=float) for name in params}
    m = len(samples)
    obstacle_offsets = _columns(values, "obstacle", "d", len(problem.obstacles))
    cables, obstacles, failures = [], [], {}
    for j in range(m):
        try:
            cable = perturbed_cable(problem.cable, values["youngs_modulus"][j],
                                    values["mass_per_length"][j], values["length"][j])
            moved = [perturbed_obstacle(o, d)
                     for o, d in zip(problem.obstacles, obstacle_offsets[j], strict=True)]
        except ValueError as exc:
            failures[j] = f"sample: {exc}"
            continue
        cables.append(cable)
        obstacles.append(moved)
    valid = np.array([j for j in range(m) if j not in failures], dtype=np.int64)
    measured = _measure(problem, cables, obstacles, _columns(values, "clip", "d", 2)[valid],
                        _columns(values, "clip", "r", 2)[valid])
    rows: dict[str, list] = {name: [] for name in OUTCOME_COLUMNS}
    position = {j: i for i, j in enumerate(valid)}
    for j in range(m):
        for k in range(s):
            if j in failures:
                _failed(rows, failures[j])
                continue
            for name in OUTCOME_COLUMNS:
                rows[name].append(measured[name][position[j] * s + k])
    table = {"sample": np.repeat(samples, s), "shape": np.tile(np.arange(s, dtype=np.int64),
                                                                len(samples))}
    table.update({name: np.repeat(values[name], s) for name in params})
    for name in OUTCOME_COLUMNS:
        table[name] = _column(name, rows[name])
    return table


def _columns(values: dict, prefix: str, kind: str, count: int) -> np.ndarray:
    """The (m, count, 3) offsets or rotation vectors of every sample of a chunk."""
    m = len(values["youngs_modulus"])
    columns = [values[f"{prefix}{k}_{kind}{a}"] for k in range(count) for a in AXES]
    return np.stack(columns, axis=-1).reshape(m, count, 3) if count else np.zeros((m, 0, 3))


def _measure(problem: StudyProblem, cables: list, obstacles: list, offsets: np.ndarray,
             rotvecs: np.ndarray) -> dict:
    """:data:`OUTCOME_COLUMNS` of every shape of the m valid samples of a chunk, sample-major
    lists of m (S + 2) values: their cables, moved obstacles, clip offsets (m, 2, 3) [m] and
    rotation vectors (m, 2, 3) [rad]."""
    m, s = len(cables), problem.n_shapes
    if m == 0:
        return {name: [] for name in OUTCOME_COLUMNS}
    nominal_positions = np.stack([c.positions for c in problem.clips])  # (S, 2, 3)
    positions = nominal_positions[None] + offsets[:, None]  # (m, S, 2, 3)
    nominal_rotations = Rotation.concatenate([c.rotations for c in problem.clips])
    errors = Rotation.from_rotvec(rotvecs.reshape(-1, 3))
    # item (sample j, shape k), clip c: the nominal rotation 2 k + c times the error 2 j + c
    nominal_index = 2 * np.arange(s)[None, :, None] + np.arange(2)
    error_index = 2 * np.arange(m)[:, None, None] + np.arange(2)
    rotations = (nominal_rotations[np.broadcast_to(nominal_index, (m, s, 2)).ravel()]
                 * errors[np.broadcast_to(error_index, (m, s, 2)).ravel()])
    result = held_equilibria(cables, np.repeat(np.arange(m), s),
                             np.tile(problem.nominal, (m, 1, 1)), positions.reshape(-1, 2, 3),
                             rotations, gravity=problem.gravity)
    x = result.shapes.reshape(m, s, -1, 3)
    radius = problem.cable.diameter / 2.0
    penetration = np.full((m, s), np.nan)
    if problem.obstacles:  # each sample's obstacles against all its shapes' links at once
        a, b = x[:, :, :-1], x[:, :, 1:]
        for j, moved in enumerate(obstacles):
            penetration[j] = np.max([o.penetration(a[j], b[j], radius).max(axis=-1)
                                     for o in moved], axis=0)
    penetration = penetration.ravel()
    k_s = np.array([c.k_axial for c in cables])[:, None, None]
    rest = np.array([np.full(c.n_links, c.rest_link_length) for c in cables])[:, None, :]
    tensions = k_s * (norms(link_vectors(x)) - rest)
    success = result.success
    measured = {
        "converged": result.converged,
        "stable": result.stable,
        "iterations": result.iterations,
        "residual": result.residuals,
        "deviation": _largest_distances(x, problem.nominal[None]),
        "displacement": _largest_distances(x, problem.planned[None]),
        "sag": (positions[..., 2].min(axis=-1) - x[..., 2].min(axis=-1)).ravel(),
        "collision": penetration > 0.0,
        "penetration": penetration,
        "max_tension": tensions.max(axis=-1).ravel(),
        "clip_force": np.linalg.norm(result.clip_wrenches[..., :3], axis=-1).max(axis=-1),
        "clip_moment": np.linalg.norm(result.clip_wrenches[..., 3:], axis=-1).max(axis=-1),
        "message": ["" if ok else message for ok, message in zip(success, result.messages,
                                                                 strict=True)],
    }
    out = {name: list(value) for name, value in measured.items()}
    for b in np.flatnonzero(result.refused):  # equilibrium refused: as evaluate_sample records
        failed: dict[str, list] = {name: [] for name in OUTCOME_COLUMNS}
        _failed(failed, result.messages[b])
        for name in OUTCOME_COLUMNS:
            out[name][b] = failed[name][0]
    return out


def _largest_distances(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """:func:`_largest_distance` of shapes (m, S, n + 1, 3) to y (broadcast), (m S,)."""
    d = x - y
    return np.sqrt(np.max(np.einsum("...ij,...ij->...i", d, d), axis=-1)).ravel()


def _column(name: str, values: list) -> np.ndarray:
    dtype = {"bool": bool, "int64": np.int64, "string": object}.get(COLUMN_TYPES.get(name), float)
    return np.asarray(values, dtype=dtype)
