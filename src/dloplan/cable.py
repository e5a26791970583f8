"""The physical cable and its mass-spring discretization (thesis chapter 3).

A :class:`Cable` describes one deformable linear object (length, diameter, mass, Young's
modulus, Poisson ratio) and how it is discretized: ``n_links`` straight links joining
``n_links + 1`` mass points, optionally with a curved rest shape (thesis 3.9). Everything the
model needs is derived from these fields, in SI units:

========================  ==========================================  ===============
quantity                  formula                                     thesis equation
========================  ==========================================  ===============
rest link length l        L / n                                       3.2
point masses m_i          m / (n+1) (``"equal"``) or consistent        3.1
axial constant k_s        E_a A / l,  A = pi d^2 / 4                  3.10
bending constant k_b      3 E I / l (``"thesis"``) or E I / l         3.13
twist constant k_t        G I_p / l,  G = E / (2 (1 + nu))             3.16
damping k_d               2 xi sqrt(m_i E A / l), xi = 0.05           3.23
time step                 sqrt(m_i l / k_s)                            3.8.2 / 6.5
========================  ==========================================  ===============

Two modelling choices of the thesis are selectable, because the thesis' own choice is only an
approximation of the rod it discretizes:

* ``bending="thesis"`` uses k_b = 3EI/l, from the analogy of one link with a cantilever (eq.
  3.13). A chain of such springs converges, as n grows, to a rod of bending stiffness
  k_b l = 3EI: **three times stiffer in bending** than a rod of the same E. The thesis'
  Young's-modulus identification (chapter 6) absorbs the factor, so the E it reports for the
  USB and Ethernet cables are "thesis-model" moduli. ``bending="rod"`` uses k_b = EI/l, the
  consistent discretization of a Kirchhoff rod (1/2 EI kappa^2 ds with kappa = beta / l), which
  converges to the continuous elastica; use it with tabulated moduli (PU, PA12).
* ``masses="equal"`` puts m/(n+1) on every point (eq. 3.1); ``masses="consistent"`` gives each
  point the mass of the half links beside it (m/n inside, m/(2n) at the two ends), which puts
  the weight where the cable is and converges faster to the continuum.

The defaults (``"rod"``, ``"consistent"``) are the consistent model; ``Cable.thesis_model``
switches both, and the axial modulus, to the thesis' choices to reproduce its numbers.

The axial modulus E_a is ``axial_modulus`` when given, else E (the thesis: one modulus for
bending and stretching). Composite cables need their own: their bending modulus is an
equivalent one, tiny against their copper cores' axial stiffness, and with E_a = E a USB cable
stretches by about 1 % under its own weight (see ``docs/model.md``, "Axial stiffness"). The
catalogue's USB and Ethernet cables have theirs by default (:data:`COMPOSITE_AXIAL_MODULI`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

GRAVITY = np.array([0.0, 0.0, -9.81])
"""Default gravity acceleration [m/s^2] in the world frame (z up)."""

BendingModel = Literal["thesis", "rod"]
MassModel = Literal["equal", "consistent"]

REST_LENGTH_TOLERANCE = 1e-3
"""Relative tolerance on the link lengths of a rest shape against L/n."""


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name}: got {value!r}, expected a finite number > 0")
    return value


STIFF_AXIAL_RATIO = 10.0
"""E_a / E from which a cable's axial springs count as stiff (:attr:`Cable.stiff_axial`): the
static solvers' second-order correction of the link lengths is applied from there on
(docs/decisions.md, "Second-order correction only for stiff axial springs"). The composite
cables' copper is 270-800 E; E_a = E (the thesis; the hoses) takes the plain Newton steps."""


