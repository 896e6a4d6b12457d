"""Offline reduction on one process [Chavez2020, § 3]: ``aromm.reduce`` on the scipy engine.

:func:`reduce` reads the :class:`~aromm.scene.reduction_section.ReductionSettings`, lifts fixed temperatures, and
runs either the eigen-free Krylov reduction (:mod:`aromm.reduction.krylov_offline`) or the AROMM pipeline of
:mod:`aromm.reduction.modal_pipeline` on :class:`ScipyModalEngine` (modes by ARPACK or LOBPCG, correction vectors,
Galerkin projections in memory), with the cache, progress and temperature fields around it.

1. Detailed basis Φ (:mod:`aromm.reduction.modal_bases`): constants, Steklov and Dirichlet modes at reference properties
   (``basis_values``), enriched by static and first-order correction vectors of the loads.
2. Reference cases, simulated exactly on the detailed modal model (:class:`~aromm.reduction.rom.ReducedModel` on Φ):
   the system itself at ``reference_values``, other scenarios on the same mesh, and the relaxation of the
   body from 30 °C cooled on its whole boundary [Chavez2020, § 3.2].
3. A :class:`~aromm.reduction.reductors.Reductor` (the amalgam by default, POD as a baseline) turns the reference
   excitation states into coefficients A; the reduced model is the detailed one transformed by A.

Reference values are explicit arguments: by default the bases and the reference case use the system's
own parameters.  A scene may state other ones (``[reduction]`` section, e.g. the values of
[Chavez2020, § 3.1–3.2] for the shipped wood scenes); the command line passes them on.
"""

from __future__ import annotations

import contextlib
import logging
import os
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from aromm.core.cache import NpzCache
from aromm.core.errors import InputError, InputWarning
from aromm.core.system import Affine, Coefficient, FloatArray, Term, ThermalSystem
from aromm.linalg.eigensolvers import ProgressCallback
from aromm.reduction import modal_pipeline
from aromm.reduction.amalgam import AmalgamReductor
from aromm.reduction.certified import certified
from aromm.reduction.greedy import PodGreedy
from aromm.reduction.krylov import KrylovReductor
from aromm.reduction.lifting import lift, liftings
from aromm.reduction.modal_pipeline import ReferenceCase, default_modes, relaxation_case
from aromm.reduction.pod import PodReductor
from aromm.reduction.reductors import Reductor
from aromm.reduction.rom import ReducedModel, from_arrays, to_arrays
from aromm.reduction.scipy_engine import DIRECT_BELOW, SOLVERS, ScipyEngine
from aromm.reduction.scipy_modal import ScipyModalEngine
from aromm.scene.reduction_section import REDUCTION_METHODS, ReductionSettings
from aromm.scene.scene_file import Scene, assemble

__all__ = ["METHODS", "REDUCTORS", "ReferenceCase", "ScipyModalEngine", "default_modes", "reduce",
           "relaxation_case", "resolve_cache", "resolve_reductor"]

log = logging.getLogger(__name__)

#: The reductors known by name; any object implementing :class:`~aromm.reduction.reductors.Reductor` is accepted too.
REDUCTORS: Mapping[str, Reductor] = {r.name: r for r in (AmalgamReductor(), PodReductor(), PodGreedy())}
#: Every method by name: "auto" (by size), the reductors, and "krylov" (eigen-free: aromm.reduction.krylov).
METHODS = REDUCTION_METHODS


def resolve_cache(cache: bool | str | os.PathLike[str] | NpzCache | None) -> NpzCache | None:
    """True → the default cache folder; a folder or an NpzCache; False/None → no cache."""
    if cache is None or cache is False:
        return None
    if cache is True:
        return NpzCache()
    if isinstance(cache, NpzCache):
        return cache
    return NpzCache(cache)


