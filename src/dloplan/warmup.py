"""Fill numba's on-disk cache with every kernel a run uses, in parallel processes.

dloplan's compiled kernels (``@dloplan.jit.njit(cache=True)``) are compiled on their first call
and loaded from ``__pycache__`` afterwards. Compiling all of them costs about 100 s of CPU, which
the first ``dloplan demo`` after an install, or the first test of each test worker, would
otherwise wait for. ``make`` runs ``python -m dloplan.warmup`` once after installing, so a fresh
clone's first ``make demo`` starts warm and ``make test``'s workers load rather than compile
(two test workers on an empty cache both compile the kernels they share).

A kernel is compiled for the argument types of its call, so the warm-up calls the kernels the
way the commands do: it runs small real jobs (:data:`EXERCISES`), each in the processes of a
pool with one process per core, the longest first. A kernel two exercises need at the same
moment is compiled by both (numba has no lock between compilations); the saves are safe
(:mod:`dloplan.jit`), and the exercises are chosen to share little. Exercises started after a
kernel was saved load it.

The command also writes the bytecode of the modules the exercises import (:func:`write_bytecode`),
which ``make``'s install (``uv pip install``: no byte-compiling) left out, even where
``PYTHONDONTWRITEBYTECODE`` is set.

Run: ``python -m dloplan.warmup [--workers N]``; it prints each exercise's time and the kernels
compiled, and exits 1 naming an exercise that failed (the kernels it compiled stay cached).
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path


def _demo_mapping(**changes) -> dict:
    """The embedded demo's scenario mapping, with top-level sections replaced."""
    from importlib import resources

    from .io.scenario import read_mapping

    with resources.as_file(resources.files("dloplan.data").joinpath("demo.yaml")) as path:
        return {**read_mapping(path), **changes}


def _job(**changes):
    from .app.load import resolve_mapping

    return resolve_mapping(_demo_mapping(**changes), "warm-up")


def _straight_path(job):
    """The job's start and target as a two-shape path (a motion the robot can be checked on
    without planning one)."""
    import numpy as np

    return np.stack([job.start, job.target])


def plan_path() -> None:
    """The demo's planner: target check, the three stages, stabilization, obstacle re-planning
    (the static solver, the advanced stage's Newton systems, the box distance search)."""
    from .pipeline.stages import plan_path

    plan_path(_job())


def robot_program() -> None:
    """The YuMi's program of a motion: gripper frames, IK of every target, the path check."""
    from .pipeline.stages import plan_motion, plan_program

    job = _job()
    grippers, trajectory = plan_motion(job, _straight_path(job))
    plan_program(job.robot, grippers, trajectory)


def twist() -> None:
    """The torsion solve of a motion under its gripper frames."""
    from .pipeline.stages import gripper_frames, plan_twist

    job = _job()
    path = _straight_path(job)
    plan_twist(job.cable, path, gripper_frames(job, path))


def demo() -> None:
    """``dloplan demo`` into a temporary folder: the demo's ``plan --verify`` (what the exercises
    above leave: stability, snap-through continuation, dynamic replay, the repair loop's checks)
    and its files written, its figures drawn here, so that the modules a run imports to write
    (the writers, the report, matplotlib) have their bytecode written (:func:`write_bytecode`)."""
    import tempfile

    from .app.files import plan_into

    with tempfile.TemporaryDirectory() as folder:
        plan_into(_job(), Path(folder) / "demo", verify=True)


def described_cell() -> None:
    """A plan on two Franka Pandas: a described cell's IK, placement and program."""
    from .pipeline.plan import make_plan

    make_plan(_job(robot={"cell": {"preset": "panda_pair", "separation": 1.0}, "place": True},
                   repair={"placement": True}))


def dynamics_with_torsion() -> None:
    """``dloplan simulate --torsion`` of a plan: the explicit time stepping with twist; and the
    explicit replay without (a harness's replay, a tensile check: the demo's replay steps
    implicitly)."""
    from .pipeline.stages import run_job, settled_shapes, simulate_plan
    from .verify.replay import replay

    doc = run_job(_job(planner={"n_shapes": 2}), check_robot=False)
    simulate_plan(doc, torsion=True)
    replay(doc.cable, settled_shapes(doc), (doc.trajectory.times, doc.clip_poses()),
           settle_duration=0.05, scheme="explicit")


