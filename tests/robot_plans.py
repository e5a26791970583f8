"""Plans of the example scenarios for the robot-program tests, made by the pipeline without its
robot checks (scenario -> planner -> gripper frames -> trajectory), cached per test session."""

from __future__ import annotations

import functools
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dloplan.app import load_job, load_scenario, run_job
from dloplan.grippers import GripperPath

EXAMPLES = Path(__file__).parents[1] / "examples"
PLAN_EXAMPLES = sorted(p.name for p in EXAMPLES.glob("*.yaml")
                       if not p.name.startswith(("identify", "harness", "study")))

ON_ONE_WORKER = pytest.mark.xdist_group("robot_plans")
"""The ``pytestmark`` of the modules that read these plans: their tests run on one worker
(``make test``: ``--dist loadgroup``), so each plan is made once for all of them (the cache is
per process; spread over two workers, both made the USB plan and the harness job)."""


@functools.cache
def example_plan(name: str):
    """``(shapes, grippers, trajectory, job)`` of an example scenario."""
    job = load_scenario(EXAMPLES / name)
    doc = run_job(job, check_robot=False)
    return doc.shapes, doc.grippers, doc.trajectory, job


@functools.cache
def harness_plan(name: str = "harness_usb.yaml"):
    """The harness job of an example (:func:`dloplan.harness.run_harness`)."""
    from dloplan.harness import run_harness

    job = load_job(EXAMPLES / name)
    return run_harness(job.cable, job.start, job.board, job.settings)


def mirrored(grippers: GripperPath) -> GripperPath:
    """The gripper path mirrored in the robot's xz-plane (y -> -y): the clip frames' u and w
    axes mirrored, v mirrored and negated (M R M with M = diag(1, -1, 1) stays a rotation)."""
    m = np.diag([1.0, -1.0, 1.0])
    rots = tuple(Rotation.from_matrix(m @ r.as_matrix() @ m) for r in grippers.rotations)
    return GripperPath(grippers.positions * [1.0, -1.0, 1.0], rots, grippers.method,
                       -grippers.twist)


# -- a small RAPID reader ------------------------------------------------------------------
_DECL = re.compile(r"^\s*(CONST|PERS|VAR) (\w+) (\w+)(\{\d+\})?(?: := (.*?))?;(?:\s*!.*)?$",
                   re.M)


def rapid_value(text: str):
    """A RAPID aggregate literal as nested lists of float / bool / str."""
    tokens = re.findall(r'\[|\]|,|"[^"]*"|[^\[\],]+', text.replace(" ", ""))
    stack = [[]]
    for tok in tokens:
        if tok == "[":
            stack.append([])
        elif tok == "]":
            done = stack.pop()
            stack[-1].append(done)
        elif tok == ",":
            continue
        elif tok.startswith('"'):
            stack[-1].append(tok[1:-1])
        elif tok in ("TRUE", "FALSE"):
            stack[-1].append(tok == "TRUE")
        else:
            stack[-1].append(float(tok))
    assert len(stack) == 1 and len(stack[0]) == 1, text
    return stack[0][0]


def read_module(text: str) -> dict:
    """Module name, declarations ``{name: (kind, type, value)}`` and procedures ``{name: lines}``
    of a RAPID module; asserts the module/procedure structure is closed."""
    lines = text.splitlines()
    head = re.fullmatch(r"MODULE (\w+)", lines[0])
    assert head and lines[-1] == "ENDMODULE", (lines[0], lines[-1])
    declarations = {}
    for kind, typ, name, _, value in _DECL.findall(text):
        assert name not in declarations, f"{name} declared twice"
        declarations[name] = (kind, typ, rapid_value(value) if value and value.startswith("[")
                              else value)
    procs = dict(re.findall(r"^    PROC (\w+)\(\)\n(.*?)\n    ENDPROC$", text, re.M | re.S))
    assert text.count("PROC ") == text.count("ENDPROC") == len(procs)
    return {"module": head.group(1), "declarations": declarations,
            "procs": {k: [line.strip() for line in v.splitlines()] for k, v in procs.items()}}
