"""The smallest eigenpair followed from a nearby mode (verify/lowest.py) against LAPACK's.

Tolerance: :func:`~dloplan.verify.lowest.follow_lowest` certifies its eigenvalue rho by a
Cholesky factor of H - (rho - tol) I: lambda_1 lies in (rho - tol - e, rho], e the
factorization's backward error (a few eps ||H|| for a band of half width 8), and LAPACK's banded
eigenvalue is within its own backward error (eps ||H|| times a low power of N) of lambda_1. With
tol at least ROUNDOFF_FACTOR eps ||H|| = 100 eps ||H|| (:func:`eigenvalue_tolerance`) the two
agree to 2 tol, the bound asserted here; they agree to a small fraction of tol in practice.
"""

import math

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.spatial.transform import Rotation

from dloplan.cable import catalogue_cable
from dloplan.obstacles import Cylinder, Table
from dloplan.sim.clips import ClipPoses
from dloplan.sim.statics import continuation, equilibrium
from dloplan.verify import lowest
from dloplan.verify.lowest import eigenvalue_tolerance, follow_lowest
from dloplan.verify.stability import (
    ROUNDOFF_FACTOR,
    band_norm,
    constrained_hessian,
    elastic_stabilities,
    stiffness_scale,
)

WEIGHTLESS = (0.0, 0.0, 0.0)
TURN = Rotation.from_euler("z", [[0.0], [180.0]], degrees=True)  # clips facing each other


def level(distance: float, height: float = 0.0) -> ClipPoses:
    return ClipPoses(np.array([[0.0, 0.0, height], [distance, 0.0, height]]), TURN)


def sagging(cable, distance: float) -> np.ndarray:
    s = np.linspace(0.0, 1.0, cable.n_points)
    guess = np.stack([np.linspace(-0.01, distance + 0.01, cable.n_points), np.zeros_like(s),
                      -0.1 * np.sin(np.pi * s)], axis=1)
    return equilibrium(cable, guess, level(distance)).shape


def straight(cable, distance: float) -> np.ndarray:
    """The straight (weightless) equilibrium between clips ``distance`` apart."""
    held = level(distance).held_points(cable.rest_link_length)
    x = np.zeros((cable.n_points, 3))
    x[[0, 1, -2, -1]] = held
    x[1:-1, 0] = np.linspace(held[1, 0], held[2, 0], cable.n_links - 1)
    return x


def band_of(cable, x, gravity=None) -> np.ndarray:
    options = {} if gravity is None else {"gravity": gravity}
    return constrained_hessian(cable, x, **options)[1]


def lapack(band, count=1):
    return sla.eig_banded(band, lower=True, select="i", select_range=(0, count - 1))


def agree(band, start, value, scale):
    """follow_lowest from (start, value) and LAPACK's smallest eigenpair, and the tolerance."""
    tolerance = eigenvalue_tolerance(value, scale, band_norm(band), ROUNDOFF_FACTOR)
    found = follow_lowest(band, start, value, scale, tolerance)
    values, vectors = lapack(band)
    return found, values[0], vectors[:, 0], tolerance


def test_a_definite_hessian_from_the_neighbouring_mode():
    """A sagging ethernet cable whose clips came 1 cm closer: its lowest mode from the one
    before, the eigenvalue to the tolerance, the mode to 1e-6."""
    cable = catalogue_cable("ethernet", n_links=30)
    before, after = band_of(cable, sagging(cable, 0.40)), band_of(cable, sagging(cable, 0.39))
    values, vectors = lapack(before)
    found, value, vector, tolerance = agree(after, vectors[:, 0], values[0],
                                            stiffness_scale(cable))
    assert value > 0 and found is not None
    assert abs(found[0] - value) <= 2 * tolerance
    assert abs(found[1] @ vector) == pytest.approx(1.0, abs=1e-6)
    assert tolerance < 1e-5 * value  # the test asks something: the eigenvalue to 1e-5


def test_an_indefinite_hessian_a_compressed_straight_chain():
    """The straight weightless chain compressed past its buckling load (lambda_1 < 0): its
    negative eigenvalue followed from a less compressed one's mode."""
    cable = catalogue_cable("pa12", n_links=30)
    rest = (cable.n_links - 1) * cable.rest_link_length
    before = band_of(cable, straight(cable, 0.991 * rest), WEIGHTLESS)
    after = band_of(cable, straight(cable, 0.99 * rest), WEIGHTLESS)
    values, vectors = lapack(before)
    found, value, _, tolerance = agree(after, vectors[:, 0], values[0], stiffness_scale(cable))
    assert value < 0 and found is not None
    assert abs(found[0] - value) <= 2 * tolerance


