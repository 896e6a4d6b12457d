"""``aromm.reduce(..., method="krylov")`` on the scipy engine: lifting, engine, cache, fields.

The reduction itself (:mod:`aromm.reduction.krylov`) sees only the engine protocol; this module picks the engine
(:class:`~aromm.reduction.scipy_engine.ScipyEngine`), lifts fixed temperatures at the basis values
(:mod:`aromm.reduction.lifting`), keys the cache by :func:`aromm.reduction.model_key.system_key` (operators, values
outside the training box, time grid, every option), and keeps Ψ for fields.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import replace

from aromm.core.cache import NpzCache
from aromm.core.system import FloatArray, ThermalSystem
from aromm.reduction import krylov
from aromm.reduction.certified import certified, span_bound
from aromm.reduction.lifting import lift
from aromm.reduction.model_key import system_key
from aromm.reduction.rom import ReducedModel, from_arrays, one_blas_thread, to_arrays
from aromm.reduction.scipy_engine import SOLVERS, ScipyEngine
from aromm.reduction.training_box import centre, material_box, training_set

WithFields = Callable[[ReducedModel, ThermalSystem, FloatArray, Mapping[str, float], str], ReducedModel]


def reduce_krylov(system: ThermalSystem, order: int, reductor: krylov.KrylovReductor, *,
                  basis_values: Mapping[str, float], solver: str, store: NpzCache | None, progress: bool, fields: bool,
                  with_fields: WithFields) -> ReducedModel:
    """The Krylov reduced model of ``system`` (fixed temperatures lifted here), from the cache when it is there.

    ``solver`` names the factorisation of the lifting, and of the shifted solves when the reductor leaves its
    own ``solver`` on ``"auto"`` and ``solver`` is one of the engine's; ``with_fields`` attaches Ψ and the
    lifting to the model (``aromm.reduction.offline``)."""
    reductor.check()
    linear = reductor.solver if reductor.solver != "auto" or solver not in SOLVERS else solver
    box = material_box(system, reductor.bounds)
    key = system_key(system, box, order, reductor.cache_key, dict(basis_values), solver, linear)
    if store is not None:
        stored = store.load("rom", key)
        kept = store.load("krylov-basis", key) if fields and stored is not None else None
        if stored is not None and (not fields or kept is not None):
            rom = from_arrays(stored).with_parameters(system.parameters)
            rom = replace(rom, info={**rom.info, "cached": 1, "offline_seconds": 0.0})
            return with_fields(rom, system, kept["psi"], basis_values, solver) if kept is not None else rom
    start = time.perf_counter()
    lifted = lift(system, basis_values, solver)
    engine = ScipyEngine(lifted, linear)
    with one_blas_thread():  # small dense algebra dominates: threaded BLAS only fights for the shared cores
        bound = span_bound(engine, lifted, reductor, box)
        rom, psi, info = krylov.krylov_model(engine, lifted, reductor, order, box, progress=progress, bound=bound)
        rom, extra = certified(engine, lifted, rom, psi, certify=reductor.certify, reference=centre(box),
                               training=training_set(box, reductor.per_axis), rtol=reductor.rtol,
                               tolerance=reductor.tolerance, certificate=bound.final if bound else None,
                               finer=bound.finer if bound else None,
                               finer_bounds=bound.finer_bounds if bound else None)
    info.update(extra)
    info.update({"offline_seconds": time.perf_counter() - start, "cached": 0, "key": key,
                 "lifted_faces": len(system.dirichlet)})
    rom = replace(rom, info=info)
    if store is not None:
        store.save("rom", key, to_arrays(rom))
        if fields:
            store.save("krylov-basis", key, {"psi": engine.to_numpy(psi)})
    return with_fields(rom, system, engine.to_numpy(psi), basis_values, solver) if fields else rom
