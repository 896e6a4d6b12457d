"""The shifted solves of a coupled heat–moisture Krylov build: CHOLMOD against smoothed-aggregation AMG + CG.

The coupled scene of benchmarks/hygrothermal_cost.py (the shipped 46³ wood VER with a `[moisture]` section), in Q1 or
finite volumes; ``A = K(μ) + s C(μ)`` at the box centre (fibre.k 0.316 W/(m K), fibre.c 3.16e6 J/(m³ K)) for each
shift of ``--shifts``; the right-hand sides of one (point, shift) of the reductor: the inputs and outputs block B
(its first ``--columns``), then C X (the second Krylov step), each solved to the relative residual ``--rtol`` and
checked by :func:`aromm.linalg.direct.check_residual`, as the scipy engine checks every solve.

* ``cholmod``: the engine's factorisation (the nested-dissection ordering of the nodes' points);
* ``amg-gs``, ``amg-cheb``: a prototype of conjugate gradients preconditioned by smoothed aggregation
  [VanekMandelBrezina1996] for the coupled system: the hierarchy of the symmetrically diagonal-scaled operator
  ``Â = D^-1/2 A D^-1/2`` (D = diag A; the petsc engine's form, aromm.engines.petsc.linear.scale_symmetrically), the
  unknowns interleaved (T, φ) node by node as a BSR matrix of 2 × 2 blocks, near-null space the two constant fields
  times D^1/2; its V-cycle pyamg's (symmetric block Gauss–Seidel, ``amg-gs``) or
  :class:`aromm.linalg.block_multigrid.BlockMultigrid`'s (Chebyshev of degree ``--degree``, ``amg-cheb``).  CG
  (:func:`aromm.linalg.multigrid.pcg.pcg`) on Â from zero, stopped when the scaled residual
  ``‖D^-1/2 (b − A x)‖ ≤ rtol ‖D^-1/2 b‖`` (the petsc engine's test) and the true one ``‖b − A x‖ ≤ rtol ‖b‖``
  are both met (the true one alone left a small fv scene's temperature at s = 1000 1/s 1.2e-3 of its scale
  from the direct solve: its residual is the λ-weighted moisture rows').

Prints set-up and per-column CPU seconds (process_time) and wall seconds, CG iterations, the memory after assembly
and the peak (ru_maxrss), the worst relative residuals (true and scaled) and the load; one fresh process per case.
``--build q1``: instead the whole coupled Krylov build of benchmarks/hygrothermal_cost.py with the shifted solves by
``amg-cheb`` from the reductor's Galerkin guesses (the scipy engine subclassed here; the library does not offer it).

    python benchmarks/coupled_solvers.py --discretisations q1 fv --shifts 0.0167 0.74 30
    python benchmarks/coupled_solvers.py --build q1
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parent))


def block_amg(a: sp.csr_array, solver: str, rtol: float, degree: int, iterations: list[int]) -> Any:
    """``b ↦ A⁻¹ b`` (n × m) by the prototype of the module docstring; CG counts appended to ``iterations``."""
    import pyamg  # type: ignore[import-untyped]

    from aromm.core.errors import NumericalError
    from aromm.linalg.block_multigrid import BlockMultigrid
    from aromm.linalg.multigrid.pcg import pcg

    n = a.shape[0]
    order = np.arange(n).reshape(2, n // 2).T.ravel()  # interleaved position → field-major index
    scale = 1.0 / np.sqrt(a.diagonal()[order])
    s = sp.diags_array(scale)
    scaled = sp.csr_array(s @ a[order][:, order] @ s)
    near_null = np.zeros((n, 2))
    near_null[0::2, 0], near_null[1::2, 1] = 1.0 / scale[0::2], 1.0 / scale[1::2]
    if solver == "amg-gs":
        cycle = pyamg.smoothed_aggregation_solver(sp.bsr_matrix(scaled, blocksize=(2, 2)), B=near_null,
                                                  symmetry="symmetric", smooth=("jacobi", {"weighting": "local"})
                                                  ).aspreconditioner(cycle="V")
    else:
        cycle = BlockMultigrid(scaled, degree=degree, rng=np.random.default_rng(0), near_null=near_null, blocksize=2)

    def precondition(r: np.ndarray, out: np.ndarray) -> np.ndarray:
        out[...] = cycle @ r if solver == "amg-gs" else cycle(r)
        return out

    def one(b: np.ndarray, guess: np.ndarray | None) -> np.ndarray:
        yb = scale * b[order]
        y = np.zeros(n) if guess is None else guess[order] / scale
        r, total = yb - scaled @ y, 0
        work = [np.empty(n) for _ in range(3)]
        while True:
            scaled_res = float(np.linalg.norm(r) / np.linalg.norm(yb))
            true_res = float(np.linalg.norm(r / scale) / np.linalg.norm(b))
            if scaled_res <= rtol and true_res <= rtol:
                break
            if total >= 2000:
                raise NumericalError(f"{solver}: residuals {scaled_res:.1e} / {true_res:.1e} after {total} iterations")
            target = float(np.linalg.norm(r)) * rtol / max(true_res, scaled_res, rtol)
            y, r, its = pcg(scaled, precondition, y, r, target=target, budget=2000 - total, work=work)
            total += its
            r = yb - scaled @ y
        iterations.append(total)
        x = np.empty(n)
        x[order] = scale * y
        return x

    return lambda b, guess=None: np.column_stack([one(b[:, j], None if guess is None else guess[:, j])
                                                  for j in range(b.shape[1])])


def build(disc: str, degree: int) -> dict[str, object]:
    """:func:`hygrothermal_cost.worker`'s coupled build with the engine's shifted solves by the ``amg-cheb``
    prototype, from the reductor's Galerkin guesses (as the engine's multigrid solves); the engine's counts added."""
    import hygrothermal_cost

    import aromm.reduction.krylov_offline as offline
    from aromm.reduction.scipy_engine import ScipyEngine

    engines: list[ScipyEngine] = []

    class Prototype(ScipyEngine):
        uses_guess = True

        def _setup(self, values: Any, shift: float, rtol: float, method: str) -> Any:
            engines.append(self)
            return block_amg(self._operator(values, shift), "amg-cheb", rtol, degree, self._stats.iterations)

    offline.ScipyEngine = Prototype  # type: ignore[misc]
    out = hygrothermal_cost.worker(True, disc, False)
    stats = engines[-1].stats
    return {**out, "setups": stats.setups, "solves": stats.solves, "setup_cpu": stats.setup_seconds,
            "solve_cpu": stats.solve_seconds, "cg_mean": float(np.mean(stats.iterations)),
            "cg_max": max(stats.iterations)}


