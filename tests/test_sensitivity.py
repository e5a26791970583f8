"""Shape sensitivity (dloplan.sim.sensitivity) against finite differences of the equilibrium.

Tolerance: 1e-6 of the largest entry. The finite differences are central with a step h = 1e-6
(m or rad or log E): their truncation error is O(h^2), below 2e-7 relative even for the stiff
curved hose (whose held free length makes the equilibrium strongly nonlinear in the clip
distance: 1.7e-5 at h = 1e-5, 1.7e-7 at h = 1e-6), and the equilibria are solved until round-off
stops the force residual falling (``POLISH``), whose effect on the quotient is below 1e-8
relative (also with the composite Ethernet's copper axial springs, passed explicitly); so
a 1e-6 disagreement can only come from a wrong derivative.
"""

from __future__ import annotations

import numpy as np
import pytest
from gripper_paths import curved_hose
from scipy.spatial.transform import Rotation

from dloplan.cable import COMPOSITE_AXIAL_MODULI, catalogue_cable
from dloplan.shapes import arc_shape, place, sine_shape
from dloplan.sim import clip_poses_from_shape, equilibrium
from dloplan.sim.sensitivity import (
    equilibrium_sensitivity,
    held_point_jacobian,
    perturbed_clips,
    twist_equilibrium_sensitivity,
)
from dloplan.sim.torsion import equilibrium_with_twist

POLISH = {"rtol": 1e-15, "max_iterations": 60}
"""The finite differences' equilibria: Newton goes on until round-off stops the residual falling
(1e-15 of the force scale is below every floor, so they never count as converged; 60 iterations
are several times what a warm start needs). A fixed tolerance would not do: with the composite
Ethernet's copper axial springs the residual's round-off floor is about 1e-10 N, and a solve
stopped at the default tolerance leaves the shape 1e-11 m off, 1e-6 of the quotient."""
STEP = 1e-6


def _case(name: str):
    if name == "ethernet-3d-arc":  # the copper axial springs (COMPOSITE_AXIAL_MODULI)
        cable = catalogue_cable("ethernet", n_links=16,
                                axial_modulus=COMPOSITE_AXIAL_MODULI["ethernet"])
        turn = Rotation.from_euler("xyz", [70, 0, 60], degrees=True)
        shape = place(arc_shape(cable.length, 16, np.radians(120)), (0.3, 0.0, 0.2), turn)
    elif name == "usb-sine-thesis-model":
        cable = catalogue_cable("usb", n_links=12).thesis_model()
        shape = place(sine_shape(cable.length, 12, 0.05), (0.2, -0.1, 0.1),
                      Rotation.from_euler("z", 30, degrees=True))
    else:  # a stiff hose with a curved rest shape (directional bending with torsion)
        cable = curved_hose(10)
        shape = place(cable.rest_shape, (0.1, 0.2, 0.3), Rotation.from_euler("x", 80, degrees=True))
    return cable, shape


def _fd_clips(solve, clips):
    columns = []
    for k in range(12):
        d = np.zeros(12)
        d[k] = STEP
        columns.append((solve(perturbed_clips(clips, d)) - solve(perturbed_clips(clips, -d)))
                       / (2 * STEP))
    return np.stack(columns, axis=-1)


