"""Eigen-free parametric rational-Krylov reduction (``method="krylov"``), written against the engine protocol.

No eigenpair is computed.  For the full model ``C(μ) Ṫ + K(μ) T = Σ_j f_j(μ, t) F_j`` with outputs ``y = E T``,
the transfer function of every input b (each load term F_j, the initial states ``C(μ) T0``) is
``H(μ, s) = E (K(μ) + s C(μ))⁻¹ b``; an input whose factor vanishes at every corner of the box (a load with
T_ext = 0 when T_ext is not in the box, an initial temperature of 0) is never excited and gets no moments.
A Galerkin model on a basis V that contains

    (K(μ_i) + s_k C(μ_i))⁻¹ b,   [(K(μ_i) + s_k C(μ_i))⁻¹ C(μ_i)]^{j−1} (K(μ_i) + s_k C(μ_i))⁻¹ b,  j ≤ steps,

matches the first ``steps`` moments of H at every (μ_i, s_k) [Antoulas2005, ch. 11] (rational Krylov; with
``dual`` also the outputs' moments, Eᵀ taken as inputs, twice the moments for the same solves since K, C are
symmetric).  Right-hand sides that are combinations of others are solved once (:func:`independent_columns`), and the
solutions of one shift are orthonormalised together.  Shifts s_k are log-spaced over 1/t_end … 3/t_first (the
Laplace frequencies of the output times); the constant field is always in V (the mean temperature).  The parameter
points μ_i are chosen greedily over the identification box ``bounds`` (a log-spaced training grid 𝒫):

1. start at the box's geometric centre μ₀; V is C(μ₀)-orthonormal;
2. indicator (selection): the relative residual of the reduced frequency response,
   ``η(μ) = max_{s, b} ‖b − (K(μ) + sC(μ)) V x_r‖ / ‖b‖`` with ``(Vᵀ(K + sC)V) x_r = Vᵀ b``, over a grid of
   shifts three times finer than the interpolation shifts; the residual is affine in (μ, s), so its norm comes
   from a QR factor of ``[U, K_j V, C_j V]`` without any n-vector per evaluation (offline/online split of
   reduced-basis a-posteriori estimates [Haasdonk2008]); take μ* = argmax η over the unused points;
3. error estimate (stopping, °C): after adding the moments at μ*, the largest change of the outputs over 𝒫
   and the output times, exact in time, between the model before and after.  The new model interpolates H at
   μ*, where the old one was worst (by η), so the change estimates the old model's worst error (the
   saturation assumption of greedy methods); stop when it is below ``tolerance`` / :data:`ESTIMATE_SAFETY` (°C)
   or after ``max_points``;
4. compress the span to the order asked (:mod:`aromm.reduction.compression`: by default the best measured of
   an output-aware Gramian compression, POD-greedy on output errors and POD of the moments); the loss of the
   compression is measured on 𝒫 and recorded.

The result is the ordinary :class:`~aromm.reduction.rom.ReducedModel` (exact modal time integration).  Every solve is
``engine.shifted_solve`` to the relative residual ``rtol`` (default 1e-10), an iterative one from the Galerkin
solution in the basis built so far (:func:`galerkin_guess`): CHOLMOD or multigrid-PCG in the scipy engine
(:mod:`aromm.reduction.scipy_engine`).  Only :mod:`aromm.reduction.engine_protocol` is imported here.
"""

from __future__ import annotations

import itertools
import logging
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
import numpy.typing as npt
from tqdm import tqdm

from aromm.core.errors import InputError
from aromm.core.system import FloatArray, ThermalSystem, TimeGrid
from aromm.reduction.compression import COMPRESSIONS, batch, best, compress, loss
from aromm.reduction.engine_protocol import Block, ReductionEngine
from aromm.reduction.rom import ReducedModel
from aromm.reduction.training_box import Box, centre, say_default, training_set

log = logging.getLogger(__name__)

