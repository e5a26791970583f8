"""The pipeline floor: a resolved job in, one plan document out (below the application).

::

    job.py        Job (and HarnessJob) with its settings: SI units, domain types, frozen
                  (made by dloplan.app from a job file)
    stages.py     check_job, plan_path, plan_motion, plan_twist, the robot program, verify_plan,
                  run_job (the stages in order), run_harness_job (a wire-harness job)
    document.py   PlanDocument: the plan as typed data, and its JSON-ready dict (to and from)
    repair/       a plan that fails its checks repaired (or refused with the reason)
    plan.py       make_plan: plan, check, repair, check again -- the one way every command
                  gets its plan

Nothing here reads or writes files, knows a file unit or a pydantic model, or imports
:mod:`dloplan.app`: the application reads job files into jobs and writes documents out.
"""

from .document import PlanDocument, document_from_dict, document_to_dict
from .job import (
    GripperSettings,
    HarnessJob,
    Job,
    MotionSettings,
    PlannerSettings,
    RepairSettings,
)
from .plan import make_plan
from .stages import check_job, run_harness_job, run_job, simulate_plan, verify_plan

__all__ = [
    "GripperSettings",
    "HarnessJob",
    "Job",
    "MotionSettings",
    "PlanDocument",
    "PlannerSettings",
    "RepairSettings",
    "check_job",
    "document_from_dict",
    "document_to_dict",
    "make_plan",
    "run_harness_job",
    "run_job",
    "simulate_plan",
    "verify_plan",
]
