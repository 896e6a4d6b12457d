"""The certified output error bound of reduced models against the full model exact in time (issue 35, item 3).

For each case: a Krylov model (default tolerance) over its box, or with ``--method aromm|pod|greedy`` a modal model
built at the scene's values (the box then only spreads the evaluation points; with ``--referee`` it is also the box
of its Krylov referee), then at ``--points`` parameter points of a Latin hypercube over the box (log scale, seeded;
off the training grid) the actual worst error over outputs and output times against
:func:`aromm.full.exact.exact_outputs`, the certified bound (:mod:`aromm.reduction.certificate`) and their ratio,
the effectivity (the bound must be ≥ 1× the error; the target is ≤ 100×; in the last two columns the direct bound's
alone, without the span a Krylov model was compressed from or a modal model's Krylov referee,
:func:`aromm.reduction.certificate.through_finer`, over the points and at the model's own values). The truth's own
rounding is measured too, as the difference of two exact-in-time evaluations of the full model (the dense modal
solution and the reduced integrator on the identity basis): errors below 10× its worst over the case are not
measurable, and those points are counted apart ("below") instead of entering the effectivity. CPU seconds of the
build (a modal model's referee included), of the certificate's offline part (the model's own) and of one bound
evaluation beside them.

    python benchmarks/certified_bound.py --size 8 --points 20
    python benchmarks/certified_bound.py --size 8 --points 20 --method aromm --order 12 [--referee]
    python benchmarks/certified_bound.py --size 8 --points 20 --cases "fibres, fixed axis" "micro-CT crop" \
        --image 100_fiberform.tif
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from aromm.api import reduce
from aromm.core.anisotropy import PhaseTensor
from aromm.core.profiles import Profile
from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.full.exact import exact_outputs
from aromm.reduction.lifting import lift
from aromm.reduction.rom import ReducedModel

FLUX = [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)]


CASES = ("two phases", "three phases", "contrast 1e4", "four unknowns", "load history", "fixed face",
         "fibres, fixed axis", "fibres, image axes", "micro-CT crop")
#: Transversely isotropic fibre phases (aromm.core.anisotropy): k_axial along the axis, k_transverse across it.
FIBRE_BOX = {"fibre.k_axial": (0.3, 3.0), "fibre.k_transverse": (0.05, 0.5)}


def crop(path: str, size: int) -> npt.NDArray[np.int_]:
    """The central ``size``³ crop of a grey micro-CT image (tifffile order pages, rows, columns = z, y, x, returned
    [x, y, z]), fibre (label 1) where the grey value is ≥ 90 (NASA PuMA's FiberForm threshold)."""
    import tifffile

    image = tifffile.imread(path)
    lo = [(n - size) // 2 for n in image.shape]
    part = image[lo[0]:lo[0] + size, lo[1]:lo[1] + size, lo[2]:lo[2] + size]
    return (np.transpose(part, (2, 1, 0)) >= 90).astype(int)


def case(name: str, size: int, image: str | None = None) -> tuple[ThermalSystem, dict[str, tuple[float, float]]]:
    rng = np.random.default_rng(2)
    two = (rng.random((size,) * 3) < 0.4).astype(int)
    gas, fibre = PhaseSpec("gas", 0, 0.026, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6)
    grid, outputs = TimeGrid(2.0, 0.05), ["z0", "z1"]
    box = {"fibre.k": (0.1, 1.0), "fibre.c": (1e6, 1e7)}
    if name.startswith("fibres"):
        axes = ((0.6, 0.0, 0.8),) if name.endswith("fixed axis") else None
        tensor = PhaseTensor("fibre", (1.0, 0.2), axes)
        return assemble_voxels(two, (5e-6,) * 3, [gas, PhaseSpec("fibre", 1, 1.0, 4e6, tensor=tensor)], FLUX,
                               time=grid, outputs=outputs), FIBRE_BOX
    if name == "micro-CT crop":  # FiberForm: carbon fibre 12 W/(m K) in air 0.0257 (PuMA's values), 5 µm voxels
        assert image is not None
        phases = [PhaseSpec("air", 0, 0.0257, 1.2e3), PhaseSpec("fibre", 1, 12.0, 1.6e6)]
        return assemble_voxels(crop(image, size), (5e-6,) * 3, phases, FLUX, time=TimeGrid(0.02, 0.0005),
                               outputs=outputs), {"fibre.k": (4.0, 36.0), "fibre.c": (8e5, 3.2e6)}
    if name == "three phases":
        three = two + (rng.random(two.shape) < 0.2) * (two == 0) * 2
        phases = [gas, fibre, PhaseSpec("filler", 2, 2.0, 2e6)]
        return assemble_voxels(three, (5e-6,) * 3, phases, FLUX, time=grid, outputs=outputs), \
            {"fibre.k": (0.1, 1.0), "filler.k": (0.5, 5.0)}
    if name == "contrast 1e4":
        fibre = PhaseSpec("fibre", 1, 500.0, 4e6)
        return assemble_voxels(two, (5e-6,) * 3, [gas, fibre], FLUX, time=TimeGrid(0.02, 0.0005),
                               outputs=outputs), {"fibre.k": (300.0, 1000.0)}
    if name == "four unknowns":
        return assemble_voxels(two, (5e-6,) * 3, [gas, fibre], FLUX, time=grid, outputs=outputs), \
            {**box, "z1.h": (5.0, 50.0), "gas.k": (0.01, 0.05)}
    faces = FLUX
    if name == "fixed face":
        faces = [FaceSpec("z0", flux=500.0), FaceSpec("z1", T=10.0)]
    if name == "load history":
        faces = [FaceSpec("z0", flux=Profile((0.0, 0.3, 0.75, 1.4), (0.0, 800.0, 200.0, 500.0))),
                 FaceSpec("z1", h=20.0, T_ext=15.0)]
    system = assemble_voxels(two, (5e-6,) * 3, [gas, fibre], faces, time=grid, outputs=outputs)
    if name == "load history":
        system = ThermalSystem(**{**system.__dict__, "parameters": {**system.parameters, "initial.T": 25.0}})
    return system, box


def hypercube(box: dict[str, tuple[float, float]], count: int, rng: np.random.Generator) -> list[dict[str, float]]:
    """``count`` points, one per stratum of every axis (log scale), strata permuted independently."""
    out: list[dict[str, float]] = [{} for _ in range(count)]
    for name, (lo, hi) in box.items():
        u = (rng.permutation(count) + rng.random(count)) / count
        for point, value in zip(out, np.exp(np.log(lo) + u * np.log(hi / lo)), strict=True):
            point[name] = float(value)
    return out


def _own_values(system: ThermalSystem, alone: ReducedModel, times: npt.NDArray[np.float64], floor: float) -> str:
    """The direct bound's effectivity at the model's own values (a modal model's basis values: what it reports
    without a box), or "below" when the error there is under ``floor``."""
    own = dict(system.parameters)
    error = float(np.abs(alone.simulate(own, times).as_array() - exact_outputs(system, own, times)).max())
    bound = alone.error_bound(own)
    return "below" if error <= floor or bound is None else f"{float(np.max(bound)) / error:.3g}"


def _span(ratio: npt.NDArray[np.float64]) -> str:
    return f"{ratio.min():6.3g}–{ratio.max():<6.3g}" if ratio.size else f"{'—':13s}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=8, help="voxels per side")
    parser.add_argument("--points", type=int, default=20)
    parser.add_argument("--order", type=int, default=200, help="order asked (the span's width caps it)")
    parser.add_argument("--method", choices=("krylov", "aromm", "pod", "greedy"), default="krylov")
    parser.add_argument("--referee", action="store_true", help="a modal model certified over the box through a "
                        "Krylov referee (aromm.reduction.referee): the box is passed to it as its bounds")
    parser.add_argument("--image", help="a grey micro-CT image (TIFF) for the micro-CT case: NASA PuMA's "
                        "python/pumapy/data/100_fiberform.tif (not shipped; without it the case is skipped)")
    parser.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    referee = " with a Krylov referee" if args.referee else ""
    print(f"{args.size}³ bodies, method {args.method}{referee}, {args.points} Latin-hypercube points per case, "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"{'case':18s} {'order':>5s} {'actual max':>11s} {'bound max':>10s} {'effectivity':>13s} "
          f"{'build CPU s':>11s} {'cert CPU s':>10s} {'bound CPU s':>11s} {'truth floor':>11s} {'below':>5s} "
          f"{'direct alone':>13s} {'at own values':>13s}")
    for name in args.cases:
        if name == "micro-CT crop" and args.image is None:
            print(f"{name:18s} skipped: no --image")
            continue
        system, box = case(name, args.size, args.image)
        start = time.process_time()
        rom = reduce(system, order=args.order, method=args.method, cache=False,
                     **({"bounds": box} if args.method == "krylov" or args.referee else {}))
        build = time.process_time() - start
        times = system.time.times if system.time is not None else np.array([])
        actual, bound, seconds, floor, direct = [], [], [], [], []
        alone = replace(rom, finer=None)  # the direct bound, without the span or the referee
        system = lift(system, rom.parameters)  # the outputs of the lifted system are the original ones exactly
        full = ReducedModel.from_system(system, np.eye(system.n))
        for mu in hypercube(box, args.points, np.random.default_rng(7)):
            truth = exact_outputs(system, mu, times)
            floor.append(float(np.abs(full.simulate(mu, times).as_array() - truth).max()))
            actual.append(float(np.abs(rom.simulate(mu, times).as_array() - truth).max()))
            start = time.process_time()
            b = rom.error_bound(mu)
            seconds.append(time.process_time() - start)
            bound.append(float(np.max(b)) if b is not None else float("nan"))
            d = alone.error_bound(mu)
            direct.append(float(np.max(d)) if d is not None else float("nan"))
        own = _own_values(system, alone, times, 10 * max(floor))
        seen = np.array(actual) > 10 * max(floor)  # the floor varies from point to point: its worst over the case
        span, direct_span = (_span((np.array(b) / np.array(actual))[seen]) for b in (bound, direct))
        print(f"{name:18s} {rom.order:5d} {max(actual):11.3g} {max(bound):10.3g} {span} {build:11.2f} "
              f"{float(rom.info.get('certify_seconds', 0)):10.2f} {np.median(seconds):11.3f} {max(floor):11.2g} "
              f"{int((~seen).sum()):5d} {direct_span} {own}")


if __name__ == "__main__":
    main()
