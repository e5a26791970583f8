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

* :class:`DismechPlant` -- dismech-newton's discrete elastic rod (Bergou et al. 2008: nodes and
  edges, stretch E A, bending E I and twist G J per edge, reference frames transported in time;
  NVIDIA Warp on the CPU; GPL-3.0, a test-only dependency: docs/decisions.md); each gripper
  prescribes the nodes and material twist of the clamped edges; quasi-static by a static solve
  of its own at every clip pose (pseudo-transient continuation of its implicit step).

Limits: the Ethernet cable (d 5 mm) comes to rest in MuJoCo at a 1 ms step; the thinner, softer USB
(d 3 mm) does not (its segments' modes outrun the step's stability), so the benchmark's plans
are Ethernet ones. Nothing of dloplan's physics is used: only its clip poses (positions,
rotations: the u-axis is the clip frame's x-axis, pointing into the cable) go in, points along
the cable come out.
Optional: the tests that use a plant skip with the reason when its package is missing
(``pip install dloplan[plants]``).

Why MuJoCo is slow and dismech-newton is not: MuJoCo reaches a rest state only by simulating the
damped dynamics (it has no static solve), at a step of 1 ms that the stiffest segment mode
allows, for the seconds the slowest (pendulum) modes take to decay: 2,000-5,500 steps per rest
state, each O(n^3) in the segments (the chain's joint-space mass matrix is dense; 12 ms at 100
segments), and the plant's segments are 5 per model link, so n = 20 means 100 segments. The
discrete elastic rod is solved for the rest state directly (Newton steps on the energy, about 20
per rest state, each a sparse banded solve, milliseconds at 100 edges), at 100 edges whatever the
plan's n.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from dloplan.cable import GRAVITY
from dloplan.correct import Plant
from dloplan.geometry import resample_by_arc_length

ARMATURE_STEPS = 4.0
"""A segment's own bending mode is slowed to a period of about 2 pi ARMATURE_STEPS time steps
(a fictitious inertia: a rest state does not depend on it)."""

DAMPING = 3.0
"""Joint damping relative to critical for a segment's mode (the whole cable's slower modes then
settle in about 2 s of simulated time)."""


def remembered_hold(plant, shape: np.ndarray, clips, gravity, rest):
    """``rest(shape, clips, gravity)`` once per shape, clips and gravity: the plant's answer
    ``(points, ok, message)``, kept in ``plant._held``.

    A plant here is deterministic (its start is the rest state it returned as ``shape``, or
    ``shape`` placed anew), so a hold asked again from the same shape with the same clips is the
    first answer: the closed loop drives the plant through the open loop's first shapes (up to
    its checkpoint) again, and they are simulated once.
    """
    key = (np.asarray(shape, dtype=float).tobytes(),
           np.asarray(clips.positions, dtype=float).tobytes(),
           clips.rotations.as_quat().tobytes(), np.asarray(gravity, dtype=float).tobytes())
    if key not in plant._held:
        plant._held[key] = rest(shape, clips, gravity)
    points, ok, message = plant._held[key]
    return points.copy(), ok, message


