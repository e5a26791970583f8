"""CPU time of the test suite: per test module and per test, the slowest first.

The suite's wall time on a shared host says little (other sessions take the cores); its CPU
time does: ``make test`` on a fresh clone takes at least (venv and warm-up CPU + this total) / 2
on 2 cores. Runs pytest (default: the suite as ``make test`` runs it, ``-n 2 --dist loadgroup``;
other arguments are passed to pytest) with this file as a plugin, which records for every test
its setup, call and teardown CPU time (user + sys of the test's worker and of the processes it
started and waited for: a ``dloplan`` subprocess, a busy loop). A module-scoped fixture is
counted in the setup of the module's first test. Processes a test does not wait for (the
figure workers' forkserver and workers, which outlive a test) are adopted and reaped here: their
CPU is in the total, not in any test's.

Prints the total CPU (every process the run started), the CPU inside tests, the modules by CPU
and the ``--top`` slowest tests by CPU (wall beside them: under load it is several times the
CPU), then each worker's timeline (first start, last end, busy time, its last tests: a worker
that ends long before the other idled while a long test or group ran alone).

Run: python benchmarks/bench_test_suite.py [--top 30] [--out FOLDER] [-- pytest arguments]
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

OUT = "BENCH_TEST_SUITE_OUT"
"""The environment variable naming the folder the plugin writes its rows into (one file per
worker: ``<worker>.jsonl``, one row per test phase)."""


def _cpu() -> float:
    """[s] user + sys of this process and of its waited-for children."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _timed(phase: str):
    """A pytest hook wrapper that appends (test id, phase, CPU s, wall s, start) to the worker's
    file (start: seconds since the epoch, for the workers' timelines)."""
    import pytest

    @pytest.hookimpl(hookwrapper=True)
    def hook(item, *args, **kwargs):
        cpu, wall, start = _cpu(), time.perf_counter(), time.time()
        yield
        row = (item.nodeid, phase, _cpu() - cpu, time.perf_counter() - wall, start)
        folder = Path(os.environ[OUT])
        worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
        with open(folder / f"{worker}.jsonl", "a") as handle:
            handle.write(json.dumps(row) + "\n")

    return hook


def _process_mark(name: str) -> None:
    """Append (name, CPU s of this process and its waited-for children since it started) to the
    worker's ``<worker>.process.jsonl``: its start and collection, and its whole run."""
    folder = Path(os.environ[OUT])
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    with open(folder / f"{worker}.process.jsonl", "a") as handle:
        handle.write(json.dumps((name, _cpu())) + "\n")


if OUT in os.environ:  # loaded by pytest as a plugin (``-p bench_test_suite``)
    pytest_runtest_setup = _timed("setup")
    pytest_runtest_call = _timed("call")
    pytest_runtest_teardown = _timed("teardown")

    def pytest_collection_finish(session):
        """The worker's CPU up to its collected tests: the interpreter, pytest, its plugins,
        every test module's imports and the assertion rewriting of each test module."""
        _process_mark("collected")

    def pytest_sessionfinish(session):
        """The worker's CPU at the end of its run (what it reaped included)."""
        _process_mark("finished")


def read_rows(folder: Path) -> dict[str, list[tuple[str, str, float, float, float]]]:
    """Every test row the plugin wrote into ``folder``, by worker."""
    return {path.stem: [tuple(json.loads(line)) for line in path.read_text().splitlines()]
            for path in sorted(folder.glob("*.jsonl")) if not path.stem.endswith(".process")}


def processes(folder: Path, rows_by_worker) -> str:
    """Each worker's CPU [s] outside its tests: up to its collected tests (start, imports,
    collection), between and around its tests (pytest's and xdist's own work), and its whole
    run, as text."""
    lines = ["worker   collected   between tests   inside tests   whole worker"]
    for path in sorted(folder.glob("*.process.jsonl")):
        worker = path.name.split(".")[0]
        marks = dict(json.loads(line) for line in path.read_text().splitlines())
        inside = sum(row[2] for row in rows_by_worker.get(worker, []))
        whole = marks.get("finished", float("nan"))
        collected = marks.get("collected", float("nan"))
        lines.append(f"{worker:6s} {collected:11.1f} {whole - collected - inside:15.1f} "
                     f"{inside:14.1f} {whole:14.1f}")
    return "\n".join(lines)


