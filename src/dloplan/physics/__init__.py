"""Pure, vectorized energy, force and Hessian kernels of the mass-spring cable model."""

from ..geometry import (
    arc_length,
    as_shape,
    bending_angles,
    link_lengths,
    link_vectors,
    resample_by_arc_length,
    shape_length,
    tangents,
)
from .chain import (
    Forces,
    SpringChain,
    band_to_sparse,
    energy,
    energy_terms,
    forces,
    gradient,
    hessian,
    hessian_band,
    link_tensions,
)

__all__ = [
    "Forces",
    "SpringChain",
    "arc_length",
    "as_shape",
    "band_to_sparse",
    "bending_angles",
    "energy",
    "energy_terms",
    "forces",
    "gradient",
    "hessian",
    "hessian_band",
    "link_lengths",
    "link_tensions",
    "link_vectors",
    "resample_by_arc_length",
    "shape_length",
    "tangents",
]
