"""The controller's inverse kinematics of a YuMi robtarget: (TCP pose, arm angle, confdata) ->
joints, as RobotWare reads a robtarget with the new arm-angle definition.

A robtarget fixes the TCP pose (6 equations) and the arm angle ``eax_a`` (the 7th,
:mod:`dloplan.robot.armangle`): finitely many joint vectors satisfy them (up to 16 for the
YuMi's geometry, Elias & Wen 2025). ``confdata`` picks one of them. :func:`robtarget_solutions`
finds them by the 7x7 damped least squares of :func:`dloplan.robot.kinematics.solve_many`
from many seeds (the given ones, the home pose and its wrist flip, and seeded-random joint
vectors) and keeps the distinct ones within the joint limits; :func:`solve_robtarget` keeps
those whose confdata is the written one. A program's round trip (:mod:`dloplan.robot.program`)
asks that exactly one solution matches and that it is the verified one. A program made as a
verdict (the reach repair's placements) first asks :func:`own_solution`, the part of the
enumeration the verified joints reach by themselves: where that passes, so does the whole.

Cost (issue 34): the enumeration's own seeds (home, its flip, the random ones: most of them
lead nowhere) are stepped by a hand-written Cholesky solve of the damped normal equations
(``cholesky`` of :func:`~dloplan.robot.kinematics.solve_many`), a third cheaper per iteration
than LAPACK's call; the given seeds, and afterwards the few seeds that found a distinct
solution, are stepped by LAPACK, so every solution kept is bitwise the one stepping every seed
by LAPACK gives, as long as the same seeds converge to the same roots both ways (rounding
decides that only for a seed on the edge of a basin or of the stall test; on the 152
robtargets of fig4_8's and qualitative-1's plans and in the tests they all do).
"""

from __future__ import annotations

from dataclasses import astuple, dataclass, replace

import numpy as np

from .chain import CellArm
from .confdata import confdata
from .kinematics import IKOptions, solve_many, wrist_flip

RANDOM_SEEDS = 96
"""Seeded-random joint vectors tried per robtarget (besides the given seeds and home)."""

SAME_SOLUTION = 1e-4
"""[rad] Two solutions closer than this in every joint are one."""

ROUND_TRIP_TOLERANCE = float(np.radians(0.05))
"""[rad] A robtarget round-trips when the controller's solution is this close to the verified
joints in every joint."""


@dataclass(frozen=True, eq=False)
class RobtargetSolution:
    """What the controller's IK makes of one robtarget.

    Attributes
    ----------
    solutions : numpy.ndarray
        (K, 7) every distinct joint vector found [rad] with the robtarget's pose and arm angle.
    matching : numpy.ndarray
        (J, 7) those with the robtarget's confdata.
    enumerated : bool
        False: only the solution reached from the verified joints and its turns
        (:func:`own_solution`), not every solution of the robtarget.
    """

    solutions: np.ndarray
    matching: np.ndarray
    enumerated: bool = True

    @property
    def unique(self) -> bool:
        """Exactly one solution has the written confdata."""
        return len(self.matching) == 1

    def deviation(self, q) -> float:
        """Largest joint difference [rad] of the matching solution nearest ``q`` (7,) from
        ``q``; inf when none matches."""
        if not len(self.matching):
            return float("inf")
        return float(np.abs(self.matching - np.asarray(q, dtype=float)).max(axis=1).min())


MEMO_SIZE = 4096
"""Robtargets whose solutions a process keeps (:func:`robtarget_solutions`): a plan's repairs
and re-checks ask for the same ones again (qualitative-1: 280 asks, 80 distinct robtargets)."""

_memo: dict = {}


