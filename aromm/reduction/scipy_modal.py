"""The AROMM pipeline's engine on one process (:class:`~aromm.reduction.modal_pipeline.ModalEngine`).

Modes by ARPACK shift-invert on a sparse factorisation or by LOBPCG with a multigrid preconditioner
(:mod:`aromm.reduction.modal_bases`, cached by content), correction vectors (:mod:`aromm.reduction.corrections`), and
Galerkin projections of the system and of its reference cases in memory; the stages on a progress bar and in the log.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Mapping, Sequence
from typing import Any

from tqdm import tqdm

from aromm.core.cache import NpzCache
from aromm.core.errors import InputError
from aromm.core.system import FloatArray, ThermalSystem
from aromm.linalg.eigensolvers import EigenProgress, PairsBar, ProgressCallback, choose_eigensolver
from aromm.reduction.corrections import with_corrections
from aromm.reduction.modal_bases import ModalBasis, compute_basis, split_modes
from aromm.reduction.modal_pipeline import ReferenceCase, reference_cases, relaxation_case
from aromm.reduction.rom import ReducedModel

log = logging.getLogger(__name__)


class ScipyModalEngine:
    """The full model of ``system`` (fixed temperatures lifted) and its reference cases ``references`` (systems on
    the same mesh, or cases) at the overrides ``reference`` in this process's memory.

    ``solver`` factorises the shift-invert and correction solves (with LOBPCG and ``"auto"``: AMG), ``eigensolver``
    (``"auto"``: by size, :func:`~aromm.linalg.eigensolvers.choose_eigensolver`), ``storage`` of the modes,
    ``store`` caches them; ``progress`` shows a bar, ``eigen_progress`` receives every eigensolver report."""

    def __init__(self, system: ThermalSystem, references: Sequence[ThermalSystem | ReferenceCase],
                 reference: Mapping[str, float], *, solver: str = "auto", eigensolver: str = "auto",
                 storage: str = "float64", store: NpzCache | None = None, progress: bool = False,
                 eigen_progress: ProgressCallback | None = None) -> None:
        self.system = system
        self.cases = reference_cases(system, references, reference)
        for case in self.cases:
            if case.system.n != system.n:
                raise InputError(f"reference case {case.name!r} has {case.system.n} free unknowns, the system "
                                 f"{system.n}: fix the temperature of the same faces in every reference case")
        self.solver, self.storage, self.store = solver, storage, store
        self.eigensolver = choose_eigensolver(eigensolver, system.n)
        self.eigen_progress, self.eigen_iterations = eigen_progress, 0
        self.bar = tqdm(total=4, desc="reduce", disable=not progress, leave=False, file=sys.stderr)
        self.started = False

    @property
    def template(self) -> ThermalSystem:
        return self.system

    def fingerprints(self) -> list[Any]:
        return [(c.system.fingerprint(), dict(c.values), c.times) for c in self.cases]

    def split(self, total: int) -> tuple[int, int]:
        return split_modes(self.system, total)

    def stage(self, label: str, detail: str) -> None:
        """The next stage on the bar (terminal) and in the log (``logging``, for batch runs)."""
        if self.started:
            self.bar.n = int(self.bar.n) + 1
            self.bar.refresh()
        self.started = True
        self.bar.set_postfix_str(detail)
        log.info("reduce: %s", detail)

    def close(self) -> None:
        self.bar.n = self.bar.total
        self.bar.refresh()
        self.bar.close()

    def modal_basis(self, n_dirichlet: int, n_steklov: int, values: Mapping[str, float],
                    samples: list[dict[str, float]]) -> ModalBasis:
        """Φ from the cache when it holds it; with LOBPCG (no factorisation) the correction solves use AMG unless a
        solver was named.  The bar moves with the converged pairs."""
        total = max(n_dirichlet + n_steklov, 1)

        def converged(report: EigenProgress) -> None:
            fraction = sum(c for c, _ in pairs.state.values()) / total
            self.bar.n = int(self.bar.n) + round(min(max(fraction, 0.0), 0.99), 2)
            self.bar.refresh()
            if self.eigen_progress is not None:
                self.eigen_progress(report)

        pairs = PairsBar(enabled=not self.bar.disable, listener=converged)
        basis = compute_basis(self.system, n_dirichlet, n_steklov, values, method=self.solver,
                              eigensolver=self.eigensolver, cache=self.store, progress=pairs, storage=self.storage)
        pairs.close()
        self.eigen_iterations += sum(pairs.iterations.values())
        if samples:
            self.stage("corrections", f"correction vectors ({len(samples)} parameter samples)")
            linear = "amg" if self.eigensolver == "lobpcg" and self.solver == "auto" else self.solver
            basis = with_corrections(self.system, basis, samples, values=values, method=linear, cache=self.store)
        return basis

    def projected(self, basis: ModalBasis, relaxation: bool) -> list[tuple[ReducedModel, ReferenceCase]]:
        memo: dict[int, FloatArray] = {}
        cases = [*self.cases, *([relaxation_case(self.system, self.cases[0].values)] if relaxation else [])]
        return [(ReducedModel.from_system(case.system, basis.vectors, memo), case) for case in cases]
