"""Loading: a job file (scenario, harness, identification) read once into a resolved job.

:func:`load_job` is the only way the commands turn a file into work: it reads the file, picks
its kind by its sections (``harness:`` -> a wire-harness job; ``identify:`` without ``start`` ->
an identification experiment; otherwise a scenario), validates it against the kind's schema and
resolves it into SI units (:mod:`dloplan.app.resolve`). A scenario whose cable says
``youngs_modulus: identify`` is identified first (thesis Fig. 6.11: measured shape -> E ->
stiffness family and weights -> plan).
"""

from __future__ import annotations

from pathlib import Path

from ..io.scenario import ScenarioError, read_mapping
from ..pipeline.document import PLAN_FORMAT
from ..pipeline.job import HarnessJob, Job
from .resolve import resolve_harness, resolve_scenario
from .schema import parse_harness, parse_scenario


def file_kind(data: dict) -> str:
    """"plan", "harness", "identification" or "scenario", by the sections of a file's mapping.

    A plan document (``format: dloplan-plan``, written by ``dloplan plan``) is no job file: it
    is read by ``dloplan verify``, ``export`` and ``simulate``.
    """
    if data.get("format") == PLAN_FORMAT:
        return "plan"
    if "harness" in data:
        return "harness"
    if "identify" in data and "start" not in data:
        return "identification"
    return "scenario"


def identify_first(data: dict, source: str, progress=lambda text: None):
    """Identify E from a scenario's ``identify:`` section; returns the Identification.

    Raises
    ------
    ValueError
        When the identification did not succeed (its one-line message).
    """
    from ..identify import identify_youngs_modulus
    from .identification import parse_identification

    setup = parse_identification(data, source)
    progress(f"identifying E of the {setup.cable.name or 'cable'} from the identify section")
    result = identify_youngs_modulus(setup.cable, setup.experiment, bounds=setup.bounds,
                                     simulator=setup.simulator)
    if not result.success:
        raise ValueError(f"{source}: identify: {result.message}")
    progress(result.message)
    return result


def resolve_mapping(data: dict, source: str, progress=lambda text: None, *,
                    allow_placement: bool = False) -> Job | HarnessJob:
    """A job file's mapping resolved: a :class:`~dloplan.pipeline.job.Job` or a
    :class:`~dloplan.pipeline.job.HarnessJob`; ``allow_placement`` lets the repair move the job
    on the table (``--allow-placement``, as the file's ``repair: {placement: true}``)."""
    kind = file_kind(data)
    if kind == "plan":
        raise ScenarioError(f"{source}: a plan document (written by dloplan plan), not a job "
                            "file: use dloplan verify (or export, simulate) on it")
    if kind == "harness":
        return resolve_harness(parse_harness(data, source), source)
    if kind == "identification":
        raise ScenarioError(f"{source}: an identification file has no job to plan (no start): "
                            "use dloplan identify")
    scenario = parse_scenario(data, source)
    if scenario.cable.youngs_modulus != "identify":
        return resolve_scenario(scenario, source, allow_placement=allow_placement)
    identification = identify_first(data, source, progress)
    return resolve_scenario(scenario, source, identification.youngs_modulus, identification,
                            allow_placement=allow_placement)


def load_job(path: str | Path, progress=lambda text: None, *,
             allow_placement: bool = False) -> Job | HarnessJob:
    """Read and resolve a job file (see the module docstring); with ``allow_placement`` the
    job may be moved on the table by the repair (:func:`resolve_mapping`).

    Returns
    -------
    Job or HarnessJob

    Raises
    ------
    ValueError
        One line naming the file and the field (:class:`~dloplan.io.scenario.ScenarioError`),
        or an identification that did not succeed.
    """
    return resolve_mapping(read_mapping(path), str(path), progress,
                           allow_placement=allow_placement)


def load_scenario(path: str | Path, progress=lambda text: None, *,
                  allow_placement: bool = False) -> Job:
    """Read and resolve a scenario file (not a harness or identification file) into a Job."""
    job = load_job(path, progress, allow_placement=allow_placement)
    if not isinstance(job, Job):
        raise ScenarioError(f"{path}: a harness job, expected a scenario with a target")
    return job
