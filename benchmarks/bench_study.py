"""Robustness-study throughput: serial, 2 local processes, a 2-worker Dask LocalCluster.

Prints samples per second on each backend, the per-task overhead of each backend (trivial
tasks), the data volume per sample (pickled parameters sent, table rows returned) and, from
these, an estimate of the throughput of a 100-worker cluster with the reasoning.

Before issue 20 (quiet machine): 14.6 samples/s serial; at commit 2268328 (compiled collision
search and Newton loop; quiet) 70.9 samples/s, 14.1 ms per sample; target 150 samples/s on one
core. The ratio printed is against 2268328. Now the static solve's set-up is compiled or cached
(clip conforming, reach check, reactions, clip axes from quaternions, the chain of a cable), a
sample builds its clip-error rotation once, and the collision columns come from the obstacles'
penetration depths (no lift report): 223 samples/s serial (4.5 ms per sample, 3.1x) under load
average 1.3, 97 samples/s under load 6.6 (best of 3 runs): the target is met on a quiet core.
A shape's warm-started solve takes 13 Newton iterations on average at n = 20 (6 to 74).

Run: PYTHONPATH=src python benchmarks/bench_study.py [--samples 96] [--links 20]

Quiet machine after the third round's merge (main 7f40e43, load 1.2, 2026-11-30 22:28 UTC), four
runs: 174-238 samples/s serial (noisy; target 150: met).
"""

from __future__ import annotations

import argparse
import os
import pickle
import time

import numpy as np
from scipy.spatial.transform import Rotation

from dloplan.cable import catalogue_cable
from dloplan.obstacles import Box, Table
from dloplan.sim.clips import ClipPoses
from dloplan.sim.statics import equilibrium
from dloplan.study import (
    DaskBackend,
    ProcessBackend,
    SerialBackend,
    draw_samples,
    map_jobs,
    parse_study,
    run_study,
    study_problem,
)
from dloplan.study.run import chunk_items

BEFORE_RATE = 70.9  # serial samples/s at commit 2268328, quiet (docstring)
TARGET_RATE = 150.0


def problem(n_links: int, n_shapes: int):
    """An Ethernet cable hanging between level clips that move apart, a box and the table."""
    cable = catalogue_cable("ethernet", n_links=n_links)
    shapes, clips = [], []
    for d in np.linspace(0.08, 0.20, n_shapes):
        c = ClipPoses(np.array([[0, 0, 0.2], [d, 0, 0.2]]),
                      Rotation.from_euler("z", [[0.0], [180.0]], degrees=True))
        s = np.linspace(0, 1, n_links + 1)
        l = cable.rest_link_length
        guess = np.stack([np.linspace(-l / 2, d + l / 2, n_links + 1), 0 * s,
                          0.2 - 0.1 * np.sin(np.pi * s)], axis=1)
        shapes.append(equilibrium(cable, guess, c).shape)
        clips.append(c)
    obstacles = [Box((0.1, 0.0, 0.02), (0.05, 0.05, 0.04), 0.0, "block"), Table(0.0)]
    return study_problem(cable, np.stack(shapes), clips, obstacles)


def _noop(shared, item):
    return item


def task_overhead(backend, count: int = 200) -> float:
    """Wall time per trivial task [s] (submission, scheduling, transfer, result)."""
    list(map_jobs(_noop, range(8), backend, shared=0))  # warm up
    t = time.perf_counter()
    list(map_jobs(_noop, range(count), backend, shared=0))
    return (time.perf_counter() - t) / count


