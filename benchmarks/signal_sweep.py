"""SIGINT, SIGTERM and SIGHUP at many moments of every long-running command, under load.

Each run starts a real ``dloplan`` command in a session of its own, waits for a moment (a
progress line, a number of processes, a delay), sends a signal to the command alone (``kill``,
``timeout``, a supervisor) or to its whole process group (a terminal's Ctrl-C or hang-up), and
checks what it left (tests/signal_runs.py): exit ``128 + signal``, no traceback, the output
folder as it was (a study keeps its completed chunks, by design: docs/study.md), no lock,
staging folder or temporary file, no process of the group (or a pipe it holds) alive after it.
A busy loop keeps one core loaded beside the commands. Prints one line per run, then the counts
and how long the group took to be gone after the signal.

    PYTHONPATH=tests .venv/bin/python benchmarks/signal_sweep.py [--quick]
"""

from __future__ import annotations

import argparse
import shutil
import signal
import statistics
import sys
import tempfile
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from signal_runs import busy_loop, signal_run  # noqa: E402

from dloplan.cli import main  # noqa: E402

SMALL = {
    "cable": {"name": "pa12", "n_links": 8},
    "start": {"kind": "straight", "placement": {"position": [0.4, -0.25, 0.2],
                                                 "rotation": {"euler": [0, 0, 90]}}},
    "target": {"kind": "arc", "angle": 60,
               "placement": {"position": [0.35, -0.22, 0.25],
                             "rotation": {"euler": [0, 0, 90]}}},
    "planner": {"n_shapes": 2}, "outputs": ["json", "csv", "report"],
}
STUDY = ROOT / "examples" / "study_m2_ethernet.yaml"
IDENTIFY = ROOT / "examples" / "identify_ethernet.yaml"
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def cases(work: Path, plan_json: Path, quick: bool):
    """(label, argv, output folder, moments, study?) of every command swept; a moment is a
    keyword dict of :func:`signal_runs.signal_run` (marker, processes, delay)."""
    job = work / "job.yaml"
    jobs = [str(job), str(work / "job2.yaml"), str(work / "job3.yaml")]
    out = work / "out"
    plan_moments = [{"delay": 0.05}, {"delay": 0.3}, {"marker": "loaded"},
                    {"marker": "target is stable"}, {"marker": "planned"},
                    {"marker": "gripper frames"}, {"marker": "robot program"},
                    {"marker": "robot program", "delay": 0.5},
                    {"marker": "robot program", "delay": 1.5}, {"marker": "verification"}]
    found = [
        ("plan --verify", ["plan", str(job), "-o", str(out), "--verify"], out, plan_moments),
        ("demo", ["demo", "-o", str(work / "demo")], work / "demo",
         [{"marker": "embedded"}, {"marker": "planned"}, {"marker": "robot program"},
          {"marker": "verification"}]),
        ("plan batch", ["plan", *jobs, "--workers", "2", "-o", str(work / "batch")],
         work / "batch", [{"processes": 3}, {"processes": 4, "delay": 1.0},
                          {"processes": 4, "delay": 3.0}]),
        ("study", ["study", str(STUDY), "--workers", "2", "--samples", "64", "--csv", "-o",
                   str(work / "study")], work / "study",
         [{"marker": "planned"}, {"marker": "running"}, {"marker": "chunk 1/"},
          {"marker": "chunk 2/"}]),
        ("verify", ["verify", str(plan_json)], work / "verify-none",
         [{"delay": 0.3}, {"marker": "verifying"}, {"marker": "verifying", "delay": 1.0}]),
        ("export report", ["export", str(plan_json), "--format", "report", "-o",
                           str(work / "exported" / "report.html")], work / "exported",
         [{"delay": 0.2}, {"delay": 0.6}]),
        ("simulate", ["simulate", str(plan_json), "-o", str(work / "sim")], work / "sim",
         [{"marker": "simulating"}, {"marker": "simulating", "delay": 1.0}]),
        ("identify", ["identify", str(IDENTIFY), "-o", str(work / "ident")], work / "ident",
         [{"marker": "identifying"}, {"marker": "identifying", "delay": 2.0}]),
    ]
    if quick:
        found = [(label, argv, folder, moments[::3]) for label, argv, folder, moments in found]
    return found


def main_sweep(quick: bool) -> int:
    work = Path(tempfile.mkdtemp(prefix="dloplan-signals-"))
    for name in ("job.yaml", "job2.yaml", "job3.yaml"):
        (work / name).write_text(yaml.safe_dump(SMALL))
    planned = work / "planned"
    assert main(["plan", str(work / "job.yaml"), "-o", str(planned), "-q"]) in (0, 1)
    out = work / "out"
    shutil.copytree(planned, out)  # the folder a signal must leave as it was
    busy = busy_loop()
    outcomes = []
    try:
        for label, argv, folder, moments in cases(work, planned / "plan.json", quick):
            for k, moment in enumerate(moments):
                for s, signum in enumerate(SIGNALS):
                    to_group = (k + s) % 2 == 1
                    outcome = signal_run(argv, folder, signum, to_group=to_group, cwd=work,
                                         label=label, **moment)
                    problems = outcome.problems()  # a changed folder: named kept, or a problem
                    outcomes.append((outcome, problems))
                    verdict = "not reached" if not outcome.reached else (
                        "BAD: " + "; ".join(problems) if problems else
                        "ok (ended by the signal before dloplan's first line)"
                        if outcome.before_start else "ok")
                    print(f"{label:14s} {signal.Signals(signum).name:7s} {outcome.moment:38s} "
                          f"exit {outcome.code!s:>4}  gone after {outcome.gone_after:5.2f} s  "
                          f"{verdict}", flush=True)
                    if problems:
                        print("    " + outcome.stderr.strip().replace("\n", "\n    ")[-2000:])
                    if folder.name == "study" and folder.exists():
                        shutil.rmtree(folder)  # each study run starts over
    finally:
        busy.kill()
        busy.wait()
    reached = [(o, p) for o, p in outcomes if o.reached]
    bad = [(o, p) for o, p in reached if p]
    gone = sorted(o.gone_after for o, _ in reached)
    early = sum(o.before_start for o, _ in reached)
    print(f"\n{len(outcomes)} runs, {len(reached)} signalled before the command ended ({early} "
          f"of them before dloplan's first line ran), {len(bad)} bad outcomes")
    if gone:
        p90 = gone[int(0.9 * (len(gone) - 1))]
        print(f"signal -> every process gone and the pipes shut: median "
              f"{statistics.median(gone):.2f} s, 90th percentile {p90:.2f} s, max "
              f"{gone[-1]:.2f} s (host shared with other sessions, one busy loop beside)")
    shutil.rmtree(work, ignore_errors=True)
    return 1 if bad else 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="every third moment only")
    sys.exit(main_sweep(parser.parse_args().quick))
