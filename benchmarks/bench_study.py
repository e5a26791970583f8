"""Robustness-study throughput on the study example: serial, 2 local processes, Dask.

The problem is the plan ``dloplan study examples/study_m2_ethernet.yaml`` studies (the plan of
``dloplan plan``, its ``study:`` section's parameters), at ``--samples`` samples. Printed:

* the samples per second of the per-sample reference (``evaluate_sample``: one ``equilibrium``
  call per shape, the study's algorithm before issue 34) and of the batched chunk
  (``evaluate_chunk``: every equilibrium of a chunk in one compiled loop), side by side in this
  process, with their CPU time, and whether their rows are equal (they are bit for bit);
* ``run_study`` on the serial backend, 2 local processes, a Dask LocalCluster of 2 one-thread
  workers and, with ``--scheduler tcp://HOST:PORT``, the workers of that cluster (start one
  with ``dask scheduler`` and ``dask worker tcp://HOST:PORT --nthreads 1`` twice; the workers
  need dloplan installed), the speed-up over serial and the per-task overhead of each backend;
* the closed-loop column (the ``correction:`` section): samples per second serial and on 2
  processes, exact (``correct_plan`` per sample, the column before issue 34 item 3,
  ``--closed-loop`` samples) and linearized (a chunk at a time, ``--closed-loop-linearized``
  samples), and how their rows compare;
* from these, an estimate of a 100-worker cluster.

Before issue 34 (quiet machine): 195 samples/s serial; target 1000 samples/s on 2 cores.
The host is shared: compare CPU times and ratios measured side by side.

Run: python benchmarks/bench_study.py [--samples 4096] [--closed-loop 16]
[--closed-loop-linearized 1024] [--closed-loop-chunk 256] [--scheduler ADDR]
"""

from __future__ import annotations

import argparse
import os
import pickle
import time
from pathlib import Path

import numpy as np

from dloplan.correct import closed_loop_study
from dloplan.study import (
    DaskBackend,
    ProcessBackend,
    SerialBackend,
    draw_samples,
    evaluate_chunk,
    evaluate_sample,
    map_jobs,
    run_study,
)
from dloplan.study.evaluate import OUTCOME_COLUMNS
from dloplan.study.run import chunk_items
from dloplan.study.spec import CorrectionSpec

# Only what the workers' server preloads is imported here (dloplan.warm_study: the study and the
# correction): a local worker runs this script's top level again when it starts (multiprocessing
# does so with the main script; Python 3.11's forkserver does not preload it), and importing
# dloplan.app there cost each worker 1.5 s of CPU at each map (x0.6-1.3 on 2 processes).

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "study_m2_ethernet.yaml"
BEFORE_RATE = 195.0  # serial samples/s before issue 34 (quiet)
TARGET_RATE = 1000.0  # on 2 cores


def _noop(shared, item):
    return item


def task_overhead(backend, count: int = 200) -> float:
    """Wall time per trivial task [s] (submission, scheduling, transfer, result)."""
    list(map_jobs(_noop, range(8), backend, shared=0))  # warm up
    t = time.perf_counter()
    list(map_jobs(_noop, range(count), backend, shared=0))
    return (time.perf_counter() - t) / count


def timed(function, *args, **kwargs):
    """(wall [s], CPU of this process [s], result)."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = function(*args, **kwargs)
    return time.perf_counter() - wall, time.process_time() - cpu, result


def reference_rows(problem, chunk: dict) -> dict:
    """The chunk's outcome columns by ``evaluate_sample``, one sample after the other."""
    params = [name for name in chunk if name != "sample"]
    rows: dict[str, list] = {name: [] for name in OUTCOME_COLUMNS}
    for j in range(len(chunk["sample"])):
        one = evaluate_sample(problem, {name: float(chunk[name][j]) for name in params})
        for name in OUTCOME_COLUMNS:
            rows[name].extend(one[name])
    return rows


def equal_rows(table: dict, rows: dict) -> bool:
    for name in OUTCOME_COLUMNS:
        a, b = table[name], np.asarray(rows[name], dtype=table[name].dtype)
        same = list(a) == list(b) if a.dtype == object else np.array_equal(a, b, equal_nan=True)
        if not same:
            return False
    return True


