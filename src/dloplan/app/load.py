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

from ..io.scenario import ScenarioError, parse_scenario, read_mapping
from ..pipeline.document import PLAN_FORMAT
from ..pipeline.job import Job
from .resolve import resolve_scenario


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
    from ..identify.files import parse_identification

    setup = parse_identification(data, source)
    progress(f"identifying E of the {setup.cable.name or 'cable'} from the identify section")
    result = identify_youngs_modulus(setup.cable, setup.experiment, bounds=setup.bounds,
                                     simulator=setup.simulator)
    if not result.success:
        raise ValueError(f"{source}: identify: {result.message}")
    progress(result.message)
    return result


def resolve_mapping(data: dict, source: str, progress=lambda text: None):
    """A job file's mapping resolved: a :class:`~dloplan.pipeline.job.Job` or a ``HarnessJob``."""
    kind = file_kind(data)
    if kind == "plan":
        raise ScenarioError(f"{source}: a plan document (written by dloplan plan), not a job "
                            "file: use dloplan verify (or export, simulate) on it")
    if kind == "harness":
        from ..harness.files import parse_harness, resolve_harness

        return resolve_harness(parse_harness(data, source), source)
    if kind == "identification":
        raise ScenarioError(f"{source}: an identification file has no job to plan (no start): "
                            "use dloplan identify")
    scenario = parse_scenario(data, source)
    if scenario.cable.youngs_modulus != "identify":
        return resolve_scenario(scenario, source)
    identification = identify_first(data, source, progress)
    return resolve_scenario(scenario, source, identification.youngs_modulus, identification)


def load_job(path: str | Path, progress=lambda text: None):
    """Read and resolve a job file (see the module docstring).

    Returns
    -------
    Job or HarnessJob

    Raises
    ------
    ValueError
        One line naming the file and the field (:class:`~dloplan.io.scenario.ScenarioError`),
        or an identification that did not succeed.
    """
    return resolve_mapping(read_mapping(path), str(path), progress)


def load_scenario(path: str | Path, progress=lambda text: None) -> Job:
    """Read and resolve a scenario file (not a harness or identification file) into a Job."""
    job = load_job(path, progress)
    if not isinstance(job, Job):
        raise ScenarioError(f"{path}: a harness job, expected a scenario with a target")
    return job
