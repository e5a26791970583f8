"""Paths of shapes built in closed form for the gripper, trajectory and export tests."""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

from dloplan.cable import catalogue_cable


def arc(n_links: int, length: float, angle: float) -> np.ndarray:
    """A planar circular arc in the x-z plane with n equal links of length L/n [m]."""
    step = angle / n_links
    link = length / n_links
    radius = link / (2.0 * np.sin(step / 2.0))
    theta = np.linspace(0.0, angle, n_links + 1)
    return np.stack([radius * np.sin(theta), np.zeros_like(theta), radius * (1 - np.cos(theta))], 1)


def curved_hose(n_links: int = 10):
    """The PA12 hose of thesis 7.2 with a quarter-circle rest shape (a stiff, curved cable)."""
    cable = catalogue_cable("pa12", n_links=n_links)
    return dataclasses.replace(cable, rest_shape=arc(n_links, cable.length, np.pi / 2))


def turnover_path(shape: np.ndarray, n_inner: int = 10, translation=(0.1, 0.05, 0.02)):
    """The shape rigidly turned over: rotated by 180 degrees about its last link's axis (through
    the last end point) in n_inner + 1 equal steps, while translated; (S + 2, n + 1, 3)."""
    axis = shape[-2] - shape[-1]
    axis /= np.linalg.norm(axis)
    fractions = np.linspace(0.0, 1.0, n_inner + 2)
    turns = Rotation.from_rotvec(np.pi * fractions[:, None] * axis)
    return np.stack(
        [
            r.apply(shape - shape[-1]) + shape[-1] + f * np.asarray(translation)
            for r, f in zip(turns, fractions, strict=True)
        ]
    ), turns


def bending_path(n_links: int = 10, n_inner: int = 8, seed: int = 3) -> np.ndarray:
    """A generic 3D path: an arc whose bending angle grows while the whole shape rotates about a
    random axis and translates; (S + 2, n + 1, 3)."""
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    shapes = []
    for f in np.linspace(0.0, 1.0, n_inner + 2):
        base = arc(n_links, 0.5, 0.3 + 2.0 * f)
        turn = Rotation.from_rotvec(1.2 * f * axis)
        shapes.append(turn.apply(base) + f * np.array([0.2, -0.1, 0.15]))
    return np.stack(shapes)


def turned_hose_plan():
    """A curved hose turned over (minimal-rotation frames, so twisted): cable, shapes, gripper
    path and trajectory, the pieces of a plan document."""
    from dloplan.grippers import gripper_path
    from dloplan.trajectory import trajectory_from_grippers

    cable = curved_hose()
    shapes, _ = turnover_path(cable.rest_shape)
    grippers = gripper_path(shapes, method="minimal", cable=cable)
    return cable, shapes, grippers, trajectory_from_grippers(grippers)
