"""numpy's ``default_rng(seed)`` for a chunk's seeds at once (dloplan.correct.noise_seeds)."""

from __future__ import annotations

import numpy as np

from dloplan.correct.noise_seeds import pcg64_states, seeded_generators


def test_the_pcg64_states_are_numpys_for_every_32_bit_seed_tried():
    """SeedSequence's hashing and PCG64's seeding over an array of seeds give the states
    ``numpy.random.PCG64(seed)`` has: the bench's sample indices, the largest 32-bit seed,
    powers of two."""
    seeds = [*range(2048), 2**31, 2**32 - 1, 123456789, 4_000_000_000, *(2**k for k in range(32))]
    for seed, (state, inc) in zip(seeds, pcg64_states(seeds), strict=True):
        assert np.random.PCG64(seed).state["state"] == {"state": state, "inc": inc}, seed


def test_the_seeded_generators_draw_what_default_rng_draws():
    """Each generator draws ``default_rng(seed)``'s numbers, bit for bit, in turn; seeds
    outside [0, 2^32) (a larger int, a SeedSequence) take ``default_rng`` itself."""
    for seeds in ([5, 0, 17, 2**32 - 1, 5], [2**40, 3], [np.random.SeedSequence(7), 2]):
        for seed, generator in zip(seeds, seeded_generators(seeds), strict=True):
            drawn = generator.normal(scale=1e-3, size=(40, 3))
            np.testing.assert_array_equal(drawn,
                                          np.random.default_rng(seed).normal(scale=1e-3,
                                                                             size=(40, 3)))
    assert list(seeded_generators([])) == []