@dataclass(frozen=True, eq=False)
class Cable:
    """An elastic cable discretized into a chain of mass points (thesis chapter 3).

    Parameters
    ----------
    length : float
        Rest length L [m].
    diameter : float
        Cross-section diameter d [m] (a full circular section is assumed for A, I, I_p).
    mass : float
        Total mass m [kg].
    youngs_modulus : float
        Young's modulus E [Pa] (for composite cables, the equivalent modulus identified for
        the chosen ``bending`` model, see the module docstring).
    poisson_ratio : float
        Poisson ratio nu in (-1, 0.5]; only the twist constant depends on it.
    n_links : int
        Number of links n >= 3 (n + 1 mass points).
    rest_shape : array_like, optional
        Curved rest shape, (n + 1, 3) points [m] whose link lengths are L/n (thesis 3.9). Its
        placement is irrelevant: only its bending angles are used. ``None`` means straight.
    bending : {"rod", "thesis"}
        Bending constant model: ``"rod"`` k_b = EI/l, ``"thesis"`` k_b = 3EI/l (eq. 3.13).
    masses : {"consistent", "equal"}
        Point masses: ``"consistent"`` (half links, m/(2n) at the ends) or ``"equal"``
        m/(n + 1) (eq. 3.1).
    damping_ratio : float
        Damping ratio xi of eq. 3.21 (default 0.05, the thesis' rubber upper bound).
    name : str
        Optional label, e.g. ``"usb"``.
    axial_modulus : float, optional
        Modulus of the axial springs E_a [Pa] (k_s = E_a A / l), separate from the bending
        modulus; ``None`` (default) uses ``youngs_modulus`` (the thesis' model, right for a
        hose of one material). :func:`catalogue_cable` gives the composite cables
        :data:`COMPOSITE_AXIAL_MODULI`.
    """

    length: float
    diameter: float
    mass: float
    youngs_modulus: float
    poisson_ratio: float = 0.4
    n_links: int = 10
    rest_shape: np.ndarray | None = field(default=None, repr=False)
    bending: BendingModel = "rod"
    masses: MassModel = "consistent"
    damping_ratio: float = 0.05
    name: str = ""
    axial_modulus: float | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "length", _positive("length", self.length))
        set_(self, "diameter", _positive("diameter", self.diameter))
        set_(self, "mass", _positive("mass", self.mass))
        set_(self, "youngs_modulus", _positive("youngs_modulus", self.youngs_modulus))
        set_(self, "damping_ratio", _positive("damping_ratio", self.damping_ratio))
        if self.axial_modulus is not None:
            set_(self, "axial_modulus", _positive("axial_modulus", self.axial_modulus))
        nu = float(self.poisson_ratio)
        if not (math.isfinite(nu) and -1.0 < nu <= 0.5):
            raise ValueError(f"poisson_ratio: got {self.poisson_ratio!r}, expected -1 < nu <= 0.5")
        set_(self, "poisson_ratio", nu)
        if isinstance(self.n_links, bool) or int(self.n_links) != self.n_links:
            raise ValueError(f"n_links: got {self.n_links!r}, expected an integer >= 3")
        set_(self, "n_links", int(self.n_links))
        if self.n_links < 3:
            raise ValueError(f"n_links: got {self.n_links}, expected an integer >= 3")
        if self.bending not in ("rod", "thesis"):
            raise ValueError(f"bending: got {self.bending!r}, expected 'rod' or 'thesis'")
        if self.masses not in ("consistent", "equal"):
            raise ValueError(f"masses: got {self.masses!r}, expected 'consistent' or 'equal'")
        if self.rest_shape is not None:
            set_(self, "rest_shape", self._checked_rest_shape(self.rest_shape))

    def _checked_rest_shape(self, rest_shape) -> np.ndarray:
        from .geometry import as_shape, link_lengths

        shape = as_shape(rest_shape, self.n_links + 1, "rest_shape").copy()
        lengths = link_lengths(shape)
        worst = float(np.max(np.abs(lengths / self.rest_link_length - 1.0)))
        if worst > REST_LENGTH_TOLERANCE:
            raise ValueError(
                f"rest_shape: link lengths differ from L/n = {self.rest_link_length:.6g} m by up "
                f"to {100 * worst:.3g} %, expected within {100 * REST_LENGTH_TOLERANCE:.2g} %"
            )
        return shape

    # -- discretization ------------------------------------------------------------------
    @property
    def n_points(self) -> int:
        """Number of mass points n + 1."""
        return self.n_links + 1

    @property
    def rest_link_length(self) -> float:
        """Rest length of one link l = L / n [m] (eq. 3.2)."""
        return self.length / self.n_links

    @property
    def point_masses(self) -> np.ndarray:
        """Mass of each point [kg], shape (n + 1,) (eq. 3.1 or consistent lumping)."""
        n = self.n_links
        if self.masses == "equal":
            return np.full(n + 1, self.mass / (n + 1))
        m = np.full(n + 1, self.mass / n)
        m[[0, -1]] *= 0.5
        return m

    @property
    def rest_angles(self) -> np.ndarray:
        """Rest bending angles beta_0 [rad], shape (n - 1,) (zeros for a straight cable)."""
        if self.rest_shape is None:
            return np.zeros(self.n_links - 1)
        from .geometry import bending_angles

        return bending_angles(self.rest_shape)

    @property
    def is_curved(self) -> bool:
        """True when the rest shape is not straight."""
        return bool(np.any(self.rest_angles > 1e-9))

    # -- section and material ------------------------------------------------------------
    @property
    def area(self) -> float:
        """Cross-section area A = pi d^2 / 4 [m^2]."""
        return math.pi * self.diameter**2 / 4.0

    @property
    def second_moment(self) -> float:
        """Second moment of area I = pi d^4 / 64 [m^4]."""
        return math.pi * self.diameter**4 / 64.0

    @property
    def polar_moment(self) -> float:
        """Polar moment of area I_p = pi d^4 / 32 [m^4]."""
        return math.pi * self.diameter**4 / 32.0

    @property
    def shear_modulus(self) -> float:
        """Shear modulus G = E / (2 (1 + nu)) [Pa]."""
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def axial_youngs_modulus(self) -> float:
        """Modulus of the axial springs E_a [Pa]: ``axial_modulus``, else ``youngs_modulus``."""
        return self.youngs_modulus if self.axial_modulus is None else self.axial_modulus

    @property
    def stiff_axial(self) -> bool:
        """Whether the axial springs are much stiffer than the bending modulus gives them:
        E_a >= :data:`STIFF_AXIAL_RATIO` E (e.g. :data:`COMPOSITE_AXIAL_MODULI`). The static
        solvers then correct their Newton steps' link lengths
        (:func:`dloplan.sim.compiled.restore_link_lengths`); with E_a = E (the thesis) they take
        the plain steps."""
        return self.axial_youngs_modulus >= STIFF_AXIAL_RATIO * self.youngs_modulus

    @property
    def axial_stiffness(self) -> float:
        """Axial stiffness E_a A [N] (the force that would double a link's length)."""
        return self.axial_youngs_modulus * self.area

    @property
    def bending_stiffness(self) -> float:
        """Effective continuum bending stiffness k_b l [N m^2] the chain converges to.

        Equal to EI for ``bending="rod"`` and 3EI for ``bending="thesis"``.
        """
        return self.k_bending * self.rest_link_length

    @property
    def weight_per_length(self) -> float:
        """Weight per unit length q = m g / L [N/m]."""
        return self.mass * float(np.linalg.norm(GRAVITY)) / self.length

    # -- spring constants (eqs. 3.10, 3.13, 3.16, 3.23) ----------------------------------
    @property
    def k_axial(self) -> float:
        """Axial spring constant k_s = E_a A / l [N/m] (eq. 3.10, E_a = E unless given)."""
        return self.axial_stiffness / self.rest_link_length

    @property
    def k_bending(self) -> float:
        """Bending spring constant k_b [N m / rad^2]: 3EI/l (thesis, eq. 3.13) or EI/l (rod)."""
        factor = 3.0 if self.bending == "thesis" else 1.0
        return factor * self.youngs_modulus * self.second_moment / self.rest_link_length

    @property
    def k_twist(self) -> float:
        """Twist spring constant k_t = G I_p / l [N m / rad^2] (eq. 3.16)."""
        return self.shear_modulus * self.polar_moment / self.rest_link_length

    @property
    def k_damping(self) -> float:
        """Fictitious damping k_d = 2 xi sqrt(m_i k_s) [N s/m] (eq. 3.23), m_i the mean mass.

        k_s is the thesis' axial spring, E A / l with the (bending) modulus E, also when the
        axial springs have a modulus of their own: the thesis sized its fictitious damping with
        its one modulus, and -k_d v damps every mode at the same rate k_d / (2 m_i), so the
        composite cables' copper (E_a ~ 800 E) would otherwise get a drag 27 times the thesis'
        that lets a USB cable fall at 7 mm/s (docs/decisions.md, "Axial modulus of composite
        cables"); their axial vibration decays at the thesis' rate all the same.
        """
        m_i = self.mass / self.n_points
        k_s = self.youngs_modulus * self.area / self.rest_link_length
        return 2.0 * self.damping_ratio * math.sqrt(m_i * k_s)

    def time_step(self, youngs_modulus_cap: float | None = None) -> float:
        """Explicit time step sqrt(m_i l / k_s) [s] (eq. 3.8.2 / 6.5).

        Parameters
        ----------
        youngs_modulus_cap : float, optional
            The fictitious modulus of thesis chapter 6 (Fig. 6.5): with the thesis' one modulus
            (E_a = E) k_s is computed from min(E, cap), which enlarges the step of stiff cables
            (at the price of an explicit scheme that may then need more damping to stay
            stable). It stands in for E only: axial springs with a modulus of their own
            (``axial_modulus``, e.g. the composite cables' copper) set the step at their own
            stiffness, since a step from the cap would be tens of times too long for them and
            the scheme would diverge (the thesis' cap assumes the springs are E's).
        """
        modulus = self.axial_youngs_modulus
        if youngs_modulus_cap is not None:
            cap = _positive("youngs_modulus_cap", youngs_modulus_cap)
            modulus = modulus if self.axial_modulus is not None else min(modulus, cap)
        k_s = modulus * self.area / self.rest_link_length
        m_i = self.mass / self.n_points
        return math.sqrt(m_i * self.rest_link_length / k_s)

    # -- variants --------------------------------------------------------------------------
    def with_links(self, n_links: int) -> Cable:
        """The same cable with another discretization (a curved rest shape is resampled)."""
        rest = self.rest_shape
        if rest is not None and n_links != self.n_links:
            from .geometry import resample_by_arc_length, tangents

            # resample, then rebuild with links of exactly L/n along the resampled directions
            directions = tangents(resample_by_arc_length(rest, n_links + 1))
            steps = directions * (self.length / n_links)
            rest = np.vstack([rest[:1], rest[0] + np.cumsum(steps, axis=0)])
        return replace(self, n_links=n_links, rest_shape=rest)

    def with_modulus(self, youngs_modulus: float) -> Cable:
        """The same cable with another Young's modulus [Pa] (the axial modulus, if given, kept)."""
        return replace(self, youngs_modulus=youngs_modulus)

    def thesis_model(self) -> Cable:
        """The same cable with the thesis' modelling choices (k_b = 3EI/l, equal masses, one
        modulus for bending and stretching: E_a = E)."""
        return replace(self, bending="thesis", masses="equal", axial_modulus=None)

    def constants(self) -> dict[str, float]:
        """The derived model constants, keyed by name with their unit in brackets."""
        return {
            "L [m]": self.length,
            "d [m]": self.diameter,
            "m [kg]": self.mass,
            "E [Pa]": self.youngs_modulus,
            "E_a [Pa]": self.axial_youngs_modulus,
            "n": self.n_links,
            "l [m]": self.rest_link_length,
            "m_i [kg]": float(self.point_masses[1]),
            "A [m^2]": self.area,
            "I [m^4]": self.second_moment,
            "Ip [m^4]": self.polar_moment,
            "G [Pa]": self.shear_modulus,
            "k_s [N/m]": self.k_axial,
            "k_b [N m]": self.k_bending,
            "k_t [N m]": self.k_twist,
            "k_d [N s/m]": self.k_damping,
            "dt [s]": self.time_step(),
        }


