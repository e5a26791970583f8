"""Study descriptions: defaults, units, and one-line errors naming the field."""

from __future__ import annotations

import math

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
    from dloplan.study import job_problem, load_study

    path = tmp_path / "job.yaml"
    path.write_text(SCENARIO.replace("SPREAD", "20"))
    job, spec = load_study(path)
    assert spec.samples == 8 and spec.spread_si("youngs_modulus") == pytest.approx(0.2)
    problem = job_problem(job)
    assert problem.planned.shape == (2, 9, 3)
    path.write_text(SCENARIO.replace("SPREAD", "-1"))
    with pytest.raises(StudyError, match=r"job.yaml: study.parameters.youngs_modulus.spread: "):
        load_study(path)


def test_a_planned_path_is_studied(tmp_path):
    from dloplan.planning import plan
    from dloplan.study import job_problem, load_study, run_study

    path = tmp_path / "job.yaml"
    path.write_text(SCENARIO.replace("SPREAD", "0"))
    job, spec = load_study(path)
    planned = plan(job.cable, job.start, job.target, 3)
    result = run_study(job_problem(job, path=planned.path), spec)
    assert result.table["shape"].max() == 4  # S + 2 = 5 shapes
    assert result.summary.n_success == 8  # zero spread: the nominal plan, which passes
