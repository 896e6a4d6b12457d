"""The full semi-discrete model solved exactly in time, by dense modal decomposition (small systems: the truth of
the reduced models' certified bounds, tests/test_certificate.py and benchmarks/certified_bound.py).

``C Ṫ + K T = F(t)`` with ``K W = C W Λ``, ``Wᵀ C W = I``: each mode ``ẏ = −λ y + a + b (t − t₀)`` is integrated in
closed form between consecutive load breakpoints and output times (loads piecewise linear in time,
:mod:`aromm.core.profiles`), from ``T(0) = initial.T + Σ c_i v_i`` with the outputs ``y = E T + Σ c_j g_j(t) d_j``
(the ``initial`` and ``feedthrough`` groups of a lifted system).  Fixed temperatures are refused: lift them first
(:func:`aromm.reduction.lifting.lift` reproduces the original outputs exactly).  Massless unknowns (zero rows of C:
the face unknowns of the finite volumes, :mod:`aromm.fv`) are condensed exactly, ``T_m = K_mm⁻¹ (F_m − K_ms T_s)``,
which leaves ``C_ss Ṫ_s + (K_ss − K_sm K_mm⁻¹ K_ms) T_s = F_s − K_sm K_mm⁻¹ F_m`` and adds the instantaneous
``E_m K_mm⁻¹ F_m(t)`` to the outputs.  Cost O(n³): a few thousand unknowns at most.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import numpy as np
import scipy.linalg as sla

from aromm.core.errors import InputError
from aromm.core.system import FloatArray, ThermalSystem, dense

#: Largest system solved densely.
MAX_UNKNOWNS = 6_000


def exact_outputs(system: ThermalSystem, values: Mapping[str, float], times: FloatArray, *,
                  reverse: bool = False) -> FloatArray:
    """Outputs (len(times) × outputs) of ``system`` at ``values`` (module docstring), exact in time.  ``reverse``:
    the unknowns numbered backwards (the same solution, another rounding: :func:`rounding`).

    >>> from aromm.core.system import TimeGrid
    >>> from aromm.core.vocabulary import FaceSpec, PhaseSpec
    >>> from aromm.fem import assemble_voxels
    >>> s = assemble_voxels(np.ones((2, 2, 2), int), (1e-3,) * 3, [PhaseSpec("a", 1, 1.0, 1e6)],
    ...                     [FaceSpec("z0", flux=1000.0)], time=TimeGrid(1.0, 0.5), outputs=["z1"])
    >>> bool(exact_outputs(s, {}, np.array([1.0]))[0, 0] > 0)  # heated through z0: the far face warms
    True
    """
    if system.dirichlet or system.n > MAX_UNKNOWNS:
        raise InputError(f"exact_outputs: dense solution of systems without fixed temperatures and at most "
                         f"{MAX_UNKNOWNS} unknowns (got {system.n}, {len(system.dirichlet)} fixed faces)")
    v = system.values(dict(values))
    order = np.arange(system.n)[::-1] if reverse else np.arange(system.n)
    grid = np.ix_(order, order)
    k, c = dense(system.conductance.evaluate(v))[grid], dense(system.capacity.evaluate(v))[grid]
    _, e = system.observation_matrix()
    e = dense(e)[:, order]
    massless = ~np.any(c != 0.0, axis=1)
    m, s = np.flatnonzero(massless), np.flatnonzero(~massless)
    rhs = np.hstack([k[np.ix_(m, s)], np.eye(m.size)])
    solve_m = np.linalg.solve(k[np.ix_(m, m)], rhs) if m.size else rhs
    condense, inject = solve_m[:, : s.size], solve_m[:, s.size:]  # K_mm⁻¹ K_ms, K_mm⁻¹
    k_s = k[np.ix_(s, s)] - k[np.ix_(s, m)] @ condense
    lam, w = sla.eigh(k_s, c[np.ix_(s, s)])
    lam = np.maximum(lam, 0.0)
    e_s = e[:, s] - e[:, m] @ condense

    def full_load(t: float) -> FloatArray:  # no load term: the initial state alone drives it
        return np.asarray(system.load.evaluate(v, at=t), dtype=float).ravel()[order] if system.load else \
            np.zeros(system.n)

    def load(t: float) -> FloatArray:
        f = full_load(t)
        return f[s] - k[np.ix_(s, m)] @ (inject @ f[m])

    breaks = {float(b) for term in system.load.terms if term.time is not None for b in term.time.times}
    cuts = sorted({0.0, *np.asarray(times, dtype=float).tolist(), *(b for b in breaks if 0 < b < max(times))})
    start = np.full(system.n, float(v["initial.T"]))  # type: ignore[arg-type]
    if system.initial:
        start = start + np.asarray(system.initial.evaluate(v), dtype=float).ravel()[order]
    y = w.T @ c[np.ix_(s, s)] @ start[s]
    out = {}
    for t0, t1 in itertools.pairwise(cuts):
        tau = t1 - t0
        a = w.T @ load(t0 + 1e-12 * tau)
        b = (w.T @ load(t1 - 1e-12 * tau) - a) / tau
        decay = np.exp(-lam * tau)
        small = lam * tau < 1e-8
        safe = np.where(small, 1.0, lam)
        phi1 = np.where(small, tau, (1 - decay) / safe)  # ∫₀^τ e^{−λ(τ−σ)} dσ
        phi2 = np.where(small, tau ** 2 / 2, (tau - phi1) / safe)  # ∫₀^τ e^{−λ(τ−σ)} σ dσ
        y = decay * y + a * phi1 + b * phi2
        out[t1] = e_s @ (w @ y) + e[:, m] @ (inject @ full_load(t1)[m])
    direct = [np.asarray(system.feedthrough.evaluate(v, at=float(t)), dtype=float).ravel() if system.feedthrough
              else 0.0 for t in times]
    return np.stack([out[float(t)] + d for t, d in zip(times, direct, strict=True)])


def rounding(system: ThermalSystem, values: Mapping[str, float], times: FloatArray) -> FloatArray:
    """The truth's own rounding, measured: per output, the largest difference over ``times`` between
    :func:`exact_outputs` with the unknowns numbered forwards and backwards (°C).  The dense eigendecomposition gives
    every rate to an absolute ε λ_max, so the slow modes' amplitudes carry about ε λ_max / λ_min of the outputs'
    size: 3e-9–1e-8 °C on 6³ bodies of 20 °C (tests/test_certificate.py), far above ε times the outputs."""
    forward = exact_outputs(system, values, times)
    return np.asarray(np.abs(forward - exact_outputs(system, values, times, reverse=True)).max(axis=0), dtype=float)