# -- the thesis' cables (section 7.2) ---------------------------------------------------------
_CATALOGUE: dict[str, dict[str, float]] = {
    # E of the composite cables is the thesis' identified value (thesis bending model, 7.2.1).
    "usb": dict(length=0.5, diameter=0.003, mass=0.010, youngs_modulus=2.5e6, poisson_ratio=0.4),
    "ethernet": dict(
        length=0.5, diameter=0.005, mass=0.010, youngs_modulus=7.5e6, poisson_ratio=0.4
    ),
    "pu": dict(length=0.5, diameter=0.006, mass=0.011, youngs_modulus=1e8, poisson_ratio=0.48),
    "pa12": dict(length=0.5, diameter=0.006, mass=0.009, youngs_modulus=1e9, poisson_ratio=0.4),
}
CATALOGUE_NAMES: tuple[str, ...] = tuple(_CATALOGUE)

COMPOSITE_AXIAL_MODULI: dict[str, float] = {"usb": 2e9, "ethernet": 2e9}
"""Axial moduli E_a [Pa] of the composite catalogue cables (USB, Ethernet):
:func:`catalogue_cable`'s default for them.

Order-of-magnitude estimates from their copper: E_cu ~ 117 GPa on about 0.3 mm^2 (USB, four
AWG 28 conductors and the shield) or 1.6 mm^2 (Ethernet, eight AWG 24), derated about three
times for the twist of the pairs and spread over the whole section A: E_a ~ 2 GPa, a thousand
times their bending moduli. Any value above about 1e8 Pa gives nearly the same shapes (the
cable is then practically inextensible: the USB between level clips sags within 0.01 mm of the
2 GPa shape at 0.4 m apart, 0.25 mm nearly taut at 0.48 m), so the estimate need not be
precise. With the thesis' single modulus (E_a = E) the USB stretches about 1 % under its own
weight and a nearly taut shape differs by up to 3 mm from an inextensible cable's (MuJoCo's
cable, issue 35); that model stays an option: ``catalogue_cable("usb", axial_modulus=None)``,
:meth:`Cable.thesis_model`, or ``axial_modulus: thesis`` in a scenario (docs/decisions.md).
The static solver converges on such nearly inextensible links by a second-order correction
of its Newton steps (:func:`dloplan.sim.compiled.restore_link_lengths`, from
:data:`STIFF_AXIAL_RATIO` E on).
"""