def resolve_reductor(method: str | Reductor | KrylovReductor) -> Reductor:
    """The reductor named ``method`` (:data:`REDUCTORS`), or ``method`` itself when it is one."""
    if isinstance(method, str):
        if method not in REDUCTORS:
            raise InputError(f"unknown reduction method {method!r}; allowed: {', '.join(METHODS)}")
        return REDUCTORS[method]
    if not isinstance(method, Reductor):
        raise InputError(f"method must be a name ({', '.join(METHODS)}) or a Reductor, got {type(method).__name__}")
    return method


def reduce(
    system: ThermalSystem | Scene,
    order: int | None = None,
    *,
    settings: ReductionSettings | None = None,
    references: Sequence[ThermalSystem | ReferenceCase] = (),
    cache: bool | str | os.PathLike[str] | NpzCache | None = True,
    progress: bool = False,
    eigen_progress: ProgressCallback | None = None,
    fields: bool = False,
    **options: Any,
) -> ReducedModel:
    """Reduced model of ``system`` at order ``order`` [Chavez2020, § 3], on one process
    (:func:`aromm.api.reduce` chooses between this and the petsc engine).

    How it is built is ``settings`` (:class:`~aromm.scene.reduction_section.ReductionSettings`, default: its
    defaults) with ``order`` and ``options`` (its field names; ``basis_values`` / ``reference_values`` name
    ``basis`` / ``reference``) replaced; ``method="auto"`` (the default) is the Krylov reduction above
    :data:`~aromm.scene.reduction_section.KRYLOV_ABOVE` free unknowns, the amalgam below:

    * Detailed basis: constants + Steklov + Dirichlet modes (aromm.reduction.modal_bases) at the reference properties
      ``basis_values`` (overrides of the system's parameters, default none), ``modes`` = Ñ in total
      (default :func:`default_modes`), split evenly unless ``n_dirichlet`` / ``n_steklov`` are given
      (``n_steklov`` counts the constants).
    * Reference cases (exact simulations of the detailed modal model): the system itself at
      ``reference_values`` (overrides of its parameters, default none), each of ``references`` (other
      scenarios on the same mesh, at the same overrides), and the relaxation from 30 °C cooled on the
      whole boundary (``relaxation``).
    * Fixed temperatures (constant or histories) are lifted at ``basis_values`` (:func:`aromm.reduction.lifting.lift`):
      the basis spans the free unknowns, its Steklov modes vanish on the fixed faces, and the reduced
      model adds the lifting to its outputs; every reference case fixes the same faces.
    * ``corrections``: enrich the basis with static and first-order dynamic correction modes of the
      system's loads (:func:`aromm.reduction.corrections.with_corrections`; an extension of [Chavez2020]) at the
      samples of
      :func:`aromm.reduction.corrections.correction_samples` (True), at given samples, or not at all (False: the
      method of the paper exactly).
    * ``method``: a reductor name (``"aromm"``: amalgam, eq. 9; ``"pod"``: POD–Galerkin baseline, refused
      beyond the rank of its snapshots; ``"greedy"``: multi-point POD-greedy, :mod:`aromm.reduction.greedy`;
      ``"krylov"``: eigen-free rational Krylov over the box ``bounds``, :mod:`aromm.reduction.krylov`, none of the
      modal options apply) or object (its ``cache_key``, when it has one, keys the cache; else its ``name``).
    * ``bounds``: name → (lower, upper), the identification box of ``method="krylov"`` (refused otherwise).
    * ``cache``: True (default folder), a folder, an NpzCache, or False.  Bases and reduced models are
      stored by content hash; a second call with the same inputs loads the result.
    * ``eigensolver``: ``"arpack"`` (shift-invert on a sparse factorisation ``solver``), ``"lobpcg"``
      (:mod:`aromm.linalg.eigensolvers`: memory the basis plus a multigrid preconditioner; the correction vectors
      then use multigrid-preconditioned CG unless ``solver`` names a factorisation) or ``"auto"`` (by
      size).  Every :class:`~aromm.linalg.eigensolvers.EigenProgress` report (converged pairs, iterations) goes
      to ``eigen_progress``, to the log, and with ``progress`` to a bar.  ``basis_storage``: ``"float32"``
      keeps and caches the modes in single precision.
    * ``fields``: keep Ψ (n × r) and the lifting of the fixed temperatures in the model, for
      temperature fields (:meth:`ReducedModel.iter_fields`).  The cache stores Ψ's coefficients on the
      detailed basis (Ñ × r) apart from the model; a cached model asked for ``fields`` rebuilds Ψ from the
      cached detailed basis.
    """
    settings = (settings or ReductionSettings()).updated(order=order, **options)
    if isinstance(system, Scene):
        system = assemble(system, matrix_free=matrix_free_krylov(system, settings, bool(references)))
    for label, given in (("basis_values", settings.basis), ("reference_values", settings.reference)):
        unknown = sorted(set(given) - system.parameter_names)
        if unknown:
            raise InputError(f"{label}: unknown parameter(s) {unknown}; "
                             f"the system has {sorted(system.parameter_names)}")
    method = settings.method_for(system.n, references=bool(references))
    krylov = KrylovReductor.named(method, settings.bounds, settings.tolerance, settings.certify)
    reductor = resolve_reductor(method) if krylov is None else None
    order, basis_values, solver = settings.order, dict(settings.basis), settings.solver
    if krylov is not None:
        from aromm.reduction.krylov_offline import reduce_krylov

        return reduce_krylov(system, order, krylov, basis_values=basis_values, solver=solver,
                             store=resolve_cache(cache), progress=progress, fields=fields, with_fields=_with_fields)
    assert reductor is not None
    original = system
    system = lift(system, basis_values, solver)  # fixed temperatures: the free unknowns (aromm.reduction.lifting)
    store = resolve_cache(cache)
    engine = ScipyModalEngine(system, [_lifted(r, basis_values, solver) for r in references], settings.reference,
                              solver=solver, eigensolver=settings.eigensolver, storage=settings.basis_storage,
                              store=store, progress=progress, eigen_progress=eigen_progress)
    chosen = modal_pipeline.plan(engine, settings, reductor)
    _check_mode_count(settings, chosen, system.n)
    with store.lock("rom", chosen.key) if store is not None else contextlib.nullcontext():  # one build at a time
        if store is not None:
            stored = store.load("rom", chosen.key)
            recipe = store.load("reconstruction", chosen.key) if fields and stored is not None else None
            if stored is not None and (not fields or recipe is not None):
                log.info("reduced model loaded from the cache %s", store.path("rom", chosen.key))
                rom = from_arrays(stored)
                rom = replace(rom, info={**rom.info, "cached": 1, "offline_seconds": 0.0})
                _order_used(order, rom)
                if recipe is None:
                    return rom
                modal = engine.modal_basis(chosen.n_dirichlet, chosen.n_steklov, basis_values, chosen.samples)
                return _with_fields(rom, original, modal.vectors @ recipe["coefficients"], basis_values, solver)
        start = time.perf_counter()
        rom, coefficients, basis = modal_pipeline.build(engine, settings, reductor, chosen)
        engine.close()
        rom, extra = _certified(system, rom, basis.vectors @ coefficients, settings)
        rom = replace(rom, info={**rom.info, **extra, "offline_seconds": time.perf_counter() - start,
                                 "lifted_faces": len(original.dirichlet), "eigensolver": engine.eigensolver,
                                 "eigen_iterations": engine.eigen_iterations})
        _order_used(order, rom)
        if store is not None:
            store.save("rom", chosen.key, to_arrays(rom))
            store.save("reconstruction", chosen.key, {"coefficients": coefficients})
        return _with_fields(rom, original, basis.vectors @ coefficients, basis_values, solver) if fields else rom


