"""Sparse symmetric positive-definite factorisations, with a pure-scipy fallback (:func:`factorize_direct`; the
solver names, ``"mg"`` included, are resolved here; :func:`aromm.linalg.direct.factorize` adds the multigrid).

Choice (measured, docs/notes/solver_facts.md and benchmarks/fem_solvers.py): SuperLU with
its default COLAMD ordering takes minutes and gigabytes on 3-D voxel systems of ~1e5
unknowns, while the supernodal Cholesky CHOLMOD (shipped in cvxopt's PyPI wheels as
``cvxopt.cholmod``) factors them in seconds.  So:

* ``"cholmod"`` (default when cvxopt imports): supernodal Cholesky, lower triangle.
* ``"splu"``: SuperLU with the ``MMD_AT_PLUS_A`` ordering (symmetric structure), pure scipy.
* ``"amg"``: pyamg smoothed-aggregation preconditioned CG (steady solves, large sizes).
* ``"mg"``: geometric multigrid-preconditioned CG on the voxel node grid read off ``points``
  (aromm.linalg.multigrid.pcg.grid_solver through aromm.linalg.direct; the homogenisation uses its matrix-free
  twin, aromm.homogenization.cell_problems).

Every solve checks its relative residual ``||A x - b|| / ||b||`` against ``rtol``
and raises :class:`~aromm.core.errors.NumericalError` naming the method when it fails.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from aromm.core.choices import DEFAULT_RTOL, METHODS
from aromm.core.errors import InputError, NumericalError
from aromm.core.system import FloatArray
from aromm.linalg.orderings import nested_dissection

Method = Literal["auto", "cholmod", "splu", "amg", "mg"]
#: cvxopt's dense ``cholmod.solve`` loops over the columns (one pass over the factor each), its sparse ``spsolve``
#: hands CHOLMOD four at a time: from this many columns a block goes through ``spsolve`` (stored dense).  ``python
#: benchmarks/wide_solve.py --sizes 32 46 --columns 200`` (one thread, residual checks included; records
#: wide_solve_32_46.txt before, wide_solve_32_46_spsolve.txt after): 0.019 → 0.0099 CPU s a column at 32³, 0.070 →
#: 0.038 at 46³ (nnz(L) 5.1e7).
SPARSE_RHS = 4
#: Columns per ``spsolve`` call (the block is copied twice, as cvxopt dense and sparse matrices; CHOLMOD grows the
#: sparse solution as it goes, so wider calls copy more: 16 and 8 equal, 4 and 32 slower in system time).
CHOLMOD_CHUNK = 16


def cholmod_available() -> bool:
    return importlib.util.find_spec("cvxopt") is not None


def resolve_method(method: str) -> str:
    if method not in METHODS:
        raise InputError(f"unknown linear solver {method!r}; allowed: {', '.join(METHODS)}")
    if method == "auto":
        return "cholmod" if cholmod_available() else "splu"
    if method == "cholmod" and not cholmod_available():
        raise InputError("linear solver 'cholmod' needs cvxopt (pip install cvxopt); use 'splu' or 'amg'")
    return method


@dataclass(frozen=True)
class Factorization:
    """``solve(b)`` for ``A x = b`` with ``b`` of shape (n,) or (n, m); residual checked."""

    matrix: sp.csr_array
    method: str
    _solve: Callable[[FloatArray], FloatArray]
    rtol: float = DEFAULT_RTOL

    def solve(self, b: FloatArray, check: bool = True) -> FloatArray:
        b = np.asarray(b, dtype=float)
        x = self._solve(b)
        if check:
            check_residual(self.matrix, x, b, self.rtol, self.method)
        return x


#: The residual b − A x computed in float64 carries a rounding error of about √k · ε · ‖abs(A) abs(x)‖ (k ≤ 27 terms per
#: row of the voxel stencil, ε the machine epsilon): no solver can certify a smaller one [Higham2002, § 3.5, Thm 10.4].
#: Both the multigrid's CG (aromm.linalg.multigrid.pcg, ``MultigridSolver.at_floor``) and the direct solves
#: (:func:`check_residual`) accept a residual within rtol plus this floor.  Measured: ε ‖abs(A) abs(x)‖ / ‖b‖ on the
#: wood VERs (K + C/60 at k_F = 1, the load) 1.9e-11 at 32³, 5.4e-11 at 64³, growing like ‖A‖ ∝ h⁻², so ≈ 1.2e-10 at
#: 96³, where a CG solve to 1e-10 stagnated at 2.1e-10 for 500 iterations; CHOLMOD's residual on voxel K + sC (12³–24³,
#: contrasts 1e3–4e6, shifts 1/60–30 s⁻¹; `python benchmarks/direct_floor.py`, 2026-12-03) 0.47–0.56 ×
#: ε ‖abs(A) abs(x)‖, so its relative residual reached 2.5e-9 at fibre.k 300 / gas 0.026, where a fixed 1e-10 refused
#: an SPD system.
FLOOR_FACTOR = float(np.sqrt(27.0))
#: A rounding floor above this fraction of ‖b‖ leaves fewer than three digits: refused as badly conditioned.
FLOOR_LIMIT = 1e-3


def rounding_floor(a: sp.csr_array, x: FloatArray, nb: float) -> float:
    """``FLOOR_FACTOR ε ‖abs(A) abs(x)‖ / ‖b‖``: the relative residual float64 cannot certify below."""
    magnitude = sp.csr_array((np.abs(a.data), a.indices, a.indptr), shape=a.shape) @ np.abs(x)
    return FLOOR_FACTOR * float(np.finfo(float).eps) * float(np.linalg.norm(magnitude)) / nb


def check_residual(a: sp.csr_array, x: FloatArray, b: FloatArray, rtol: float, method: str) -> None:
    """Raise NumericalError when ``||A x - b|| > (rtol + floor) ||b||`` (floor: :func:`rounding_floor`), when the
    floor itself exceeds :data:`FLOOR_LIMIT`, or when x is not finite.  A singular matrix is refused before, by its
    factorisation (not positive definite)."""
    if not np.all(np.isfinite(x)):
        raise NumericalError(f"linear solver {method!r} returned non-finite values (singular matrix?)")
    r = float(np.linalg.norm(a @ x - b))
    nb = max(float(np.linalg.norm(b)), 1e-300)
    if r <= rtol * nb:
        return
    a = sp.csr_array(a)
    floor = rounding_floor(a, x, nb)
    if r > (rtol + floor) * nb or floor > FLOOR_LIMIT:
        raise NumericalError(
            f"linear solver {method!r}: relative residual {r / nb:.2e} exceeds {rtol:.0e} and its float64 rounding "
            f"floor {floor:.1e} (matrix badly conditioned: is some part of the body insulated from every fixed "
            "temperature or exchange?)"
        )


def factorize_direct(a: sp.spmatrix | sp.sparray, method: str = "auto", rtol: float = DEFAULT_RTOL,
              points: FloatArray | None = None, ordering: npt.NDArray[np.int64] | None = None) -> Factorization:
    """Factorise a sparse SPD matrix once for repeated solves.

    ``points`` (one coordinate row per unknown) enables the geometric nested-dissection
    ordering of aromm.linalg.orderings for the direct methods (13x less factorisation time than
    AMD at 1e5 voxel unknowns); without them CHOLMOD orders by AMD and SuperLU by MMD.  ``ordering``: that
    permutation computed once for many matrices of one sparsity pattern (shifted operators), instead of points.
    """
    a = sp.csr_array(a)
    name = resolve_method(method)
    if a.shape[0] == 0:
        return Factorization(a, name, np.zeros_like, rtol)
    perm = ordering if ordering is not None else \
        nested_dissection(a, points) if points is not None and name in ("cholmod", "splu") else None
    if name == "cholmod":
        return Factorization(a, name, _cholmod(a, perm), rtol)
    if name == "splu":
        return Factorization(a, name, _splu(a, perm), rtol)
    if name == "mg":
        raise InputError("linear solver 'mg' is iterative: aromm.linalg.direct.factorize runs it")
    return Factorization(a, name, _amg(a, rtol), rtol)


def _splu(a: sp.csr_array, perm: npt.NDArray[np.int64] | None) -> Callable[[FloatArray], FloatArray]:
    if perm is None:
        return spla.splu(sp.csc_matrix(a), permc_spec="MMD_AT_PLUS_A").solve
    lu = spla.splu(sp.csc_matrix(a[perm][:, perm]), permc_spec="NATURAL")
    inverse = np.argsort(perm)

    def solve(b: FloatArray) -> FloatArray:
        return lu.solve(b[perm])[inverse]

    return solve


def _cholmod(a: sp.csr_array, perm: npt.NDArray[np.int64] | None) -> Callable[[FloatArray], FloatArray]:
    import cvxopt  # type: ignore[import-untyped]
    import cvxopt.cholmod  # type: ignore[import-untyped]

    low = sp.tril(a, format="coo")
    mat = cvxopt.spmatrix(low.data.astype(float), low.row.astype(int), low.col.astype(int), a.shape)
    try:
        if perm is None:
            factor = cvxopt.cholmod.symbolic(mat, uplo="L")
        else:
            factor = cvxopt.cholmod.symbolic(mat, uplo="L", p=cvxopt.matrix(perm.astype(int).tolist(), tc="i"))
        cvxopt.cholmod.numeric(mat, factor)
    except ArithmeticError as err:
        raise NumericalError(f"CHOLMOD: matrix is not positive definite ({err})") from None

    def solve(b: FloatArray) -> FloatArray:
        wide = b.reshape(b.shape[0], -1)
        if wide.shape[1] < SPARSE_RHS:
            rhs = cvxopt.matrix(np.asfortranarray(wide))
            cvxopt.cholmod.solve(factor, rhs)
            return np.array(rhs).reshape(b.shape)
        out = np.empty(wide.shape)
        for lo in range(0, wide.shape[1], CHOLMOD_CHUNK):
            block = cvxopt.sparse(cvxopt.matrix(np.asfortranarray(wide[:, lo:lo + CHOLMOD_CHUNK])))
            x = cvxopt.cholmod.spsolve(factor, block)
            n, w = x.size
            values = np.frombuffer(x.V, dtype=float)  # column-major; every entry stored unless an exact zero
            out[:, lo:lo + w] = values.reshape(w, n).T if values.size == n * w else np.array(cvxopt.matrix(x))
        return out.reshape(b.shape)

    return solve


def _amg(a: sp.csr_array, rtol: float) -> Callable[[FloatArray], FloatArray]:
    import pyamg  # type: ignore[import-untyped]

    ml = pyamg.smoothed_aggregation_solver(sp.csr_matrix(a), symmetry="symmetric")
    m = ml.aspreconditioner(cycle="V")

    def solve_one(b: FloatArray) -> FloatArray:
        x, info = spla.cg(a, b, rtol=rtol * 0.1, maxiter=500, M=m)
        if info != 0:
            raise NumericalError(f"pyamg-preconditioned CG did not converge in 500 iterations (info={info})")
        return np.asarray(x)

    def solve(b: FloatArray) -> FloatArray:
        if b.ndim == 1:
            return solve_one(b)
        return np.column_stack([solve_one(b[:, j]) for j in range(b.shape[1])])

    return solve