def _relative(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.mark.parametrize("name", ["ethernet-3d-arc", "usb-sine-thesis-model", "curved-hose"])
def test_clip_and_modulus_jacobians_match_finite_differences(name):
    cable, shape = _case(name)
    clips = clip_poses_from_shape(shape)
    eq = equilibrium(cable, shape, clips)
    assert eq.success
    sens = equilibrium_sensitivity(cable, eq.shape, clips)
    fd = _fd_clips(lambda c: equilibrium(cable, eq.shape, c, **POLISH).shape, clips)
    assert _relative(sens.clips, fd) < 1e-6

    def at(log_e):
        return equilibrium(cable.with_modulus(cable.youngs_modulus * np.exp(log_e)), eq.shape,
                           clips, **POLISH).shape

    fd_e = (at(STEP) - at(-STEP)) / (2 * STEP)
    assert _relative(sens.log_modulus, fd_e) < 1e-6
    # a stiffer cable sags less: d z / d log E > 0 at the lowest free point
    lowest = 2 + int(np.argmin(eq.shape[2:-2, 2]))
    assert sens.log_modulus[lowest, 2] > 0


@pytest.mark.parametrize("name", ["ethernet-3d-arc", "curved-hose"])
def test_twist_jacobians_match_finite_differences_and_differ_from_the_plain_ones(name):
    cable, shape = _case(name)
    clips = clip_poses_from_shape(shape)
    # roll the first clip about its axis by 0.3 rad: the cable carries twist
    roll = np.zeros(12)
    roll[3:6] = 0.3 * clips.u_axes[0]
    clips = perturbed_clips(clips, roll)
    eq = equilibrium_with_twist(cable, shape, clips)
    assert eq.stable
    sens = twist_equilibrium_sensitivity(cable, eq)
    assert sens.torsion

    def solve(c, c_cable=cable):
        return equilibrium_with_twist(c_cable, eq.shape, c, directors=eq.directors,
                                      **POLISH).shape

    fd = _fd_clips(solve, clips)
    assert _relative(sens.clips, fd) < 1e-6
    fd_e = (solve(clips, cable.with_modulus(cable.youngs_modulus * np.exp(STEP)))
            - solve(clips, cable.with_modulus(cable.youngs_modulus * np.exp(-STEP)))) / (2 * STEP)
    assert _relative(sens.log_modulus, fd_e) < 1e-6
    # the torsion-free derivative misses the twist's coupling: measurably different
    plain = equilibrium_sensitivity(cable, eq.shape, clips)
    assert _relative(plain.clips, fd) > 1e-5


def test_rigid_motion_of_both_clips_moves_the_shape_rigidly():
    """Invariance: moving both clips by the same translation translates the equilibrium; turning
    both about a point turns it (up to gravity, so only the translation is exact)."""
    cable, shape = _case("ethernet-3d-arc")
    clips = clip_poses_from_shape(shape)
    sens = equilibrium_sensitivity(cable, equilibrium(cable, shape, clips).shape, clips)
    for axis in range(3):
        d = np.zeros(12)
        d[axis] = d[6 + axis] = 1.0
        assert np.allclose(sens.clips @ d, np.eye(3)[axis], atol=1e-9)


def test_linear_prediction_is_second_order_accurate():
    cable, shape = _case("ethernet-3d-arc")
    clips = clip_poses_from_shape(shape)
    eq = equilibrium(cable, shape, clips)
    sens = equilibrium_sensitivity(cable, eq.shape, clips)
    scale_per_clip = np.r_[[1e-2] * 3, [5e-2] * 3]  # 1 cm, 0.05 rad
    direction = np.random.default_rng(1).normal(size=12) * np.tile(scale_per_clip, 2)
    errors = []
    for scale in (1.0, 0.5):
        exact = equilibrium(cable, eq.shape, perturbed_clips(clips, scale * direction)).shape
        errors.append(np.max(np.abs(sens.predict(scale * direction) - exact)))
    assert 3.0 < errors[0] / errors[1] < 5.0  # the linearization error is O(delta^2)


def test_held_point_jacobian_matches_the_clip_geometry():
    cable, shape = _case("usb-sine-thesis-model")
    clips = clip_poses_from_shape(shape)
    jac = held_point_jacobian(clips, cable.rest_link_length)
    d = np.random.default_rng(2).normal(size=12) * 1e-6
    moved = perturbed_clips(clips, d).held_points(cable.rest_link_length)
    base = clips.held_points(cable.rest_link_length)
    assert np.allclose(moved - base, jac @ d, atol=1e-15)


def test_an_unstable_shape_or_bad_delta_is_refused():
    cable, shape = _case("ethernet-3d-arc")
    clips = clip_poses_from_shape(shape)
    # a shape far from equilibrium with its links compressed to half: H_ff indefinite
    squeezed = shape[0] + 0.5 * (shape - shape[0])
    with pytest.raises(ValueError, match="not positive definite"):
        equilibrium_sensitivity(cable, squeezed, clip_poses_from_shape(squeezed))
    with pytest.raises(ValueError, match="delta"):
        perturbed_clips(clips, np.zeros(11))
    with pytest.raises(ValueError, match="shape"):
        equilibrium_sensitivity(cable, shape[:-1], clips)


@pytest.mark.parametrize("name", ["usb-sine-thesis-model", "ethernet-3d-arc"])
def test_modulus_column_matches_the_identification_sensitivity(name):
    """An independent implementation: identify.simulate.modulus_sensitivity (sparse LU), with
    the thesis' one modulus and with the Ethernet's copper axial modulus (E then leaves the
    axial springs alone)."""
    from dloplan.identify.simulate import modulus_sensitivity

    cable, shape = _case(name)
    clips = clip_poses_from_shape(shape)
    eq = equilibrium(cable, shape, clips)
    ours = equilibrium_sensitivity(cable, eq.shape, clips).log_modulus
    assert _relative(ours, modulus_sensitivity(cable, eq.shape)) < 1e-9


@pytest.mark.parametrize("clamp_links", [2, 3])
def test_a_grip_of_several_links_has_the_jacobians_of_its_resolved_equilibria(clamp_links):
    """A finer chain holding the same length of cable holds several links per gripper (the
    correction's clip fit on a refined model, dloplan.correct.step): the free points start at
    k + 1. Both Jacobians against central differences of equilibria re-solved with the same
    clamp (model_error.clamped_equilibrium, solved to rtol 1e-14: the round-off floor of these
    forces), 1e-6 relative as above; the held points move rigidly with their clip, and k = 1
    gives the model's own sensitivity."""
    from dloplan.correct.model_error import clamped_equilibrium
    from dloplan.sim.sensitivity import held_indices

    cable, shape = _case("ethernet-3d-arc")
    fine = cable.with_links(16 * clamp_links)
    clips = clip_poses_from_shape(shape)
    start = np.array([np.interp(np.linspace(0, 16, fine.n_points), np.arange(17), shape[:, i])
                      for i in range(3)]).T

    def solve(c, log_e=0.0, guess=None):
        moved = fine.with_modulus(fine.youngs_modulus * np.exp(log_e))
        return clamped_equilibrium(moved, start if guess is None else guess, c, clamp_links,
                                   rtol=1e-14)[0]

    x0 = solve(clips)
    sens = equilibrium_sensitivity(fine, x0, clips, clamp_links=clamp_links)
    assert _relative(sens.clips, _fd_clips(lambda c: solve(c, guess=x0), clips)) < 1e-6
    fd_log = (solve(clips, STEP, x0) - solve(clips, -STEP, x0)) / (2 * STEP)
    assert _relative(sens.log_modulus, fd_log) < 1e-6
    held = held_indices(fine.n_points, clamp_links)
    assert len(held) == 2 * (clamp_links + 1)
    assert np.all(sens.log_modulus[held] == 0.0)
    # a common translation moves the held points one for one
    assert np.allclose(sens.clips[held][:, :, 0:3] + sens.clips[held][:, :, 6:9],
                       np.broadcast_to(np.eye(3), (len(held), 3, 3)), atol=1e-12)
    coarse = cable.with_links(16)
    x1 = equilibrium(coarse, shape, clips, **POLISH).shape
    one = equilibrium_sensitivity(coarse, x1, clips, clamp_links=1)
    assert np.array_equal(one.clips, equilibrium_sensitivity(coarse, x1, clips).clips)


def test_the_compiled_held_response_is_the_dense_solve():
    """sim.compiled.held_response (the sensitivity's one factorization and 13 right-hand sides,
    compiled; LAPACK's dpbtrf / dpbtrs and a dense coupling block before) is H_ff^-1 [-H_fh dh,
    -load_f] of the dense matrix its band stands for, to round-off, for any number of held
    coordinates (a clamp of one or several links), and refuses a free Hessian that is not
    positive definite."""
    from dloplan.sim.compiled import held_response

    rng = np.random.default_rng(3)
    for n_dof, width, edge in ((60, 9, 6), (75, 9, 12), (40, 3, 3)):
        lower = np.zeros((n_dof, n_dof))
        for k in range(width):
            lower += np.diag(rng.normal(size=n_dof - k), -k)
        dense = lower @ lower.T + n_dof * np.eye(n_dof)  # SPD, half bandwidth 2 (width - 1)
        w = 2 * (width - 1) + 1
        band = np.array([np.r_[np.diag(dense, -k), np.zeros(k)] for k in range(w)])
        dh, load = rng.normal(size=(2 * edge, 12)), rng.normal(size=n_dof)
        free = np.arange(edge, n_dof - edge)
        held = np.r_[0:edge, n_dof - edge : n_dof]
        expected = np.linalg.solve(dense[np.ix_(free, free)], np.concatenate(
            [-dense[np.ix_(free, held)] @ dh, -load[free, None]], axis=1))
        solved = np.empty((len(free), 13))
        assert held_response(band, edge, dh, load, solved)
        assert np.allclose(solved, expected, rtol=0.0, atol=1e-12 * np.max(np.abs(expected)))
        band[0, n_dof // 2] = -1.0  # a negative pivot: not positive definite
        assert not held_response(band, edge, dh, load, solved)