def _certified(system: ThermalSystem, rom: ReducedModel, psi: FloatArray,
               settings: ReductionSettings) -> tuple[ReducedModel, dict[str, float | int | str]]:
    """The modal model with its certificate (:mod:`aromm.reduction.certified`; by size unless ``settings.certify``),
    at the basis values, its ``error_bound`` taken at the system's own values (a modal model has no training box)."""
    values = {**system.parameters, **settings.basis}
    engine = ScipyEngine(system, settings.solver if settings.solver in SOLVERS else "auto")
    return certified(engine, system, rom, psi, certify=settings.certify, reference=values,
                     training=[dict(system.parameters)], rtol=KrylovReductor.rtol)


def _check_mode_count(settings: ReductionSettings, chosen: modal_pipeline.ModalPlan, n: int) -> None:
    """Warn when the mesh has fewer free unknowns than the Ñ modes asked."""
    asked = int(settings.modes) if settings.modes is not None else default_modes(settings.order)
    used = chosen.n_dirichlet + chosen.n_steklov
    if settings.n_dirichlet is None and settings.n_steklov is None and used < asked:
        default = '' if settings.modes is not None else f' (default 1.5 × order {settings.order} + 20)'
        warnings.warn(f"Ñ = {asked} modes asked{default}, but the mesh has {n} free unknowns: Ñ = {used} modes used "
                      f"({chosen.n_dirichlet} Dirichlet, {chosen.n_steklov} Steklov)", InputWarning, stacklevel=3)