def worker(disc: str, solver: str, shift: float, *, rtol: float, columns: int, degree: int) -> dict[str, object]:
    from hygrothermal_cost import SCENE, scene_data

    from aromm.linalg.direct import check_residual, factorize
    from aromm.reduction.scipy_engine import ScipyEngine
    from aromm.scene.scene_file import assemble, scene_from_dict

    system = assemble(scene_from_dict(scene_data(True, disc), SCENE))
    engine = ScipyEngine(system, "cholmod")
    mu = {"fibre.k": 0.316, "fibre.c": 3.16e6}
    b = np.hstack([engine.inputs(mu), engine.output_block()])
    width = b.shape[1]
    b = b[:, :columns] if columns else b
    a = engine._operator(mu, shift)
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    c0, w0 = time.process_time(), time.perf_counter()
    iterations: list[int] = []
    if solver == "cholmod":
        fac = factorize(a, "cholmod", rtol, ordering=engine._nested_dissection(a))
        solve = lambda rhs: fac.solve(rhs, check=False)  # noqa: E731
    else:
        solve = block_amg(a, solver, rtol, degree, iterations)
    c1, w1 = time.process_time(), time.perf_counter()
    x1 = solve(b)
    b2 = engine.capacity(mu, x1)
    x2 = solve(b2)
    c2, w2 = time.process_time(), time.perf_counter()
    pairs = [(rhs[:, j], x[:, j]) for rhs, x in ((b, x1), (b2, x2)) for j in range(rhs.shape[1])]
    for rhs, x in pairs:
        check_residual(a, x, rhs, rtol, solver)
    s = 1.0 / np.sqrt(a.diagonal())
    cols = len(pairs)
    return {"n": a.shape[0], "width": width, "columns": cols, "setup_cpu": c1 - c0, "setup_wall": w1 - w0,
            "column_cpu": (c2 - c1) / cols, "column_wall": (w2 - w1) / cols,
            "iterations": [min(iterations), max(iterations)] if iterations else [],
            "base_gb": base, "peak_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6,
            "residual": max(float(np.linalg.norm(rhs - a @ x) / np.linalg.norm(rhs)) for rhs, x in pairs),
            "scaled": max(float(np.linalg.norm(s * (rhs - a @ x)) / np.linalg.norm(s * rhs)) for rhs, x in pairs),
            "load": os.getloadavg()[0]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--discretisations", nargs="+", default=["q1", "fv"], choices=["q1", "fv"])
    parser.add_argument("--solvers", nargs="+", default=["cholmod", "amg-cheb"],
                        choices=["cholmod", "amg-gs", "amg-cheb"])
    parser.add_argument("--shifts", nargs="+", type=float, default=[0.74])
    parser.add_argument("--rtol", type=float, default=1e-10)
    parser.add_argument("--columns", type=int, default=0, help="first columns of B (0: all)")
    parser.add_argument("--degree", type=int, default=2, help="Chebyshev degree of amg-cheb")
    parser.add_argument("--build", choices=["q1", "fv"], help="the whole coupled Krylov build with amg-cheb instead")
    parser.add_argument("--worker", nargs=6, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.build:
        print(json.dumps(build(args.build, args.degree)))
        return
    if args.worker:
        disc, solver, shift, rtol, columns, degree = args.worker
        result = worker(disc, solver, float(shift), rtol=float(rtol), columns=int(columns), degree=int(degree))
        print(json.dumps(result))
        return
    print(f"{'disc':>4} {'solver':>8} {'shift':>7} {'unknowns':>8} {'cols':>4} {'setup CPU':>9} {'wall':>6} "
          f"{'col CPU':>7} {'wall':>6} {'its':>7} {'base GB':>7} {'peak GB':>7} {'residual':>8} {'scaled':>8} load")
    for disc in args.discretisations:
        for shift in args.shifts:
            for solver in args.solvers:
                out = subprocess.run([sys.executable, __file__, "--worker", disc, solver, str(shift), str(args.rtol),
                                      str(args.columns), str(args.degree)],
                                     check=True, capture_output=True, text=True).stdout
                r = json.loads(out.strip().splitlines()[-1])
                its = "-".join(str(i) for i in r["iterations"]) or "-"
                print(f"{disc:>4} {solver:>8} {shift:7.3g} {r['n']:8d} {r['columns']:4d} {r['setup_cpu']:9.2f} "
                      f"{r['setup_wall']:6.2f} {r['column_cpu']:7.3f} {r['column_wall']:6.3f} {its:>7} "
                      f"{r['base_gb']:7.2f} {r['peak_gb']:7.2f} {r['residual']:8.1e} {r['scaled']:8.1e} "
                      f"{r['load']:.1f}", flush=True)


if __name__ == "__main__":
    main()
