"""Time from a scenario to a verified robot program: ``dloplan plan EX --verify`` per example.

For every example (``examples/*.yaml``, ``examples/cells/*.yaml``) the command runs as a fresh
process, as a user runs it, and the table gives its wall time, its CPU time (user + sys of the
command, its figure server and workers: ``bench_demo.run``) and where the time went, read from
the plan document it wrote (``plan.json``: ``timings`` per stage, the verification's own
``timings``, each kept repair's ``seconds``):

    start       interpreter start, imports, reading the job (and writing ``plan.json``, the
                first file written): the wall time until ``plan.json``'s modification time
                not in a stage
    write       after ``plan.json``: the other files, the figures still being drawn, exit
    target      the grippers' distance at the start and target and the target check
                (stabilized start and target, their collision check)
    plan        the three-stage planner with stabilization and obstacle re-planning; a
                harness job's phases and insertion (split below the table)
    motion      gripper frames and the timed trajectory; twist: the torsion solve; a harness
                job's steps besides its phases (``total`` less the phases: gripper frames,
                trajectory, cycle, forces)
    robot       the robot program (IK per target, path check, controller round trip)
    verify      the verification after planning: stability, snap-through continuation,
                replay, robot check (``stab/snap/replay`` split below the table)
    repair      the repair loop: each kept repair's time by kind (candidates it rejected
                included), the repaired plan verified again (``verified again``: every check,
                each round), the kept program's round trips enumerated at the end (``program
                completed``), the rest (the loop's own work, refused kinds) as ``other``

An example ``dloplan plan`` does not verify (a harness job) or does not take (an
identification file) is listed with the reason. Each example runs ``--runs`` times (the fastest
by wall time is shown), after one untimed run of the first example per checkout (byte code and
kernel caches; ``--warm-each`` runs every example once untimed first).

``--before REV`` times another revision (a git revision of this repository, exported with
``git archive``, or a ``src`` folder), run for run alternating with this checkout, and prints
the ratios. ``--no-figures`` runs this checkout's command with ``--no-figures`` (the revision
before as it is: what a user who needs no figures gains against it). ``--first-run`` measures
the first run after an install: a copy of this ``src`` without any kernel cache, ``dloplan
demo`` in it (every kernel compiled on first use), then in a second copy ``python -m
dloplan.warmup`` (what ``make`` runs after installing) and the first ``dloplan demo`` after it.

The host is shared: the load average is printed; compare CPU times and ratios measured side
by side, not wall times taken at different moments.

Run: python benchmarks/bench_time_to_program.py [--runs 1] [--only NAME ...] [--before REV]
     [--no-figures] [--first-run]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_demo import adopt_orphans, environment, run

ROOT = Path(__file__).resolve().parent.parent
TARGET_WARM_S = 3.0
TARGET_FIRST_RUN_S = 20.0
STAGES = (("target", ("grip check", "target check")), ("plan", ("plan",)),
          ("motion", ("grippers",)), ("twist", ("twist",)), ("robot", ("robot",)),
          ("verify", ("verify",)), ("repair", ("repair",)))
REPAIR_PART = "repair: "
"""The prefix of the plan document's timings that split the repair's (``repair: verified
again``, ``repair: program completed``: :class:`dloplan.pipeline.repair.RepairResult`)."""


def examples(only: list[str]) -> list[Path]:
    """The shipped examples, those named in ``only`` (file stems) if given."""
    found = sorted((ROOT / "examples").glob("*.yaml")) + \
        sorted((ROOT / "examples" / "cells").glob("*.yaml"))
    return [p for p in found if not only or p.stem in only]


def run_plan(example: Path, folder: Path, source: str | None, extra: tuple = ()) -> dict:
    """``dloplan plan EXAMPLE --verify -o FOLDER [EXTRA]`` once: wall, CPU, exit code, the
    document's timings and repairs, and the command's last lines when it wrote no document."""
    shutil.rmtree(folder, ignore_errors=True)
    command = [sys.executable, "-m", "dloplan.cli", "plan", str(example), "--verify",
               "-o", str(folder), *extra]
    launched = time.time()
    wall, cpu, stderr, code = run(command, environment(source), check=False)
    document = folder / "plan.json"
    out = {"wall": wall, "cpu": cpu, "code": code}
    if not document.exists():
        out["error"] = " | ".join(stderr.strip().splitlines()[-2:])
        return out
    doc = json.loads(document.read_text())
    timings = doc.get("timings") or {}
    stages = {name: sum(float(timings.get(k, 0.0)) for k in keys) for name, keys in STAGES}
    known = {k for _, keys in STAGES for k in keys}
    parts = {k.removeprefix(REPAIR_PART): float(v) for k, v in timings.items()
             if k.startswith(REPAIR_PART)}  # of the repair's time, spent by no kind of repair
    others = {k: float(v) for k, v in timings.items()  # a harness's phases (not their total)
              if k not in known and k != "total" and not k.startswith(REPAIR_PART)}
    stages["plan"] += sum(others.values())
    if "total" in timings:  # a harness job: its frames, trajectory and forces after the phases
        stages["motion"] += float(timings["total"]) - sum(others.values())
    until_document = document.stat().st_mtime - launched
    stages["start"] = until_document - sum(stages.values())
    stages["write"] = wall - until_document
    verification = (doc.get("verification") or {}).get("timings") or {}
    repairs: dict[str, float] = {}
    for repair in doc.get("repairs") or ():
        repairs[repair["kind"]] = repairs.get(repair["kind"], 0.0) + float(repair["seconds"])
    if stages["repair"] > 0:
        repairs.update(parts)
        repairs["other"] = stages["repair"] - sum(repairs.values())
    out.update(stages=stages, others=others, verification=verification, repairs=repairs,
               verified=doc.get("verification") is not None)
    return out


def best(results: list[dict]) -> dict:
    return min(results, key=lambda r: r["wall"])


def row(name: str, result: dict) -> str:
    head = f"{name:<28} {result['code']:>4} {result['wall']:6.2f} {result['cpu']:6.2f}"
    if "error" in result:
        return f"{head}   no plan: {result['error']}"
    stages = result["stages"]
    return head + "".join(f" {stages[k]:7.2f}" for k in ("start", *dict(STAGES), "write"))


def details(result: dict) -> str:
    """The verification's and the repairs' split of one example, one line."""
    if "error" in result:
        return ""
    parts = [", ".join(f"{k} {v:.2f}" for k, v in result["others"].items())] \
        if result["others"] else []
    if result["verification"]:
        parts.append("verify: " + ", ".join(f"{k} {float(v):.2f}"
                                            for k, v in result["verification"].items()))
    elif not result["verified"]:
        parts.append("not verified (see the command's warnings)")
    if result["repairs"]:
        parts.append("repairs: " + ", ".join(f"{k} {v:.2f}" for k, v in result["repairs"].items()))
    return "; ".join(parts)


def source_of(revision: str, folder: Path) -> str:
    """A ``src`` folder of ``revision``: the folder itself, or the revision exported."""
    if Path(revision, "dloplan").is_dir():
        return str(Path(revision).resolve())
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision, "src"],
                             capture_output=True, check=True).stdout
    folder.mkdir(parents=True, exist_ok=True)
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    return str(folder / "src")


def first_run(folder: Path) -> None:
    """The first ``dloplan demo`` on an empty kernel cache, and after the warm-up."""
    python = sys.executable
    for name, warm in (("no warm-up", False), ("after make's warm-up", True)):
        copy = folder / name.replace(" ", "-").replace("'", "")
        shutil.copytree(ROOT / "src", copy / "src",
                        ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
        env = environment(str(copy / "src"))
        if warm:
            wall, cpu, _, _, stdout = run([python, "-m", "dloplan.warmup"], env, check=False,
                                          stdout=True)
            print(f"  python -m dloplan.warmup: {wall:.1f} s wall, {cpu:.1f} s CPU")
            print("\n".join(f"    {line}" for line in stdout.strip().splitlines()))
        before = kernels(copy / "src")
        wall, cpu, _, code = run([python, "-m", "dloplan.cli", "demo", "-o",
                                  str(copy / "demo")], env, check=False)
        print(f"  first dloplan demo, {name}: {wall:.1f} s wall, {cpu:.1f} s CPU (exit {code}; "
              f"{kernels(copy / 'src') - before} kernels compiled and cached by it; target "
              f"{TARGET_FIRST_RUN_S:.0f} s)")


def kernels(source: Path) -> int:
    """Compiled overloads in numba's cache under a ``src`` folder (``*.nbc`` files)."""
    return sum(1 for _ in source.rglob("__pycache__/*.nbc"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=1, help="timed runs per example (best kept)")
    parser.add_argument("--only", nargs="*", default=[], help="example file stems")
    parser.add_argument("--before", help="a git revision or a src folder to compare with")
    parser.add_argument("--no-figures", action="store_true",
                        help="this checkout's runs with --no-figures")
    parser.add_argument("--first-run", action="store_true",
                        help="also time the first run on an empty kernel cache")
    parser.add_argument("--warm-each", action="store_true",
                        help="one untimed run of every example first (not only the first)")
    parser.add_argument("--no-examples", action="store_true",
                        help="skip the examples (with --first-run: only the first run)")
    args = parser.parse_args()
    adopt_orphans()
    print(f"load average {', '.join(f'{v:.1f}' for v in os.getloadavg())} on "
          f"{os.cpu_count()} cores (a shared host: compare CPU times and side-by-side ratios)")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        sources = {"this": None}
        if args.before:
            sources = {"before": source_of(args.before, folder / "before"), "this": None}
        results: dict[str, dict[str, list]] = {name: {} for name in sources}
        extra = {"this": ("--no-figures",) if args.no_figures else ()}
        for k, example in enumerate([] if args.no_examples else examples(args.only)):
            if k == 0 or args.warm_each:
                for name, source in sources.items():  # untimed: byte code, kernels
                    run_plan(example, folder / "out", source, extra.get(name, ()))
            for _ in range(args.runs):
                for name, source in sources.items():
                    results[name].setdefault(example.stem, []).append(
                        run_plan(example, folder / "out", source, extra.get(name, ())))
        header = (f"{'example':<28} {'exit':>4} {'wall':>6} {'CPU':>6} "
                  + "".join(f" {k:>7}" for k in ("start", *dict(STAGES), "write")))
        for name in sources if not args.no_examples else ():
            print(f"\n== {name}: dloplan plan EX --verify {' '.join(extra.get(name, ()))}, best of "
                  f"{args.runs} by wall [s] "
                  f"(target {TARGET_WARM_S:.0f} s wall warm)")
            print(header)
            for stem, runs in results[name].items():
                print(row(stem, best(runs)))
            print("   where the verification and the repairs spent it [s]:")
            for stem, runs in results[name].items():
                line = details(best(runs))
                if line:
                    print(f"   {stem:<28} {line}")
        if args.before and not args.no_examples:
            print("\nspeed-up, before / this (wall, CPU):")
            for stem, runs in results["this"].items():
                this, before = best(runs), best(results["before"][stem])
                print(f"   {stem:<28} {before['wall'] / this['wall']:5.2f}x "
                      f"{before['cpu'] / this['cpu']:5.2f}x")
        if args.first_run:
            print("\nfirst run after an install (copies of src without kernel caches):")
            first_run(folder / "first")
    print(f"\nload average at the end {', '.join(f'{v:.1f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()
