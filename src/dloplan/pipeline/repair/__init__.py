"""Plans that pass their own checks: verification-guided repair (docs/repair.md).

Reading order: :mod:`.failures` (what failed, sorted by kind), :mod:`.routes` (stable branches
and clip routes against snap-through), :mod:`.placement` (the job's place on the table),
:mod:`.rebuild` (a document made again by the pipeline's stages), :mod:`.loop` (the order, the
budget, the records: :func:`repair_plan`; :func:`dloplan.pipeline.make_plan` calls it);
:mod:`.harness` is a wire-harness job's own way (planned, verified per phase, its tensioning
slowed where that is what failed).
"""

from .failures import KINDS, Failure, diagnose
from .loop import Budget, Repair, RepairResult, repair_plan
from .placement import translated_job

__all__ = [
    "KINDS",
    "Budget",
    "Failure",
    "Repair",
    "RepairResult",
    "diagnose",
    "repair_plan",
    "translated_job",
]
