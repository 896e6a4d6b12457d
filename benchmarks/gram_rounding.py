"""The rounding of the certificate's Gram matrices: the residuals R = M − N̂Z formed in float64 or in extended
precision, against the floor the bound adds (aromm.reduction.certificate.riesz, error_bound).

On the 12³ two-phase body of tests/test_certificate.py (box centre k_F = 0.5 W/(m K), c_F = 5e6 J/(m³ K), a random
10-column basis, rtol 1e-10) the Gram matrices ``MᵀZ + RᵀZ`` of every rung of the σ ladder are formed from multigrid
solves and from direct (CHOLMOD) solves, each with R in float64 and in ``np.longdouble`` (the scipy engine's way).
Printed per rung: the largest difference between the multigrid and the direct Gram matrices, in units of the
entries' scale √(G_ii G_jj); that difference over the quadratic forms' floor (8 m ε) alone and over the whole floor
with the residuals' rounding (2 ε ρ_i ρ_j per computation, ρ² = (k + 1)(u/ε)|Z|ᵀ|N̂||Z|); and max ρ / √G_ii with
u = ε (the float64 worst case, whose square over k + 1 is the ratio |Z|ᵀ|N̂||Z| / ZᵀN̂Z).

    python benchmarks/gram_rounding.py
"""

from __future__ import annotations

import numpy as np

from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.reduction.certificate import ladder
from aromm.reduction.lifting import lift
from aromm.reduction.scipy_engine import ScipyEngine

REFERENCE = {"fibre.k": 0.5, "fibre.c": 5e6}
EPS = float(np.finfo(float).eps)


def grams(solver: str, extended: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sigmas, Gram matrices, ρ) with R formed in extended precision or in float64."""
    labels = (np.random.default_rng(2).random((12,) * 3) < 0.4).astype(int)
    phases = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6)]
    faces = [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)]
    system = lift(assemble_voxels(labels, (5e-6,) * 3, phases, faces, time=TimeGrid(60.0, 0.1),
                                  outputs=["z0", "z1"], matrix_free=solver == "mg"), {}, "splu")
    engine = ScipyEngine(system, solver)
    basis, _ = engine.orthonormalise(None, np.random.default_rng(0).standard_normal((system.n, 10)), REFERENCE, 1e-10)
    m = engine.join([engine.input_terms(), engine.output_block(), engine.term_products(basis)])
    assert system.time is not None
    sigmas = ladder(system.time.end, system.time.dt)
    out, spread = [], []
    for sigma in sigmas:
        z = engine.shifted_solve(REFERENCE, float(sigma), m, 1e-10)
        if extended:
            r = engine.shifted_residual(REFERENCE, float(sigma), z, m, 1e-10)
            rho = engine.residual_rounding(REFERENCE, float(sigma), z, 1e-10)
        else:
            v = system.values(REFERENCE)
            a = (system.conductance.evaluate(v) + float(sigma) * system.capacity.evaluate(v)).tocsr()
            r = m - a @ z
            terms = int(np.diff(a.indptr).max()) + 1
            rho = np.sqrt(terms * np.einsum("ij,ij->j", abs(z), abs(a) @ abs(z)))
        g = m.T @ z + r.T @ z
        out.append((g + g.T) / 2)
        spread.append(rho)
    return sigmas, np.stack(out), np.stack(spread)


def main() -> None:
    print("R formed in   sigma (1/s)   gap / scale   gap / 8mε floor   gap / whole floor   max ρ/√G_ii")
    for extended in (False, True):
        sigmas, mg, rho_mg = grams("mg", extended)
        _, direct, rho_direct = grams("cholmod", extended)
        m = mg.shape[1]
        for j, sigma in enumerate(sigmas):
            scale = np.sqrt(np.diagonal(direct[j]))
            gap = np.abs(mg[j] - direct[j])
            forms = 8 * m * EPS * np.outer(scale, scale)
            whole = forms + 2 * EPS * (np.outer(rho_mg[j], rho_mg[j]) + np.outer(rho_direct[j], rho_direct[j]))
            kind = "longdouble" if extended else "float64"
            print(f"{kind:12s} {sigma:11.4g} {(gap / np.outer(scale, scale)).max():13.2g} {(gap / forms).max():17.3g}"
                  f" {(gap / whole).max():19.3g} {(rho_direct[j] / scale).max():13.4g}")


if __name__ == "__main__":
    main()