HARNESS = {
    "cable": {"name": "usb", "n_links": 10, "youngs_modulus": 2.5e6},
    "start": {"kind": "straight",
              "placement": {"position": [0.22, -0.25, 0.05], "rotation": {"euler": [0, 0, 90]}}},
    "table": {"height": 0.0},
    "planner": {"physical_mode": "equilibrium"},
    "harness": {
        "fixtures": [{"name": "right", "position": [0.50, -0.15, 0.0315],
                      "axis": [-0.7071, 0.7071, 0], "slot_width": 0.008, "depth": 0.01},
                     {"name": "left", "position": [0.50, 0.15, 0.0315],
                      "axis": [-0.7071, -0.7071, 0], "slot_width": 0.008, "depth": 0.01}],
        "pegs": [{"name": "peg", "base": [0.38, 0.0, 0.0], "radius": 0.012, "height": 0.06,
                  "plate_height": 0.03, "plate_size": [0.08, 0.12], "side": [-1, 0, 0]}],
        "n_shapes": [2, 2],
        "tension": {"contact_force": 0.2, "max_axial_force": 5.0, "max_offset": 0.05}},
}
"""A small wire-harness job (the USB cable of ``examples/harness_usb.yaml`` on its board, two
shapes per phase): its plan and verification are what compile the contact kernels."""


def harness() -> None:
    """``dloplan plan --verify`` of a harness job: the held equilibria against pegs and plates
    (the compiled contact Newton loop) and the replay with contacts."""
    from .app.load import resolve_mapping
    from .pipeline.plan import make_plan

    make_plan(resolve_mapping(HARNESS, "warm-up harness"), verify=True)


def study() -> None:
    """A two-sample chunk of a study and of its closed loop (E x0.7 and x1.4, measured after
    the start) on a 10-link Ethernet cable laid straight, then bent into a 120 degree arc
    beside a box: the calls, and so the kernels' argument types, of a real study's tasks (the
    batched equilibria and obstacle checks, the plants driven as a batch, the linearized
    correction: ``dloplan correct``'s kernels). The study workers' server runs it too, as its
    preload (:mod:`dloplan.warm_study`): it imports no more than a study's tasks do."""
    import numpy as np
    from scipy.spatial.transform import Rotation

    from .cable import GRAVITY, catalogue_cable
    from .correct.linearized import linearized_rows, nominal_correction
    from .grippers import gripper_path
    from .obstacles import Box
    from .shapes import arc_shape, place, straight_shape
    from .study import draw_samples, evaluate_chunk, parse_study, study_problem
    from .study.run import chunk_items

    cable = catalogue_cable("ethernet", 10)
    turn = Rotation.from_euler("z", 90, degrees=True)
    path = np.stack([place(straight_shape(cable.length, 10), (0.35, -0.25, 0.15), turn),
                     place(arc_shape(cable.length, 10, np.radians(120.0)), (0.3, -0.2, 0.15),
                           turn)])
    grippers = gripper_path(path, method="auxiliary")
    clips = [grippers.clip_poses(j) for j in range(len(path))]
    problem = study_problem(cable, path, clips, [Box((0.3, 0.1, 0.05), (0.1, 0.1, 0.1))])
    spec = parse_study({"samples": 2, "parameters": {"youngs_modulus": {"spread": 10},
                                                     "obstacle_position": {"spread": 1}}})
    samples = draw_samples(spec, problem.cable, problem.obstacles)
    evaluate_chunk(problem, chunk_items(samples, 2, [0])[0])
    nominal = nominal_correction(cable, path, grippers, 0, stabilized=problem.nominal,
                                 gravity=GRAVITY)
    weight = cable.mass / cable.length
    linearized_rows(nominal, [(0, 0.7 * cable.youngs_modulus, weight, cable.length),
                              (1, 1.4 * cable.youngs_modulus, weight, cable.length)],
                    noise=1e-3, n_measured=200)