#: A moment vector whose part outside the basis is below this fraction of its C-norm adds nothing; with solves
#: to a relative residual rtol above it, the threshold is rtol (:attr:`KrylovReductor.drop`).
DROP = 1e-10
#: The greedy stops when the change is below tolerance / ESTIMATE_SAFETY: on the 24³ wood VER the change after the
#: last point underestimated the worst error over the 3×3 grid by 1.4–30× (benchmarks/mor_peers.py, 2026-12-01).
ESTIMATE_SAFETY = 10.0
#: The residual indicator scans this many shifts per interpolation shift.
INDICATOR_REFINEMENT = 3

class Bound(Protocol):
    """The certified bound of a span's Galerkin model (basis, model) at every training point (°C, max over outputs);
    told the span, its model and the compression's coefficients before the span's buffer is overwritten."""

    def __call__(self, basis: Block, model: ReducedModel) -> FloatArray: ...
    def compressed(self, basis: Block, model: ReducedModel, coefficients: FloatArray) -> None: ...


@dataclass(frozen=True)
class KrylovReductor:
    """Options of the Krylov reduction (module docstring).

    ``bounds``: (name, lower, upper) per parameter of the identification box (empty:
    :data:`~aromm.reduction.training_box.DEFAULT_FACTOR` around the scene's material parameters); ``tolerance``
    (°C) of the greedy; ``shifts`` per parameter point;
    ``steps`` moments per shift; ``rtol`` of the shifted solves; ``compression`` (aromm.reduction.compression);
    ``max_points``; ``per_axis`` training points per box axis (0: 5 for ≤ 2 parameters, 3 for ≤ 4, else 2, and
    above six a Sobol set, :func:`~aromm.reduction.training_box.training_set`);
    ``dual``: the outputs' moments too; ``solver``: the engine's linear solver (``"auto"``: by size);
    ``highest``: the largest shift is ``highest / t_first`` (the response at t_first carries frequencies above
    1/t_first); ``certify``: attach the certified output error bound (:mod:`aromm.reduction.certificate`) and stop
    the greedy on it (None: by size, :mod:`aromm.reduction.certified`: stop on it below
    :data:`~aromm.reduction.certified.CERTIFY_BELOW` unknowns, certify the returned model below
    :data:`~aromm.reduction.certified.CERTIFY_AFTER_BELOW`; by their measured cost).
    """

    bounds: Box = ()
    tolerance: float = 1e-5
    shifts: int = 6
    steps: int = 2
    rtol: float = 1e-10
    compression: str = "auto"
    max_points: int = 10
    per_axis: int = 0
    dual: bool = True
    solver: str = "auto"
    highest: float = 3.0
    certify: bool | None = None
    name: str = field(default="krylov", init=False)

    @classmethod
    def over(cls, bounds: Mapping[str, tuple[float, float]] | None = None, **options: object) -> KrylovReductor:
        """From a mapping name → (lower, upper); checks every option."""
        box = tuple(sorted((str(k), float(lo), float(hi)) for k, (lo, hi) in (bounds or {}).items()))
        out = cls(box, **options)  # type: ignore[arg-type]
        out.check()
        return out

    @classmethod
    def named(cls, method: object, bounds: Mapping[str, tuple[float, float]] | None = None,
              tolerance: float | None = None, certify: bool | None = None) -> KrylovReductor | None:
        """The Krylov reductor that ``method`` asks for (``"krylov"`` over ``bounds`` with ``tolerance`` (°C) and
        ``certify``, None: the defaults), or a KrylovReductor itself; None for any other method."""
        if isinstance(method, KrylovReductor) or method != "krylov":
            return method if isinstance(method, KrylovReductor) else None
        return cls.over(bounds, certify=certify, **({} if tolerance is None else {"tolerance": tolerance}))

    def check(self) -> None:
        for name, lo, hi in self.bounds:
            if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo <= hi):
                raise InputError(f"krylov bounds of {name!r}: need 0 < lower <= upper (finite), got [{lo}, {hi}]")
        if not (np.isfinite(self.tolerance) and self.tolerance >= 0):
            raise InputError(f"krylov tolerance must be a finite number >= 0 (°C), got {self.tolerance!r}")
        if not 0 < self.rtol < 1:
            raise InputError(f"krylov rtol must lie in (0, 1), got {self.rtol!r}")
        if not (np.isfinite(self.highest) and self.highest > 0):
            raise InputError(f"krylov highest must be a finite number > 0, got {self.highest!r}")
        for key in ("shifts", "steps", "max_points"):
            if int(getattr(self, key)) < 1:
                raise InputError(f"krylov {key} must be >= 1, got {getattr(self, key)!r}")
        if self.per_axis < 0 or self.per_axis == 1:
            raise InputError(f"krylov per_axis must be 0 (automatic) or >= 2, got {self.per_axis!r}")
        if self.compression not in COMPRESSIONS:
            raise InputError(f"unknown compression {self.compression!r}; allowed: {', '.join(COMPRESSIONS)}")
        if self.certify not in (None, True, False):
            raise InputError(f"krylov certify must be true, false or None (by size), got {self.certify!r}")

    @property
    def cache_key(self) -> str:
        return repr((self.name, self.bounds, self.tolerance, self.shifts, self.steps, self.rtol, self.compression,
                     self.max_points, self.per_axis, self.dual, self.solver, self.highest, self.certify))

    @property
    def drop(self) -> float:
        """Threshold of new directions: a solve to the relative residual rtol fixes its vector only to about rtol
        (relative), so a part outside the basis below ``max(DROP, rtol)`` of the vector's norm is solver noise,
        not a direction (it would only widen the basis)."""
        return max(DROP, self.rtol)

    def shift_values(self, grid: TimeGrid) -> FloatArray:
        """The interpolation shifts (1/s): ``shifts`` log-spaced over 1/t_end … highest/t_first."""
        return np.geomspace(1.0 / grid.end, self.highest / grid.dt, self.shifts)


