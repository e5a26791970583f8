"""Importing this module loads the compiled kernels of a study's tasks into this process.

It is the preload of the server the local study workers are forked from
(:class:`dloplan.study.ProcessBackend`, a ``forkserver``): imported there once, it runs the
warm-up's study exercise (:func:`dloplan.warmup.study`: a two-sample study chunk and closed
loop), so every worker forked from the server starts with :func:`dloplan.study.
evaluate_chunk`'s and the linearized closed loop's (:func:`dloplan.correct.probability.
linearized_chunk`) modules imported and their kernels loaded from numba's cache, where each
worker of each map loaded them at its first task (0.9 s of its CPU: on two cores a 1024-sample
closed-loop column ran at x0.6-1.2 of serial). Import it nowhere else.
"""

from __future__ import annotations

import warnings

from .warmup import study

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    try:
        study()
    except Exception:  # noqa: BLE001 - the workers then load what is missing themselves
        pass
