"""Where one ``dloplan plan EX --verify`` spends its time outside the solvers (issue 34 item 1).

Three looks at one example, each in fresh processes as a user runs the command (after one
untimed run: byte code and kernel caches warm):

1. **imports** (``python -X importtime``): the cumulative import time of the top-level packages
   the command imports (numba, scipy, pydantic, matplotlib in the figure workers' server...) and
   of dloplan's slowest modules; the sum is the command's import time on its critical path;
2. **kernels**: every numba dispatcher the command calls, with the time of its first call's
   dispatch (typing the arguments, looking the overload up in the on-disk cache, loading and
   linking it: ``Dispatcher._compile_for_args``) and how many overloads were loaded from the
   cache; the sum is what loading cached kernels costs;
3. **the command's timeline**: cProfile of :func:`dloplan.cli.main` in the process (CPU time
   of the main process: stage by stage, the writers one by one, the wait for the figure
   workers), the process's CPU before ``main`` (interpreter start and the command line's
   import) and after it (exit).

Run: python benchmarks/profile_plan.py EXAMPLE [--top 25] [--no-verify-flag]
     (``EXAMPLE`` a file stem of examples/ or examples/cells/, or a path).
The host is shared: CPU times are the comparable numbers; the load average is printed.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_demo import adopt_orphans, environment, run

ROOT = Path(__file__).resolve().parent.parent


def example_path(name: str) -> Path:
    """An example by file stem (examples/ or examples/cells/) or path."""
    for folder in (ROOT / "examples", ROOT / "examples" / "cells"):
        if (folder / f"{name}.yaml").exists():
            return folder / f"{name}.yaml"
    return Path(name)


MAIN_ONLY = ("import multiprocessing.util as u; flags = u._args_from_interpreter_flags; "
             "u._args_from_interpreter_flags = lambda: [a for a in flags() if a not in "
             "('-X', 'importtime')]; from dloplan.console import run; run()")
"""The command with ``-X importtime`` kept from the processes it starts (the figure workers'
server would otherwise write its imports into the same stream)."""


def import_times(arguments: list[str]) -> list[tuple[int, int, int, str]]:
    """``python -X importtime`` of ``dloplan ARGUMENTS``, the main process alone: (self us,
    cumulative us, depth, module) per module."""
    done = subprocess.run([sys.executable, "-X", "importtime", "-c", MAIN_ONLY, *arguments],
                          capture_output=True, text=True, env=environment(None), check=False)
    rows = []
    for line in done.stderr.splitlines():
        match = re.match(r"import time:\s+(\d+) \|\s+(\d+) \|( *)(\S+)", line)
        if match:
            rows.append((int(match[1]), int(match[2]), len(match[3]) // 2, match[4]))
    return rows


def print_imports(rows, top: int) -> None:
    """The import time by package (self times summed: scipy by sub-package, dloplan's own
    modules apart) and dloplan's slowest modules."""
    total = sum(r[1] for r in rows if r[2] == 0) / 1e6
    print(f"imports of the main process: {total:.2f} s in {len(rows)} modules; self time by "
          "package:")
    by_package: dict[str, int] = {}
    for self_us, _, _, name in rows:
        parts = name.split(".")
        package = ".".join(parts[:2]) if parts[0] == "scipy" else parts[0]
        by_package[package] = by_package.get(package, 0) + self_us
    for package, us in sorted(by_package.items(), key=lambda kv: -kv[1])[:top]:
        print(f"   {package:<32} {us / 1e3:8.1f} ms")
    own = sorted((r for r in rows if r[3].startswith("dloplan")), key=lambda r: -r[0])
    print(f"   dloplan's {len(own)} modules, slowest by self time:")
    for self_us, _, _, name in own[:top]:
        print(f"      {name:<40} {self_us / 1e3:6.1f} ms")