@dataclass
class Span:
    """The greedy's result: basis V (an engine block), its Galerkin model, the points μ_i, the estimated error
    after each point (°C), the coordinates of the raw moment vectors in V."""

    basis: Block
    model: ReducedModel
    points: list[dict[str, float]]
    history: list[float]
    moments: FloatArray


class _Moments:
    """Adds the moments at one parameter point to the basis; counts solves on a bar and in the log."""

    def __init__(self, engine: ReductionEngine, reductor: KrylovReductor, shifts: FloatArray,
                 reference: Mapping[str, float], *, active: npt.NDArray[np.bool_], progress: bool) -> None:
        self.engine, self.reductor, self.shifts, self.reference = engine, reductor, shifts, reference
        self.select = np.eye(active.size)[:, active]
        self.bar = tqdm(total=0, desc="krylov solves", disable=not progress, leave=False, file=sys.stderr)
        self.raw: list[FloatArray] = []

    def add(self, basis: Block, mu: Mapping[str, float]) -> Block:
        eng, opt = self.engine, self.reductor
        joined = eng.join([eng.combine(eng.inputs(mu), self.select), *([eng.output_block()] if opt.dual else [])])
        keep = independent_columns(eng, joined, opt.drop)
        first = joined if keep.size == eng.width(joined) else eng.combine(joined, np.eye(eng.width(joined))[:, keep])
        del joined
        per_point = eng.width(first) * len(self.shifts) * opt.steps
        self.bar.total += per_point
        done = eng.stats.solves
        for s in self.shifts:  # both blocks at one shift share the engine's set-up; one orthonormalisation a shift
            guess = galerkin_guess(eng, basis, mu, float(s))
            rhs = first
            solutions = []
            for step in range(opt.steps):
                b = rhs if step == 0 else eng.capacity(mu, rhs)
                rhs = eng.shifted_solve(mu, float(s), b, opt.rtol, guess(b))
                solutions.append(rhs)
            x = eng.join(solutions)
            del solutions, rhs
            basis, _ = eng.orthonormalise(basis, x, self.reference, opt.drop)
            cx = eng.capacity(self.reference, x)
            norms = np.sqrt(np.maximum(np.diag(eng.dot(x, cx)), 1e-300))
            self.raw.append(eng.dot(basis, cx) / norms)
            self.bar.update(eng.width(x))
        stats = eng.stats
        its = stats.iterations[-per_point:] if stats.iterations else []
        log.info("krylov: point %s: %d solves (%d in all), basis %d columns%s", _label(mu), stats.solves - done,
                 stats.solves, eng.width(basis), f", CG iterations {min(its)}–{max(its)}" if its else "")
        return basis

    def coordinates(self, width: int) -> FloatArray:
        return np.column_stack([np.vstack([c, np.zeros((width - c.shape[0], c.shape[1]))]) for c in self.raw])


