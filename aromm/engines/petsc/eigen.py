"""Dirichlet and Steklov eigenbases by SLEPc, with the definitions and normalisation of
:mod:`aromm.reduction.modal_bases`.

With reference operators K0 (conduction), C0 (capacity) and the boundary mass B [Chavez2020, § 3.1]:

* Dirichlet modes (eq. 6): ``K0_II v = λ C0_II v`` on the interior rows, ``v = 0`` on Γ;
* Steklov modes (eqs. 7–8): ``K0 v = λ ζB v`` with ``ζ = 1ᵀC0 1 / 1ᵀB 1``; the constants (λ = 0) are
  computed apart (:func:`aromm.reduction.modal_bases.zero_modes`) and dropped here.

Both are generalised Hermitian problems solved by Krylov–Schur with shift-and-invert (SLEPc ``EPS`` +
``ST sinvert``), the inner solves being a MUMPS Cholesky factorisation or CG + GAMG to a tight tolerance
(``solver``, aromm.engines.petsc.linear).  As in aromm.reduction.modal_bases, Steklov uses a small negative shift
``σ = −1e-6 max(diag K0 / diag ζB)`` (K0 and B are both singular), then one purification solve
``V ← (K0 − σζB)⁻¹ ζB V`` (the discrete harmonic extension), then a Rayleigh–Ritz step.  Every mode is
capacity-normalised, ``vᵀ C0 v = 1``.  Residuals and orthogonality are checked against the tolerances of
aromm.reduction.modal_bases; a :class:`~aromm.core.errors.NumericalError` names the solver when they fail.

Vectors are this rank's rows (n_local × count); every returned array is identical across ranks except
those rows.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from aromm.core.errors import NumericalError
from aromm.core.system import FloatArray
from aromm.engines.petsc import convert, linear, runtime
from aromm.engines.petsc.layout import RowLayout
from aromm.reduction.modal_bases import ORTHOGONALITY_TOL, RESIDUAL_TOL

#: SLEPc's relative residual tolerance for converged eigenpairs (ARPACK in aromm.reduction.modal_bases works to machine
#: precision; 1e-12 gives eigenvalues equal to ARPACK's to ~1e-14 relative on the test cases).
EIGEN_TOL = 1e-12
#: Relative tolerance of the iterative inner solves of shift-and-invert (must be tighter than EIGEN_TOL).
INNER_RTOL = 1e-13
#: Purification and Rayleigh–Ritz apply (K0 − σζB)⁻¹ once more to every Steklov vector.
STEKLOV_SHIFT = 1e-6


@dataclass(frozen=True)
class Reference:
    """Distributed K0 (W/K), C0 (J/K), boundary mass B (m²), ζ (J/(m² K)) and the row layout."""

    stiffness: Any
    capacity: Any
    boundary: Any
    zeta: float
    rows: RowLayout
    comm: Any

    def on_gamma(self) -> np.ndarray:
        """This rank's rows on the boundary (local indices): nonzero diagonal of B."""
        return np.flatnonzero(convert.array(self.boundary.getDiagonal()) > 0.0)


def _solve_eps(a: Any, b: Any, count: int, *, target: float, solver: str, prefix: str) -> tuple[
        FloatArray, FloatArray, Any]:
    """The ``count`` eigenpairs of ``a v = λ b v`` nearest ``target`` (ascending), this rank's rows, and the EPS."""
    SLEPc = runtime.slepc()
    eps = SLEPc.EPS().create(comm=a.getComm())
    eps.setOperators(a, b)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setDimensions(nev=count)
    eps.setTarget(target)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
    eps.setTolerances(tol=EIGEN_TOL, max_it=1000)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    linear.configure(st.getKSP(), solver, INNER_RTOL)
    eps.setOptionsPrefix(prefix)
    eps.setFromOptions()
    try:
        eps.solve()
    except runtime.petsc().Error as err:
        raise NumericalError(f"SLEPc Krylov–Schur ({prefix.strip('_')}, inner {solver}) failed: {err}") from None
    converged = int(eps.getConverged())
    if converged < count:
        raise NumericalError(f"SLEPc Krylov–Schur ({prefix.strip('_')}, {count} modes, inner {solver}) converged "
                             f"{converged} of {count} eigenpairs in {eps.getIterationNumber()} restarts; ask for "
                             "fewer modes")
    lam = np.array([eps.getEigenvalue(i).real for i in range(count)])
    order = np.argsort(lam)
    v = a.createVecRight()
    vec = np.empty((v.getLocalSize(), count), order="F")
    for position, i in enumerate(order):  # written in ascending order: no reordering copy
        eps.getEigenvector(int(i), v)
        vec[:, position] = v.getArray(readonly=True)
    return lam[order], vec, eps


