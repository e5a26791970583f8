"""The application layer: load a job file once, get its plan from the pipeline, write every output.

::

    job file ──► load.py, resolve.py ──► Job (dloplan.pipeline.job: SI units, weights chosen)
                                              │
                 dloplan.pipeline: check_job | run_job (plan_path ─► plan_motion ─► plan_twist
                                              │                ─► verify_plan), repair
                                              ▼
                 PlanDocument (dloplan.pipeline.document) ◄── read_plan (document_file.py)
                                              │
                 writers.py: json, csv, ros, rapid, figures, report (report.py)

``cli.py`` parses arguments, calls these functions and prints; ``study.py`` gives a study the
same plan; ``files.py`` plans one file or a batch into folders. The pipeline's public names are
re-exported here, so ``from dloplan.app import load_job, make_plan, write_outputs`` is the
whole way from a file to its outputs.
"""

from ..pipeline.document import PlanDocument
from ..pipeline.job import Job
from ..pipeline.plan import make_plan
from ..pipeline.stages import (
    check_harness_job,
    check_job,
    run_harness_job,
    run_job,
    simulate_plan,
    verify_plan,
)
from .document_file import read_plan, write_plan
from .load import load_job, load_scenario
from .writers import WRITERS, write_outputs

__all__ = [
    "WRITERS",
    "Job",
    "PlanDocument",
    "check_harness_job",
    "check_job",
    "load_job",
    "load_scenario",
    "make_plan",
    "read_plan",
    "run_harness_job",
    "run_job",
    "simulate_plan",
    "verify_plan",
    "write_outputs",
    "write_plan",
]