def galerkin_guess(engine: ReductionEngine, basis: Block, mu: Mapping[str, float],
                   shift: float) -> Callable[[Block], Block | None]:
    """``b ↦ V (Vᵀ A V)⁻¹ Vᵀ b``, A = K(μ) + s C(μ): the Galerkin solution in the span V built so far, the initial
    guess of the iterative shifted solves.  It is the best approximation of A⁻¹ b in V in the energy norm, so CG
    starts below the zero guess's error; the solve's tolerance stays ``rtol ‖b‖``, so the guess changes the
    iteration count, not the accuracy.  Once V holds the moments of the earlier shifts and points, most of A⁻¹ b is
    in V (that is what the greedy's estimate measures) and CG has fewer decades to go.  None for a solver that
    ignores guesses (a direct one): then nothing is formed."""
    if not engine.uses_guess:
        return lambda rhs: None
    reduced = engine.reduced_operator(basis, mu, shift)

    def guess(rhs: Block) -> Block:
        return engine.combine(basis, np.asarray(np.linalg.solve(reduced, engine.dot(basis, rhs)), dtype=float))

    return guess


def independent_columns(engine: ReductionEngine, block: Block, drop: float) -> npt.NDArray[np.intp]:
    """Columns of ``block``, in order, whose part outside the span of the columns kept before them exceeds ``drop``
    times their norm (Euclidean; the part formed explicitly, so exact multiples leave ≈ 1e-16, not the 1e-8 of a
    Gram-matrix difference).  A right-hand side that is a combination of others (a flux load on a face and the
    mean temperature of that face are one vector up to a factor) has solutions that are the same combination:
    solving it adds no direction, only its cost."""
    width = engine.width(block)
    eye = np.eye(width)
    kept: list[int] = []
    for j in range(width):
        column = engine.combine(block, eye[:, j:j + 1])
        norm = float(np.sqrt(engine.dot(column, column)[0, 0]))
        rest = norm
        if kept and norm > 0:
            others = engine.combine(block, eye[:, kept])
            coefficients = np.linalg.lstsq(engine.dot(others, others), engine.dot(others, column), rcond=None)[0]
            part = engine.combine(engine.join([column, others]), np.vstack([[1.0], -coefficients]))
            rest = float(np.sqrt(engine.dot(part, part)[0, 0]))
        if rest > drop * norm:
            kept.append(j)
    return np.array(kept, dtype=np.intp)


def _label(mu: Mapping[str, float]) -> str:
    return ", ".join(f"{k}={v:.3g}" for k, v in mu.items())


