"""Offline reduction: detailed modal basis, reference simulations, a reductor, the reduced model [Chavez2020, § 3].

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
import sys
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from tqdm import tqdm

from aromm.core.cache import NpzCache, content_key
from aromm.core.errors import InputError, InputWarning
from aromm.core.system import Affine, Coefficient, FloatArray, Term, ThermalSystem, TimeGrid
from aromm.linalg.eigensolvers import EigenProgress, PairsBar, ProgressCallback, choose_eigensolver
from aromm.reduction.amalgam import AmalgamReductor
from aromm.reduction.corrections import correction_samples, with_corrections
from aromm.reduction.greedy import PodGreedy
from aromm.reduction.krylov import KrylovReductor
from aromm.reduction.lifting import lift, liftings
from aromm.reduction.modal_bases import ModalBasis, boundary_of, compute_basis, split_modes
from aromm.reduction.pod import PodReductor
from aromm.reduction.reductors import DetailedModel, Reductor, snapshot_times
from aromm.reduction.rom import ReducedModel, from_arrays, to_arrays
from aromm.scene.reduction_section import REDUCTION_METHODS
from aromm.scene.scene_file import Scene, assemble

log = logging.getLogger(__name__)

#: The reductors known by name; any object implementing :class:`~aromm.reduction.reductors.Reductor` is accepted too.
REDUCTORS: Mapping[str, Reductor] = {r.name: r for r in (AmalgamReductor(), PodReductor(), PodGreedy())}
#: Every method by name: the reductors, and "krylov" (eigen-free, no detailed basis: aromm.reduction.krylov).
METHODS = REDUCTION_METHODS
#: Relaxation reference case [Chavez2020, § 3.2]: initially at 30 °C, cooled on all faces (h in W/(m² K)).
RELAXATION_T0 = 30.0
RELAXATION_H = 20.0
_ROM_VERSION = 4  # 4: histories, feedthrough and lifted fixed temperatures


@dataclass(frozen=True)
class ReferenceCase:
    """A reference simulation for the reductor: a system on the same mesh, parameter values, times."""

    system: ThermalSystem
    values: Mapping[str, float] = field(default_factory=dict)
    times: FloatArray | None = None
    name: str = "reference"


def default_modes(order: int) -> int:
    """Default detailed basis size Ñ = 1.5 ñ + 20 (ñ = 200 → Ñ = 320: on the shipped wood VER Ñ = 300 gave
    0.002 °C at ñ = 200 within 252 s of CPU, benchmarks/aromm_wood.py)."""
    return int(1.5 * order) + 20


def relaxation_case(system: ThermalSystem, values: Mapping[str, float], h: float = RELAXATION_H,
                    initial: float = RELAXATION_T0) -> ReferenceCase:
    """[Chavez2020, § 3.2]: the body at ``initial`` °C cooled by ``h`` on its whole boundary, no other load."""
    cooled = ThermalSystem(
        n=system.n,
        conductance=Affine((*system.conductance.with_role("conduction").terms,
                            Term("H_boundary", Coefficient(("relaxation.h",)), boundary_of(system), "exchange"))),
        capacity=system.capacity,
        parameters={**values, "relaxation.h": h},
        time=system.time,
        boundary=system.boundary,
    )
    return ReferenceCase(cooled, {**values, "relaxation.h": h, "initial.T": initial}, name="relaxation")


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


def at_reference(system: ThermalSystem, reference_values: Mapping[str, float]) -> dict[str, float]:
    """The system's parameters with the reference overrides it knows (the values of its reference case)."""
    own = {k: float(v) for k, v in system.parameters.items()}
    return {**own, **{k: float(v) for k, v in reference_values.items() if k in own}}


def _cases(system: ThermalSystem, reference_values: Mapping[str, float],
           references: Sequence[ThermalSystem | ReferenceCase]) -> list[ReferenceCase]:
    cases = [ReferenceCase(system, at_reference(system, reference_values), name="system")]
    cases += [ReferenceCase(r, at_reference(r, reference_values)) if isinstance(r, ThermalSystem) else r
              for r in references]
    for case in cases:
        if case.system.n != system.n:
            raise InputError(f"reference case {case.name!r} has {case.system.n} free unknowns, the system "
                             f"{system.n}: fix the temperature of the same faces in every reference case")
    return cases


