"""Independent plants for the closed loop: cables simulated by code that is not dloplan's.

A plant stands for the real cable in :func:`dloplan.correct.run_closed_loop`: it follows the
plan's clip poses quasi-statically and is measured with noise. :class:`dloplan.correct.Plant`
is the same mass-spring chain as the model on more links; the plants here are other
simulators, with their own discretization, their own elasticity and their own grippers:

* :class:`MujocoPlant` -- MuJoCo 3.x's cable (``<composite type="cable">`` with the
  ``mujoco.elasticity.cable`` plugin: a chain of capsules on ball joints, Cosserat bending and
  twist from E and G, inextensible); each gripper is a mocap body welded to the first (last)
  segments, the clamped length ``clamp``; quasi-static by stepping the damped dynamics to rest
  at every clip pose.

Limits: the Ethernet cable (d 5 mm) comes to rest at a 1 ms step; the thinner, softer USB
(d 3 mm) does not (its segments' modes outrun the step's stability), so the benchmark's plans
are Ethernet ones. Nothing of dloplan's physics is used: only its clip poses (positions,
rotations: the u-axis is the clip frame's x-axis, pointing into the cable) go in, points along
the cable come out.
Optional: the tests that use a plant skip with the reason when its package is missing
(``pip install dloplan[plants]``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from dloplan.cable import GRAVITY, Cable
from dloplan.geometry import resample_by_arc_length

ARMATURE_STEPS = 4.0
"""A segment's own bending mode is slowed to a period of about 2 pi ARMATURE_STEPS time steps
(a fictitious inertia: a rest state does not depend on it)."""

DAMPING = 3.0
"""Joint damping relative to critical for a segment's mode (the whole cable's slower modes then
settle in about 2 s of simulated time)."""


def _quat_wxyz(matrix: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(matrix).as_quat(scalar_first=True)


@dataclass(eq=False)
class MujocoPlant:
    """MuJoCo's elastic cable held by two welded grippers (module docstring).

    Parameters
    ----------
    cable : Cable
        The real cable: its length, diameter, mass and E (bending; G = E / (2 (1 + nu)) for
        twist); ``cable.n_links`` MuJoCo segments.
    noise : float
        Measurement noise per coordinate [m].
    n_measured : int
        Points measured along the cable.
    seed : int
        Seed of the noise.
    substeps : int
        Rest states solved between consecutive clip poses.
    clamp : float, optional
        Length each gripper clamps [m] (default one segment); rounded to whole segments.
    timestep : float
        MuJoCo's time step [s].
    settle : float
        Simulated time per rest state [s] at most; it ends earlier once every point moves less
        than ``rest_speed``.
    rest_speed : float
        [m/s] the speed under which the cable counts as at rest (its slowest modes, about 10
        rad/s, are then within 0.01 mm of rest).
    ramp : float
        [s] the grippers move from their last pose to the new one over this simulated time
        (linear and slerp; a jump would yank the welds), then the cable settles.
    """

    cable: Cable
    noise: float = 0.0
    n_measured: int = 50
    seed: int = 0
    substeps: int = 2
    clamp: float | None = None
    timestep: float = 1e-3
    settle: float = 5.0
    rest_speed: float = 5e-5
    ramp: float = 0.5
    _model: object = field(default=None, init=False, repr=False)
    _data: object = field(default=None, init=False, repr=False)
    _states: dict = field(default_factory=dict, init=False, repr=False)

    @property
    def clamp_links(self) -> int:
        """Segments held by each gripper (>= 1)."""
        if self.clamp is None:
            return 1
        return max(1, round(self.clamp / self.cable.rest_link_length))

    def _build(self) -> None:
        import mujoco

        c = self.cable
        n = c.n_links
        k = self.clamp_links
        seg = c.rest_link_length
        shear = c.youngs_modulus / (2.0 * (1.0 + c.poisson_ratio))
        welds = []
        for j in range(k):  # body j runs from point j to j + 1 (x-axis along the cable)
            welds.append(("B_first" if j == 0 else f"B_{j}", "grip0",
                          [j * seg - 0.5 * k * seg, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]))
        for j in range(n - k, n):  # u of the last clip points into the cable: x = -u
            name = "B_last" if j == n - 1 else f"B_{j}"
            welds.append((name, "grip1", [0.5 * k * seg - (j - (n - k)) * seg, 0.0, 0.0],
                          [0.0, 0.0, 0.0, 1.0]))
        equality = "\n".join(
            f'<weld body1="{grip}" body2="{body}" relpose="{" ".join(map(str, pos))} '
            f'{" ".join(map(str, quat))}" solref="{2 * self.timestep} 1" '
            'solimp="0.99 0.999 0.0001"/>'
            for body, grip, pos, quat in welds)
        gravity = " ".join(str(v) for v in GRAVITY)
        xml = f"""
<mujoco>
  <option timestep="{self.timestep}" gravity="{gravity}" integrator="implicitfast"/>
  <extension><plugin plugin="mujoco.elasticity.cable"/></extension>
  <worldbody>
    <body name="grip0" mocap="true"/>
    <body name="grip1" mocap="true"/>
    <composite type="cable" curve="s" count="{n + 1} 1 1" size="{c.length}" initial="free">
      <plugin plugin="mujoco.elasticity.cable">
        <config key="twist" value="{shear}"/>
        <config key="bend" value="{c.youngs_modulus}"/>
        <config key="vmax" value="0"/>
      </plugin>
      <joint kind="main" damping="{self._damping()}" armature="{self._armature()}"/>
      <geom type="capsule" size="{0.5 * c.diameter}" mass="{c.mass / n}" contype="0"
            conaffinity="0"/>
    </composite>
  </worldbody>
  <equality>{equality}</equality>