def timed(problem_, study, backend) -> tuple[float, dict]:
    t = time.perf_counter()
    result = run_study(problem_, study, backend=backend)
    return time.perf_counter() - t, result.table


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--samples", type=int, default=96)
    parser.add_argument("--links", type=int, default=20)
    parser.add_argument("--shapes", type=int, default=7, help="S + 2")
    parser.add_argument("--chunk", type=int, default=8)
    args = parser.parse_args()
    prob = problem(args.links, args.shapes)
    study = {"samples": args.samples, "chunk_size": args.chunk, "seed": 1,
             "parameters": {"youngs_modulus": {"spread": 30}, "mass_per_length": {"spread": 5},
                            "length": {"spread": 1}, "clip_position": {"spread": 1},
                            "clip_orientation": {"spread": 1},
                            "obstacle_position": {"spread": 5}}}
    spec = parse_study(study)
    print(f"study: n = {args.links} links, S + 2 = {args.shapes} shapes, N = {args.samples} "
          f"samples, chunks of {args.chunk}; {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.1f} (other jobs make the speed-ups noisy)")

    # data volume
    samples = draw_samples(spec, prob.cable, prob.obstacles)
    item = chunk_items(samples, args.chunk, [0])[0]
    sent = len(pickle.dumps(item)) / args.chunk
    shared = len(pickle.dumps(prob))

    rates = {}
    serial_time, table = timed(prob, study, SerialBackend())
    rates["serial"] = args.samples / serial_time
    per_sample = serial_time / args.samples
    returned = len(pickle.dumps({k: v[:args.chunk * args.shapes] for k, v in table.items()}))
    returned /= args.chunk
    rows = len(table["sample"])
    with ProcessBackend(2) as backend:
        timed(prob, {**study, "samples": 2 * args.chunk}, backend)  # start the forkserver
        t, _ = timed(prob, study, backend)
        rates["2 local processes"] = args.samples / t
        overhead_proc = task_overhead(backend)
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        backend = DaskBackend(client=client)
        timed(prob, {**study, "samples": 2 * args.chunk}, backend)  # warm the workers
        t, _ = timed(prob, study, backend)
        rates["Dask LocalCluster, 2 workers"] = args.samples / t
        overhead_dask = task_overhead(backend)

    print(f"\nper sample (serial): {1e3 * per_sample:.1f} ms = {args.shapes} equilibria + "
          f"collision checks; per task of {args.chunk} samples: "
          f"{1e3 * per_sample * args.chunk:.0f} ms")
    for name, rate in rates.items():
        print(f"  {name:<30} {rate:8.1f} samples/s  (x{rate / rates['serial']:.2f})")
    print(f"  serial against commit 2268328 ({BEFORE_RATE} samples/s, quiet): "
          f"{rates['serial'] / BEFORE_RATE:.1f}x; target {TARGET_RATE:.0f} samples/s")
    print(f"\ntrivial-task overhead: local processes {1e3 * overhead_proc:.2f} ms, "
          f"Dask {1e3 * overhead_dask:.2f} ms per task")
    print(f"data per sample: {sent:.0f} B of parameters sent, {returned:.0f} B of table rows "
          f"returned ({rows // args.samples} rows); the problem ({shared / 1e3:.1f} kB) is "
          "sent once per worker")

    # estimate for a 100-worker cluster
    workers = 100
    task_compute = per_sample * args.chunk
    # the Dask scheduler handles tasks one after another: its cost per task bounds the task
    # rate whatever the number of workers; the trivial-task time on 2 workers measures it
    # (with 2 workers nearly all of it is scheduler and transfer latency)
    scheduler_rate = 1.0 / overhead_dask  # tasks/s
    compute_rate = workers / (task_compute + overhead_dask)  # tasks/s if the scheduler keeps up
    tasks_per_s = min(scheduler_rate, compute_rate)
    bandwidth = (sent + returned) * args.chunk * tasks_per_s
    print(f"\nestimate for {workers} workers (one thread each, as fast as these cores):")
    print(f"  compute-bound: {workers} / ({1e3 * task_compute:.0f} ms + "
          f"{1e3 * overhead_dask:.1f} ms) = {compute_rate:.0f} tasks/s")
    print(f"  scheduler-bound: 1 / {1e3 * overhead_dask:.2f} ms = {scheduler_rate:.0f} tasks/s")
    bound = "compute" if compute_rate < scheduler_rate else "scheduler"
    print(f"  -> {tasks_per_s:.0f} tasks/s = {tasks_per_s * args.chunk:.0f} samples/s "
          f"({bound}-bound), scheduler traffic {bandwidth / 1e3:.0f} kB/s")
    print(f"  per-task overhead is {100 * overhead_dask / task_compute:.1f} % of a task's "
          f"compute: chunks of {args.chunk} samples keep it small; chunks of "
          f"{max(1, int(np.ceil(20 * overhead_dask / per_sample)))} samples or more keep it "
          "under 5 %, and a 100-worker study needs N >= a few hundred chunks to fill the "
          "workers.")
    print(f"  a study of 10^5 samples: about {1e5 / (tasks_per_s * args.chunk) / 60:.1f} min "
          f"on {workers} workers, {1e5 * per_sample / 3600:.1f} h serial here.")


if __name__ == "__main__":
    main()
