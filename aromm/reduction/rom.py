"""The online reduced model: a Galerkin-projected ThermalSystem with exact modal time integration.

For a basis Ψ (n × r) every term of the ThermalSystem keeps its coefficient and role and gets a projected
operator [Chavez2020, eq. 10] (sign convention ``M = −ΨᵀKΨ`` of [Quemener2012])::

    L(p) = Σ c_j(p) Ψᵀ C_j Ψ          (L_F, L_G)
    A(p) = Σ k_j(p) Ψᵀ K_j Ψ = −M(p)  (M_F, M_G, M_H)
    N(p) = Σ f_j(p) Ψᵀ F_j            (N)
    L(p) dX/dt = −A(p) X + N(p, t),   L(p) X(0) = Σ c_j(p) Ψᵀ C_j T0(p),   y = E Ψ X + D(p, t).

The projected operators form an ordinary :class:`~aromm.core.system.ThermalSystem` of order r (dense
operators), so parameter handling and affine evaluation are those of the full model.  Evaluation never
touches the mesh.  For each parameter set the small generalised eigenproblem ``A W = L W Λ``
(``Wᵀ L W = I``, Λ ≥ 0) diagonalises the system; with ``Y = Wᵀ L X`` and inputs constant in time the
solution is exact at any time::

    Y(t) = e^{−Λt} Y0 + (1 − e^{−Λt})/Λ · Wᵀ N     (→ Y0 + t WᵀN for Λ = 0),

and it stays exact for load histories that are piecewise linear in time (:mod:`aromm.reduction.modal_integration`),
so the reduced model has no time-step error.  The steady limit (when A is invertible) is ``X∞ = A⁻¹ N`` with
the histories held at their final values.  ``D(p, t)`` is the feedthrough of a system whose fixed
temperatures were lifted (:mod:`aromm.reduction.lifting`), zero otherwise.  A whole swarm of parameter sets is
evaluated in one call with stacked (batched) Cholesky, inverse and eigh.  The offline construction of Ψ
is in :mod:`aromm.reduction.offline`.  Temperature fields ``T(t) ≈ Ψ X(t) + Σ_d τ_d g_d(t) ℓ_d`` (the lifting of fixed
temperatures, :mod:`aromm.reduction.lifting`) need Ψ itself (n × r), which a model keeps only when built with
``reduce(..., fields=True)``; they are reconstructed one time at a time.
"""

from __future__ import annotations

import contextlib
import functools
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from threadpoolctl import ThreadpoolController

from aromm.core import resources
from aromm.core.domain import warn_outside
from aromm.core.errors import InputError, NumericalError
from aromm.core.forward_model import one_set
from aromm.core.observables import Observables
from aromm.core.profiles import Profile
from aromm.core.resources import FLOAT
from aromm.core.system import (
    Affine,
    Coefficient,
    FloatArray,
    Term,
    ThermalSystem,
    TimeGrid,
    is_matrix_free,
    require_free_transient,
)
from aromm.reduction.certificate import Certificate, error_bound, through_finer
from aromm.reduction.modal_integration import ModalForm, diagonalise

#: Largest condition number of the reduced conductance accepted for a steady limit.
STEADY_CONDITION_MAX = 1e13
#: (m, r, n_times) arrays alive at once in _ModalForm.modal: measured peak 4.2 (tracemalloc).
MODAL_WORK = 5


@functools.cache
def _threads() -> ThreadpoolController:
    """Created on first use (inspecting the loaded BLAS costs ~2 ms; limiting through it ~0.01 ms)."""
    return ThreadpoolController()


def one_blas_thread() -> contextlib.AbstractContextManager[object]:
    """Small dense algebra runs single-threaded: on a loaded 2-core machine threaded OpenBLAS made a
    200 × 200 eigh 13× slower (258 ms vs 19 ms, measured)."""
    limiter: contextlib.AbstractContextManager[object] = _threads().limit(limits=1, user_api="blas")
    return limiter


def project(affine: Affine, basis: FloatArray, memo: dict[int, FloatArray] | None = None) -> Affine:
    """Every term with its operator projected: ``Ψᵀ A Ψ`` for a matrix, ``Ψᵀ f`` for a vector.

    ``memo`` (id of an operator → projection) shares work between systems on one mesh.
    """
    memo = {} if memo is None else memo
    out = []
    for t in affine.terms:
        key = id(t.operator)
        if key not in memo:
            if is_matrix_free(t.operator):  # column by column: no (n × r) product held
                memo[key] = np.column_stack([basis.T @ np.asarray(t.operator @ basis[:, j])
                                             for j in range(basis.shape[1])]) if basis.shape[1] else \
                    np.zeros((0, 0))
            elif sp.issparse(t.operator):
                memo[key] = basis.T @ (sp.csr_array(t.operator) @ basis)
            else:
                memo[key] = basis.T @ np.asarray(t.operator, dtype=float)
        out.append(replace(t, operator=memo[key]))
    return Affine(tuple(out))