EXERCISES = {
    "plan path": plan_path,
    "robot program": robot_program,
    "twist": twist,
    "harness": harness,
    "study": study,
    "demo": demo,
    "simulate --torsion": dynamics_with_torsion,
    "described cell": described_cell,
}
"""The warm-up's jobs in the order they are started. The first three compile disjoint kernel
sets (the static solver and planner, about 55 % of the demo's compilation; the IK, 30 %; the
torsion solver, 20 %): on two processes the first takes one while the other two follow each
other on the second. The harness job comes next, on the first process when the planner is
done: it is the one exercise that needs none of the torsion solver's kernels, which the second
process is still compiling then. Started before them, the demo compiled 8 of them a second time
(125 compilations for 116 kernels then). The study comes next, on the other process, and the
demo after it: started beside the harness job, the demo reached the replay's implicit stepping
(``implicit_steps``, its contacts' ``push_out``) while the harness job compiled it and compiled
it too (131 compilations for 126 overloads); after the study it finds them cached, and the
study's ``solve_held`` and the snap continuation's ``continue_held`` share ``_held_item``, which
the study compiles first. In this order the one kernel compiled twice is the frames'
quaternions that the planner and the IK both start with. The demo's ``plan --verify`` then
compiles only the snap check's continuation (and writes the demo's files); the torsion replay
adds what the demo does not use, and the described cell compiles nothing new (it writes the
Panda's parsed description and the cell modules' bytecode). Measured with numba's compile
events: docs/performance.md."""


def kernel_files(root: Path | None = None) -> int:
    """The number of compiled overloads (``*.nbc``) cached under dloplan's folder."""
    root = Path(__file__).parent if root is None else root
    return sum(1 for _ in root.rglob("__pycache__/*.nbc"))


def run_exercise(name: str) -> tuple[str, float, str]:
    """One exercise in a pool process: (name, seconds, error or "")."""
    import warnings

    start = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            EXERCISES[name]()
    except Exception as exc:  # noqa: BLE001 - reported, the other exercises go on
        return name, time.perf_counter() - start, f"{type(exc).__name__}: {exc}"
    return name, time.perf_counter() - start, ""


def warm(workers: int | None = None, progress=print, exercises=None) -> bool:
    """Run the exercises (default :data:`EXERCISES`, by name) on ``workers`` processes
    (default: one per core); True if all ran."""
    workers = workers or os.cpu_count() or 1
    names = list(EXERCISES if exercises is None else exercises)
    before = kernel_files()
    start = time.perf_counter()
    context = multiprocessing.get_context("spawn")  # fresh interpreters: nothing half-loaded
    ok = True
    with ProcessPoolExecutor(min(workers, len(names)), mp_context=context,
                             initializer=write_bytecode) as pool:
        futures = [pool.submit(run_exercise, name) for name in names]
        for future in as_completed(futures):
            name, seconds, error = future.result()
            ok = ok and not error
            progress(f"warm-up: {name} {seconds:.1f} s" + (f" FAILED: {error}" if error else ""))
    progress(f"warm-up: {kernel_files() - before} kernels compiled and cached in "
             f"{time.perf_counter() - start:.1f} s on {workers} processes")
    return ok


def write_bytecode() -> None:
    """Let this process, and the processes it starts afterwards, write the bytecode of the modules
    they import (``__pycache__/*.pyc``), even where ``PYTHONDONTWRITEBYTECODE`` is set.

    ``make`` installs with ``uv pip install``, which (like ``pip install --no-compile``) does
    not byte-compile the 11 000 modules it installs (about 40 s of CPU), so a module's bytecode
    is written on its first import. Where ``PYTHONDONTWRITEBYTECODE`` is set (container images
    often set it) nothing ever is, and every process compiled every module it imports from
    source: 1.2 s of CPU more for each ``dloplan`` command's start (numpy, scipy, numba,
    dloplan: 2.0 s instead of 0.8 s), in each test worker, each subprocess the tests start and
    each figure workers' server (docs/performance.md). The warm-up's exercises import what a
    run imports, so with this they write its bytecode once, as pip would have (pip's
    byte-compiling ignores the variable too).
    Called by :func:`main` and in each of the pool's processes (their initializer):
    multiprocessing starts its interpreters with the parent's flags, ``-B`` where the variable was
    set when the parent started.
    """
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    sys.dont_write_bytecode = False


def main(argv=None) -> int:
    write_bytecode()  # first: the modules imported from here on are written as well
    from .cli import use_command_blas_threads

    parser = argparse.ArgumentParser(prog="python -m dloplan.warmup",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=None,
                        help="processes (default: one per core)")
    args = parser.parse_args(argv)
    if args.workers is not None and args.workers < 1:
        parser.error(f"--workers: got {args.workers}, expected an integer >= 1")
    use_command_blas_threads()  # the exercises run as the command does (the pool inherits it)
    return 0 if warm(args.workers) else 1


if __name__ == "__main__":
    sys.exit(main())