def _residuals(a: Any, b: Any, lam: FloatArray, vec: FloatArray, comm: Any) -> FloatArray:
    """``||A v − λ B v|| / (||A v|| + |λ| ||B v||)`` per column (aromm.reduction.modal_bases._relative_residuals)."""
    sq = np.empty((3, vec.shape[1]))
    for cols, (av, bv) in convert.blocks((a, b), vec):
        sq[:, cols] = [((av - bv * lam[cols]) ** 2).sum(axis=0), (av**2).sum(axis=0), (bv**2).sum(axis=0)]
    sq = runtime.allsum(sq, comm)
    num, ka, mb = np.sqrt(sq)
    return num / np.maximum(ka + np.abs(lam) * mb, 1e-300)


def dirichlet_modes(ref: Reference, count: int, solver: str, out: FloatArray) -> FloatArray:
    """The ``count`` slowest Dirichlet modes (eq. 6): their eigenvalues (s⁻¹, returned, ascending) and their
    C0-normalised vectors written into the first columns of ``out`` (this rank's rows of the full numbering,
    zero on Γ)."""
    PETSc = runtime.petsc()
    rows, comm = ref.rows, ref.comm
    interior = np.setdiff1d(np.arange(rows.local), ref.on_gamma())
    n_interior = int(runtime.allsum([interior.size], comm)[0])
    count = min(count, n_interior)
    if count <= 0:
        return np.zeros(0)
    index = PETSc.IS().createGeneral((interior + rows.lo).astype(PETSc.IntType), comm=comm)
    k_ii = ref.stiffness.createSubMatrix(index, index)
    c_ii = ref.capacity.createSubMatrix(index, index)
    lam, vec, eps = _solve_eps(k_ii, c_ii, count, target=0.0, solver=solver, prefix="aromm_dirichlet_")
    eps.destroy()  # its inner solver's multigrid hierarchy or factorisation (peak memory)
    res = _residuals(k_ii, c_ii, lam, vec, comm)
    if res.max(initial=0.0) > RESIDUAL_TOL:
        raise NumericalError(f"SLEPc Dirichlet eigensolver ({solver}): relative residual {res.max():.1e} exceeds "
                             f"{RESIDUAL_TOL:.0e} (mode {int(res.argmax())} of {count})")
    gram = convert.quadratic(c_ii, vec, vec, comm)
    dev = float(np.abs(gram - np.eye(count)).max())
    if dev > ORTHOGONALITY_TOL:
        raise NumericalError(f"SLEPc Dirichlet eigensolver: modes not C0-orthonormal (max |VᵀCV − I| = {dev:.1e})")
    out[:, :count] = 0.0
    out[interior, :count] = vec
    return lam


def steklov_modes(ref: Reference, count: int, n_zero: int, solver: str) -> tuple[FloatArray, FloatArray]:
    """The ``count`` lowest non-zero Steklov modes (eqs. 7–8): eigenvalues (s⁻¹), C0-normalised vectors."""
    rows, comm = ref.rows, ref.comm
    b = ref.boundary.copy()
    b.scale(ref.zeta)
    gamma = ref.on_gamma()
    count = min(count, int(runtime.allsum([gamma.size], comm)[0]) - n_zero)
    if count <= 0:
        return np.zeros(0), np.zeros((rows.local, 0))
    ratio = convert.array(ref.stiffness.getDiagonal())[gamma] / convert.array(b.getDiagonal())[gamma]
    sigma = -STEKLOV_SHIFT * runtime.allmax(float(ratio.max(initial=0.0)), comm)
    _, vec, eps = _solve_eps(ref.stiffness, b, count + n_zero, target=sigma, solver=solver,
                             prefix="aromm_steklov_")
    ksp = eps.getST().getKSP()  # operator K0 − σζB
    rhs, x = b.createVecLeft(), b.createVecRight()
    for j in range(vec.shape[1]):  # purification: the discrete harmonic extension of each trace
        x.getArray()[:] = vec[:, j]
        b.mult(x, rhs)
        linear.solve(ksp, rhs, x, "Steklov purification", INNER_RTOL)
        vec[:, j] = x.getArray(readonly=True)
    eps.destroy()
    kr = convert.quadratic(ref.stiffness, vec, vec, comm)
    br = convert.quadratic(b, vec, vec, comm)
    try:
        lam, q = sla.eigh((kr + kr.T) / 2, (br + br.T) / 2)
    except np.linalg.LinAlgError as err:
        raise NumericalError(f"Steklov Rayleigh–Ritz: traces of the computed modes are dependent ({err})") from None
    vec = convert.combine_rows(vec, q, out=vec)[:, n_zero:]  # in place, block of rows by block of rows
    lam = lam[n_zero:]
    res = _residuals(ref.stiffness, b, lam, vec, comm)
    if res.max(initial=0.0) > RESIDUAL_TOL:
        raise NumericalError(f"SLEPc Steklov eigensolver (shift {sigma:.2e} s⁻¹, {solver}): relative residual "
                             f"{res.max():.1e} exceeds {RESIDUAL_TOL:.0e} (mode {int(res.argmax())} of {count})")
    if lam[0] <= 1e-8 * lam[-1]:
        raise NumericalError("SLEPc Steklov eigensolver: a zero eigenvalue beyond the constants (disconnected body?)")
    vec /= np.sqrt(convert.diagonal(ref.capacity, vec, comm))
    return lam, vec
