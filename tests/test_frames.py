"""frame_from_axis, compiled: the same frames as the numpy/scipy construction it replaced;
slerp_quaternions: the same rotations as scipy's Slerp."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from dloplan.frames import (
    UP,
    compose,
    frame_from_axis,
    quaternion_x_axes,
    slerp_quaternions,
    table_frame,
)


def numpy_frames(u, up=UP) -> Rotation:
    """The former numpy construction, kept here as the reference."""
    u = np.atleast_2d(np.asarray(u, dtype=float))
    u = u / np.linalg.norm(u, axis=-1, keepdims=True)
    aux = np.broadcast_to(np.asarray(up, dtype=float), u.shape).copy()
    for fallback in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
        parallel = np.linalg.norm(np.cross(u, aux), axis=-1) < 1e-6
        aux[parallel] = fallback
    v = np.cross(aux, u)
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    return Rotation.from_matrix(np.stack([u, v, np.cross(u, v)], axis=-1))


AXES = np.concatenate([
    np.random.default_rng(3).normal(size=(200, 3)) * [[1.0, 2.0, 0.5]],
    [[0.0, 0.0, 1.0], [0.0, 0.0, -3.0], [1e-8, 0.0, 1.0], [0.0, 0.0, 1e-3]],  # along up
    [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -0.5, 0.0], [1.0, 1.0, 0.0]],
])


@pytest.mark.parametrize("up", [UP, np.array([1.0, 0.0, 0.0]), np.array([0.3, -0.2, 0.9])])
def test_frames_are_those_of_the_numpy_construction(up):
    # every trace/diagonal branch of the matrix-to-quaternion step is met among 200 random
    # axes; the quaternions agree to round-off (same sign convention as scipy's from_matrix)
    fast = frame_from_axis(AXES, up).as_quat()
    reference = numpy_frames(AXES, up).as_quat()
    assert np.abs(fast - reference).max() < 1e-14
    matrices = frame_from_axis(AXES, up).as_matrix()
    unit = AXES / np.linalg.norm(AXES, axis=1, keepdims=True)
    assert np.abs(matrices[:, :, 0] - unit).max() < 1e-15  # x-axis = u
    assert np.abs(np.linalg.det(matrices) - 1.0).max() < 1e-14


def test_frames_keep_the_shape_of_the_axes():
    assert len(frame_from_axis([1.0, 0.0, 0.0])) == 1
    assert frame_from_axis(AXES[:12].reshape(3, 4, 3)).as_quat().shape == (3, 4, 4)
    mixed_up = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])  # one up per axis
    assert np.abs(frame_from_axis(AXES[:2], mixed_up).as_quat()
                  - numpy_frames(AXES[:2], mixed_up).as_quat()).max() < 1e-14


def test_slerp_is_scipys_slerp():
    """Random keys (large steps, signs of the quaternions flipped at random: q and -q are one
    rotation), nearly equal and equal neighbouring keys, the key times themselves and both
    ends: the rotations agree with scipy's Slerp to 1e-14 (round-off of unit quaternions)."""
    rng = np.random.default_rng(11)
    keys = Rotation.random(40, random_state=5).as_quat()
    keys *= rng.choice([-1.0, 1.0], size=(40, 1))
    keys[10] = keys[9]  # equal keys
    keys[20] = (Rotation.from_quat(keys[19]) * Rotation.from_rotvec([1e-9, 0.0, 0.0])).as_quat()
    times = np.cumsum(rng.uniform(0.01, 0.5, size=40))
    t = np.concatenate([np.sort(rng.uniform(times[0], times[-1], size=2000)), times])
    mine = Rotation.from_quat(slerp_quaternions(times, keys, t))
    reference = Slerp(times, Rotation.from_quat(keys))(t)
    assert (mine * reference.inv()).magnitude().max() < 1e-14
    assert np.allclose(np.linalg.norm(slerp_quaternions(times, keys, t), axis=1), 1.0,
                       atol=1e-15)
    both = slerp_quaternions(times, np.stack([keys, keys[::-1]], axis=1), t)  # (K, 2, 4) keys
    assert np.abs(both[:, 0] - slerp_quaternions(times, keys, t)).max() < 1e-15
    assert np.abs(both[:, 1] - slerp_quaternions(times, keys[::-1], t)).max() < 1e-15


def test_quaternion_x_axes_are_the_rotations_first_columns():
    quaternions = Rotation.random(300, random_state=4).as_quat().reshape(100, 3, 4)
    expected = Rotation.from_quat(quaternions.reshape(-1, 4)).as_matrix()[:, :, 0]
    assert np.abs(quaternion_x_axes(quaternions).reshape(-1, 3) - expected).max() < 1e-15


@pytest.mark.parametrize("sizes", [(2000, 2000), (1, 500), (500, 1)])
def test_compose_is_scipys_product_bit_for_bit(sizes):
    """``frames.compose`` (the replay's clip motion, the grasp roll's scores) is ``p * q``
    element by element, bit for bit: unit quaternions of any rotation, small rotation vectors
    (a replay's sub-steps), both orders, broadcast from one rotation either way; a single
    rotation goes to scipy."""
    rng = np.random.default_rng(7)
    n, m = sizes
    p = Rotation.from_quat(rng.normal(size=(n, 4)))
    q = Rotation.from_rotvec(rng.normal(size=(m, 3)) * rng.uniform(0, 1e-3, size=(m, 1)))
    for a, b in ((p, q), (q, p), (p, p[::-1])):
        assert np.array_equal(compose(a, b).as_quat(), (a * b).as_quat())
    single = Rotation.from_rotvec([0.1, 0.2, 0.3])
    assert np.array_equal(compose(single, p).as_quat(), (single * p).as_quat())


def test_the_table_frame_turns_with_the_job_and_is_the_world_s_along_y():
    # a chord along +y given in degrees (cos 90 deg = 6e-17): exactly the world frame
    along_y = Rotation.from_euler("z", 90, degrees=True).apply([0.45, 0.0, 0.0])
    assert table_frame([along_y]).magnitude() == 0.0
    turn = Rotation.from_euler("z", 37, degrees=True)
    for d in ([0.0, 1.0, 0.2], [1.0, -0.3, -0.5]):
        np.testing.assert_allclose((table_frame([turn.apply(d)]) * table_frame([d]).inv())
                                   .as_rotvec(), turn.as_rotvec(), atol=1e-12)
        y = table_frame([d]).apply([0.0, 1.0, 0.0])  # y: the direction on the table
        np.testing.assert_allclose(y, np.array([d[0], d[1], 0.0]) / np.hypot(d[0], d[1]))
    # a vertical chord: the next direction; every direction vertical: the world frame
    np.testing.assert_allclose(table_frame([[0, 0, 1.0], [1.0, 0, 0]]).apply([0, 1.0, 0]),
                               [1.0, 0, 0], atol=1e-15)
    assert table_frame([[0, 0, 2.0]]).magnitude() == 0.0
