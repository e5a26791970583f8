"""Timing of gripper frames, trajectory timing and exports on a long path (prints, no asserts).

Run: PYTHONPATH=src python benchmarks/bench_grippers.py
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from dloplan.app import PlanDocument, write_plan
from dloplan.cable import catalogue_cable
from dloplan.grippers import gripper_path
from dloplan.io.export import write_ros_trajectory, write_trajectory_csv
from dloplan.io.rapid import write_rapid
from dloplan.trajectory import trajectory_from_grippers


def _path(n_links: int, n_shapes: int) -> np.ndarray:
    theta = np.linspace(0.0, np.pi / 2, n_links + 1)
    arc = np.stack([np.sin(theta), np.zeros_like(theta), 1 - np.cos(theta)], 1) * 0.3
    turns = Rotation.from_rotvec(np.linspace(0, np.pi, n_shapes)[:, None] * [0.3, 0.2, 0.9])
    return np.stack([t.apply(arc) for t in turns])


def _time(label: str, fn, repeat: int = 3):
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    print(f"{label:<40s} {1e3 * best:9.2f} ms")
    return out, best


def _bench(cable, path: np.ndarray) -> None:
    timings = {}
    g = None
    for method in ("auxiliary", "minimal", "rigid"):
        kwargs = {"aux": [0.0, 1.0, 0.0]} if method == "auxiliary" else {}
        g, timings[method] = _time(
            f"gripper_path({method})", lambda m=method, k=kwargs: gripper_path(path, method=m, **k)
        )
    print(f"{'ratio rigid / minimal':<40s} {timings['rigid'] / timings['minimal']:9.2f}")
    traj, _ = _time("trajectory_from_grippers", lambda: trajectory_from_grippers(g))
    _time("sample at 250 Hz", lambda: traj.sample(250.0))
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        _time("write_plan", lambda: write_plan(out / "p.json", PlanDocument(cable, path, g, traj)))
        _time("write_ros_trajectory (knots)", lambda: write_ros_trajectory(out / "t.yaml", traj))
        _time("write_trajectory_csv (100 Hz)", lambda: write_trajectory_csv(out / "t.csv", traj))
        _time("write_rapid", lambda: write_rapid(out / "rapid", traj))


def main() -> None:
    cable = catalogue_cable("pa12", n_links=50)
    for n_shapes in (12, 102, 1002):
        print(f"-- {n_shapes} shapes x 51 points")
        _bench(cable, _path(50, n_shapes))


if __name__ == "__main__":
    main()
