"""Gripper (TCP) poses along a planned path: the result type and the method choice (Table 4.3).

Relative twist
--------------
A cable without torsion keeps the orientation of one clip relative to the other, except for
what bending explains. With Q_i = F1_i^-1 F2_i the last clip's frame seen from the first clip
at shape i, split Q_i = T_i S_i Q_0 where S_i is the minimal rotation taking Q_0 e_x to
Q_i e_x (the change of direction of the last clip's u-axis, seen from the first clip: bending)
and T_i is a rotation about Q_i e_x (that u-axis). The **relative twist** tau_i is the signed
angle of T_i [rad], right-handed about the last clip's inward u-axis, unwrapped along the path
so it is continuous; tau_0 = 0. It is independent of the world frame and of rigid motions of
the whole path, and zero for a path that only moves the cable rigidly with frames that follow
it. Fig. 4.28's failure (minimal rotation on a curved hose turned over) shows as |tau| ~ pi.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import Cable
from ..frames import UP, minimal_rotation
from ..geometry import as_path
from ..sim.clips import ClipPoses
from .axes import CLIP_NAMES, clip_axes
from .methods import (
    DEFAULT_MIN_ANGLE,
    ClipRotations,
    auxiliary_vector_frames,
    minimal_rotation_frames,
    rigid_rotation_frames,
)

Method = Literal["auto", "auxiliary", "minimal", "rigid"]
METHODS: tuple[str, ...] = ("auto", "auxiliary", "minimal", "rigid")
RESOLVED_METHODS: tuple[str, ...] = ("auxiliary", "minimal", "rigid")

DEFAULT_MAX_TWIST = float(np.radians(15.0))
"""Largest |relative twist| [rad] a gripper path may have and still count as a success."""

DEFAULT_MAX_STEP = float(np.radians(45.0))
"""A clip frame turning by more than this [rad] between two shapes is reported."""


@dataclass(frozen=True, eq=False)
class GripperPath:
    """Clip (TCP) poses at every shape of a path.

    Parameters
    ----------
    positions : numpy.ndarray
        (S + 2, 2, 3) clip points [m]: middles of the first and the last link.
    rotations : tuple of scipy.spatial.transform.Rotation
        ``clip_to_world`` of the first and of the last clip, S + 2 each; x = u (inward link
        axis), y = v, z = w.
    method : str
        The method used: ``"auxiliary"``, ``"minimal"`` or ``"rigid"``.
    twist : numpy.ndarray
        (S + 2,) relative twist between the clips [rad] (module docstring), twist[0] = 0.
    warnings : tuple of str
        Everything noticed on the way (fallbacks, large steps, realigned initial frames).
    success : bool
        False when |twist| exceeds ``max_twist`` somewhere.
    message : str
        One line: method (and why, for ``auto``) and the largest twist.
    max_twist : float
        The twist threshold [rad] used for ``success``.
    """

    positions: np.ndarray
    rotations: ClipRotations
    method: str
    twist: np.ndarray
    warnings: tuple[str, ...] = ()
    success: bool = True
    message: str = ""
    max_twist: float = DEFAULT_MAX_TWIST

    def __post_init__(self) -> None:
        pos = np.asarray(self.positions, dtype=float)
        if pos.ndim != 3 or pos.shape[1:] != (2, 3) or len(pos) < 1:
            raise ValueError(f"positions: expected shape (n_shapes, 2, 3), got {pos.shape}")
        if not np.all(np.isfinite(pos)):
            raise ValueError("positions: non-finite coordinate (NaN or inf)")
        rots = tuple(self.rotations)
        if len(rots) != 2 or not all(
            isinstance(r, Rotation) and not r.single and len(r) == len(pos) for r in rots
        ):
            raise ValueError(
                f"rotations: expected two scipy Rotations of {len(pos)} rotations (one per clip)"
            )
        twist = np.asarray(self.twist, dtype=float)
        if twist.shape != (len(pos),):
            raise ValueError(f"twist: expected shape ({len(pos)},), got {twist.shape}")
        if self.method not in RESOLVED_METHODS:
            raise ValueError(f"method: got {self.method!r}, expected one of {RESOLVED_METHODS}")
        set_ = object.__setattr__
        set_(self, "positions", pos)
        set_(self, "rotations", rots)
        set_(self, "twist", twist)
        set_(self, "warnings", tuple(self.warnings))

    @property
    def n_shapes(self) -> int:
        """Number of shapes S + 2."""
        return len(self.positions)

    @property
    def u_axes(self) -> np.ndarray:
        """(S + 2, 2, 3) clip u-axes (frame x-axes, inward)."""
        return self.axis(0)

    def axis(self, k: int) -> np.ndarray:
        """(S + 2, 2, 3) frame axis k (0: u, 1: v, 2: w) of both clips."""
        e = np.eye(3)[k]
        return np.stack([r.apply(e) for r in self.rotations], axis=1)

    @property
    def matrices(self) -> np.ndarray:
        """(S + 2, 2, 3, 3) ``clip_to_world`` matrices (columns u, v, w)."""
        return np.stack([r.as_matrix() for r in self.rotations], axis=1)

    @property
    def roll(self) -> np.ndarray:
        """(S + 2, 2) each clip's own rotation about the cable from the start [rad].

        The relative twist compares one clip with the other, so a path that turns both clips
        over together reads zero twist; the roll tells how far each gripper turned the cable
        about its axis (:func:`clip_roll`).
        """
        return np.stack([clip_roll(r) for r in self.rotations], axis=1)

    @property
    def twist_warning(self) -> str | None:
        """This path's warning of a relative twist over ``max_twist`` (None if within it)."""
        return relative_twist_warning(self.method, self.twist, self.max_twist)

    def clip_poses(self, index: int) -> ClipPoses:
        """The two clip poses at shape ``index``."""
        rot = Rotation.concatenate([r[index : index + 1] for r in self.rotations])
        return ClipPoses(self.positions[index], rot)


