"""Conforming-mesh FE of the cell of [GarnierDanes]: mesh size vs error vs seconds, and the convergence rate.

Reference for E_c: Rayleigh's series for the simple-cubic array with the SC lattice coefficients
(effective_formulas.md §7; relative error < 2e-6 at phi = 4 pi/81 = 0.155, with or without contact
resistance). E_II and E_1bot have no closed form: their observed order comes from three
successive meshes. The neutral inclusion (D + C = 1) must give exactly 1 in the continuum; its
discrete defect is printed too.

Run: ``python benchmarks/bounds_fem.py`` (a few minutes; ``AROMM_SIZE=large`` adds finer meshes).
Both element orders are measured on the same gmsh meshes: P1 and P2 (the default of
aromm.bounds.cell_fem).  h is the element size in units of the sphere radius (graded to h/4
on the sphere); N is the number of unknowns of the split (contact-resistance) system; rates
are measured against h (the meshes are scaled copies of each other).
"""

from __future__ import annotations

import os
import time

import numpy as np

from aromm.bounds.cell_fem import CellModel
from aromm.bounds.models import rayleigh_simple_cubic

B, KAPPA = 0.5, 10.0
PHI = np.pi / (6 * (1 + B) ** 3)
LARGE = os.environ.get("AROMM_SIZE") == "large"
SIZES = {1: [0.4, 0.3, 0.2, 0.14, 0.1] + ([0.07, 0.05] if LARGE else []),
         2: [0.45, 0.3, 0.2, 0.14] + ([0.1] if LARGE else [])}


def rate(e: list[float], h: list[float]) -> list[float]:
    return [float(np.log(e[i] / e[i + 1]) / np.log(h[i] / h[i + 1])) for i in range(len(e) - 1)]


def main() -> None:
    exact = {c: rayleigh_simple_cubic(PHI, KAPPA, c) for c in (0.0, 0.1)}
    print(f"E_c of the simple-cubic cell, phi = {PHI:.5f} (B = {B}), kappa = {KAPPA:g}; "
          f"exact (Rayleigh/SC): C=0 {exact[0.0]:.7f}, C=0.1 {exact[0.1]:.7f}")
    for order, sizes in SIZES.items():
        print(f"\nP{order} elements")
        print(f"{'h/a':>6} {'N':>7} {'E_c(C=0)':>10} {'rel.err':>10} {'E_c(C=.1)':>10} {'rel.err':>10} "
              f"{'E_neutral-1':>12} {'E_II':>9} {'E_1bot':>9} {'mesh+asm s':>10} {'solve s':>8}")
        err0: list[float] = []
        err1: list[float] = []
        sub: list[tuple[float, float]] = []
        for h in sizes:
            t0 = time.perf_counter()
            cell = CellModel("cell", B, h, order)
            cell.system(True)
            cell.system(False)
            t_mesh = time.perf_counter() - t0
            t0 = time.perf_counter()
            e0, e1, neutral = cell.E(0.0, 1 / KAPPA), cell.E(0.1, 1 / KAPPA), cell.E(0.5, 0.5)
            t_solve = (time.perf_counter() - t0) / 3
            e_ii = CellModel("cylinder", B, h, order).E(0.1, 1 / KAPPA)
            e_bot = CellModel("slab", B, h, order).E(0.1, 1 / KAPPA)
            err0.append(e0 / exact[0.0] - 1)
            err1.append(e1 / exact[0.1] - 1)
            sub.append((e_ii, e_bot))
            print(f"{h:6.2f} {cell.n_unknowns:7d} {e0:10.6f} {err0[-1]:+10.2e} {e1:10.6f} {err1[-1]:+10.2e} "
                  f"{neutral - 1:+12.2e} {e_ii:9.6f} {e_bot:9.6f} {t_mesh:10.2f} {t_solve:8.3f}", flush=True)
        a0, a1 = np.abs(err0), np.abs(err1)
        print("  observed rate of |E_c error| vs h, successive meshes:")
        print("    C = 0  :", " ".join(f"{r:5.2f}" for r in rate(list(a0), sizes)))
        print("    C = 0.1:", " ".join(f"{r:5.2f}" for r in rate(list(a1), sizes)))
        for name, errs in (("C = 0", a0), ("C = 0.1", a1)):
            k = min(3, len(errs))
            fit = np.polyfit(np.log(sizes[-k:]), np.log(errs[-k:]), 1)[0]
            print(f"    least-squares rate over the {k} finest meshes ({name}): {fit:.2f}")
        for j, name in enumerate(("E_II", "E_1bot")):
            v = [s_[j] for s_ in sub]
            orders = [float(np.log(abs(v[i] - v[i + 1]) / abs(v[i + 1] - v[i + 2]))
                            / np.log(sizes[i + 1] / sizes[i + 2])) for i in range(len(v) - 2)]
            print(f"    observed order of {name} (C = 0.1) from successive differences:",
                  " ".join(f"{o:5.2f}" for o in orders))


if __name__ == "__main__":
    main()
