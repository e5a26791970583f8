"""Identification experiment files (YAML or JSON), read and written (see docs/identification.md).

An identification file is a scenario reduced to ``version``, ``units``, ``cable`` (as in a
scenario, with ``youngs_modulus: identify``) and the ``identify`` section, so the ``identify``
section of a full scenario has the same format::

    version: 1
    units: m                     # lengths in the file: m or mm (converted to SI on loading)
    cable: {name: ethernet, n_links: 16, youngs_modulus: identify}
    identify:
      held: both                 # both | first (a cantilever)
      measurement_noise: 0.001   # [file units], one standard deviation per coordinate
      bounds: [1.0e+5, 1.0e+10]  # [Pa]
      simulator: branch          # branch | static | dynamic
      # measured_file: {path: shapes.csv, label: xi_0}   # instead of measured_shape
      substeps: 1                # equilibria per listed clip pose (interpolated)
      initial_shape: [[0, 0, 0.3], [0.5, 0, 0.3]]       # any number of points
      trajectory:                # clip poses, the first holding the initial shape
        - first: {position: [0.016, 0, 0.3], u: [1, 0, 0]}
          last: {position: [0.484, 0, 0.3], u: [-1, 0, 0]}
        - first: {position: [0.175, 0, 0.3], rotation: {euler: [0, -90, 0], seq: xyz}}
          last: {position: [0.325, 0, 0.3], rotation: {quaternion: [0, 0.707, 0, 0.707]}}
      measured_shape: [[...], ...]                       # any number of points

A clip pose is a ``position`` (the middle of the held end link) and either ``u``, the inward
direction of the held link (the roll does not matter to the model), or a full ``rotation``
(``clip_to_world``: Euler angles or a quaternion in scipy's x-y-z-w order).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import yaml
from pydantic import Field, model_validator
from scipy.spatial.transform import Rotation

from ..cable import Cable, catalogue_cable
from ..frames import frame_from_axis
from ..identify.experiment import Experiment, Manipulation
from ..identify.fit import DEFAULT_BOUNDS
from ..io.scenario import (
    CableSpec,
    RotationSpec,
    ScenarioError,
    parse_model,
    read_mapping,
)
from ..job_model import JobModel
from ..sim.clips import ClipPoses
from ..sim.statics import interpolate_clips
from .resolve import build_cable, rotation

Vector3 = Annotated[list[float], Field(min_length=3, max_length=3)]
Points = Annotated[list[Annotated[list[float], Field(min_length=2, max_length=3)]],
                   Field(min_length=2)]


class ClipSpec(JobModel):
    """One clip: ``position`` and either ``u`` (inward link direction) or ``rotation``."""

    position: Vector3
    u: Vector3 | None = None
    rotation: RotationSpec | None = None

    @model_validator(mode="after")
    def _one_form(self):
        if (self.u is None) == (self.rotation is None):
            raise ValueError("give exactly one of u or rotation")
        if not np.all(np.isfinite(self.position)):
            raise ValueError("position must be finite numbers")
        if self.u is not None and not (np.all(np.isfinite(self.u))
                                       and np.linalg.norm(self.u) > 1e-9):
            raise ValueError("u must be a finite, non-zero vector")
        return self

    def rotation_to_world(self):
        if self.u is not None:
            return frame_from_axis(self.u)[0]
        return rotation(self.rotation)


class ClipPairSpec(JobModel):
    """The two clips at one instant."""

    first: ClipSpec
    last: ClipSpec


class MeasuredFileSpec(JobModel):
    """A registered-shape file of the vision tools (:mod:`dloplan.vision.shapes_io`)."""

    path: str = Field(description=".csv or .json, relative to the identification file")
    label: str | None = Field(None, description="the shape to use (default: the only one)")


class IdentifySpec(JobModel):
    """The ``identify`` section: the experiment and the search settings."""

    held: Literal["both", "first"] = "both"
    measurement_noise: Annotated[float, Field(gt=0, allow_inf_nan=False)] = Field(
        0.001, description="[file units]")
    bounds: Annotated[list[Annotated[float, Field(gt=0, allow_inf_nan=False)]],
                      Field(min_length=2, max_length=2)] = Field(
        default_factory=lambda: list(DEFAULT_BOUNDS), description="[Pa]")
    simulator: Literal["branch", "static", "dynamic"] = "branch"
    substeps: Annotated[int, Field(ge=1, le=100)] = 1
    initial_shape: Points
    trajectory: Annotated[list[ClipPairSpec], Field(min_length=1)]
    measured_shape: Points | None = None
    measured_file: MeasuredFileSpec | None = None

    @model_validator(mode="after")
    def _ordered(self):
        if not self.bounds[0] < self.bounds[1]:
            raise ValueError(f"bounds must be [E_min, E_max] with E_min < E_max [Pa], got "
                             f"{self.bounds}")
        if (self.measured_shape is None) == (self.measured_file is None):
            raise ValueError("give exactly one of measured_shape (points) or measured_file (a "
                             "registered-shape file)")
        for name in ("initial_shape", "measured_shape"):
            if getattr(self, name) is not None and not np.all(
                    np.isfinite(np.asarray(getattr(self, name), dtype=float))):
                raise ValueError(f"{name} must be finite numbers")
        return self


class IdentificationFile(JobModel):
    """A standalone identification file: version, units, cable, identify."""

    version: Literal[1] = 1
    units: Literal["m", "mm"] = "m"
    cable: CableSpec
    identify: IdentifySpec


@dataclass(frozen=True, eq=False)
class IdentificationJob:
    """An identification file resolved into library objects (SI units).

    Attributes
    ----------
    cable : Cable
        The cable (its modulus is a placeholder until identified).
    experiment : Experiment
        The experiment.
    bounds : tuple of float
        (E_min, E_max) [Pa].
    simulator : str
        ``"static"`` or ``"dynamic"``.
    source : str
        Where it was read from.
    """

    cable: Cable
    experiment: Experiment
    bounds: tuple[float, float]
    simulator: str
    source: str = ""


def _points(rows, scale: float) -> np.ndarray:
    widths = {len(r) for r in rows}
    if len(widths) != 1:
        raise ValueError(f"every point needs 3 (x, y, z) or 2 (x, z) coordinates, got {widths}")
    return np.asarray(rows, dtype=float) * scale


def registered_points(path: str | Path, label: str | None = None) -> np.ndarray:
    """The points [m] of one shape of a registered-shape file (CSV or JSON of the vision tools).

    Parameters
    ----------
    path : str or Path
        The file (:func:`dloplan.vision.shapes_io.read_shapes`).
    label : str, optional
        The shape's label; required when the file holds several.
    """
    from ..vision.shapes_io import read_shapes

    shapes = read_shapes(path)
    if label is None:
        if len(shapes) != 1:
            raise ValueError(f"measured_file.label: {path} holds {len(shapes)} shapes "
                             f"({', '.join(s.label for s in shapes)}), expected the label of one")
        return shapes[0].points
    chosen = [s for s in shapes if s.label == label]
    if not chosen:
        raise ValueError(f"measured_file.label: no shape {label!r} in {path} (it holds "
                         f"{', '.join(s.label for s in shapes)})")
    return chosen[0].points


def experiment_from_spec(spec: IdentifySpec, scale: float = 1.0, name: str = "",
                         folder: str | Path = ".") -> Experiment:
    """Build the :class:`Experiment` of a validated ``identify`` section (``scale`` [m/unit]).

    A ``measured_file`` is read relative to ``folder``, in its own units (metres).
    """
    poses = [
        ClipPoses(np.array([pair.first.position, pair.last.position]) * scale,
                  Rotation.concatenate([pair.first.rotation_to_world(),
                                        pair.last.rotation_to_world()]))
        for pair in spec.trajectory
    ]
    if spec.substeps > 1:
        fractions = np.arange(1, spec.substeps + 1) / spec.substeps
        poses = [poses[0]] + [p for a, b in zip(poses, poses[1:], strict=False)
                              for p in interpolate_clips(a, b, fractions)]
    manipulation = Manipulation(_points(spec.initial_shape, scale), poses, held=spec.held)
    if spec.measured_file is not None:
        measured = registered_points(Path(folder) / spec.measured_file.path,
                                     spec.measured_file.label)
    else:
        measured = _points(spec.measured_shape, scale)
    return Experiment(manipulation, measured, measurement_noise=spec.measurement_noise * scale,
                      name=name)


MAX_NOISE_FRACTION = 0.1
"""Largest measurement noise (one sd per coordinate) as a fraction of the cable's length: more
is a noise in the wrong units (1.0 kept from a file in mm when its units became m)."""


def parse_identification(data: Any, source: str = "identification") -> IdentificationJob:
    """Validate and resolve an identification mapping (see the module docstring).

    A full scenario mapping works too: only ``units``, ``cable`` and ``identify`` are read.

    Raises
    ------
    ScenarioError
        One line naming the field, for any invalid entry.
    """
    if not isinstance(data, dict):
        raise ScenarioError(f"{source}: expected a mapping, got {type(data).__name__}")
    if "identify" not in data or data["identify"] is None:
        raise ScenarioError(f"{source}: no identify section (the experiment to identify E from)")
    wanted = {k: data[k] for k in ("version", "units", "cable", "identify") if k in data}
    spec = parse_model(IdentificationFile, wanted, source)
    scale = 1e-3 if spec.units == "mm" else 1.0
    try:
        cable = build_cable(spec.cable, scale, youngs_modulus=1e7)  # placeholder modulus
        experiment = experiment_from_spec(spec.identify, scale, name=Path(source).stem,
                                          folder=Path(source).parent)
        if experiment.measurement_noise > MAX_NOISE_FRACTION * cable.length:
            raise ValueError(
                f"identify.measurement_noise: {spec.identify.measurement_noise:g} {spec.units}, "
                f"expected less than {MAX_NOISE_FRACTION:g} of the cable's "
                f"{cable.length / scale:g} {spec.units} (the noise is in the file's units: "
                "millimetres written into a file in metres?)")
    except ValueError as exc:
        raise ScenarioError(f"{source}: {exc}") from None
    lo, hi = spec.identify.bounds
    return IdentificationJob(cable, experiment, (lo, hi), spec.identify.simulator, source)


def load_identification(path: str | Path) -> IdentificationJob:
    """Read an identification file (YAML or JSON) or a scenario with an ``identify`` section."""
    return parse_identification(read_mapping(path), str(path))


def experiment_to_dict(experiment: Experiment, cable: dict, *, bounds=DEFAULT_BOUNDS,
                       units: str = "m", decimals: int = 6) -> dict:
    """The identification-file mapping of an experiment (the inverse of the loader).

    Parameters
    ----------
    experiment : Experiment
        The experiment.
    cable : dict
        The ``cable`` entry of the file, e.g. ``{"name": "ethernet", "n_links": 16,
        "youngs_modulus": "identify"}`` (lengths in ``units``).
    bounds : (float, float)
        Search bounds [Pa].
    units : {"m", "mm"}
        Length unit of the file.
    decimals : int
        Rounding of the written lengths (in ``units``).
    """
    if units not in ("m", "mm"):
        raise ValueError(f"units: got {units!r}, expected 'm' or 'mm'")
    per_metre = 1e3 if units == "mm" else 1.0

    def rows(points) -> list[list[float]]:
        return np.round(np.asarray(points) * per_metre, decimals).tolist()

    manipulation = experiment.manipulation
    trajectory = []
    for clips in manipulation.clips:
        quats = np.round(clips.rotations.as_quat(), 9).tolist()
        pos = rows(clips.positions)
        trajectory.append({key: {"position": pos[k], "rotation": {"quaternion": quats[k]}}
                           for k, key in enumerate(("first", "last"))})
    return {
        "version": 1,
        "units": units,
        "cable": dict(cable),
        "identify": {
            "held": manipulation.held,
            "measurement_noise": float(experiment.measurement_noise * per_metre),
            "bounds": [float(b) for b in bounds],
            "simulator": "branch",
            "substeps": 1,
            "initial_shape": rows(manipulation.initial_shape),
            "trajectory": trajectory,
            "measured_shape": rows(experiment.measured_shape),
        },
    }


def dump_identification(data: dict) -> str:
    """YAML text of an identification mapping, points one per line."""
    class _Dumper(yaml.SafeDumper):
        pass

    def short_list(dumper, value):
        flow = all(not isinstance(v, list | dict) for v in value)
        return dumper.represent_sequence("tag:yaml.org,2002:seq", value, flow_style=flow)

    _Dumper.add_representer(list, short_list)
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, width=100)


def design_cable(name: str | None = None, experiment_file: str | None = None, *,
                 modulus: float | None = None, n_links: int | None = None) -> Cable:
    """The cable to design an experiment for: a catalogue name or an identification file's.

    Parameters
    ----------
    name : str, optional
        A catalogue cable (its modulus is the expected one unless ``modulus`` is given).
    experiment_file : str, optional
        An identification file (its cable; ``modulus`` is then required).
    modulus : float, optional
        The expected E [Pa].
    n_links : int, optional
        Starting discretization (default the file's, or 16).
    """
    if name is None and experiment_file is None:
        raise ValueError("design: give a catalogue cable name (--cable NAME) or an "
                         "identification file (with --modulus)")
    if name is not None and experiment_file is not None:
        raise ValueError("design: give a catalogue cable name (--cable) or an identification "
                         "file, not both")
    if name is not None:
        cable = catalogue_cable(name, n_links=n_links or 16)
    else:
        if modulus is None:
            raise ValueError("modulus: an identification file has no expected E; give "
                             "--modulus [Pa]")
        cable = load_identification(experiment_file).cable
        if n_links is not None:
            cable = cable.with_links(n_links)
    return cable if modulus is None else cable.with_modulus(modulus)
