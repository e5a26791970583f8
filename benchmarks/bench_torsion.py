"""Static equilibrium with and without torsion (issue 10).

For the Ethernet cable and the PA12 hose (straight) and a curved PA12 hose (quarter-circle rest
shape, directional bending), n = 10, 50, 200: the time of `equilibrium` (points only) and of
`equilibrium_with_twist` (points and twist angles jointly) from the same start, their ratio, the
iterations, and the largest point distance between the two answers (zero for untwisted clips and
a straight cable; for the curved hose the torsion-free model only knows unsigned rest angles and
its cone-shaped energy at the rest angles can keep it from converging).
A second table twists the straight PU cable by one radian at one clip.

Issue 20. Before the compiled kernels (quiet): Ethernet n = 50 with torsion 43 ms (147 ms at
n = 200). At commit 2268328 (closed-form twist kernels, compiled Newton loop; quiet): 2.82 ms, the
ratio printed is against it; target 1.5 ms. Now (constant-width banded Cholesky for the joint
band, the set-up and result compiled), best of 5 under load average 1.3 on the 2 shared cores:
Ethernet n = 10 / 50 / 200 with torsion 1.00 / 1.24 / 3.67 ms (n = 50: 2.3x), 3-5 times the
torsion-free solve, the same iterations (under load 7.0: 0.98 / 1.48 / 4.08 ms): target met.

The curved PA12 hose without torsion (381 iterations at n = 50, no convergence in 500 at
n = 200) is the model, not the solver: the torsion-free bending energy knows only unsigned
angles, so each joint can turn its bending plane at no cost (at the rest shape, n = 50,
weightless, 47 of the 141 free Hessian eigenvalues are zero); gravity alone (an energy drop of
1e-6 J) selects the equilibrium along curved valleys where Newton's quadratic model holds only
for small steps. With torsion (directional bending) the same hose converges in 2 iterations.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from bench_statics import best_time  # the same best-of-N timer (this folder)
from scipy.spatial.transform import Rotation

from dloplan import catalogue_cable
from dloplan.physics.rod_frames import transported_directors
from dloplan.sim import ClipPoses, equilibrium
from dloplan.sim.statics import conform_guess
from dloplan.sim.torsion import equilibrium_with_twist, rest_clip_poses

BEFORE_MS = 2.82  # Ethernet, n = 50, with torsion, commit 2268328, quiet (docstring)
TARGET_MS = 1.5
CLIPS = ClipPoses(np.array([[0.0, 0, 0], [0.4, 0, 0]]),
                  Rotation.from_euler("z", [[0.0], [180.0]], degrees=True))


def arc(n_links: int, length: float, angle: float) -> np.ndarray:
    step = angle / n_links
    radius = length / n_links / (2.0 * np.sin(step / 2.0))
    theta = np.linspace(0.0, angle, n_links + 1)
    return np.stack([radius * np.sin(theta), np.zeros_like(theta), radius * (1 - np.cos(theta))],
                    1)




def straight(cable, start=0.0):
    x = np.zeros((cable.n_points, 3))
    x[:, 0] = start + cable.rest_link_length * np.arange(cable.n_points)
    return x


def main() -> None:
    print("Static equilibrium without and with torsion (best of 5)")
    print(f"{'case':>12} {'n':>4} {'plain [ms]':>11} {'it':>3} {'torsion [ms]':>13} {'it':>3} "
          f"{'ratio':>6} {'diff [mm]':>10}  plain converged")
    for name in ("ethernet", "pa12", "pa12-curved"):
        for n in (10, 50, 200):
            cable = catalogue_cable(name.split("-")[0], n_links=n)
            if name.endswith("curved"):
                cable = dataclasses.replace(cable, rest_shape=arc(n, cable.length, np.pi / 2))
                clips = rest_clip_poses(cable)
                start = cable.rest_shape
            else:
                clips = CLIPS
                start = conform_guess(cable, straight(cable, -cable.rest_link_length / 2), clips)
            t_plain, plain = best_time(lambda: equilibrium(cable, start, clips), 5)  # noqa: B023
            t_twist, twisted = best_time(
                lambda: equilibrium_with_twist(cable, start, clips), 5)  # noqa: B023
            diff = 1e3 * float(np.abs(plain.shape - twisted.shape).max())
            before = (f"  (torsion at 2268328: {BEFORE_MS} ms, {BEFORE_MS / (1e3 * t_twist):.1f}x; "
                      f"target {TARGET_MS} ms)" if (name, n) == ("ethernet", 50) else "")
            print(f"{name:>12} {n:>4} {1e3 * t_plain:11.2f} {plain.iterations:3d} "
                  f"{1e3 * t_twist:13.2f} {twisted.iterations:3d} {t_twist / t_plain:6.1f} "
                  f"{diff:10.4f}  {plain.converged}{before}")
    print()
    print("PU cable twisted by 1 rad at the last clip, weightless (torque vs G Ip alpha / L)")
    print(f"{'n':>4} {'time [ms]':>10} {'it':>3} {'torque [N m]':>13} {'G Ip a/L':>10} "
          f"{'rel. diff':>10}")
    for n in (10, 50, 200):
        cable = catalogue_cable("pu", n_links=n)
        clips = rest_clip_poses(cable)
        last = clips.rotations[1] * Rotation.from_rotvec([1.0, 0.0, 0.0])
        twisted_clips = ClipPoses(clips.positions,
                                  Rotation.concatenate([clips.rotations[0], last]))
        # start with all the twist on the last interior point (the parallel-transported frames)
        directors = transported_directors(straight(cable), clips.rotations[0].apply([0, 1.0, 0]))
        t, eq = best_time(lambda: equilibrium_with_twist(  # noqa: B023
            cable, straight(cable), twisted_clips, directors=directors,  # noqa: B023
            gravity=(0, 0, 0)), 5)
        torque = float(np.abs(eq.torques).mean())
        closed = cable.shear_modulus * cable.polar_moment / cable.length
        print(f"{n:4d} {1e3 * t:10.2f} {eq.iterations:3d} {torque:13.6g} {closed:10.6g} "
              f"{torque / closed - 1:10.2e}")


if __name__ == "__main__":
    main()
