"""Compression of a reduced model to a smaller order by a Galerkin change of basis, and its measured loss.

The Krylov span of :mod:`aromm.reduction.krylov` (order R, C(μ₀)-orthonormal columns, the constant first) is compressed
to order r ≤ R by coefficients A (R × r): the reduced model on Ψ = V A is ``span.transform(A)`` (operators
``AᵀXA``), still Galerkin, so its capacity stays SPD and its conductance PSD.  Three rules:

* ``"pod"``: POD in the C(μ₀) product of the raw moment vectors (the columns the solves returned, each scaled
  to unit C-norm): the leading left singular vectors of their coordinates.  It ignores what the outputs see:
  the issue-25 prototype lost 30–250× against the full span at 24³–46³;
* ``"trajectory"``: POD of the span model's state trajectories X(μ, t) over the training set and output
  times (a POD weighted by the dynamics: a direction counts by how much state it carries in time);
* ``"greedy"``: POD-greedy [Haasdonk2008] on the span model (:func:`aromm.reduction.greedy.pod_greedy`): enrich with the
  trajectory of the training point whose *output* error (°C, exact in time) is largest, until the order or
  the tolerance — the output-aware rule.

* ``"gramian"`` (default): dominant subspace of a controllability and an observability Gramian of the span
  model summed over the training set [Antoulas2005, ch. 4 and 7] (Galerkin on the dominant subspace of P + Q,
  as in dominant-subspace projection): at each μ, in the modal coordinates of the span model (``Wᵀ L W = I``,
  ``Wᵀ A W = Λ``), for unit inputs B (loads, initial fields) and unit output rows E over the horizon T = t_end,
  P is the mean over the output times t of the step responses' outer products (Y(t) = φ(Λt) t WᵀB, the inputs
  are steps and histories, not impulses) and Q the time-limited observability Gramian

      Q_ij = ((E W)ᵀ(E W))_ij (1 − e^{−(λ_i+λ_j)T}) / (λ_i + λ_j)    (→ T where λ_i + λ_j = 0);

  the directions ``W (P/tr P + Q/tr Q) Wᵀ`` are summed over 𝒫 and their leading eigenvectors kept.  Q makes it
  output-aware: the directions the face means see weigh as much as those the loads excite.  Measured on a
  7³ two-phase body at contrast 1e3 (tests' scale, order 40 / 80 from spans of 171 / 185): gramian 2.9e-5 /
  5.7e-8 °C, POD of the moments 4.4e-4 / 3.9e-6, greedy 2.0e-3 / 2.2e-4 (impulse-response P instead of the
  step responses: 5.4e-5 / 3.0e-7).

``"auto"`` (default) tries ``"gramian"``, ``"greedy"`` and ``"pod"``, each truncated to 80, 90 and 100 % of
the order (their columns are nested; a Galerkin model's error is not monotone in the order), and keeps the one
whose measured loss (:func:`loss`) is smallest: none of them wins everywhere (24³ wood VER, order 50 from a
span of 83 without the outputs' moments: greedy 9.7e-7 °C, pod 2.0e-6, gramian 2.3e-6 against the exact
outputs; at order 30 pod 1.0e-5, greedy 2.1e-5, gramian 5.3e-5; benchmarks/mor_peers.py).

Every rule keeps the ``kept`` columns (the constant) and returns G-orthonormal coefficients (G = I here).
:func:`loss` measures what a compression costs: the largest output difference (°C) from the span model over
the training set and the output times.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.reduction.greedy import pod_greedy
from aromm.reduction.rom import ReducedModel

COMPRESSIONS = ("auto", "gramian", "greedy", "trajectory", "pod")
#: The rules ``"auto"`` tries, keeping the one with the smallest measured loss.
AUTO = ("gramian", "greedy", "pod")
#: ... each at these fractions of the order (Galerkin errors are not monotone in the order).
AUTO_FRACTIONS = (0.8, 0.9, 1.0)
#: Singular values below this fraction of the largest carry no direction.
RANK_TOL = 1e-12


def batch(training: Sequence[Mapping[str, float]]) -> dict[str, FloatArray]:
    """Parameter arrays of equal length from a list of parameter dicts (same keys)."""
    keys = sorted({k for mu in training for k in mu})
    return {k: np.array([float(mu[k]) for mu in training]) for k in keys}


def _leading(kept: FloatArray, directions: FloatArray, order: int) -> FloatArray:
    """``kept`` then the leading left singular vectors of ``directions`` after removing the kept span."""
    q, _ = np.linalg.qr(kept)
    rest = directions - q @ (q.T @ directions)
    u, s, _ = np.linalg.svd(rest, full_matrices=False)
    rank = int(np.count_nonzero(s > RANK_TOL * s[0])) if s.size and s[0] > 0 else 0
    take = min(order - q.shape[1], rank)
    return np.column_stack([q, u[:, :take]])


def compress(span: ReducedModel, method: str, order: int, *, training: Sequence[Mapping[str, float]],
             times: FloatArray, kept: FloatArray, moments: FloatArray, tolerance: float = 0.0) -> FloatArray:
    """Coefficients A (R × r) of the compression ``method`` (module docstring) of ``span`` to ``order``.

    ``moments``: coordinates of the raw moment vectors in the span (for ``"pod"``); ``tolerance`` (°C) stops
    ``"greedy"`` early.  An order at least R returns the identity.
    """
    if method not in COMPRESSIONS:
        raise InputError(f"unknown compression {method!r}; allowed: {', '.join(COMPRESSIONS)}")
    size = span.order
    if order >= size:
        return np.eye(size)
    if order < kept.shape[1] + 1:
        raise InputError(f"order must be at least {kept.shape[1] + 1} (the constant and one more column), got {order}")
    if method == "auto":
        return best(span, order, training=training, times=times, kept=kept, moments=moments, tolerance=tolerance)[1]
    if method == "pod":
        scale = np.linalg.norm(moments, axis=0)
        return _leading(kept, moments[:, scale > 0] / scale[scale > 0], order)
    if method == "gramian":
        return _leading(kept, gramian_directions(span, training, times), order)
    if method == "trajectory":
        states = [span.states(mu, times).T for mu in training]
        return _leading(kept, np.hstack(states), order)
    own = [{k: v for k, v in mu.items() if k in span.parameter_names} for mu in training]
    return pod_greedy(span, own, times, order, kept=kept, gram=np.eye(size), tolerance=tolerance).coefficients


def best(span: ReducedModel, order: int, *, training: Sequence[Mapping[str, float]], times: FloatArray,
         kept: FloatArray, moments: FloatArray, tolerance: float = 0.0) -> tuple[str, FloatArray]:
    """``"auto"``: the rule of :data:`AUTO` and the fraction of :data:`AUTO_FRACTIONS` of the order (every rule's
    columns are nested) with the smallest :func:`loss`, named (e.g. ``"greedy@40"``) with its coefficients."""
    if order >= span.order:
        return "none", np.eye(span.order)
    tried = []
    for method in AUTO:
        full = compress(span, method, order, training=training, times=times, kept=kept, moments=moments,
                        tolerance=tolerance)
        for fraction in AUTO_FRACTIONS:
            a = full[:, :max(kept.shape[1] + 1, round(fraction * full.shape[1]))]
            tried.append((loss(span, a, training, times), f"{method}@{a.shape[1]}", a))
    _, name, a = min(tried, key=lambda item: item[0])
    return name, a


def loss(span: ReducedModel, coefficients: FloatArray, training: Sequence[Mapping[str, float]],
         times: FloatArray) -> float:
    """Largest output difference (°C) between ``span`` and its compression over ``training`` × ``times``."""
    params = batch(training)
    full = span.simulate_batch(params, times)
    return float(np.abs(span.transform(coefficients).simulate_batch(params, times) - full).max(initial=0.0))


def gramian_directions(span: ReducedModel, training: Sequence[Mapping[str, float]], times: FloatArray) -> FloatArray:
    """Square-root factor F (R × R) of Σ_μ W (P/tr P + Q/tr Q) Wᵀ (module docstring, ``"gramian"``)."""
    horizon = float(times[-1])
    sys_ = span.projected
    values, m = sys_.batch_values(batch(training))
    lmat, amat = sys_.capacity.stack(values, m), sys_.conductance.stack(values, m)
    inputs = np.column_stack([np.asarray(t.operator) for t in sys_.load.terms] +
                             [np.asarray(t.operator) for t in span.initial.terms])
    inputs = inputs[:, np.linalg.norm(inputs, axis=0) > 0]
    inputs = inputs / np.linalg.norm(inputs, axis=0)
    _, e = sys_.observation_matrix()
    outputs = np.asarray(e, dtype=float)
    outputs = outputs[np.linalg.norm(outputs, axis=1) > 0]  # an output on a fixed face: known, no direction
    outputs = outputs / np.linalg.norm(outputs, axis=1, keepdims=True)
    total = np.zeros((span.order, span.order))
    for i in range(m):
        chol = np.linalg.cholesky(lmat[i])
        rinv = np.linalg.inv(chol)
        lam, q = np.linalg.eigh(rinv @ amat[i] @ rinv.T)
        lam = np.maximum(lam, 0.0)
        w = rinv.T @ q
        rate = lam[:, None] + lam[None, :]
        weight = np.where(rate * horizon > 1e-12, -np.expm1(-rate * horizon) / np.where(rate > 0, rate, 1.0), horizon)
        wb, ew = w.T @ inputs, outputs @ w
        x = np.outer(lam, times)
        phi = np.where(x > 1e-12, -np.expm1(-x) / np.where(lam > 0, lam, 1.0)[:, None], times[None, :])  # → t
        steps = (phi[:, None, :] * wb[:, :, None]).reshape(lam.size, -1)
        p, qq = steps @ steps.T / times.size, (ew.T @ ew) * weight
        total += w @ (p / np.trace(p) + qq / np.trace(qq)) @ w.T
    vals, vecs = np.linalg.eigh((total + total.T) / 2)
    return vecs * np.sqrt(np.maximum(vals, 0.0))
