"""``aromm.reduce(..., engine="petsc")``: the AROMM reduced model with the offline work on PETSc/SLEPc.

The steps and defaults are those of :func:`aromm.reduction.offline.reduce` [Chavez2020, § 3]: the detailed basis
(constants, Steklov, Dirichlet, correction modes) is computed distributed (aromm.engines.petsc.basis), every
term is projected onto it (aromm.engines.petsc.projection), and from there on the work is on Ñ × Ñ matrices
that every rank holds: reference cases, amalgam (or POD) and the reference error are
:func:`aromm.reduction.offline.reduce_detailed` itself.  Collective: every rank calls it and returns the same model;
rank 0 alone reads and writes the cache (the key is a content hash of the image layers, the scene and the options,
independent of the number of ranks).
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from aromm.core.cache import NpzCache, content_key
from aromm.core.errors import InputError
from aromm.core.system import ThermalSystem
from aromm.engines.petsc import convert, linear, runtime
from aromm.engines.petsc.assembly import DistributedSystem, DistributedTerm, assemble_boxes, distribute_system
from aromm.engines.petsc.basis import compute_basis, correction_count, with_corrections
from aromm.engines.petsc.memory import StageMemory
from aromm.engines.petsc.problem import VoxelProblem
from aromm.engines.petsc.projection import project
from aromm.reduction.corrections import correction_samples
from aromm.reduction.modal_bases import split_counts
from aromm.reduction.offline import (
    ReferenceCase,
    at_reference,
    mode_counts,
    reduce_detailed,
    reduction_info,
    relaxation_case,
    resolve_cache,
    resolve_reductor,
)
from aromm.reduction.reductors import Reductor
from aromm.reduction.rom import ReducedModel, from_arrays, to_arrays
from aromm.scene.scene_file import Scene

_VERSION = 2  # 2: image digest independent of the cut (boxes)

Source = ThermalSystem | Scene | VoxelProblem | DistributedSystem


def distributed(source: Source, comm: Any) -> DistributedSystem:
    """A voxel scene or problem assembled by boxes; a ThermalSystem (held by every rank) split by rows."""
    if isinstance(source, DistributedSystem):
        return source
    if isinstance(source, ThermalSystem):
        return distribute_system(source, comm)
    problem = source if isinstance(source, VoxelProblem) else VoxelProblem.from_scene(source)
    return assemble_boxes(problem, comm)


def relaxed(system: DistributedSystem, values: Mapping[str, float]) -> tuple[DistributedSystem, ReferenceCase]:
    """The relaxation case of [Chavez2020, § 3.2] (aromm.reduction.offline.relaxation_case) on the distributed
    operators."""
    case = relaxation_case(system.template, values)
    names = set(case.system.conductance.names)
    h = case.system.conductance["H_boundary"]
    conductance = (*(t for t in system.conductance if t.name in names),
                   DistributedTerm(h.name, h.coefficient, system.boundary, h.role))
    return replace(system, template=case.system, conductance=conductance, load=(), dirichlet={},
                   observation={}), case


def _boundary_count(system: DistributedSystem) -> int:
    diagonal = convert.array(system.boundary.getDiagonal())
    return int(runtime.allsum([np.count_nonzero(diagonal > 0)], system.comm)[0])


def _cached(store: NpzCache | None, key: str, comm: Any) -> ReducedModel | None:
    """Rank 0 reads the cache and broadcasts what it found (small arrays)."""
    if store is None:
        return None
    stored = store.load("rom", key) if runtime.is_root(comm) else None
    stored = runtime.mpi(comm).bcast(stored, root=0)
    if stored is None:
        return None
    rom = from_arrays(stored)
    return replace(rom, info={**rom.info, "cached": 1, "offline_seconds": 0.0})


def reduce(
    source: Source,
    order: int = 200,
    *,
    modes: int | None = None,
    n_dirichlet: int | None = None,
    n_steklov: int | None = None,
    basis_values: Mapping[str, float] | None = None,
    reference_values: Mapping[str, float] | None = None,
    references: Sequence[Source | ReferenceCase] = (),
    relaxation: bool = True,
    corrections: bool | Sequence[Mapping[str, float]] = True,
    method: str | Reductor = "aromm",
    solver: str = "gamg",
    cache: bool | str | os.PathLike[str] | NpzCache | None = True,
    comm: Any = None,
) -> ReducedModel:
    """AROMM reduced model of ``source`` at order ``order`` on the petsc engine (options of aromm.reduce).

    ``source``: a voxel :class:`~aromm.scene.scene_file.Scene` or box-read :class:`VoxelProblem` (assembled by
    boxes), or a ThermalSystem every rank holds (distributed by rows).  ``solver``: inner solver of the eigensolvers
    and of the correction solves, ``"gamg"`` (CG + GAMG) or ``"mumps"`` (Cholesky).
    """
    reductor = resolve_reductor(method)
    if isinstance(order, bool) or not isinstance(order, int | np.integer) or order < 1:
        raise InputError(f"order must be a positive integer, got {order!r}")
    solver = linear.check_solver(solver)
    comm = comm if comm is not None else runtime.world()
    start = time.perf_counter()
    memory = StageMemory(comm)
    memory.start("assembly")
    system = distributed(source, comm)
    others = [distributed(r.system if isinstance(r, ReferenceCase) else r, comm) for r in references]
    stages = {"assembly_seconds": time.perf_counter() - start}
    for other in others:
        if other.n != system.n:
            raise InputError(f"reference case {other.description!r} has {other.n} unknowns, the system {system.n}")
    template = system.template
    n_d, n_s = mode_counts(int(order), modes, n_dirichlet, n_steklov,
                           lambda total: split_counts(total, system.n, _boundary_count(system)))
    ref_vals = at_reference(template, reference_values or {})
    samples = (correction_samples(template, basis_values) if corrections is True
               else [] if corrections is False else [dict(s) for s in corrections])
    key = content_key("petsc", _VERSION, system.fingerprint, order, n_d, n_s, basis_values or {}, reductor.name,
                      solver, relaxation, samples, [o.fingerprint for o in others], reference_values or {},
                      [(dict(r.values), r.times) for r in references if isinstance(r, ReferenceCase)])
    store = resolve_cache(cache)
    found = _cached(store, key, comm)
    if found is not None:
        return found

    memory.start("basis")
    basis = compute_basis(system, n_d, n_s, basis_values, solver, reserve=correction_count(system, samples))
    clock = time.perf_counter()
    memory.start("corrections")
    if samples:
        basis = with_corrections(system, basis, samples, basis_values, solver)
    stages["corrections_seconds"] = time.perf_counter() - clock
    clock = time.perf_counter()
    memory.start("projection")
    memo: dict[int, np.ndarray] = {}
    detailed = project(system, basis.vectors, memo)
    cases = [(detailed, ReferenceCase(template, ref_vals, name="system"))]
    for other, given in zip(others, references, strict=True):
        if isinstance(given, ReferenceCase):
            case = replace(given, system=other.template)
        else:
            case = ReferenceCase(other.template, at_reference(other.template, reference_values or {}))
        cases.append((project(other, basis.vectors, memo), case))
    if relaxation:
        cooled, relax = relaxed(system, ref_vals)
        cases.append((project(cooled, basis.vectors, memo), relax))
    stages["projection_seconds"] = time.perf_counter() - clock
    clock = time.perf_counter()
    memory.start("amalgam")
    rom, err = reduce_detailed(detailed, cases, basis, int(order), reductor, check_values=ref_vals)
    stages["amalgam_seconds"] = time.perf_counter() - clock
    info = {**reduction_info(rom, basis, reductor.name, seconds=time.perf_counter() - start, error=err, key=key),
            **stages, **memory.record(), "basis_bytes": runtime.allmax(basis.vectors.nbytes, comm),
            "engine": "petsc", "ranks": runtime.size(comm), "solver": solver}
    rom = replace(rom, info=info)
    if store is not None and runtime.is_root(comm):
        store.save("rom", key, to_arrays(rom))
    return rom
