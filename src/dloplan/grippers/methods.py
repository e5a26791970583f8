"""The three ways of completing the clip frames along a path (thesis 4.6.1-4.6.3).

Each function returns, for both clips, the ``clip_to_world`` rotations at every shape: a pair
of :class:`scipy.spatial.transform.Rotation`, each holding S + 2 rotations, whose x-axes are
the clip u-axes of :func:`dloplan.grippers.axes.clip_axes` and whose y- and z-axes are the
thesis' v- and w-axes (right-handed, u x v = w).

* :func:`auxiliary_vector_frames` (4.6.1): v = u x a / |u x a|, w = u x v for a constant
  user vector a. Fails where u is (nearly) parallel to a; that is detected and raised.
* :func:`minimal_rotation_frames` (4.6.2): from user-given initial frames, each frame is turned
  by the least-angle rotation taking u_{i-1} to u_i. The thesis finds that rotation with a
  constrained optimization (eqs. 4.25-4.29); its closed form (rotation about u_{i-1} x u_i by
  the angle between them, :func:`dloplan.frames.minimal_rotation`) is used.
* :func:`rigid_rotation_frames` (4.6.3): an "equivalent rigid body" frame per shape and clip
  (the clip's link axis, the chord of the shape and their normal); its incremental rotations
  R_i^{i-1} = R_i^o (R_{i-1}^o)^T (eq. 4.31) are applied to the initial clip frames (eq. 4.30).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ..frames import UP, frame_from_axis, minimal_rotation
from ..geometry import as_path
from .axes import CLIP_NAMES, clip_axes

ROTATION_TOLERANCE = 1e-6
"""Largest |R^T R - I| and |det R - 1| accepted for a user-given frame matrix."""

DEFAULT_MIN_ANGLE = float(np.radians(5.0))
"""Smallest angle [rad] between the u-axis and the auxiliary vector (4.6.1), or between the
u-axis and the chord (4.6.3), for which the frame counts as defined."""

ClipRotations = tuple[Rotation, Rotation]
"""``clip_to_world`` rotations of the first and the last clip, S + 2 each."""


def as_initial_frames(initial, name: str = "initial") -> ClipRotations:
    """Validate user-given initial clip frames.

    Parameters
    ----------
    initial : scipy.spatial.transform.Rotation or array_like
        Two ``clip_to_world`` rotations (first clip, last clip): a Rotation holding 2, or
        (2, 3, 3) matrices whose columns are the u, v, w axes.

    Raises
    ------
    ValueError
        When it does not hold two frames, or a matrix is not a rotation (not orthonormal,
        or a reflection with det -1), naming the clip.
    """
    if isinstance(initial, Rotation):
        if initial.single or len(initial) != 2:
            raise ValueError(
                f"{name}: expected a scipy Rotation holding 2 rotations (one per clip)"
            )
        quat = initial.as_quat()
        if not np.all(np.isfinite(quat)):
            raise ValueError(f"{name}: non-finite quaternion (NaN or inf)")
        return initial[0:1], initial[1:2]
    try:
        mats = np.asarray(initial, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"{name}: expected a Rotation or (2, 3, 3) matrices, got {type(initial).__name__}"
        ) from exc
    if mats.shape != (2, 3, 3):
        raise ValueError(f"{name}: expected (2, 3, 3) rotation matrices, got shape {mats.shape}")
    if not np.all(np.isfinite(mats)):
        raise ValueError(f"{name}: non-finite matrix entry (NaN or inf)")
    for clip, mat in enumerate(mats):
        orth = float(np.max(np.abs(mat.T @ mat - np.eye(3))))
        det = float(np.linalg.det(mat))
        if orth > ROTATION_TOLERANCE or abs(det - 1.0) > ROTATION_TOLERANCE:
            raise ValueError(
                f"{name}: the {CLIP_NAMES[clip]} clip's frame is not a rotation "
                f"(max |R^T R - I| = {orth:.3g}, det = {det:.6g}), expected an orthonormal "
                f"right-handed matrix within {ROTATION_TOLERANCE:g}"
            )
    rot = Rotation.from_matrix(mats)
    return rot[0:1], rot[1:2]


def aligned_initial_frames(initial, u0: np.ndarray) -> tuple[ClipRotations, list[str]]:
    """Initial frames whose x-axes are the first shape's u-axes.

    A user frame gives the roll of its clip about u; its x-axis is turned onto u_0 by the
    minimal rotation (as :func:`dloplan.sim.clips.clip_poses_from_shape` does). Without user
    frames, :func:`dloplan.frames.frame_from_axis` (z leaning to world up) is used.

    Parameters
    ----------
    initial : Rotation, array_like or None
        See :func:`as_initial_frames`.
    u0 : numpy.ndarray
        (2, 3) unit u-axes of the first shape.

    Returns
    -------
    frames, warnings
        The two single-rotation frames, and a warning per clip turned by more than 1 degree.
    """
    if initial is None:
        rot = frame_from_axis(u0)
        return (rot[0:1], rot[1:2]), []
    frames = as_initial_frames(initial)
    aligned, warnings = [], []
    for clip, frame in enumerate(frames):
        x_axis = frame.apply([1.0, 0.0, 0.0])
        turn = minimal_rotation(x_axis, u0[clip])
        angle = float(turn.magnitude()[0])
        if angle > np.radians(1.0):
            warnings.append(
                f"initial: the {CLIP_NAMES[clip]} clip's frame x-axis is {np.degrees(angle):.1f} "
                "degrees off the first shape's u-axis; the minimal rotation turned it onto it"
            )
        aligned.append(turn * frame)
    return (aligned[0], aligned[1]), warnings


def _accumulate(steps: Rotation, start: Rotation) -> Rotation:
    """Frames F_0 = start, F_i = steps[i-1] F_{i-1} (eq. 4.30), as one Rotation of len + 1."""
    frames = [start]
    for i in range(len(steps)):
        frames.append(steps[i : i + 1] * frames[-1])
    return Rotation.concatenate(frames)


def auxiliary_vector_frames(path, aux=UP, *, min_angle: float = DEFAULT_MIN_ANGLE) -> ClipRotations:
    """Clip frames from a constant auxiliary vector (thesis 4.6.1).

    v = u x a / |u x a| and w = u x v at every shape and clip.

    Parameters
    ----------
    path : array_like
        (S + 2, n + 1, 3) shapes [m].
    aux : array_like
        The auxiliary vector a, (3,) (normalized here); default world z.
    min_angle : float
        Smallest angle [rad] between u and a for which v is computed.

    Raises
    ------
    ValueError
        When u comes within ``min_angle`` of +-a (the method's failure case: v is undefined or
        spins), naming the shape and the clip; or when ``aux`` is not a non-zero 3-vector.
    """
    a = np.asarray(aux, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) == 0.0:
        raise ValueError(f"aux: got {aux!r}, expected a finite non-zero 3-vector")
    a = a / np.linalg.norm(a)
    _, u = clip_axes(path)
    v = np.cross(u, a)
    sines = np.linalg.norm(v, axis=-1)
    angles = np.arcsin(np.clip(sines, 0.0, 1.0))
    bad = angles < min_angle
    if np.any(bad):
        shape_index, clip = np.argwhere(bad)[0]
        raise ValueError(
            f"aux: the auxiliary vector {np.round(a, 6).tolist()} is "
            f"{np.degrees(angles[shape_index, clip]):.2f} degrees from the {CLIP_NAMES[clip]} "
            f"clip's u-axis at shape {shape_index} (less than "
            f"min_angle = {np.degrees(min_angle):.2f} degrees): the auxiliary-vector frame is "
            "undefined there (thesis 4.6.1); choose another vector or method 'minimal'/'rigid'"
        )
    v = v / sines[..., None]
    w = np.cross(u, v)
    mats = np.stack([u, v, w], axis=-1)
    return Rotation.from_matrix(mats[:, 0]), Rotation.from_matrix(mats[:, 1])


def minimal_rotation_frames(path, initial=None) -> tuple[ClipRotations, list[str]]:
    """Clip frames turned by the least-angle rotation between consecutive u-axes (thesis 4.6.2).

    F_i = M(u_{i-1}, u_i) F_{i-1}, with M the closed-form solution of eqs. 4.25-4.29
    (:func:`dloplan.frames.minimal_rotation`).

    Parameters
    ----------
    path : array_like
        (S + 2, n + 1, 3) shapes [m].
    initial : Rotation or array_like, optional
        The user's initial clip frames (see :func:`aligned_initial_frames`).

    Returns
    -------
    frames, warnings
    """
    _, u = clip_axes(path)
    start, warnings = aligned_initial_frames(initial, u[0])
    frames = tuple(
        _accumulate(minimal_rotation(u[:-1, clip], u[1:, clip]), start[clip]) for clip in (0, 1)
    )
    return frames, warnings


def body_frames(path, *, min_angle: float = DEFAULT_MIN_ANGLE) -> tuple[ClipRotations, np.ndarray]:
    """Equivalent rigid-body frames of every shape, one per clip (thesis Fig. 4.29-4.30).

    At each clip: x along the clip's inward u-axis, z along u x c with c the chord pointing
    from that clip's end to the other end (x_n - x_0 for the first clip, x_0 - x_n for the
    last), y = z x x.

    Returns
    -------
    frames : tuple of Rotation
        ``body_to_world`` per clip, S + 2 each (identity where undefined).
    defined : numpy.ndarray
        (S + 2, 2) bool: False where u is within ``min_angle`` of the chord (a straight
        stretch) or the chord has zero length, so the body frame is undefined.
    """
    x = as_path(path)
    _, u = clip_axes(x)
    chord = x[:, -1] - x[:, 0]
    chords = np.stack([chord, -chord], axis=1)
    normal = np.cross(u, chords)
    chord_length = np.linalg.norm(chords, axis=-1)
    sines = np.linalg.norm(normal, axis=-1) / np.where(chord_length > 0, chord_length, 1.0)
    defined = (chord_length > 0) & (np.arcsin(np.clip(sines, 0.0, 1.0)) >= min_angle)
    normal = np.where(
        defined[..., None],
        normal / np.maximum(np.linalg.norm(normal, axis=-1), 1e-300)[..., None],
        0,
    )
    mats = np.stack([u, np.cross(normal, u), normal], axis=-1)
    mats[~defined] = np.eye(3)
    return (Rotation.from_matrix(mats[:, 0]), Rotation.from_matrix(mats[:, 1])), defined


def rigid_rotation_frames(
    path, initial=None, *, min_angle: float = DEFAULT_MIN_ANGLE
) -> tuple[ClipRotations, list[str]]:
    """Clip frames moved by the rotations of the equivalent rigid body (thesis 4.6.3).

    F_i = R_i^{i-1} F_{i-1} with R_i^{i-1} = B_i B_{i-1}^T (eqs. 4.30-4.31), B the body frames
    of :func:`body_frames` at that clip. Where a body frame is undefined (the clip's link runs
    along the chord: a straight stretch), that step uses the minimal rotation instead and a
    warning names the shapes and the clip.

    Parameters
    ----------
    path : array_like
        (S + 2, n + 1, 3) shapes [m].
    initial : Rotation or array_like, optional
        The user's initial clip frames (see :func:`aligned_initial_frames`).
    min_angle : float
        Smallest angle [rad] between u and the chord for a defined body frame.

    Returns
    -------
    frames, warnings
    """
    _, u = clip_axes(path)
    start, warnings = aligned_initial_frames(initial, u[0])
    bodies, defined = body_frames(path, min_angle=min_angle)
    frames = []
    for clip in (0, 1):
        steps = bodies[clip][1:] * bodies[clip][:-1].inv()
        fallback = ~(defined[1:, clip] & defined[:-1, clip])
        if np.any(fallback):
            minimal = minimal_rotation(u[:-1, clip], u[1:, clip])
            quat = np.where(fallback[:, None], minimal.as_quat(), steps.as_quat())
            steps = Rotation.from_quat(quat)
            where = ", ".join(f"{i}->{i + 1}" for i in np.flatnonzero(fallback))
            warnings.append(
                f"rigid rotation: the {CLIP_NAMES[clip]} clip's link runs along the chord "
                f"(within {np.degrees(min_angle):.1f} degrees) so the rigid-body frame is "
                f"undefined; steps {where} use the minimal rotation"
            )
        frames.append(_accumulate(steps, start[clip]))
    return (frames[0], frames[1]), warnings
