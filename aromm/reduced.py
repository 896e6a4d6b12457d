"""The AROMM reduced model: Galerkin-projected affine matrices and exact modal time integration.

For a basis Ψ (n × r) every term of the ThermalSystem keeps its coefficient and gets a projected
operator (seed 001 eq. 10, sign convention of the method note §5: ``M = −ΨᵀKΨ``)::

    L(p) = Σ c_j(p) Ψᵀ C_j Ψ          (L_F, L_G)
    A(p) = Σ k_j(p) Ψᵀ K_j Ψ = −M(p)  (M_F, M_G, M_H)
    N(p) = Σ f_j(p) Ψᵀ F_j            (N)
    L(p) dX/dt = −A(p) X + N(p),   L(p) X(0) = T0 Σ c_j(p) Ψᵀ C_j 1,   y = E Ψ X.

Evaluation never touches the full mesh.  For each parameter set the small generalised
eigenproblem ``A W = L W Λ`` (``Wᵀ L W = I``, Λ ≥ 0) diagonalises the system; with ``Y = Wᵀ L X``
and inputs constant in time the solution is exact at any time::

    Y(t) = e^{−Λt} Y0 + (1 − e^{−Λt})/Λ · Wᵀ N     (→ Y0 + t WᵀN for Λ = 0),

and the steady limit (when A is invertible) is ``X∞ = A⁻¹ N``.  A whole swarm of parameter sets
is evaluated in one call with stacked (batched) Cholesky, inverse and eigh.

The same class holds the *detailed* modal model (Ψ = Φ, the Ñ Dirichlet–Steklov modes) from
which the amalgam and the POD baseline are built: :meth:`ReducedModel.transform` applies a
coefficient matrix ``A`` (Ψ = Φ A) to every projected operator at the cost of ``AᵀXA``.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from threadpoolctl import ThreadpoolController
from tqdm import tqdm

from aromm.amalgam import amalgam
from aromm.cache import NpzCache, content_key
from aromm.eigensolvers import PairsBar, ProgressCallback, choose_eigensolver
from aromm.errors import InputError, NumericalError
from aromm.modes import (
    ModalBasis,
    boundary_mass,
    compute_basis,
    correction_samples,
    default_basis_values,
    is_exchange,
    split_modes,
    with_corrections,
)
from aromm.pod import pod_coefficients
from aromm.system import Affine, Coefficient, FloatArray, Observables, Term, ThermalSystem, TimeGrid

#: Modal rates below this fraction of the largest are the zero (mean-temperature) modes.
ZERO_RATE = 1e-11
#: Negative modal rates beyond this fraction of the largest mean a growing mode (refused).
NEGATIVE_RATE = 1e-8


@functools.cache
def _threads() -> ThreadpoolController:
    """Created on first use (inspecting the loaded BLAS costs ~2 ms; limiting through it ~0.01 ms)."""
    return ThreadpoolController()


def _one_blas_thread() -> contextlib.AbstractContextManager[object]:
    """Small dense algebra runs single-threaded: on a loaded 2-core machine threaded OpenBLAS made a
    200 × 200 eigh 13× slower (258 ms vs 19 ms, measured), solvers.md reports up to 100×."""
    limiter: contextlib.AbstractContextManager[object] = _threads().limit(limits=1, user_api="blas")
    return limiter


@dataclass(frozen=True)
class ProjectedTerm:
    """``coefficient(p) * operator`` with a projected (r × r) matrix or (r,) vector."""

    name: str
    coefficient: Coefficient
    operator: FloatArray


def _project_affine(affine: Affine, basis: FloatArray, vector: bool, memo: dict[int, FloatArray]) -> tuple[
        ProjectedTerm, ...]:
    out = []
    for t in affine.terms:
        key = id(t.operator)
        if key not in memo:
            if vector:
                memo[key] = basis.T @ np.asarray(t.operator, dtype=float)
            else:
                op = sp.csr_array(t.operator) @ basis
                memo[key] = basis.T @ op
        out.append(ProjectedTerm(t.name, t.coefficient, memo[key]))
    return tuple(out)


@dataclass(frozen=True)
class ReducedModel:
    """A Galerkin-projected ThermalSystem of order r; implements the ForwardModel protocol (aromm.model).

    ``initial`` holds ``Ψᵀ C_j 1`` per capacity term (the initial state for a uniform ``initial.T``).
    ``info`` records how it was built (orders, seconds, errors on the reference cases).
    """

    capacity: tuple[ProjectedTerm, ...]
    conductance: tuple[ProjectedTerm, ...]
    load: tuple[ProjectedTerm, ...]
    initial: tuple[ProjectedTerm, ...]
    output_names: tuple[str, ...]
    output_matrix: FloatArray
    parameters: Mapping[str, float]
    time: TimeGrid | None = None
    info: Mapping[str, float | int | str] = field(default_factory=dict)

    # ----------------------------------------------------------------- construction
    @classmethod
    def from_system(cls, system: ThermalSystem, basis: FloatArray,
                    memo: dict[int, FloatArray] | None = None) -> ReducedModel:
        """Galerkin projection of every term of ``system`` onto the columns of ``basis`` (n × r).

        ``memo`` (id of a sparse operator → projection) shares work between systems on one mesh.
        """
        if system.dirichlet:
            names = ", ".join(d.param for d in system.dirichlet)
            raise InputError(
                f"fixed temperatures ({names}) are not supported by the reduced model (natural boundary "
                "conditions only); replace them by convection with a large h (penalty)"
            )
        if system.is_steady:
            raise InputError("the reduced model needs a transient system (a [time] section and capacities c)")
        memo = {} if memo is None else memo
        ones = np.ones(system.n)
        output_names, e = system.observation_matrix()
        initial = tuple(
            ProjectedTerm(t.name, t.coefficient, basis.T @ (sp.csr_array(t.operator) @ ones))
            for t in system.capacity.terms
        )
        return cls(
            capacity=_project_affine(system.capacity, basis, False, memo),
            conductance=_project_affine(system.conductance, basis, False, memo),
            load=_project_affine(system.load, basis, True, memo),
            initial=initial,
            output_names=output_names,
            output_matrix=e @ basis,
            parameters={k: float(v) for k, v in system.parameters.items()},
            time=system.time,
        )

    def transform(self, a: FloatArray, info: Mapping[str, float | int | str] | None = None) -> ReducedModel:
        """The model on the basis Ψ A (``a`` is r × r'): every operator becomes ``AᵀXA`` / ``AᵀX``."""

        def mat(terms: tuple[ProjectedTerm, ...]) -> tuple[ProjectedTerm, ...]:
            return tuple(replace(t, operator=a.T @ t.operator @ a) for t in terms)

        def vec(terms: tuple[ProjectedTerm, ...]) -> tuple[ProjectedTerm, ...]:
            return tuple(replace(t, operator=a.T @ t.operator) for t in terms)

        return replace(self, capacity=mat(self.capacity), conductance=mat(self.conductance), load=vec(self.load),
                       initial=vec(self.initial), output_matrix=self.output_matrix @ a,
                       info=dict(info) if info is not None else dict(self.info))

    # ----------------------------------------------------------------- protocol
    @property
    def order(self) -> int:
        return int(self.output_matrix.shape[1])

    @property
    def outputs(self) -> tuple[str, ...]:
        return self.output_names

    @property
    def parameter_names(self) -> frozenset[str]:
        names = {p for group in (self.capacity, self.conductance, self.load) for t in group
                 for p in t.coefficient.params}
        return frozenset(names | {"initial.T"})

    @property
    def default_times(self) -> FloatArray:
        return self.time.times if self.time is not None else np.zeros(1)

    def simulate(self, params: Mapping[str, float] | None = None,
                 times: npt.ArrayLike | None = None) -> Observables:
        """One parameter set (overrides of the scene's values) → face means at ``times`` (exact in time)."""
        t = self._times(times)
        y = self.simulate_batch({k: [v] for k, v in (params or {}).items()}, t)[0]
        return Observables(t=t, mean_T={name: y[:, i] for i, name in enumerate(self.output_names)})

    def simulate_batch(self, params: Mapping[str, npt.ArrayLike],
                       times: npt.ArrayLike | None = None) -> FloatArray:
        """Arrays of equal length m per parameter → outputs (m, len(times), n_outputs)."""
        t = self._times(times)
        values, m = self._values(params)
        with _one_blas_thread():
            modal = self._modal(values, m)
            y = modal.outputs(t)
        return y

    def states(self, params: Mapping[str, float] | None, times: npt.ArrayLike) -> FloatArray:
        """Reduced states X (len(times), r) for one parameter set (T ≈ Ψ X)."""
        values, m = self._values({k: [v] for k, v in (params or {}).items()})
        with _one_blas_thread():
            return self._modal(values, m).states(np.asarray(times, dtype=float))[0]

    def rates(self, params: Mapping[str, npt.ArrayLike] | None = None) -> FloatArray:
        """Modal rates Λ (s⁻¹, ascending, ≥ 0; 1/Λ are the time constants), shape (m, r)."""
        values, m = self._values(params or {})
        with _one_blas_thread():
            return self._modal(values, m).rates

    def steady(self, params: Mapping[str, npt.ArrayLike] | None = None) -> FloatArray:
        """Steady limit of the outputs, (m, n_outputs); refused when no exchange fixes the mean temperature."""
        values, m = self._values(params or {})
        a = self._stack(self.conductance, values, m)
        n = self._stack(self.load, values, m) if self.load else np.zeros((m, self.order))
        try:
            x = np.linalg.solve(a, n[..., None])[..., 0]
        except np.linalg.LinAlgError:
            raise NumericalError("reduced steady state: conductance matrix is singular (no exchange with the "
                                 "surroundings, the mean temperature has no steady limit)") from None
        cond = np.linalg.cond(a)
        if not np.all(cond < 1e13):
            raise NumericalError(f"reduced steady state: conductance matrix condition number {cond.max():.1e} "
                                 "(no exchange with the surroundings, the mean temperature has no steady limit)")
        return x @ self.output_matrix.T

    # ----------------------------------------------------------------- internals
    def _times(self, times: npt.ArrayLike | None) -> FloatArray:
        if times is None:
            if self.time is None:
                raise InputError("no output times given and the system has no time grid")
            return self.time.times
        t = np.atleast_1d(np.asarray(times, dtype=float)).ravel()
        if t.size == 0 or not np.all(np.isfinite(t)) or np.any(t < 0):
            raise InputError("output times must be finite and non-negative")
        return t

    def _values(self, params: Mapping[str, npt.ArrayLike]) -> tuple[dict[str, FloatArray], int]:
        known = self.parameter_names
        unknown = sorted(set(params) - known)
        if unknown:
            raise InputError(f"unknown parameter(s) {unknown}; this model has {sorted(known)}")
        arrays = {k: np.atleast_1d(np.asarray(v, dtype=float)).ravel() for k, v in params.items()}
        sizes = {a.size for a in arrays.values()}
        if len(sizes) > 1:
            raise InputError(f"parameter arrays must have equal lengths, got {sorted(sizes)}")
        m = sizes.pop() if sizes else 1
        values: dict[str, FloatArray] = {k: np.full(m, v) for k, v in self.parameters.items()}
        values.setdefault("initial.T", np.zeros(m))
        values.update(arrays)
        for k, v in values.items():
            if not np.all(np.isfinite(v)):
                raise InputError(f"parameter {k!r} has non-finite values")
        return values, m

    @staticmethod
    def _stack(terms: Sequence[ProjectedTerm], values: Mapping[str, FloatArray], m: int) -> FloatArray:
        coef = np.stack([np.broadcast_to(t.coefficient(values), (m,)) for t in terms], axis=1)  # (m, j)
        ops = np.stack([t.operator for t in terms])
        return np.tensordot(coef, ops, axes=(1, 0))

    def _modal(self, values: Mapping[str, FloatArray], m: int) -> _ModalForm:
        lmat = self._stack(self.capacity, values, m)
        amat = self._stack(self.conductance, values, m)
        nvec = self._stack(self.load, values, m) if self.load else np.zeros((m, self.order))
        rhs0 = self._stack(self.initial, values, m) * values["initial.T"][:, None]
        try:
            chol = np.linalg.cholesky(lmat)
        except np.linalg.LinAlgError:
            raise NumericalError("reduced model: projected capacity matrix L is not positive definite "
                                 "(non-positive capacity, or a dependent basis)") from None
        rinv = np.linalg.inv(chol)
        sym = rinv @ amat @ np.swapaxes(rinv, 1, 2)
        lam, q = np.linalg.eigh((sym + np.swapaxes(sym, 1, 2)) / 2)
        top = np.max(np.abs(lam), axis=1, keepdims=True)
        if np.any(lam < -NEGATIVE_RATE * top):
            raise NumericalError(f"reduced model: growing mode (rate {lam.min():.3e} s⁻¹): the projected "
                                 "conductance is not positive semi-definite (negative conductivity?)")
        lam = np.where(lam < ZERO_RATE * top, 0.0, lam)
        w = np.swapaxes(rinv, 1, 2) @ q  # Wᵀ L W = I, Wᵀ A W = Λ
        wt = np.swapaxes(w, 1, 2)
        return _ModalForm(lam, w, (wt @ rhs0[..., None])[..., 0], (wt @ nvec[..., None])[..., 0],
                          self.output_matrix)


@dataclass(frozen=True)
class _ModalForm:
    """Diagonalised reduced system for m parameter sets: Ẏ = −ΛY + b, Y(0) = y0, X = W Y."""

    rates: FloatArray  # (m, r)
    w: FloatArray  # (m, r, r)
    y0: FloatArray  # (m, r)
    b: FloatArray  # (m, r)
    e: FloatArray  # (n_out, r)

    def modal(self, t: FloatArray) -> FloatArray:
        """Y at times t, shape (m, r, nt): exact for inputs constant in time."""
        x = self.rates[..., None] * t[None, None, :]
        small = x < 1e-8
        phi = np.where(small, t * (1.0 - 0.5 * x), -np.expm1(-x) / np.where(small, 1.0, self.rates[..., None]))
        return np.exp(-x) * self.y0[..., None] + phi * self.b[..., None]

    def outputs(self, t: FloatArray) -> FloatArray:
        g = self.e[None] @ self.w  # (m, n_out, r)
        return np.swapaxes(g @ self.modal(t), 1, 2)

    def states(self, t: FloatArray) -> FloatArray:
        return np.swapaxes(self.w @ self.modal(t), 1, 2)


# ===================================================================== building a reduced model

#: Fibre properties of the amalgam reference cases in seed 001 §3.2 (gas as in the bases).
SEED001_REFERENCE_VALUES: Mapping[str, float] = {"fibre.k": 0.1, "fibre.c": 1.2e6, "gas.k": 0.025, "gas.c": 1.2e3}
#: Relaxation reference case of seed 001 §3.2: initially at 30 °C, cooled on all faces (h in W/(m² K)).
RELAXATION_T0 = 30.0
RELAXATION_H = 20.0
METHODS = ("aromm", "pod")
_ROM_VERSION = 2


@dataclass(frozen=True)
class ReferenceCase:
    """A reference simulation for the amalgam: a system on the same mesh, parameter values, times."""

    system: ThermalSystem
    values: Mapping[str, float] = field(default_factory=dict)
    times: FloatArray | None = None
    name: str = "reference"


def default_modes(order: int) -> int:
    """Default detailed basis size Ñ = 1.5 ñ + 20 (ñ = 200 → Ñ = 320: on the shipped wood VER Ñ = 300 gave
    0.002 °C at ñ = 200 within 252 s of CPU, benchmarks/aromm_wood.py)."""
    return int(1.5 * order) + 20


def default_reference_values(system: ThermalSystem) -> dict[str, float]:
    """The system's parameters with the seed 001 reference properties for phases named fibre/gas."""
    out = {k: float(v) for k, v in system.parameters.items()}
    out.update({k: v for k, v in SEED001_REFERENCE_VALUES.items() if k in out})
    return out


def relaxation_case(system: ThermalSystem, values: Mapping[str, float], boundary: sp.csr_array,
                    h: float = RELAXATION_H, initial: float = RELAXATION_T0) -> ReferenceCase:
    """Seed 001 §3.2: the body at ``initial`` °C cooled by ``h`` on its whole boundary, no other load."""
    conduction = tuple(t for t in system.conductance.terms if not is_exchange(t.operator))
    cooled = ThermalSystem(
        n=system.n,
        conductance=Affine((*conduction, Term("H_boundary", Coefficient(("relaxation.h",)), boundary))),
        capacity=system.capacity,
        parameters={**values, "relaxation.h": h},
        time=system.time,
    )
    return ReferenceCase(cooled, {**values, "relaxation.h": h, "initial.T": initial}, name="relaxation")


def snapshot_times(grid: TimeGrid | None) -> FloatArray:
    """The scene's output grid plus 60 log-spaced times from dt/100 (early boundary layers)."""
    if grid is None:
        raise InputError("the reduced model needs a time grid ([time] section)")
    early = np.geomspace(grid.dt / 100.0, grid.end, 60)
    return np.unique(np.concatenate([early, grid.times]))


def _resolve_cache(cache: bool | str | os.PathLike[str] | NpzCache | None) -> NpzCache | None:
    if cache is None or cache is False:
        return None
    if cache is True:
        return NpzCache()
    if isinstance(cache, NpzCache):
        return cache
    return NpzCache(cache)


def reduce(
    system: ThermalSystem,
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
    method: str = "aromm",
    solver: str = "auto",
    eigensolver: str = "auto",
    basis_storage: str = "float64",
    cache: bool | str | os.PathLike[str] | NpzCache | None = True,
    progress: bool = False,
    eigen_progress: ProgressCallback | None = None,
) -> ReducedModel:
    """AROMM reduced model of ``system`` at order ``order`` (seed 001 §3).

    * Detailed basis: constants + Steklov + Dirichlet modes (aromm.modes) at ``basis_values``
      (default: the system's parameters with the seed's reference properties for fibre/gas),
      ``modes`` = Ñ in total (default :func:`default_modes`), split evenly unless ``n_dirichlet`` /
      ``n_steklov`` are given (``n_steklov`` counts the constants).
    * Reference cases (exact simulations of the detailed modal model): the system itself at
      ``reference_values`` (default: seed 001 §3.2, k_F = 0.1, c_F = 1.2e6), each of
      ``references`` (other scenarios on the same mesh), and the relaxation from 30 °C cooled
      on the whole boundary (``relaxation``).
    * ``corrections``: enrich the basis with static and first-order dynamic correction modes of the
      system's loads (aromm.modes.with_corrections; an extension of seed 001) at the parameter
      samples of :func:`aromm.modes.correction_samples` (True), at given samples (a list of
      parameter dicts), or not at all (False: the method of the seed exactly).  They are kept
      principal and alone by the amalgam, like the constants.
    * ``method``: ``"aromm"`` (amalgam, eq. 9) or ``"pod"`` (POD–Galerkin baseline).
    * ``cache``: True (default directory), a directory, an NpzCache, or False.  Bases and reduced
      models are stored by content hash; a second call with the same inputs loads the result.
    * ``eigensolver``: ``"arpack"`` (shift-invert on a sparse factorisation ``solver``), ``"lobpcg"``
      (aromm.eigensolvers; the correction modes then use multigrid-preconditioned CG unless ``solver``
      says otherwise) or ``"auto"`` (by size).  ``eigen_progress`` receives every
      :class:`~aromm.eigensolvers.EigenProgress` report (converged pairs, iterations); ``progress``
      shows them as a bar.  ``basis_storage``: ``"float32"`` keeps and caches the modes in single precision.
    """
    if method not in METHODS:
        raise InputError(f"unknown reduction method {method!r}; allowed: {', '.join(METHODS)}")
    if isinstance(order, bool) or not isinstance(order, int | np.integer) or order < 1:
        raise InputError(f"order must be a positive integer, got {order!r}")
    total = int(modes) if modes is not None else default_modes(int(order))
    if n_dirichlet is None and n_steklov is None:
        n_d, n_s = split_modes(system, total)
    else:
        n_s = int(n_steklov) if n_steklov is not None else total - int(n_dirichlet or 0)
        n_d = int(n_dirichlet) if n_dirichlet is not None else total - n_s
    ref_vals = default_reference_values(system)
    ref_vals.update({k: float(v) for k, v in (reference_values or {}).items()})
    cases: list[ReferenceCase] = [ReferenceCase(system, ref_vals, name="system")]
    for ref in references:
        if isinstance(ref, ThermalSystem):
            vals = default_reference_values(ref)
            vals.update({k: float(v) for k, v in (reference_values or {}).items()})
            cases.append(ReferenceCase(ref, vals))
        else:
            cases.append(ref)
    for case in cases:
        if case.system.n != system.n:
            raise InputError(f"reference case {case.name!r} has {case.system.n} unknowns, the system {system.n}")
    store = _resolve_cache(cache)
    if corrections is True:
        samples = correction_samples(system, basis_values)
    elif corrections is False:
        samples = []
    else:
        samples = [dict(s) for s in corrections]
    eig = choose_eigensolver(eigensolver, system.n)
    linear = "amg" if eig == "lobpcg" and solver == "auto" else solver
    key = content_key(_ROM_VERSION, system.fingerprint(), order, n_d, n_s, basis_values or {}, method, solver,
                      relaxation, samples, [(c.system.fingerprint(), dict(c.values), c.times) for c in cases],
                      *([eig] if eig != "arpack" else []), *([basis_storage] if basis_storage != "float64" else []))
    if store is not None:
        stored = store.load("rom", key)
        if stored is not None:
            rom = _from_arrays(stored)
            return replace(rom, info={**rom.info, "cached": 1, "offline_seconds": 0.0})

    start = time.perf_counter()
    stages = tqdm(total=4, desc="reduce", disable=not progress, leave=False, file=sys.stderr)
    stages.set_postfix_str("modes")
    pairs = PairsBar(enabled=progress, listener=eigen_progress)
    basis = compute_basis(system, n_d, n_s, basis_values, method=solver, eigensolver=eig, cache=store,
                          progress=pairs, storage=basis_storage)
    pairs.close()
    stages.set_postfix_str("correction modes")
    if samples:
        basis = with_corrections(system, basis, samples, values=basis_values, method=linear, cache=store)
    stages.update()
    stages.set_postfix_str("projection")
    memo: dict[int, FloatArray] = {}
    detailed = ReducedModel.from_system(system, basis.vectors, memo)
    if relaxation:
        cases.append(relaxation_case(system, ref_vals, boundary_mass(system)))
    snapshots = []
    for case in cases:
        model = detailed if case.system is system else ReducedModel.from_system(case.system, basis.vectors, memo)
        names = model.parameter_names
        times = case.times if case.times is not None else snapshot_times(case.system.time or system.time)
        x = model.states({k: v for k, v in case.values.items() if k in names}, times).T
        free = np.flatnonzero(basis.kinds != "zero")
        scale = float(np.linalg.norm(x[free]))
        snapshots.append(x / scale if scale > 0 else x)
    stages.update()
    stages.set_postfix_str(method)
    states = np.hstack(snapshots)
    coefficients = _reduction(basis, states, order, method=method, detailed=detailed, system=system,
                              basis_values=basis_values)
    stages.update()
    rom = detailed.transform(coefficients)
    check_t = snapshot_times(system.time)
    own = {k: v for k, v in ref_vals.items() if k in detailed.parameter_names}
    err = float(np.abs(rom.simulate(own, check_t).as_array() - detailed.simulate(own, check_t).as_array()).max(
        initial=0.0))
    stages.update()
    stages.close()
    info: dict[str, float | int | str] = {
        "method": method, "order": rom.order, "modes": basis.size, "n_dirichlet": basis.count("dirichlet"),
        "n_steklov": basis.count("steklov") + basis.count("zero"), "n_corrections": basis.count("correction"),
        "zeta": basis.zeta,
        "basis_seconds": float(basis.info.get("seconds", 0.0)), "basis_cached": int(basis.info.get("cached", 0)),
        "gram_condition": float(basis.info.get("gram_condition", np.nan)),
        "offline_seconds": time.perf_counter() - start, "reference_error": err, "cached": 0, "key": key,
        "eigensolver": eig, "eigen_iterations": sum(pairs.iterations.values()),
    }
    rom = replace(rom, info=info)
    if store is not None:
        store.save("rom", key, _to_arrays(rom))
    return rom


def _reduction(basis: ModalBasis, states: FloatArray, order: int, *, method: str, detailed: ReducedModel,
               system: ThermalSystem, basis_values: Mapping[str, float] | None) -> FloatArray:
    """Coefficients A (Ñ × ñ) of the reduced basis Ψ = Φ A.

    The constants are kept alone; the correction vectors (when the order leaves room for them and one
    more mode) are kept as whole columns, the other ñ − m columns come from the amalgam (or POD) of
    the Dirichlet–Steklov modes.  Otherwise the correction directions compete like modes.
    """
    if order >= basis.size:
        return np.eye(basis.size)
    corr = basis.corrections if basis.corrections is not None else np.zeros((basis.size, 0))
    zero = basis.zero_modes
    rows = np.flatnonzero(basis.kinds != "correction")
    keep_corr = 0 < corr.shape[1] < order - zero.size and order - corr.shape[1] < rows.size
    units = np.zeros((basis.size, zero.size))
    units[zero, np.arange(zero.size)] = 1.0
    if method == "pod":
        bvals, _ = detailed._values({k: [v] for k, v in _basis_values(system, basis_values).items()
                                     if k in detailed.parameter_names})
        gram = detailed._stack(detailed.capacity, bvals, 1)[0]
        kept = np.column_stack([units, corr]) if keep_corr else units
        return pod_coefficients(states, gram, order, kept)
    if not keep_corr:
        return amalgam(states, order, zero).coefficients
    sub = amalgam(states[rows], order - corr.shape[1], np.searchsorted(rows, zero)).coefficients
    a = np.zeros((basis.size, order))
    a[rows, : sub.shape[1]] = sub
    a[:, sub.shape[1]:] = corr
    return a


def _basis_values(system: ThermalSystem, values: Mapping[str, float] | None) -> dict[str, float]:
    out = default_basis_values(system)
    out.update({k: float(v) for k, v in (values or {}).items()})
    return out


# ----------------------------------------------------------------- (de)serialisation, no pickle

_GROUPS = ("capacity", "conductance", "load", "initial")


def _to_arrays(rom: ReducedModel) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for group in _GROUPS:
        terms: tuple[ProjectedTerm, ...] = getattr(rom, group)
        out[f"{group}.names"] = np.array([t.name for t in terms], dtype=str)
        out[f"{group}.params"] = np.array([",".join(t.coefficient.params) for t in terms], dtype=str)
        out[f"{group}.kinds"] = np.array([t.coefficient.kind for t in terms], dtype=str)
        out[f"{group}.scales"] = np.array([t.coefficient.scale for t in terms], dtype=float)
        for i, t in enumerate(terms):
            out[f"{group}.op{i}"] = t.operator
    out["outputs.names"] = np.array(rom.output_names, dtype=str)
    out["outputs.matrix"] = rom.output_matrix
    out["parameters.names"] = np.array(list(rom.parameters), dtype=str)
    out["parameters.values"] = np.array(list(rom.parameters.values()), dtype=float)
    out["time"] = np.array([rom.time.end, rom.time.dt] if rom.time is not None else [], dtype=float)
    out["info.names"] = np.array(list(rom.info), dtype=str)
    out["info.values"] = np.array([str(v) for v in rom.info.values()], dtype=str)
    return out


def _info_value(text: str) -> float | int | str:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            continue
    return text


def _from_arrays(data: Mapping[str, np.ndarray]) -> ReducedModel:
    groups: dict[str, tuple[ProjectedTerm, ...]] = {}
    for group in _GROUPS:
        names = [str(s) for s in data[f"{group}.names"]]
        terms = []
        for i, name in enumerate(names):
            params = str(data[f"{group}.params"][i])
            coef = Coefficient(tuple(params.split(",")) if params else (),
                               "harmonic" if str(data[f"{group}.kinds"][i]) == "harmonic" else "product",
                               float(data[f"{group}.scales"][i]))
            terms.append(ProjectedTerm(name, coef, np.asarray(data[f"{group}.op{i}"])))
        groups[group] = tuple(terms)
    t = data["time"]
    return ReducedModel(
        capacity=groups["capacity"], conductance=groups["conductance"], load=groups["load"],
        initial=groups["initial"], output_names=tuple(str(s) for s in data["outputs.names"]),
        output_matrix=np.asarray(data["outputs.matrix"]),
        parameters={str(k): float(v) for k, v in zip(data["parameters.names"], data["parameters.values"],
                                                      strict=True)},
        time=TimeGrid(float(t[0]), float(t[1])) if t.size else None,
        info={str(k): _info_value(str(v)) for k, v in zip(data["info.names"], data["info.values"], strict=True)},
    )