def closed_loop_rates(doc, samples, at: int, n_exact: int, n_linearized: int,
                      chunk: int | None):
    """The closed-loop column's samples per second, exact (before) and linearized (after),
    serial and on 2 local processes, and how their rows compare on the exact run's samples;
    the linearized method in chunks of ``chunk`` samples (None: its default, as ``dloplan
    study`` runs it, :func:`dloplan.correct.probability.linearized_chunk_size`)."""
    from dloplan.pipeline.stages import settled_shapes

    common = {"stabilized": settled_shapes(doc), "trajectory": doc.trajectory, "chunk_size": chunk}
    print(f"\nclosed loop (one correction after shape {at}):")
    rows = {}
    for method, count in (("exact", n_exact), ("linearized", n_linearized)):
        correction = CorrectionSpec(at=at, samples=count, method=method)
        closed_loop_study(doc.cable, doc.shapes, doc.grippers, samples,
                          CorrectionSpec(at=at, samples=2, method=method), **common)  # warm
        wall, cpu, (rows[method], success) = timed(
            closed_loop_study, doc.cable, doc.shapes, doc.grippers, samples, correction, **common)
        line = (f"  {method:<10} {count:5d} samples: serial {count / wall:8.1f} samples/s "
                f"({1e3 * cpu / count:.2f} ms CPU per sample)")
        with ProcessBackend(2) as backend:
            closed_loop_study(doc.cable, doc.shapes, doc.grippers, samples,
                              CorrectionSpec(at=at, samples=8, method=method), backend=backend,
                              **{**common, "chunk_size": 1})  # both workers started and warm
            wall2, _, _ = timed(closed_loop_study, doc.cable, doc.shapes, doc.grippers, samples,
                                correction, backend=backend, **common)
        print(f"{line}, 2 local processes {count / wall2:8.1f} samples/s (x{wall / wall2:.2f}); "
              f"{success.message}")
    exact, linear = rows["exact"], rows["linearized"][: len(rows["exact"])]
    decided = [a["corrections"] == b["corrections"] for a, b in zip(linear, exact, strict=True)]
    both = [abs(a["closed_loop_error"] - b["closed_loop_error"]) for a, b in
            zip(linear, exact, strict=True) if a["corrections"] and b["corrections"]]
    same_open = all(a["open_loop_error"] == b["open_loop_error"] for a, b in
                    zip(linear, exact, strict=True) if not np.isnan(b["open_loop_error"]))
    print(f"  on the exact run's {len(exact)} samples: open loop bit for bit {same_open}, "
          f"decisions equal {sum(decided)}/{len(decided)}, closed-loop errors of the samples "
          f"both corrected ({len(both)}) within {1e3 * max(both, default=0.0):.3f} mm")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=4096)
    parser.add_argument("--reference", type=int, default=256,
                        help="samples evaluated one by one for the side-by-side rate")
    parser.add_argument("--closed-loop", type=int, default=16,
                        help="closed-loop samples of the exact method (correct_plan per sample)")
    parser.add_argument("--closed-loop-linearized", type=int, default=1024,
                        help="closed-loop samples of the linearized method (a chunk at a time)")
    parser.add_argument("--closed-loop-chunk", type=int,
                        help="samples per task of the linearized closed loop (default: its own, "
                             "as `dloplan study` runs it)")
    parser.add_argument("--scheduler", help="a Dask scheduler address tcp://HOST:PORT")
    args = parser.parse_args()
    from dloplan.app import load_scenario, run_job
    from dloplan.app.study import study_problem_of, study_spec

    job = load_scenario(EXAMPLE)
    doc = run_job(job)
    problem = study_problem_of(doc)
    spec = study_spec(job, args.samples, 1)
    print(f"{EXAMPLE.name}: n = {doc.cable.n_links} links, {problem.n_shapes} shapes, "
          f"{len(problem.obstacles)} obstacle(s), N = {spec.samples} samples in chunks of "
          f"{spec.chunk}; {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.1f} (a shared host: compare CPU times and ratios)")

    samples = draw_samples(spec, problem.cable, problem.obstacles)
    chunk = chunk_items(samples, args.reference, [0])[0]
    evaluate_chunk(problem, chunk)  # kernels loaded
    w_ref, c_ref, rows = timed(reference_rows, problem, chunk)
    w_new, c_new, table = timed(evaluate_chunk, problem, chunk)
    n = args.reference
    print(f"\none process, {n} samples side by side:")
    print(f"  per sample (evaluate_sample):  {n / w_ref:8.1f} samples/s wall, "
          f"{n / c_ref:8.1f} per CPU second")
    print(f"  batched (evaluate_chunk):      {n / w_new:8.1f} samples/s wall, "
          f"{n / c_new:8.1f} per CPU second  (x{c_ref / c_new:.1f} CPU)")
    print(f"  rows equal bit for bit: {equal_rows(table, rows)}; "
          f"{int(np.sum(table['converged']))}/{len(table['converged'])} equilibria converged, "
          f"{np.mean(table['iterations']):.1f} Newton iterations on average")

    rates, overheads = {}, {}
    wall, cpu, result = timed(run_study, problem, spec, backend=SerialBackend())
    rates["serial"] = spec.samples / wall
    print(f"\nrun_study, {spec.samples} samples ({1e3 * cpu / spec.samples:.2f} ms CPU per "
          "sample serial):")
    with ProcessBackend(2) as backend:
        run_study(problem, {**spec.model_dump(), "samples": 64}, backend=backend)  # started
        wall, _, _ = timed(run_study, problem, spec, backend=backend)
        rates["2 local processes"] = spec.samples / wall
        overheads["local processes"] = task_overhead(backend)
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        backend = DaskBackend(client=client)
        run_study(problem, {**spec.model_dump(), "samples": 64}, backend=backend)  # warm
        wall, _, _ = timed(run_study, problem, spec, backend=backend)
        rates["Dask LocalCluster, 2 workers"] = spec.samples / wall
        overheads["Dask"] = task_overhead(backend)
    if args.scheduler:
        with DaskBackend(scheduler=args.scheduler) as backend:
            run_study(problem, {**spec.model_dump(), "samples": 64}, backend=backend)
            wall, _, _ = timed(run_study, problem, spec, backend=backend)
            rates[f"Dask at {args.scheduler} ({backend.workers} threads)"] = spec.samples / wall
    for name, rate in rates.items():
        print(f"  {name:<34} {rate:8.1f} samples/s  (x{rate / rates['serial']:.2f})")
    print(f"  serial against before issue 34 ({BEFORE_RATE:.0f} samples/s, quiet): "
          f"{rates['serial'] / BEFORE_RATE:.1f}x; target {TARGET_RATE:.0f} samples/s on 2 cores")
    print("  trivial-task overhead: " + ", ".join(f"{k} {1e3 * v:.2f} ms"
                                                  for k, v in overheads.items()))
    item = chunk_items(samples, spec.chunk, [0])[0]
    sent = len(pickle.dumps(item)) / spec.chunk
    returned = len(pickle.dumps(evaluate_chunk(problem, item))) / spec.chunk
    print(f"  data per sample: {sent:.0f} B sent, {returned:.0f} B returned; the problem "
          f"({len(pickle.dumps(problem)) / 1e3:.1f} kB) once per worker")

    if args.closed_loop:
        closed_loop_rates(doc, samples, problem.n_shapes // 2, args.closed_loop,
                          args.closed_loop_linearized, args.closed_loop_chunk)

    workers = 100
    per_sample = 1.0 / rates["serial"]
    task_compute = per_sample * spec.chunk
    overhead = overheads["Dask"]
    compute_rate, scheduler_rate = workers / (task_compute + overhead), 1.0 / overhead
    tasks_per_s = min(compute_rate, scheduler_rate)
    bound = "compute" if compute_rate < scheduler_rate else "scheduler"
    print(f"\nestimate for {workers} one-thread workers as fast as these cores: "
          f"{tasks_per_s * spec.chunk:.0f} samples/s ({bound}-bound: tasks of "
          f"{1e3 * task_compute:.0f} ms, {1e3 * overhead:.1f} ms scheduler time per task)")


if __name__ == "__main__":
    main()
