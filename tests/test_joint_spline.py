"""The joint spline of a robot program (dloplan.robot.joint_spline), tested as numerics.

- It is scipy's ``CubicSpline(x, y, axis=0)`` (not-a-knot) to round-off: values, first and
  second derivatives on random knots and values, at the knots, between them and outside
  (extrapolated), for 2 (a line), 3 (a parabola: scipy's special case), 4, 5 and many knots,
  including spacings uneven enough that the tridiagonal solve interchanges rows.
- It reproduces what it must exactly (to round-off): a cubic from 4 knots on, the parabola
  through 3 points, the line through 2; the values at the knots; continuous first and second
  derivatives at every interior knot; one cubic over the first two and the last two pieces
  (not-a-knot).
- Its callers' outputs are those of scipy's spline: a program's sampled joint motion and a
  described cell's line deviation.
- Bad input names the argument, what it got and what it expects.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from dloplan.robot import line_deviation, motion
from dloplan.robot.chain import CellArm
from dloplan.robot.description import load_arm, vendored
from dloplan.robot.joint_spline import NotAKnotSpline
from dloplan.trajectory.timelaw import Profile

ULPS = 8.0
"""Round-off allowed against scipy, in units of the spacing of the largest value compared."""


def _knots(rng, n, uneven=False):
    """(n,) strictly increasing knots: random, or random with spacings over four decades."""
    if uneven:
        return np.concatenate([[0.0], np.cumsum(np.exp(rng.uniform(-7.0, 2.0, n - 1)))])
    return np.concatenate([[0.0], np.cumsum(rng.uniform(0.05, 1.0, n - 1))]) - 0.3


def _assert_round_off(got, expected):
    assert got.shape == expected.shape
    np.testing.assert_allclose(got, expected, rtol=0,
                               atol=ULPS * np.spacing(np.abs(expected).max()))


@pytest.mark.parametrize("n", [2, 3, 4, 5, 9, 60])
@pytest.mark.parametrize("uneven", [False, True])
def test_it_is_scipys_not_a_knot_spline_to_round_off(n, uneven):
    rng = np.random.default_rng(n + 100 * uneven)
    for columns in [(), (7,), (3, 2)]:
        x = _knots(rng, n, uneven)
        y = rng.normal(size=(n, *columns))
        mine, scipys = NotAKnotSpline(x, y), CubicSpline(x, y, axis=0)
        width = x[-1] - x[0]
        at = np.concatenate([x, rng.uniform(x[0] - 0.2 * width, x[-1] + 0.2 * width, 300)])
        for nu in (0, 1, 2):
            _assert_round_off(mine(at, nu), scipys(at, nu))
            _assert_round_off(mine(x[1] + 0.01, nu), scipys(x[1] + 0.01, nu))  # a scalar


def test_the_tridiagonal_solve_pivots_like_lapack():
    """Spacings over four decades make the elimination interchange rows (LAPACK ``gtsv``'s
    partial pivoting); the slopes at the knots still are scipy's."""
    rng = np.random.default_rng(7)
    for _ in range(100):
        n = int(rng.integers(4, 12))
        x = _knots(rng, n, uneven=True)
        y = rng.normal(size=(n, 2))
        _assert_round_off(NotAKnotSpline(x, y)(x, 1), CubicSpline(x, y, axis=0)(x, 1))


@pytest.mark.parametrize("n", [4, 5, 12])
def test_a_cubic_is_reproduced(n):
    rng = np.random.default_rng(n)
    x = _knots(rng, n)
    x = (x - x[0]) / (x[-1] - x[0])
    a = rng.normal(size=(4, 3))

    def cubic(t, nu):
        t = t[:, None]
        return [a[0] + a[1] * t + a[2] * t**2 + a[3] * t**3, a[1] + 2 * a[2] * t + 3 * a[3] * t**2,
                2 * a[2] + 6 * a[3] * t][nu]

    spline = NotAKnotSpline(x, cubic(x, 0))
    at = np.linspace(-0.1, 1.1, 101)
    for nu, tolerance in zip((0, 1, 2), (1e-13, 1e-11, 1e-9), strict=True):
        np.testing.assert_allclose(spline(at, nu), cubic(at, nu), rtol=0, atol=tolerance)


def test_three_knots_give_the_parabola_and_two_the_line():
    x = np.array([0.1, 0.4, 1.3])
    y = np.array([[1.0, -2.0], [0.5, 0.0], [2.0, 1.0]])
    at = np.linspace(-0.5, 2.0, 41)
    for column in range(2):
        parabola = np.polyfit(x, y[:, column], 2)
        for nu in (0, 1, 2):
            np.testing.assert_allclose(NotAKnotSpline(x, y)(at, nu)[:, column],
                                       np.polyval(np.polyder(parabola, nu), at), atol=1e-12)
    line = NotAKnotSpline(x[:2], y[:2])
    np.testing.assert_allclose(line(at), y[0] + (at[:, None] - x[0]) * (y[1] - y[0]) / 0.3,
                               atol=1e-12)
    np.testing.assert_array_equal(line(at, 2), 0.0)


