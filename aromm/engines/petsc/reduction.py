"""``aromm.reduce(..., engine="petsc")``: the AROMM reduced model with the offline work on PETSc/SLEPc.

The pipeline is :mod:`aromm.reduction.modal_pipeline` itself [Chavez2020, § 3]; :class:`PetscModalEngine` provides its
two distributed steps: the detailed basis (constants, Steklov, Dirichlet, correction modes: aromm.engines.petsc.basis)
and the projection of every term onto it (aromm.engines.petsc.projection).  From there on the work is on Ñ × Ñ
matrices that every rank holds.  Collective: every rank calls it and returns the same model; rank 0 alone reads and
writes the cache (the key is the pipeline's, made of the image layers, the scene and the options, independent of
the number of ranks).
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from aromm.core.cache import NpzCache
from aromm.core.errors import InputError
from aromm.core.system import ThermalSystem
from aromm.engines.petsc import convert, linear, runtime
from aromm.engines.petsc.assembly import DistributedSystem, DistributedTerm, assemble_boxes, distribute_system
from aromm.engines.petsc.basis import compute_basis, correction_count, with_corrections
from aromm.engines.petsc.eigen import choose
from aromm.engines.petsc.memory import StageMemory
from aromm.engines.petsc.problem import VoxelProblem
from aromm.engines.petsc.projection import project
from aromm.reduction import modal_pipeline
from aromm.reduction.modal_bases import ModalBasis, split_counts
from aromm.reduction.modal_pipeline import ReferenceCase, reference_cases, relaxation_case
from aromm.reduction.offline import resolve_cache, resolve_reductor
from aromm.reduction.rom import ReducedModel, from_arrays, to_arrays
from aromm.scene.reduction_section import ReductionSettings
from aromm.scene.scene_file import Scene

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
    """The relaxation case of [Chavez2020, § 3.2] (aromm.reduction.modal_pipeline.relaxation_case) on the
    distributed operators."""
    case = relaxation_case(system.template, values)
    names = set(case.system.conductance.names)
    h = case.system.conductance["H_boundary"]
    conductance = (*(t for t in system.conductance if t.name in names),
                   DistributedTerm(h.name, h.coefficient, system.boundary, h.role))
    return replace(system, template=case.system, conductance=conductance, load=(), dirichlet={},
                   observation={}), case


def cached(store: NpzCache | None, key: str, comm: Any) -> ReducedModel | None:
    """Rank 0 reads the cache and broadcasts what it found (small arrays)."""
    if store is None:
        return None
    stored = store.load("rom", key) if runtime.is_root(comm) else None
    stored = runtime.mpi(comm).bcast(stored, root=0)
    if stored is None:
        return None
    rom = from_arrays(stored)
    return replace(rom, info={**rom.info, "cached": 1, "offline_seconds": 0.0})


class PetscModalEngine:
    """The full model distributed by rows (``system``) and the reference cases on the same image (``others``, with
    the cases they were given as), for :func:`aromm.reduction.modal_pipeline.build`.  ``solver``: inner solver of
    the eigensolvers and of the correction solves, ``"gamg"`` (CG + GAMG) or ``"mumps"`` (Cholesky);
    ``eigensolver``: ``"arpack"`` (shift-invert), ``"lobpcg"`` (preconditioned, aromm.engines.petsc.eigen) or
    ``"auto"``."""

    def __init__(self, system: DistributedSystem, others: Sequence[tuple[DistributedSystem, Source | ReferenceCase]],
                 reference: Mapping[str, float], solver: str, memory: StageMemory, *,
                 eigensolver: str = "auto") -> None:
        self.system, self.others, self.solver, self.memory = system, others, solver, memory
        self.eigensolver = choose(eigensolver)
        self.iterations: dict[str, float] = {}
        self.cases = reference_cases(system.template, [replace(given, system=other.template)
                                                       if isinstance(given, ReferenceCase) else other.template
                                                       for other, given in others], reference)
        self.stages: dict[str, float] = {}
        self.current, self.clock = "", time.perf_counter()

    @property
    def template(self) -> ThermalSystem:
        return self.system.template

    def fingerprints(self) -> list[Any]:
        return [(s.fingerprint, dict(c.values), c.times)
                for s, c in zip((self.system, *(o for o, _ in self.others)), self.cases, strict=True)]

    def split(self, total: int) -> tuple[int, int]:
        diagonal = convert.array(self.system.boundary.getDiagonal())
        on_gamma = int(runtime.allsum([np.count_nonzero(diagonal > 0)], self.system.comm)[0])
        return split_counts(total, self.system.n, on_gamma)

    def stage(self, label: str, detail: str) -> None:
        """Seconds and peak memory per stage (``info``: ``<label>_seconds`` and the StageMemory record)."""
        now = time.perf_counter()
        if self.current:
            self.stages[f"{self.current}_seconds"] = now - self.clock
        self.current, self.clock = label, now
        if label:
            self.memory.start(label)
        else:
            self.memory.stop()

    def modal_basis(self, n_dirichlet: int, n_steklov: int, values: Mapping[str, float],
                    samples: list[dict[str, float]]) -> ModalBasis:
        basis = compute_basis(self.system, n_dirichlet, n_steklov, values, self.solver,
                              reserve=correction_count(self.system, samples), eigensolver=self.eigensolver)
        self.iterations = {k: float(basis.info[k]) for k in ("steklov_iterations", "dirichlet_iterations")}
        if not samples:
            return basis
        self.stage("corrections", f"correction vectors ({len(samples)} parameter samples)")
        return with_corrections(self.system, basis, samples, values, self.solver)

    def projected(self, basis: ModalBasis, relaxation: bool) -> list[tuple[ReducedModel, ReferenceCase]]:
        memo: dict[int, np.ndarray] = {}
        systems = [self.system, *(o for o, _ in self.others)]
        out = [(project(s, basis.vectors, memo), case) for s, case in zip(systems, self.cases, strict=True)]
        if relaxation:
            cooled, case = relaxed(self.system, self.cases[0].values)
            out.append((project(cooled, basis.vectors, memo), case))
        return out


def reduce(source: Source, settings: ReductionSettings, *, references: Sequence[Source | ReferenceCase] = (),
           cache: bool | str | os.PathLike[str] | NpzCache | None = True, comm: Any = None) -> ReducedModel:
    """AROMM reduced model of ``source`` as ``settings`` say (the options of aromm.reduce, the method resolved:
    :func:`aromm.api.reduce`) on the petsc engine.

    ``source``: a voxel :class:`~aromm.scene.scene_file.Scene` or box-read :class:`VoxelProblem` (assembled by
    boxes), or a ThermalSystem every rank holds (distributed by rows).  ``settings.solver``: ``"gamg"`` or
    ``"mumps"`` (:func:`aromm.engines.petsc.linear.check_solver`); ``settings.eigensolver``: the eigenbases by
    SLEPc's shift-invert (``"arpack"``, also ``"auto"``) or preconditioned eigensolver (``"lobpcg"``,
    :func:`aromm.engines.petsc.eigen.choose`).
    """
    reductor = resolve_reductor(settings.method)
    solver = linear.check_solver(settings.solver)
    comm = comm if comm is not None else runtime.world()
    start = time.perf_counter()
    memory = StageMemory(comm)
    memory.start("assembly")
    system = distributed(source, comm)
    others = [(distributed(r.system if isinstance(r, ReferenceCase) else r, comm), r) for r in references]
    assembly = time.perf_counter() - start
    for other, _ in others:
        if other.n != system.n:
            raise InputError(f"reference case {other.description!r} has {other.n} unknowns, the system {system.n}")
    engine = PetscModalEngine(system, others, settings.reference, solver, memory,
                              eigensolver=settings.eigensolver)
    chosen = modal_pipeline.plan(engine, replace(settings, solver=solver), reductor)
    store = resolve_cache(cache)
    found = cached(store, chosen.key, comm)
    if found is not None:
        return found
    with runtime.root_logs(comm, modal_pipeline.__name__):  # its log lines once, not once per rank
        rom, _, basis = modal_pipeline.build(engine, replace(settings, solver=solver), reductor, chosen)
    engine.stage("", "done")
    info = {**rom.info, "offline_seconds": time.perf_counter() - start, "assembly_seconds": assembly, **engine.stages,
            **memory.record(), "basis_bytes": runtime.allmax(basis.vectors.nbytes, comm), "engine": "petsc",
            "ranks": runtime.size(comm), "solver": solver, "eigensolver": engine.eigensolver, **engine.iterations}
    rom = replace(rom, info=info)
    if store is not None and runtime.is_root(comm):
        store.save("rom", chosen.key, to_arrays(rom))
    return rom
