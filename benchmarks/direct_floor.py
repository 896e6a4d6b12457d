"""The residual a direct (CHOLMOD) solve leaves, against its float64 rounding floor ε ‖abs(A) abs(x)‖ / ‖b‖.

The figures behind aromm.linalg.factorizations.FLOOR_FACTOR: on voxel systems K + sC of random two-phase bodies
(gas 0.026 W/(m K), fibre.k from 30 to 1e5, the load of scenario 1), the relative residual of a CHOLMOD solve and
the floor, side by side, with their ratio; a fixed relative tolerance of 1e-10 refuses every row whose residual is
above it, the floor-judged check (rtol + FLOOR_FACTOR × floor) none.

    python benchmarks/direct_floor.py --sizes 12 16 24
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.sparse as sp

from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.linalg.direct import factorize
from aromm.linalg.factorizations import FLOOR_FACTOR


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[12, 16, 24], help="voxels per side")
    parser.add_argument("--fibre-k", type=float, nargs="+", default=[30.0, 300.0, 1000.0, 1e5])
    parser.add_argument("--shifts", type=float, nargs="+", default=[1 / 60.0, 30.0], help="s (1/s) of K + sC")
    args = parser.parse_args()
    rng = np.random.default_rng(1)
    eps = float(np.finfo(float).eps)
    print("n    fibre.k   shift (1/s)  residual   floor ε|A||x|/|b|  ratio  CPU s")
    for n in args.sizes:
        labels = (rng.random((n, n, n)) < 0.4).astype(np.int32)
        for kf in args.fibre_k:
            phases = [PhaseSpec("gas", 0, 0.026, 1.2e3), PhaseSpec("fibre", 1, kf, 4e6)]
            system = assemble_voxels(labels, (5e-6,) * 3, phases, [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)],
                                     time=TimeGrid(60.0, 0.1), outputs=["z0"])
            v = system.values()
            b = np.asarray(system.load.evaluate(v), dtype=float).ravel()
            for s in args.shifts:
                cpu = time.process_time()
                a = sp.csr_array(system.conductance.evaluate(v) + s * system.capacity.evaluate(v))
                x = factorize(a, "cholmod", rtol=1.0).solve(b[:, None], check=False)[:, 0]
                residual = float(np.linalg.norm(a @ x - b) / np.linalg.norm(b))
                magnitude = sp.csr_array((np.abs(a.data), a.indices, a.indptr), shape=a.shape) @ np.abs(x)
                floor = eps * float(np.linalg.norm(magnitude)) / float(np.linalg.norm(b))
                print(f"{n:<4d} {kf:<9g} {s:<12.3g} {residual:<10.2e} {floor:<18.2e} {residual / floor:5.2f}  "
                      f"{time.process_time() - cpu:.2f}")
    print(f"accepted when residual <= rtol + {FLOOR_FACTOR:.3g} × floor (aromm.linalg.factorizations.check_residual)")


if __name__ == "__main__":
    main()
