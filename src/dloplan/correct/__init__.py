"""Closed-loop shape correction: a measured shape mid-task corrects the rest of the plan.

* :mod:`.measurement` -- a measured shape checked (order, length, disagreement) and resampled;
* :mod:`.step` -- :func:`correct_plan`: modulus update, clip correction, re-timing;
* :mod:`.plant` -- :func:`run_closed_loop`: the plan run on a mismatched simulated cable;
* :mod:`.document` -- :func:`correct_document` / :func:`write_correction`: the same on a plan
  document, and its outputs (``dloplan correct``);
* :mod:`.probability` -- :func:`closed_loop_sample` / :func:`closed_loop_success`: closed-loop
  success probability over sampled cables, for a study.

The method, its limits and the command are in ``docs/correction.md``.
"""

from .measurement import CorrectionRefused, resample_measured
from .plant import ClosedLoopRun, Plant, run_closed_loop
from .probability import ClosedLoopSuccess, closed_loop_sample, closed_loop_success
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
    "closed_loop_success",
    "correct_plan",
    "fit_clips",
    "resample_measured",
    "run_closed_loop",
    "update_modulus",
]
