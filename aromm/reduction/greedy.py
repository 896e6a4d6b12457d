"""Multi-point POD-greedy reduction on the exact detailed modal model (an alternative to the amalgam).

The amalgam [Chavez2020, eq. 9] groups the Ñ Dirichlet–Steklov modes from reference simulations at one
parameter set; its error away from that set is what an identification over wide bounds meets.  POD-greedy
[Haasdonk2008] builds the reduced basis Ψ = Φ A from the parameter sets where the current reduced model is
worst, on a training set 𝒫 (e.g. a grid over the identification bounds):

1. start from the kept columns (the constants, the correction vectors), G-orthonormalised, with
   ``G = Φᵀ C0 Φ`` the capacity Gram matrix of the detailed basis at the basis values;
2. reduce, and evaluate the reduced model on all of 𝒫 (exactly in time, aromm.reduction.rom); its true error
   is ``e(μ) = max_{t,k} |ỹ_k(μ, t) − y_k(μ, t)|`` (°C) against the detailed modal model of order Ñ, also
   exact in time, so no time-stepping error enters either side;
3. stop when ``max e ≤ tolerance`` or the order is reached; otherwise take μ* = argmax e, the detailed
   trajectory X(μ*) (Ñ × K states at the snapshot times), its G-orthogonal projection error
   ``R = X − A Aᵀ G X``, and append its leading ``step`` POD modes (SVD of ``Lᵀ R`` with ``G = L Lᵀ``);
   re-orthonormalise twice (classical Gram–Schmidt in G, "twice is enough").

The result is a Galerkin basis, so the reduced capacity stays SPD and the conductance PSD: the exact
modal evaluator applies unchanged.  The training errors of every iteration are kept (``history``).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError, NumericalError
from aromm.core.system import FloatArray, ThermalSystem
from aromm.reduction.reductors import DetailedModel, snapshot_times
from aromm.reduction.rom import ReducedModel

#: Projection-error singular values below this fraction of the largest are the trajectory's null space.
RANK_TOL = 1e-12
#: Default factors of the training grid around the reference values (each material parameter).
TRAINING_FACTORS = (0.1, 1.0, 10.0)
#: Default number of iterations the order is spread over (modes per iteration = ceil(order / this)).
ITERATIONS = 25


@dataclass(frozen=True)
class PodGreedy:
    """The POD-greedy reductor (:class:`aromm.reduction.reductors.Reductor`; ``aromm.reduce(system, method=...)``).

    ``training``: parameter sets (overrides of the system's values); empty → :func:`training_grid` over
    :func:`material_parameters` with :data:`TRAINING_FACTORS`.  ``tolerance`` (°C): stop as soon as the
    worst training error is below it (0: always reach the order, else the order may be smaller).
    ``step``: modes added per iteration (0: ceil(order / 25)).  Snapshot times: the scene's output grid
    plus early log-spaced times (:func:`aromm.reduction.reductors.snapshot_times`).
    """

    training: tuple[tuple[tuple[str, float], ...], ...] = ()
    tolerance: float = 0.0
    step: int = 0
    name: str = "greedy"

    @classmethod
    def over(cls, training: Sequence[Mapping[str, float]], tolerance: float = 0.0, step: int = 0) -> PodGreedy:
        """From a list of parameter dicts (stored sorted, so that equal options give equal cache keys)."""
        if not np.isfinite(tolerance) or tolerance < 0:
            raise InputError(f"greedy tolerance must be a finite number >= 0 (°C), got {tolerance!r}")
        if step < 0:
            raise InputError(f"greedy step must be >= 0 (0: automatic), got {step!r}")
        sets = tuple(tuple(sorted((str(k), float(v)) for k, v in mu.items())) for mu in training)
        return cls(sets, float(tolerance), int(step))

    @property
    def cache_key(self) -> str:
        """Every option, so that reduced models built with other training sets are not mixed up in the cache."""
        return repr((self.name, self.training, self.tolerance, self.step))

    def coefficients(self, detailed: DetailedModel, order: int) -> FloatArray:
        model = detailed.model
        base = dict(model.parameters)
        training = ([{**base, **dict(mu)} for mu in self.training] if self.training else
                    training_grid(base, material_parameters(model.projected)))
        own = [{k: v for k, v in mu.items() if k in model.parameter_names} for mu in training]
        kept = np.column_stack([detailed.constants(), detailed.corrections(order)])
        return pod_greedy(model, own, snapshot_times(model.time), order, kept=kept, gram=detailed.basis.gram,
                          tolerance=self.tolerance, step=self.step).coefficients


@dataclass(frozen=True)
class Greedy:
    """Coefficients A (Ñ × ñ) of the greedy basis, the worst training error (°C) after each iteration
    (``history[i]`` for the basis of ``orders[i]`` columns) and the training set index picked each time."""

    coefficients: FloatArray
    history: FloatArray
    orders: npt.NDArray[np.int64]
    picked: npt.NDArray[np.int64]


def material_parameters(system: ThermalSystem) -> list[str]:
    """Names in the capacity terms and in the conduction terms inside the body (not the exchanges)."""
    terms = (*system.capacity.terms, *system.conductance.with_role("conduction").terms)
    return sorted({p for t in terms for p in t.coefficient.params})


def training_grid(values: Mapping[str, float], names: Sequence[str],
                  factors: Sequence[float] = TRAINING_FACTORS) -> list[dict[str, float]]:
    """Tensor grid: every parameter of ``names`` at ``values[name] × factor`` for each factor."""
    missing = [n for n in names if n not in values]
    if missing:
        raise InputError(f"training grid: no value for {missing}; known: {sorted(values)}")
    axes = [[float(values[n]) * f for f in factors] for n in names]
    return [{**values, **dict(zip(names, point, strict=True))} for point in itertools.product(*axes)]


def _orthonormal(v: FloatArray, gram: FloatArray) -> FloatArray:
    """G-orthonormal columns spanning ``v`` (Cholesky QR twice; ``v`` of full column rank)."""
    for _ in range(2):
        g = v.T @ gram @ v
        try:
            r = np.linalg.cholesky((g + g.T) / 2)
        except np.linalg.LinAlgError:
            raise NumericalError("POD-greedy: the basis lost rank during G-orthonormalisation") from None
        v = np.linalg.solve(r, v.T).T
    return v


def pod_greedy(detailed: ReducedModel, training: Sequence[Mapping[str, float]], times: FloatArray, order: int, *,
               kept: FloatArray, gram: FloatArray, tolerance: float = 0.0, step: int = 0) -> Greedy:
    """POD-greedy coefficients in the detailed modal space (module docstring).

    ``kept`` (Ñ × q) columns stay in the basis (constants, correction vectors); ``gram`` is the capacity Gram
    matrix of the detailed basis; ``times`` the snapshot times (s).
    """
    if not training:
        raise InputError("POD-greedy needs at least one training parameter set")
    if order < max(1, kept.shape[1]):
        raise InputError(f"order must be at least {max(1, kept.shape[1])} (the kept columns), got {order}")
    names = detailed.parameter_names
    keys = sorted({k for mu in training for k in mu if k in names})
    batch = {k: np.array([float(mu[k]) for mu in training]) for k in keys}
    truth = detailed.simulate_batch(batch, times)  # (m, K, n_out)
    g = (gram + gram.T) / 2
    chol = np.linalg.cholesky(g)
    step = step or -(-order // ITERATIONS)
    a = _orthonormal(kept, g) if kept.shape[1] else np.zeros((g.shape[0], 0))
    history: list[float] = []
    orders: list[int] = []
    picked: list[int] = []
    while True:
        if a.shape[1]:
            errors = np.abs(detailed.transform(a).simulate_batch(batch, times) - truth).max(axis=(1, 2))
        else:
            errors = np.abs(truth).max(axis=(1, 2))
        history.append(float(errors.max()))
        orders.append(a.shape[1])
        if errors.max() <= tolerance or a.shape[1] >= order:
            break
        worst = int(np.argmax(errors))
        picked.append(worst)
        x = detailed.states({k: float(v[worst]) for k, v in batch.items()}, times).T  # (Ñ, K)
        residual = x - a @ (a.T @ (g @ x))
        u, s, _ = np.linalg.svd(chol.T @ residual, full_matrices=False)
        rank = int(np.count_nonzero(s > RANK_TOL * s[0])) if s.size and s[0] > 0 else 0
        take = min(step, order - a.shape[1], rank)
        if take == 0:
            raise NumericalError(f"POD-greedy: the trajectory of training set {worst} already lies in the basis "
                                 f"of order {a.shape[1]} but its error is {errors.max():.3e} °C (above the "
                                 f"tolerance {tolerance:g}); the detailed model is not reproduced")
        new = np.linalg.solve(chol.T, u[:, :take])
        a = _orthonormal(np.column_stack([a, new]), g)
    return Greedy(a, np.array(history), np.array(orders, dtype=np.int64), np.array(picked, dtype=np.int64))