def _transformed(affine: Affine, a: FloatArray) -> Affine:
    return Affine(tuple(replace(t, operator=a.T @ t.operator @ a if np.ndim(t.operator) == 2 else a.T @ t.operator)
                        for t in affine.terms))


@dataclass(frozen=True)
class ReducedModel:
    """A Galerkin-projected ThermalSystem of order r; implements the ForwardModel protocol (aromm.core.forward_model).

    ``projected`` is the reduced system (dense r × r operators, projected observation rows, the scene's
    parameters and time grid, the feedthrough of a lifted system); ``initial`` holds ``Ψᵀ C_j 1`` per
    capacity term with the coefficient ``c_j · initial.T`` (the initial state of a uniform initial
    temperature), and ``Ψᵀ C_j v_i`` with ``c_j · c_i`` for each initial-field term of the system.
    ``info`` records how the model was built (orders, seconds, errors on the reference cases).
    ``basis`` is Ψ on every unknown of the full model (n × r, zero rows on fixed nodes) and ``field_lifting``
    the lifting of the fixed temperatures (terms ``τ_d g_d(t) ℓ_d``, vectors of length n), for fields; both are
    empty by default (evaluations of outputs never need them).  :meth:`transform` carries ``basis`` along
    (Ψ A), so a model given the identity as its basis records the coefficients of its reductions.
    ``box`` is the training box, (name, lower, upper) per parameter (SI), over which the model was built: every
    other parameter is pinned at its value in ``projected.parameters`` (:mod:`aromm.core.domain` says where
    the model is valid); empty for a model built at the scene's values only (the modal methods).
    ``certificate`` is the offline data of its certified output error bound, ``finer`` a certified model of the same
    full model and larger order (a Krylov model's span before its compression) that tightens it (:meth:`error_bound`).
    """

    projected: ThermalSystem
    initial: Affine
    info: Mapping[str, float | int | str] = field(default_factory=dict)
    basis: FloatArray | None = field(default=None, repr=False, compare=False)
    field_lifting: Affine = field(default=Affine(), repr=False, compare=False)
    box: tuple[tuple[str, float, float], ...] = ()
    certificate: Certificate | None = field(default=None, repr=False, compare=False)
    finer: ReducedModel | None = field(default=None, repr=False, compare=False)

    @classmethod
    def from_system(cls, system: ThermalSystem, basis: FloatArray,
                    memo: dict[int, FloatArray] | None = None) -> ReducedModel:
        """Galerkin projection of every term of ``system`` onto the columns of ``basis`` (n × r).

        Fixed temperatures must have been lifted first (:func:`aromm.reduction.lifting.lift`; :func:`aromm.reduce`
        does it): the basis spans the free unknowns only.
        """
        require_free_transient(system, "the projection onto a basis")
        fields = [(Coefficient(("initial.T",)), np.ones(system.n), "")]
        fields += [(t.coefficient, np.asarray(t.operator, dtype=float), f"·{t.name}") for t in system.initial.terms]
        initial = Affine(tuple(
            Term(t.name + suffix, t.coefficient.times(coef), basis.T @ np.asarray(t.operator @ vec), "capacity")
            for coef, vec, suffix in fields for t in system.capacity.terms))
        outputs, e = system.observation_matrix()
        e_basis = np.asarray(e @ basis)  # dense or sparse (sensor) rows
        projected = ThermalSystem(
            n=basis.shape[1],
            conductance=project(system.conductance, basis, memo),
            capacity=project(system.capacity, basis, memo),
            load=project(system.load, basis, memo),
            observation={name: e_basis[i] for i, name in enumerate(outputs)},
            parameters={k: float(v) for k, v in system.parameters.items()},
            time=system.time,
            feedthrough=system.feedthrough,
        )
        return cls(projected, initial)

    def transform(self, a: FloatArray, info: Mapping[str, float | int | str] | None = None) -> ReducedModel:
        """The model on the basis Ψ A (``a`` is r × r'): every operator becomes ``AᵀXA`` / ``AᵀX``."""
        sys_ = self.projected
        projected = replace(sys_, n=a.shape[1], conductance=_transformed(sys_.conductance, a),
                            capacity=_transformed(sys_.capacity, a), load=_transformed(sys_.load, a),
                            observation={k: row @ a for k, row in sys_.observation.items()})
        return ReducedModel(projected, _transformed(self.initial, a),
                            dict(info) if info is not None else dict(self.info),
                            self.basis @ a if self.basis is not None else None, self.field_lifting)

    def with_parameters(self, values: Mapping[str, float]) -> ReducedModel:
        """The model with a scene's values of the parameters of its training box (a model of the cache serves every
        scene whose values differ only inside its box, :mod:`aromm.reduction.model_key`; the values it pinned
        stay)."""
        names = {name for name, _, _ in self.box}
        own = {**self.projected.parameters, **{k: float(v) for k, v in values.items() if k in names}}
        finer = self.finer.with_parameters(values) if self.finer is not None else None
        return replace(self, projected=replace(self.projected, parameters=own), finer=finer)

    def check_domain(self, values: Mapping[str, npt.ArrayLike], use: str) -> None:
        """Warn (:class:`~aromm.core.errors.ModelWarning`, once) when ``values`` leave the model's domain: its box,
        or another value of a parameter it pinned that enters its operators (:mod:`aromm.core.domain`; the
        parameters of its loads and initial state only scale inputs)."""
        operators = self.projected.capacity.parameters | self.projected.conductance.parameters
        warn_outside(self.box, self.parameters, values, use, scaling=self.parameter_names - operators)

    @property
    def output_error(self) -> float:
        """What the model says of its own output error (°C, ``info["reference_error"]``: a Krylov model's greedy
        estimate plus compression loss over its box, the amalgam's error on its reference case); 0 when unknown.  An
        estimate, not a bound: identification adds its shift to the intervals (inverse.uncertainty.bias_shift)."""
        value = float(self.info.get("reference_error", 0.0))
        return value if math.isfinite(value) else 0.0

    def error_bound(self, params: Mapping[str, float] | None = None, *,
                    finer_bound: FloatArray | None = None) -> FloatArray | None:
        """Certified upper bound (°C) of the largest ``|reduced − full|`` over the output times, per output, at
        ``params`` (:mod:`aromm.reduction.certificate`: against the same full model exact in time); None without a
        certificate (a model built on another engine, or too large to certify).  With a ``finer`` certified model of
        the same full model (a Krylov model's span before its compression) the smaller of the two valid bounds:
        the direct one, and the difference to the finer model plus the finer model's bound
        (:func:`~aromm.reduction.certificate.through_finer`; ``finer_bound``: the finer model's bound there, when
        known)."""
        if self.certificate is None:
            return None
        values = {**self.parameters, **(params or {})}
        direct = error_bound(self, self.certificate, values)
        if self.finer is None:
            return direct
        return np.minimum(direct, through_finer(self, self.finer, values, finer_bound))

    # ----------------------------------------------------------------- protocol
    @property
    def order(self) -> int:
        return self.projected.n

    @property
    def outputs(self) -> tuple[str, ...]:
        return tuple(self.projected.observation)

    @property
    def parameter_names(self) -> frozenset[str]:
        return self.projected.parameter_names

    @property
    def parameters(self) -> Mapping[str, float]:
        return self.projected.parameters

    @property
    def time(self) -> TimeGrid | None:
        return self.projected.time

    @property
    def default_times(self) -> FloatArray:
        return self.time.times if self.time is not None else np.zeros(1)

    def simulate(self, params: Mapping[str, float] | None = None,
                 times: npt.ArrayLike | None = None, *, fields: bool = False) -> Observables:
        """One parameter set (overrides of the scene's values) → outputs at ``times`` (exact in time); with
        ``fields`` also the reconstructed temperature fields (len(times), n) (:meth:`iter_fields`)."""
        t = self._times(times)
        self.check_domain({**self.parameters, **(params or {})}, "simulate")
        obs = one_set(self, params, t)
        return replace(obs, fields=np.stack([f for _, f in self.iter_fields(params, t)])) if fields else obs

    def iter_fields(self, params: Mapping[str, float] | None,
                    times: npt.ArrayLike) -> Iterator[tuple[float, FloatArray]]:
        """``(t, T(t) ≈ Ψ X(t) + Σ_d τ_d g_d(t) ℓ_d)`` for each time (°C at the n unknowns of the full model),
        one field at a time (only the r-vectors X of all times are held) [Chavez2020, eq. 5]."""
        if self.basis is None:
            raise InputError("this reduced model keeps no basis Ψ, so it cannot reconstruct temperature fields: "
                             "build it with reduce(..., fields=True)")
        t = self._times(times)
        values, _ = self.projected.batch_values({k: [v] for k, v in (params or {}).items()})
        for ti, x in zip(t, self.states(params, t), strict=True):
            lifted = self.field_lifting.stack(values, 1, float(ti))[0] if self.field_lifting else 0.0
            yield float(ti), self.basis @ x + lifted

    def simulate_batch(self, params: Mapping[str, npt.ArrayLike],
                       times: npt.ArrayLike | None = None) -> FloatArray:
        """Arrays of equal length m per parameter → outputs (m, len(times), n_outputs)."""
        t = self._times(times)
        values, m = self.projected.batch_values(params)
        n_out = len(self.outputs)
        resources.require(FLOAT * m * t.size * (MODAL_WORK * self.order + n_out), "the reduced model",
                          f"{m} parameter sets × {t.size} times × ({MODAL_WORK} work arrays × {self.order} modes + "
                          f"{n_out} outputs), 8 bytes each", "ask for fewer output times or fewer parameter sets")
        with one_blas_thread():
            return self._modal(values, m).outputs(t)

    def states(self, params: Mapping[str, float] | None, times: npt.ArrayLike) -> FloatArray:
        """Reduced states X (len(times), r) for one parameter set (T ≈ Ψ X)."""
        values, m = self.projected.batch_values({k: [v] for k, v in (params or {}).items()})
        with one_blas_thread():
            return self._modal(values, m).states(np.asarray(times, dtype=float))[0]

    def rates(self, params: Mapping[str, npt.ArrayLike] | None = None) -> FloatArray:
        """Modal rates Λ (s⁻¹, ascending, ≥ 0; 1/Λ are the time constants), shape (m, r)."""
        values, m = self.projected.batch_values(params or {})
        with one_blas_thread():
            return self._modal(values, m).rates

    def steady(self, params: Mapping[str, npt.ArrayLike] | None = None) -> FloatArray:
        """Steady limit of the outputs, (m, n_outputs), histories held at their final values; refused when
        no exchange fixes the mean temperature."""
        values, m = self.projected.batch_values(params or {})
        a = self.projected.conductance.stack(values, m)
        n = self._load(values, m, np.inf)
        cond = np.linalg.cond(a)
        if not np.all(cond < STEADY_CONDITION_MAX):
            raise NumericalError(f"reduced steady state: conductance matrix condition number {np.max(cond):.1e} "
                                 "(no exchange with the surroundings, the mean temperature has no steady limit)")
        x = np.linalg.solve(a, n[..., None])[..., 0]
        direct = self.projected.feedthrough
        return x @ self.projected.observation_matrix()[1].T + (direct.stack(values, m, np.inf) if direct else 0.0)

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

    def _load(self, values: Mapping[str, FloatArray], m: int, at: float) -> FloatArray:
        return self.projected.load.stack(values, m, at) if self.projected.load else np.zeros((m, self.order))

    def _modal(self, values: Mapping[str, FloatArray], m: int) -> ModalForm:
        lmat = self.projected.capacity.stack(values, m)
        amat = self.projected.conductance.stack(values, m)
        rhs0 = self.initial.stack(values, m)
        lam, w = diagonalise(lmat, amat)
        wt = np.swapaxes(w, 1, 2)
        constant = np.zeros((m, self.order))
        timed: list[tuple[FloatArray, Profile]] = []
        for term in self.projected.load.terms:
            vec = np.broadcast_to(term.coefficient(values), (m,))[:, None] * (wt @ np.asarray(term.operator))
            if term.time is None:
                constant += vec
            else:
                timed.append((vec, term.time))
        direct = [(np.broadcast_to(t.coefficient(values), (m,))[:, None] * np.asarray(t.operator), t.time)
                  for t in self.projected.feedthrough.terms]
        return ModalForm(lam, w, (wt @ rhs0[..., None])[..., 0], constant, timed,
                         self.projected.observation_matrix()[1], direct)


