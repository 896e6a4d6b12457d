"""Cost model of the petsc engine's Krylov reductor (docs/scaling.md), grounded in counted work.

Reads the records of ``benchmarks/petsc_krylov.py --json FILE`` (petsc rows at one size, 1 … P ranks) and
predicts the offline build of ``aromm reduce --engine petsc --method krylov`` at 256³, 512³, 1024³.

Counted, per build (the records' ``info`` and PETSc's event log; independent of N for a given VER and box:
the greedy's parameter points, the shifts and moments fix them, the multigrid keeps the CG iterations flat —
11.6 at 32³, 12.1 at 64³):

* ``S`` shifted solves and ``U`` multigrid set-ups, ``I`` mean CG iterations per solve, ``s`` basis columns;
* per CG iteration and rank: ``R`` global reductions, ``M`` messages and ``B`` bytes sent (PETSc's KSPSolve
  event, inclusive of the V-cycles' halo exchanges), from the record with the most ranks.

Time per rank for ``N`` unknowns on ``P`` ranks (``n = N / P`` unknowns per rank):

    T = n (U a_U + S I a_I + a_0)                                 computation, rates per unknown
      + S I (R α ⌈log2 P⌉ + M α + B(n) / β)                       communication per CG iteration
      + c_G s² ⌈log2 P⌉ α                                          the block Gram–Schmidt's reductions

``a_U``, ``a_I`` (CPU s per unknown per set-up / per CG iteration) and ``a_0`` (everything else: image, assembly,
greedy indicator, orthogonalisation, projection) are the 1-rank record's CPU seconds divided by the counts —
**2-core figures** of a shared machine (Debian's reference BLAS); ``B(n) = B_meas (n / n_meas)^(2/3)`` (a box's
faces); ``α`` (latency, s) and ``β`` (bytes/s per rank) are the interconnect's, *assumed* (not measurable on one
2-core node) and printed.  Memory per rank: ``m0 + b n`` fitted to the per-rank peaks of the records (``m0``:
Python, numpy, scipy and PETSc loaded, measured, plus the fit's intercept; ``b``: bytes per owned unknown, the
operators, the multigrid hierarchy and the ``s`` basis columns); the CPU a rank spends beyond its share of the
counted work in the multi-rank records (replicated small algebra, waits) is added to every plan as a constant.
The ranks of a plan are the fewest whose memory fits ``--memory`` GB per rank; the 3-D boxes must keep ≥ 8 nodes
per axis for the geometric multigrid (``P ≤ (n_side/8)³``).
Everything past the measured size is an extrapolation and is printed as such, with the data it rests on.

Usage: python benchmarks/scaling_model.py benchmarks/records/petsc_krylov_64.json [...] [--size 64] [--memory 4]
[--latency 2e-6] [--bandwidth 5e9]
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

SIZES = (256, 512, 1024)
NODES_PER_BOX_AXIS = 8  # the geometric multigrid halves every rank's node box at least twice


def counted(record: dict) -> dict[str, float]:  # type: ignore[type-arg]
    """Per-rank counts of one record: per CG iteration, reductions, messages and bytes (largest rank)."""
    info = record["info"]
    iterations = info["solves"] * info["cg_iterations_mean"]
    events = [r.get("KSPSolve", {}) for r in record["events"]]
    largest = {k: max(float(e.get(k, 0.0)) for e in events) for k in ("numReductions", "numMessages",
                                                                       "messageLength")}
    return {"R": largest["numReductions"] / iterations, "M": largest["numMessages"] / iterations,
            "B": largest["messageLength"] / iterations, "iterations": iterations}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("records", type=Path, nargs="+")
    parser.add_argument("--size", type=int, default=64, help="the image size n of the records the model rests on")
    parser.add_argument("--memory", type=float, default=4.0, help="GB of memory per rank (per core) on the cluster")
    parser.add_argument("--latency", type=float, default=2e-6, help="assumed interconnect latency α (s)")
    parser.add_argument("--bandwidth", type=float, default=5e9, help="assumed bandwidth per rank β (bytes/s)")
    args = parser.parse_args()
    records = [r for path in args.records for r in json.loads(path.read_text())
               if r["engine"] == "petsc" and r["n"] == args.size]
    if not any(r["ranks"] == 1 for r in records):
        raise SystemExit(f"need a petsc record at 1 rank at n = {args.size}")
    records.sort(key=lambda r: r["ranks"])
    one, most = records[0], records[-1]
    unknowns = float(one["unknowns"])
    info = one["info"]
    solves, setups, its, span = info["solves"], info["setups"], info["cg_iterations_mean"], info["krylov_span"]
    cpu = max(one["cpu"])
    a_u = info["setup_seconds"] / (setups * unknowns)
    a_i = info["solve_seconds"] / (solves * its * unknowns)
    a_0 = (cpu - info["setup_seconds"] - info["solve_seconds"]) / unknowns
    comm = counted(most)
    n_most = unknowns / most["ranks"]
    owned = np.array([unknowns / r["ranks"] for r in records])
    peak = np.array([max(r["peak"]) for r in records])
    fixed = float(np.median([f for r in records for f in r.get("fixed", [])] or [0.0]))
    b, c0 = (np.polyfit(owned, peak - fixed, 1) if len(records) > 1 else ((peak[0] - fixed) / owned[0], 0.0))
    m0 = fixed + max(float(c0), 0.0)  # every rank: the loaded process, ghost layers, replicated coarse levels
    compute_rate = setups * a_u + solves * its * a_i + a_0
    # CPU a rank spends beyond its share of the counted work (replicated small dense algebra, and the waits of
    # oversubscribed ranks that process_time counts): the largest over the multi-rank records, an upper bound
    extra = max([max(r["cpu"]) - unknowns / r["ranks"] * compute_rate for r in records if r["ranks"] > 1] or [0.0])
    print(f"records at n = {args.size} ({int(unknowns):,} unknowns), ranks {[r['ranks'] for r in records]}; "
          f"load {min(r['load'][0] for r in records):.1f}–{max(r['load'][1] for r in records):.1f} on 2 shared cores")
    print(f"  counted: S = {solves:.0f} solves, U = {setups:.0f} set-ups, I = {its:.1f} CG its/solve, s = {span:.0f} "
          f"columns; per CG iteration and rank at P = {most['ranks']}: R = {comm['R']:.2f} reductions, "
          f"M = {comm['M']:.1f} messages, B = {comm['B']:,.0f} bytes")
    print(f"  1-rank CPU {cpu:.1f} s = set-ups {info['setup_seconds']:.1f} + solves {info['solve_seconds']:.1f} + rest "
          f"{cpu - info['setup_seconds'] - info['solve_seconds']:.1f}: a_U = {a_u:.3g}, a_I = {a_i:.3g}, "
          f"a_0 = {a_0:.3g} CPU s per unknown (2-core figures)")
    for r, n_r, p_r in zip(records, owned, peak, strict=True):
        c = counted(r) if r["ranks"] > 1 else {"R": 0.0, "M": 0.0, "B": 0.0}
        print(f"  P = {r['ranks']}: peak {p_r / 2**20:,.0f} MB/rank = {p_r / n_r:,.0f} B per owned unknown "
              f"({(p_r - fixed) / n_r:,.0f} above the fixed {fixed / 2**20:.0f} MB); CPU {max(r['cpu']):.1f} s/rank "
              f"(model's computation {n_r * compute_rate:.1f}); "
              f"per CG it. R {c['R']:.2f}, M {c['M']:.1f}, B {c['B']:,.0f}")
    print(f"  memory per rank = {m0 / 2**20:.0f} MB + {b:,.0f} B × owned unknowns (fit over the ranks; the fixed "
          f"process {fixed / 2**20:.0f} MB); CPU per rank beyond its share ≤ {extra:.1f} s (added to every plan); "
          f"assumed α = {args.latency:g} s, β = {args.bandwidth:g} B/s")
    print("EXTRAPOLATION (order and span as measured; counts held; rates of the 2-core machine):")
    print(f"{'image':>7} {'unknowns':>14} {'ranks':>6} {'GB/rank':>8} {'max P (boxes)':>13} {'compute h':>10} "
          f"{'comm h':>7} {'hours':>7} {'CPU h':>8}")
    budget = args.memory * 2**30 - m0
    for side in SIZES:
        n_total = float((side + 1) ** 3)
        ranks = max(1, math.ceil(n_total * b / budget))
        max_p = (side // NODES_PER_BOX_AXIS) ** 3
        n = n_total / ranks
        compute = n * compute_rate + extra
        hops = math.ceil(math.log2(ranks)) if ranks > 1 else 0
        per_it = (comm["R"] * hops * args.latency + comm["M"] * args.latency
                  + comm["B"] * (n / n_most) ** (2 / 3) / args.bandwidth)
        communication = solves * its * per_it + 2 * span**2 * hops * args.latency
        print(f"{side:>6}³ {n_total:>14,.0f} {ranks:>6,} {(m0 + b * n) / 2**30:>8.2f} {max_p:>13,} "
              f"{compute / 3600:>10.2f} {communication / 3600:>7.3f} {(compute + communication) / 3600:>7.2f} "
              f"{ranks * compute / 3600:>8,.1f}")


if __name__ == "__main__":
    main()
