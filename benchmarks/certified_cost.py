"""What the certified bound costs: a Krylov build of the generated wood VER without its certificate, with it by
default, and with the greedy stopping on it.

For ``aromm.studies.chavez2020.small_wood(n)`` (scenario 1; box fibre.k ∈ [0.1, 1] W/(m K) × fibre.c ∈ [1e6, 1e7]
J/(m³ K), tolerance 1e-5 °C, the default reductor otherwise), each build in a fresh process on one BLAS thread: CPU
seconds (user + system), peak memory, the order kept, the greedy's points, the certified bound over the training grid
(°C) and whether it met the tolerance, and the load average.  Modes: ``none`` (``certify=False``), ``default``
(None: below :data:`aromm.reduction.certified.CERTIFY_BELOW` unknowns the same as ``on bound``, from there the
returned model certified once built) and ``on bound`` (``certify=True``: the greedy stops on the bound).  The data
behind ``CERTIFY_BELOW`` and ``CERTIFY_AFTER_BELOW``.

    python benchmarks/certified_cost.py --sizes 24 32 46
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

BOX = {"fibre.k": (0.1, 1.0), "fibre.c": (1e6, 1e7)}


MODES = {"none": False, "default": None, "on bound": True}


def worker(n: int, certify: bool | None) -> dict[str, object]:
    import warnings

    from aromm.api import assemble
    from aromm.core.errors import ModelWarning
    from aromm.reduction.offline import reduce
    from aromm.studies.chavez2020 import loading, small_wood

    system = assemble(loading(small_wood(n), "z"))
    before = resource.getrusage(resource.RUSAGE_SELF)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)
        rom = reduce(system, 200, method="krylov", bounds=BOX, tolerance=1e-5, cache=False, certify=certify)
    after = resource.getrusage(resource.RUSAGE_SELF)
    return {"unknowns": system.n, "cpu": after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime,
            "peak_gb": after.ru_maxrss / 1e6, "order": rom.order, "points": int(rom.info.get("krylov_points", 0)),
            "bound": float(rom.info.get("error_bound", float("nan"))), "converged": int(rom.info["converged"]),
            "load": os.getloadavg()[0]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[24, 32])
    parser.add_argument("--worker", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(int(args.worker[0]), MODES[args.worker[1]])))
        return
    print(f"{'n³':>4} {'unknowns':>9} {'mode':>9} {'CPU s':>7} {'peak GB':>7} {'order':>5} {'points':>6} "
          f"{'bound °C':>9} {'met':>3}  load")
    for n in args.sizes:
        for mode in MODES:
            out = subprocess.run([sys.executable, __file__, "--worker", str(n), mode], check=True,
                                 capture_output=True, text=True).stdout
            r = json.loads(out.strip().splitlines()[-1])
            print(f"{n:4d} {r['unknowns']:9d} {mode:>9} {r['cpu']:7.1f} "
                  f"{r['peak_gb']:7.2f} {r['order']:5d} {r['points']:6d} {r['bound']:9.2g} {r['converged']:3d}  "
                  f"{r['load']:.1f}", flush=True)


if __name__ == "__main__":
    main()
