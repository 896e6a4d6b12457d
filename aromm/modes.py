"""Dirichlet and Steklov eigenbases of a heterogeneous body [Chavez2020, § 3.1, eqs. 6–8].

With reference properties (k0, c0) per phase, ``K0`` is the conduction operator and ``C0`` the
capacity operator at those values, and ``B`` the boundary mass ``∫_Γ φ_a φ_b``:

* Dirichlet modes (eq. 6): ``K0_II v = λ C0_II v`` on the interior DOFs, ``v = 0`` on Γ;
* Steklov modes (eqs. 7–8): ``K0 v = λ ζ B v`` with ``ζ = ∫ c0 dΩ / ∫_Γ dΓ`` (J m⁻² K⁻¹), so that
  both families have eigenvalues in s⁻¹ (a time constant τ = 1/λ); the eigenvectors are discretely
  k0-harmonic (``(K0 v)_I = 0``).  The constant is a Steklov mode of eigenvalue 0, one per connected
  component; it carries the mean temperature and is kept.

Every mode is capacity-normalised, ``vᵀ C0 v = 1``.  Dirichlet modes are C0-orthogonal; Steklov
modes are ζB- and K0-orthogonal; a Dirichlet and a Steklov mode are K0-orthogonal exactly
(``v_D`` vanishes on Γ, ``K0 v_S`` vanishes inside), but not C0-orthogonal (docs/notes/aromm_method.md §3).

Solvers (docs/notes/solver_facts.md): ARPACK shift-invert with a sparse Cholesky factorisation
passed as ``OPinv`` (never eigsh's own SuperLU/COLAMD), ordered by geometric nested dissection when
the system has node coordinates (aromm.ordering); Steklov with a small negative shift (K0 and
B are both singular), then one purification solve ``V ← (K0 − σζB)⁻¹ ζB V`` (the discrete harmonic
extension, which removes the interior garbage shift-invert leaves with a singular B), then a
Rayleigh–Ritz step.  Small systems use dense ``eigh`` (every mode).  Residuals and orthogonality
are checked against stated tolerances and a :class:`~aromm.errors.NumericalError` names the solver
when they fail.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse import csgraph

from aromm.cache import NpzCache, content_key
from aromm.errors import InputError, NumericalError
from aromm.linalg import Factorization, factorize
from aromm.shifts import SHIFT
from aromm.system import FloatArray, ThermalSystem

#: Largest system solved with dense ``eigh`` (every mode) instead of ARPACK.
DENSE_LIMIT = 1500
#: Relative eigen-residual ``||K v − λ M v|| / (||K v|| + λ ||M v||)`` accepted.
RESIDUAL_TOL = 1e-6
#: Largest deviation of the family's Gram matrix from the identity accepted.
ORTHOGONALITY_TOL = 1e-6
#: Largest condition number of the combined capacity Gram matrix ``Φᵀ C0 Φ`` accepted.
GRAM_CONDITION_MAX = 1e12

_BASIS_VERSION = 3
#: Default conductivity factors of the correction samples (each conduction parameter in turn); on the
#: generated 10³ wood image (0.1, 1, 3) was as accurate as (0.1, 0.3, 1, 3) with two fewer factorisations
#: per parameter, and (1,) alone 100× less accurate at k_F = 0.05.
CORRECTION_FACTORS = (0.1, 1.0, 3.0)
#: Directions of the correction vectors with a relative Gram eigenvalue below this are dependent (dropped).
CORRECTION_RANK_TOL = 1e-12
#: A component's constant is a zero mode when ``|K0 1|`` stays below this fraction of the largest diagonal
#: entry of K0 (rows of a conduction matrix sum to zero up to round-off, ~1e-16 of the entries).
NULL_CONSTANT = 1e-10


@dataclass(frozen=True)
class ReferenceOperators:
    """``K0`` (W/K), ``C0`` (J/K) at reference values, boundary mass ``B`` (m²) and ζ (J/(m² K))."""

    stiffness: sp.csr_array
    capacity: sp.csr_array
    boundary: sp.csr_array
    zeta: float
    values: Mapping[str, float]
    points: FloatArray | None = None  # node coordinates (m): nested-dissection ordering of the factorisations

    @property
    def n(self) -> int:
        return int(self.stiffness.shape[0])

    @property
    def interior(self) -> npt.NDArray[np.int64]:
        return np.flatnonzero(self.boundary.diagonal() == 0.0)

    def key(self) -> str:
        return content_key(self.stiffness, self.capacity, self.boundary)


@dataclass(frozen=True)
class ModalBasis:
    """Columns: the constant modes (one per component), the Steklov modes, then the Dirichlet modes.

    ``eigenvalues`` in s⁻¹ (0 for the constants), ``kinds`` one of ``"zero"``, ``"steklov"``,
    ``"dirichlet"``; every column has ``vᵀ C0 v = 1``.
    """

    vectors: FloatArray
    eigenvalues: FloatArray
    kinds: npt.NDArray[np.str_]
    zeta: float
    gram: FloatArray  # Φᵀ C0 Φ, the capacity Gram matrix at the reference values (unit diagonal)
    info: Mapping[str, float] = field(default_factory=dict)
    corrections: FloatArray | None = None  # (size, m): correction vectors in this basis, see with_corrections

    @property
    def size(self) -> int:
        return int(self.vectors.shape[1])

    @property
    def zero_modes(self) -> npt.NDArray[np.int64]:
        return np.flatnonzero(self.kinds == "zero")


    def count(self, kind: str) -> int:
        return int(np.count_nonzero(self.kinds == kind))


def boundary_of(system: ThermalSystem) -> sp.csr_array:
    """The boundary mass ``B = ∫_Γ φ_a φ_b`` (m²) the assembler attached to ``system``."""
    if system.boundary is None:
        raise InputError("the system carries no boundary mass (ThermalSystem.boundary): the Steklov modes "
                         "need the outer boundary; assemble it with aromm.assemble or a DEM network")
    return system.boundary


def reference_operators(system: ThermalSystem, values: Mapping[str, float] | None = None) -> ReferenceOperators:
    """``K0`` = conduction terms (those with ``K 1 = 0``) and ``C0`` = capacity terms at ``values``.

    ``values`` (the reference properties k0, c0 of the bases) override the system's own parameters;
    ζ from [Chavez2020, eq. 8].
    """
    if system.is_steady:
        raise InputError("the modal bases need a transient system (a [time] section and phase capacities c)")
    if system.dirichlet:
        names = ", ".join(d.param for d in system.dirichlet)
        raise InputError(f"fixed temperatures ({names}): build the bases on the lifted system of the free "
                         "unknowns (aromm.lifting.lift; aromm.reduce does it)")
    vals: dict[str, float] = {k: float(v) for k, v in system.parameters.items()}
    vals.update({k: float(v) for k, v in (values or {}).items()})
    k0 = sp.csr_array(system.conductance.with_role("conduction").evaluate(vals))
    c0 = sp.csr_array(system.capacity.evaluate(vals))
    b = boundary_of(system)
    n = system.n
    area = float(b.sum())
    heat = float(c0.sum())
    if not (heat > 0 and area > 0):
        raise InputError("reference capacity and boundary area must be positive to build the bases")
    points = system.geometry.points if system.geometry is not None and system.geometry.points.shape[0] == n else None
    return ReferenceOperators(sp.csr_array(k0), sp.csr_array(c0), b, heat / area, vals, points)


def split_modes(system: ThermalSystem, total: int) -> tuple[int, int]:
    """Split Ñ = ``total`` into (n_dirichlet, n_steklov) evenly, moving to one family what the other lacks
    (at most n_interior Dirichlet modes and n_boundary Steklov modes exist)."""
    on_gamma = int(np.count_nonzero(boundary_of(system).diagonal() > 0))
    return split_counts(total, system.n, on_gamma)


def split_counts(total: int, n: int, on_gamma: int) -> tuple[int, int]:
    """:func:`split_modes` for ``n`` unknowns of which ``on_gamma`` lie on the boundary."""
    n_interior = n - on_gamma
    n_s = min((total + 1) // 2, on_gamma)
    n_d = min(total - n_s, n_interior)
    n_s = min(total - n_d, on_gamma)
    return n_d, n_s


def zero_modes(ops: ReferenceOperators) -> FloatArray:
    """One constant per connected component of the conduction graph, capacity-normalised (columns), for the
    components where it is a null vector of K0 (not those touching a lifted fixed face, aromm.lifting)."""
    graph = sp.csr_array(ops.stiffness != 0)
    count, labels = csgraph.connected_components(graph, directed=False)
    scale = float(np.abs(ops.stiffness.diagonal()).max(initial=0.0))
    columns = []
    for j in range(count):
        ind = (labels == j).astype(float)
        if float(np.abs(ops.stiffness @ ind).max(initial=0.0)) <= NULL_CONSTANT * scale:
            columns.append(ind / np.sqrt(ind @ (ops.capacity @ ind)))
    return np.column_stack(columns) if columns else np.zeros((ops.n, 0))


def _relative_residuals(k: sp.csr_array, m: sp.csr_array, lam: FloatArray, v: FloatArray) -> FloatArray:
    kv = k @ v
    mv = m @ v
    num = np.linalg.norm(kv - mv * lam, axis=0)
    den = np.linalg.norm(kv, axis=0) + np.abs(lam) * np.linalg.norm(mv, axis=0)
    return num / np.maximum(den, 1e-300)


def _eigsh(a: sp.csr_array, m: sp.csr_array, count: int, sigma: float, *, fac: Factorization, label: str) -> tuple[
        FloatArray, FloatArray]:
    """ARPACK shift-invert with our own factorisation ``fac`` of ``A − σM`` as OPinv."""
    op = spla.LinearOperator(a.shape, matvec=lambda x: fac.solve(np.asarray(x).ravel(), check=False),
                             dtype=float)
    try:
        lam, vec = spla.eigsh(a, k=count, M=m, sigma=sigma, which="LM", OPinv=op)
    except spla.ArpackNoConvergence as err:
        raise NumericalError(
            f"ARPACK shift-invert ({label}, {count} modes, factorisation {fac.method}) did not converge: "
            f"{len(err.eigenvalues)} of {count} eigenpairs; ask for fewer modes"
        ) from None
    order = np.argsort(lam)
    return lam[order], vec[:, order]


def dirichlet_modes(ops: ReferenceOperators, count: int, method: str = "auto") -> tuple[FloatArray, FloatArray]:
    """The ``count`` slowest Dirichlet modes (eq. 6): eigenvalues (s⁻¹) and C0-normalised vectors (n, count)."""
    interior = ops.interior
    n_i = interior.size
    count = min(count, n_i)
    if count <= 0:
        return np.zeros(0), np.zeros((ops.n, 0))
    k_ii = sp.csr_array(ops.stiffness[interior][:, interior])
    c_ii = sp.csr_array(ops.capacity[interior][:, interior])
    if n_i <= DENSE_LIMIT:
        lam, vec = sla.eigh(k_ii.toarray(), c_ii.toarray(), subset_by_index=(0, count - 1))
    else:
        pts = ops.points[interior] if ops.points is not None else None
        lam, vec = _eigsh(k_ii, c_ii, count, 0.0, fac=factorize(k_ii, method, points=pts), label="Dirichlet modes")
    res = _relative_residuals(k_ii, c_ii, lam, vec)
    if res.max(initial=0.0) > RESIDUAL_TOL:
        raise NumericalError(
            f"Dirichlet eigensolver: relative residual {res.max():.1e} exceeds {RESIDUAL_TOL:.0e} "
            f"(mode {int(res.argmax())} of {count})"
        )
    gram = vec.T @ (c_ii @ vec)
    dev = float(np.abs(gram - np.eye(count)).max())
    if dev > ORTHOGONALITY_TOL:
        raise NumericalError(f"Dirichlet eigensolver: modes not C0-orthonormal (max |VᵀCV − I| = {dev:.1e})")
    full = np.zeros((ops.n, count))
    full[interior] = vec
    return lam, full


def steklov_modes(ops: ReferenceOperators, count: int, method: str = "auto") -> tuple[FloatArray, FloatArray]:
    """The ``count`` lowest non-zero Steklov modes (eqs. 7–8): eigenvalues (s⁻¹) and C0-normalised vectors.

    The constants (eigenvalue 0) are returned by :func:`zero_modes`, not here.
    """
    b = sp.csr_array(ops.zeta * ops.boundary)
    on_gamma = np.flatnonzero(ops.boundary.diagonal() > 0)
    n_zero = zero_modes(ops).shape[1]
    count = min(count, on_gamma.size - n_zero)
    if count <= 0:
        return np.zeros(0), np.zeros((ops.n, 0))
    # Scale of the spectrum: the largest ratio diag(K0)/diag(ζB) on Γ bounds λ from above.
    top = float(np.max(ops.stiffness.diagonal()[on_gamma] / b.diagonal()[on_gamma]))
    sigma = -1e-6 * top
    want = count + n_zero
    if ops.n <= DENSE_LIMIT:
        shifted = (ops.stiffness - sigma * b).toarray()
        # eigenvalues ν of (K0 − σζB)⁻¹ ζB are 1/(λ − σ); the largest give the smallest λ.
        nu, w = sla.eigh(b.toarray(), shifted, subset_by_index=(ops.n - want, ops.n - 1))
        vec = w[:, np.argsort(-nu)]
        fac = factorize(ops.stiffness - sigma * b, method, points=ops.points)
    else:
        fac = factorize(ops.stiffness - sigma * b, method, points=ops.points)
        _, vec = _eigsh(ops.stiffness, b, want, sigma, fac=fac, label="Steklov modes")
    # Purification: one application of (K0 − σζB)⁻¹ζB is the discrete harmonic extension of the trace.
    vec = fac.solve(b @ vec, check=False)
    # Rayleigh–Ritz on the purified subspace (ζB is SPD there: independent traces).
    kr = vec.T @ (ops.stiffness @ vec)
    br = vec.T @ (b @ vec)
    try:
        lam, q = sla.eigh((kr + kr.T) / 2, (br + br.T) / 2)
    except np.linalg.LinAlgError as err:
        raise NumericalError(f"Steklov Rayleigh–Ritz: traces of the computed modes are dependent ({err})") from None
    vec = vec @ q
    lam, vec = lam[n_zero:], vec[:, n_zero:]
    res = _relative_residuals(ops.stiffness, b, lam, vec)
    if res.max(initial=0.0) > RESIDUAL_TOL:
        raise NumericalError(
            f"Steklov eigensolver (shift {sigma:.2e} s⁻¹, {fac.method}): relative residual {res.max():.1e} "
            f"exceeds {RESIDUAL_TOL:.0e} (mode {int(res.argmax())} of {count})"
        )
    if lam[0] <= 1e-8 * lam[-1]:
        raise NumericalError("Steklov eigensolver: a zero eigenvalue beyond the constants (disconnected body?)")
    norms = np.sqrt(np.einsum("ij,ij->j", vec, ops.capacity @ vec))
    return lam, vec / norms


def _check_combined(ops: ReferenceOperators, vectors: FloatArray) -> tuple[FloatArray, float]:
    """The capacity Gram matrix ``Φᵀ C0 Φ`` (unit diagonal) and its condition number; refuses a dependent basis."""
    gram = vectors.T @ (ops.capacity @ vectors)
    return gram, check_gram(gram)


def check_gram(gram: FloatArray) -> float:
    """Condition number of a capacity Gram matrix ``Φᵀ C0 Φ``; NumericalError beyond GRAM_CONDITION_MAX."""
    ev = np.linalg.eigvalsh((gram + gram.T) / 2)
    cond = float(ev[-1] / ev[0]) if ev[0] > 0 else np.inf
    if not cond < GRAM_CONDITION_MAX:
        raise NumericalError(
            f"modal basis: capacity Gram matrix has condition number {cond:.1e} > {GRAM_CONDITION_MAX:.0e} "
            "(Dirichlet and Steklov modes nearly dependent); ask for fewer Steklov modes"
        )
    return cond


def compute_basis(
    system: ThermalSystem,
    n_dirichlet: int,
    n_steklov: int,
    values: Mapping[str, float] | None = None,
    *,
    method: str = "auto",
    cache: NpzCache | None = None,
) -> ModalBasis:
    """Constants + ``n_steklov`` Steklov + ``n_dirichlet`` Dirichlet modes of ``system`` at reference ``values``.

    ``n_steklov`` counts the constants.  Cached in ``cache`` (key: K0, C0, B and the options), so
    scenes that differ only in their loads and exchanges share one basis.
    """
    if n_dirichlet < 0 or n_steklov < 1:
        raise InputError(f"mode counts must be n_dirichlet >= 0 and n_steklov >= 1, got {n_dirichlet}, {n_steklov}")
    ops = reference_operators(system, values)
    key = content_key(_BASIS_VERSION, ops.key(), n_dirichlet, n_steklov, method)
    if cache is not None:
        stored = cache.load("basis", key)
        if stored is not None:
            return ModalBasis(stored["vectors"], stored["eigenvalues"], stored["kinds"], float(stored["zeta"]),
                              stored["gram"],
                              {"seconds": 0.0, "cached": 1.0, "gram_condition": float(stored["gram_condition"])})
    start = time.perf_counter()
    z = zero_modes(ops)
    lam_s, v_s = steklov_modes(ops, n_steklov - z.shape[1], method)
    t_s = time.perf_counter() - start
    lam_d, v_d = dirichlet_modes(ops, n_dirichlet, method)
    vectors = np.column_stack([z, v_s, v_d])
    eigenvalues = np.concatenate([np.zeros(z.shape[1]), lam_s, lam_d])
    kinds = np.array(["zero"] * z.shape[1] + ["steklov"] * lam_s.size + ["dirichlet"] * lam_d.size)
    gram, cond = _check_combined(ops, vectors)
    seconds = time.perf_counter() - start
    if cache is not None:
        cache.save("basis", key, {"vectors": vectors, "eigenvalues": eigenvalues, "kinds": kinds,
                                  "zeta": np.float64(ops.zeta), "gram": gram, "gram_condition": np.float64(cond)})
    return ModalBasis(vectors, eigenvalues, kinds, ops.zeta, gram,
                      {"seconds": seconds, "steklov_seconds": t_s, "cached": 0.0, "gram_condition": cond})


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
    key = content_key(_BASIS_VERSION, "corrections", system.fingerprint(), ops.key(), samples, basis.size,
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
    return ModalBasis(np.column_stack([basis.vectors, extra]),
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
        shift = float(sample.get(SHIFT, 0.0))  # (K + s C)⁻¹: aromm.shifts
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
