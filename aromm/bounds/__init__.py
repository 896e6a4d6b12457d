"""Effective conductivity of sphere composites with contact resistance: models and bounds of [GarnierDanes].

* :mod:`aromm.bounds.models`: closed-form models (Wiener, Hashin-Shtrikman, Maxwell-Eucken,
  Hasselman-Johnson, Hatta-Taya, Lewis-Nielsen, Rayleigh for the simple-cubic array) and the
  Torquato-Rintoul third-order bounds;
* :mod:`aromm.bounds.wall`: the Danes-Garnier wall-insertion bounds W1a, W_inf_a, W1b, W_inf_b;
* :mod:`aromm.fem.mesh`: a ThermalSystem from any conforming simplex mesh (meshio),
  phases from cell sets, contact resistance on split interface nodes;
* :mod:`aromm.bounds.cell_fem`: gmsh meshes of the simple-cubic cell of [GarnierDanes] and its FE values
  (E_c, E_II, E_1bot);
* :mod:`aromm.bounds.summary`: every model at once (``aromm bounds``);
* :mod:`aromm.studies.garnier_danes`: Table 1 and the preference map of [GarnierDanes].

Every value is ``E = lambda_eff / lambda_m``.
"""

from aromm.bounds.cell_fem import CellModel, cell_mesh, cell_values
from aromm.bounds.domain import cell_B, cell_phi
from aromm.bounds.models import (
    hashin_shtrikman_lower,
    hashin_shtrikman_upper,
    hasselman_johnson,
    hatta_taya,
    lewis_nielsen,
    maxwell_eucken,
    rayleigh_simple_cubic,
    torquato_rintoul_lower,
    torquato_rintoul_upper,
    wiener_parallel,
    wiener_series,
    zeta2_simple_cubic,
)
from aromm.bounds.summary import MODEL_KEYS, every_model, material
from aromm.bounds.wall import wall_1a, wall_1b, wall_inf_a, wall_inf_b
from aromm.fem.mesh import assemble_mesh

__all__ = [
    "MODEL_KEYS",
    "CellModel",
    "assemble_mesh",
    "cell_B",
    "cell_mesh",
    "cell_phi",
    "cell_values",
    "every_model",
    "hashin_shtrikman_lower",
    "hashin_shtrikman_upper",
    "hasselman_johnson",
    "hatta_taya",
    "lewis_nielsen",
    "material",
    "maxwell_eucken",
    "rayleigh_simple_cubic",
    "torquato_rintoul_lower",
    "torquato_rintoul_upper",
    "wall_1a",
    "wall_1b",
    "wall_inf_a",
    "wall_inf_b",
    "wiener_parallel",
    "wiener_series",
    "zeta2_simple_cubic",
]