def test_a_near_singular_hessian():
    """A definite band shifted by its smallest eigenvalue (lambda_1 zero to round-off): the
    followed eigenvalue is zero to the tolerance, as LAPACK's is."""
    cable = catalogue_cable("ethernet", n_links=30)
    before, after = band_of(cable, sagging(cable, 0.40)), band_of(cable, sagging(cable, 0.39))
    shifted = after.copy()
    shifted[0] -= lapack(after)[0][0]
    values, vectors = lapack(before)
    found, value, _, tolerance = agree(shifted, vectors[:, 0], values[0] - lapack(after)[0][0],
                                       stiffness_scale(cable))
    assert abs(value) <= tolerance and found is not None
    assert abs(found[0] - value) <= 2 * tolerance


def test_the_second_mode_never_passes_for_the_lowest():
    """Started from the second eigenvector and eigenvalue (two modes that crossed between
    sub-steps): the certificate refuses lambda_2, so the result is lambda_1 or None."""
    cable = catalogue_cable("ethernet", n_links=30)
    band = band_of(cable, sagging(cable, 0.40))
    values, vectors = lapack(band, 2)
    tolerance = eigenvalue_tolerance(values[1], stiffness_scale(cable), band_norm(band),
                                     ROUNDOFF_FACTOR)
    found = follow_lowest(band, vectors[:, 1], values[1], stiffness_scale(cable), tolerance)
    assert found is None or abs(found[0] - values[0]) <= 2 * tolerance
    # and with the iterations cut to one, where it cannot have converged: refused
    original = lowest.MAX_ITERATIONS
    try:
        lowest.MAX_ITERATIONS = 1
        assert follow_lowest(band, vectors[:, 1], values[1], stiffness_scale(cable),
                             tolerance) is None
    finally:
        lowest.MAX_ITERATIONS = original


def test_bad_starts_are_refused():
    cable = catalogue_cable("ethernet", n_links=30)
    band = band_of(cable, sagging(cable, 0.40))
    zero = np.zeros(band.shape[1])
    assert follow_lowest(band, zero, 1.0, 1.0, 1e-6) is None
    assert follow_lowest(band, np.full(band.shape[1], math.nan), 1.0, 1.0, 1e-6) is None
    assert follow_lowest(band, np.ones(band.shape[1]), math.nan, 1.0, 1e-6) is None


def test_followed_stabilities_are_the_banded_solves(monkeypatch):
    """``elastic_stabilities(method="follow")`` along the sub-steps of a USB cable lowered
    onto a table beside a peg (it touches down, points press): every verdict, message and
    contact state (sliding flags included) of ``method="band"``, the eigenvalues (without and
    with the pressing points sticking) to the tolerance, most of them followed."""
    cable = catalogue_cable("usb", 24)
    contacts = (Cylinder((0.22, 0.03, 0.0), 0.012, 0.06, "peg"), Table(0.0))
    s = np.linspace(0.0, 1.0, cable.n_points)
    guess = np.stack([np.linspace(-0.01, 0.46, cable.n_points), np.zeros_like(s),
                      0.15 - 0.1 * np.sin(np.pi * s)], axis=1)
    steps = continuation(cable, guess, [level(0.45, 0.15), level(0.45, 0.03)], substeps=40,
                         contacts=contacts, every_substep=True)
    shapes = np.stack([eq.shape for group in steps for eq in group])
    calls = []

    def counted(*args):
        calls.append(lowest.follow_lowest(*args))
        return calls[-1]

    monkeypatch.setattr("dloplan.verify.stability.follow_lowest", counted)
    followed = elastic_stabilities([cable] * len(shapes), shapes, contacts=contacts, k=1,
                                   method="follow")
    banded = elastic_stabilities([cable] * len(shapes), shapes, contacts=contacts, k=1,
                                 method="band")
    scale = stiffness_scale(cable)
    for x, a, b in zip(shapes, followed, banded, strict=True):
        norm = band_norm(constrained_hessian(cable, x, contacts=contacts)[1])
        assert (a.stable, a.stable_with_friction, a.message, a.contacts, a.threshold) == \
            (b.stable, b.stable_with_friction, b.message, b.contacts, b.threshold)
        for got, want in ((a.smallest, b.smallest), (a.sticking, b.sticking)):
            assert abs(got - want) <= 2 * eigenvalue_tolerance(want, scale, norm,
                                                               ROUNDOFF_FACTOR)
    assert any(any(state.active for state in stab.contacts) for stab in banded)
    assert any(stab.sticking != stab.smallest for stab in banded)  # points press
    accepted = sum(found is not None for found in calls)
    assert accepted > 0.8 * len(shapes)
    with pytest.raises(ValueError, match="k"):
        elastic_stabilities([cable], shapes[:1], k=3, method="follow")
