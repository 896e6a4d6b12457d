"""Explicit (forward-Euler) integration of a ThermalSystem, as in DEM codes [Hassan2019, eq. 4-5].

[Hassan2019, eq. 5] for particle p:

    T_p(t + dt) = T_p(t) + dt / C_p [ Q_p + sum_q H_pq (T_q - T_p) ],   C_p = rho_c c V_p / phi,

i.e. ``T <- T + dt C^-1 (F - K T)`` on the free unknowns (fixed temperatures held).  It is
stable iff ``dt < 2 / lambda_max(C^-1 K)`` (free block).  That limit is computed with
ARPACK on the symmetric ``C^-1/2 K C^-1/2``; the cheap bound
``dt_bound = min_p C_p / sum_q H_pq`` (Gershgorin: ``lambda_max <= max_p 2 sum_q H_pq / C_p``)
is always stable and about half the exact limit on packings (the smallest particle sets
it).  A requested step above the exact limit is refused with an InputError naming it.

For the implicit path use :func:`aromm.full.solve.simulate` on the same system.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from aromm.core.errors import InputError, NumericalError
from aromm.core.observables import Observables
from aromm.core.system import FloatArray, ThermalSystem

SAFETY = 0.9  # default step = SAFETY * exact stability limit


@dataclass(frozen=True)
class _Explicit:
    """Free-block operators of one parameter set: C_ff (diagonal), K_ff, constant right-hand side."""

    free: npt.NDArray[np.int64]
    fixed: npt.NDArray[np.int64]
    fixed_values: FloatArray
    capacity: FloatArray
    k_ff: sp.csr_array
    rhs: FloatArray
    t0: float


def _prepare(system: ThermalSystem, values: Mapping[str, float] | None) -> _Explicit:
    if system.is_steady:
        raise InputError("explicit integration needs a transient system (with a capacity term)")
    if system.load.timed or any(d.time is not None for d in system.dirichlet) or system.initial:
        raise InputError("explicit integration takes constant loads and fixed temperatures only "
                         "(use aromm.full.solve.transient for histories)")
    v = system.values(values)
    n = system.n
    fixed_values = np.full(n, np.nan)
    for d in system.dirichlet:
        fixed_values[d.dofs] = float(np.asarray(v[d.param]))
    mask = np.isfinite(fixed_values)
    free, fixed = np.flatnonzero(~mask), np.flatnonzero(mask)
    cap = sp.csr_array(system.capacity.evaluate(v))
    if (cap - sp.diags(cap.diagonal())).count_nonzero():
        raise InputError("explicit integration needs a diagonal (lumped) capacity, as in the DEM network")
    c = cap.diagonal()[free]
    if np.any(c <= 0):
        raise InputError("explicit integration: every free unknown needs a positive capacity")
    k = sp.csr_array(system.conductance.evaluate(v))
    rows = k[free]
    k_ff, k_fd = sp.csr_array(rows[:, free]), sp.csr_array(rows[:, fixed])
    load = np.asarray(system.load.evaluate(v), dtype=float) if system.load else np.zeros(n)
    rhs = load[free] - k_fd @ fixed_values[fixed]
    return _Explicit(free, fixed, fixed_values[fixed], c, k_ff, rhs, float(np.asarray(v["initial.T"])))


def stability_limit(system: ThermalSystem, values: Mapping[str, float] | None = None) -> float:
    """Exact forward-Euler limit ``2 / lambda_max(C^-1 K)`` (s) on the free unknowns."""
    e = _prepare(system, values)
    return _exact_limit(e)


def stability_bound(system: ThermalSystem, values: Mapping[str, float] | None = None) -> float:
    """Cheap always-stable step ``min_p C_p / sum_q |K_pq|_{q != p}`` (s) (Gershgorin)."""
    e = _prepare(system, values)
    return _bound(e)


def _bound(e: _Explicit) -> float:
    diag = e.k_ff.diagonal()  # = sum_q H_pq over all neighbours, fixed ones included
    return float(np.min(e.capacity / np.maximum(diag, 1e-300)))


def _exact_limit(e: _Explicit) -> float:
    s = 1.0 / np.sqrt(e.capacity)
    a = sp.csr_array(sp.diags(s) @ e.k_ff @ sp.diags(s))
    if a.shape[0] <= 2:
        lam = float(np.linalg.eigvalsh(a.toarray()).max())
    else:
        try:
            lam = float(spla.eigsh(a, k=1, which="LA", tol=1e-6, return_eigenvectors=False)[0])
        except spla.ArpackNoConvergence as err:
            raise NumericalError(f"ARPACK did not converge for the largest eigenvalue of C^-1 K: {err}") from None
    if not lam > 0:
        raise NumericalError(f"largest eigenvalue of C^-1 K is {lam:g}: conductance not positive")
    return 2.0 / (lam * (1.0 + 1e-6))  # ARPACK tolerance: keep on the safe side


def simulate_explicit(
    system: ThermalSystem,
    values: Mapping[str, float] | None = None,
    times: npt.ArrayLike | None = None,
    *,
    dt: float | None = None,
    fields: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> Observables:
    """Forward Euler [Hassan2019, eq. 5] from the uniform ``initial.T``; outputs at ``times`` (s).

    ``dt`` defaults to 0.9 x the exact stability limit; a larger requested ``dt`` than the
    limit is refused.  Each output interval is split into equal steps not above ``dt``, so
    outputs fall exactly on ``times``.  ``progress(step, total)`` is called every 100 steps.
    """
    e = _prepare(system, values)
    if times is None:
        if system.time is None:
            raise InputError("explicit integration: give output times or a system with a time grid")
        times = system.time.times
    t_out = np.asarray(times, dtype=float).ravel()
    if t_out.size == 0 or not np.all(np.isfinite(t_out)) or np.any(t_out < 0) or np.any(np.diff(t_out) <= 0):
        raise InputError("output times must be finite, non-negative and strictly increasing")
    limit = _exact_limit(e)
    if dt is None:
        dt = SAFETY * limit
    elif not dt > 0:
        raise InputError(f"time step must be positive, got {dt}")
    elif dt >= limit:
        raise InputError(
            f"explicit time step {dt:.3e} s exceeds the stability limit 2/lambda_max(C^-1 K) = {limit:.3e} s "
            f"of this network (cheap safe bound min C_p/sum H_pq = {_bound(e):.3e} s); use a smaller dt "
            "or the implicit solver aromm.full.solve.simulate"
        )
    starts = np.concatenate([[0.0], t_out[:-1]])
    counts = np.ceil((t_out - starts) / dt - 1e-9).astype(int)
    total = int(counts.sum())
    inv_c = 1.0 / e.capacity
    x = np.full(e.free.size, e.t0)
    names, obs = system.observation_matrix()
    full = np.empty(system.n)
    full[e.fixed] = e.fixed_values
    outs: list[FloatArray] = []
    stored: list[FloatArray] = []
    step = 0
    for start, end, count in zip(starts, t_out, counts, strict=True):
        h = (end - start) / count if count else 0.0
        for _ in range(count):
            x += h * inv_c * (e.rhs - e.k_ff @ x)
            step += 1
            if progress is not None and step % 100 == 0:
                progress(step, total)
        if not np.all(np.isfinite(x)):
            raise NumericalError("explicit integration produced non-finite temperatures")
        full[e.free] = x
        outs.append(obs @ full)
        if fields:
            stored.append(full.copy())
    y = np.asarray(outs).reshape(len(t_out), len(names))
    return Observables(
        t=t_out, mean_T={name: y[:, i] for i, name in enumerate(names)},
        fields=np.asarray(stored) if fields else None,
    )
