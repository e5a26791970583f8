"""Importing this module loads the compiled kernels of a study's tasks into this process.

It is the preload of the server the local study workers are forked from
(:class:`dloplan.study.ProcessBackend`, a ``forkserver``): imported there once, every worker
forked from the server starts with :func:`dloplan.study.evaluate_chunk`'s and the linearized
closed loop's (:func:`dloplan.correct.probability.linearized_chunk`) modules imported and their
kernels loaded from numba's cache, where each worker of each map loaded them at its first task
(0.9 s of its CPU: on two cores a 1024-sample closed-loop column ran at x0.6-1.2 of serial).
Import it nowhere else.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.spatial.transform import Rotation

from .cable import GRAVITY, catalogue_cable
from .correct.linearized import linearized_rows, nominal_correction
from .grippers import gripper_path
from .obstacles import Box
from .shapes import arc_shape, place, straight_shape
from .study import draw_samples, evaluate_chunk, parse_study, study_problem
from .study.run import chunk_items


def exercise() -> None:
    """A two-sample chunk of a study and of its closed loop (E x0.7 and x1.4, measured after
    the start) on a 10-link Ethernet cable laid straight, then bent into a 120 degree arc
    beside a box: the calls, and so the kernels' argument types, of a real study's tasks."""
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


with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    try:
        exercise()
    except Exception:  # noqa: BLE001 - the workers then load what is missing themselves
        pass
