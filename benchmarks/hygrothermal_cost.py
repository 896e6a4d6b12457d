"""What coupling heat and moisture costs: the Krylov build of the shipped 46³ wood VER's scene as it is (thermal)
and with a `[moisture]` section (the same scene plus vapour exchange with the air of its convective face z1, a
humidity step there from 50 to 80 % RH), in Q1 and in finite volumes.

Each build in a fresh process on one BLAS thread, no cache, the same box (fibre.k ∈ [0.1, 1] W/(m K) × fibre.c ∈
[1e6, 1e7] J/(m³ K)) and tolerance (1e-5 °C, and 1e-5 in φ), the certificate as asked (``--certify``: on for both;
by default off, so that both builds do the same kind of work: the coupled system's 2n unknowns are above
:data:`aromm.reduction.certified.CERTIFY_AFTER_BELOW`, where a build is not certified by default).  Prints unknowns,
CPU seconds (user + system), peak memory, the order kept and the greedy's points, and the load average.

Moisture properties (orders of magnitude, [Kuenzel1995]'s kind of data; not fitted to a material): cell wall ξ 200
kg/m³, D_φ 1e-9 kg/(m s), δ_p 1e-13 kg/(m s Pa); air in the lumens ξ 0.0173 kg/m³ (saturated vapour density at
20 °C), D_φ 0, δ_p 2e-10 kg/(m s Pa); z1: β 2e-8 kg/(m² s Pa), φ_ext 0.8; φ(0) = 0.5; T_ref 20 °C, φ_ref 0.5.

    python benchmarks/hygrothermal_cost.py
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import copy
import json
import resource
import subprocess
import sys
from pathlib import Path

SCENE = Path(__file__).resolve().parent.parent / "data" / "scenes" / "wood_s1.toml"
BOX = {"fibre.k": (0.1, 1.0), "fibre.c": (1e6, 1e7)}
MOISTURE = {"fibre": {"xi": 200.0, "D_phi": 1e-9, "delta_p": 1e-13},
            "gas": {"xi": 0.0173, "D_phi": 0.0, "delta_p": 2e-10}}


def scene_data(coupled: bool, discretisation: str) -> dict[str, object]:
    from aromm.scene.scene_file import read_toml

    data = copy.deepcopy(read_toml(SCENE))
    data["model"] = {**data.get("model", {}), "discretisation": discretisation}
    data.pop("reduction", None)
    if coupled:
        data["moisture"] = {"T_ref": 20.0, "phi_ref": 0.5}
        for phase, props in MOISTURE.items():
            data["phases"][phase].update(props)
        data["boundary"]["z1"].update({"beta": 2e-8, "phi_ext": 0.8})
        data["initial"]["phi"] = 0.5
        data["outputs"]["mean_phi"] = ["z0", "z1"]
    return data


def worker(coupled: bool, discretisation: str, certify: bool) -> dict[str, object]:
    import warnings

    from aromm.api import assemble
    from aromm.core.errors import ModelWarning
    from aromm.reduction.offline import reduce
    from aromm.scene.scene_file import scene_from_dict

    system = assemble(scene_from_dict(scene_data(coupled, discretisation), SCENE))
    before = resource.getrusage(resource.RUSAGE_SELF)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)
        rom = reduce(system, 200, method="krylov", bounds=BOX,
                     tolerance=1e-5, cache=False, certify=certify)
    after = resource.getrusage(resource.RUSAGE_SELF)
    return {"unknowns": system.n, "cpu": after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime,
            "user": after.ru_utime - before.ru_utime, "peak_gb": after.ru_maxrss / 1e6, "order": rom.order,
            "points": int(rom.info.get("krylov_points", 0)), "converged": int(rom.info["converged"]),
            "bound": float(rom.info.get("error_bound", float("nan"))), "load": os.getloadavg()[0]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--discretisations", nargs="+", default=["q1", "fv"], choices=["q1", "fv"])
    parser.add_argument("--certify", action="store_true", help="certify both builds")
    parser.add_argument("--worker", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        coupled, disc, certify = args.worker
        print(json.dumps(worker(coupled == "coupled", disc, certify == "1")))
        return
    print(f"{'model':>9} {'disc':>4} {'unknowns':>9} {'CPU s':>7} {'user s':>7} {'peak GB':>7} {'order':>5} "
          f"{'points':>6} {'met':>3} {'bound':>8}  load")
    for disc in args.discretisations:
        for kind in ("thermal", "coupled"):
            out = subprocess.run([sys.executable, __file__, "--worker", kind, disc, str(int(args.certify))],
                                 check=True, capture_output=True, text=True).stdout
            r = json.loads(out.strip().splitlines()[-1])
            print(f"{kind:>9} {disc:>4} {r['unknowns']:9d} {r['cpu']:7.1f} {r['user']:7.1f} {r['peak_gb']:7.2f} "
                  f"{r['order']:5d} {r['points']:6d} {r['converged']:3d} {r['bound']:8.2g}  {r['load']:.1f}",
                  flush=True)


if __name__ == "__main__":
    main()