def robtarget_solutions(arm: CellArm, position, rotation_matrix, psi: float, seeds=(),
                        options: IKOptions | None = None,
                        rng: np.random.Generator | None = None) -> np.ndarray:
    """Every distinct joint vector within the limits found with a TCP pose and arm angle.

    Parameters
    ----------
    arm : CellArm
    position : array_like
        (3,) TCP position in the world [m].
    rotation_matrix : array_like
        (3, 3) ``tcp_to_world``.
    psi : float
        The arm angle [rad].
    seeds : sequence of array_like
        (7,) joint vectors [rad] to start from besides the home pose, its wrist flip and
        :data:`RANDOM_SEEDS` random ones.
    options : IKOptions, optional
        Damping and step (default :class:`IKOptions`); converged at 1e-9 m and 1e-9 rad
        (a Newton step from 1e-5 gets there in one or two more iterations, and distinct
        solutions near a singularity of the arm angle stay apart), 100 iterations per seed,
        a seed whose error stalls given up.
    rng : numpy.random.Generator, optional
        For the random seeds; default seeded with 0 (deterministic: the answer is then kept,
        and the same question asked again, exactly the same arm, pose, arm angle, seeds and
        options, gets it without solving; :data:`MEMO_SIZE`).

    Returns
    -------
    numpy.ndarray
        (K, 7) [rad] (read-only), ordered by their distance from the first seed (or home).
    """
    opts = _round_trip_options(options)
    position = np.asarray(position, dtype=float)
    rotation_matrix = np.asarray(rotation_matrix, dtype=float)
    seeds = [np.asarray(s, dtype=float) for s in seeds]
    if rng is not None:
        return _solutions(arm, position, rotation_matrix, psi, seeds, opts, rng)
    key = (arm, position.tobytes(), rotation_matrix.tobytes(), float(psi),
           tuple(s.tobytes() for s in seeds), astuple(opts))
    found = _memo.get(key)
    if found is None:
        found = _solutions(arm, position, rotation_matrix, psi, seeds, opts,
                           np.random.default_rng(0))
        while len(_memo) >= MEMO_SIZE:  # the oldest answer goes
            del _memo[next(iter(_memo))]
        _memo[key] = found
    return found


def _round_trip_options(options: IKOptions | None) -> IKOptions:
    """``options`` (default :class:`IKOptions`) with the round trip's convergence: 1e-9 m and
    1e-9 rad, 100 iterations (:func:`robtarget_solutions`)."""
    return replace(options if options is not None else IKOptions(), max_iterations=100,
                   position_tolerance=1e-9, angle_tolerance=1e-9)


def _solutions(arm: CellArm, position, rotation_matrix, psi: float, seeds, opts: IKOptions,
               rng: np.random.Generator) -> np.ndarray:
    """:func:`robtarget_solutions` solved (its options complete): the enumeration's own seeds
    stepped by the Cholesky solve, then the seeds that found a distinct solution solved again
    by LAPACK (module docstring)."""
    starts = np.array([np.clip(s, arm.lower, arm.upper) for s in seeds]
                      + [arm.home, wrist_flip(arm, arm.home)]
                      + list(rng.uniform(arm.lower, arm.upper, (RANDOM_SEEDS, 7))))
    given = len(seeds)
    q, ok = _solved(arm, position, rotation_matrix, psi, starts, opts, given)
    _, sources = _distinct(arm, q[ok])
    again = np.flatnonzero(ok)[sources]
    again = again[again >= given]
    if len(again):
        q[again], ok[again] = _solved(arm, position, rotation_matrix, psi, starts[again], opts,
                                      len(again))
    found, _ = _distinct(arm, q[ok])
    found = found[np.argsort(np.abs(found - starts[0]).max(axis=1), kind="stable")]
    found.setflags(write=False)
    return found


def _solved(arm: CellArm, position, rotation_matrix, psi: float, starts, opts: IKOptions,
            exact: int) -> tuple[np.ndarray, np.ndarray]:
    """The 7x7 damped least squares from ``starts`` (N, 7), each given up when stalled: joints
    (N, 7) [rad] and converged (N,); the first ``exact`` starts stepped by LAPACK, the rest by
    the Cholesky solve (:func:`dloplan.robot.kinematics.solve_many`)."""
    n = len(starts)
    q, ok = np.empty((n, 7)), np.zeros(n, dtype=bool)
    for part, cholesky in ((slice(0, exact), False), (slice(exact, n), True)):
        count = len(starts[part])
        if count:
            q[part], ok[part], _, _ = solve_many(
                arm, np.tile(position, (count, 1)), np.tile(rotation_matrix, (count, 1, 1)),
                starts[part], opts, np.full(count, float(psi)), give_up=True,
                cholesky=cholesky)
    return q, ok


