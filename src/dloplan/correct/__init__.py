"""Closed-loop shape correction: a measured shape mid-task corrects the rest of the plan.

* :mod:`.measurement` -- a measured shape checked (order, length, disagreement) and resampled;
* :mod:`.model_error` -- the discretization error carried as a measured bias;
* :mod:`.step` -- :func:`correct_plan`: modulus update, clip correction, re-timing;
* :mod:`.plant` -- :func:`run_closed_loop`: the plan run on a mismatched simulated cable;
  :func:`reachable_error`: the floor a perfect correction would reach; :func:`shared_floor`:
  what one correction can do for cables the measurement cannot tell apart;
* :mod:`.report` -- a correction's report as text;
* :mod:`.probability` -- :func:`closed_loop_sample` / :func:`closed_loop_success`: closed-loop
  success probability over sampled cables, for a study.

The method, its limits and the command are in ``docs/correction.md``; the command's adapter
(a plan document corrected, checked and written) is :mod:`dloplan.app.correct`.
"""

from .measurement import CorrectionRefused, resample_measured
from .plant import (
    ClosedLoopRun,
    Plant,
    reachable_error,
    run_closed_loop,
    shape_error,
    shared_floor,
)
from .probability import (
    ClosedLoopSuccess,
    closed_loop_sample,
    closed_loop_study,
    closed_loop_success,
)
from .step import Correction, CorrectionLimits, ModelUpdate, correct_plan, fit_clips, update_modulus

__all__ = [
    "ClosedLoopRun",
    "ClosedLoopSuccess",
    "Correction",
    "CorrectionLimits",
    "CorrectionRefused",
    "ModelUpdate",
    "Plant",
    "closed_loop_sample",
    "closed_loop_study",
    "closed_loop_success",
    "correct_plan",
    "fit_clips",
    "resample_measured",
    "reachable_error",
    "run_closed_loop",
    "shape_error",
    "shared_floor",
    "update_modulus",
]
