"""Many plants driven through their clip poses in one compiled call (a study's closed loop).

:meth:`~.plant.Plant.hold` is one clamped equilibrium (:func:`.model_error.clamped_equilibrium`):
its Python set-up (the chain, the tolerance, the clamped points) costs several times the
compiled Newton loop of a small cable, and a closed-loop study drives every sampled plant
through a dozen clip poses. :func:`drive_plants` does, sample by sample and stop by stop in one
compiled loop, what :meth:`~.plant.Plant.hold` does from the previous stop's shape: the clamped
links laid along the clips' u-axes, the residual tolerance of
:func:`dloplan.sim.result.residual_tolerance` at that start, the trust-region Newton loop
(:func:`dloplan.sim.compiled.newton_positions`) from the same start, trust radius and
tolerance. The same kernels run in the same order, so a stop's shape is bit for bit the one
``hold`` returns (tested). A Newton loop that stops at a saddle (its escape uses LAPACK's
banded eigen-solver) hands the sample back: ``hold`` itself finishes its remaining stops.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np
from scipy.spatial.transform import Rotation

from ..cable import Cable
from ..jit import njit
from ..physics.chain import HALF_BANDWIDTH, SpringChain
from ..physics.compiled import chain_energy
from ..sim import ClipPoses
from ..sim.batch import HANDED_BACK, held_equilibria, held_loop
from ..sim.compiled import CONVERGED, MAX_ITERATIONS, SADDLE, STALLED, newton_positions
from ..sim.newton import newton_message
from ..sim.result import DEFAULT_RTOL, ROUNDOFF, force_scale, point_weight, stiffest
from .model_error import clamped_equilibrium
from .plant import continuation_guess

NEWTON_ITERATIONS = 500
"""Newton iterations per stop (:func:`dloplan.sim.statics.minimize_energy`'s default)."""

_OUTCOMES = {CONVERGED: "converged", MAX_ITERATIONS: "max_iterations", STALLED: "stalled"}


@njit(cache=True)
def drive_clamped(starts, previous, k_s, rest_lengths, k_b, rest_angles, masses, gravity, link,
                  length, tolerance, roundoff, stiff, stiff_axial, clamp, positions, u_axes,
                  max_iterations, restart, predict_from, shapes, done, outcomes, iterations,
                  spent, residuals):
    """The plants' equilibria at every stop, each from the one before (or the two before's
    secant prediction, :func:`.plant.continuation_guess`), in place.

    Parameters
    ----------
    starts : numpy.ndarray
        (B, n + 1, 3) the guess of the first stop [m] (the equilibrium before it, when it is
        predicted).
    previous : numpy.ndarray
        (B, n + 1, 3) the equilibrium before ``starts`` [m] (read with ``predict_from`` 0).
    k_s, rest_lengths, k_b, rest_angles, masses : numpy.ndarray
        Per sample (B,), (B, n), (B,), (B, n - 1), (B, n + 1): the chains' constants.
    gravity : numpy.ndarray
        (3,) [m/s^2].
    link, length, tolerance, stiff : numpy.ndarray
        Per sample (B,): rest link length [m], length [m], the tolerance without its round-off
        floor (1e-10 of the force scale) [N], the stiffest spring of the floor [N/m].
    roundoff : float
        The floor's factor (16 eps).
    stiff_axial : numpy.ndarray
        (B,) bool: the chains' :attr:`~dloplan.physics.chain.SpringChain.stiff_axial`.
    clamp : numpy.ndarray
        (B,) int: links clamped by each gripper.
    positions, u_axes : numpy.ndarray
        (B, M, 2, 3) clip points [m] and u-axes of every stop.
    max_iterations : int
    restart : bool
        The Newton loop's ``restart`` (:func:`dloplan.sim.compiled.newton_positions`): False
        for the plants (:meth:`~.plant.Plant.hold`'s loop, bit for bit).
    predict_from : int
        Stops s >= ``predict_from`` start from 2 x_(s-1) - x_(s-2), ``starts`` standing for
        x_(-1) and ``previous`` for x_(-2); the others from x_(s-1) (``starts`` for stop 0).
    shapes : numpy.ndarray
        (B, M, n + 1, 3) out: the equilibria.
    done : numpy.ndarray
        (B,) int out: the stops solved; a sample stops at its first stop that is not a stable
        equilibrium (``outcomes`` says why) or that reaches a saddle (``outcomes`` = SADDLE,
        for :meth:`~.plant.Plant.hold` to redo).
    outcomes, iterations : numpy.ndarray
        (B,) int out: the Newton outcome and iterations of the last stop tried.
    spent : numpy.ndarray
        (B,) int out: the Newton iterations of all the stops tried.
    residuals : numpy.ndarray
        (B,) out: its largest free force [N].
    """
    n_points = starts.shape[1]
    history = np.empty(max_iterations + 1)
    band = np.empty((HALF_BANDWIDTH + 1, 3 * n_points))
    grad = np.empty((n_points, 3))
    for b in range(starts.shape[0]):
        done[b] = 0
        spent[b] = 0
        for s in range(positions.shape[1]):
            x = shapes[b, s]
            guess = starts[b] if s == 0 else shapes[b, s - 1]
            if s >= predict_from:  # continuation_guess's secant, its arithmetic
                before = previous[b] if s == 0 else starts[b] if s == 1 else shapes[b, s - 2]
                for i in range(n_points):
                    for a in range(3):
                        x[i, a] = 2.0 * guess[i, a] - before[i, a]
            else:
                for i in range(n_points):
                    for a in range(3):
                        x[i, a] = guess[i, a]
            k = clamp[b]
            for i in range(k + 1):
                offset = (i - 0.5 * k) * link[b]
                for a in range(3):
                    x[i, a] = positions[b, s, 0, a] + offset * u_axes[b, s, 0, a]
                    x[n_points - 1 - i, a] = positions[b, s, 1, a] + offset * u_axes[b, s, 1, a]
            size = length[b] + np.max(np.abs(x))
            limit = max(tolerance[b], roundoff * size * stiff[b])
            history[0] = chain_energy(x, k_s[b], rest_lengths[b], k_b[b], rest_angles[b],
                                      masses[b], gravity)
            outcome, its, residual, _, _ = newton_positions(
                x, k + 1, n_points - k - 1, k_s[b], rest_lengths[b], k_b[b],
                rest_angles[b], masses[b], gravity, length[b], limit, max_iterations,
                np.int64(0), 0.25 * length[b], history, np.int64(1), grad, band,
                np.bool_(True), stiff_axial[b], restart)
            outcomes[b], iterations[b], residuals[b] = outcome, its, residual
            spent[b] += its
            if outcome != CONVERGED:
                break
            done[b] = s + 1


@dataclass(frozen=True, eq=False)
class PlantDrive:
    """The result of :func:`drive_plants`.

    Attributes
    ----------
    shapes : numpy.ndarray
        (B, M, n + 1, 3) the plants' equilibria at the stops [m] (not meaningful after a
        failure).
    failed : numpy.ndarray
        (B,) int: the first stop that is not a stable equilibrium, -1 when none.
    messages : tuple of str
        The failed stop's Newton message ("" when none failed).
    iterations : numpy.ndarray
        (B,) int: the Newton iterations of the stops the compiled loop tried (a saddle's
        finish by ``hold`` not counted).
    """

    shapes: np.ndarray
    failed: np.ndarray
    messages: tuple
    iterations: np.ndarray


@dataclass(frozen=True, eq=False)
class PlantChains:
    """What :func:`drive_chains` needs of B cables, made once (:meth:`of`) and reused, joined
    or taken apart (a study's plants driven twice, the clip fit's chain at one E per sample).

    Attributes
    ----------
    cables : tuple of Cable
        The B cables, all with the same number of links -- or, in a row whose ``moduli`` is
        not NaN, the cable to take at that E (:meth:`cable`: made only when asked for).
    moduli : numpy.ndarray
        (B,) the Young's modulus [Pa] of a row made by :meth:`at_moduli`, NaN in a row made by
        :meth:`of`.
    constants : tuple of numpy.ndarray
        k_s (B,), rest lengths (B, n), k_b (B,), rest angles (B, n - 1), masses (B, n + 1):
        :attr:`~dloplan.physics.chain.SpringChain.constants` stacked.
    link, length, tolerance, stiff : numpy.ndarray
        (B,) rest link length [m], length [m], the residual tolerance without its round-off
        floor (:func:`dloplan.sim.result.residual_tolerance`'s) [N], the stiffest spring of
        the floor [N/m].
    stiff_axial : numpy.ndarray
        (B,) bool: :attr:`~dloplan.physics.chain.SpringChain.stiff_axial`.
    """

    cables: tuple
    moduli: np.ndarray
    constants: tuple
    link: np.ndarray
    length: np.ndarray
    tolerance: np.ndarray
    stiff: np.ndarray
    stiff_axial: np.ndarray

    @classmethod
    def of(cls, cables: Sequence[Cable], gravity) -> PlantChains:
        """The constants of ``cables`` under ``gravity`` (3,) [m/s^2]."""
        gravity = np.asarray(gravity, dtype=float)
        cables = tuple(cables)
        chains = [SpringChain.from_cable(cable, gravity) for cable in cables]
        return cls(cables, np.full(len(cables), np.nan),
                   tuple(np.array([chain.constants[k] for chain in chains]) for k in range(5)),
                   np.array([cable.rest_link_length for cable in cables]),
                   np.array([cable.length for cable in cables]),
                   DEFAULT_RTOL * np.array([force_scale(cable, gravity) for cable in cables]),
                   np.array([stiffest(cable) for cable in cables]),
                   np.array([chain.stiff_axial for chain in chains]))

    @classmethod
    def at_moduli(cls, cable: Cable, moduli, gravity) -> PlantChains:
        """:meth:`of` the cables ``cable.with_modulus(e)``, e in ``moduli`` [Pa], bit for bit,
        without making them: the moduli's constants by :class:`Cable`'s own properties
        evaluated for all of them at once (:class:`_AtModuli`), the rest (rest lengths and
        angles, masses, a point's weight) taken from ``cable``'s chain."""
        gravity = np.asarray(gravity, dtype=float)
        at = _AtModuli(cable, moduli)
        count = len(at.youngs_modulus)
        base = SpringChain.from_cable(cable, gravity).constants

        def rows(value):
            return np.repeat(np.asarray(value, dtype=float)[None], count, axis=0)

        l2 = cable.rest_link_length**2
        stiff = np.maximum.reduce(np.broadcast_arrays(at.k_axial, at.k_bending / l2,
                                                      at.k_twist / l2, 0.0))  # stiffest's
        return cls((cable,) * count, at.youngs_modulus,
                   (np.broadcast_to(at.k_axial, (count,)).astype(float), rows(base[1]),
                    at.k_bending, rows(base[3]), rows(base[4])),
                   np.full(count, cable.rest_link_length), np.full(count, cable.length),
                   DEFAULT_RTOL * force_scale(at, gravity, point_weight(cable, gravity)),
                   stiff, np.broadcast_to(at.stiff_axial, (count,)).copy())

    @classmethod
    def join(cls, parts: Sequence[PlantChains]) -> PlantChains:
        """The cables of ``parts`` one after the other."""
        return cls(**{name: _joined([getattr(p, name) for p in parts])
                      for name in _FIELDS})

    def take(self, index) -> PlantChains:
        """The cables at ``index`` (a sequence of positions)."""
        index = np.asarray(index, dtype=np.int64)
        return PlantChains(**{name: _taken(getattr(self, name), index) for name in _FIELDS})

    def cable(self, b: int) -> Cable:
        """The cable of row ``b``."""
        e = float(self.moduli[b])
        return self.cables[b] if np.isnan(e) else self.cables[b].with_modulus(e)

    def chain(self, b: int, gravity) -> SpringChain:
        """The chain of row ``b`` under ``gravity`` (3,) [m/s^2] (a saddle's escape,
        :func:`.model_error.clamped_equilibrium`)."""
        return SpringChain.from_cable(self.cable(b), gravity)

    def __len__(self) -> int:
        return len(self.link)


class _AtModuli:
    """A cable's properties at many Young's moduli at once: :class:`Cable`'s own property code
    run with ``youngs_modulus`` an array (B,) [Pa] (every other field the cable's), so each
    value is, bit for bit, that property of ``cable.with_modulus(e)`` (float64 arithmetic in
    numpy rounds as Python's). ``k_bending``, ``k_axial``, ``k_twist``, ``stiff_axial`` ...:
    arrays (B,) where they depend on E, the cable's value where they do not."""

    def __init__(self, cable: Cable, moduli) -> None:
        self._cable = cable
        self.youngs_modulus = np.array(moduli, dtype=float).reshape(-1)

    def __getattr__(self, name: str):
        member = getattr(type(self._cable), name, None)
        if isinstance(member, property):
            return member.fget(self)
        return getattr(self._cable, name)


_FIELDS = tuple(f.name for f in fields(PlantChains))


def _joined(values: list):
    """One field of several :class:`PlantChains` one after the other: an array (B,), a tuple
    of arrays (B, ...) (the constants) or a tuple of per-cable objects (cables, chains)."""
    first = values[0]
    if isinstance(first, np.ndarray):
        return np.concatenate(values)
    if first and isinstance(first[0], np.ndarray):
        return tuple(np.concatenate(parts) for parts in zip(*values, strict=True))
    return sum(values, ())


def _taken(value, index: np.ndarray):
    """One field of a :class:`PlantChains` at ``index`` (its kinds as :func:`_joined`'s)."""
    if isinstance(value, np.ndarray):
        return value[index]
    if value and isinstance(value[0], np.ndarray):
        return tuple(part[index] for part in value)
    return tuple(value[i] for i in index)


def drive_plants(cables: Sequence[Cable], clamp_links, starts, positions, quaternions, *,
                 gravity, predict_from: int | None = None, previous=None) -> PlantDrive:
    """Every plant's equilibria at its stops, each warm-started from the one before.

    Sample b, stop s is :meth:`~.plant.Plant.hold` of ``cables[b]`` clamping ``clamp_links``
    links at the stop's clips, from the shape of stop s - 1 (``starts[b]`` for stop 0) -- from
    stop ``predict_from`` on, from :func:`.plant.continuation_guess` of the two before it
    (``starts[b]`` standing for the one before stop 0, ``previous[b]`` for the one before that),
    as :func:`.plant.run_closed_loop` continues -- bit for bit (the module docstring); a stop
    that is not a stable equilibrium ends its sample.

    Parameters
    ----------
    cables : sequence of Cable
        The B plant cables, all with the same number of links.
    clamp_links : array_like
        (B,) int: links each gripper of a plant clamps (:attr:`~.plant.Plant.clamp_links`).
    starts : array_like
        (B, n + 1, 3) guesses of the first stop [m].
    positions, quaternions : array_like
        (B, M, 2, 3) clip points [m] and (B, M, 2, 4) unit ``clip_to_world`` quaternions
        (x, y, z, w) of the stops.
    gravity : array_like
        (3,) [m/s^2].
    predict_from : int, optional
        The first stop started from the secant prediction (None: none).
    previous : array_like, optional
        (B, n + 1, 3) the equilibria before ``starts`` [m]: needed with ``predict_from`` 0.
    """
    return drive_chains(PlantChains.of(cables, gravity), clamp_links, starts, positions,
                        quaternions, gravity=gravity, predict_from=predict_from,
                        previous=previous)


def drive_chains(plants: PlantChains, clamp_links, starts, positions, quaternions, *,
                 gravity, restart: bool = False, predict_from: int | None = None,
                 previous=None) -> PlantDrive:
    """:func:`drive_plants` of the cables whose constants ``plants`` holds; with ``restart``
    the Newton loops take a plain step after every very successful one (:func:`dloplan.sim.
    compiled.newton_positions`), which ``hold`` does not: the same equilibria to the solver's
    tolerance, not bit for bit (the study's clip-fit trials, whose starts are linear
    predictions)."""
    gravity = np.asarray(gravity, dtype=float)
    # copies: writable and C-ordered whatever the caller holds (a read-only array, as a test's
    # or a table's, compiled a second overload of the kernel)
    starts = np.array(starts, dtype=float, order="C")
    positions = np.array(positions, dtype=float, order="C")
    quaternions = np.asarray(quaternions, dtype=float)
    u_axes = u_axes_of(quaternions)
    n_samples, n_stops = positions.shape[:2]
    clamps = np.broadcast_to(np.asarray(clamp_links, dtype=np.int64), (n_samples,)).copy()
    shapes = np.empty((n_samples, n_stops) + starts.shape[1:])
    done = np.zeros(n_samples, dtype=np.int64)
    outcomes = np.zeros(n_samples, dtype=np.int64)
    iterations = np.zeros(n_samples, dtype=np.int64)
    spent = np.zeros(n_samples, dtype=np.int64)
    residuals = np.zeros(n_samples)
    predict = n_stops if predict_from is None else int(predict_from)
    if predict == 0 and previous is None:
        raise ValueError("previous: the equilibria before the starts are needed to predict "
                         "the first stop (predict_from 0)")
    previous = starts if previous is None else np.array(previous, dtype=float, order="C")
    drive_clamped(starts, previous, *plants.constants, gravity, plants.link, plants.length,
                  plants.tolerance, ROUNDOFF * np.finfo(float).eps, plants.stiff,
                  plants.stiff_axial, clamps, positions, u_axes, NEWTON_ITERATIONS,
                  np.bool_(restart), np.int64(predict), shapes, done, outcomes, iterations,
                  spent, residuals)
    failed = np.full(n_samples, -1)
    messages = [""] * n_samples
    for b in np.flatnonzero(done < n_stops):
        first = int(done[b])
        if outcomes[b] != SADDLE:
            failed[b], messages[b] = first, newton_message(
                _OUTCOMES[int(outcomes[b])], int(iterations[b]), float(residuals[b]))
            continue
        for s in range(first, n_stops):  # the saddle's escape: the readable way, to the end
            clips = ClipPoses(positions[b, s], Rotation(quaternions[b, s], normalize=False))
            guess = starts[b] if s == 0 else shapes[b, s - 1]
            if s >= predict:
                guess = continuation_guess(guess, previous[b] if s == 0 else starts[b] if s == 1
                                           else shapes[b, s - 2])
            shapes[b, s], ok, message = clamped_equilibrium(
                plants.cable(b), guess, clips, int(clamps[b]), gravity=gravity,
                chain=plants.chain(b, gravity))
            if not ok:
                failed[b], messages[b] = s, message
                break
    return PlantDrive(shapes, failed, tuple(messages), spent)


def hold_chains(plants: PlantChains, guesses, positions, quaternions, *, gravity) -> list:
    """Each cable of ``plants`` held by both clips: item b is :func:`dloplan.sim.batch.
    held_equilibria` of ``plants.cable(b)`` from ``guesses[b]`` at the clips
    ``positions[b]``, ``quaternions[b]``, bit for bit, its loop (:func:`dloplan.sim.batch.
    held_loop`) run on the constants ``plants`` made once (the study's model at each updated
    E): none of the per-call chains, force scales, clip wrenches and messages of
    ``held_equilibria``, which finishes only the items the loop hands back (a saddle, clips at
    the edge of the reach).

    Parameters
    ----------
    plants : PlantChains
        The B cables (one per item).
    guesses : array_like
        (B, n + 1, 3) starting shapes [m].
    positions, quaternions : array_like
        (B, 2, 3) clip points [m] and (B, 2, 4) unit ``clip_to_world`` quaternions (x, y, z, w).
    gravity : array_like
        (3,) [m/s^2].

    Returns
    -------
    list
        Per item the stable equilibrium (n + 1, 3) [m], or None where there is none.
    """
    x0 = np.array(guesses, dtype=float, order="C")
    positions = np.array(positions, dtype=float, order="C")
    quaternions = np.array(quaternions, dtype=float, order="C")
    count = len(x0)
    shapes, _, _, _, status, _ = held_loop(
        x0, np.arange(count, dtype=np.int64), plants.constants, np.asarray(gravity, dtype=float),
        positions, quaternions, plants.link, plants.length, plants.tolerance,
        ROUNDOFF * np.finfo(float).eps, plants.stiff, plants.stiff_axial, NEWTON_ITERATIONS)
    out: list = [shapes[b] if status[b] == CONVERGED else None for b in range(count)]
    for b in np.flatnonzero(status == HANDED_BACK):  # the readable way
        held = held_equilibria([plants.cable(b)], np.zeros(1, dtype=np.int64), x0[b : b + 1],
                               positions[b : b + 1],
                               Rotation(quaternions[b], normalize=False), gravity=gravity)
        out[b] = held.shapes[0] if held.success[0] else None
    return out


def u_axes_of(quaternions: np.ndarray) -> np.ndarray:
    """The x-axes of unit quaternions (..., 4) (x, y, z, w), (..., 3): the clips' u-axes, by
    the formula and in the order of operations of :attr:`ClipPoses.u_axes` (bit for bit)."""
    x, y, z, w = np.moveaxis(quaternions, -1, 0)
    return np.ascontiguousarray(np.stack(
        [x * x - y * y - z * z + w * w, 2.0 * (x * y + z * w), 2.0 * (x * z - y * w)], axis=-1))