def residual_indicator(engine: ReductionEngine, model: ReducedModel, basis: Block,
                       training: Sequence[Mapping[str, float]], shifts: FloatArray, *,
                       active: npt.NDArray[np.bool_]) -> FloatArray:
    """η(μ) of the module docstring for every training point: the largest relative residual over shifts and
    ``active`` inputs of the reduced frequency response."""
    u = engine.input_terms()
    vtu, utu = engine.dot(basis, u), engine.dot(u, u)
    sys_ = model.projected
    values, m = sys_.batch_values(batch(training))
    amat, lmat = sys_.conductance.stack(values, m), sys_.capacity.stack(values, m)
    out = np.zeros(m)
    for i, mu in enumerate(training):
        a = engine.input_coefficients(mu)
        size = np.sqrt(np.maximum(np.diag(a.T @ utu @ a), 0.0)) * active
        if not np.any(size > 0):
            continue
        x = np.linalg.solve(amat[i][None] + shifts[:, None, None] * lmat[i][None], np.broadcast_to(
            vtu @ a, (shifts.size, *(vtu @ a).shape)))
        norms = engine.residual_norms(basis, mu, shifts, x)
        out[i] = float(np.max(norms[:, size > 0] / size[size > 0]))
    return out


def build_span(engine: ReductionEngine, reductor: KrylovReductor, box: Box, times: FloatArray,
               shifts: FloatArray, *, max_width: int, progress: bool = False, bound: Bound | None = None) -> Span:
    """Greedy rational-Krylov span over the box (module docstring, steps 1–3).  With ``bound`` (the certified
    output error bound of a span's model at every training point, °C, :mod:`aromm.reduction.certificate`), a span
    whose estimate meets the tolerance is kept only when its bound is below half of it (the other half is the
    compression's); else the next point is where the bound is largest (as the bound finds it, lazily:
    :class:`aromm.reduction.certified.SpanBound`)."""
    say_default(reductor.bounds, box)
    training = training_set(box, reductor.per_axis)
    reference = centre(box)
    fine = np.geomspace(shifts[0], shifts[-1], INDICATOR_REFINEMENT * len(shifts))
    corners = [dict(zip([n for n, _, _ in box], c, strict=True)) for c in itertools.product(
        *[(lo, hi) for _, lo, hi in box])]
    active = np.any([engine.input_weights(mu) != 0 for mu in (*corners, reference)], axis=0)
    log.info("krylov: %d of %d inputs excited over the box", int(active.sum()), active.size)
    moments = _Moments(engine, reductor, shifts, reference, active=active, progress=progress)
    basis, _ = engine.orthonormalise(None, engine.constant(), reference, DROP)
    params = batch(training)
    used = np.zeros(len(training), dtype=bool)
    mu: dict[str, float] = reference
    points: list[dict[str, float]] = []
    history: list[float] = []
    previous: FloatArray | None = None
    while True:
        basis = moments.add(basis, mu)
        points.append(mu)
        model = engine.project(basis)
        outputs = model.simulate_batch(params, times)
        worst: FloatArray | None = None
        if previous is not None:
            history.append(float(np.abs(outputs - previous).max()))
            log.info("krylov: estimated error %.3g °C with %d points", history[-1], len(points))
            if history[-1] <= reductor.tolerance / ESTIMATE_SAFETY:
                if bound is None:
                    break
                worst = bound(basis, model)
                log.info("krylov: certified bound %.3g °C over the training grid with %d points", worst.max(),
                         len(points))
                if worst.max() <= reductor.tolerance / 2 or np.all(used):
                    break
        previous = outputs
        if len(points) >= reductor.max_points or engine.width(basis) >= max_width:
            break
        score = worst if worst is not None else residual_indicator(engine, model, basis, training, fine,
                                                                   active=active)
        score = np.where(used, -np.inf, score)
        best = int(np.argmax(score))
        used[best] = True
        mu = training[best]
        log.info("krylov: next point %s (%s %.3g)", _label(mu), "bound" if worst is not None else
                 "worst relative residual", score[best])
    moments.bar.close()
    return Span(basis, model, points, history, moments.coordinates(engine.width(basis)))


Info = dict[str, float | int | str]