def reduce(
    system: ThermalSystem | Scene,
    order: int = 200,
    *,
    modes: int | None = None,
    n_dirichlet: int | None = None,
    n_steklov: int | None = None,
    basis_values: Mapping[str, float] | None = None,
    reference_values: Mapping[str, float] | None = None,
    references: Sequence[ThermalSystem | ReferenceCase] = (),
    relaxation: bool = True,
    corrections: bool | Sequence[Mapping[str, float]] = True,
    method: str | Reductor | KrylovReductor = "aromm",
    bounds: Mapping[str, tuple[float, float]] | None = None,
    solver: str = "auto",
    eigensolver: str = "auto",
    basis_storage: str = "float64",
    cache: bool | str | os.PathLike[str] | NpzCache | None = True,
    progress: bool = False,
    eigen_progress: ProgressCallback | None = None,
    fields: bool = False,
) -> ReducedModel:
    """Reduced model of ``system`` at order ``order`` [Chavez2020, § 3], on one process
    (:func:`aromm.api.reduce` chooses between this and the petsc engine).

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
    if bounds and method != "krylov":
        raise InputError("reduce: bounds (the identification box) belong to method 'krylov'")
    if isinstance(system, Scene):
        system = assemble(system)
    krylov = KrylovReductor.named(method, bounds)
    reductor = resolve_reductor(method) if krylov is None else None
    for label, given in (("basis_values", basis_values), ("reference_values", reference_values)):
        unknown = sorted(set(given or {}) - system.parameter_names)
        if unknown:
            raise InputError(f"{label}: unknown parameter(s) {unknown}; "
                             f"the system has {sorted(system.parameter_names)}")
    if isinstance(order, bool) or not isinstance(order, int | np.integer) or order < 1:
        raise InputError(f"order must be a positive integer, got {order!r}")
    basis_values = dict(basis_values or {})
    if krylov is not None:
        from aromm.reduction.krylov_offline import reduce_krylov

        return reduce_krylov(system, int(order), krylov, basis_values=basis_values, solver=solver,
                             store=resolve_cache(cache), progress=progress, fields=fields, with_fields=_with_fields)
    assert reductor is not None
    fixed = len(system.dirichlet)
    original = system
    system = lift(system, basis_values, solver)  # fixed temperatures: the free unknowns (aromm.reduction.lifting)
    references = [_lifted(r, basis_values, solver) for r in references]
    n_d, n_s = mode_counts(int(order), modes, n_dirichlet, n_steklov, lambda total: split_modes(system, total))
    asked = int(modes) if modes is not None else default_modes(int(order))
    if n_dirichlet is None and n_steklov is None and n_d + n_s < asked:
        warnings.warn(f"Ñ = {asked} modes asked{'' if modes is not None else f' (default 1.5 × order {order} + 20)'}, "
                      f"but the mesh has {system.n} free unknowns: Ñ = {n_d + n_s} modes used ({n_d} Dirichlet, "
                      f"{n_s} Steklov)", InputWarning, stacklevel=2)
    cases = _cases(system, reference_values or {}, references)
    store = resolve_cache(cache)
    if corrections is True:
        samples = correction_samples(system, basis_values)
    else:
        samples = [dict(s) for s in corrections] if corrections is not False else []
    eig = choose_eigensolver(eigensolver, system.n)
    key = content_key(_ROM_VERSION, system.fingerprint(), order, n_d, n_s, basis_values,
                      getattr(reductor, "cache_key", reductor.name), solver,
                      relaxation, samples, [(c.system.fingerprint(), dict(c.values), c.times) for c in cases],
                      *([eig] if eig != "arpack" else []), *([basis_storage] if basis_storage != "float64" else []))
    with store.lock("rom", key) if store is not None else contextlib.nullcontext():  # one build per model at a time
        if store is not None:
            stored = store.load("rom", key)
            recipe = store.load("reconstruction", key) if fields and stored is not None else None
            if stored is not None and (not fields or recipe is not None):
                log.info("reduced model loaded from the cache %s", store.path("rom", key))
                rom = from_arrays(stored)
                rom = replace(rom, info={**rom.info, "cached": 1, "offline_seconds": 0.0})
                _order_used(int(order), rom)
                if recipe is None:
                    return rom
                modal = _detailed_basis(system, n_d, n_s, basis_values=basis_values, samples=samples, solver=solver,
                                        eigensolver=eig, storage=basis_storage, store=store, stages=_Stages(False))
                return _with_fields(rom, original, modal.vectors @ recipe["coefficients"], basis_values, solver)

        start = time.perf_counter()
        stages = _Stages(progress)

        def converged(report: EigenProgress) -> None:  # the reduce bar moves with the pairs during the basis step
            stages.within(sum(c for c, _ in pairs.state.values()) / max(n_d + n_s, 1))
            if eigen_progress is not None:
                eigen_progress(report)

        pairs = PairsBar(enabled=progress, listener=converged)
        basis = _detailed_basis(system, n_d, n_s, basis_values=basis_values, samples=samples, solver=solver,
                                eigensolver=eig, storage=basis_storage, store=store, stages=stages, progress=pairs)
        pairs.close()
        stages.next("projection and reference cases")
        memo: dict[int, FloatArray] = {}
        model = ReducedModel.from_system(system, basis.vectors, memo)
        if relaxation:
            cases.append(relaxation_case(system, cases[0].values))
        projected = [(model if case.system is system else ReducedModel.from_system(case.system, basis.vectors, memo),
                      case) for case in cases]
        stages.next(f"{reductor.name} to order {order}")
        tracked = replace(model, basis=np.eye(basis.size))  # transform() carries Ψ's coefficients A (Ψ = Φ A)
        rom, err = reduce_detailed(tracked, projected, basis, int(order), reductor, check_values=cases[0].values)
        coefficients, rom = rom.basis, replace(rom, basis=None)
        assert coefficients is not None
        stages.close()
        info = {**reduction_info(rom, basis, reductor.name, seconds=time.perf_counter() - start, error=err, key=key),
                "lifted_faces": fixed, "eigensolver": eig, "eigen_iterations": sum(pairs.iterations.values())}
        rom = replace(rom, info=info)
        _order_used(int(order), rom)
        log.info("reduced model built: order %d from %d modes in %.1f s, reference error %.3g °C",
                 rom.order, basis.size, info["offline_seconds"], err)
        if store is not None:
            store.save("rom", key, to_arrays(rom))
            store.save("reconstruction", key, {"coefficients": coefficients})
        return _with_fields(rom, original, basis.vectors @ coefficients, basis_values, solver) if fields else rom


def _detailed_basis(system: ThermalSystem, n_d: int, n_s: int, *, basis_values: Mapping[str, float],
                    samples: list[dict[str, float]], solver: str, eigensolver: str, storage: str,
                    store: NpzCache | None, stages: _Stages, progress: ProgressCallback | None = None) -> ModalBasis:
    """The detailed basis Φ (Ñ modes and the correction vectors), from the cache when it holds them.

    With LOBPCG (no factorisation) the correction solves use AMG unless a solver was named."""
    stages.next(f"modes (Ñ = {n_d} Dirichlet + {n_s} Steklov)")
    basis = compute_basis(system, n_d, n_s, basis_values, method=solver, eigensolver=eigensolver, cache=store,
                          progress=progress, storage=storage)
    if samples:
        stages.next(f"correction vectors ({len(samples)} parameter samples)")
        linear = "amg" if eigensolver == "lobpcg" and solver == "auto" else solver
        basis = with_corrections(system, basis, samples, values=basis_values, method=linear, cache=store)
    return basis


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


#: Reduced columns whose capacity Gram eigenvalue is below this fraction of the largest are dependent.
DEPENDENT_COLUMNS = 1e-10


def independent(coefficients: FloatArray, gram: FloatArray) -> FloatArray:
    """The coefficients A unchanged when the columns of Ψ = Φ A are independent in the capacity product
    (``AᵀGA``, G = ΦᵀC0Φ); otherwise an orthonormal basis of their span without the dependent directions
    (the Galerkin model depends on the span only).  Kept correction vectors can fall in the span of the
    amalgamated modes when the detailed basis is complete (tiny bodies) and make L singular."""
    g = coefficients.T @ gram @ coefficients
    w, u = np.linalg.eigh((g + g.T) / 2)
    keep = w > DEPENDENT_COLUMNS * float(w.max(initial=0.0))
    if np.all(keep):
        return coefficients
    log.info("reduce: %d dependent reduced column(s) dropped", int(np.count_nonzero(~keep)))
    return (coefficients @ u[:, keep]) / np.sqrt(w[keep])


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


def mode_counts(order: int, modes: int | None, n_dirichlet: int | None, n_steklov: int | None,
                split: Callable[[int], tuple[int, int]]) -> tuple[int, int]:
    """(n_dirichlet, n_steklov) of :func:`reduce`: Ñ = ``modes`` (default :func:`default_modes`) split by
    ``split`` (aromm.reduction.modal_bases.split_modes) unless one of the counts is given."""
    total = int(modes) if modes is not None else default_modes(order)
    if n_dirichlet is None and n_steklov is None:
        return split(total)
    n_s = int(n_steklov) if n_steklov is not None else total - int(n_dirichlet or 0)
    n_d = int(n_dirichlet) if n_dirichlet is not None else total - n_s
    return n_d, n_s


def reduce_detailed(model: ReducedModel, cases: Sequence[tuple[ReducedModel, ReferenceCase]], basis: ModalBasis,
                    order: int, reductor: Reductor, *, check_values: Mapping[str, float]) -> tuple[ReducedModel, float]:
    """The order-ñ model from the detailed modal model ``model`` (on Φ) and the reference cases projected onto
    Φ (``cases``: projected model and case), and its largest output error (°C) against ``model`` at
    ``check_values`` on the snapshot times.

    Works on Ñ × Ñ matrices only: whoever computed Φ and projected the operators (one process, or PETSc
    under MPI, aromm.engines.petsc) hands over the projected models; ``basis.vectors`` is not used.
    """
    snapshots = [_snapshot(case, projected, basis.kinds, model.time) for projected, case in cases]
    detailed = DetailedModel(basis, model, np.hstack(snapshots))
    coefficients = np.eye(basis.size) if order >= basis.size else reductor.coefficients(detailed, order)
    rom = model.transform(independent(coefficients, basis.gram))
    check_t = snapshot_times(model.time)
    own = {k: v for k, v in check_values.items() if k in model.parameter_names}
    err = float(np.abs(rom.simulate(own, check_t).as_array() - model.simulate(own, check_t).as_array()).max(
        initial=0.0))
    return rom, err


def reduction_info(rom: ReducedModel, basis: ModalBasis, method: str, *, seconds: float, error: float,
                   key: str) -> dict[str, float | int | str]:
    """What ``ReducedModel.info`` records of an offline build (orders, mode counts, seconds, errors)."""
    return {
        "method": method, "order": rom.order, "modes": basis.size, "n_dirichlet": basis.count("dirichlet"),
        "n_steklov": basis.count("steklov") + basis.count("zero"), "n_corrections": basis.count("correction"),
        "zeta": basis.zeta,
        "basis_seconds": float(basis.info.get("seconds", 0.0)), "basis_cached": int(basis.info.get("cached", 0)),
        "gram_condition": float(basis.info.get("gram_condition", np.nan)),
        "offline_seconds": seconds, "reference_error": error, "cached": 0, "key": key,
    }


def _snapshot(case: ReferenceCase, model: ReducedModel, kinds: np.ndarray, grid: TimeGrid | None) -> FloatArray:
    """Excitation states (Ñ × K) of one reference case, scaled to unit norm outside the constants."""
    names = model.parameter_names
    times = case.times if case.times is not None else snapshot_times(case.system.time or grid)
    x = model.states({k: v for k, v in case.values.items() if k in names}, times).T
    scale = float(np.linalg.norm(x[np.flatnonzero(kinds != "zero")]))
    return x / scale if scale > 0 else x


class _Stages:
    """The build's stages on a progress bar (terminal) and in the log (``logging``, for batch runs)."""

    def __init__(self, progress: bool) -> None:
        self.bar = tqdm(total=4, desc="reduce", disable=not progress, leave=False, file=sys.stderr)
        self.started = False

    def next(self, stage: str) -> None:
        if self.started:
            self.bar.n = int(self.bar.n) + 1
            self.bar.refresh()
        self.started = True
        self.bar.set_postfix_str(stage)
        log.info("reduce: %s", stage)

    def within(self, fraction: float) -> None:
        """Progress within the current stage (0 to 1): the bar moves during a long stage."""
        self.bar.n = int(self.bar.n) + round(min(max(fraction, 0.0), 0.99), 2)
        self.bar.refresh()

    def close(self) -> None:
        self.bar.n = self.bar.total
        self.bar.refresh()
        self.bar.close()
