"""The public entry points that choose an engine: the only library code that branches on ``engine=``.

Numerical wings (:mod:`aromm.full`, :mod:`aromm.reduction`, :mod:`aromm.homogenization`) work on one process
and never import an engine; :mod:`aromm.engines` implements the same operations distributed by PETSc under
MPI.  Each function here checks the engine, then hands the call to the wing (``engine="scipy"``, the
default) or to the petsc engine (collective: every rank calls it and gets the same result).

* :func:`simulate` — the full model, :func:`aromm.full.solve.simulate` or
  :func:`aromm.engines.petsc.transient.simulate`;
* :func:`reduce` — the reduced model, :func:`aromm.reduction.offline.reduce` or
  :func:`aromm.engines.petsc.reduction.reduce`;
* :func:`homogenize` — the effective conductivity tensor, :func:`aromm.homogenization.properties.homogenize`
  (voxel cell problems, mesh probes) or the probes [Chavez2020, eq. 13] solved by the petsc engine;
* :func:`fluxmetric` — [Chavez2020, eq. 13] under the scene's own faces, on either engine;
* :func:`mean_capacity` — [Chavez2020, eq. 14] on either engine.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Mapping
from dataclasses import fields, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from aromm.core.cache import NpzCache, content_key
from aromm.core.errors import InputError, ModelWarning
from aromm.core.observables import Observables
from aromm.core.system import FloatArray, ParamValues, ThermalSystem
from aromm.engines import check_engine, is_root
from aromm.full import solve
from aromm.homogenization import properties
from aromm.homogenization.properties import PROBE_BOUNDARIES, Fluxmetric, conductivity
from aromm.reduction import offline
from aromm.reduction.certified import tolerance_note
from aromm.reduction.krylov import KrylovReductor
from aromm.reduction.model_key import model_key, scene_physics_key
from aromm.reduction.offline import resolve_cache
from aromm.reduction.referee import REFEREE_ORDER, refereed
from aromm.reduction.rom import ReducedModel, from_arrays, to_arrays
from aromm.scene.reduction_section import ReductionSettings
from aromm.scene.scene_file import Scene, assemble

#: Options of :func:`reduce` that say where and how a build reports, not what it builds.
RUN_OPTIONS = ("references", "cache", "progress", "eigen_progress", "fields")

__all__ = ["built_order", "default_boundary", "fluxmetric", "homogenize", "is_root", "mean_capacity", "reduce",
           "simulate"]


def simulate(system: ThermalSystem | Scene, values: ParamValues | None = None, times: npt.ArrayLike | None = None,
             *, engine: str = "scipy", **options: Any) -> Observables:
    """Full model (:func:`aromm.full.solve.simulate`: steady solve or BDF2 / backward-Euler transient; ``options``
    ``fields``, ``method``, ``scheme``, ``progress`` as there).

    ``engine="petsc"``: the same solves distributed by PETSc under MPI (:mod:`aromm.engines.petsc.transient`;
    every rank calls it; ``system`` may be a voxel Scene, assembled by each rank for its own rows; ``method``
    is then ``gamg`` or ``mumps``; no ``fields``)."""
    if check_engine(engine) == "petsc":
        from aromm.engines.petsc.transient import simulate as simulate_petsc

        if options.pop("fields", False):
            raise InputError("the petsc engine returns face means only (fields stay distributed); use engine='scipy'")
        options.pop("progress", None)
        return simulate_petsc(system, values, times, scheme=options.get("scheme", "bdf2"),
                              solver=options.get("method", "auto"))
    if isinstance(system, Scene):
        raise InputError("simulate: the scipy engine takes an assembled ThermalSystem (aromm.assemble(scene))")
    return solve.simulate(system, values, times, **options)


def reduce(system: ThermalSystem | Scene, order: int | None = None, *, engine: str = "scipy",
           settings: ReductionSettings | None = None, **options: Any) -> ReducedModel:
    """Reduced model of ``system`` at order ``order`` [Chavez2020, § 3]: ``settings``
    (:class:`~aromm.scene.reduction_section.ReductionSettings`) with ``order`` and its fields among ``options``
    replaced; the other ``options`` (``references``, ``cache``, ``progress``, ``eigen_progress``, ``fields``) as
    :func:`aromm.reduction.offline.reduce`.

    ``engine="petsc"``: the offline work on PETSc/SLEPc under ``mpiexec`` (collective,
    :func:`aromm.engines.petsc.reduction.reduce`; ``system`` may then be a voxel Scene and ``solver`` is ``gamg``
    or ``mumps``, and ``eigensolver`` SLEPc's shift-invert or preconditioned eigensolver,
    aromm.engines.petsc.eigen); it keeps no fields and the basis in float64.  With
    ``method="krylov"`` (and ``"auto"`` above the size where it pays) the Krylov reductor runs on KSP solves only,
    no SLEPc (:func:`aromm.engines.petsc.krylov_reduction.reduce_krylov`); a scene with ``[moisture]`` is reduced
    there by the Krylov method only (``"auto"`` takes it at any size, :func:`_coupled_method`).

    A voxel scene (a Scene, or the petsc engine's box-read VoxelProblem) is cached under the key of its model
    (:func:`aromm.reduction.model_key.model_key`), which names neither the engine nor the solvers: a model built
    on one engine is loaded by the other.

    A Krylov model that did not meet its tolerance by its own estimates (``info["converged"]`` 0: the greedy stopped
    on ``max_points``, or the order asked cost more than half the tolerance) is returned with a
    :class:`~aromm.core.errors.ModelWarning` that says the estimated error and why, whether built or cached."""
    engine = check_engine(engine)
    run = {k: options.pop(k) for k in RUN_OPTIONS if k in options}
    settings = _resolved(system, (settings or ReductionSettings()).updated(order=order, **options), run, engine)
    rom = _refereed(system, settings, engine, run, _cached_or_built(system, settings, engine, run))
    note = tolerance_note(rom.info)
    if note is not None and is_root(engine):
        warnings.warn(note, ModelWarning, stacklevel=2)
    return rom


def built_order(system: ThermalSystem | Scene, settings: ReductionSettings | None = None, *, engine: str = "scipy",
                **run: Any) -> int | None:
    """The order asked of the last reduced model built for ``system`` with ``settings`` whatever its order
    (``aromm reduce --order 60`` then ``aromm identify``: identify asks for that model instead of building one at the
    default order), or None when there is none in the cache; ``run`` as :func:`reduce` (``cache``, ``references``).
    The petsc engine keeps no such record (None)."""
    settings = _resolved(system, settings or ReductionSettings(), run, engine)
    family = _family_key(system, settings, engine, run)
    store = resolve_cache(run.get("cache", True)) if family is not None else None
    found = store.load("model-order", family) if store is not None and family is not None else None
    return int(found["order"]) if found is not None else None


#: The order that stands in the key of a model's family (every order of the same scene and settings).
FAMILY = 0


def _resolved(system: Any, settings: ReductionSettings, run: Mapping[str, Any],
              engine: str = "scipy") -> ReductionSettings:
    """``settings`` with ``method="auto"`` resolved by the system's size (:func:`_coupled_method` for a scene with
    moisture on the petsc engine)."""
    references = bool(run.get("references"))
    method = settings.method_for(_unknowns(system), references=references)
    if engine == "petsc" and getattr(system, "moisture", None) is not None:
        method = _coupled_method(system, settings, method, references)
    return replace(settings, method=method)


def _coupled_method(system: Any, settings: ReductionSettings, method: Any, references: bool) -> Any:
    """The method of a reduced model of coupled heat and moisture on the petsc engine: Krylov only (its shifted solves
    are the full model's coupled KSP solves; the modal bases' SLEPc eigenproblems are not coupled), so ``"auto"``
    takes ``"krylov"`` at any size unless modal options or reference cases ask for the amalgam; any other method is
    refused (:class:`~aromm.core.errors.InputError` naming it and what is allowed)."""
    modal = settings.modal_options()
    if settings.method == "auto" and not modal and not references:
        return "krylov"
    if KrylovReductor.named(method, settings.bounds, settings.tolerance, settings.certify) is not None:
        return method
    asked = getattr(method, "name", method)
    why = (f"method = {asked!r}" if settings.method != "auto" else
           f"method = 'auto' with {', '.join(modal) if modal else 'reference cases'} (the amalgam's)")
    where = getattr(system, "where", "")
    raise InputError(f"{where}moisture: {why}: the petsc engine builds reduced models of coupled "
                     "heat and moisture by the Krylov method only (method = \"krylov\" or \"auto\", without modal "
                     "options or references); reduce it with --engine scipy for a modal model")


def _cached_or_built(system: Any, settings: ReductionSettings, engine: str, run: dict[str, Any]) -> ReducedModel:
    """The model from the cache under its key (:func:`_model_key`), else built and stored."""
    key = _model_key(system, settings, engine, run)
    if key is None:
        return _build(system, settings, engine, run)
    store = resolve_cache(run.get("cache", True))
    assert store is not None  # _model_key gives no key without a cache
    root = is_root(engine)
    with store.lock("rom", key) if root else contextlib.nullcontext():  # one build per model at a time
        found = store.load("rom", key) if root else None
        if engine == "petsc":
            from aromm.engines.petsc import runtime

            found = runtime.mpi(runtime.world()).bcast(found, root=0)
        if found is not None:
            rom = from_arrays(found).with_parameters(system.parameters)
            return replace(rom, info={**rom.info, "cached": 1, "offline_seconds": 0.0})
        rom = _build(system, settings, engine, run)
        rom = replace(rom, info={**rom.info, "engine": engine, "model_key": key})
        if root:
            store.save("rom", key, to_arrays(rom))
            _remember_order(store, system, settings, engine, run)
    return rom


def _refereed(system: Any, settings: ReductionSettings, engine: str, run: dict[str, Any],
              rom: ReducedModel) -> ReducedModel:
    """A certified modal model given ``bounds``, with its Krylov referee over them (:mod:`aromm.reduction.referee`):
    the Krylov model of the same scene over that box, from the cache or built (its own key: the modal model, cached
    without it, serves every box).  The worst bound over the box is kept in the cache under both models' keys: a
    warm call loads it instead of evaluating the bound at every training point again: for an amalgam of order 200 on
    16³ voxels, 2.8 CPU s cold against 0.03 CPU s for the whole warm reduce and 6.4 ms for one simulation
    (``python benchmarks/referee_cost.py``, record benchmarks/records/referee_cost_16_200_3343793.txt)."""
    modal = KrylovReductor.named(settings.method, settings.bounds, settings.tolerance, settings.certify) is None
    if not (modal and settings.bounds and rom.certificate is not None):
        return rom
    krylov = ReductionSettings(order=REFEREE_ORDER, method="krylov", basis=settings.basis, bounds=settings.bounds,
                               tolerance=settings.tolerance, certify=settings.certify, solver=settings.solver)
    options = {k: v for k, v in run.items() if k in ("cache", "progress")}
    referee = _cached_or_built(system, krylov, engine, options)
    keys = (rom.info.get("model_key"), referee.info.get("model_key"))
    store = resolve_cache(run.get("cache", True)) if all(keys) and is_root(engine) else None
    key = content_key("referee", *keys)
    found = store.load("referee", key) if store is not None else None
    out = refereed(rom, referee, None if found is None else float(found["worst"]))
    if store is not None and found is None and referee.certificate is not None:
        store.save("referee", key, {"worst": np.array(float(out.info["error_bound"]))})
    return out


def _remember_order(store: NpzCache, system: Any, settings: ReductionSettings, engine: str,
                    run: dict[str, Any]) -> None:
    """Record the order of the model just built for its family (:func:`built_order`)."""
    family = _family_key(system, settings, engine, run)
    if family is not None:
        store.save("model-order", family, {"order": np.array(settings.order)})


def _family_key(system: Any, settings: ReductionSettings, engine: str, run: dict[str, Any]) -> str | None:
    """The key of every order's model for ``system`` and ``settings`` (:func:`_model_key` at order :data:`FAMILY`), or
    None: the petsc engine keeps no order record (its key is collective over the ranks, and rank 0 alone writes)."""
    return _model_key(system, replace(settings, order=FAMILY), engine, run) if engine == "scipy" else None


def _model_key(system: Any, settings: ReductionSettings, engine: str, run: dict[str, Any]) -> str | None:
    """The engine-free key of the model (:mod:`aromm.reduction.model_key`), or None: a mesh scene or an assembled
    system (the engine's own key then), no cache, or ``fields`` (the scipy engine's cache keeps Ψ's recipe)."""
    if run.get("fields") or run.get("cache", True) in (False, None):
        return None
    krylov = KrylovReductor.named(settings.method, settings.bounds, settings.tolerance,
                                  settings.certify) is not None
    box = frozenset(settings.bounds) if krylov else frozenset()  # the values one model serves (model_key)
    keys = [_physics(source, engine, box) for source in (system, *run.get("references", ()))]
    if any(k is None for k in keys):
        return None
    options = {f.name: getattr(settings, f.name) for f in fields(settings)
               if f.name != "order" and (krylov or f.name != "bounds")}  # the modal methods have no box
    return model_key(str(keys[0]), settings.order, options, [str(k) for k in keys[1:]])


def _physics(source: Any, engine: str, box: frozenset[str]) -> str | None:
    if isinstance(source, Scene):
        return scene_physics_key(source, box)
    if engine == "petsc":
        from aromm.engines.petsc.problem import VoxelProblem

        if isinstance(source, VoxelProblem):
            from aromm.engines.petsc import runtime
            from aromm.engines.petsc.assembly import physics_key

            return physics_key(source, runtime.world(), box)
    return None


def _build(system: Any, settings: ReductionSettings, engine: str, run: dict[str, Any]) -> ReducedModel:
    """The reduced model on ``engine`` (each engine's own cache of bases and models); the method resolved."""
    if engine == "scipy":
        references = [assemble(r) if isinstance(r, Scene) else r for r in run.pop("references", ())]
        return offline.reduce(system, settings=settings, references=references, **run)
    if run.get("fields"):
        raise InputError("reduce: fields (the basis Ψ) are kept by the scipy engine only")
    if settings.basis_storage != "float64":
        raise InputError("basis_storage applies to the scipy engine (the petsc engine keeps the basis in float64)")
    cache = run.get("cache", True)
    reductor = KrylovReductor.named(settings.method, settings.bounds, settings.tolerance, settings.certify)
    if reductor is not None:
        from aromm.engines.petsc.krylov_reduction import reduce_krylov

        return reduce_krylov(system, settings.order, reductor, solver=settings.solver, cache=cache,
                             progress=bool(run.get("progress")))
    if settings.certify:
        raise InputError("reduce: on the petsc engine certify needs method = \"krylov\" (its modal models carry no "
                         "certificate yet)")
    from aromm.engines.petsc.reduction import reduce as reduce_petsc

    return reduce_petsc(system, settings, references=run.get("references", ()), cache=cache)


def _unknowns(system: Any) -> int:
    """Unknowns of a system, else voxels of a voxel scene or box-read problem (what ``method="auto"`` compares;
    0 for a mesh scene, which the petsc engine distributes as a ThermalSystem)."""
    if isinstance(system, ThermalSystem):
        return system.n
    shape = getattr(system, "shape", None) or getattr(getattr(system, "geometry", None), "shape", None)
    return int(np.prod(shape)) if isinstance(shape, tuple) else 0


def default_boundary(scene: Scene, engine: str = "scipy") -> str:
    """The boundary condition of :func:`homogenize` when none is named: ``"flux"`` ([Chavez2020, eq. 13]) on the
    petsc engine, which homogenises by probes, else :func:`aromm.homogenization.properties.default_boundary`."""
    return "flux" if engine == "petsc" else properties.default_boundary(scene)


def homogenize(scene: Scene, boundary: str | None = None, method: str = "auto",
               engine: str = "scipy") -> FloatArray:
    """Effective conductivity tensor (3x3, W/(m K)) of the scene's material under ``boundary``
    (:func:`aromm.homogenization.properties.homogenize`; by default :func:`default_boundary`).

    ``engine="petsc"`` (PETSc under MPI, collective: every rank calls it and gets the tensor): the probes
    ``"flux"`` ([Chavez2020, eq. 13]) or ``"temperature"`` with ``method`` ``gamg`` or ``mumps``."""
    engine = check_engine(engine)
    boundary = boundary or default_boundary(scene, engine)
    if engine == "scipy":
        return properties.homogenize(scene, boundary, method)
    if boundary not in PROBE_BOUNDARIES:
        raise InputError(f"the petsc engine homogenises with boundary 'flux' or 'temperature' (periodic conditions "
                         f"need a voxel image and the scipy engine), got {boundary!r}")
    from aromm.engines.petsc.homogenization import probe_solver

    return conductivity(scene, boundary, probe_solver(method))


def fluxmetric(scene: Any, method: str = "auto", engine: str = "scipy") -> Fluxmetric:
    """The fluxmetric conductivity of [Chavez2020, § 4.2] (eq. 13 under the scene's own faces,
    :func:`aromm.homogenization.properties.fluxmetric`); ``engine="petsc"``: its steady probe solved by boxes
    (collective; ``method`` ``gamg`` or ``mumps``)."""
    if check_engine(engine) == "petsc":
        from aromm.engines.petsc.homogenization import probe_solver

        return properties.fluxmetric(scene, solve=probe_solver(method))
    return properties.fluxmetric(scene, method)


def mean_capacity(scene: Any, engine: str = "scipy") -> float:
    """Volume-averaged volumetric heat capacity c̄ (J/(m^3 K)), [Chavez2020, eq. 14], on ``engine`` (the petsc
    engine counts the phases' volumes over each rank's rows of the image)."""
    if check_engine(engine) == "petsc":
        from aromm.engines.petsc.homogenization import mean_capacity as mean_capacity_petsc

        return float(mean_capacity_petsc(scene))
    return properties.mean_capacity(scene)
