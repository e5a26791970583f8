"""Timings of the vision pipeline on a rendered 640x480 scene (prints; asserts nothing).

Run: PYTHONPATH=src:tests python benchmarks/bench_vision.py
"""

from __future__ import annotations

import time

import numpy as np
from _vision_scene import CABLE_BGR, INTRINSICS, MARKER_LENGTH, MARKER_POSES, render, sine_cable

from dloplan.geometry import resample_by_arc_length
from dloplan.vision import (
    HsvRange,
    MarkerLayout,
    calibrate_extrinsics,
    compare_shapes,
    extract_centreline,
    register_on_plane,
)


def best_of(fn, repeat=5):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return min(times), out


def main() -> None:
    cable = sine_cable()
    image = render([(cable, 0.006, CABLE_BGR)])
    layout = MarkerLayout(MARKER_LENGTH, MARKER_POSES)
    blue = HsvRange((95, 120, 60), (120, 255, 255))
    t_edges, cal = best_of(lambda: calibrate_extrinsics(image, INTRINSICS, layout))
    t_cv, _ = best_of(lambda: calibrate_extrinsics(image, INTRINSICS, layout,
                                                   refine_edges=False))
    t_line, _ = best_of(lambda: extract_centreline(image, blue))
    t_reg, shape = best_of(lambda: register_on_plane(image, cal, blue, 11, 0.003,
                                                     start_near=cable[0]))
    plan = np.repeat(resample_by_arc_length(cable, 11)[None] + [0, 0, 0.003], 7, axis=0)
    t_cmp, result = best_of(lambda: compare_shapes(plan, [shape] * 7))
    print(f"calibration, 4 markers, edge-refined corners : {1e3 * t_edges:7.1f} ms")
    print(f"calibration, 4 markers, OpenCV corners       : {1e3 * t_cv:7.1f} ms "
          f"(edge refinement costs x{t_edges / t_cv:.1f})")
    print(f"centreline extraction                        : {1e3 * t_line:7.1f} ms")
    print(f"registration (centreline + plane + resample) : {1e3 * t_reg:7.1f} ms")
    print(f"error table, 7 shapes x 11 points            : {1e3 * t_cmp:7.2f} ms")
    print(f"registered vs drawn: mean {1e3 * result.euclidean_mean:.2f} mm")


if __name__ == "__main__":
    main()
