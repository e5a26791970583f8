"""Study descriptions: defaults, units, and one-line errors naming the field."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dloplan.study import StudyError, StudySpec, parse_study


def test_defaults_and_si_spreads():
    spec = parse_study({"parameters": {"youngs_modulus": {"spread": 20},
                                       "clip_position": {"spread": 1.5},
                                       "clip_orientation": {"spread": 2}}})
    assert spec.samples == 100 and spec.sampler == "lhs" and spec.seed == 0
    assert spec.distribution("youngs_modulus") == "lognormal"
    assert spec.distribution("clip_position") == "normal"
    assert spec.spread_si("youngs_modulus") == pytest.approx(0.20)
    assert spec.spread_si("clip_position") == pytest.approx(1.5e-3)
    assert spec.spread_si("clip_orientation") == pytest.approx(math.radians(2))
    assert spec.criteria.max_deviation == 20.0 and spec.criteria.collision_free
    assert parse_study(None) == StudySpec()


@pytest.mark.parametrize(
    ("data", "field", "words"),
    [
        ({"parameters": {"youngs_modulus": {"spread": -5}}},
         "study.parameters.youngs_modulus.spread", "greater than or equal to 0"),
        ({"samples": 0}, "study.samples", "greater than or equal to 1"),
        ({"parameters": {"length": {"distribution": "weibull", "spread": 1}}},
         "study.parameters.length.distribution", "'lognormal', 'normal' or 'uniform'"),
        ({"parameters": {"stiffness": {"spread": 1}}},
         "study.parameters", "unknown parameter 'stiffness'"),
        ({"parameters": {"clip_position": {"distribution": "lognormal", "spread": 1}}},
         "study.parameters", "signed error"),
        ({"sampler": "sobol"}, "study.sampler", "'lhs' or 'random'"),
        ({"criteria": {"max_sag": 0}}, "study.criteria.max_sag", "greater than 0"),
        ({"sample": 10}, "study.sample", "Extra inputs are not permitted"),
    ],
)
def test_bad_specs_name_the_field(data, field, words):
    with pytest.raises(StudyError) as info:
        parse_study(data)
    message = str(info.value)
    assert message.startswith(field + ":"), message
    assert words in message
    assert "\n" not in message


def test_not_a_mapping():
    with pytest.raises(StudyError, match="study: expected a mapping, got list"):
        parse_study([1, 2])


SCENARIO = """units: mm
cable: {name: ethernet, n_links: 8}
start: {kind: arc, angle: 150, placement: {position: [0, 0, 200], rotation: {euler: [90, 0, 0]}}}
target: {kind: arc, angle: 170, placement: {position: [0, 0, 200], rotation: {euler: [90, 0, 0]}}}
study:
  samples: 8
  parameters:
    youngs_modulus: {spread: SPREAD}
"""


def test_scenario_file_with_a_study_section(tmp_path):
    from dloplan.app import load_scenario
    from dloplan.app.study import study_spec
    from dloplan.io.scenario import ScenarioError

    path = tmp_path / "job.yaml"
    path.write_text(SCENARIO.replace("SPREAD", "20"))
    job = load_scenario(path)
    spec = study_spec(job)
    assert spec.samples == 8 and spec.spread_si("youngs_modulus") == pytest.approx(0.2)
    assert study_spec(job, samples=3, seed=4).samples == 3
    for samples in (0, -5):  # overrides pass the same schema
        with pytest.raises(StudyError, match=r"job.yaml: study.samples: "):
            study_spec(job, samples=samples)
    path.write_text(SCENARIO.replace("SPREAD", "-1"))
    with pytest.raises(ScenarioError, match=r"job.yaml: study.parameters.youngs_modulus.spread: "):
        load_scenario(path)
    path.write_text(SCENARIO.split("study:")[0])
    with pytest.raises(StudyError, match="no study section: nothing to vary"):
        study_spec(load_scenario(path))


def test_a_zero_spread_study_reproduces_the_plan_of_dloplan_plan(tmp_path):
    from dloplan.app import load_scenario, run_job
    from dloplan.app.study import study_problem_of, study_spec
    from dloplan.study import run_study

    path = tmp_path / "job.yaml"
    path.write_text(SCENARIO.replace("SPREAD", "0"))
    job = load_scenario(path)
    doc = run_job(job)  # what dloplan plan computes and writes
    problem = study_problem_of(doc)
    assert np.array_equal(problem.nominal, doc.stabilized)
    assert np.array_equal(problem.planned, doc.shapes)
    result = run_study(problem, study_spec(job))
    assert result.table["shape"].max() == doc.n_shapes + 1
    assert result.summary.n_success == 8  # zero spread: the nominal plan, which passes
    assert np.max(result.table["deviation"]) < 1e-9  # every sample settles on the plan's shapes


def test_the_package_gives_each_name_from_its_submodule():
    """``dloplan.study`` imports a submodule when one of its names is first read (a scenario's
    schema needs ``.spec`` alone): every exported name is the submodule's own object, and a name
    it does not export is an AttributeError."""
    import importlib

    import dloplan.study as study

    for name in study.__all__:
        value = getattr(study, name)
        assert value.__module__.startswith("dloplan.study.")
        assert value is getattr(importlib.import_module(value.__module__), name)
    with pytest.raises(AttributeError, match="has no attribute 'nothing'"):
        study.nothing  # noqa: B018
