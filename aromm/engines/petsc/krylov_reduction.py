"""``aromm.reduce(..., method="krylov", engine="petsc")``: the eigen-free Krylov reduced model built on PETSc KSP.

The source is assembled by boxes (a voxel scene) or distributed by rows (a ThermalSystem every rank holds)
as for the engine's other reductions (:func:`aromm.engines.petsc.reduction.distributed`); the reduction is
:func:`aromm.reduction.krylov.krylov_model` itself on :class:`~aromm.engines.petsc.krylov_engine.PetscKrylovEngine`,
so it builds the span of the scipy engine (same parameter points, shifts, moments and compression) with CG + GAMG
solves and sums over the ranks.  The certified output error bound (:mod:`aromm.reduction.certified`, when asked or
by size) is formed the same way: its shifted solves by the same KSP, its Gram matrices summed over the ranks.
Collective: every rank calls it and returns the same model; rank 0 alone reads and writes the cache (keyed by the
content of the image, the scene and every option, not by the number of ranks).  No SLEPc call is made; the
reductor's ``krylov:`` log lines are said by rank 0 only.
"""

from __future__ import annotations

import os
import time
from dataclasses import replace
from typing import Any

import numpy as np

from aromm.core.cache import NpzCache
from aromm.core.errors import InputError
from aromm.engines.petsc import runtime
from aromm.engines.petsc.krylov_engine import SOLVERS, PetscKrylovEngine
from aromm.engines.petsc.memory import StageMemory
from aromm.engines.petsc.reduction import Source, cached, distributed
from aromm.reduction.certified import CERTIFY_BELOW, certified, span_bound
from aromm.reduction.krylov import KrylovReductor, krylov_model
from aromm.reduction.model_key import system_key
from aromm.reduction.offline import resolve_cache
from aromm.reduction.rom import ReducedModel, one_blas_thread, to_arrays
from aromm.reduction.training_box import centre, material_box, training_set


def reduce_krylov(source: Source, order: int, reductor: KrylovReductor, *, solver: str = "auto",
                  cache: bool | str | os.PathLike[str] | NpzCache | None = True, progress: bool = False,
                  comm: Any = None) -> ReducedModel:
    """The Krylov reduced model of ``source`` at order ≤ ``order`` (options of :class:`KrylovReductor`).

    ``solver``: the shifted solves' PETSc solver (:data:`~aromm.engines.petsc.krylov_engine.SOLVERS`: ``"auto"``
    geometric multigrid on the DMDA where the grid halves, else GAMG), unless the reductor names one itself."""
    reductor.check()
    if isinstance(order, bool) or not isinstance(order, int | np.integer) or order < 1:
        raise InputError(f"order must be a positive integer, got {order!r}")
    linear_solver = reductor.solver if reductor.solver != "auto" else solver
    if linear_solver not in SOLVERS:
        raise InputError(f"krylov reduction on the petsc engine: unknown solver {linear_solver!r}; allowed: "
                         f"{', '.join(SOLVERS)}")
    comm = comm if comm is not None else runtime.world()
    start = time.perf_counter()
    cpu = time.process_time()
    memory = StageMemory(comm)
    memory.start("assembly")
    system = distributed(source, comm)
    assembly = time.perf_counter() - start
    box = material_box(system.template, reductor.bounds)
    key = system_key(system.template, box, "petsc-krylov", int(order), reductor.cache_key, linear_solver,
                     fingerprint=system.fingerprint)
    store = resolve_cache(cache)
    found = cached(store, key, comm)
    if found is not None:
        return found.with_parameters(system.template.parameters)
    memory.start("krylov")
    engine = PetscKrylovEngine(system, linear_solver)
    try:
        with one_blas_thread(), runtime.root_logs(comm, krylov_model.__module__):
            bound = span_bound(engine, system.template, reductor, box)
            rom, psi, info = krylov_model(engine, system.template, reductor, int(order), box,
                                          progress=progress and runtime.is_root(comm), bound=bound)
            rom, extra = certified(engine, system.template, rom, psi, certify=reductor.certify, reference=centre(box),
                                   training=training_set(box, reductor.per_axis), rtol=reductor.rtol,
                                   tolerance=reductor.tolerance, certificate=bound.final if bound else None,
                                   finer=bound.finer if bound else None,
                                   finer_bounds=bound.finer_bounds if bound else None,
                                   after_below=CERTIFY_BELOW)  # its wide blocks iterate (KSP)
            info.update(extra)
    finally:
        engine.close()
    info.update({"offline_seconds": time.perf_counter() - start, "assembly_seconds": assembly,
                 "offline_cpu_seconds": runtime.allmax(time.process_time() - cpu, comm), "cached": 0, "key": key,
                 "engine": "petsc", "ranks": runtime.size(comm), **memory.record()})
    rom = replace(rom, info=info)
    if store is not None and runtime.is_root(comm):
        store.save("rom", key, to_arrays(rom))
    return rom