# ----------------------------------------------------------------- (de)serialisation, no pickle

_GROUPS = ("capacity", "conductance", "load", "initial", "feedthrough")


def _affine(model: ReducedModel, group: str) -> Affine:
    return model.initial if group == "initial" else getattr(model.projected, group)


def to_arrays(model: ReducedModel) -> dict[str, np.ndarray]:
    """Numeric and string arrays only (stored with ``np.savez``, read with ``allow_pickle=False``)."""
    out: dict[str, np.ndarray] = {}
    for group in _GROUPS:
        terms = _affine(model, group).terms
        out[f"{group}.names"] = np.array([t.name for t in terms], dtype=str)
        out[f"{group}.roles"] = np.array([t.role for t in terms], dtype=str)
        out[f"{group}.params"] = np.array([",".join(t.coefficient.params) for t in terms], dtype=str)
        out[f"{group}.kinds"] = np.array([t.coefficient.kind for t in terms], dtype=str)
        out[f"{group}.scales"] = np.array([t.coefficient.scale for t in terms], dtype=float)
        out[f"{group}.weights"] = np.array([(*t.coefficient.weights, t.coefficient.component) if t.coefficient.weights
                                            else (0.0, 0.0, 0.0, 0.0) for t in terms], dtype=float).reshape(-1, 4)
        for i, t in enumerate(terms):
            out[f"{group}.op{i}"] = np.asarray(t.operator)
            if t.time is not None:
                out[f"{group}.time{i}"] = t.time.arrays()
                out[f"{group}.timekind{i}"] = np.array(t.time.kind)
    names, e = model.projected.observation_matrix()
    out["outputs.names"] = np.array(names, dtype=str)
    out["outputs.matrix"] = e
    out["parameters.names"] = np.array(list(model.parameters), dtype=str)
    out["parameters.values"] = np.array(list(model.parameters.values()), dtype=float)
    out["time"] = np.array([model.time.end, model.time.dt] if model.time is not None else [], dtype=float)
    out["box.names"] = np.array([name for name, _, _ in model.box], dtype=str)
    out["box.bounds"] = np.array([[lo, hi] for _, lo, hi in model.box], dtype=float).reshape(-1, 2)
    out["info.names"] = np.array(list(model.info), dtype=str)
    out["info.values"] = np.array([str(v) for v in model.info.values()], dtype=str)
    if model.certificate is not None:
        out.update({f"certificate.{k}": v for k, v in model.certificate.arrays().items()})
    if model.finer is not None:
        out.update({f"finer.{k}": v for k, v in to_arrays(model.finer).items()})
    return out