</mujoco>"""
        self._model = mujoco.MjModel.from_xml_string(xml)
        self._data = mujoco.MjData(self._model)

    def _stiffness(self) -> float:
        """A segment joint's bending stiffness E I / l [N m / rad]."""
        c = self.cable
        return c.youngs_modulus * c.second_moment / c.rest_link_length

    def _armature(self) -> float:
        """Joint armature [kg m^2]: a fictitious inertia that slows the segments' own modes to
        well inside the time step's stability (a rest state does not depend on inertia)."""
        return self._stiffness() * (ARMATURE_STEPS * self.timestep) ** 2

    def _damping(self) -> float:
        """Joint damping [N m s/rad]: critical for a segment's mode with the armature."""
        return DAMPING * 2.0 * math.sqrt(self._stiffness() * self._armature())

    def points(self) -> np.ndarray:
        """(n + 1, 3) the cable's points now [m]: the segments' origins and the last's end."""
        import mujoco

        m, d = self._model, self._data
        ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "B_first")]
        ids += [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"B_{j}")
                for j in range(1, self.cable.n_links - 1)]
        ids.append(mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "B_last"))
        origins = d.xpos[ids].copy()
        end = origins[-1] + d.xmat[ids[-1]].reshape(3, 3)[:, 0] * self.cable.rest_link_length
        return np.vstack([origins, end])

    def _place(self, shape: np.ndarray) -> None:
        """Put the cable's segments on a polyline of n + 1 points (the free root's pose and
        the ball joints' rotations), at rest."""
        import mujoco
        from scipy.spatial.transform import Rotation

        m, d = self._model, self._data
        x = resample_by_arc_length(shape, self.cable.n_points)
        tangents = np.diff(x, axis=0)
        tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
        frames = []
        previous = Rotation.identity()
        for k, t in enumerate(tangents):  # minimal rotation from the previous segment's x
            a = previous.apply([1.0, 0.0, 0.0])
            axis = np.cross(a, t)
            s, cth = np.linalg.norm(axis), float(np.dot(a, t))
            turn = Rotation.from_rotvec(axis / s * math.atan2(s, cth)) if s > 1e-12 else \
                Rotation.identity()
            if k == 0:
                turn = Rotation.align_vectors([t], [[1.0, 0.0, 0.0]])[0]
            previous = turn * previous if k > 0 else turn
            frames.append(previous)
        qpos = np.zeros(m.nq)
        qpos[:3] = x[0]
        qpos[3:7] = frames[0].as_quat(scalar_first=True)
        for j in range(1, len(frames)):
            relative = frames[j - 1].inv() * frames[j]
            qpos[7 + 4 * (j - 1): 11 + 4 * (j - 1)] = relative.as_quat(scalar_first=True)
        d.qpos[:] = qpos
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)

    def hold(self, shape: np.ndarray, clips, gravity=GRAVITY, rtol: float = 0.0):
        """The rest state held by ``clips`` from the plant's current state (or ``shape`` the
        first time): ``(points (n + 1, 3), ok, message)``."""
        import mujoco

        if self._model is None:
            self._build()
        m, d = self._model, self._data
        key = np.asarray(shape, dtype=float).tobytes()
        if key in self._states:  # a rest state this plant returned: continue from it exactly
            d.qpos[:], d.mocap_pos[:2], d.mocap_quat[:2] = self._states[key]
            d.qvel[:] = 0.0
        else:
            self._place(shape)
        from scipy.spatial.transform import Rotation, Slerp

        target_pos = np.asarray(clips.positions, dtype=float)
        target_quat = [_quat_wxyz(clips.rotations[g].as_matrix()) for g in range(2)]
        if key not in self._states:  # placed anew: the grippers are where the clips are
            start_pos, start_quat = target_pos, target_quat
        else:
            start_pos = d.mocap_pos[:2].copy()
            start_quat = [d.mocap_quat[g].copy() for g in range(2)]
        slerps = [Slerp([0.0, 1.0], Rotation.from_quat(np.array([start_quat[g], target_quat[g]]),
                                                      scalar_first=True)) for g in range(2)]
        ramp_steps = max(1, int(self.ramp / self.timestep)) if key in self._states else 1
        for step in range(1, ramp_steps + 1):
            w = step / ramp_steps
            for g in range(2):
                d.mocap_pos[g] = (1.0 - w) * start_pos[g] + w * target_pos[g]
                d.mocap_quat[g] = slerps[g](w).as_quat(scalar_first=True)
            if step < ramp_steps:
                mujoco.mj_step(m, d)
        steps = int(self.settle / self.timestep)
        check = max(1, int(0.01 / self.timestep))
        before = self.points()
        for step in range(1, steps + 1):
            mujoco.mj_step(m, d)
            if step % check == 0:
                now = self.points()
                moved = float(np.max(np.linalg.norm(now - before, axis=1)))
                speed = moved / (check * m.opt.timestep)
                before = now
                if speed < self.rest_speed:
                    self._states[now.tobytes()] = (d.qpos.copy(), d.mocap_pos[:2].copy(),
                                                   d.mocap_quat[:2].copy())
                    return now, True, f"at rest after {step * m.opt.timestep:.2f} s"
        return self.points(), False, f"not at rest after {self.settle} s (speed {speed:.3g} m/s)"

    def measure(self, shape: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The noisy measurement of a plant shape, (n_measured, 3) [m]."""
        points = resample_by_arc_length(shape, self.n_measured)
        return points + rng.normal(scale=self.noise, size=points.shape)
