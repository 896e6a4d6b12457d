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
the system has node coordinates (aromm.linalg.orderings); Steklov with a small negative shift (K0 and
B are both singular), then one purification solve ``V ← (K0 − σζB)⁻¹ ζB V`` (the discrete harmonic
extension, which removes the interior garbage shift-invert leaves with a singular B), then a
Rayleigh–Ritz step.  Above a measured size both families are solved instead by the chunked LOBPCG of
aromm.linalg.eigensolvers (memory: the basis plus a multigrid preconditioner; ``eigensolver="lobpcg"``, no
purification needed).  Small systems use dense ``eigh`` (every mode).  Residuals and orthogonality
are checked against stated tolerances and a :class:`~aromm.core.errors.NumericalError` names the solver
when they fail.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse import csgraph

from aromm.core.cache import NpzCache, content_key
from aromm.core.errors import InputError, NumericalError
from aromm.core.system import FloatArray, ThermalSystem, require_free_transient
from aromm.linalg.direct import Factorization, factorize, resolve_method
from aromm.linalg.eigen_checks import chunked_gram, column_norms, relative_residuals
from aromm.linalg.eigensolvers import ProgressCallback, choose_eigensolver, report_done, smallest_eigenpairs

#: Largest system solved with dense ``eigh`` (every mode) instead of ARPACK.
DENSE_LIMIT = 1500
#: Relative eigen-residual ``||K v − λ M v|| / (||K v|| + λ ||M v||)`` accepted.
RESIDUAL_TOL = 1e-6
#: Largest deviation of the family's Gram matrix from the identity accepted.
ORTHOGONALITY_TOL = 1e-6
#: Largest condition number of the combined capacity Gram matrix ``Φᵀ C0 Φ`` accepted.
GRAM_CONDITION_MAX = 1e12

