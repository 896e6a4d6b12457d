"""The default discretisation row of identify against the re-fit it stands in for (issue 36, item 4).

Data of one discretisation (the full model at the truth, 0.01 °C of noise), identification with the full model of
the other: the estimate's distance to the truth is the discretisation's share of the error.  For each case it prints
that distance |ln(k̂/k*)|, the shift a re-fit with the data's discretisation finds
(``identify --discretisation-check``, :func:`inverse.identification.alternative_shift`), the default row
(:func:`aromm.homogenization.discretisation_gap.discretisation_gap`, by the fluxmetric k̄) and, beside it, the gap of
the cell problem's k̄ (fixed temperatures on z0 and z1), which the row does not use; CPU seconds of the row and of
the re-fit.  Images: walls crossed by the heat (tracheids turned across the loaded axis) and the wood
generator's VER heated along its tracheids, Table 1 scenario 1 over 20 s.

    python benchmarks/discretisation_gap.py --sizes 6 12 18 24
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from aromm.full.solve import FullModel
from aromm.homogenization.cell_problems import effective_conductivity
from aromm.homogenization.discretisation_gap import discretisation_gap
from aromm.homogenization.representativeness import with_values
from aromm.scene.scene_file import assemble, load_scene
from aromm.studies.chavez2020 import scenario_1_text, small_wood
from inverse.identification import identify
from inverse.measurements import simulate_measurements

TRUTH = {"fibre.k": 0.3, "fibre.c": 4.0e6}
UNKNOWNS = {"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)}
BOX = 230e-6


def walls_across(n: int) -> np.ndarray:
    """Fibre walls on planes i % 3 == 0 and k % 3 == 0: tubes along y, the heat (along z) crosses the k-walls."""
    i, _, k = np.meshgrid(range(n), range(n), range(n), indexing="ij")
    return ((i % 3 == 0) | (k % 3 == 0)).astype(np.int32)


def wood_ver(n: int) -> np.ndarray:
    """The wood generator's VER (tracheids along z, the loaded axis) at n³ over the paper's box."""
    return np.asarray(small_wood(n, BOX).geometry.labels)  # type: ignore[attr-defined]


def case(folder: Path, labels: np.ndarray, data_by: str, model_by: str) -> list[str]:
    n = labels.shape[0]
    np.save(folder / "labels.npy", labels)
    path = folder / "scene.toml"
    path.write_text(scenario_1_text(f'image = "labels.npy"\nvoxel_size = {BOX / n!r}', end="20.0", dt="0.5"),
                    encoding="utf-8")
    scene = load_scene(path)
    data_model = FullModel(assemble(replace(scene, discretisation=data_by)))
    data = simulate_measurements(data_model, TRUTH, noise=0.01, rng=np.random.default_rng(0))
    model = FullModel(assemble(replace(scene, discretisation=model_by)))
    start = time.process_time()
    plain = identify(model, data, UNKNOWNS, particles=8, iterations=4)
    fit = time.process_time() - start
    start = time.process_time()
    refit = identify(model, data, UNKNOWNS, particles=8, iterations=4, alternatives={"discretisation": data_model})
    refit_s = time.process_time() - start - fit
    k = plain.estimates["fibre.k"]
    shift = float(refit.uncertainty.budget["discretisation"][0]) / k
    row = discretisation_gap(replace(scene, discretisation=model_by), plain.estimates)
    flux = float(row.half["fibre.k"])
    at = with_values(scene, plain.estimates)  # the cell problem's k̄ (fixed temperatures on z0, z1): not the row
    k_q1, k_fv = (effective_conductivity(replace(at, discretisation=d), "temperature", axes=(2,)).k[2, 2]
                  for d in ("q1", "fv"))
    cell = abs(math.log(k_q1 / k_fv))
    return [f"{n}³", data_by, model_by, f"{k:.4f}", f"{abs(math.log(k / TRUTH['fibre.k'])):.4f}", f"{shift:.4f}",
            f"{flux:.4f}", f"{flux / shift:.2f}", f"{cell:.4f}", f"{cell / shift:.2f}",
            f"{row.seconds:.2f}", f"{refit_s:.1f}"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[6, 12, 18])
    args = parser.parse_args()
    print(f"# python benchmarks/discretisation_gap.py --sizes {' '.join(map(str, args.sizes))}; load average "
          f"{os.getloadavg()[0]:.2f}; relative shifts of fibre.k (|ln|), CPU s")
    head = ["case", "image", "data", "model", "k̂", "truth", "re-fit", "row", "/re-fit", "cell k̄ gap", "/re-fit",
            "row s", "re-fit s"]
    table = [head]
    for name, image in (("walls across", walls_across), ("wood VER", wood_ver)):
        for n in args.sizes:
            for data_by, model_by in (("fv", "q1"), ("q1", "fv")):
                with tempfile.TemporaryDirectory() as folder:
                    table.append([name, *case(Path(folder), image(n), data_by, model_by)])
                    print("  ".join(table[-1]), flush=True)
    widths = [max(len(r[j]) for r in table) for j in range(len(table[0]))]
    print("\n".join("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in table))


if __name__ == "__main__":
    main()
