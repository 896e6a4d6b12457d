"""Conforming-mesh FE of the seed-002 cell: mesh size vs error vs seconds, and the convergence rate.

Reference for E_c: Rayleigh's series for the simple-cubic array with the SC lattice coefficients
(etc_formulas §7; relative error < 2e-6 at phi = 4 pi/81 = 0.155, with or without contact
resistance). E_II and E_1bot have no closed form: their observed order comes from three
successive meshes. The neutral inclusion (D + C = 1) must give exactly 1 in the continuum; its
discrete defect is printed too.

Run: ``python benchmarks/bounds_fem.py`` (about a minute; ``AROMM_SIZE=large`` adds h = 0.05).
h is the element size in units of the sphere radius (graded to h/4 on the sphere); N is the
number of unknowns of the split (contact-resistance) system; the rate is measured against
N^(-1/3), the mean element size.
"""

from __future__ import annotations

import os
import time

import numpy as np

from aromm.effective.cell_fem import CellModel
from aromm.effective.models import rayleigh_simple_cubic

B, KAPPA = 0.5, 10.0
PHI = np.pi / (6 * (1 + B) ** 3)
SIZES = [0.4, 0.3, 0.2, 0.14, 0.1, 0.07] + ([0.05] if os.environ.get("AROMM_SIZE") == "large" else [])


def rate(e: list[float], n: list[int]) -> list[float]:
    return [float(np.log(e[i] / e[i + 1]) / np.log((n[i + 1] / n[i]) ** (1 / 3))) for i in range(len(e) - 1)]


def main() -> None:
    exact = {c: rayleigh_simple_cubic(PHI, KAPPA, c) for c in (0.0, 0.1)}
    print(f"E_c of the simple-cubic cell, phi = {PHI:.5f} (B = {B}), kappa = {KAPPA:g}; "
          f"exact (Rayleigh/SC): C=0 {exact[0.0]:.7f}, C=0.1 {exact[0.1]:.7f}")
    print(f"{'h/a':>6} {'N':>7} {'E_c(C=0)':>10} {'rel.err':>9} {'E_c(C=.1)':>10} {'rel.err':>9} "
          f"{'|E_neutral-1|':>13} {'E_II':>9} {'E_1bot':>9} {'mesh s':>7} {'solve s':>8}")
    n_list: list[int] = []
    err0: list[float] = []
    err1: list[float] = []
    sub: list[tuple[float, float]] = []
    for h in SIZES:
        t0 = time.perf_counter()
        cell = CellModel("cell", B, h)
        cell.system(True)
        cell.system(False)
        t_mesh = time.perf_counter() - t0
        t0 = time.perf_counter()
        e0, e1, neutral = cell.E(0.0, 1 / KAPPA), cell.E(0.1, 1 / KAPPA), cell.E(0.5, 0.5)
        t_solve = (time.perf_counter() - t0) / 3
        e_ii = CellModel("cylinder", B, h).E(0.1, 1 / KAPPA)
        e_bot = CellModel("slab", B, h).E(0.1, 1 / KAPPA)
        n_list.append(cell.n_unknowns)
        err0.append(abs(e0 / exact[0.0] - 1))
        err1.append(abs(e1 / exact[0.1] - 1))
        sub.append((e_ii, e_bot))
        print(f"{h:6.2f} {cell.n_unknowns:7d} {e0:10.6f} {err0[-1]:9.2e} {e1:10.6f} {err1[-1]:9.2e} "
              f"{abs(neutral - 1):13.2e} {e_ii:9.6f} {e_bot:9.6f} {t_mesh:7.2f} {t_solve:8.3f}", flush=True)
    print("\nobserved rate of E_c error vs N^(-1/3), successive meshes:")
    print("  C = 0  :", " ".join(f"{r:5.2f}" for r in rate(err0, n_list)))
    print("  C = 0.1:", " ".join(f"{r:5.2f}" for r in rate(err1, n_list)))
    for name, errs in (("C = 0", err0), ("C = 0.1", err1)):
        k = min(3, len(errs))
        fit = np.polyfit(np.log(np.asarray(n_list[-k:], float) ** (-1 / 3)), np.log(errs[-k:]), 1)[0]
        print(f"  least-squares rate over the {k} finest meshes ({name}): {fit:.2f}")
    for j, name in enumerate(("E_II", "E_1bot")):
        v = [s[j] for s in sub]
        orders = [float(np.log(abs(v[i] - v[i + 1]) / abs(v[i + 1] - v[i + 2]))
                        / np.log((n_list[i + 1] / n_list[i]) ** (1 / 3))) for i in range(len(v) - 2)]
        print(f"  observed order of {name} (C = 0.1) from successive differences:",
              " ".join(f"{o:5.2f}" for o in orders))


if __name__ == "__main__":
    main()
