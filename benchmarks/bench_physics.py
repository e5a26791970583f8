"""Time of one energy + gradient evaluation of the mass-spring chain against n (issue 2).

Prints the time for n = 10, 100, 1000 and the exponent of a log-log fit (1 = linear): the numpy
reference kernels (energy + gradient; Hessian band) and the compiled one-pass kernel (energy,
gradient and Hessian band together, issue 20), with their ratio.
"""

from __future__ import annotations

import timeit

import numpy as np

from dloplan import catalogue_cable
from dloplan.physics import SpringChain, energy, gradient, hessian_band
from dloplan.physics.chain import shape_derivatives


def main() -> None:
    sizes = [10, 100, 1000]
    rows = []
    for n in sizes:
        cable = catalogue_cable("ethernet", n_links=n)
        chain = SpringChain.from_cable(cable)
        x = np.random.default_rng(0).normal(size=(n + 1, 3))
        repeat = max(20, 20000 // n)
        t_eg = min(timeit.repeat(lambda: (energy(chain, x), gradient(chain, x)),  # noqa: B023
                                 number=repeat, repeat=5)) / repeat
        t_h = min(timeit.repeat(lambda: hessian_band(chain, x), number=repeat, repeat=5)) / repeat  # noqa: B023
        shape_derivatives(chain, x)  # load the compiled kernel
        t_c = min(timeit.repeat(lambda: shape_derivatives(chain, x),  # noqa: B023
                                number=repeat, repeat=5)) / repeat
        rows.append((n, t_eg, t_h, t_c))
    print(f"{'n':>6} {'energy+gradient [us]':>22} {'Hessian band [us]':>18} "
          f"{'compiled all three [us]':>24} {'ratio':>6}")
    for n, t_eg, t_h, t_c in rows:
        print(f"{n:>6} {1e6 * t_eg:>22.1f} {1e6 * t_h:>18.1f} {1e6 * t_c:>24.1f} "
              f"{(t_eg + t_h) / t_c:>6.1f}")
    ns = np.log([r[0] for r in rows])
    for label, k in (("energy+gradient", 1), ("Hessian", 2), ("compiled", 3)):
        slope = np.polyfit(ns[1:], np.log([r[k] for r in rows[1:]]), 1)[0]
        print(f"{label}: time ~ n^{slope:.2f} between n = 100 and 1000 (1.00 = linear)")


if __name__ == "__main__":
    main()
