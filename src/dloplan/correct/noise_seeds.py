"""numpy's ``default_rng(seed)`` for many small integer seeds at once, bit for bit.

``numpy.random.default_rng(seed)`` builds a :class:`numpy.random.SeedSequence`, hashes the
seed into its pool, draws four 64-bit words from the pool and seeds a
:class:`numpy.random.PCG64` with them: about 20-30 us of Python-level object construction per
call, as much as the draws a study's measurement then takes from it. For seeds in
[0, 2^32) (one entropy word, no spawn key) every step of that is the same arithmetic for every
seed, so here it runs on numpy arrays over all the seeds together (numpy 1.17+'s
``SeedSequence.mix_entropy``, ``generate_state`` and ``pcg_setseq_128_srandom_r``, with the
same constants), and one generator is set to each state in turn (:func:`seeded_generators`).
Other seeds take ``default_rng`` itself.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np

_MASK32 = 0xFFFFFFFF
_MASK128 = (1 << 128) - 1
_INIT_A, _MULT_A = 0x43B0D7E5, 0x931E8875  # numpy/random/bit_generator.pyx
_INIT_B, _MULT_B = 0x8B51F9DD, 0x58F38DED
_MIX_MULT_L, _MIX_MULT_R = 0xCA01F9DD, 0x4973F715
_XSHIFT = 16
_POOL_SIZE = 4
_PCG_MULTIPLIER = (2549297995355413924 << 64) + 4865540595714422341  # PCG_DEFAULT_MULTIPLIER_128


def _hash_constants(init: int, mult: int, count: int) -> list[int]:
    """The hash constant's values after each of ``count`` multiplications, from ``init``."""
    values, h = [], init
    for _ in range(count):
        h = (h * mult) & _MASK32
        values.append(h)
    return values


# SeedSequence's hash constant does not depend on the data: its sequence is fixed.
_MIX_CONSTANTS = [_INIT_A] + _hash_constants(_INIT_A, _MULT_A, 16)
_STATE_CONSTANTS = [_INIT_B] + _hash_constants(_INIT_B, _MULT_B, 8)


def _hashmix(value: np.ndarray, k: int) -> np.ndarray:
    """SeedSequence's ``hashmix`` with the k-th hash constant (uint64 arrays of 32-bit
    values)."""
    value = value ^ _MIX_CONSTANTS[k]
    value = (value * _MIX_CONSTANTS[k + 1]) & _MASK32
    return value ^ (value >> _XSHIFT)


def _mix(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    result = (_MIX_MULT_L * x - _MIX_MULT_R * y) & _MASK32
    return result ^ (result >> _XSHIFT)


def pcg64_states(seeds: Sequence[int]) -> list[tuple[int, int]]:
    """The (state, inc) of ``numpy.random.PCG64(seed)`` for each seed in [0, 2^32).

    Parameters
    ----------
    seeds : sequence of int
        (B,) seeds, each in [0, 2^32).

    Returns
    -------
    list of tuple
        (B,) the 128-bit state and increment, as ``PCG64(seed).state["state"]`` holds them.
    """
    entropy = np.asarray(seeds, dtype=np.uint64)
    k = 0
    pool = []
    for i in range(_POOL_SIZE):  # mix_entropy: the seed, then zeros
        pool.append(_hashmix(entropy if i == 0 else np.zeros_like(entropy), k))
        k += 1
    for i_src in range(_POOL_SIZE):
        for i_dst in range(_POOL_SIZE):
            if i_src != i_dst:
                pool[i_dst] = _mix(pool[i_dst], _hashmix(pool[i_src], k))
                k += 1
    words = []
    for i in range(8):  # generate_state(4, np.uint64): eight 32-bit words
        value = pool[i % _POOL_SIZE] ^ _STATE_CONSTANTS[i]
        value = (value * _STATE_CONSTANTS[i + 1]) & _MASK32
        words.append(value ^ (value >> _XSHIFT))
    state64 = [(words[2 * j] | (words[2 * j + 1] << np.uint64(32))).tolist() for j in range(4)]
    states = []
    for s0, s1, i0, i1 in zip(*state64, strict=True):
        inc = ((((i0 << 64) | i1) << 1) | 1) & _MASK128  # pcg_setseq_128_srandom_r
        state = inc
        state = (state + ((s0 << 64) | s1)) & _MASK128
        state = (state * _PCG_MULTIPLIER + inc) & _MASK128
        states.append((state, inc))
    return states


def seeded_generators(seeds: Sequence) -> Iterator[np.random.Generator]:
    """``numpy.random.default_rng(seed)`` for each seed in turn, bit for bit: one generator
    set to each seed's state when every seed is an integer in [0, 2^32)
    (:func:`pcg64_states`), else ``default_rng`` itself. Each generator is valid until the
    next is taken."""
    small = all(isinstance(s, (int, np.integer)) and 0 <= s <= _MASK32 for s in seeds)
    if not small or len(seeds) == 0:
        yield from (np.random.default_rng(seed) for seed in seeds)
        return
    generator = np.random.Generator(np.random.PCG64(0))
    bits = generator.bit_generator
    for state, inc in pcg64_states([int(s) for s in seeds]):
        bits.state = {"bit_generator": "PCG64", "state": {"state": state, "inc": inc},
                      "has_uint32": 0, "uinteger": 0}
        yield generator