#: Version of the cached bases (bump when their definition changes).
BASIS_VERSION = 3
#: Precisions in which a basis may be kept (and cached).
BASIS_STORAGE = ("float64", "float32")
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
    require_free_transient(system, "the modal bases")
    vals: dict[str, float] = {k: float(v) for k, v in system.parameters.items()}
    vals.update({k: float(v) for k, v in (values or {}).items()})
    k0 = sp.csr_array(system.conductance.with_role("conduction").evaluate(vals))
    c0 = sp.csr_array(system.capacity.evaluate(vals))
    b = boundary_of(system)
    area = float(b.sum())
    heat = float(c0.sum())
    if not (heat > 0 and area > 0):
        raise InputError("reference capacity and boundary area must be positive to build the bases")
    points = system.unknown_points()
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
    components where it is a null vector of K0 (not those touching a lifted fixed face, aromm.reduction.lifting)."""
    graph = sp.csr_array(ops.stiffness != 0)
    count, labels = csgraph.connected_components(graph, directed=False)
    scale = float(np.abs(ops.stiffness.diagonal()).max(initial=0.0))
    columns = []
    for j in range(count):
        ind = (labels == j).astype(float)
        if float(np.abs(ops.stiffness @ ind).max(initial=0.0)) <= NULL_CONSTANT * scale:
            columns.append(ind / np.sqrt(ind @ (ops.capacity @ ind)))
    return np.column_stack(columns) if columns else np.zeros((ops.n, 0))


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
    except spla.ArpackError as err:  # e.g. -9999: no Arnoldi factorisation (many modes of a singular M)
        raise NumericalError(
            f"ARPACK shift-invert ({label}, {count} modes of a {a.shape[0]}-unknown problem, factorisation "
            f"{fac.method}) failed: {err}; ask for fewer modes or use eigensolver='lobpcg'"
        ) from None
    order = np.argsort(lam)
    return lam[order], vec[:, order]


def dirichlet_modes(ops: ReferenceOperators, count: int, method: str = "auto", *, eigensolver: str = "auto",
                    progress: ProgressCallback | None = None) -> tuple[FloatArray, FloatArray]:
    """The ``count`` slowest Dirichlet modes (eq. 6): eigenvalues (s⁻¹) and C0-normalised vectors (n, count).

    ``eigensolver``: ``"arpack"`` (shift-invert, sparse factorisation ``method``), ``"lobpcg"``
    (aromm.linalg.eigensolvers) or ``"auto"`` (by size, :func:`aromm.linalg.eigensolvers.choose_eigensolver`).
    """
    interior = ops.interior
    n_i = interior.size
    count = min(count, n_i)
    if count <= 0:
        return np.zeros(0), np.zeros((ops.n, 0))
    k_ii = sp.csr_array(ops.stiffness[interior][:, interior])
    c_ii = sp.csr_array(ops.capacity[interior][:, interior])
    if choose_eigensolver(eigensolver, n_i) == "lobpcg":
        found = smallest_eigenpairs(k_ii, c_ii, count, rng=np.random.default_rng(0), label="Dirichlet modes",
                                    progress=progress)
        lam, vec = found.eigenvalues, found.vectors
        vec /= column_norms(c_ii, vec)
    else:
        report_done(progress, "Dirichlet modes", count, started=True)
        if n_i <= DENSE_LIMIT:
            lam, vec = sla.eigh(k_ii.toarray(), c_ii.toarray(), subset_by_index=(0, count - 1))
        else:
            pts = ops.points[interior] if ops.points is not None else None
            lam, vec = _eigsh(k_ii, c_ii, count, 0.0, fac=factorize(k_ii, method, points=pts),
                              label="Dirichlet modes")
        report_done(progress, "Dirichlet modes", count)
    res = relative_residuals(k_ii, c_ii, lam, vec)
    if res.max(initial=0.0) > RESIDUAL_TOL:
        raise NumericalError(
            f"Dirichlet eigensolver: relative residual {res.max():.1e} exceeds {RESIDUAL_TOL:.0e} "
            f"(mode {int(res.argmax())} of {count})"
        )
    dev = float(np.abs(chunked_gram(c_ii, vec) - np.eye(count)).max())
    if dev > ORTHOGONALITY_TOL:
        raise NumericalError(f"Dirichlet eigensolver: modes not C0-orthonormal (max |VᵀCV − I| = {dev:.1e})")
    full = np.zeros((ops.n, count))
    full[interior] = vec
    return lam, full


def steklov_modes(ops: ReferenceOperators, count: int, method: str = "auto", *, eigensolver: str = "auto",
                  progress: ProgressCallback | None = None) -> tuple[FloatArray, FloatArray]:
    """The ``count`` lowest non-zero Steklov modes (eqs. 7–8): eigenvalues (s⁻¹) and C0-normalised vectors.

    The constants (eigenvalue 0) are returned by :func:`zero_modes`, not here; ``eigensolver`` as in
    :func:`dirichlet_modes` (LOBPCG keeps the iterates M-orthogonal to the constants).
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
    if choose_eigensolver(eigensolver, ops.n) == "lobpcg":
        found = smallest_eigenpairs(ops.stiffness, b, count, shift=sigma, constraints=zero_modes(ops),
                                    rng=np.random.default_rng(0), label="Steklov modes", progress=progress)
        lam, vec = found.eigenvalues, found.vectors
        label = "LOBPCG"
    else:
        report_done(progress, "Steklov modes", count, started=True)
        lam, vec = _steklov_shift_invert(ops, b, want, n_zero, sigma=sigma, method=method)
        label = f"shift-invert, {resolve_method(method)}"
        report_done(progress, "Steklov modes", count)
    res = relative_residuals(ops.stiffness, b, lam, vec)
    if res.max(initial=0.0) > RESIDUAL_TOL:
        raise NumericalError(
            f"Steklov eigensolver ({label}, shift {sigma:.2e} s⁻¹): relative residual {res.max():.1e} "
            f"exceeds {RESIDUAL_TOL:.0e} (mode {int(res.argmax())} of {count})"
        )
    if lam[0] <= 1e-8 * lam[-1]:
        raise NumericalError("Steklov eigensolver: a zero eigenvalue beyond the constants (disconnected body?)")
    return lam, vec / column_norms(ops.capacity, vec)