INNER = r"""
import cProfile, json, os, pstats, sys, time
t_start = time.process_time()
import dloplan.cli as cli
for name, value in cli.BLAS_THREADS.items():  # as the command sets them (cli.run)
    os.environ.setdefault(name, value)
from numba.core import base, dispatcher
calls, refresh = {}, []
original = dispatcher.Dispatcher._compile_for_args
def timed(self, *args, **kws):
    c0 = time.process_time()
    try:
        return original(self, *args, **kws)
    finally:
        name = f"{self.py_func.__module__}.{self.py_func.__qualname__}"
        n, c = calls.get(name, (0, 0.0))
        calls[name] = (n + 1, c + time.process_time() - c0)
dispatcher.Dispatcher._compile_for_args = timed
original_refresh = base.BaseContext.refresh
def timed_refresh(self):
    c0 = time.process_time()
    original_refresh(self)
    refresh.append(time.process_time() - c0)
base.BaseContext.refresh = timed_refresh
loads = []
import dloplan.jit as jit
load = jit.KERNEL_LOAD
def timed_load(cache, sig, context):
    c0 = time.process_time()
    data = load(cache, sig, context)
    loads.append((cache._name, time.process_time() - c0, data is not None))
    return data
jit.KERNEL_LOAD = timed_load
from dloplan.app import writers
timeline = [("interpreter start", t_start),
            ("imports (numba, dloplan.cli, dloplan.app)", time.process_time())]
stage = cli.Console.stage
def timed_stage(self, text):
    timeline.append((text[:70], time.process_time()))
    stage(self, text)
cli.Console.stage = timed_stage
def timed_writer(name, writer):
    def write(doc, target, options):
        try:
            return writer.write(doc, target, options)
        finally:
            timeline.append((f"writer {name}", time.process_time()))
    return writers.Writer(writer.target, write)
writers.WRITERS.update({k: timed_writer(k, w) for k, w in writers.WRITERS.items()})
profile = cProfile.Profile()
top = int(os.environ["PROFILE_TOP"])
if top:
    profile.enable()
code = cli.main(sys.argv[1:])
profile.disable()
timeline.append(("main returned", time.process_time()))
if top:
    stats = pstats.Stats(profile, stream=sys.stderr)
    stats.sort_stats("cumulative").print_stats(top)
json.dump({"code": code, "timeline": timeline, "kernels": calls, "loads": loads,
           "refresh": refresh}, open(os.environ["PROFILE_OUT"], "w"))
"""



def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("example")
    parser.add_argument("--top", type=int, default=25)
    parser.add_argument("--profile", action="store_true", help="print cProfile's table too")
    parser.add_argument("--no-verify-flag", action="store_true", help="plan without --verify")
    args = parser.parse_args()
    adopt_orphans()
    example = example_path(args.example)
    print(f"{example.relative_to(ROOT) if example.is_relative_to(ROOT) else example}: load "
          f"average {', '.join(f'{v:.1f}' for v in os.getloadavg())} on {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        plan = ["plan", str(example), "-o", str(out)] + ([] if args.no_verify_flag
                                                          else ["--verify"])
        command = [sys.executable, "-m", "dloplan.cli", *plan]
        run(command, environment(None), check=False)  # untimed: caches warm
        wall, cpu, stderr, code = run(command, environment(None), check=False)
        doc = json.loads((out / "plan.json").read_text())
        print(f"\ndloplan {' '.join(plan[:2])} (exit {code}): {wall:.2f} s wall, {cpu:.2f} s "
              "CPU (all processes)")
        print("   stages [s wall]: " + ", ".join(f"{k} {float(v):.2f}"
                                                  for k, v in doc["timings"].items()))
        print("   the console's lines:")
        for line in stderr.strip().splitlines():
            print(f"      {line}")
        print()
        print_imports(import_times(plan), args.top)

        result = Path(tmp) / "inner.json"
        env = {**environment(None), "PROFILE_OUT": str(result),
               "PROFILE_TOP": str(args.top if args.profile else 0)}
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", INNER, *plan], env=env,
                              capture_output=True, text=True, check=False)
        inner_wall = time.perf_counter() - t0
        data = json.loads(result.read_text())
        if args.profile:
            print(done.stderr[-20000:])
        kernels = sorted(data["kernels"].items(), key=lambda kv: -kv[1][1])
        dispatch = sum(v[1] for _, v in kernels)
        loads = data["loads"]
        print(f"\nnumba: {len(kernels)} dispatchers called, their first dispatch {dispatch:.2f} s "
              f"CPU in all: numba's own set-up on the first (its registries, "
              f"{sum(data['refresh']):.2f} s), {len(loads)} overloads loaded from the cache "
              f"({sum(t for _, t, _ in loads):.2f} s; {sum(not ok for _, _, ok in loads)} cache "
              "misses); slowest:")
        for name, (count, cpu_s) in kernels[:args.top]:
            print(f"   {name:<60} {1e3 * cpu_s:7.1f} ms ({count} dispatch"
                  f"{'es' if count > 1 else ''})")
        print(f"\nthe main process's CPU timeline ({inner_wall:.2f} s wall in all"
              f"{', cProfile on' if args.profile else ''}) [s CPU, since the last line]:")
        last = 0.0
        for text, at in data["timeline"]:
            print(f"   {at:6.2f} {at - last:+6.2f}  {text}")
            last = at
    print(f"\nload average at the end {', '.join(f'{v:.1f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()
