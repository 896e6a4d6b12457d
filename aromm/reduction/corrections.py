"""Correction modes: the detailed basis enriched with static and first-order dynamic responses to the loads.

For each parameter sample s and load vector U_j, the static response ``x = K(s)⁻¹ U_j`` and the first time
moment ``K(s)⁻¹ C_i x`` (moment matching at zero frequency, the "static correction" / mode-acceleration idea of
modal synthesis; an extension of [Chavez2020], not in it; docs/method/corrections.md).  They are
C0-orthonormalised against the Dirichlet–Steklov basis of :mod:`aromm.reduction.modal_bases` and appended to it as kind
``"correction"``; the coefficients of the corrections themselves travel with the basis so that the reducer keeps
them as whole columns.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from aromm.core.cache import NpzCache, content_key
from aromm.core.system import FloatArray, ThermalSystem
from aromm.linalg.direct import factorize
from aromm.reduction.modal_bases import BASIS_VERSION, ModalBasis, ReferenceOperators, reference_operators
from aromm.reduction.shifted import SHIFT

#: Default conductivity factors of the correction samples (each conduction parameter in turn); on the
#: generated 10³ wood image (0.1, 1, 3) was as accurate as (0.1, 0.3, 1, 3) with two fewer factorisations
#: per parameter, and (1,) alone 100× less accurate at k_F = 0.05.
CORRECTION_FACTORS = (0.1, 1.0, 3.0)
#: Directions of the correction vectors with a relative Gram eigenvalue below this are dependent (dropped).
CORRECTION_RANK_TOL = 1e-12


def correction_samples(system: ThermalSystem, values: Mapping[str, float] | None = None,
                       factors: tuple[float, ...] = CORRECTION_FACTORS) -> list[dict[str, float]]:
    """Parameter sets of the correction modes: the reference values, then each conduction parameter
    (of the terms with ``K 1 = 0``) multiplied in turn by each of ``factors``."""
    ref = {k: float(v) for k, v in system.parameters.items()}
    ref.update({k: float(v) for k, v in (values or {}).items()})
    names = sorted(system.conductance.with_role("conduction").parameters)
    samples = [ref]
    for name in names:
        for f in factors:
            if f != 1.0:
                samples.append({**ref, name: ref[name] * f})
    return samples


def with_corrections(
    system: ThermalSystem,
    basis: ModalBasis,
    samples: list[dict[str, float]],
    *,
    values: Mapping[str, float] | None = None,
    method: str = "auto",
    cache: NpzCache | None = None,
) -> ModalBasis:
    """The basis enriched with static and first-order dynamic correction modes of the system's loads.

    For each parameter sample s and load term U_j: the static response ``x = K(s)⁻¹ U_j`` and the
    first time moment ``K(s)⁻¹ C_i x`` for each capacity term (moment matching at zero frequency,
    the "static correction" / mode-acceleration idea of modal synthesis; an extension of [Chavez2020],
    not in it).  They make the steady state exact at the samples and the slow response accurate,
    which truncated Dirichlet modes capture only slowly when k differs from k0 (measured in
    benchmarks/aromm_accuracy.py).  The detailed basis gains their C0-orthonormalised parts
    orthogonal to it (kind ``"correction"``), and ``corrections`` holds the coefficients of the
    correction vectors themselves in the enriched basis, which the reducer keeps as whole columns.
    A system without exchange (K singular) is shifted by a tiny multiple of its capacity.
    """
    if not system.load.terms:
        return basis
    ops = reference_operators(system, values)
    key = content_key(BASIS_VERSION, "corrections", system.fingerprint(), ops.key(), samples, basis.size,
                      basis.vectors[::97].copy(), method)
    stored = cache.load("corrections", key) if cache is not None else None
    if stored is not None:
        extra, coefficients = stored["vectors"], stored["coefficients"]
    else:
        extra, coefficients = _correction_vectors(system, basis, ops, samples, method)
        if cache is not None:
            cache.save("corrections", key, {"vectors": extra, "coefficients": coefficients})
    # the new columns are C0-orthonormal and C0-orthogonal to the basis: the Gram matrix grows by an identity
    gram = sla.block_diag(basis.gram, np.eye(extra.shape[1]))
    return ModalBasis(np.column_stack([basis.vectors, extra.astype(basis.vectors.dtype)]),
                      np.concatenate([basis.eigenvalues, np.full(extra.shape[1], np.nan)]),
                      np.concatenate([basis.kinds, np.array(["correction"] * extra.shape[1])]),
                      basis.zeta, gram, {**basis.info, "corrections": float(coefficients.shape[1])}, coefficients)


def _correction_vectors(system: ThermalSystem, basis: ModalBasis, ops: ReferenceOperators,
                        samples: list[dict[str, float]], method: str) -> tuple[FloatArray, FloatArray]:
    """New columns P (C0-orthonormal, C0-orthogonal to the basis) and the coefficients (Ñ + m, m0) of the
    C0-orthonormalised correction vectors S in the enriched basis: S = [Φ, P] coefficients."""
    exchange = bool(system.conductance.with_role("exchange"))
    cols = []
    for sample in samples:
        v = {k: val for k, val in sample.items() if k in system.parameter_names}
        k_mat = sp.csr_array(system.conductance.evaluate(system.values(v)))
        c_terms = [sp.csr_array(t.operator) for t in system.capacity.terms]
        c_mat = sp.csr_array(system.capacity.evaluate(system.values(v)))
        shift = float(sample.get(SHIFT, 0.0))  # (K + s C)⁻¹: aromm.reduction.shifted
        if not exchange and shift == 0.0:
            shift = 1e-8 * k_mat.diagonal().sum() / c_mat.diagonal().sum()
        if shift:
            k_mat = sp.csr_array(k_mat + shift * c_mat)
        fac = factorize(k_mat, method, points=ops.points)
        for t in system.load.terms:
            x = fac.solve(np.asarray(t.operator, dtype=float))
            cols.append(x)
            cols.extend(fac.solve(c @ x) for c in c_terms)
        del fac  # one factorisation alive at a time (peak memory)
    return enrich(np.column_stack(cols), basis, lambda a, b: a.T @ (ops.capacity @ b))


#: ``product(A, B) = Aᵀ C0 B`` for tall A, B (n × a, n × b): the capacity inner product, computed in one
#: process or summed over MPI ranks that each hold some rows (aromm.engines.petsc).
CapacityProduct = Callable[[FloatArray, FloatArray], FloatArray]


def enrich(x: FloatArray, basis: ModalBasis, product: CapacityProduct) -> tuple[FloatArray, FloatArray]:
    """New columns P (C0-orthonormal, C0-orthogonal to the basis) spanning the correction vectors ``x``, and
    the coefficients (Ñ + m, m0) of the C0-orthonormalised corrections S in the enriched basis [Φ, P]."""
    x = x / np.sqrt(np.maximum(np.diag(product(x, x)), 1e-300))
    z = basis.vectors[:, basis.zero_modes]  # the constants are kept anyway: remove them first
    for _ in range(2):
        x = x - z @ np.linalg.solve(product(z, z), product(z, x))
    s = _orthonormal(x, product, CORRECTION_RANK_TOL)
    phi, gram = basis.vectors, basis.gram
    a = np.zeros((phi.shape[1], s.shape[1]))
    r = s
    for _ in range(2):  # block Gram–Schmidt in the C0 product, twice for accuracy
        step = np.linalg.solve(gram, product(phi, r))
        a += step
        r = r - phi @ step
    p = _orthonormal(r, product, CORRECTION_RANK_TOL)
    b = product(p, r)
    return p, np.vstack([a, b])


def _orthonormal(x: FloatArray, product: CapacityProduct, tol: float) -> FloatArray:
    """C0-orthonormal basis of span(x), directions with Gram eigenvalue below ``tol`` (relative to 1) dropped."""
    g = product(x, x)
    w, u = np.linalg.eigh((g + g.T) / 2)
    keep = w > tol * max(1.0, float(w.max(initial=0.0)))
    return (x @ u[:, keep]) / np.sqrt(w[keep])
