"""Choosing the identification experiment: candidate designs scored by the predicted sd of E.

For a cable with an expected modulus (e.g. the catalogue's) and a measurement noise, every
candidate manipulation (:func:`candidate_designs`: cantilevers, the dual-arm bend of thesis
Fig. 6.3 at several tilts, a dual-arm sag, a hanging loop) is simulated once and scored by the
standard error of ln E a measurement of ``n_measured`` points along its final shape would give,
the Gauss-Newton prediction of :mod:`dloplan.identify.fit`:

    sd(ln E) = noise / |d r / d ln E|      (r: distances of the points to the model's curve)

Two more checks per design:

* **links needed**: the discretization the final shape's curvature requires
  (:func:`~dloplan.identify.fit.links_for_curvature`); the design is simulated with it, so
  a soft cable's tight bend near a clip is resolved and costs what it costs;
* **robust** (checked for informative designs): the manipulation, simulated quasi-statically at
  E / 2 and 2 E, ends on the branch continued from the shape at E (within 1 % of L); a design
  whose outcome snaps to another branch nearby makes the cost jump (thesis Fig. 6.8's irregular
  curves).

The recommendation is the robust, informative design (sd <= 0.1) of smallest sd.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..cable import Cable
from ..geometry import resample_by_arc_length
from .design import (
    bending_manipulation,
    cantilever_manipulation,
    hanging_loop_manipulation,
    simulate_design,
)
from .distance import curve_residuals
from .experiment import Manipulation, initial_on
from .fit import MAX_LINKS, MAX_LOG_SD, links_for_curvature
from .measured import measured_curve
from .simulate import final_equilibrium, run_manipulation

BEND_ANGLES = (0.0, 30.0, 60.0, 90.0)
"""Tilts [deg] of the dual-arm bend candidates (90: thesis Fig. 6.3)."""


def candidate_designs(cable: Cable) -> dict[str, Manipulation]:
    """The default candidate experiments for ``cable``, by name.

    Cantilevers (horizontal, tilted up 45 deg), the dual-arm bend (clips brought to 0.3 L and
    tilted up by each of :data:`BEND_ANGLES`; 90 deg is the thesis' design), a dual-arm sag
    (clips 0.8 L apart, level) and a hanging loop (clips 0.1 L apart, pointing down).
    """
    designs = {
        "cantilever": cantilever_manipulation(cable),
        "cantilever tilted 45 deg": cantilever_manipulation(cable, angle=45.0),
    }
    for angle in BEND_ANGLES:
        designs[f"dual-arm bend {angle:g} deg"] = bending_manipulation(
            cable, clip_distance=0.3 * cable.length, angle=angle)
    designs["dual-arm sag"] = bending_manipulation(cable, clip_distance=0.8 * cable.length,
                                                   angle=0.0)
    designs["hanging loop"] = hanging_loop_manipulation(cable)
    return designs


@dataclass(frozen=True, eq=False)
class DesignScore:
    """How well one design would identify E.

    Attributes
    ----------
    name : str
        The design's name.
    manipulation : Manipulation
        The design.
    log_sd : float
        Predicted sd(ln E) [-] (inf when the simulation fails).
    n_links : int
        Links the final shape's curvature needs (the design was simulated with them).
    robust : bool
        The outcome stays on its branch between E / 2 and 2 E.
    message : str
        The verdict in words.
    simulated : bool
        The design's simulation converged (False: ``log_sd`` is inf for that reason, not for
        a flat outcome).
    """

    name: str
    manipulation: Manipulation
    log_sd: float
    n_links: int
    robust: bool
    message: str
    simulated: bool = True

    @property
    def informative(self) -> bool:
        """sd(ln E) <= MAX_LOG_SD."""
        return self.log_sd <= MAX_LOG_SD

    @property
    def usable(self) -> bool:
        """Informative and robust."""
        return self.informative and self.robust


def score_design(cable: Cable, name: str, manipulation: Manipulation, *, noise: float = 1e-3,
                 n_measured: int = 100) -> DesignScore:
    """Score one design at the cable's modulus (module docstring).

    Parameters
    ----------
    cable : Cable
        The cable with the expected modulus and a starting discretization.
    name : str
        A label.
    manipulation : Manipulation
        The design (its clip poses are kept at any n).
    noise : float
        Measurement noise per coordinate [m].
    n_measured : int
        Points the measurement will have along the cable.
    """
    try:
        run = simulate_design(cable, manipulation)
        needed = links_for_curvature(cable, measured_curve(run.final, 1e-5))
        n = min(max(needed, cable.n_links), MAX_LINKS)
        if n != cable.n_links:
            cable = cable.with_links(n)
            run = simulate_design(cable, manipulation)
    except ValueError as exc:
        return DesignScore(name, manipulation, math.inf, cable.n_links, False,
                           f"{name}: cannot be simulated ({exc})", simulated=False)
    points = resample_by_arc_length(run.final, n_measured)
    fit = curve_residuals(points, run.final, run.sensitivity)
    size = math.sqrt(0.5 * fit.curvature)
    log_sd = noise / size if size > 0 else math.inf
    gaps = []
    for factor in (0.5, 2.0) if log_sd <= MAX_LOG_SD else ():  # a flat design fails anyway
        other = cable.with_modulus(cable.youngs_modulus * factor)
        path = run_manipulation(other, manipulation, initial_on(cable, manipulation)).final
        branch = final_equilibrium(other, manipulation, run.final).final
        gaps.append(float(np.max(np.linalg.norm(path - branch, axis=1))))
    robust = max(gaps, default=0.0) <= 0.01 * cable.length
    words = ["informative" if log_sd <= MAX_LOG_SD else "not informative"]
    if not robust:
        words.append(f"snaps to another branch within a factor 2 of E ({1e3 * max(gaps):.0f} mm)")
    return DesignScore(name, manipulation, float(log_sd), n, bool(robust),
                       f"{name}: sd(ln E) ~ {log_sd:.3g} with {n_measured} points of "
                       f"{1e3 * noise:g} mm noise, n = {n}; {', '.join(words)}")


@dataclass(frozen=True, eq=False)
class DesignReport:
    """Scores of the candidate designs, best first, and the recommendation.

    Attributes
    ----------
    scores : tuple of DesignScore
        Sorted: usable designs first, then by sd(ln E).
    recommended : DesignScore or None
        The first usable design (None when none is).
    youngs_modulus : float
        The expected E the designs were scored at [Pa].
    """

    scores: tuple[DesignScore, ...]
    recommended: DesignScore | None
    youngs_modulus: float

    def to_dict(self) -> dict:
        """JSON-able form: every score (best first) and the recommended design's name."""
        return {"scores": [{"design": s.name, "log_sd": s.log_sd, "n_links": s.n_links,
                            "robust": s.robust, "informative": s.informative,
                            "usable": s.usable, "simulated": s.simulated, "message": s.message}
                           for s in self.scores],
                "recommended": None if self.recommended is None else self.recommended.name}

    def lines(self) -> list[str]:
        """A table and the recommendation, for printing."""
        out = [f"{'design':28}{'sd(ln E)':>10}{'n':>6}  robust  verdict"]
        for s in self.scores:
            verdict = ("ok" if s.usable else "fails" if not s.simulated
                       else "flat" if not s.informative else "snaps")
            out.append(f"{s.name:28}{s.log_sd:10.3g}{s.n_links:6d}  {'yes' if s.robust else 'no':6}"
                       f"  {verdict}")
        failed = [s for s in self.scores if not s.simulated]
        unsimulated = (f"{len(failed)} of {len(self.scores)} designs cannot be simulated at "
                       f"E = {self.youngs_modulus:.3g} Pa (first: {failed[0].message})"
                       if failed else "")
        if self.recommended is None:
            out.append("no candidate identifies E to 10 %: " + (
                unsimulated if len(failed) == len(self.scores) else
                "; ".join(filter(None, ["lower the noise or measure more points",
                                        unsimulated]))))
        else:
            out.append(f"recommended: {self.recommended.name} (sd(ln E) ~ "
                       f"{self.recommended.log_sd:.2g}, identify with n = "
                       f"{self.recommended.n_links})")
        return out


def recommend_design(cable: Cable, *, noise: float = 1e-3, n_measured: int = 100,
                     candidates: dict[str, Manipulation] | None = None) -> DesignReport:
    """Score candidate designs (default :func:`candidate_designs`) and recommend one.

    Parameters
    ----------
    cable : Cable
        The cable with its expected modulus.
    noise : float
        Measurement noise per coordinate [m], > 0.
    n_measured : int
        Points the measurement will have, >= 2.
    candidates : dict, optional
        Designs by name.
    """
    if not (math.isfinite(noise) and noise > 0):
        raise ValueError(f"noise: got {noise!r}, expected a distance > 0 [m]")
    if int(n_measured) != n_measured or n_measured < 2:
        raise ValueError(f"n_measured: got {n_measured!r}, expected an integer >= 2")
    designs = candidate_designs(cable) if candidates is None else candidates
    scores = [score_design(cable, name, m, noise=noise, n_measured=int(n_measured))
              for name, m in designs.items()]
    scores.sort(key=lambda s: (not s.usable, s.log_sd))
    best = scores[0] if scores and scores[0].usable else None
    return DesignReport(tuple(scores), best, cable.youngs_modulus)
