"""Each matrix-free kernel against this machine's memory bandwidth: ns per voxel, the bytes it must move, and the
fraction of the bandwidth bound it reaches, compiled (numba) and numpy side by side, in one process, one thread.

The bound of a kernel is (bytes it must read and write once) / (copy bandwidth measured here, ``np.copyto`` of
two 256 MB arrays, read + write counted).  Bytes per voxel, float64 vectors unless said:

* fv product ``A x``: x 8, three float32 links 12, out 8 → 28; residual ``b − A x``: + b 8 → 36;
* fv red–black Gauss–Seidel, one colour: x 8, b 8, links 12 read, half of x written 4 → 32;
* fv restriction (2 × 2 × 2 sums): 8 + 1 → 9; prolongation (x += P e on live cells): 8 + 8 + 1 + 1 → 18;
* Q1 product ``K x`` (27-point, per node): x 8, phase code 1, out 8 → 17 (float32 vectors: 9); "numpy kept" reads
  7 kept per-voxel weights besides (+ 28 or 56 bytes, not counted: the bound is the one without them);
* the first coarse level's product in the V-cycle (float32, per *coarse* node, n³/8 of them): 27 coefficients 108,
  x 4, out 4 → 116 (aromm.linalg.multigrid.coarse_stencil); "csr" is scipy's product of the same rows, which also
  reads 27 int32 column indices (+ 108, not counted).

Usage: NUMBA_NUM_THREADS=1 python benchmarks/kernels.py [--n 128] [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np


def _seconds(run: Callable[[], object], repeat: int) -> float:
    run()  # compile / warm the caches
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return float(best)


def bandwidth(repeat: int) -> float:
    """Copy bandwidth in bytes/s (read + write), 256 MB arrays."""
    src = np.ones(1 << 25)
    dst = np.empty_like(src)
    return 2 * src.nbytes / _seconds(lambda: np.copyto(dst, src), repeat)


def main() -> None:
    from aromm.fv.kernels import NUMPY, kernels
    from aromm.fv.stencil import conductance_stencil
    from aromm.linalg.multigrid.coarse_stencil import compiled_product, numpy_product
    from aromm.linalg.multigrid.hierarchy import ElementLevel
    from aromm.linalg.multigrid.operator import VoxelOperator

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=128)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    n, rng = args.n, np.random.default_rng(0)
    bw = bandwidth(args.repeat)
    print(f"# {n}³ voxels, copy bandwidth {bw / 1e9:.1f} GB/s, NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS')},"
          f" load {os.getloadavg()[0]:.2f}")
    print(f"{'kernel':>28} {'backend':>10} {'ns/node':>9} {'B/voxel':>8} {'bound ns':>9} {'of bound':>9}")
    k = np.where(rng.random((n, n, n)) < 0.4, 10.0, 1.0)
    st = conductance_stencil((k, k, k), (1.0, 1.0, 1.0), 2)
    x, b, out = rng.random(st.shape), rng.random(st.shape), np.empty(st.shape)
    coarse = np.empty(((n + 1) // 2,) * 3)
    alive = st.alive()
    compiled = kernels()
    rows: list[tuple[str, float, dict[str, Callable[[], object]]]] = []
    for ops in {compiled.name: compiled, "numpy": NUMPY}.values():
        rows += [
            ("fv product", 28, {ops.name: lambda ops=ops: ops.product(st, x, out)}),
            ("fv residual", 36, {ops.name: lambda ops=ops: ops.residual(st, b, x, out)}),
            ("fv Gauss–Seidel colour", 32, {ops.name: lambda ops=ops: ops.sweep(st, b, x, 0)}),
            ("fv restriction", 9, {ops.name: lambda ops=ops: ops.restrict(x, coarse)}),
            ("fv prolongation", 18, {ops.name: lambda ops=ops: ops.prolong(coarse, out, alive, 1.0)}),
        ]
    phase = rng.integers(0, 2, size=(n, n, n))
    kept = VoxelOperator(phase, np.array([[1.0] * 3, [10.0] * 3]), (1.0, 1.0, 1.0))  # numpy, weights kept
    variants = {"numpy kept": kept, "numpy": replace(kept, keep_weights=False, compiled=False, _cache={}),
                "numba": replace(kept, keep_weights=False, _cache={})}  # numba when installed, else numpy again
    for dtype, size in ((np.float64, 17), (np.float32, 9)):
        u = rng.random(kept.n).astype(dtype)
        y = np.empty_like(u)
        rows.append((f"Q1 product {np.dtype(dtype).name}", size,
                     {name: lambda op=op, u=u, y=y: op.matvec(u, out=y) for name, op in variants.items()}))
    level = ElementLevel.coarse_of(replace(kept, keep_weights=False, _cache={}))
    stencil, csr = level.to_stencil(np.float32), level.to_csr(np.float32)
    v = rng.random(stencil.shape[0]).astype(np.float32)
    w = np.empty(stencil.node_shape, dtype=np.float32)
    product = compiled_product()
    coarse_runs: dict[str, Callable[[], object]] = {
        "numpy": lambda: numpy_product(stencil.data, v.reshape(w.shape), w, stencil.periodic), "csr": lambda: csr @ v}
    if product is not None:
        coarse_runs = {"numba": lambda: product(stencil.data, v.reshape(w.shape), w, stencil.periodic), **coarse_runs}
    rows.append(("Q1 coarse level float32", 116, coarse_runs))
    for label, size, runs in rows:
        for backend, run in runs.items():
            nodes = stencil.shape[0] if label.startswith("Q1 coarse") else n**3
            ns = _seconds(run, args.repeat) / nodes * 1e9
            bound = size / bw * 1e9
            print(f"{label:>28} {backend:>10} {ns:9.2f} {size:8d} {bound:9.2f} {bound / ns:9.1%}", flush=True)


if __name__ == "__main__":
    main()
