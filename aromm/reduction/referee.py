"""A modal model certified over a box through a Krylov referee (issue 35).

The direct certificate of a Galerkin model (:mod:`aromm.reduction.certificate`) multiplies a primal and a dual
residual norm; for a modal model (amalgam, POD, greedy) at its own order both fall slowly, and the bound runs up to
10⁴× its actual error (a fixed-temperature face at order 40, docs/method/krylov.md).  A Krylov model of the same full
model over a box, certified itself, referees it: by the triangle inequality, at every parameter point μ::

    max_t |y_modal − y| ≤ max_t |y_modal − y_Krylov| + bound_Krylov(μ)

(:func:`aromm.reduction.certificate.through_finer`; the difference exact in time).  Where the referee is far more
accurate than the modal model, the right side is nearly the modal model's actual error.  Measured on 8³ bodies,
amalgam of order 40, 20 Latin-hypercube points (``python benchmarks/certified_bound.py --method aromm --order 40
--referee``): effectivities 1.0–2.5 (fixed face; 6–24,000 directly), 1.0–1.03 (two phases), 1.0–1.14 (load history).

A modal model has no training box of its own (it serves every value, and its cache key holds none); the box is the
scene's ``[reduction] bounds``, or ``identify``'s ``--unknown`` ranges joined with them.  :func:`aromm.api.reduce`
takes the referee from the cache or builds it: the Krylov model ``method="krylov"`` builds over that box with the
same tolerance, certify and solver settings (one cache entry serves both), only for a certified modal model; it costs
one Krylov build.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from aromm.reduction.certified import worst_bound
from aromm.reduction.rom import ReducedModel
from aromm.reduction.training_box import training_set
from aromm.scene.reduction_section import ReductionSettings

#: The referee's order asked: the Krylov default (the compression keeps what its tolerance needs).
REFEREE_ORDER = ReductionSettings().order


def refereed(rom: ReducedModel, referee: ReducedModel, worst: float | None = None) -> ReducedModel:
    """``rom`` (a certified modal model) with the certified Krylov model ``referee`` of the same full model as its
    ``finer`` model, and in its info the worst bound (°C) over the referee's training grid and the model's own values
    (``error_bound``: ``worst`` when it was computed before for these two models, :func:`aromm.api.reduce` keeps
    it), the referee's order and its own worst bound.  An uncertified referee (too large to certify) leaves ``rom``'s
    bound as it was, and its info says why."""
    if referee.certificate is None:
        return replace(rom, info={**rom.info, "referee": f"none: {referee.info.get('certificate', 'not certified')}"})
    rom = replace(rom, finer=replace(referee, info={}))
    points: list[Mapping[str, float]] = [*training_set(referee.box), dict(rom.parameters)]
    return replace(rom, info={**rom.info, "error_bound": worst_bound(rom, points) if worst is None else worst,
                              "referee_order": referee.order,
                              "referee_bound": float(referee.info.get("error_bound", float("nan"))),
                              "certificate": "primal-dual contour bound, through a certified Krylov referee over "
                                             f"the box ({len(points)} points)"})