def test_it_interpolates_is_twice_continuously_differentiable_and_not_a_knot():
    rng = np.random.default_rng(11)
    x = _knots(rng, 8)
    y = rng.normal(size=(8, 3))
    spline = NotAKnotSpline(x, y)
    np.testing.assert_array_equal(spline(x[:-1]), y[:-1])  # h = 0: the knot's value itself
    np.testing.assert_allclose(spline(x[-1]), y[-1], rtol=0, atol=1e-14)
    c = spline.coefficients  # (4, pieces, 3) the coefficients of h^3, h^2, h, 1
    dx = np.diff(x)[:, None]
    ends = [c[0] * dx**3 + c[1] * dx**2 + c[2] * dx + c[3],  # each piece at its right end
            3 * c[0] * dx**2 + 2 * c[1] * dx + c[2], 6 * c[0] * dx + 2 * c[1]]
    for nu, end in enumerate(ends):
        np.testing.assert_allclose(end[:-1], spline(x[1:-1], nu), rtol=0, atol=1e-12)
    np.testing.assert_allclose(c[0, 0], c[0, 1], rtol=1e-12)  # third derivative continuous
    np.testing.assert_allclose(c[0, -2], c[0, -1], rtol=1e-12)  # at x[1] and x[-2]


def _scipys_move_spline(path):
    return CubicSpline(np.linspace(0.0, 1.0, len(path)), path, axis=0)


def test_a_programs_joint_motion_is_the_one_scipys_spline_gave(monkeypatch):
    """:class:`~dloplan.robot.motion.JointMotion` sampled with the own spline and with
    scipy's: moves of 1, 2, 3 and 8 sub-steps, one overlapping the next (a fly-by)."""
    rng = np.random.default_rng(5)
    laws = tuple(Profile.jerk_limited(d, 6.0, 50.0) for d in (1.0, 1.5, 0.8, 2.0))
    paths = tuple(tuple(rng.uniform(-1, 1, (n + 1, 6)) for n in (1, 2, 3, 8)) for _ in range(2))
    starts = np.concatenate([[0.0], np.cumsum([law.duration for law in laws])[:-1]])
    starts[2] -= 0.1
    arrivals = np.concatenate([starts, [starts[-1] + laws[-1].duration]])
    t = np.linspace(0.0, arrivals[-1], 777)
    mine = motion.JointMotion(paths, laws, starts, arrivals).sample(t, 2)
    monkeypatch.setattr(motion, "move_spline", _scipys_move_spline)
    scipys = motion.JointMotion(paths, laws, starts, arrivals).sample(t, 2)
    for got, expected in zip(mine, scipys, strict=True):
        for order in range(3):
            _assert_round_off(got[order], expected[order])


def test_a_cells_line_deviation_is_the_one_scipys_spline_gave(monkeypatch):
    """:func:`~dloplan.robot.line_deviation.line_deviation` (the spline for 3 sub-steps and
    more) of a UR5e's moves with the own spline and with scipy's."""
    arm = CellArm("left", load_arm(vendored("ur5e.urdf"), "tool0"))
    rng = np.random.default_rng(2)
    counts = np.array([3, 5, 1, 4])
    joints = np.cumsum(rng.normal(0.0, 0.05, (1 + counts.sum(), 6)), axis=0) + [0, -1.2, 1.5,
                                                                               -1.8, -1.5, 0]
    positions = rng.uniform(0.2, 0.5, (len(counts) + 1, 3))
    mine = line_deviation.line_deviation(arm, joints, positions, counts)
    monkeypatch.setattr(line_deviation, "move_spline", _scipys_move_spline)
    scipys = line_deviation.line_deviation(arm, joints, positions, counts)
    _assert_round_off(mine, scipys)
    assert np.all(mine[1:] > 0.0)


@pytest.mark.parametrize(("x", "y", "nu", "words"), [
    ([0.0], [[1.0]], 0, "x: got shape (1,), expected (n,) knots with n >= 2"),
    ([[0.0, 1.0]], [1.0, 2.0], 0, "x: got shape (1, 2)"),
    ([0.0, 1.0, 2.0], [1.0, 2.0], 0, "y: got shape (2,), expected (3, ...) values"),
    ([0.0, 1.0], [1.0, np.nan], 0, "x, y: expected finite values"),
    ([0.0, np.inf], [1.0, 2.0], 0, "x, y: expected finite values"),
    ([0.0, 1.0, 1.0], [1.0, 2.0, 3.0], 0, "expected strictly increasing knots"),
    ([0.0, 2.0, 1.0], [1.0, 2.0, 3.0], 0, "expected strictly increasing knots"),
    ([0.0, 1.0], [1.0, 2.0], 3, "nu: got 3, expected 0, 1 or 2"),
])
def test_bad_input_is_refused_with_its_name(x, y, nu, words):
    with pytest.raises(ValueError) as refused:
        NotAKnotSpline(x, y)(0.5, nu)
    assert words in str(refused.value)
