"""Exact-in-time outputs of the full finite-element model, the reference of benchmarks/mor_peers.py.

For inputs constant in time the semi-discrete model ``C Ṫ = −K T + F`` has the exact solution
``T(t) = Σ_i v_i (1 − e^{−λ_i t}) v_iᵀF / λ_i`` over all n eigenpairs of (K, C) — out of reach by dense
``eigh`` at 24³ voxels (15 625 unknowns, 2 GB per dense matrix).  The reference here is the Galerkin
projection of the full model onto a shift-and-invert Krylov space, integrated exactly in time by aromm's
modal evaluator::

    V_m = span{ S⁰ b, S¹ b, …, S^{m−1} b },   S = (K + σC)⁻¹ C,   b = (K + σC)⁻¹ F,   Vᵀ C V = I,

one sparse factorisation per parameter set (CHOLMOD, nested dissection) and m solves; the exponential
converges on this space for all t > 0 at a rate independent of the mesh [vandenEshofHochbruck2006].  Its
own error is measured, not assumed: the largest output change between m/2 and m (printed), and
independently the modal solution with the static correction at parameters where every eigenvalue below
60/t_first is computed (`modal_reference`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from aromm.core.system import FloatArray, ThermalSystem
from aromm.linalg.direct import factorize
from aromm.reduction.rom import ReducedModel


def krylov_basis(system: ThermalSystem, values: Mapping[str, float], size: int,
                 shifts: Sequence[float]) -> FloatArray:
    """C(μ)-orthonormal basis of the union of the shift-and-invert Krylov spaces of the loads, ``size``
    steps per shift (rational Arnoldi cycling through the shifts, module docstring): its first
    ``len(shifts) * j`` columns span the spaces after j steps."""
    v = system.values(values)
    k = sp.csr_array(system.conductance.evaluate(v))
    c = sp.csr_array(system.capacity.evaluate(v))
    # the loads' spatial vectors with their coefficients (a history multiplies a vector in time: same space)
    f = sum((float(t.coefficient(v)) * np.asarray(t.operator, dtype=float) for t in system.load.terms),
            start=np.zeros(system.n))
    points = system.geometry.points if system.geometry is not None else None
    solvers = [factorize(k + shift * c, points=points) for shift in shifts]
    basis = np.zeros((system.n, size * len(shifts)))
    last = [f / np.sqrt(f @ f)] * len(shifts)
    j = 0
    for _ in range(size):
        for i, fac in enumerate(solvers):
            w = fac.solve(c @ last[i] if j >= len(shifts) else last[i])
            for _ in range(2):  # full re-orthogonalisation in the C product, twice
                w = w - basis[:, :j] @ (basis[:, :j].T @ (c @ w))
            norm = float(np.sqrt(w @ (c @ w)))
            basis[:, j] = w / norm
            last[i] = basis[:, j]
            j += 1
    return basis


def krylov_outputs(system: ThermalSystem, values: Mapping[str, float], times: FloatArray, size: int,
                   shifts: Sequence[float]) -> tuple[FloatArray, float]:
    """Face means (len(times), n_out) on the Krylov space of ``size`` vectors per shift, and their largest
    change when only the first half of each is kept (the reference's own error estimate, °C)."""
    basis = krylov_basis(system, values, size, shifts)
    own = {k: v for k, v in values.items() if k in system.parameter_names}
    full = ReducedModel.from_system(system, basis).simulate(own, times).as_array()
    half = ReducedModel.from_system(system, basis[:, : len(shifts) * (size // 2)]).simulate(own, times).as_array()
    return full, float(np.abs(full - half).max())


def modal_reference(system: ThermalSystem, values: Mapping[str, float], times: FloatArray,
                    rate_times_t: float = 60.0) -> tuple[FloatArray, int]:
    """Eigenpairs of (K, C) below ``rate_times_t / times[0]`` exactly in time plus the static correction of
    the others (neglected: ``e^{−λ t} ≤ e^{−rate_times_t}`` of their static share); the mode count."""
    v = system.values(values)
    k = sp.csc_array(system.conductance.evaluate(v))
    c = sp.csc_array(system.capacity.evaluate(v))
    # the loads' spatial vectors with their coefficients (a history multiplies a vector in time: same space)
    f = sum((float(t.coefficient(v)) * np.asarray(t.operator, dtype=float) for t in system.load.terms),
            start=np.zeros(system.n))
    cut = rate_times_t / float(times[0])
    count = 8
    while True:
        lam, vec = spla.eigsh(k, k=count, M=c, sigma=0.0, which="LM")
        if lam.max() > cut or count >= system.n // 4:
            break
        count *= 2
    keep = lam <= cut
    lam, vec = lam[keep], vec[:, keep]
    static = spla.spsolve(k, f)
    b = vec.T @ f
    _, e = system.observation_matrix()
    ev = e @ vec
    decay = np.exp(-np.outer(times, lam)) * (b / lam)  # (nt, modes)
    return (e @ static)[None, :] - decay @ ev.T, int(lam.size)
