"""The AROMM offline pipeline written once, over a modal engine [Chavez2020, § 3].

The steps every engine takes to the amalgamated model are the same; only where the large vectors live differs (one
process: :mod:`aromm.reduction.offline`; rows distributed by PETSc: aromm.engines.petsc.reduction).  An engine
implementing :class:`ModalEngine` provides the detailed basis Φ (modes and correction vectors) and the Galerkin
projection of the reference cases onto it; :func:`plan` fixes the mode counts, correction samples and cache key,
:func:`build` runs

1. Φ: constants, Steklov and Dirichlet modes at the basis values, and correction vectors (engine);
2. the detailed modal model of the system and of each reference case: the other scenarios, the relaxation from
   30 °C cooled on the whole boundary [Chavez2020, § 3.2] (engine);
3. the reductor's coefficients A from the reference excitation states, on Ñ × Ñ matrices that every process holds
   (:func:`reduce_detailed`), and the model's record (:func:`reduction_info`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

import numpy as np

from aromm.core.cache import content_key
from aromm.core.system import Affine, Coefficient, FloatArray, Term, ThermalSystem, TimeGrid
from aromm.reduction.corrections import correction_samples
from aromm.reduction.modal_bases import ModalBasis, boundary_of
from aromm.reduction.reductors import DetailedModel, Reductor, snapshot_times
from aromm.reduction.rom import ReducedModel
from aromm.scene.reduction_section import ReductionSettings

log = logging.getLogger(__name__)

ROM_VERSION = 7  # 7: certified modal models (an entry of 6 has none); 6: the output time grid in the key; 5: one
#                  pipeline for every engine (histories, feedthrough and lifted fixed temperatures since 4)
#: Relaxation reference case [Chavez2020, § 3.2]: initially at 30 °C, cooled on all faces (h in W/(m² K)).
RELAXATION_T0 = 30.0
RELAXATION_H = 20.0
#: Reduced columns whose capacity Gram eigenvalue is below this fraction of the largest are dependent.
DEPENDENT_COLUMNS = 1e-10


@dataclass(frozen=True)
class ReferenceCase:
    """A reference simulation for the reductor: a system on the same mesh, parameter values, times."""

    system: ThermalSystem
    values: Mapping[str, float] = field(default_factory=dict)
    times: FloatArray | None = None
    name: str = "reference"


class ModalEngine(Protocol):
    """What :func:`build` needs from an engine holding the full model of one system (fixed temperatures lifted).
    ``modal_basis`` enters the ``"corrections"`` stage itself when it computes correction vectors."""

    @property
    def template(self) -> ThermalSystem:
        """The system's parameters, time grid and term names (its operators may live elsewhere)."""
        ...

    def fingerprints(self) -> list[Any]:
        """Content of the system and of each reference case (operators or image, values, times): the cache key."""
        ...

    def split(self, total: int) -> tuple[int, int]:
        """Ñ = ``total`` modes split into (Dirichlet, Steklov incl. constants) counts."""
        ...

    def stage(self, label: str, detail: str) -> None:
        """The build enters stage ``label`` (``"basis"``, ``"corrections"``, ``"projection"``, ``"amalgam"``),
        described by ``detail`` (progress, log, records of seconds and memory)."""
        ...

    def modal_basis(self, n_dirichlet: int, n_steklov: int, values: Mapping[str, float],
                    samples: list[dict[str, float]]) -> ModalBasis:
        """Φ: the modes at ``values`` and the correction vectors at ``samples``."""
        ...

    def projected(self, basis: ModalBasis, relaxation: bool) -> list[tuple[ReducedModel, ReferenceCase]]:
        """The detailed modal models (Galerkin on Φ) of the system at its reference values (first), of the other
        reference cases and, with ``relaxation``, of :func:`relaxation_case`."""
        ...


@dataclass(frozen=True)
class ModalPlan:
    """What a build will do: the mode counts, the correction samples, the cache key."""

    n_dirichlet: int
    n_steklov: int
    samples: list[dict[str, float]]
    key: str


def at_reference(system: ThermalSystem, reference_values: Mapping[str, float]) -> dict[str, float]:
    """The system's parameters with the reference overrides it knows (the values of its reference case)."""
    own = {k: float(v) for k, v in system.parameters.items()}
    return {**own, **{k: float(v) for k, v in reference_values.items() if k in own}}


def reference_cases(system: ThermalSystem, others: Sequence[ThermalSystem | ReferenceCase],
                    reference: Mapping[str, float]) -> list[ReferenceCase]:
    """The system at its reference values (first, named ``"system"``) and each other case: a system on the same
    mesh at the same overrides ``reference``, or a case as given."""
    cases = [ReferenceCase(system, at_reference(system, reference), name="system")]
    return cases + [ReferenceCase(r, at_reference(r, reference)) if isinstance(r, ThermalSystem) else r
                    for r in others]


def default_modes(order: int) -> int:
    """Default detailed basis size Ñ = 1.5 ñ + 20 (ñ = 200 → Ñ = 320: on the shipped wood VER Ñ = 300 gave
    0.002 °C at ñ = 200 within 252 s of CPU, benchmarks/aromm_wood.py)."""
    return int(1.5 * order) + 20


