"""Identification of phase properties from face-mean temperatures [Chavez2020, § 4].

    β̂ = argmin_β J(β),   J = ½ Σ_i Σ_j (Y_ij − Ŷ_ij(β))²       (eq. 12)

searched by particle swarm inside the given bounds, then refined by trust-region least
squares from the swarm's best (:mod:`inverse.optimisers`); the linearised uncertainty of the
estimates is computed at the optimum (:mod:`inverse.uncertainty`).  Several scenarios (e.g.
the three loading directions of [Chavez2020, Table 1]) can be fitted jointly: their criteria add.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aromm.core.domain import range_values
from aromm.core.errors import InputError
from aromm.core.labchecks import OVERFLOW
from aromm.core.system import FloatArray
from aromm.core.vocabulary import is_positive
from inverse import checkpoint as ckpt
from inverse import optimisers as opt
from inverse.criterion import LeastSquares, ModelInput, Scenario, scenarios_of
from inverse.defaults import DEFAULT_ITERATIONS, DEFAULT_PARTICLES
from inverse.kinds import reweighted, several
from inverse.measurements import Measurements
from inverse.residuals import offset_note
from inverse.uncertainty import Uncertainty, linearised

if TYPE_CHECKING:
    from inverse.posterior import Posterior

CHECKPOINT_FORMAT = 2  # 2: chained optimisers, swarm generator PCG64 (1: legacy MT19937 state)
AT_BOUND = 1e-6  # normalised distance to a bound below which an estimate is reported as on it
MAX_DECADES = 8  # widest search of a positive parameter: conductivities of solids and gases span 1e-3..1e3 W/(m K)


@dataclasses.dataclass(frozen=True)
class Progress:
    """Reported after each swarm iteration (``stage="pso"``) and each refinement evaluation (``"refine"``)."""

    stage: str
    step: int
    total: int
    evaluations: int
    criterion: float


@dataclasses.dataclass(frozen=True)
class History:
    """Best criterion so far after each record: swarm iterations, then refinement evaluations."""

    stage: tuple[str, ...]
    evaluations: npt.NDArray[np.int64]
    criterion: FloatArray


@dataclasses.dataclass(frozen=True)
class Fit:
    """Measured and fitted face-mean temperatures (n_times, n_faces) of one scenario."""

    name: str
    t: FloatArray
    faces: tuple[str, ...]
    measured: FloatArray
    fitted: FloatArray


@dataclasses.dataclass(frozen=True)
class Identification:
    """Result of :func:`identify`; :meth:`to_json` gives the docs/design.md shape.  ``posterior`` holds MCMC
    samples of the unknowns when asked for (:func:`inverse.posterior.sample_posterior`, attached with
    ``dataclasses.replace``)."""

    estimates: Mapping[str, float]
    criterion: float
    evaluations: int
    seconds: float
    uncertainty: Uncertainty
    history: History
    model: Mapping[str, object]
    bounds: Mapping[str, tuple[float, float]]
    fits: tuple[Fit, ...]
    posterior: Posterior | None = None

    def to_json(self) -> dict[str, object]:
        out: dict[str, object] = {
            "estimates": {k: float(v) for k, v in self.estimates.items()},
            "criterion": float(self.criterion),
            "evaluations": int(self.evaluations),
            "seconds": float(self.seconds),
            "model": dict(self.model),
            "uncertainty": self.uncertainty.to_json(),
        }
        if self.posterior is not None:
            out["posterior"] = self.posterior.to_json()
        return out


def _describe(scenarios: Sequence[Scenario], description: Mapping[str, object] | None) -> dict[str, object]:
    out: dict[str, object] = {"type": sorted({type(s.model).__name__ for s in scenarios}),
                              "scenarios": len(scenarios),
                              "outputs": [list(s.measurements.faces) for s in scenarios],
                              "times": [len(s.measurements.t) for s in scenarios]}
    out.update(description or {})
    return out


class _Recorder:
    """History, progress reports and checkpoints of one run (state carried over from a resume)."""

    def __init__(self, criterion: LeastSquares, previous: Mapping[str, np.ndarray] | None,
                 progress: Callable[[Progress], None] | None) -> None:
        self.criterion = criterion
        self.progress = progress
        prev = previous or {}
        self.stage: list[str] = [str(s) for s in prev.get("history_stage", [])]
        self.evals: list[int] = [int(e) for e in prev.get("history_evaluations", [])]
        self.best: list[float] = [float(c) for c in prev.get("history_criterion", [])]
        self.evaluations_before = int(prev.get("evaluations", 0))
        self.seconds_before = float(prev.get("seconds", 0.0))
        self.start = time.perf_counter()

    @property
    def evaluations(self) -> int:
        return self.evaluations_before + self.criterion.evaluations

    @property
    def seconds(self) -> float:
        return self.seconds_before + time.perf_counter() - self.start

    def record(self, stage: str, step: int, total: int, value: float) -> None:
        best = min(value, self.best[-1]) if self.best else value
        self.stage.append(stage)
        self.evals.append(self.evaluations)
        self.best.append(best)
        if self.progress is not None:
            self.progress(Progress(stage, step, total, self.evaluations, best))

    def arrays(self) -> dict[str, np.ndarray]:
        return {"history_stage": np.array(self.stage, dtype=str), "history_evaluations": np.array(self.evals),
                "history_criterion": np.array(self.best), "evaluations": np.asarray(self.evaluations),
                "seconds": np.asarray(self.seconds)}

    def history(self) -> History:
        return History(tuple(self.stage), np.array(self.evals, dtype=np.int64), np.array(self.best, dtype=float))


#: Budget fields an optimiser may be given more of when a checkpoint is resumed.
BUDGETS = ("iterations", "generations", "max_iterations")


def _signature(optimiser: opt.Optimiser) -> object:
    """What identifies an optimiser in a checkpoint: its settings, except the budget (resumable with more)."""
    if dataclasses.is_dataclass(optimiser):
        return {k: v for k, v in dataclasses.asdict(optimiser).items() if k not in BUDGETS}
    return optimiser.name


def bounds_problem(name: str, low: float, high: float) -> str | None:
    """Why ``low:high`` cannot be searched for ``name`` (None when it can): a parameter positive by nature needs
    ``0 < low`` and at most :data:`MAX_DECADES` decades between its bounds (beyond, the model at the ends is
    singular or overflows: 1e-300:1e300 is no physical range)."""
    if not is_positive(name):
        return None
    if low <= 0:
        return f"positive by nature, its lower bound must be > 0, got {low:g}"
    decades = math.log10(high) - math.log10(low)
    if decades > MAX_DECADES:
        return (f"bounds {low:g}:{high:g} span {decades:.0f} decades, more than the {MAX_DECADES} a physical search "
                "needs (the model is singular or overflows at such ends); give a physical range, e.g. 0.01:100 for "
                "a conductivity in W/(m K), 1e4:1e7 for a capacity in J/(m³ K)")
    return None


def relative_scales(box: opt.Box, estimates: FloatArray) -> FloatArray:
    """Magnitudes of the relative sensitivities: ``|β̂|`` for a parameter searched in a positive (or negative)
    interval, the half-width of its bounds for one whose bounds reach zero (a clock offset, a temperature
    in °C: no relative scale, and the estimate may be zero)."""
    estimates = np.abs(np.asarray(estimates, dtype=float))
    straddle = (box.lower <= 0.0) & (box.upper >= 0.0) | (estimates == 0.0)
    return np.where(straddle, 0.5 * (box.upper - box.lower), estimates)


def default_optimisers(particles: int = DEFAULT_PARTICLES, iterations: int = DEFAULT_ITERATIONS,
                       refine: bool = True) -> tuple[opt.Optimiser, ...]:
    """The chain of [Chavez2020, § 4.1]: a particle swarm, then a least-squares refinement from its best."""
    chain: list[opt.Optimiser] = [opt.ParticleSwarm(particles=particles, iterations=iterations)]
    if refine:
        chain.append(opt.LeastSquaresRefinement())
    return tuple(chain)


def identify(
    model: ModelInput,
    measurements: Measurements | None = None,
    unknowns: Mapping[str, tuple[float, float]] | None = None,
    *,
    seed: int = 0,
    optimisers: Sequence[opt.Optimiser] | None = None,
    particles: int = DEFAULT_PARTICLES,
    iterations: int = DEFAULT_ITERATIONS,
    fixed: Mapping[str, float] | None = None,
    refine: bool = True,
    checkpoint: str | os.PathLike[str] | None = None,
    resume: bool = False,
    progress: Callable[[Progress], None] | None = None,
    description: Mapping[str, object] | None = None,
    noise_std: float | None = None,
    model_error: float = 0.0,
    alternatives: Mapping[str, ModelInput] | None = None,
) -> Identification:
    """Estimate ``unknowns`` (name → (lower, upper) bounds, SI units) from ``measurements``.

    ``model`` is a forward model (FullModel, ReducedModel) evaluated at the measurement times,
    or, with ``measurements=None``, a list of ``(model, measurements)`` pairs fitted jointly.
    ``fixed`` overrides other model parameters.  ``optimisers`` is the chain of searches, each started
    from the best point of the previous one (:mod:`inverse.optimisers`); by default a particle swarm of
    ``particles`` particles and ``iterations`` iterations then, with ``refine``, a least-squares
    refinement.  Random draws come from ``np.random.default_rng(seed)``.
    ``checkpoint`` names an ``.npz`` file rewritten after every step that carries a resumable state;
    with ``resume`` an existing one for the same problem is continued (and may be given more iterations).
    ``description`` adds entries to the result's ``model`` (e.g. ``{"kind": "reduced", "order": 200}``).
    ``noise_std`` (°C), a known sensor noise, is compared with the residual (:mod:`inverse.uncertainty`).
    ``model_error``, a stated relative error of the model's temperature rise (e.g. 0.02 for the voxel model's
    discretisation error), widens the intervals (:func:`inverse.uncertainty.model_error_std`); intervals of
    positive parameters are on a log scale.
    ``alternatives`` are the same measurement model built otherwise, given like ``model``, by source of the budget
    (:data:`inverse.uncertainty.BIAS_SOURCES`): ``"discretisation"`` another discretisation (in aromm q1 ↔ fv),
    ``"segmentation"`` the grey image thresholded by another standard method.  The least-squares refinement is re-run
    with each from the estimates, and the difference of the estimates enters the budget under its source (a bias,
    added linearly: :func:`alternative_shift`).
    """
    if unknowns is None:
        raise InputError("unknowns are required, e.g. {'fibre.k': (0.05, 1.0), 'fibre.c': (1e5, 1e7)}")
    chain = tuple(optimisers) if optimisers is not None else default_optimisers(particles, iterations, refine)
    for o in chain:
        if not isinstance(o, opt.Optimiser):
            raise InputError(f"optimisers: {o!r} is not an optimiser (an object with a name and a run method)")
    scenarios = scenarios_of(model, measurements, {*unknowns, *(fixed or {})})
    for sc in scenarios:  # a logger's overflow code must never reach the optimiser (aromm.core.labchecks)
        bad = np.abs(sc.measurements.as_array()) >= OVERFLOW
        if np.any(bad):
            i, j = np.argwhere(bad)[0]
            raise InputError(f"measurements {sc.measurements.source or sc.name}: {sc.measurements.faces[j]} at t = "
                             f"{sc.measurements.t[i]:g} s is {sc.measurements.as_array()[i, j]:g}, a logger's "
                             "overflow code, not a reading")
    for sc in scenarios:  # a reduced model says when the search (which reaches the ends of every range) leaves it
        check = getattr(sc.model, "check_domain", None)
        if check is not None:
            check({**range_values(unknowns), **(fixed or {})}, "identify")
    box = opt.Box.from_bounds(unknowns)
    for name, low, high in zip(box.names, box.lower, box.upper, strict=True):
        refused = bounds_problem(name, float(low), float(high))
        if refused is not None:
            raise InputError(f"unknown {name!r}: {refused}")
    criterion = LeastSquares(scenarios, box.names, fixed)
    mixed = several(criterion)  # temperatures and humidities: each kind weighted by its own noise (inverse.kinds)
    if mixed and noise_std is not None:
        raise InputError("noise_std is a temperature noise (°C); with relative-humidity outputs (phi:<face>) "
                         "the noise of each kind is estimated from its residuals (inverse.kinds): leave it out")
    info = _describe(scenarios, description)
    problem_key = ckpt.problem_key({"format": CHECKPOINT_FORMAT, "unknowns": box.as_dict(),
                                    "fixed": dict(fixed or {}), "seed": seed,
                                    "optimisers": [_signature(o) for o in chain], "model": _describe(scenarios, None),
                                    "measurements": ckpt.measurements_digest([s.measurements for s in scenarios])})
    previous = ckpt.load(checkpoint, problem_key) if (checkpoint is not None and resume
                                                      and Path(checkpoint).exists()) else None
    rec = _Recorder(criterion, previous, progress)
    problem = opt.Problem(box.dim, lambda u: criterion.residuals(box.to_physical(u)))
    rng = np.random.default_rng(seed)
    first = int(previous["stage"]) if previous is not None else 0
    best_u: FloatArray | None = None
    best_cost = np.inf
    if previous is not None and "best_u" in previous:
        best_u, best_cost = np.asarray(previous["best_u"]), float(previous["best_cost"])
    for index, optimiser in enumerate(chain):
        stage_rng = rng.spawn(1)[0]  # one generator per link, the same whatever the resume point
        if index < first:
            continue
        state = {k.split("/", 1)[1]: v for k, v in (previous or {}).items()
                 if index == first and k.startswith("state/")}

        # the best point so far, as it stands when this link starts (saved with the link's own state)
        before = {"stage": np.asarray(index), "best_cost": np.asarray(best_cost),
                  **({"best_u": best_u} if best_u is not None else {})}

        def on_step(step: opt.Step, name: str = optimiser.name, before: dict[str, np.ndarray] = before) -> None:
            rec.record(name, step.step, step.total, step.cost)
            if checkpoint is not None and step.state is not None:
                ckpt.save(checkpoint, problem_key,
                          {**before, **{f"state/{k}": v for k, v in step.state.items()}, **rec.arrays()})

        outcome = optimiser.run(problem, best_u, stage_rng, state=state or None, callback=on_step)
        if outcome.cost <= best_cost:
            best_u, best_cost = np.asarray(outcome.u, dtype=float), float(outcome.cost)
    assert best_u is not None, "an empty chain of optimisers"
    u_best = best_u
    if mixed:
        u_best, noise = reweighted(criterion, box, u_best)
        info["noise_by_kind"] = noise

    theta = box.to_physical(u_best[None])[0]
    fits = tuple(Fit(sc.name, np.asarray(sc.measurements.t, dtype=float), sc.measurements.faces,
                     sc.measurements.as_array(), y[0])
                 for sc, y in zip(scenarios, criterion.predictions(theta[None]), strict=True))
    r = criterion.residuals(theta[None])[0]  # weighted (inverse.kinds), as the sensitivity
    sensitivity = -opt.jacobian(problem.residuals, u_best) / box.dtheta_du(u_best)[None, :]
    notes = [f"{name} = {value:.6g} is at its {'lower' if u < 0.5 else 'upper'} bound: widen the bounds"
             for name, value, u in zip(box.names, theta, u_best, strict=True) if min(u, 1.0 - u) < AT_BOUND]
    starts0 = criterion.start(theta) if all(len(f.t) > 1 for f in fits) else [f.fitted[0] for f in fits]
    offsets = [n for f, y0 in zip(fits, starts0, strict=True)
               if (n := offset_note(f.t, f.measured, f.fitted, start=y0, faces=f.faces, label=f.name)) is not None]
    starts = np.cumsum([0] + [f.measured.size for f in fits])[:-1]  # rows of r: scenarios, then times × faces
    blocks = [s0 + np.arange(f.measured.size).reshape(f.measured.shape) for s0, f in zip(starts, fits, strict=True)]
    rise = np.concatenate([(f.fitted - y0).ravel() for f, y0 in zip(fits, starts0, strict=True)])
    rise = rise * criterion.flat_weights()
    positive = [is_positive(n) for n in box.names]
    biases = {source: alternative_shift(other, measurements, box, fixed=fixed, start=u_best, positive=positive)
              for source, other in (alternatives or {}).items()}
    uncertainty = linearised(box.names, theta, sensitivity, r, notes=notes, blocks=blocks, noise_std=noise_std,
                             data_notes=offsets, scales=relative_scales(box, theta),
                             positive=positive, model_error=model_error, model_rise=rise,
                             biases=biases,
                             **reduced_error([sc.model for sc in scenarios], dict(zip(box.names, theta, strict=True)),
                                             [dict(zip(sc.measurements.faces, w, strict=True))
                                              for sc, w in zip(scenarios, criterion.weights, strict=True)]
                                             if mixed else None))
    return Identification(
        estimates=dict(zip(box.names, (float(v) for v in theta), strict=True)),
        criterion=0.5 * float(r @ r),
        evaluations=rec.evaluations,
        seconds=rec.seconds,
        uncertainty=uncertainty,
        history=rec.history(),
        model=info,
        bounds=box.as_dict(),
        fits=fits,
    )


def alternative_shift(alternative: ModelInput, measurements: Measurements | None, box: opt.Box, *,
                      fixed: Mapping[str, float] | None, start: FloatArray, positive: Sequence[bool]) -> FloatArray:
    """``|θ_alt − θ̂|``: how far the estimates move when the least-squares refinement is re-run, from them, with
    ``alternative`` (the same measurement model built otherwise: another discretisation, another threshold of the
    grey image); ``start`` the estimates in the normalised coordinates of ``box``.  For a ``positive`` parameter,
    whose interval is taken on log θ (:func:`inverse.uncertainty.domain_interval`), the shift is
    ``θ̂ |ln(θ_alt / θ̂)|``: the interval then reaches θ_alt on either side.

    On a voxel image the conforming elements (q1) overestimate the conductance of the voxel geometry and the
    two-point finite volumes (fv) underestimate it (docs/method/finite_volumes.md), so the two estimates bracket the
    one of the resolved geometry: the difference bounds the discretisation's share of the error (as far as the
    bracket carries over from k̄ to the transient outputs, which is measured, not proven).  Two standard thresholds
    bracket no truth: their shift measures how much the choice of method moves the estimates, not a bound."""
    scenarios = scenarios_of(alternative, measurements, {*box.names, *(fixed or {})})
    criterion = LeastSquares(scenarios, box.names, fixed)
    moved = opt.refine(lambda u: criterion.residuals(box.to_physical(u)), start)
    theta, other = box.to_physical(start[None])[0], box.to_physical(moved.u[None])[0]
    logs = np.asarray(positive, dtype=bool) & (theta > 0) & (other > 0)
    ratio = np.where(logs, other / np.where(logs, theta, 1.0), 1.0)
    return np.where(logs, theta * np.abs(np.log(ratio)), np.abs(other - theta))


#: The unit of a reduced model's output error once the residuals are weighted by their kind's noise (inverse.kinds).
WEIGHTED = "× the noise of its output's kind"


def reduced_error(models: Sequence[Any], estimates: Mapping[str, float],
                  weights: Sequence[Mapping[str, float]] | None = None) -> dict[str, Any]:
    """The reduced models' output error for the interval (inverse.uncertainty.linearised): their certified bound at
    the estimates (°C, the largest over models and outputs; aromm.reduction.certificate) when every model has one,
    else what they estimate of themselves (``output_error``, an estimate).  With ``weights`` (per model, measured
    output → weight of its residuals: :mod:`inverse.kinds`) each output's bound is weighted, over the measured ones."""
    bounds = [b(estimates) if callable(b := getattr(m, "error_bound", None)) else None for m in models]
    found = [b for b in bounds if b is not None]
    if found and len(found) == len(bounds):
        if weights is None:
            return {"output_error": max(float(np.max(b)) for b in found), "output_error_certified": True}
        worst = max(float(b[m.outputs.index(name)]) * w for m, b, ws in zip(models, found, weights, strict=True)
                    for name, w in ws.items())
        return {"output_error": worst, "output_error_certified": True, "output_error_unit": WEIGHTED}
    estimate = max(float(getattr(m, "output_error", 0.0)) for m in models)
    if weights is None:
        return {"output_error": estimate}
    # one estimate for every output: weighted by the largest weight (the smallest noise), an upper bound of each
    return {"output_error": estimate * max(w for ws in weights for w in ws.values()), "output_error_unit": WEIGHTED}
