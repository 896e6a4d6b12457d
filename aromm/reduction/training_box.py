"""The Krylov reduction's parameter box and its training set (:mod:`aromm.reduction.krylov`).

A box is (name, lower, upper) per parameter (SI); without one, :data:`DEFAULT_FACTOR` around the scene's material
parameters.  The greedy's candidate points are a log-spaced tensor grid of the box, or above six axes points of a
low-discrepancy sequence (:func:`training_set`).
"""

from __future__ import annotations

import itertools
import logging

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import ThermalSystem

Box = tuple[tuple[str, float, float], ...]

log = logging.getLogger(__name__)

#: Default box around the scene's values when none is given: each material parameter × [1/10, 10] (the extremes
#: of the POD-greedy's training factors, aromm.reduction.greedy.TRAINING_FACTORS).
DEFAULT_FACTOR = 10.0
#: Most points of the default training set (:func:`training_set`): 2⁶ = 64 corners of a six-axis box, the tensor
#: grid's largest.  A coupled heat–moisture scene's default box has ten axes (k, c, ξ, D_φ, δ_p of two phases): on a
#: 6×5×4 image (tests/petsc_moisture_krylov_cases.py's scene, scipy engine, defaults) its build over 65 points took
#: 183.9 CPU s and missed its tolerance at 10 greedy points; over that module's two-axis box 112.2 CPU s, met
#: (``python benchmarks/training_box_cost.py [--bounds]``, one BLAS thread, load 0.6–1.9, record
#: benchmarks/records/training_box_cost_f3426bf.txt; 423.5 and 237.4 CPU s at 3343793, before the certificate's Gram
#: matrices were kept contiguous and the greedy's bound was evaluated lazily).  Its 1,024 corners would multiply the
#: greedy's evaluations by about 16 (not measured).
TRAINING_POINTS = 64  # a power of 2: the Sobol sequence's balance
#: Most axes of the default tensor grid (2 points per axis, at most :data:`TRAINING_POINTS`): 6.
GRID_AXES = TRAINING_POINTS.bit_length() - 1


def material_box(system: ThermalSystem, bounds: Box) -> Box:
    """``bounds`` checked against the system, or :data:`DEFAULT_FACTOR` around its material parameters."""
    if bounds:
        unknown = sorted({name for name, _, _ in bounds} - system.parameter_names)
        if unknown:
            raise InputError(f"krylov bounds: unknown parameter(s) {unknown}; the system has "
                             f"{sorted(system.parameter_names)}")
        return bounds
    terms = (*system.capacity.terms, *system.conductance.with_role("conduction").terms)
    names = sorted({p for t in terms for p in t.coefficient.params})
    return tuple((n, float(system.parameters[n]) / DEFAULT_FACTOR, float(system.parameters[n]) * DEFAULT_FACTOR)
                 for n in names)


def say_default(bounds: Box, box: Box) -> None:
    """Say before a build over the default box of more than :data:`GRID_AXES` axes (a coupled heat–moisture scene's
    ten) that it is slow and how to avoid it: a WARNING record, in the log and on a terminal (aromm.cli.logs)."""
    if not bounds and len(box) > GRID_AXES:
        log.warning("no bounds given: the reduced model is trained over every material parameter × [1/%g, %g] (%d "
                    "axes: %s); that costs minutes even on a small image — give the box of the parameters that will "
                    "vary ([reduction] bounds in the scene, or identify's --unknown ranges)", DEFAULT_FACTOR,
                    DEFAULT_FACTOR, len(box), ", ".join(name for name, _, _ in box))


def training_set(box: Box, per_axis: int = 0) -> list[dict[str, float]]:
    """Tensor grid log-spaced along every axis of the box (``per_axis`` 0: by the number of axes); left to itself
    (``per_axis`` 0) a box of more than :data:`GRID_AXES` axes, whose corners alone would exceed
    :data:`TRAINING_POINTS`, gets that many points of the unscrambled Sobol sequence instead, log-spaced (its first
    point is the lower corner), and the upper corner [Sobol1967].

    >>> [len(training_set(tuple((f"p{i}.k", 0.1, 10.0) for i in range(d)))) for d in (2, 4, 6, 10)]  # 2¹⁰ corners
    [25, 81, 64, 65]
    """
    count = per_axis or (5 if len(box) <= 2 else 3 if len(box) <= 4 else 2)
    if per_axis == 0 and len(box) > GRID_AXES:
        from scipy.stats import qmc

        sobol = qmc.Sobol(len(box), scramble=False).random_base2(int(np.log2(TRAINING_POINTS)))
        unit = np.vstack([sobol, np.ones(len(box))])
        lo, hi = np.array([[lo, hi] for _, lo, hi in box]).T
        return [{name: float(v) for (name, _, _), v in zip(box, lo * (hi / lo) ** u, strict=True)} for u in unit]
    axes = [np.geomspace(lo, hi, count) if hi > lo else np.array([lo]) for _, lo, hi in box]
    return [{name: float(v) for (name, _, _), v in zip(box, point, strict=True)} for point in itertools.product(*axes)]


def centre(box: Box) -> dict[str, float]:
    return {name: float(np.sqrt(lo * hi)) for name, lo, hi in box}
