"""Agreement of the petsc engine at P ranks and 1 rank with ARPACK and the serial engine (the cases of
tests/test_petsc_engine.py, printed as numbers with seconds); P = 4 is cut in 2×2×1 boxes, P = 2 in z-slabs.

Prints: the largest relative difference of the Dirichlet and Steklov eigenvalues from ARPACK (scipy's eigsh,
shift-invert) for the MUMPS and the CG + GAMG inner solvers; the largest difference (°C) of the face means of the
reduced model (with and without correction modes), of the transient and steady full models, and the relative
difference of the homogenised k, from the serial (scipy) engine; then the P-rank results against the 1-rank
ones; wall seconds of each run and the load average.

Usage: python benchmarks/petsc_agreement.py [--ranks 4]   (needs petsc4py/slepc4py/mpi4py and mpiexec;
--ranks 1 skips the mpiexec run)
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import petsc_cases  # noqa: E402
import test_petsc_engine as cases  # noqa: E402

from aromm.engines.petsc import runtime  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--ranks", type=int, choices=(1, 2, 4), default=4,
                        help="ranks of the mpiexec run (4: 2×2×1 boxes, 2: z-slabs, 1: none)")
    args = parser.parse_args()
    load = os.getloadavg()[0]
    two: dict[str, np.ndarray] = {}
    two_s = 0.0
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "two.npz"
        start = time.perf_counter()
        if args.ranks > 1:
            run = cases.mpiexec(sys.executable, str(ROOT / "tests" / "petsc_worker.py"), str(out), ranks=args.ranks,
                                options=petsc_cases.BOXES_2x2x1 if args.ranks == 4 else "")
            if run.returncode != 0:
                raise SystemExit(run.stderr[-3000:])
            two_s = time.perf_counter() - start
            with np.load(out) as data:
                two = {k: data[k] for k in data.files}
    start = time.perf_counter()
    one = petsc_cases.results(runtime.world())
    one_s = time.perf_counter() - start
    start = time.perf_counter()
    reference = petsc_cases.arpack()
    serial = petsc_cases.serial()
    serial_s = time.perf_counter() - start
    many = f"{args.ranks} ranks"
    print(f"load average {load:.1f} → {os.getloadavg()[0]:.1f} (2 cores, shared); wall s: {many} {two_s:.0f} "
          f"(incl. start-up), 1 rank {one_s:.0f}, serial + ARPACK {serial_s:.0f}")
    if two:
        print(f"process grid: {tuple(int(g) for g in two['grid'])}; box rows vs the DMDA's AO: "
              f"{int(two['numbering_error'])} (largest difference)")
    print(f"{'quantity':<44} {many:>10} {'1 rank':>10}")
    runs = (two, one) if two else (one,)
    for family in ("dirichlet", "steklov"):
        for solver in ("mumps", "gamg"):
            ref = reference[family]
            rows = [np.max(np.abs(r[f"{family}_{solver}"] / ref - 1)) for r in runs]
            print(f"{family} eigenvalues vs ARPACK, {solver} (rel.)".ljust(44 + 11 * (len(runs) == 1))
                  + "".join(f"{v:>10.1e}" for v in rows))
    for key, label in (("rom_corrections_True", "reduced model face means, corrections (°C)"),
                       ("rom_corrections_False", "reduced model face means, no corrections (°C)"),
                       ("transient", "full transient face means (°C)"), ("steady", "full steady face means (°C)")):
        rows = [np.max(np.abs(r[key] - serial[key])) for r in runs]
        print(label.ljust(44 + 11 * (len(runs) == 1)) + "".join(f"{v:>10.1e}" for v in rows))
    for b in ("flux", "temperature"):
        rows = [np.max(np.abs(np.diag(r[f"k_{b}"]) / np.diag(serial[f"k_{b}"]) - 1)) for r in runs]
        print(f"homogenised k ({b}) vs serial (rel.)".ljust(44 + 11 * (len(runs) == 1))
              + "".join(f"{v:>10.1e}" for v in rows))
    if two:
        print(f"{many} against 1 rank (largest difference; relative for eigenvalues and k):")
        for key in one:
            if key not in ("grid", "numbering_error"):
                diff = np.max(np.abs(np.asarray(two[key]) - np.asarray(one[key])))
                scale = np.max(np.abs(one[key])) if key.startswith(("dirichlet", "steklov", "k_")) else 1.0
                print(f"  {key:<40} {diff / scale:>10.1e}")


if __name__ == "__main__":
    main()