def converged(span: Span, reductor: KrylovReductor, compression_loss: float) -> bool:
    """Whether the build met its tolerance by its own measures: the greedy stopped on its estimate (not on
    ``max_points`` or the width limit) and the compression lost at most half the tolerance (the share it was given).
    These are estimates, not bounds (docs/method/krylov.md): the estimate has run 0.9-260x below the actual error."""
    stopped = bool(span.history) and span.history[-1] <= reductor.tolerance / ESTIMATE_SAFETY
    return stopped and compression_loss <= reductor.tolerance / 2


def _check_outputs(engine: ReductionEngine, names: tuple[str, ...]) -> None:
    """The reduction is output-aware: refuse a system without outputs or whose outputs are all on fixed temperatures
    (after lifting their rows vanish on the free unknowns: they are known, there is nothing to reduce for)."""
    if not names:
        raise InputError("the krylov reduction needs outputs ([outputs] mean_T or a [sensors] entry): its moments, "
                         "greedy and compression are those of the outputs")
    block = engine.output_block()
    if not np.any(np.diag(np.asarray(engine.dot(block, block))) > 0):
        raise InputError(f"outputs {', '.join(names)} lie on fixed-temperature faces only (known values, nothing to "
                         "reduce for): add an output on another face or a sensor, or use method = \"aromm\"")


def krylov_model(engine: ReductionEngine, system: ThermalSystem, reductor: KrylovReductor, order: int, box: Box, *,
                 progress: bool = False, bound: Bound | None = None) -> tuple[ReducedModel, Block, Info]:
    """The reduced model of order ≤ ``order`` over ``box`` (:func:`~aromm.reduction.training_box.material_box` of the
    reductor's bounds), its basis Ψ (an engine block) and what the build recorded.

    Errors are measured at the scene's output times (those of the outputs the model is used for)."""
    reductor.check()
    if system.time is None:
        raise InputError("the krylov reduction needs a time grid ([time] section)")
    times = system.time.times
    _check_outputs(engine, tuple(system.observation))
    shifts = reductor.shift_values(system.time)
    start = time.process_time()
    span = build_span(engine, reductor, box, times, shifts, max_width=max(4 * order, 2), progress=progress,
                      bound=bound)
    span_seconds = time.process_time() - start
    training = training_set(box, reductor.per_axis)
    kept = np.eye(span.model.order)[:, :1]
    tol = reductor.tolerance / 2
    if reductor.compression == "auto":
        chosen, coefficients = best(span.model, order, training=training, times=times, kept=kept,
                                    moments=span.moments, tolerance=tol)
    else:
        chosen = reductor.compression
        coefficients = compress(span.model, chosen, order, training=training, times=times, kept=kept,
                                moments=span.moments, tolerance=tol)
    rom = replace(span.model.transform(coefficients), box=box)
    stats = engine.stats
    its = stats.iterations
    info: Info = {
        "method": "krylov", "order": rom.order, "modes": span.model.order, "n_dirichlet": 0, "n_steklov": 0,
        "krylov_points": len(span.points), "krylov_span": span.model.order,
        "krylov_estimate": span.history[-1] if span.history else float("nan"),
        "compression": chosen, "compression_loss": loss(span.model, coefficients, training, times),
        "solver": stats.method, "solves": stats.solves, "setups": stats.setups,
        "setup_seconds": stats.setup_seconds, "solve_seconds": stats.solve_seconds,
        "cg_iterations_max": max(its) if its else 0, "cg_iterations_mean": float(np.mean(its)) if its else 0.0,
        "basis_seconds": span_seconds, "basis_cached": 0,
    }
    info["reference_error"] = float(info["krylov_estimate"]) + float(info["compression_loss"])
    info["tolerance"] = reductor.tolerance
    info["converged"] = int(converged(span, reductor, float(info["compression_loss"])))
    log.info("krylov: span %d columns at %d points, order %d, compression loss %.3g °C", span.model.order,
             len(span.points), rom.order, info["compression_loss"])
    if bound is not None:
        bound.compressed(span.basis, span.model, coefficients)
    return rom, engine.combine(span.basis, coefficients, consume=True), info