def _distinct(arm: CellArm, solutions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct joint vectors (K, 7) among the solutions (N, 7) and their turns
    (:func:`_with_turns`), in order (closer than :data:`SAME_SOLUTION` to an earlier kept one
    in every joint: the same), and the solution (K,) int each came from."""
    candidates, sources = _with_turns(arm, solutions)
    kept: list[int] = []
    alive = np.ones(len(candidates), dtype=bool)
    while alive.any():  # the first candidate no kept one is close to is kept
        first = int(np.argmax(alive))
        kept.append(first)
        alive &= np.abs(candidates - candidates[first]).max(axis=1) >= SAME_SOLUTION
    return candidates[kept], sources[kept]


def _with_turns(arm: CellArm, solutions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The solutions (K, 7) and their turns, (K', 7), each solution followed by its turns:
    every combination of whole turns of the joints whose range exceeds 2 pi that stays within
    the limits; and the solution (K',) int each is a turn of."""
    out = np.asarray(solutions, dtype=float).reshape(-1, 7)
    sources = np.arange(len(out))
    turns = np.arange(-2, 3) * 2.0 * np.pi
    for j in np.flatnonzero(arm.upper - arm.lower > 2.0 * np.pi):
        turned = out[:, None, :] + (turns[:, None] * np.eye(7)[j])[None]
        within = (arm.lower[j] <= out[:, j, None] + turns) & (out[:, j, None] + turns
                                                              <= arm.upper[j])
        out = turned[within]
        sources = np.broadcast_to(sources[:, None], within.shape)[within]
    return out, sources


def solve_robtarget(arm: CellArm, position, rotation_matrix, psi: float, conf, seeds=(),
                    options: IKOptions | None = None) -> RobtargetSolution:
    """The controller's solutions of a robtarget: those of :func:`robtarget_solutions` whose
    :func:`~dloplan.robot.confdata.confdata` is ``conf`` (4,) int."""
    found = robtarget_solutions(arm, position, rotation_matrix, psi, seeds, options)
    return _with_confdata(found, conf)


def _with_confdata(found: np.ndarray, conf, enumerated: bool = True) -> RobtargetSolution:
    """The solutions ``found`` (K, 7) [rad] and those whose confdata is ``conf`` (4,) int."""
    keep = np.all(confdata(found) == np.asarray(conf, dtype=int), axis=-1) if len(found) \
        else np.zeros(0, bool)
    return RobtargetSolution(found, found[keep], enumerated)


def own_solution(arm: CellArm, position, rotation_matrix, psi: float, conf, seed,
                 options: IKOptions | None = None) -> RobtargetSolution:
    """The solution the controller's IK reaches from ``seed`` (7,) [rad] alone, and its turns
    within the limits: part of :func:`solve_robtarget` with ``seeds=[seed]``, for a verdict.

    :func:`robtarget_solutions` solves its first seed by LAPACK as this does (the same call,
    so bit for bit the same joints) and keeps that solution and its turns among the distinct
    ones (only its own turns come before it, and they are whole turns apart), so every
    solution here is one of its, and a matching one here is a matching one there:
    ``deviation(seed)`` is never below the enumeration's. A round trip this passes
    (:data:`ROUND_TRIP_TOLERANCE`) the enumeration passes; one it fails needs the enumeration
    (another solution may match). ``enumerated`` is False: the other solutions of the pose
    and arm angle are not known.

    Parameters
    ----------
    arm, position, rotation_matrix, psi, options
        As for :func:`robtarget_solutions`.
    conf : array_like
        (4,) int, the written confdata.
    seed : array_like
        (7,) the verified joints [rad].

    Returns
    -------
    RobtargetSolution
    """
    starts = np.clip(np.asarray(seed, dtype=float), arm.lower, arm.upper)[None]
    q, ok = _solved(arm, np.asarray(position, dtype=float),
                    np.asarray(rotation_matrix, dtype=float), psi, starts,
                    _round_trip_options(options), 1)
    found, _ = _with_turns(arm, q[ok])
    return _with_confdata(found, conf, enumerated=False)