def timeline(rows_by_worker) -> str:
    """Each worker's first test start, last test end and busy time, relative to the first start
    of any worker [s]: a worker that ends well before the other idled while a long test or group
    ran alone (its last tests are listed)."""
    begin = min(row[4] for rows in rows_by_worker.values() for row in rows)
    end = max(row[4] + row[3] for rows in rows_by_worker.values() for row in rows)
    lines = ["worker   first   last end   busy (wall in tests)   last tests"]
    for worker, rows in sorted(rows_by_worker.items()):
        last = max(row[4] + row[3] for row in rows)
        tail = sorted({row[0].split("::")[0] for row in sorted(rows, key=lambda r: r[4])[-12:]})
        lines.append(f"{worker:6s} {min(r[4] for r in rows) - begin:7.1f} {last - begin:10.1f} "
                     f"{sum(r[3] for r in rows):10.1f}             {', '.join(tail)}")
    lines.append(f"the last test ended {end - begin:.1f} s after the first started")
    return "\n".join(lines)


def summary(rows, top: int) -> str:
    """The modules by CPU and the ``top`` slowest tests by CPU, as text."""
    tests: dict[str, list[float]] = collections.defaultdict(lambda: [0.0, 0.0])
    modules: dict[str, list[float]] = collections.defaultdict(lambda: [0.0, 0.0, 0])
    for nodeid, phase, cpu, wall, _start in rows:
        tests[nodeid][0] += cpu
        tests[nodeid][1] += wall
        module = modules[nodeid.split("::")[0]]
        module[0] += cpu
        module[1] += wall
        module[2] += phase == "call"
    lines = [f"{len(tests)} tests, {sum(t[0] for t in tests.values()):.1f} s CPU inside them",
             "", "   CPU s    wall s  tests  module"]
    for name, (cpu, wall, count) in sorted(modules.items(), key=lambda m: -m[1][0]):
        lines.append(f"{cpu:8.1f}  {wall:8.1f}  {count:5d}  {name}")
    lines += ["", f"the {top} slowest tests:", "   CPU s    wall s  test"]
    for name, (cpu, wall) in sorted(tests.items(), key=lambda t: -t[1][0])[:top]:
        lines.append(f"{cpu:8.1f}  {wall:8.1f}  {name}")
    return "\n".join(lines)


def main() -> int:
    from bench_demo import adopt_orphans, run

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--top", type=int, default=30, help="slowest tests listed")
    parser.add_argument("--out", help="keep the rows in this folder (default: a temporary one)")
    parser.add_argument("pytest_args", nargs="*", help="after --: pytest's arguments")
    args = parser.parse_args()
    pytest_args = args.pytest_args or ["-q", "-n", "2", "--dist", "loadgroup"]
    adopt_orphans()
    root = Path(__file__).resolve().parents[1]
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(args.out or scratch)
        folder.mkdir(parents=True, exist_ok=True)
        env = {**os.environ, OUT: str(folder),
               "PYTHONPATH": os.pathsep.join(filter(None, [str(root / "benchmarks"),
                                                            os.environ.get("PYTHONPATH")]))}
        os.chdir(root)
        wall, cpu, stderr, code, stdout = run(
            [sys.executable, "-m", "pytest", "-p", "bench_test_suite", *pytest_args], env,
            check=False, stdout=True)
        print(stdout[-3000:], stderr[-2000:], sep="\n")
        by_worker = read_rows(folder)
        print(summary([row for rows in by_worker.values() for row in rows], args.top))
        print("", timeline(by_worker), "", processes(folder, by_worker), sep="\n")
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"\npytest exit {code}: {wall:.1f} s wall, {cpu:.1f} s CPU in all its processes "
          f"(load average now {load}; the host is shared)")
    return code


if __name__ == "__main__":
    sys.exit(main())