def _quat_wxyz(matrix: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(matrix).as_quat(scalar_first=True)


def _free_part(x: np.ndarray, segment: float) -> np.ndarray:
    """The free part between the clamps, (m + 1, 3), as segments of ``segment`` [m]: a polyline
    too short for them (a shorter clamp than the shape was planned with leaves excess cable; a
    taut start cannot take it) is given a sag of the missing length, then resampled."""
    from dloplan.geometry import shape_length
    from dloplan.physics.compiled import stretch_to_length

    need = (len(x) - 1) * segment
    if float(shape_length(x)) < need:
        along = (x[-1] - x[0]) / max(float(np.linalg.norm(x[-1] - x[0])), 1e-12)
        gravity = np.array([0.0, 0.0, -1.0])
        down = gravity - float(gravity @ along) * along  # across the chord, downwards
        if np.linalg.norm(down) < 1e-6:  # a vertical chord: any direction across it
            down = np.cross(along, [1.0, 0.0, 0.0])
        bump = np.sin(np.linspace(0.0, np.pi, len(x)))[:, None] * (down / np.linalg.norm(down))
        x = x + stretch_to_length(x, bump, need) * bump
    return resample_by_arc_length(x, len(x))


def clamped_polyline(plant: Plant, shape: np.ndarray, clips) -> np.ndarray:
    """``shape`` resampled to the plant's n + 1 points, the clamped segments straight along the
    clips' u-axes and centred on the clip points, the free part between them of whole segments
    (:func:`_free_part`)."""
    x = resample_by_arc_length(shape, plant.cable.n_points)
    k = plant.clamp_links
    offsets = (np.arange(k + 1) - 0.5 * k) * plant.cable.rest_link_length
    u = clips.u_axes
    x[: k + 1] = clips.positions[0] + offsets[:, None] * u[0]
    x[::-1][: k + 1] = clips.positions[1] + offsets[:, None] * u[1]
    x[k : len(x) - k] = _free_part(x[k : len(x) - k], plant.cable.rest_link_length)
    return x


@dataclass(frozen=True, eq=False)
class MujocoPlant(Plant):
    """MuJoCo's elastic cable held by two welded grippers (module docstring).

    Parameters
    ----------
    cable, noise, n_measured, seed, substeps, clamp
        As :class:`dloplan.correct.Plant`: the real cable (its length, diameter, mass and E:
        bending, G = E / (2 (1 + nu)) for twist; ``cable.n_links`` MuJoCo segments), noise per
        coordinate [m], points measured, the noise's seed, rest states between consecutive clip
        poses, the clamped length [m] (default one segment; rounded to whole segments).
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

    timestep: float = 1e-3
    settle: float = 5.0
    rest_speed: float = 5e-5
    ramp: float = 0.5
    _sim: dict = field(default_factory=dict, init=False, repr=False)
    _states: dict = field(default_factory=dict, init=False, repr=False)
    _held: dict = field(default_factory=dict, init=False, repr=False)

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
        self._sim["model"] = mujoco.MjModel.from_xml_string(xml)
        self._sim["data"] = mujoco.MjData(self._sim["model"])

    @property
    def resolution(self) -> float:
        """[m] a rest state's resolution: at ``rest_speed`` the slowest modes (about 10 rad/s)
        are within rest_speed / (5 rad/s) of rest (0.01 mm)."""
        return self.rest_speed / 5.0

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

        m, d = self._sim["model"], self._sim["data"]
        ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "B_first")]
        ids += [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"B_{j}")
                for j in range(1, self.cable.n_links - 1)]
        ids.append(mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "B_last"))
        origins = d.xpos[ids].copy()
        end = origins[-1] + d.xmat[ids[-1]].reshape(3, 3)[:, 0] * self.cable.rest_link_length
        return np.vstack([origins, end])

    def _place(self, shape: np.ndarray, clips) -> None:
        """Put the cable's segments on a polyline of n + 1 points (the free root's pose and
        the ball joints' rotations), at rest, the clamped segments straight along the clips'
        u-axes where the welds hold them (a shape planned with another clamp length would
        start with the welds yanking the end segments)."""
        import mujoco
        from scipy.spatial.transform import Rotation

        m, d = self._sim["model"], self._sim["data"]
        x = clamped_polyline(self, shape, clips)
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
        first time): ``(points (n + 1, 3), ok, message)`` (:func:`remembered_hold`)."""
        return remembered_hold(self, shape, clips, gravity, self._rest)

    def _rest(self, shape: np.ndarray, clips, gravity):
        """:meth:`hold` simulated: the grippers ramped to ``clips``, then the damped dynamics
        stepped until the cable is at rest (MuJoCo's gravity is the model's)."""
        import mujoco

        if not self._sim:
            self._build()
        m, d = self._sim["model"], self._sim["data"]
        key = np.asarray(shape, dtype=float).tobytes()
        if key in self._states:  # a rest state this plant returned: continue from it exactly
            d.qpos[:], d.mocap_pos[:2], d.mocap_quat[:2] = self._states[key]
            d.qvel[:] = 0.0
        else:
            self._place(shape, clips)
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


def import_dismech():
    """dismech-newton, imported (its Warp kernels compile on the first use, about 4 minutes once,
    cached in ``~/.cache/warp``). Version 0.1.0.post4 annotates a method with ``Slots | None``,
    ``Slots`` a Warp struct, which Python before 3.14 evaluates at the import and refuses: a
    Warp struct is given ``|`` for that annotation (it has no other use at run time).

    Warp builds its kernels without their adjoints (``enable_backward``): the plant takes no
    gradient (no ``wp.Tape``), and the forward code is the same, so the rest states are bit for
    bit those with them; a new machine's first compilation costs about 40 % less CPU."""
    import warp

    warp.config.quiet = True
    warp.config.enable_backward = False
    from warp._src.codegen import Struct

    Struct.__or__ = Struct.__ror__ = lambda self, other: self
    import dismech_newton
    import newton

    return newton, dismech_newton


def _angle_about(axis: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(m,) the angle [rad] from ``a`` to ``b`` (each (m, 3), perpendicular to ``axis``) about
    ``axis``."""
    return np.arctan2(np.einsum("ij,ij->i", axis, np.cross(a, b)), np.einsum("ij,ij->i", a, b))


@dataclass(frozen=True, eq=False)
class DismechPlant(Plant):
    """dismech-newton's discrete elastic rod held by two clamps (module docstring).

    The rod is built straight (its rest shape) with ``cable.n_links`` edges of the cable's
    length, diameter, mass (uniform), E (bending E I), G (twist G J) and axial modulus (stretch
    E_a A; the cable's ``axial_youngs_modulus``). Each gripper prescribes the positions of the
    ``clamp_links`` edges at its end (straight along the clip's u-axis, centred on the clip
    point) and their material twist (the material direction m1 along the clip's z-axis). A rest
    state is the static equilibrium, solved by the rod's own implicit step from rest with a time
    step growing fourfold per step (pseudo-transient continuation: the first steps are damped by
    the inertia, the last are Newton steps on the energy, with a line search), until the Newton
    step moves no coordinate by more than ``tolerance`` at a step so long that inertia is
    negligible (``static_step``).

    Limits: positions, strains and energies are float32 (dismech-newton's kernels), so a rest
    state is resolved to about 1e-8 m of position but only to the tolerance where the line
    search still sees the energy fall: 1e-5 m with E_a = E; with a copper axial modulus
    (E_a = 267 E) the stretch energy's rounding hides the bending's last changes (Newton steps
    of 10-40 micrometres stall; 0.1 mm is reached), and on the 3D Ethernet job one rest state
    did not settle at all (benchmarks/bench_correct.py, "stiff axial").

    Parameters
    ----------
    cable, noise, n_measured, seed, substeps, clamp
        As :class:`dloplan.correct.Plant`: the real cable (``cable.n_links`` edges, 100 in the
        benchmark), noise per coordinate [m], points measured, the noise's seed, rest states
        between consecutive clip poses, clamped length [m] (default one edge; rounded to whole
        edges).
    tolerance : float
        [m] the largest coordinate change of the last Newton step at rest (float32 positions
        resolve about 1e-8 m here).
    first_step : float
        [s] the first pseudo time step (a start far from rest: a few, damped, steps).
    static_step : float
        [s] a step at least this long counts as static (the inertia term M / dt^2 is then below
        1e-6 of the softest elastic stiffness of the benchmark's cables).
    max_steps : int
        Steps per rest state at most.
    """

    tolerance: float = 1e-5
    first_step: float = 0.02
    static_step: float = 1e3
    max_steps: int = 200
    _sim: dict = field(default_factory=dict, init=False, repr=False)
    _states: dict = field(default_factory=dict, init=False, repr=False)
    _held: dict = field(default_factory=dict, init=False, repr=False)

    @property
    def resolution(self) -> float:
        """[m] a rest state's resolution: the Newton tolerance (``tolerance``)."""
        return self.tolerance

    def _build(self, gravity) -> None:
        newton, dismech = import_dismech()
        c = self.cable
        n, l, k = c.n_links, c.rest_link_length, self.clamp_links
        builder = newton.ModelBuilder(gravity=tuple(float(g) for g in gravity))
        rod = newton.Rod.create_straight((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), c.length,
                                         segment_count=n, radius=0.5 * c.diameter)
        dismech.add_rod(builder, rod,
                        cfg=newton.ModelBuilder.ShapeConfig(density=c.mass / (c.area * c.length)),
                        stretch_stiffness=c.axial_stiffness / l,
                        bend_stiffness=c.youngs_modulus * c.second_moment / l,
                        twist_stiffness=c.shear_modulus * c.polar_moment / l, proxies=False)
        for e in [*range(k), *range(n - k, n)]:
            dismech.fix_segment(builder, edge=e)
        model = builder.finalize(device="cpu")
        solver = dismech.DiSMechSolver(model, exact=True, iterations=1, linesearch=8,
                                       self_contact=False)
        states = [model.state() for _ in range(3)]
        for state in states:
            dismech.flatten_state(state)
        self._sim.update(model=model, solver=solver, states=states, gravity=np.array(gravity),
                         centre=None)

    def _clamped(self, clips) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The clamped nodes' indices, their positions (local frame) and each clamped edge's
        (index, material direction m1 = the clip's z-axis)."""
        c, k = self.cable, self.clamp_links
        n = c.n_links
        offsets = (np.arange(k + 1) - 0.5 * k) * c.rest_link_length
        u = clips.u_axes
        local = np.asarray(clips.positions) - self._sim["centre"]
        nodes = np.r_[np.arange(k + 1), n - np.arange(k + 1)]
        positions = np.vstack([local[0] + offsets[:, None] * u[0],
                               local[1] + offsets[:, None] * u[1]])
        z = clips.rotations.as_matrix()[:, :, 2]
        edges = np.r_[np.arange(k), np.arange(n - k, n)]
        directions = np.vstack([np.repeat(z[:1], k, axis=0), np.repeat(z[1:], k, axis=0)])
        return nodes, positions, (edges, directions)

    def _clamp_nodes(self, state, clips) -> None:
        """Put the clamped nodes of ``state`` where the clips hold them."""
        nodes, positions, _ = self._clamped(clips)
        x = state.particle_q.numpy()
        x[nodes] = positions
        state.particle_q.assign(x)

    def _clamp_twist(self, state, clips, previous_theta: np.ndarray | None) -> None:
        """Twist the clamped edges of ``state`` (its frames current) so that their material
        direction m1 is the clip's z-axis, continued from ``previous_theta`` (no jump of 2 pi)."""
        _, _, (edges, directions) = self._clamped(clips)
        x = state.particle_q.numpy()
        t = x[edges + 1] - x[edges]
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        theta = _angle_about(t, state.dismech.edge_d1_q.numpy()[edges], directions)
        if previous_theta is not None:
            theta = previous_theta + np.angle(np.exp(1j * (theta - previous_theta)))
        twist = state.dismech.edge_q.numpy()
        twist[edges] = theta
        state.dismech.edge_q.assign(twist)

    def _place(self, state, shape: np.ndarray, clips) -> None:
        """``state`` on the polyline ``shape`` (clamps straight), reference directors transported
        along the curve from the first clip's z-axis (reference twist 0), the free edges
        untwisted, the clamped ones twisted to their clips."""
        x = clamped_polyline(self, shape, clips) - self._sim["centre"]
        t = np.diff(x, axis=0)
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        d1 = np.empty_like(t)
        a = clips.rotations.as_matrix()[0][:, 2]
        d1[0] = a - (a @ t[0]) * t[0]
        for e in range(1, len(t)):  # space-parallel transport (the plant's own formula)
            m = d1[e - 1]
            d1[e] = m - (m @ t[e]) / (1.0 + t[e - 1] @ t[e]) * (t[e - 1] + t[e])
            d1[e] /= np.linalg.norm(d1[e])
        state.particle_q.assign(x.astype(np.float32))
        state.dismech.edge_d1_q.assign(d1.astype(np.float32))
        state.dismech.edge_q.assign(np.zeros(len(t), dtype=np.float32))
        state.dismech.triplet_ref_twist_q.assign(np.zeros(len(t) - 1, dtype=np.float32))
        state.dismech.triplet_strain_q.fill_(float("nan"))
        self._clamp_twist(state, clips, None)

    def _moved(self, state, previous, old_clips, clips) -> None:
        """``state`` = ``previous`` with the grippers moved from ``old_clips`` to ``clips``:
        every node carried by the two grippers' rigid motions, blended along the cable, the
        frames transported in time (the solver's restart), the clamps prescribed."""
        centre = self._sim["centre"]
        x = previous.particle_q.numpy().astype(float) + centre
        s = np.linspace(0.0, 1.0, len(x))[:, None]
        turn = clips.rotations * old_clips.rotations.inv()
        carried = [turn[g].apply(x - old_clips.positions[g]) + clips.positions[g]
                   for g in range(2)]
        state.dismech.q.assign(previous.dismech.q)
        state.particle_q.assign(((1.0 - s) * carried[0] + s * carried[1] - centre)
                                .astype(np.float32))
        self._clamp_nodes(state, clips)
        self._sim["solver"].restart(state, previous)
        edges = self._clamped(clips)[2][0]
        self._clamp_twist(state, clips, previous.dismech.edge_q.numpy()[edges])

    def _solve(self, a, b) -> tuple[object, bool, str]:
        """The rest state from state ``a`` (``b`` a spare state; class docstring):
        ``(state, converged, message)``. The Newton step and the line search's choice are read
        from the solver (``_dq``, ``_pick``: dismech-newton has no public residual)."""
        solver = self._sim["solver"]
        solver.reset(a)
        dt = self.first_step
        moved = np.inf
        for step in range(1, self.max_steps + 1):
            a.dismech.qd.zero_()
            solver.step(a, b, None, None, dt)
            moved = float(np.max(np.abs(solver._dq.numpy())))
            taken = int(solver._pick.numpy()[0]) > 0
            if dt >= self.static_step and moved < self.tolerance:
                return b if taken else a, True, f"at rest after {step} steps"
            if taken:
                a, b = b, a
            if taken or moved < self.tolerance:  # a step below the tolerance may find no
                dt = min(4.0 * dt, 1e3 * self.static_step)  # descent in float32: go on
            else:  # no descent along the Newton step: more inertia (a shorter step)
                dt = max(dt / 16.0, 1e-6)
        return a, False, (f"not at rest after {self.max_steps} steps (last Newton step "
                          f"{moved:.3g} m)")

    def hold(self, shape: np.ndarray, clips, gravity=GRAVITY, rtol: float = 0.0):
        """The rest state held by ``clips`` from the plant's state ``shape`` (a rest state this
        plant returned: continued from it, twist and frames included) or from the polyline
        ``shape``: ``(points (n + 1, 3), ok, message)`` (:func:`remembered_hold`)."""
        return remembered_hold(self, shape, clips, gravity, self._rest)

    def _rest(self, shape: np.ndarray, clips, gravity):
        """:meth:`hold` solved."""
        if not self._sim:
            self._build(gravity)
        if not np.allclose(self._sim["gravity"], gravity):
            self._sim["model"].gravity.assign(np.asarray([gravity], dtype=np.float32))
            self._sim["gravity"] = np.array(gravity)
        if self._sim["centre"] is None:  # float32 positions: a local frame near the cable
            self._sim["centre"] = np.mean(np.asarray(clips.positions), axis=0)
        start, previous, spare = self._sim["states"]
        key = np.asarray(shape, dtype=float).tobytes()
        if key in self._states:
            q, d1, ref, old_clips = self._states[key]
            previous.dismech.q.assign(q)
            previous.dismech.edge_d1_q.assign(d1)
            previous.dismech.triplet_ref_twist_q.assign(ref)
            previous.dismech.triplet_strain_q.fill_(float("nan"))
            self._moved(start, previous, old_clips, clips)
        else:
            self._place(start, shape, clips)
        rest, ok, message = self._solve(start, spare)
        points = rest.particle_q.numpy().astype(float) + self._sim["centre"]
        if ok:
            self._states[points.tobytes()] = (rest.dismech.q.numpy().copy(),
                                              rest.dismech.edge_d1_q.numpy().copy(),
                                              rest.dismech.triplet_ref_twist_q.numpy().copy(),
                                              clips)
        return points, ok, message


def assert_demo_corrected(folder, make_plant):
    """The sagging demo planned at its own n (12) by ``dloplan plan``, run on the plant
    ``make_plant(cable)`` (the plan's cable) with one correction at mid-path: the correction is
    not refused, at least halves the final error, its prediction interval holds the plant's
    result, and the corrected plan passes every check ``dloplan verify`` runs or is refused
    naming the check (robot program, verification). Returns the run."""
    from pathlib import Path

    import yaml

    from dloplan.app import read_plan
    from dloplan.app.correct import check_correction
    from dloplan.cli import main
    from dloplan.correct import CorrectionRefused, run_closed_loop

    data = yaml.safe_load((Path(__file__).parent / "data" / "sagging_demo.yaml").read_text())
    data["outputs"] = ["json"]
    scenario = folder / "demo.yaml"
    scenario.write_text(yaml.safe_dump(data))
    assert main(["plan", str(scenario), "-o", str(folder / "plan"), "-q"]) in (0, 1)
    doc = read_plan(folder / "plan" / "plan.json")
    run = run_closed_loop(make_plant(doc.cable), doc.cable, doc.shapes, doc.grippers,
                          [(len(doc.shapes) - 1) // 2], stabilized=doc.stabilized,
                          trajectory=doc.trajectory)
    assert not run.refusals, run.refusals
    (correction,) = run.corrections
    assert run.closed_loop_error < 0.5 * run.open_loop_error
    low, high = correction.prediction_interval
    assert low <= run.closed_loop_error <= high
    try:
        corrected, _ = check_correction(doc, correction, verify=True)
    except CorrectionRefused as exc:
        assert "robot program" in str(exc) or "verification" in str(exc)
    else:
        assert corrected.robot.ok and corrected.verification.ok
    return run
