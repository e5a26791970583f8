"""Plans that pass their own checks: verification-guided repair (docs/repair.md).

Reading order: :mod:`.failures` (what failed, sorted by kind), :mod:`.routes` (stable branches
and clip routes against snap-through), :mod:`.placement` (the job's place on the table),
:mod:`.rebuild` (a document made again by the pipeline's stages), :mod:`.loop` (the order, the
budget, the records: :func:`repair_plan`, and :func:`plan_and_repair` for ``dloplan plan``).
"""

from .failures import KINDS, Failure, diagnose
from .loop import Budget, Repair, RepairResult, plan_and_repair, repair_plan
from .placement import translated_job

__all__ = [
    "KINDS",
    "Budget",
    "Failure",
    "Repair",
    "RepairResult",
    "diagnose",
    "plan_and_repair",
    "repair_plan",
    "translated_job",
]