def catalogue_cable(name: str, n_links: int = 10, **overrides) -> Cable:
    """One of the four cables of thesis section 7.2.

    ``usb`` (d 3 mm, 10 g, E 2.5 MPa), ``ethernet`` (d 5 mm, 10 g, E 7.5 MPa), ``pu`` hose
    (d 6 mm, 11 g, E 100 MPa) and ``pa12`` hose (d 6 mm, 9 g, E 1 GPa), all 0.5 m long. The
    moduli of USB and Ethernet are those the thesis identified with its own bending model;
    Poisson ratios are not given in the thesis and are typical values for the materials. The
    composite cables (USB, Ethernet) stretch with their copper's axial modulus
    (:data:`COMPOSITE_AXIAL_MODULI`) unless ``axial_modulus`` is given (None: the thesis' one
    modulus for bending and stretching, E_a = E); the hoses with their E.

    Parameters
    ----------
    name : str
        One of :data:`CATALOGUE_NAMES` (case-insensitive).
    n_links : int
        Discretization.
    **overrides
        Any other :class:`Cable` field (``bending``, ``length``, ...).
    """
    key = str(name).strip().lower()
    if key not in _CATALOGUE:
        raise ValueError(
            f"cable: unknown catalogue name {name!r}, expected one of {', '.join(_CATALOGUE)}"
        )
    axial = {"axial_modulus": COMPOSITE_AXIAL_MODULI[key]} if key in COMPOSITE_AXIAL_MODULI else {}
    params = {**_CATALOGUE[key], **axial, "n_links": n_links, "name": key, **overrides}
    return Cable(**params)
