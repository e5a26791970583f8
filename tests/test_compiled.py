"""The compiled kernels against the readable numpy reference, and the compiled Newton loop.

Tolerances: the compiled kernels evaluate the same formulas in another order, so they agree to
round-off (1e-12 relative to the largest entry; observed ~1e-15). The compiled and the generic
Newton loops take the same decisions on the same numbers up to round-off, so their iterates agree
to about 1e-12 m and their iteration counts exactly on these cases (energies along the way to
1e-9: a saddle escape of a strongly compressed cable amplifies round-off for a while).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import level_clips, sagging_guess
from scipy.linalg import lapack
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from dloplan import catalogue_cable
from dloplan.cable import COMPOSITE_AXIAL_MODULI
from dloplan.geometry import arc_length, resample_by_arc_length, shape_length
from dloplan.obstacles.shapes import Cylinder, Table
from dloplan.physics.chain import (
    SpringChain,
    energy,
    forces,
    gradient,
    gradient_and_hessian_band,
    shape_derivatives,
    shape_energy,
    shape_forces,
)
from dloplan.physics.compiled import (
    GEOMETRY_COLUMNS,
    chain_derivatives,
    chain_energy,
    chain_gradient,
    kept_chain_derivatives,
    kept_chain_energy,
    resample_polyline,
    stretch_to_length,
)
from dloplan.sim.clips import ClipPoses, conform_guess, place_held_points
from dloplan.sim.compiled import CONVERGED, MAX_ITERATIONS, restore_link_lengths
from dloplan.sim.newton import factor_band, solve_band, trust_region_newton
from dloplan.sim.result import clip_reactions, residual_tolerance
from dloplan.sim.statics import equilibrium, minimize_energy


def arc(cable, total_angle):
    n = cable.n_links
    headings = total_angle / (n - 1) * np.arange(n)
    steps = np.stack([np.cos(headings), np.zeros(n), np.sin(headings)], 1)
    return np.vstack([np.zeros(3), np.cumsum(steps, 0)]) * cable.rest_link_length


def chain_cases():
    straight = catalogue_cable("ethernet", n_links=12)
    curved = replace(straight, rest_shape=arc(straight, 2.0))
    thesis = catalogue_cable("pa12", n_links=7, bending="thesis")
    contacts = (Cylinder(base=(0.05, 0.0, -0.2), radius=0.02, height=0.4), Table(-0.01))
    return {
        "straight": (straight, SpringChain.from_cable(straight)),
        "curved": (curved, SpringChain.from_cable(curved)),
        "thesis": (thesis, SpringChain.from_cable(thesis, (0.0, 3.0, -9.81))),
        "contacts": (straight, SpringChain.from_cable(straight, contacts=contacts)),
    }


def relative(a, b):
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


@pytest.mark.parametrize("kind", ["straight", "curved", "thesis", "contacts"])
def test_compiled_kernels_match_the_numpy_reference(kind, rng):
    cable, chain = chain_cases()[kind]
    base = cable.rest_shape if cable.rest_shape is not None else arc(cable, 0.0)
    for scale in (1e-4, 0.01, 0.05):  # near rest (small angles, series branch) to tangled
        x = base + scale * rng.standard_normal(base.shape)
        f, g, band = shape_derivatives(chain, x)
        g_ref, band_ref = gradient_and_hessian_band(chain, x)
        assert abs(f - float(energy(chain, x))) <= 1e-12 * abs(float(energy(chain, x)))
        assert abs(shape_energy(chain, x) - f) <= 1e-12 * abs(f)
        assert relative(g, gradient(chain, x)) < 1e-12
        assert relative(g, g_ref - forces(chain, x).gravity) < 1e-12
        assert relative(band, band_ref) < 1e-12
        fast, slow = shape_forces(chain, x), forces(chain, x)
        for part in ("axial", "bending", "gravity", "contact"):
            if getattr(slow, part) is not None:
                assert relative(getattr(fast, part), getattr(slow, part)) < 1e-12



@pytest.mark.parametrize("kind", ["straight", "curved", "thesis"])
def test_the_gradient_kernel_is_the_derivatives_kernels_gradient_bit_for_bit(kind, rng):
    """``chain_gradient`` (the explicit step's: dG/dc without the second derivative) gives the
    energy and gradient of ``chain_derivatives`` (with the Hessian band) exactly, near rest
    (the small-angle series), bent and tangled."""
    cable, chain = chain_cases()[kind]
    base = cable.rest_shape if cable.rest_shape is not None else arc(cable, 0.0)
    constants = chain.constants
    for scale in (1e-6, 1e-4, 0.01, 0.05):
        x = np.ascontiguousarray(base + scale * rng.standard_normal(base.shape))
        grad, full = np.empty_like(x), np.empty_like(x)
        band = np.empty((9, 3 * len(x)))
        assert chain_gradient(x, *constants, grad) == chain_derivatives(x, *constants, full, band)
        np.testing.assert_array_equal(grad, full)

@pytest.mark.parametrize("kind", ["straight", "curved", "thesis"])
def test_the_derivatives_from_the_energys_kept_geometry_are_equal_bit_for_bit(kind, rng):
    """The Newton loop's derivatives at an accepted trial reuse the link lengths, directions
    and joint angles its energy computed (``kept_chain_energy``, ``kept_chain_derivatives``):
    the energy, gradient and band are ``chain_energy``'s and ``chain_derivatives``' exactly,
    near rest (the small-angle series, a straight chain), bent and tangled; and the kept rows
    are x's, not a shape evaluated before."""
    cable, chain = chain_cases()[kind]
    base = cable.rest_shape if cable.rest_shape is not None else arc(cable, 0.0)
    constants = chain.constants
    geometry = np.full((len(base) - 1, GEOMETRY_COLUMNS), np.nan)
    for scale in (0.0, 1e-6, 1e-4, 0.01, 0.05):
        x = np.ascontiguousarray(base + scale * rng.standard_normal(base.shape))
        grad, kept_grad = np.empty_like(x), np.empty_like(x)
        band, kept_band = np.empty((9, 3 * len(x))), np.full((9, 3 * len(x)), np.nan)
        f = chain_energy(x, *constants)
        assert kept_chain_energy(x, *constants, geometry) == f
        assert not np.isnan(geometry[:-1]).any()
        assert kept_chain_derivatives(x, *constants, geometry, kept_grad, kept_band) \
            == chain_derivatives(x, *constants, grad, band)
        np.testing.assert_array_equal(kept_grad, grad)
        np.testing.assert_array_equal(kept_band, band)


def test_contact_terms_are_active_in_the_contact_case(rng):
    cable, chain = chain_cases()["contacts"]
    x = arc(cable, 0.0) + np.array([0.0, 0.0, -0.012])  # below the table top
    f, _, band = shape_derivatives(chain, x)
    plain = SpringChain.from_cable(cable)
    assert f > shape_energy(plain, x)
    assert np.max(band[0]) > 0.5 * chain.contact_stiffness  # the penalty on the diagonal


def test_banded_cholesky_matches_lapack(rng):
    for n_dof, width in ((1, 0), (5, 8), (40, 3), (141, 8), (300, 10), (60, 1)):
        a = rng.standard_normal((n_dof, n_dof))
        dense = a @ a.T + n_dof * np.eye(n_dof)
        dense[np.abs(np.subtract.outer(np.arange(n_dof), np.arange(n_dof))) > width] = 0.0
        dense += (width + 2) * n_dof * np.eye(n_dof)  # diagonally dominant: positive definite
        band = np.zeros((width + 1, n_dof))
        for k in range(min(width + 1, n_dof)):
            band[k, : n_dof - k] = np.diag(dense, -k)
        factor = factor_band(band)
        reference, info = lapack.dpbtrf(band, lower=1)
        assert info == 0
        assert relative(factor, reference) < 1e-12
        rhs = rng.standard_normal(n_dof)
        assert relative(solve_band(factor, rhs), np.linalg.solve(dense, rhs)) < 1e-10
        assert factor_band(band, -2.0 * np.max(band[0])) is None  # indefinite after the shift


def test_stretch_to_length_matches_a_bracketing_root(rng):
    chord = np.stack([np.linspace(0, 0.3, 20), np.zeros(20), np.zeros(20)], 1)
    deviation = rng.standard_normal((20, 3)) * 0.01
    need = 0.45
    a = stretch_to_length(chord, deviation, need)
    b = brentq(lambda s: float(shape_length(chord + s * deviation)) - need, 0.0, 1e3, xtol=1e-14)
    assert abs(a - b) <= 1e-10 * b
    assert abs(float(shape_length(chord + a * deviation)) - need) < 1e-12


@pytest.mark.parametrize("case", ["buckled", "sagging", "curved", "stiff", "saddle",
                                  "sagging, copper", "saddle, copper"])
def test_compiled_newton_loop_follows_the_generic_loop(case):
    """With E_a = E both loops take the plain steps; with the copper axial springs both try the
    second-order correction (``SpringChain.stiff_axial``)."""
    cable = catalogue_cable("ethernet", n_links=30)
    if case.endswith(", copper"):
        cable = replace(cable, axial_modulus=COMPOSITE_AXIAL_MODULI["ethernet"])
        case = case.removesuffix(", copper")
    clips = level_clips(0.4)
    if case == "curved":
        cable = replace(cable, rest_shape=arc(cable, 1.0))
    if case == "stiff":
        cable = cable.with_modulus(1e10)
    n = cable.n_links
    l = cable.rest_link_length
    straight = np.stack([np.linspace(-l / 2, 0.4 + l / 2, n + 1), np.zeros(n + 1),
                         np.zeros(n + 1)], 1)
    # a curved rest shape from a straight start stalls (no bending direction is preferred)
    guess = sagging_guess(cable, 0.4) if case in ("sagging", "curved") else straight
    chain = SpringChain.from_cable(cable)
    start = conform_guess(cable, guess, clips)
    if case == "saddle":  # weightless and straight: Newton finds the straight, compressed
        chain = SpringChain.from_cable(cable, (0.0, 0.0, 0.0))  # saddle and must leave it
        start = place_held_points(straight, clips, l)
    free = slice(2, n - 1)
    # the solvers' own tolerance: with the Ethernet's copper axial springs 1e-10 of the force
    # scale is below the residual's round-off floor (residual_tolerance)
    tolerance = residual_tolerance(cable, x=start)
    x, g, iterations, residual, stable, history, message = minimize_energy(
        chain, start, free, cable.length, tolerance)

    def derivatives(y):
        _, grad, band = shape_derivatives(chain, y)
        return grad[free].ravel(), band[:, 3 * free.start: 3 * free.stop], \
            float(np.max(np.linalg.norm(grad[free], axis=1))), grad

    def moved(y, p):
        out = y.copy()
        out[free] += p.reshape(-1, 3)
        return out

    def corrected(y, p):
        out = moved(y, p)
        return out if restore_link_lengths(y, out, free.start, free.stop) else None

    generic = trust_region_newton(
        start, lambda y: shape_energy(chain, y), derivatives, moved,
        lambda p: float(np.max(np.linalg.norm(p.reshape(-1, 3), axis=1))),
        cable.length, tolerance, corrected=corrected if chain.stiff_axial else None)
    assert stable and generic.stable
    assert iterations == generic.iterations
    assert message == generic.message
    assert np.max(np.abs(x - generic.state)) < 1e-12
    # with E_a = E to 1e-9; with the copper springs to 1e-10 of the run's largest energy: the
    # saddle's compressed springs start at 309 J and end at 3.4 mJ, and the two loops' iterates
    # part by round-off on the way down (at most 4.6e-9 J, at 3.6 mJ; the same steps, the same
    # end to 1e-12 m)
    atol = 1e-10 * history[0] if chain.stiff_axial else 0.0
    assert np.allclose(history, generic.history, rtol=1e-9, atol=atol)
    assert np.all(np.diff(history) <= 1e-13 * np.abs(history[:-1]))
    if case == "saddle":
        assert np.max(np.hypot(x[:, 1], x[:, 2])) > 0.05  # buckled out of the line
        return
    eq = equilibrium(cable, guess, clips)
    assert eq.success and np.max(np.abs(eq.shape - x)) < 1e-12


def numpy_conform(cable, guess, clips, gravity):
    """The numpy construction conform_guess compiles (its docstring): blend the guess's ends
    onto the inner held points, scale its deviation from the chord to the rest length, respace."""
    l = cable.rest_link_length
    held = clips.held_points(l)
    x = np.array(guess, dtype=float)
    x[[0, 1, -2, -1]] = held
    inner = np.array(guess[1:-1], dtype=float)
    need = (cable.n_links - 2) * l
    s = arc_length(inner)
    s = s / s[-1] if s[-1] > 0 else np.linspace(0.0, 1.0, len(inner))
    inner += (1 - s)[:, None] * (held[1] - inner[0]) + s[:, None] * (held[2] - inner[-1])
    chord = held[1] + s[:, None] * (held[2] - held[1])
    deviation = inner - chord
    if abs(shape_length(inner) / need - 1.0) < 1e-6:
        x[1:-1] = inner
        return x
    if np.linalg.norm(held[2] - held[1]) >= need:
        x[1:-1] = resample_by_arc_length(chord, len(inner))
        return x
    if np.max(np.linalg.norm(deviation, axis=1)) < 1e-9 * cable.length:
        axis = (held[2] - held[1]) / np.linalg.norm(held[2] - held[1])
        for candidate in (np.asarray(gravity, dtype=float), np.array([0, 0, -1.0]),
                          np.array([0, 1.0, 0])):
            perp = candidate - (candidate @ axis) * axis
            if np.linalg.norm(perp) > 1e-6 * max(np.linalg.norm(candidate), 1e-300):
                break
        bow = perp / np.linalg.norm(perp)
        deviation = 0.5 * (1.0 - np.cos(2.0 * np.pi * s))[:, None] * bow * cable.length
    amplitude = brentq(lambda a: float(shape_length(chord + a * deviation)) - need, 0.0, 1e6,
                       xtol=1e-15)
    x[1:-1] = resample_by_arc_length(chord + amplitude * deviation, len(inner))
    return x


@pytest.mark.parametrize("n", [5, 12, 60])
def test_compiled_conform_guess_matches_the_numpy_construction(n, rng):
    cable = catalogue_cable("ethernet", n_links=n)
    l = cable.rest_link_length
    straight = np.stack([np.linspace(-l / 2, 0.4 + l / 2, n + 1), np.zeros(n + 1),
                         np.zeros(n + 1)], 1)
    askew = ClipPoses(np.array([[0.0, 0, 0], [0.1, 0.2, 0.05]]),
                      Rotation.random(2, random_state=3))
    upright = ClipPoses(np.array([[0.0, 0, 0], [0.0, 0, 0.3]]),
                        Rotation.from_euler("y", [[-90.0], [90.0]], degrees=True))
    guesses = {"straight": straight, "crooked": straight + rng.normal(0, 0.01, straight.shape),
               "short": 0.5 * straight, "wavy": sagging_guess(cable, 0.4)}
    for clips in (level_clips(0.4), askew, upright, level_clips(0.6)):
        for gravity in ((0, 0, -9.81), (0, 0, 0), (3.0, 0, 0)):
            for guess in guesses.values():
                if np.linalg.norm(np.diff(clips.held_points(l)[1:3], axis=0)) > 1.02 * (n - 2) * l:
                    continue  # out of reach: equilibrium refuses these clips first
                fast = conform_guess(cable, guess, clips, gravity)
                assert np.abs(fast - numpy_conform(cable, guess, clips, gravity)).max() < 1e-12
                assert np.abs(fast[[0, 1, -2, -1]] - clips.held_points(l)).max() < 1e-15


def test_compiled_resampling_matches_the_numpy_resampling(rng):
    points = np.cumsum(rng.normal(size=(30, 3)), axis=0)
    points = np.insert(points, 7, points[6], axis=0)  # a zero-length link is skipped
    for m in (2, 3, 31, 200):
        out = np.empty((m, 3))
        resample_polyline(points, out)
        assert np.abs(out - resample_by_arc_length(points, m)).max() < 1e-12


def test_compiled_clip_reactions_are_force_and_moment_sums(rng):
    x = rng.normal(size=(9, 3))
    grad = rng.normal(size=(9, 3))
    clips = ClipPoses(rng.normal(size=(2, 3)), Rotation.random(2, random_state=1))
    wrenches = clip_reactions(x, grad, clips)
    for k, idx in enumerate(([0, 1], [-2, -1])):
        assert np.allclose(wrenches[k, :3], -grad[idx].sum(0), rtol=0, atol=1e-14)
        moment = np.cross(x[idx] - clips.positions[k], -grad[idx]).sum(0)
        assert np.allclose(wrenches[k, 3:], moment, rtol=0, atol=1e-14)
    assert np.all(clip_reactions(x, grad, clips, "first")[1] == 0.0)


def test_clip_axes_are_the_rotations_x_axes_and_the_positions_are_copied():
    rotations = Rotation.random(2, random_state=7)
    positions = np.array([[0.0, 0, 0], [0.3, 0, 0]])
    clips = ClipPoses(positions, rotations)
    assert np.abs(clips.u_axes - rotations.apply([1.0, 0, 0])).max() < 1e-15
    before = clips.held_points(0.01)
    positions[1, 0] = 5.0  # the caller's array: the clips keep their own copy
    assert np.array_equal(clips.held_points(0.01), before)


def test_contact_free_chains_are_built_once_per_cable_and_gravity():
    cable = catalogue_cable("usb", n_links=6)
    assert SpringChain.from_cable(cable) is SpringChain.from_cable(cable)
    weightless = SpringChain.from_cable(cable, (0.0, 0.0, 0.0))
    assert weightless is not SpringChain.from_cable(cable)
    assert np.all(weightless.gravity == 0.0)
    table = (Table(-0.01),)
    assert SpringChain.from_cable(cable, contacts=table) is not \
        SpringChain.from_cable(cable, contacts=table)
    other = catalogue_cable("usb", n_links=6)  # an equal cable, another object: its own chain
    assert SpringChain.from_cable(other) is not SpringChain.from_cable(cable)


def test_every_cached_kernel_has_a_name_of_its_own():
    """numba tells compilations of one qualified name apart by a per-process counter in the
    symbol name; code cached by two processes at once (the test workers, a study's processes)
    can then hold two different kernels under one symbol, and the loader links the wrong one
    (seen: the width-8 banded pass in width-10 solves, failing torsion tests after a cold
    parallel run). So no cached kernel may be a closure or share its qualified name."""
    import importlib
    import pkgutil

    from numba.core.registry import CPUDispatcher

    import dloplan

    names = {}
    for info in pkgutil.walk_packages(dloplan.__path__, "dloplan."):
        module = importlib.import_module(info.name)
        for value in vars(module).values():
            if isinstance(value, CPUDispatcher) and value.__module__ == info.name:
                qualified = f"{info.name}.{value.py_func.__qualname__}"
                names.setdefault(qualified, set()).add(id(value))
    assert names, "no compiled kernels found"
    assert [name for name in names if "<locals>" in name] == []
    assert [name for name, kernels in names.items() if len(kernels) > 1] == []


_ALLOCATIONS = """
import numpy as np
from numba.core.runtime import rtsys
from dloplan import catalogue_cable
from dloplan.physics.chain import SpringChain
from dloplan.physics.compiled import chain_energy
from dloplan.sim.clips import ClipPoses, conform_guess
from dloplan.sim.compiled import newton_positions
from dloplan.sim.result import residual_tolerance
from scipy.spatial.transform import Rotation

cable = catalogue_cable("ethernet", n_links=10)
chain = SpringChain.from_cable(cable)
n = cable.n_links
l = cable.rest_link_length
clips = ClipPoses(np.array([[0.0, 0.0, 0.0], [0.4, 0.0, 0.0]]),
                  Rotation.from_euler("z", [[0.0], [180.0]], degrees=True))
x0 = conform_guess(cable, np.stack([np.linspace(-l / 2, 0.4 + l / 2, n + 1), np.zeros(n + 1),
                                    -0.1 * np.sin(np.linspace(0.0, np.pi, n + 1))], 1), clips)


def solve(max_iterations):
    x = x0.copy()
    history = np.empty(max_iterations + 1)
    history[0] = chain_energy(x, *chain.constants)
    grad, band = np.empty_like(x), np.empty((9, 3 * (n + 1)))
    before = rtsys.get_allocation_stats().alloc
    status, iterations, *_ = newton_positions(
        x, 2, n - 1, *chain.constants, cable.length, residual_tolerance(cable, x=x0),
        max_iterations, np.int64(0), 0.25 * cable.length, history, np.int64(1), grad, band,
        np.bool_(True), np.bool_(chain.stiff_axial), False)  # restart passed, as the library's
    # callers pass it: the overload the warm-up cached (omitted, it compiled a second one)
    return int(status), int(iterations), rtsys.get_allocation_stats().alloc - before


solve(500)  # compiled or loaded (the runtime starts with the first kernel)
print(*solve(2), *solve(500))
"""


def test_the_newton_loop_allocates_its_work_arrays_once_per_solve():
    """The plants' Newton loop allocates its work arrays once per solve, none per iteration:
    the kernels it calls every iteration (energy, derivatives, banded Cholesky, the step, the
    link-length correction) allocate nothing and count no references (``dloplan.jit.
    njit_leaf``); before, an iteration allocated about six arrays (the bending blocks, two
    link directions per energy, the correction's five) and counted every array argument of
    every call (ten iterations allocated 59 arrays more than two). numba counts allocations
    only when told at its start: a fresh interpreter."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "NUMBA_NRT_STATS": "1"}
    out = subprocess.run([sys.executable, "-c", _ALLOCATIONS], env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    stopped, two, few, converged, iterations, many = (int(v) for v in out)
    assert (stopped, two) == (MAX_ITERATIONS, 2) and converged == CONVERGED and iterations >= 8
    assert many == few  # the work arrays and the arguments' runtime records, once per call


def test_the_leaf_kernels_are_compiled_without_the_runtime():
    """What the Newton loops call every iteration is a leaf kernel (no reference counts), and
    a leaf kernel cannot allocate: numba refuses to compile one that does."""
    from numba.core.errors import NumbaError

    from dloplan.jit import njit_leaf
    from dloplan.physics.compiled import (
        chain_derivatives,
        chain_energy,
        chain_geometry,
        kept_chain_derivatives,
        kept_chain_energy,
    )
    from dloplan.sim.compiled import model_step, restored_lengths
    from dloplan.sim.newton import cholesky_band, cholesky_solve

    for kernel in (chain_energy, chain_derivatives, chain_geometry, kept_chain_energy,
                   kept_chain_derivatives, cholesky_band, cholesky_solve, model_step,
                   restored_lengths):
        assert kernel.targetoptions.get("_nrt") is False, kernel.__name__

    @njit_leaf
    def allocating(n):
        return np.zeros(n).sum()

    with pytest.raises(NumbaError):
        allocating(3)
