"""The study workers' server preload (:mod:`dloplan.warm_study`): it runs the warm-up's study
exercise (:func:`dloplan.warmup.study`, the one study exercise), which reaches the kernels a
study's tasks call (the preload swallows its own errors in the server, so a broken exercise
would only show as cold workers)."""

from __future__ import annotations


def test_the_exercise_runs_the_kernels_of_a_studys_tasks():
    import dloplan.warm_study as warm
    from dloplan import warmup
    from dloplan.correct.plant_batch import drive_clamped
    from dloplan.sim.batch import solve_held
    from dloplan.study.backends import STUDY_PRELOAD

    assert warm.study is warmup.study  # the warm-up's exercise, not a copy
    warmup.study()  # raises what the server's import would swallow
    assert STUDY_PRELOAD == (warm.__name__,)
    assert drive_clamped.signatures  # the plants and the clip fit's trials
    assert solve_held.signatures  # the study's equilibria and the model update's
