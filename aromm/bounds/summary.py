"""Every model and bound of [GarnierDanes] for one material, keyed as in docs/design.md (``aromm bounds``).

W1a and W1b need finite-element values of two sub-cells (E_II, E_1bot), computed on demand on a
coarse conforming mesh (:mod:`aromm.bounds.cell_fem`, a few seconds).  On-demand rather than
a shipped table: E_II and E_1bot depend on three parameters (B, C, D) and E_1bot has a
logarithmic contact singularity at high contrast, so an interpolated table would need a dense
3-D grid whose accuracy could not be stated more simply than the mesh size; the accuracy at a
given ``mesh_size`` is measured in benchmarks/bounds_fem.py.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from aromm.bounds import models as m
from aromm.bounds import wall as w
from aromm.bounds.cell_fem import CellModel
from aromm.bounds.domain import PHI_MAX_SC, cell_B, check_B, check_contact, check_kappa, check_phi, checked

MODEL_KEYS = ("maxwell_eucken", "hasselman_johnson", "hashin_shtrikman_lower", "hashin_shtrikman_upper",
              "wiener_parallel", "wiener_series", "torquato_rintoul_lower", "torquato_rintoul_upper",
              "wall_1a", "wall_inf_a", "wall_1b", "wall_inf_b", "lewis_nielsen", "hatta_taya")

ROLE = {"maxwell_eucken": "estimate", "hasselman_johnson": "estimate", "lewis_nielsen": "estimate",
        "hatta_taya": "estimate", "hashin_shtrikman_lower": "lower (C = 0)",
        "hashin_shtrikman_upper": "upper (C = 0)", "wiener_parallel": "upper (C = 0)",
        "wiener_series": "lower (C = 0)", "torquato_rintoul_lower": "lower", "torquato_rintoul_upper": "upper",
        "wall_1a": "lower, SC cell (FE)", "wall_inf_a": "lower, SC cell", "wall_1b": "upper, SC cell (FE)",
        "wall_inf_b": "upper, SC cell"}


@dataclass(frozen=True)
class Material:
    """Inputs of :func:`every_model`: phi, kappa = lambda_f/lambda_m, C, the cell's B and xi (resolved)."""

    phi: float
    kappa: float
    contact: float
    B: float
    xi: float

    @property
    def D(self) -> float:
        return 1.0 / self.kappa


def material(phi: float, kappa: float, contact: float = 0.0, B: float | None = None,
             xi: float | None = None) -> Material:
    """Check the inputs; B defaults to the simple-cubic cell of volume fraction phi, xi to zeta2(SC)."""
    p = float(check_phi(phi, PHI_MAX_SC))
    k = float(check_kappa(kappa))
    c = float(check_contact(contact))
    b = float(cell_B(p)) if B is None else float(check_B(B))
    x = float(m.zeta2_simple_cubic(p)) if xi is None else float(checked("xi (microstructure parameter)", xi,
                                                                            0.0, 1.0))
    return Material(p, k, c, b, x)


def every_model(mat: Material, mesh_size: float = 0.3,
                progress: Callable[[str], None] | None = None) -> dict[str, float | None]:
    """All 14 values ``E = lambda_eff/lambda_m``; ``wall_1a``/``wall_1b`` are None when B = 0 (no cell mesh)."""
    p, k, c, d = mat.phi, mat.kappa, mat.contact, mat.D
    out: dict[str, float | None] = {
        "maxwell_eucken": float(m.maxwell_eucken(p, k)),
        "hasselman_johnson": float(m.hasselman_johnson(p, k, c)),
        "hashin_shtrikman_lower": float(m.hashin_shtrikman_lower(p, k)),
        "hashin_shtrikman_upper": float(m.hashin_shtrikman_upper(p, k)),
        "wiener_parallel": float(m.wiener_parallel(p, k)),
        "wiener_series": float(m.wiener_series(p, k)),
        "torquato_rintoul_lower": float(m.torquato_rintoul_lower(p, k, c, mat.xi)),
        "torquato_rintoul_upper": float(m.torquato_rintoul_upper(p, k, c, mat.xi)),
        "wall_inf_a": float(w.wall_inf_a(mat.B, c, d)),
        "wall_inf_b": float(w.wall_inf_b(mat.B, c, d)),
        "lewis_nielsen": float(m.lewis_nielsen(p, k)),
        "hatta_taya": float(m.hatta_taya(p, k)),
        "wall_1a": None,
        "wall_1b": None,
    }
    if mat.B > 0.0:
        if progress is not None:
            progress("E_II (cylinder)")
        out["wall_1a"] = float(w.wall_1a(mat.B, CellModel("cylinder", mat.B, mesh_size).E(c, d)))
        if progress is not None:
            progress("E_1bot (slab)")
        out["wall_1b"] = float(w.wall_1b(mat.B, CellModel("slab", mat.B, mesh_size).E(c, d)))
    return {key: out[key] for key in MODEL_KEYS}