def mode_counts(settings: ReductionSettings, split: Callable[[int], tuple[int, int]]) -> tuple[int, int]:
    """(n_dirichlet, n_steklov): Ñ = ``settings.modes`` (default :func:`default_modes` of the order) split by
    ``split`` (aromm.reduction.modal_bases.split_modes) unless one of the counts is given."""
    total = int(settings.modes) if settings.modes is not None else default_modes(settings.order)
    if settings.n_dirichlet is None and settings.n_steklov is None:
        return split(total)
    n_s = int(settings.n_steklov) if settings.n_steklov is not None else total - int(settings.n_dirichlet or 0)
    n_d = int(settings.n_dirichlet) if settings.n_dirichlet is not None else total - n_s
    return n_d, n_s


def plan(engine: ModalEngine, settings: ReductionSettings, reductor: Reductor, *extra: Any) -> ModalPlan:
    """Mode counts, correction samples (:func:`aromm.reduction.corrections.correction_samples` at the basis values
    unless ``settings.corrections`` names them) and the cache key: the engine's fingerprints, the settings, the
    reductor and ``extra``; not the settings' ``bounds``, which no modal build uses (a certified modal model's Krylov
    referee is kept apart: :mod:`aromm.reduction.referee`)."""
    n_d, n_s = mode_counts(settings, engine.split)
    default = correction_samples(engine.template, settings.basis) if settings.corrections is True else ()
    samples = settings.samples(default)
    name = getattr(reductor, "cache_key", reductor.name)
    grid = engine.template.time  # the model's output grid (its reference cases may run on their own)
    key = content_key(ROM_VERSION, engine.fingerprints(), None if grid is None else (grid.end, grid.dt), n_d, n_s,
                      samples, name, replace(settings, bounds={}).key(), *extra)
    return ModalPlan(n_d, n_s, samples, key)


def build(engine: ModalEngine, settings: ReductionSettings, reductor: Reductor,
          chosen: ModalPlan) -> tuple[ReducedModel, FloatArray, ModalBasis]:
    """The order-ñ model (its ``info`` from :func:`reduction_info` without the seconds), the coefficients A of its
    basis on Φ (Ψ = Φ A), and Φ."""
    engine.stage("basis", f"modes (Ñ = {chosen.n_dirichlet} Dirichlet + {chosen.n_steklov} Steklov)")
    basis = engine.modal_basis(chosen.n_dirichlet, chosen.n_steklov, settings.basis, chosen.samples)
    engine.stage("projection", "projection and reference cases")
    cases = engine.projected(basis, settings.relaxation)
    engine.stage("amalgam", f"{reductor.name} to order {settings.order}")
    model = cases[0][0]
    tracked = replace(model, basis=np.eye(basis.size))  # transform() carries Ψ's coefficients A (Ψ = Φ A)
    rom, err = reduce_detailed(tracked, cases, basis, settings.order, reductor, check_values=cases[0][1].values)
    coefficients = rom.basis
    assert coefficients is not None
    rom = replace(rom, basis=None, info=reduction_info(rom, basis, reductor.name, error=err, key=chosen.key))
    log.info("reduced model built: order %d from %d modes, reference error %.3g °C", rom.order, basis.size, err)
    return rom, coefficients, basis


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


def reduce_detailed(model: ReducedModel, cases: Sequence[tuple[ReducedModel, ReferenceCase]], basis: ModalBasis,
                    order: int, reductor: Reductor, *, check_values: Mapping[str, float]) -> tuple[ReducedModel, float]:
    """The order-ñ model from the detailed modal model ``model`` (on Φ) and the reference cases projected onto
    Φ (``cases``: projected model and case), and its largest output error (°C) against ``model`` at
    ``check_values`` on the snapshot times.

    Works on Ñ × Ñ matrices only: whoever computed Φ and projected the operators hands over the projected models;
    ``basis.vectors`` is not used.
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


def reduction_info(rom: ReducedModel, basis: ModalBasis, method: str, *, error: float,
                   key: str) -> dict[str, float | int | str]:
    """What ``ReducedModel.info`` records of an offline build (orders, mode counts, errors; the caller adds the
    seconds)."""
    return {
        "method": method, "order": rom.order, "modes": basis.size, "n_dirichlet": basis.count("dirichlet"),
        "n_steklov": basis.count("steklov") + basis.count("zero"), "n_corrections": basis.count("correction"),
        "zeta": basis.zeta,
        "basis_seconds": float(basis.info.get("seconds", 0.0)), "basis_cached": int(basis.info.get("cached", 0)),
        "gram_condition": float(basis.info.get("gram_condition", np.nan)),
        "reference_error": error, "cached": 0, "key": key,
    }


def _snapshot(case: ReferenceCase, model: ReducedModel, kinds: np.ndarray, grid: TimeGrid | None) -> FloatArray:
    """Excitation states (Ñ × K) of one reference case, scaled to unit norm outside the constants."""
    names = model.parameter_names
    times = case.times if case.times is not None else snapshot_times(case.system.time or grid)
    x = model.states({k: v for k, v in case.values.items() if k in names}, times).T
    scale = float(np.linalg.norm(x[np.flatnonzero(kinds != "zero")]))
    return x / scale if scale > 0 else x