def _info_value(text: str) -> float | int | str:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            continue
    return text


def from_arrays(data: Mapping[str, np.ndarray]) -> ReducedModel:
    """Inverse of :func:`to_arrays`."""
    groups: dict[str, Affine] = {}
    for group in _GROUPS:
        terms = []
        for i, name in enumerate(str(s) for s in data[f"{group}.names"]):
            params = str(data[f"{group}.params"][i])
            kind = str(data[f"{group}.kinds"][i])
            weights: tuple[float, ...] = ()
            component = 0
            if kind == "link":  # its three cone weights, then the coordinate (to_arrays)
                row = [float(w) for w in data[f"{group}.weights"][i]]
                weights, component = tuple(row[:3]), int(row[3])
            coef = Coefficient(tuple(params.split(",")) if params else (),
                               "link" if kind == "link" else "harmonic" if kind == "harmonic" else "product",
                               float(data[f"{group}.scales"][i]), weights, component)
            role = str(data[f"{group}.roles"][i])
            time = (Profile.from_arrays(data[f"{group}.time{i}"], str(data[f"{group}.timekind{i}"]))
                    if f"{group}.time{i}" in data else None)
            terms.append(Term(name, coef, np.asarray(data[f"{group}.op{i}"]), role, time))  # type: ignore[arg-type]
        groups[group] = Affine(tuple(terms))
    t = data["time"]
    e = np.asarray(data["outputs.matrix"])
    projected = ThermalSystem(
        n=e.shape[1], conductance=groups["conductance"], capacity=groups["capacity"], load=groups["load"],
        observation={str(name): e[i] for i, name in enumerate(data["outputs.names"])},
        parameters={str(k): float(v) for k, v in zip(data["parameters.names"], data["parameters.values"],
                                                      strict=True)},
        time=TimeGrid(float(t[0]), float(t[1])) if t.size else None,
        feedthrough=groups["feedthrough"],
    )
    info = {str(k): _info_value(str(v)) for k, v in zip(data["info.names"], data["info.values"], strict=True)}
    box = tuple((str(n), float(lo), float(hi)) for n, (lo, hi) in zip(data.get("box.names", ()),
                                                                       data.get("box.bounds", ()), strict=True))
    cert = {k.removeprefix("certificate."): v for k, v in data.items() if k.startswith("certificate.")}
    finer = {k.removeprefix("finer."): v for k, v in data.items() if k.startswith("finer.")}
    return ReducedModel(projected, groups["initial"], info, box=box,
                        certificate=Certificate.from_arrays(cert) if cert else None,
                        finer=from_arrays(finer) if finer else None)