#: Grid nodes above which a voxel scene reduced by the Krylov method is assembled with matrix-free terms
#: (aromm.fem.voxel_terms): where its shifted solves use multigrid (aromm.reduction.scipy_engine.DIRECT_BELOW); below,
#: CHOLMOD needs the matrices anyway.  Measured on small_wood(32) (35,937 nodes; benchmarks/reduce_scaling.py,
#: docs/one_machine.md): 15.2 CPU s and 0.35 GB matrix-free against 18.5 CPU s and 0.42 GB assembled.
MATRIX_FREE_ABOVE = DIRECT_BELOW


def matrix_free_krylov(scene: Scene, settings: ReductionSettings, references: bool) -> bool:
    """True for a voxel scene above :data:`MATRIX_FREE_ABOVE` nodes that the Krylov method reduces."""
    shape = getattr(scene.geometry, "shape", None)
    if not isinstance(shape, tuple):
        return False
    nodes = int(np.prod(np.asarray(shape) + 1))
    krylov = KrylovReductor.named(settings.method_for(nodes, references), settings.bounds, settings.tolerance,
                                  settings.certify)
    return nodes > MATRIX_FREE_ABOVE and krylov is not None


def _with_fields(rom: ReducedModel, original: ThermalSystem, psi: FloatArray, basis_values: Mapping[str, float],
                 solver: str) -> ReducedModel:
    """``rom`` with Ψ on every unknown of ``original`` (zero rows on its fixed nodes) and the lifting of its
    fixed temperatures, ``Σ_d τ_d g_d(t) ℓ_d`` (:mod:`aromm.reduction.lifting`, at the basis values like the
    reduction)."""
    if not original.dirichlet:
        return replace(rom, basis=psi)
    free = np.flatnonzero(original.fixed_owner() < 0)
    full = np.zeros((original.n, psi.shape[1]))
    full[free] = psi
    ell = liftings(original, basis_values, solver)
    terms = tuple(Term(f"lift_{d.name}", Coefficient((d.param,)), ell[:, i], "output", d.time)
                  for i, d in enumerate(original.dirichlet))
    return replace(rom, basis=full, field_lifting=Affine(terms))


def _lifted(case: ThermalSystem | ReferenceCase, values: Mapping[str, float], solver: str) -> ThermalSystem | \
        ReferenceCase:
    """A reference case with its fixed temperatures lifted at the basis values, like the system."""
    if isinstance(case, ThermalSystem):
        return lift(case, values, solver)
    return replace(case, system=lift(case.system, values, solver))


def _order_used(order: int, rom: ReducedModel) -> None:
    """Warn when the model's order is below the one asked: the detailed basis (modes and correction vectors) had
    fewer vectors, and the whole of it is the model."""
    if rom.order < order:
        warnings.warn(f"order ñ = {order} asked, but the detailed basis has {rom.order} vectors (Ñ = "
                      f"{rom.info.get('modes')} incl. correction vectors): order {rom.order} used (raise --modes, "
                      "or ask for a lower order)", InputWarning, stacklevel=3)