def relative_twist(first: Rotation, last: Rotation) -> np.ndarray:
    """Relative twist between two clips along a path [rad] (module docstring).

    Parameters
    ----------
    first, last : scipy.spatial.transform.Rotation
        ``clip_to_world`` of the two clips, one per shape (K each), x-axes the u-axes.

    Returns
    -------
    numpy.ndarray
        (K,) signed twist, unwrapped, zero at the first shape.
    """
    if not all(isinstance(r, Rotation) and not r.single for r in (first, last)) or len(
        first
    ) != len(last):
        raise ValueError(
            "first, last: expected two scipy Rotations of equal length (one per shape)"
        )
    q = first.inv() * last
    x = q.apply([1.0, 0.0, 0.0])
    swing = minimal_rotation(np.broadcast_to(x[0], x.shape), x)
    twist = q * (swing * q[0:1]).inv()
    angles = np.einsum("ij,ij->i", twist.as_rotvec(), x)
    return np.unwrap(angles)


def clip_roll(rotations: Rotation) -> np.ndarray:
    """One clip's rotation about its own u-axis along a path [rad], zero at the first shape.

    Each step R_i^-1 R_(i+1) is split into the minimal rotation of the u-axis (the cable's end
    changing direction) and a rotation about the new u-axis (the roll); the rolls add up.

    Parameters
    ----------
    rotations : scipy.spatial.transform.Rotation
        K ``clip_to_world`` rotations of one clip, x-axes the u-axes.

    Returns
    -------
    numpy.ndarray
        (K,) accumulated signed roll, right-handed about the u-axis.
    """
    if len(rotations) < 2:
        return np.zeros(len(rotations))
    step = rotations[:-1].inv() * rotations[1:]
    x = step.apply([1.0, 0.0, 0.0])
    swing = minimal_rotation(np.broadcast_to([1.0, 0.0, 0.0], x.shape), x)
    roll = step * swing.inv()
    return np.r_[0.0, np.cumsum(np.einsum("ij,ij->i", roll.as_rotvec(), x))]


def relative_twist_warning(method: str, twist: np.ndarray, max_twist: float) -> str | None:
    """The warning of frames whose relative twist (S + 2,) [rad] exceeds ``max_twist`` [rad]
    somewhere (None where it does not): the frames' own estimate of the cable's twist, which
    the torsion model replaces where it has run (:func:`dloplan.pipeline.stages.frame_warnings`).
    """
    worst = int(np.argmax(np.abs(twist)))
    if abs(twist[worst]) <= max_twist:
        return None
    hint = " (try method 'rigid')" if method != "rigid" else ""
    return (f"relative twist between the clips reaches {np.degrees(twist[worst]):.1f} degrees at "
            f"shape {worst} (more than {np.degrees(max_twist):.0f}): the cable would be "
            f"twisted{hint}")


def _step_warnings(rotations: ClipRotations, max_step: float) -> list[str]:
    warnings = []
    for clip, rot in enumerate(rotations):
        if len(rot) < 2:
            continue
        steps = (rot[:-1].inv() * rot[1:]).magnitude()
        for i in np.flatnonzero(steps > max_step):
            warnings.append(
                f"shape {i} -> {i + 1}, {CLIP_NAMES[clip]} clip: the frame turns by "
                f"{np.degrees(steps[i]):.1f} degrees in one step (more than "
                f"{np.degrees(max_step):.0f}); plan more intermediate shapes"
            )
    return warnings


