"""Clip positions and u-axes read off every shape of a planned path (thesis 4.6, Fig. 4.24).

The clips grip the middle of the first and of the last link. The same convention as
:mod:`dloplan.sim.clips` is kept for both clips: **u points inward**, from the cable's end into
the cable (first clip: along x_1 - x_0; last clip: along x_{n-1} - x_n), so that mirroring a
problem mirrors its clip frames.
"""

from __future__ import annotations

import numpy as np

from ..geometry import as_path

CLIP_NAMES = ("first", "last")
"""Names of the two clips, in the order of every (..., 2, ...) clip axis."""

ZERO_LINK_TOLERANCE = 1e-9
"""An end link shorter than this fraction of the shape's mean link length counts as zero."""


def clip_axes(path) -> tuple[np.ndarray, np.ndarray]:
    """Clip positions and inward unit u-axes of every shape of a path (thesis Fig. 4.24).

    Parameters
    ----------
    path : array_like
        (S + 2, n + 1, 3) shapes [m] (a single (n + 1, 3) shape is accepted).

    Returns
    -------
    positions : numpy.ndarray
        (S + 2, 2, 3) middles of the first and the last link [m].
    u : numpy.ndarray
        (S + 2, 2, 3) unit u-axes: first clip along x_1 - x_0, last clip along x_{n-1} - x_n.

    Raises
    ------
    ValueError
        When an end link has zero length (its clip axis is undefined), naming the shape and
        the clip.
    """
    x = as_path(path)
    ends = x[:, [0, -1]]
    inner = x[:, [1, -2]]
    u = inner - ends
    lengths = np.linalg.norm(u, axis=-1)
    scale = np.linalg.norm(np.diff(x, axis=1), axis=-1).mean(axis=1)
    zero = lengths <= ZERO_LINK_TOLERANCE * np.maximum(scale, np.finfo(float).tiny)[:, None]
    if np.any(zero):
        shape_index, clip = np.argwhere(zero)[0]
        raise ValueError(
            f"path: shape {shape_index}, {CLIP_NAMES[clip]} clip: the end link has zero length "
            f"({lengths[shape_index, clip]:.3g} m), its clip axis is undefined"
        )
    return 0.5 * (ends + inner), u / lengths[..., None]
