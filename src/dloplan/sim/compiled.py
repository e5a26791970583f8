"""The static solvers' Newton loops, compiled: no Python per iteration.

:func:`dloplan.sim.newton.trust_region_newton` is the readable, generic loop (any state, any
energy: positions with contacts, twist angles). For the plain chain (positions only, no contact
obstacles) every iteration is the same few kernels, so the whole loop runs here in one numba
function: the compiled energy, gradient and Hessian band of :mod:`dloplan.physics.compiled` and
the compiled banded Cholesky of :mod:`dloplan.sim.newton`. It takes the same decisions in the same
order as the generic loop (tests compare both, iterate by iterate), and hands back to Python at
a saddle, where :func:`dloplan.sim.newton.escape_saddle` (an eigenvector of the band) takes over.
:func:`newton_twist` is the same loop for points and twist angles together (the torsion solver,
:mod:`dloplan.sim.torsion`), with the closed-form twist kernels of
:mod:`dloplan.physics.twist_compiled`.

Status codes of :func:`newton_positions`: :data:`CONVERGED`, :data:`MAX_ITERATIONS`,
:data:`STALLED`, :data:`SADDLE`.

numba's on-disk cache (``cache=True``) is keyed on the source file of each compiled function
alone: these loops carry the kernels they call (``physics/compiled.py``,
``physics/twist_compiled.py``, ``sim/newton.py``) compiled in, and keep the old ones after an edit
of those files until this file changes too or its ``__pycache__/*.nbi`` / ``*.nbc`` entries are
deleted. Measure kernel changes with a cleared cache.
"""

from __future__ import annotations

import math

import numpy as np

from ..jit import njit, njit_leaf
from ..physics.compiled import (
    GEOMETRY_COLUMNS,
    chain_derivatives,
    chain_energy,
    chain_geometry,
    kept_chain_derivatives,
    kept_chain_energy,
)
from ..physics.twist_compiled import (
    interleaved_band,
    moved_directors,
    twist_energies,
    twist_stencils,
)
from .newton import NEUTRAL, cholesky_band, cholesky_solve, step_verdict, wants_correction

CONVERGED, MAX_ITERATIONS, STALLED, SADDLE = 0, 1, 2, 3
RUNNING = -1  # internal: none of them yet