def resolve_method(method: str, cable: Cable | None) -> tuple[str, str]:
    """The method Table 4.3 picks, and why.

    ``"auto"``: equivalent rigid rotation for a cable with a curved rest shape (stiff, curved
    hoses), minimal rotation otherwise; the auxiliary vector only when asked for by name.
    """
    if method not in METHODS:
        raise ValueError(f"method: got {method!r}, expected one of {', '.join(METHODS)}")
    if method != "auto":
        return method, f"method {method!r} as asked"
    if cable is None:
        raise ValueError(
            "cable: method 'auto' needs the cable (Table 4.3 chooses by its rest shape)"
        )
    if cable.is_curved:
        return "rigid", "auto: equivalent rigid rotation (the cable's rest shape is curved)"
    return "minimal", "auto: minimal rotation (the cable's rest shape is straight)"


def gripper_path(
    path,
    *,
    method: Method = "auto",
    cable: Cable | None = None,
    initial=None,
    aux=UP,
    min_angle: float = DEFAULT_MIN_ANGLE,
    max_twist: float = DEFAULT_MAX_TWIST,
    max_step: float = DEFAULT_MAX_STEP,
) -> GripperPath:
    """Clip (TCP) poses for every shape of a planned path (thesis 4.6, Table 4.3).

    Parameters
    ----------
    path : array_like
        (S + 2, n + 1, 3) shapes [m], start and target included.
    method : {"auto", "auxiliary", "minimal", "rigid"}
        See :func:`resolve_method` and :mod:`dloplan.grippers.methods`.
    cable : Cable, optional
        Needed by ``"auto"``; when given, the path must have ``cable.n_points`` points.
    initial : Rotation or array_like, optional
        Initial clip frames (two ``clip_to_world`` rotations, or (2, 3, 3) matrices); their
        x-axes are turned onto the first shape's u-axes. Used by ``"minimal"`` and
        ``"rigid"``; the auxiliary-vector method defines the frames itself and rejects them.
    aux : array_like
        Auxiliary vector of ``"auxiliary"`` (default world z).
    min_angle : float
        [rad] Failure angle of the auxiliary vector and the rigid-body frame.
    max_twist : float
        [rad] Largest |relative twist| counted as a success.
    max_step : float
        [rad] Frame rotation between two shapes above which a warning is given.

    Returns
    -------
    GripperPath

    Raises
    ------
    ValueError
        For a malformed path, zero-length end links, a user frame that is not a rotation, an
        auxiliary vector nearly parallel to a u-axis, or inconsistent arguments.
    """
    x = as_path(path)
    if cable is not None and x.shape[1] != cable.n_points:
        raise ValueError(
            f"path: {x.shape[1]} points per shape, expected cable.n_points = {cable.n_points}"
        )
    for name, value in (("min_angle", min_angle), ("max_twist", max_twist), ("max_step", max_step)):
        if not np.isfinite(value) or value <= 0:
            raise ValueError(f"{name}: got {value!r}, expected a finite angle > 0 [rad]")
    resolved, why = resolve_method(method, cable)
    result = _frames_for(x, resolved, why, initial, aux, min_angle, max_twist, max_step)
    if method == "auto" and resolved == "minimal" and not result.success:
        worst = np.degrees(np.abs(result.twist)).max()
        rigid = _frames_for(x, "rigid", "auto: equivalent rigid rotation (minimal rotation "
                            f"would twist the cable by {worst:.0f} deg)",
                            initial, aux, min_angle, max_twist, max_step)
        if rigid.success:
            return rigid
    return result


def _frames_for(x, resolved, why, initial, aux, min_angle, max_twist, max_step) -> GripperPath:
    """The gripper path of one resolved method (see :func:`gripper_path`)."""
    positions, u = clip_axes(x)
    if resolved == "auxiliary":
        if initial is not None:
            raise ValueError(
                "initial: the auxiliary-vector method defines the frames itself; "
                "pass initial frames only with method 'minimal', 'rigid' or 'auto'"
            )
        rotations = auxiliary_vector_frames(x, aux, min_angle=min_angle)
        warnings: list[str] = []
    elif resolved == "minimal":
        rotations, warnings = minimal_rotation_frames(x, initial)
    else:
        rotations, warnings = rigid_rotation_frames(x, initial, min_angle=min_angle)
    warnings += _step_warnings(rotations, max_step)
    twist = relative_twist(*rotations)
    worst = int(np.argmax(np.abs(twist)))
    success = bool(abs(twist[worst]) <= max_twist)
    roll = np.degrees(np.abs([clip_roll(r) for r in rotations]).max())
    message = (
        f"{why}; largest relative twist {np.degrees(twist[worst]):.1f} degrees at shape {worst}; "
        f"each clip rolls up to {roll:.1f} degrees about the cable"
    )
    if not success:
        warnings.append(relative_twist_warning(resolved, twist, max_twist))
    return GripperPath(
        positions=positions,
        rotations=rotations,
        method=resolved,
        twist=twist,
        warnings=tuple(warnings),
        success=success,
        message=message,
        max_twist=float(max_twist),
    )
