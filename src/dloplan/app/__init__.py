"""The application layer: load a job file once, run one pipeline, write every output.

::

    job file ──► load (load.py, job.py) ──► Job (SI units, weights chosen, settings resolved)
                                              │
                 pipeline.py: check_job | run_job (plan_path ─► plan_motion ─► plan_twist
                                              │                ─► verify_plan)
                                              ▼
                 document.py: PlanDocument (typed, versioned plan.json) ◄── read_plan
                                              │
                 writers.py: json, csv, ros, rapid, figures, report (report.py)

``cli.py`` parses arguments, calls these functions and prints; ``study.py`` gives a study the
same plan; ``batch.py`` plans many files on a backend.
"""

from .document import PlanDocument, read_plan, write_plan
from .job import Job
from .load import load_job, load_scenario
from .pipeline import check_job, run_harness_job, run_job, simulate_plan, verify_plan
from .writers import WRITERS, write_outputs

__all__ = [
    "WRITERS",
    "Job",
    "PlanDocument",
    "check_job",
    "load_job",
    "load_scenario",
    "read_plan",
    "run_harness_job",
    "run_job",
    "simulate_plan",
    "verify_plan",
    "write_outputs",
    "write_plan",
]
