"""What a coupled heat–moisture scene's default training box costs the Krylov reduction, and what giving
``[reduction] bounds`` saves (aromm.reduction.training_box).

The scene is tests/petsc_moisture_krylov_cases.py's (a 6×5×4 two-phase image, Q1, heat and vapour exchange at z0,
fluxes at z1, exchange with dry air at x1), assembled and reduced on the scipy engine with ``method="krylov"`` and
the defaults otherwise (tolerance 1e-5, at most 10 greedy points, certificate by size: on at this size), no cache.
Without ``--bounds`` the box is the default one (each material parameter × [1/10, 10]: k, c, ξ, D_φ, δ_p of both
phases, ten axes, so 64 Sobol points and the upper corner); with ``--bounds`` the two-axis box of that test module
(fibre.k ∈ [0.2, 0.6] × gas.D_φ ∈ [5e-10, 5e-9]).

Prints the axes and training points, then CPU seconds (process_time) and wall seconds of the build, the CPU seconds
spent in the greedy's certified bound (:class:`aromm.reduction.certified.SpanBound` calls: the Gram matrices of the
growing span and the bound's evaluation at every training point) and, of those, in the evaluations
(:func:`aromm.reduction.certificate.error_bound` as the greedy calls it, with their count), the order and greedy
points, the error at the scene's values against the exact full model (:func:`aromm.full.exact.exact_outputs`)
beside the truth's rounding there (:func:`aromm.full.exact.rounding`), the greedy's estimate and the certified bound
(worst over the training grid), and the load average.  Run each box in its own process:

    OMP_NUM_THREADS=1 python benchmarks/training_box_cost.py              # default ten-axis box (≈ 400 CPU s)
    OMP_NUM_THREADS=1 python benchmarks/training_box_cost.py --bounds     # the two-axis box

Measured at f3426bf (record benchmarks/records/training_box_cost_f3426bf.txt, load 0.6–1.9): the ten-axis box 183.9
CPU s (68 bound evaluations in the greedy), tolerance missed at 10 points (bound 1.9e-3); the two-axis box 112.2 CPU s
(103 evaluations), tolerance met (bound 9.7e-6), against 143.6 CPU s (175) for the code before the lazy evaluation
run beside it.  Earlier records: c1663b5 (252.3 / 144.1 CPU s), 3343793 (423.5 / 237.4: the Gram matrices not
contiguous, the last bounds evaluated twice).

Record: benchmarks/records/training_box_cost_<commit>.txt.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the test helpers' scene and box

import petsc_moisture_krylov_cases as cases

import aromm
from aromm.full.exact import exact_outputs, rounding
from aromm.reduction import certified
from aromm.reduction.training_box import material_box, training_set
from aromm.scene.scene_file import assemble


class Clock:
    """CPU seconds and calls of a wrapped function."""

    def __init__(self) -> None:
        self.seconds, self.calls = 0.0, 0

    def wrap(self, function: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.process_time()
            try:
                return function(*args, **kwargs)
            finally:
                self.seconds += time.process_time() - start
                self.calls += 1
        return timed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bounds", action="store_true", help=f"the two-axis box {cases.BOX} instead of the default")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    system = assemble(cases.scene("q1"))
    assert system.time is not None
    given = tuple((name, lo, hi) for name, (lo, hi) in cases.BOX.items()) if args.bounds else ()
    box = material_box(system, given)
    print(f"{'given' if args.bounds else 'default'} box, {len(box)} axes: "
          + ", ".join(f"{name} {lo:.3g}–{hi:.3g}" for name, lo, hi in box))
    print(f"{len(training_set(box))} training points, {system.n} unknowns, load average {os.getloadavg()[0]:.2f}, "
          f"OMP_NUM_THREADS={os.environ['OMP_NUM_THREADS']}", flush=True)
    greedy, evaluations = Clock(), Clock()
    certified.SpanBound.__call__ = greedy.wrap(certified.SpanBound.__call__)  # type: ignore[method-assign]
    certified.error_bound = evaluations.wrap(certified.error_bound)  # what SpanBound.__call__ calls
    cpu, wall = time.process_time(), time.perf_counter()
    rom = aromm.reduce(system, method="krylov", cache=False, **({"bounds": cases.BOX} if args.bounds else {}))
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    times = system.time.times
    error = np.abs(rom.simulate({}, times).as_array() - exact_outputs(system, {}, times)).max()
    floor = rounding(system, {}, times).max()
    print(f"build {cpu:.1f} CPU s ({wall:.1f} s wall); greedy's certified bound {greedy.seconds:.1f} CPU s "
          f"({100 * greedy.seconds / cpu:.0f} %) in {greedy.calls} steps, of which its evaluations "
          f"{evaluations.seconds:.1f} CPU s ({100 * evaluations.seconds / cpu:.0f} %, {evaluations.calls} calls, "
          f"{evaluations.seconds / max(evaluations.calls, 1):.3f} s each); the built model's certificate "
          f"{float(rom.info.get('certify_seconds', float('nan'))):.1f} CPU s (certified(): its worst bound over the "
          "training grid)")
    print(f"order {rom.order}, greedy points {rom.info.get('krylov_points')}, converged {rom.info.get('converged')}; "
          f"error at the scene's values {error:.3g} (truth's rounding {floor:.2g}), estimate "
          f"{float(rom.info.get('reference_error', float('nan'))):.3g}, certified bound "
          f"{float(rom.info.get('error_bound', float('nan'))):.3g} (worst over the training grid); load average "
          f"{os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
