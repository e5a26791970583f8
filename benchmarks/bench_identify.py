"""Young's modulus identification: simulations and time per cable (issue 7, thesis Table 7.1).

Part 1: the four catalogue cables (n = 16, rod model), synthetic experiments with 1 mm noise
resampled to 49 points, default bounds 1e5..1e10 Pa; prints Table 7.1's columns (iterations,
simulations, f(x), first-order optimality, E) plus the error, the 95 % interval, the Newton
iterations inside the simulations and the wall time, with and without warm starts.

Part 2: the bending-model factor: the same USB data fitted with ``bending="rod"``,
``bending="thesis"`` and ``Cable.thesis_model()`` (thesis bending and equal masses).

Part 3: discretization bias (thesis Figs. 6.6-6.7): data from a fine model (n = 64) fitted with
n = 10, 16, 32.

Part 4: the dynamic simulator with and without the capped modulus of Fig. 6.5 (USB, n = 8).

    PYTHONPATH=src python benchmarks/bench_identify.py
"""

from __future__ import annotations

import time
from dataclasses import replace

from dloplan import catalogue_cable
from dloplan.identify import (
    DynamicSettings,
    Experiment,
    bending_manipulation,
    cantilever_manipulation,
    identify_youngs_modulus,
    synthetic_experiment,
)


def design(name, cable):
    if name == "usb":
        return bending_manipulation(cable, clip_distance=0.05, angle=60.0)
    if name == "ethernet":
        return cantilever_manipulation(cable, angle=45.0)
    return cantilever_manipulation(cable)


def timed(*args, **kwargs):
    start = time.perf_counter()
    result = identify_youngs_modulus(*args, **kwargs)
    return result, time.perf_counter() - start


def part1() -> None:
    print("Part 1: catalogue cables, n = 16, 1 mm noise, bounds 1e5..1e10 Pa")
    print(f"{'cable':9}{'E true':>10}{'E found':>11}{'error':>8}{'95 % interval':>22}"
          f"{'iter':>5}{'sims':>5}{'f(x) m^2':>10}{'optim.':>9}{'newton':>7}{'time s':>8}"
          f"{'cold s':>8}{'cold newton':>12}")
    for name in ("usb", "ethernet", "pu", "pa12"):
        cable = catalogue_cable(name, n_links=16)
        experiment = synthetic_experiment(cable, design(name, cable), seed=5)
        r, t = timed(cable, experiment)
        cold, t_cold = timed(cable, experiment, warm_start=False)
        lo, hi = r.confidence_interval
        print(f"{name:9}{cable.youngs_modulus:10.3g}{r.youngs_modulus:11.4g}"
              f"{100 * (r.youngs_modulus / cable.youngs_modulus - 1):+7.2f}%"
              f"{lo:11.3g}..{hi:<9.3g}{r.iterations:5d}{r.simulations:5d}{r.cost:10.2e}"
              f"{r.optimality:9.1e}{r.solver_iterations:7d}{t:8.3f}{t_cold:8.3f}"
              f"{cold.solver_iterations:12d}")


def part2() -> None:
    print("\nPart 2: bending model factor on the same USB data (rod-model data, E = 2.5e6 Pa)")
    cable = catalogue_cable("usb", n_links=16)
    experiment = synthetic_experiment(cable, design("usb", cable), seed=5)
    rod = identify_youngs_modulus(cable, experiment).youngs_modulus
    for label, variant in (("rod", cable), ("thesis bending", replace(cable, bending="thesis")),
                           ("thesis_model()", cable.thesis_model())):
        e = identify_youngs_modulus(variant, experiment).youngs_modulus
        print(f"  {label:16} E = {e:10.4g} Pa   E / E_rod = {e / rod:.4f}")


def part3() -> None:
    print("\nPart 3: discretization bias, data from n = 64 (no noise), fitted with n "
          "(cantilevers: the clip holds the cable's end the same way at every n)")
    for name, angle in (("usb", 45.0), ("ethernet", 45.0), ("pa12", 0.0)):
        fine = catalogue_cable(name, n_links=64)
        data = synthetic_experiment(fine, cantilever_manipulation(fine, angle=angle), noise=0.0)
        for n in (10, 16, 32):
            cable = fine.with_links(n)
            experiment = Experiment(cantilever_manipulation(cable, angle=angle),
                                    data.measured_shape, measurement_noise=1e-3)
            r, t = timed(cable, experiment)
            print(f"  {name:8} n = {n:3d}: E = {r.youngs_modulus:10.4g} Pa "
                  f"({100 * (r.youngs_modulus / fine.youngs_modulus - 1):+6.2f} %), RMS "
                  f"{1e3 * r.rms_error:5.2f} mm, {r.simulations} simulations, {t:.2f} s")


def part4() -> None:
    print("\nPart 4: dynamic simulator (USB, n = 8, bounds 1.5e6..4e6 Pa)")
    cable = catalogue_cable("usb", n_links=8)
    manipulation = bending_manipulation(cable, clip_distance=0.15, angle=60.0, steps=2)
    experiment = synthetic_experiment(cable, manipulation, noise=0.0)
    r, t = timed(cable, experiment, bounds=(1.5e6, 4e6))
    print(f"  static              E = {r.youngs_modulus:.4g} Pa, {r.simulations} sims, "
          f"{r.solver_iterations} Newton iterations, {t:.2f} s")
    for cap in (None, 1e6, 2e5):
        settings = DynamicSettings(max_settle=30.0, rest_speed=1e-3, youngs_modulus_cap=cap)
        r, t = timed(cable, experiment, bounds=(1.5e6, 4e6), simulator="dynamic",
                     dynamic=settings)
        label = "no cap" if cap is None else f"cap {cap:.0e} Pa"
        e = f"{r.youngs_modulus:.4g} Pa" if r.success else "failed"
        print(f"  dynamic {label:12} E = {e}, {r.simulations} sims "
              f"({r.failed_simulations} failed), {r.solver_iterations} time steps, {t:.2f} s"
              + ("" if r.success else f": {r.message[:90]}"))


if __name__ == "__main__":
    part1()
    part2()
    part3()
    part4()