def _steklov_shift_invert(ops: ReferenceOperators, b: sp.csr_array, want: int, n_zero: int, *, sigma: float,
                          method: str) -> tuple[FloatArray, FloatArray]:
    """ARPACK (or dense) shift-invert, purification and Rayleigh–Ritz; the constants removed."""
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
    return lam[n_zero:], vec[:, n_zero:]


def _check_combined(ops: ReferenceOperators, vectors: FloatArray) -> tuple[FloatArray, float]:
    """The capacity Gram matrix ``Φᵀ C0 Φ`` (unit diagonal) and its condition number; refuses a dependent basis."""
    gram = chunked_gram(ops.capacity, vectors)
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
    eigensolver: str = "auto",
    cache: NpzCache | None = None,
    progress: ProgressCallback | None = None,
    storage: str = "float64",
) -> ModalBasis:
    """Constants + ``n_steklov`` Steklov + ``n_dirichlet`` Dirichlet modes of ``system`` at reference ``values``.

    ``n_steklov`` counts the constants.  Cached in ``cache`` (key: K0, C0, B and the options), so
    scenes that differ only in their loads and exchanges share one basis.  ``eigensolver`` and
    ``progress`` (converged pairs of each family) as in :func:`dirichlet_modes`.  ``storage``
    ``"float32"`` rounds the vectors to single precision (half the bytes in memory and in the cache;
    the effect on face means is measured in benchmarks/reduce_scaling.py --float32).
    """
    if n_dirichlet < 0 or n_steklov < 1:
        raise InputError(f"mode counts must be n_dirichlet >= 0 and n_steklov >= 1, got {n_dirichlet}, {n_steklov}")
    if storage not in BASIS_STORAGE:
        raise InputError(f"unknown basis storage {storage!r}; allowed: {', '.join(BASIS_STORAGE)}")
    ops = reference_operators(system, values)
    solver = choose_eigensolver(eigensolver, ops.n)
    key = content_key(BASIS_VERSION, ops.key(), n_dirichlet, n_steklov, method,
                      *([solver] if solver != "arpack" else []), *([storage] if storage != "float64" else []))
    if cache is not None:
        stored = cache.load("basis", key)
        if stored is not None:
            return ModalBasis(stored["vectors"], stored["eigenvalues"], stored["kinds"], float(stored["zeta"]),
                              stored["gram"],
                              {"seconds": 0.0, "cached": 1.0, "gram_condition": float(stored["gram_condition"])})
    start = time.perf_counter()
    z = zero_modes(ops)
    lam_s, v_s = steklov_modes(ops, n_steklov - z.shape[1], method, eigensolver=solver, progress=progress)
    t_s = time.perf_counter() - start
    lam_d, v_d = dirichlet_modes(ops, n_dirichlet, method, eigensolver=solver, progress=progress)
    vectors = np.column_stack([z, v_s, v_d])
    eigenvalues = np.concatenate([np.zeros(z.shape[1]), lam_s, lam_d])
    kinds = np.array(["zero"] * z.shape[1] + ["steklov"] * lam_s.size + ["dirichlet"] * lam_d.size)
    gram, cond = _check_combined(ops, vectors)
    vectors = vectors.astype(storage, copy=False)
    seconds = time.perf_counter() - start
    if cache is not None:
        cache.save("basis", key, {"vectors": vectors, "eigenvalues": eigenvalues, "kinds": kinds,
                                  "zeta": np.float64(ops.zeta), "gram": gram, "gram_condition": np.float64(cond)})
    return ModalBasis(vectors, eigenvalues, kinds, ops.zeta, gram,
                      {"seconds": seconds, "steklov_seconds": t_s, "cached": 0.0, "gram_condition": cond})