@njit_leaf(cache=True)
def _longest(p):
    """Largest point displacement of a step p over free points (3 coordinates each) [m]."""
    longest = 0.0
    for i in range(p.shape[0] // 3):
        d = math.sqrt(p[3 * i] ** 2 + p[3 * i + 1] ** 2 + p[3 * i + 2] ** 2)
        longest = max(longest, d)
    return longest


LENGTH_REGULARIZATION = 1e-6
"""Tikhonov term of the length projection's tridiagonal system (:func:`restore_link_lengths`),
relative to its unit diagonal: a straight chain between its held points cannot change all its
link lengths at once (the system is singular there), and the projection then stays bounded."""


@njit(cache=True)
def restore_link_lengths(x, trial, first, stop):
    """Second-order correction of a Newton step on a chain of nearly inextensible links.

    ``trial`` (n + 1, 3) is ``x`` moved by a step p over the free points ``first .. stop - 1``.
    A link that turns by an angle theta changes its length by l (1 - cos theta) ~ l theta^2 / 2,
    a term the quadratic model does not see; with axial springs a thousand times stiffer than the
    bending ones that energy rejects any step longer than a fraction of the length scale the
    bending sets (issue 35: 8 -> 516 iterations). As in the second-order correction of
    constrained trust-region methods (Nocedal & Wright, Numerical Optimization, 2nd ed., 15.6;
    Conn, Gould & Toint, Trust-Region Methods, 15.3.2), the free points of ``trial`` are moved,
    in place, by the least-norm q with J q = -r: one Gauss-Newton step that gives every link
    touching a free point the length the step's linearization promised,

        r_j = |e_j(trial)| - (|e_j(x)| + t_j(x) . (p_{j+1} - p_j)),
        (J J^T + mu I) lambda = r,   q = -J^T lambda,

    J the Jacobian of the link lengths at ``trial`` over the free points (rows -t_j at point j,
    +t_j at point j + 1): J J^T is tridiagonal (1 or 2 on the diagonal, -t_j . t_{j+1} beside
    it), so the correction costs O(n). r is O(|p|^2 / l), so is q, and Newton's quadratic
    convergence is kept; the ratio test then judges the corrected step against the model's
    prediction for p. A correction longer than the step itself (the linearization is no guide
    there) is not applied.

    Parameters
    ----------
    x, trial : numpy.ndarray
        (n + 1, 3) the state and the trial state [m]; ``trial`` is corrected in place.
    first, stop : int
        The free point range; points outside it do not move.

    Returns
    -------
    bool
        True if the correction was applied.
    """
    return restored_lengths(x, trial, first, stop, np.empty((x.shape[0], 3)),
                            np.empty((4, x.shape[0])))


@njit_leaf(cache=True)
def restored_lengths(x, trial, first, stop, tangents, rows):
    """:func:`restore_link_lengths` on work arrays of the caller's: ``tangents`` (n + 1, 3) and
    ``rows`` (4, n + 1) (the residual, the diagonal, the upper diagonal and the multipliers of
    the tridiagonal system); the same arithmetic, nothing allocated."""
    n_points = x.shape[0]
    j0 = first - 1  # the links touching a free point: j0 .. j1 - 1 (link j joins j, j + 1)
    j1 = min(stop, n_points - 1)
    m = j1 - j0
    residual, diagonal, upper, multipliers = rows[0], rows[1], rows[2], rows[3]
    step = 0.0
    for j in range(j0, j1):
        k = j - j0
        length_x = 0.0
        t_dp = 0.0
        length = 0.0
        for a in range(3):
            e_x = x[j + 1, a] - x[j, a]
            e = trial[j + 1, a] - trial[j, a]
            length_x += e_x * e_x
            t_dp += e_x * (e - e_x)
            length += e * e
        length_x = math.sqrt(length_x)
        length = math.sqrt(length)
        for a in range(3):
            tangents[k, a] = (trial[j + 1, a] - trial[j, a]) / length
        residual[k] = length - (length_x + t_dp / length_x)
    for i in range(first, stop):
        step = max(step, math.sqrt((trial[i, 0] - x[i, 0]) ** 2 + (trial[i, 1] - x[i, 1]) ** 2
                                   + (trial[i, 2] - x[i, 2]) ** 2))
    # tridiagonal (J J^T + mu I), solved by Thomas' algorithm (symmetric positive definite)
    for k in range(m):
        j = j0 + k
        diagonal[k] = (1.0 if first <= j else 0.0) + (1.0 if j + 1 < stop else 0.0) \
            + LENGTH_REGULARIZATION
        upper[k] = 0.0
        if k + 1 < m:
            upper[k] = -(tangents[k, 0] * tangents[k + 1, 0] + tangents[k, 1] * tangents[k + 1, 1]
                         + tangents[k, 2] * tangents[k + 1, 2])
    multipliers[0] = residual[0]
    for k in range(1, m):
        factor = upper[k - 1] / diagonal[k - 1]
        diagonal[k] -= factor * upper[k - 1]
        multipliers[k] = residual[k] - factor * multipliers[k - 1]
    multipliers[m - 1] /= diagonal[m - 1]
    for k in range(m - 2, -1, -1):
        multipliers[k] = (multipliers[k] - upper[k] * multipliers[k + 1]) / diagonal[k]
    longest = 0.0  # q_i = -(lambda_{i-1} t_{i-1} - lambda_i t_i), links i - 1 and i
    for i in range(first, stop):
        k = i - j0
        q2 = 0.0
        for a in range(3):
            q = -multipliers[k - 1] * tangents[k - 1, a]
            if k < m:
                q += multipliers[k] * tangents[k, a]
            q2 += q * q
        longest = max(longest, math.sqrt(q2))
    if not longest <= step:
        return False
    for i in range(first, stop):
        k = i - j0
        for a in range(3):
            q = -multipliers[k - 1] * tangents[k - 1, a]
            if k < m:
                q += multipliers[k] * tangents[k, a]
            trial[i, a] += q
    return True


@njit_leaf(cache=True)
def newton_direction(h, g, shift, factor, p):
    """The full Newton step p = -(H + shift I)^-1 g by banded Cholesky (``factor`` scratch).

    Returns ``(solved, g . p, p . p)``; ``solved`` is False where H + shift I is not positive
    definite (p is then undefined).
    """
    if not cholesky_band(h, shift, factor):
        return False, 0.0, 0.0
    n_free = p.shape[0]
    for j in range(n_free):
        p[j] = g[j]
    cholesky_solve(factor, p)
    g_p = 0.0
    p_p = 0.0
    for j in range(n_free):
        p[j] = -p[j]
        g_p += g[j] * p[j]
        p_p += p[j] * p[j]
    return True, g_p, p_p


@njit_leaf(cache=True)
def stop_status(residual, tolerance, h, scale, factor, iterations, max_iterations,
                 stop_at_saddle):
    """Why the loop stops here (converged and stable, out of iterations, at a saddle), or
    :data:`RUNNING`."""
    if residual <= tolerance and cholesky_band(h, NEUTRAL * scale, factor):
        return CONVERGED
    if iterations >= max_iterations:
        return MAX_ITERATIONS
    if residual <= tolerance and stop_at_saddle:
        return SADDLE
    return RUNNING


@njit(cache=True, inline="always")
def model_change(alpha, g_p, p_p, shift):
    """The quadratic model's change [J] for the step alpha p, p the solution of
    (H + shift I) p = -g: alpha g.p + alpha^2 p.H.p / 2 with p.H.p = -g.p - shift p.p."""
    return alpha * g_p + 0.5 * alpha**2 * (-g_p - shift * p_p)


@njit_leaf(cache=True)
def model_step(h, g, shift, scale, radius, factor, p, twist):
    """The Newton step p for the shift, its size (:func:`twist_step_length` with ``twist``,
    else the largest point displacement), the factor alpha truncating it to the trust radius
    and the model's predicted change; ``(solved, shift, longest, alpha, predicted)``, the shift
    raised when H + shift I is not positive definite."""
    solved, g_p, p_p = newton_direction(h, g, shift, factor, p)
    if not solved:
        return False, max(4.0 * shift, 1e-8 * scale), 0.0, 0.0, 0.0
    longest = twist_step_length(p) if twist else _longest(p)
    alpha = min(1.0, radius / longest) if longest > 0 else 1.0
    return True, shift, longest, alpha, model_change(alpha, g_p, p_p, shift)


@njit(cache=True, inline="always")
def largest_force(grad, first, stop):
    """The largest net force on the points ``first .. stop - 1`` [N]: the Newton loops'
    residual, from the (n + 1, 3) gradient ``grad``."""
    largest = 0.0
    for i in range(first, stop):
        largest = max(largest, math.sqrt(grad[i, 0] ** 2 + grad[i, 1] ** 2 + grad[i, 2] ** 2))
    return largest


@njit(cache=True, inline="always")
def copy_points(source, target):
    """``target`` <- ``source`` (n + 1, 3) (or any two 2-d arrays of one shape), element by
    element (a kernel without numba's runtime, :func:`dloplan.jit.njit_leaf`, has no array
    assignment)."""
    for i in range(source.shape[0]):
        for a in range(source.shape[1]):
            target[i, a] = source[i, a]


@njit(cache=True, inline="always")
def moved_by(x, alpha, p, first, trial):
    """``trial`` <- ``x`` with the free points from ``first`` on moved by alpha p [m]."""
    copy_points(x, trial)
    for j in range(p.shape[0]):
        trial[first + j // 3, j % 3] += alpha * p[j]


@njit(cache=True)
def newton_positions(x, first, stop, k_s, rest_lengths, k_b, rest_angles, masses, gravity,
                     length_scale, tolerance, max_iterations, iterations, radius, history,
                     n_history, grad, band, stop_at_saddle, correct_lengths, restart=False):
    """Run the trust-region Newton loop on the free points ``first .. stop - 1`` of x, in place.

    Parameters
    ----------
    x : numpy.ndarray
        (n + 1, 3) state [m], updated in place.
    first, stop : int
        The free point range.
    k_s, rest_lengths, k_b, rest_angles, masses, gravity
        The chain's constants (:attr:`dloplan.physics.chain.SpringChain.constants`).
    length_scale, tolerance, max_iterations
        As in :func:`dloplan.sim.newton.trust_region_newton`.
    iterations : int
        Iterations already done (after a saddle escape).
    radius : float
        Trust radius [m] to start with.
    history : numpy.ndarray
        (max_iterations + 1,) energies [J]; ``history[:n_history]`` are filled already, the
        first being the start's energy.
    n_history : int
        Entries of ``history`` in use.
    grad, band : numpy.ndarray
        (n + 1, 3) and (9, 3(n + 1)) work arrays: on return the last gradient [N] and band.
    stop_at_saddle : bool
        Return :data:`SADDLE` at a converged but unstable point (else step on from it).
    correct_lengths : bool
        Try the second-order correction :func:`restore_link_lengths` on a step that is not very
        successful (:func:`dloplan.sim.newton.wants_correction`): for stiff axial springs
        (:attr:`dloplan.physics.chain.SpringChain.stiff_axial`); else the plain steps.
    restart : bool
        After a very successful step (the shift relaxed: the model's ratio above 3/4), take the
        next one with no shift, where :func:`dloplan.sim.newton.step_verdict` divides it by 8.
        For a start the shift had to be raised for: a linear prediction of a stiff-axial chain
        (the study's clip-fit trials, :func:`dloplan.correct.plant_batch.drive_chains`) stretches
        its links enough to make the Hessian indefinite there, the shift climbs to about 1e-4
        of the Hessian's scale, and its decay then damped three more steps of the soft bending
        modes. Off (the default), the loop is :func:`~dloplan.sim.newton.trust_region_newton`'s,
        decision by decision.

    Returns
    -------
    tuple
        ``(status, iterations, residual, radius, n_history)``.
    """
    free = slice(3 * first, 3 * stop)
    n_free = 3 * (stop - first)
    return _newton_loop(x, first, stop, k_s, rest_lengths, k_b, rest_angles, masses, gravity,
                        length_scale, tolerance, max_iterations, iterations, radius, history,
                        n_history, grad, band, grad.ravel()[free], band[:, free],
                        stop_at_saddle, correct_lengths, restart,
                        np.empty((band.shape[0], n_free)), np.empty(n_free), np.empty_like(x),
                        np.empty_like(x), np.empty((x.shape[0], 3)), np.empty((4, x.shape[0])),
                        np.empty((x.shape[0] - 1, GEOMETRY_COLUMNS)),
                        np.empty((x.shape[0] - 1, GEOMETRY_COLUMNS)),
                        np.empty((x.shape[0] - 1, GEOMETRY_COLUMNS)))


@njit_leaf(cache=True)
def _newton_loop(x, first, stop, k_s, rest_lengths, k_b, rest_angles, masses, gravity,
                 length_scale, tolerance, max_iterations, iterations, radius, history, n_history,
                 grad, band, g, h, stop_at_saddle, correct_lengths, restart, factor, p, trial,
                 corrected, tangents, rows, geometry, trial_geometry, corrected_geometry):
    """:func:`newton_positions`' loop on its work arrays (the factor, the step, two trial
    states, :func:`restored_lengths`' arrays and the geometry rows of x, the trial and the
    corrected trial, each (n, :data:`~dloplan.physics.compiled.GEOMETRY_COLUMNS`)):
    nothing allocated, no reference counted per iteration (:func:`dloplan.jit.njit_leaf`).
    ``g`` and ``h`` are the free coordinates' views of ``grad`` (flattened) and ``band``, which
    every iteration rewrites in place. The derivatives at an accepted trial reuse the link
    lengths, directions and joint angles its energy computed (the same values)."""
    shift = 0.0
    f = history[n_history - 1]
    chain_geometry(x, geometry)
    while True:
        kept_chain_derivatives(x, k_s, rest_lengths, k_b, rest_angles, masses, gravity,
                               geometry, grad, band)
        residual = largest_force(grad, first, stop)
        scale = np.mean(h[0])
        status = stop_status(residual, tolerance, h, scale, factor, iterations, max_iterations,
                             stop_at_saddle)
        if status != RUNNING:
            return status, iterations, residual, radius, n_history
        accepted = False
        for _ in range(60):  # adapt the shift until a step is accepted
            solved, shift, longest, alpha, predicted = model_step(h, g, shift, scale, radius,
                                                                   factor, p, np.bool_(False))
            if not solved:
                continue
            moved_by(x, alpha, p, first, trial)
            f_trial = kept_chain_energy(trial, k_s, rest_lengths, k_b, rest_angles, masses,
                                        gravity, trial_geometry)
            if correct_lengths and wants_correction(f, f_trial, predicted):
                copy_points(trial, corrected)
                if restored_lengths(x, corrected, first, stop, tangents, rows):
                    f_corrected = kept_chain_energy(corrected, k_s, rest_lengths, k_b,
                                                    rest_angles, masses, gravity,
                                                    corrected_geometry)
                    if f_corrected < f_trial:
                        copy_points(corrected, trial)
                        copy_points(corrected_geometry, trial_geometry)
                        f_trial = f_corrected
            tried = shift
            accepted, shift, radius = step_verdict(f, f_trial, predicted, shift, scale, radius,
                                                   longest, length_scale)
            if accepted:
                if restart and shift < tried:  # relaxed: very successful
                    shift = 0.0
                copy_points(trial, x)
                copy_points(trial_geometry, geometry)
                f = f_trial
                break
        iterations += 1
        if not accepted:
            return STALLED, iterations, residual, radius, n_history
        history[n_history] = f
        n_history += 1


@njit(cache=True)
def _twist_derivatives(x, d1, chain, twist, link, work, grad, tgrad, dgrad, agrad, blocks,
                       band_pos, band, g):
    """Joint gradient g and band over interleaved (x, y, z, l theta) coordinates, in place;
    returns the residual over the free points 2 .. n-2 [N] and free angles 1 .. n-2 [N]."""
    k_s, rest_lengths, k_b, rest_angles, masses, gravity = chain
    k_t, rest_twist, k_bd, rest_curvatures, directional = twist
    chain_derivatives(x, k_s, rest_lengths, k_b, rest_angles, masses, gravity, grad, band_pos)
    twist_stencils(x, d1, k_t, rest_twist, k_bd, rest_curvatures, directional, work, tgrad,
                   dgrad, agrad, blocks, np.bool_(True))
    interleaved_band(band_pos, blocks, link, band)
    n_points = x.shape[0]
    residual = 0.0
    for i in range(n_points):
        norm = 0.0
        for c in range(3):
            grad[i, c] += tgrad[i, c] + dgrad[i, c]
            g[4 * i + c] = grad[i, c]
            norm += grad[i, c] ** 2
        if 2 <= i < n_points - 2:
            residual = max(residual, math.sqrt(norm))
    for j in range(d1.shape[0]):
        g[4 * j + 3] = agrad[j] / link
        if 1 <= j < d1.shape[0] - 1:
            residual = max(residual, abs(agrad[j]) / link)
    return residual


@njit(cache=True)
def twist_energy_of(x, d1, chain, twist):
    """U^s + U^b + U^g + U^t + U^d [J] of a state (contacts excluded)."""
    k_s, rest_lengths, k_b, rest_angles, masses, gravity = chain
    k_t, rest_twist, k_bd, rest_curvatures, directional = twist
    u_t, u_d = twist_energies(x, d1, k_t, rest_twist, k_bd, rest_curvatures, directional)
    return chain_energy(x, k_s, rest_lengths, k_b, rest_angles, masses, gravity) + u_t + u_d


@njit(cache=True)
def twist_trial(x, d1, p, link, trial, trial_d1, angles, correct):
    """The state after the step p over the free interleaved coordinates (angles as l theta);
    with ``correct``, the points' :func:`restore_link_lengths` before the directors are carried
    along (returns False, and builds nothing more, when the correction is not applied)."""
    n = d1.shape[0]
    trial[:] = x
    angles[:] = 0.0
    for j in range(p.shape[0]):  # p[0] is theta_1, then point 2, theta_2, ...
        q = j + 7
        if q % 4 == 3:
            angles[q // 4] = p[j] / link
        else:
            trial[q // 4, q % 4] += p[j]
    if correct and not restore_link_lengths(x, trial, np.int64(2), n - 1):
        return False
    moved_directors(x, trial, d1, angles, trial_d1)
    for c in range(3):
        trial_d1[0, c] = d1[0, c]
        trial_d1[n - 1, c] = d1[n - 1, c]
    return True


@njit_leaf(cache=True)
def twist_step_length(p):
    """Largest point displacement [m] or l theta [m] of a step over the free coordinates."""
    longest = 0.0
    j = 0
    while j < p.shape[0]:
        if (j + 7) % 4 == 3:
            longest = max(longest, abs(p[j]))
            j += 1
        else:
            longest = max(longest, math.sqrt(p[j] ** 2 + p[j + 1] ** 2 + p[j + 2] ** 2))
            j += 3
    return longest


@njit(cache=True)
def newton_twist(x, d1, chain, twist, link, length_scale, tolerance, max_iterations, iterations,
                 radius, history, n_history, work, grad, tgrad, dgrad, agrad, blocks, band_pos,
                 band, stop_at_saddle, correct_lengths):
    """The trust-region Newton loop of :func:`dloplan.sim.torsion.equilibrium_with_twist`.

    The same decisions in the same order as :func:`dloplan.sim.newton.trust_region_newton` with
    the torsion solver's callbacks, over the free points 2 .. n-2 and the free links' angles
    1 .. n-2 (interleaved, angles as l theta [m]); x (n + 1, 3) and d1 (n, 3) are updated in
    place. ``chain`` and ``twist`` are the constants of :class:`dloplan.physics.chain.
    SpringChain` and :class:`dloplan.physics.twist.TwistChain`; the work arrays hold the last
    derivatives on return (``grad`` the points' total gradient [N], ``band`` the joint band).
    Other arguments (``correct_lengths``: the points' :func:`restore_link_lengths`) and the
    returned tuple as in :func:`newton_positions`.
    """
    n = d1.shape[0]
    first = 7
    stop = 4 * n - 4
    n_free = stop - first
    g_all = np.empty(4 * n + 3)
    factor = np.empty((band.shape[0], n_free))
    p = np.empty(n_free)
    trial = np.empty_like(x)
    trial_d1 = np.empty_like(d1)
    corrected = np.empty_like(x)
    corrected_d1 = np.empty_like(d1)
    angles = np.empty(n)
    shift = 0.0
    f = history[n_history - 1]
    while True:
        residual = _twist_derivatives(x, d1, chain, twist, link, work, grad, tgrad, dgrad,
                                      agrad, blocks, band_pos, band, g_all)
        g = g_all[first:stop]
        h = band[:, first:stop]
        scale = np.mean(h[0])
        status = stop_status(residual, tolerance, h, scale, factor, iterations, max_iterations,
                             stop_at_saddle)
        if status != RUNNING:
            return status, iterations, residual, radius, n_history
        accepted = False
        for _ in range(60):  # adapt the shift until a step is accepted
            solved, shift, longest, alpha, predicted = model_step(h, g, shift, scale, radius,
                                                                   factor, p, np.bool_(True))
            if not solved:
                continue
            for j in range(n_free):
                p[j] *= alpha
            twist_trial(x, d1, p, link, trial, trial_d1, angles, np.bool_(False))
            f_trial = twist_energy_of(trial, trial_d1, chain, twist)
            if correct_lengths and wants_correction(f, f_trial, predicted) and twist_trial(
                    x, d1, p, link, corrected, corrected_d1, angles, np.bool_(True)):
                f_corrected = twist_energy_of(corrected, corrected_d1, chain, twist)
                if f_corrected < f_trial:
                    trial[:] = corrected
                    trial_d1[:] = corrected_d1
                    f_trial = f_corrected
            accepted, shift, radius = step_verdict(f, f_trial, predicted, shift, scale, radius,
                                                   longest, length_scale)
            if accepted:
                x[:] = trial
                d1[:] = trial_d1
                f = f_trial
                break
        iterations += 1
        if not accepted:
            return STALLED, iterations, residual, radius, n_history
        history[n_history] = f
        n_history += 1


@njit(cache=True)
def held_response(band, edge, dh, load, solved):
    """The free coordinates' response to the held ones and to a load, by one banded Cholesky
    factorization of the free Hessian: ``solved`` (N_f, m + 1) <- H_ff^-1 [-H_fh dh, -load_f]
    (the implicit differentiation of :func:`dloplan.sim.sensitivity.equilibrium_sensitivity`).

    Parameters
    ----------
    band : numpy.ndarray
        (w + 1, N) the lower band of the Hessian over all N coordinates [N/m].
    edge : int
        Held coordinates at either end: 0 .. edge - 1 and N - edge .. N - 1; the free ones
        between, N_f = N - 2 edge.
    dh : numpy.ndarray
        (2 edge, m) the held coordinates' derivatives (first end, then last, in order).
    load : numpy.ndarray
        (N,) the load's derivative (its free part is used) [N].
    solved : numpy.ndarray
        (N_f, m + 1) filled with the responses.

    Returns
    -------
    bool
        False when H_ff is not positive definite (``solved`` then undefined).
    """
    w = band.shape[0]
    n_dof = band.shape[1]
    n_free = n_dof - 2 * edge
    free_band = np.empty((w, n_free))
    for i in range(w):
        for j in range(n_free):
            free_band[i, j] = band[i, edge + j]
    factor = np.empty((w, n_free))
    if not cholesky_band(free_band, 0.0, factor):
        return False
    m = dh.shape[1]
    column = np.empty(n_free)
    for c in range(m + 1):
        if c == m:
            for r in range(n_free):
                column[r] = -load[edge + r]
        else:
            column[:] = 0.0
            for h in range(edge):  # H[r, h] = band[r - h, h] for the first end's (r > h)
                for r in range(edge, min(h + w, edge + n_free)):
                    column[r - edge] -= band[r - h, h] * dh[h, c]
            for q in range(edge):  # H[r, hc] = band[hc - r, r] for the last end's (hc > r)
                hc = n_dof - edge + q
                for r in range(max(hc - w + 1, edge), edge + n_free):
                    column[r - edge] -= band[hc - r, r] * dh[edge + q, c]
        cholesky_solve(factor, column)
        for r in range(n_free):
            solved[r, c] = column[r]
    return True
