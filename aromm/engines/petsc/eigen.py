"""Dirichlet and Steklov eigenbases by SLEPc, with the definitions and normalisation of
:mod:`aromm.reduction.modal_bases`.

With reference operators K0 (conduction), C0 (capacity) and the boundary mass B [Chavez2020, § 3.1]:

* Dirichlet modes (eq. 6): ``K0_II v = λ C0_II v`` on the interior rows, ``v = 0`` on Γ;
* Steklov modes (eqs. 7–8): ``K0 v = λ ζB v`` with ``ζ = 1ᵀC0 1 / 1ᵀB 1``; the constants (λ = 0) are
  computed apart (:func:`aromm.reduction.modal_bases.zero_modes`) and dropped here.

Both are generalised Hermitian problems, solved by one of two methods (``eigensolver``, the knob of
aromm.linalg.eigensolvers; :func:`choose`, ``"auto"`` is shift-invert, measured):

* ``"arpack"``: Krylov–Schur with shift-and-invert (SLEPc ``EPS`` + ``ST sinvert``), the inner solves being a
  MUMPS Cholesky factorisation or CG + GAMG to a tight tolerance (``solver``, aromm.engines.petsc.linear).  As in
  aromm.reduction.modal_bases, Steklov uses a small negative shift ``σ = −1e-6 max(diag K0 / diag ζB)`` (K0 and B
  are both singular), then one purification solve ``V ← (K0 − σζB)⁻¹ ζB V`` (the discrete harmonic extension),
  then a Rayleigh–Ritz step.
* ``"lobpcg"``: a preconditioned eigensolver with no inner solve, SLEPc's Generalized Davidson (``EPS gd``,
  ``ST precond``, ``KSP preonly`` + ``PC gamg``: one V-cycle per new direction), converged to :data:`BLOCK_TOL`.
  Dirichlet: the smallest λ of ``(K0_II, C0_II)``, preconditioned by GAMG on K0_II.  Steklov: ζB is singular,
  so, as the serial LOBPCG does (aromm.linalg.eigensolvers), the largest ``μ = 1/(λ − σ)`` of the inverted pencil
  ``ζB x = μ M x``, ``M = K0 − σζB`` (SPD, its inner product a norm; σ = −1e-4 max(diag K0 / diag ζB)),
  preconditioned by GAMG on M, with the constants deflated (kept M-orthogonal); its eigenvectors are discretely
  harmonic, no purification is needed.
  SLEPc's own LOBPCG (``-aromm_steklov_eps_type lobpcg``) fails on that pencil (LAPACK sygvd on a
  near-singular Gram matrix, 24³ wood VER, measured) and took 1.4–1.6× GD's CPU on the Dirichlet modes there.

Every mode is capacity-normalised, ``vᵀ C0 v = 1``.  Residuals and orthogonality are checked against the tolerances
of aromm.reduction.modal_bases; a :class:`~aromm.core.errors.NumericalError` names the solver when they fail.

Vectors are this rank's rows (n_local × count); every returned array is identical across ranks except
those rows.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from aromm.core.choices import EIGENSOLVERS
from aromm.core.errors import InputError, NumericalError
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
#: Relative residual ``||A x − θ B x|| / (||A|| + |θ| ||B||)`` (SLEPc's ``EPS_CONV_NORM``, matrix norms) of the
#: preconditioned eigensolver.  The per-vector residual that aromm.reduction.modal_bases checks (vector norms in the
#: denominator) is up to ~100× larger for the smooth modes: 1e-8 left 1.1e-6 > RESIDUAL_TOL on the 12³ wood VER,
#: 1e-10 leaves ≤ 2.5e-8 there and at 24³.
BLOCK_TOL = 1e-10
#: Steklov shift of the preconditioned eigensolver, ``σ = −PRECONDITIONED_SHIFT max(diag K0 / diag ζB)``: the
#: constants' direction is M's smallest eigenvalue (proportional to −σ), and at the shift-invert's 1e-6 Generalized
#: Davidson stalled at a residual of 1.2e-10 on the 12³ wood VER (round-off of the near-singular M); 1e-4 converges,
#: in as many iterations.
PRECONDITIONED_SHIFT = 1e-4
#: ``eigensolver="auto"`` keeps shift-invert: the preconditioned eigensolver did not pay where measured
#: (benchmarks/petsc_engine.py, wood VER, Ñ = 94, CG + GAMG, 2026-12-02, 2 shared cores at load 5–11): CPU per rank
#: 1.25× shift-invert's on 1 rank at 32³ (66.5 against 53.0 s) and 0.97× at 40³ (133.8 / 137.6 s); on 2 ranks
#: 0.97× at 32³ and 1.01× at 40³ (136.9 / 136.0 s); peak memory per rank within 3 %; its iterations (≈ 2,000) did
#: not grow from 32³ to 40³, so it is the choice to measure first on a cluster (``eigensolver="lobpcg"``).
#: Iterations allowed to the preconditioned eigensolver (one new direction each).
BLOCK_MAX_ITERATIONS = 20_000


def choose(eigensolver: str) -> str:
    """``"arpack"`` (Krylov–Schur shift-invert; also for ``"auto"``) or ``"lobpcg"`` (preconditioned Davidson)."""
    if eigensolver not in EIGENSOLVERS:
        raise InputError(f"unknown eigensolver {eigensolver!r}; allowed: {', '.join(EIGENSOLVERS)}")
    return "arpack" if eigensolver == "auto" else eigensolver


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


def _eps(a: Any, b: Any, count: int, *, tol: float, max_it: int, prefix: str) -> Any:
    """A SLEPc EPS for the ``count`` eigenpairs of the Hermitian pencil ``a v = λ b v`` (``b`` SPD); PETSc options
    with ``prefix`` override its set-up."""
    SLEPc = runtime.slepc()
    eps = SLEPc.EPS().create(comm=a.getComm())
    eps.setOptionsPrefix(prefix)
    eps.setOperators(a, b)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setDimensions(nev=count)
    eps.setTolerances(tol=tol, max_it=max_it)
    return eps


def _run(eps: Any, count: int, *, what: str, descending: bool = False) -> tuple[FloatArray, FloatArray]:
    """Solve ``eps``: the ``count`` eigenvalues, ascending (or descending), and their vectors in that order, this
    rank's rows.  ``what`` names the solver in errors."""
    eps.setFromOptions()
    family = eps.getOptionsPrefix().removeprefix("aromm_").strip("_")
    try:
        eps.solve()
    except runtime.petsc().Error as err:
        raise NumericalError(f"SLEPc {what} ({family}) failed: {err}") from None
    converged = int(eps.getConverged())
    if converged < count:
        raise NumericalError(f"SLEPc {what} ({family}, {count} modes) converged {converged} of {count} eigenpairs "
                             f"in {eps.getIterationNumber()} iterations; ask for fewer modes")
    lam = np.array([eps.getEigenvalue(i).real for i in range(count)])
    order = np.argsort(-lam if descending else lam)
    v = eps.getOperators()[0].createVecRight()
    vec = np.empty((v.getLocalSize(), count), order="F")
    for position, i in enumerate(order):  # written in the order asked: no reordering copy
        eps.getEigenvector(int(i), v)
        vec[:, position] = v.getArray(readonly=True)
    return lam[order], vec


def _shift_invert(a: Any, b: Any, count: int, *, target: float, solver: str, prefix: str) -> tuple[
        FloatArray, FloatArray, Any]:
    """The ``count`` eigenpairs of ``a v = λ b v`` nearest ``target`` (ascending), this rank's rows, and the EPS
    (Krylov–Schur, shift-and-invert)."""
    SLEPc = runtime.slepc()
    eps = _eps(a, b, count, tol=EIGEN_TOL, max_it=1000, prefix=prefix)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setTarget(target)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    linear.configure(st.getKSP(), solver, INNER_RTOL)
    lam, vec = _run(eps, count, what=f"Krylov–Schur (inner {solver})")
    return lam, vec, eps


def _preconditioned(a: Any, b: Any, count: int, *, largest: bool, preconditioner: Any, prefix: str,
                    deflation: list[Any] | None = None) -> tuple[FloatArray, FloatArray, int]:
    """The ``count`` smallest (or ``largest``) eigenpairs of ``a v = λ b v`` by Generalized Davidson with one GAMG
    V-cycle on ``preconditioner`` per new direction, kept ``b``-orthogonal to ``deflation``; eigenvalues in
    that order, this rank's rows, and the iterations."""
    # The SI operators of µm voxels have entries ~1e-7, so b-normalised vectors have 2-norms ~1e3: the operators
    # are scaled by a power of two (exact, λ unchanged) to a mean diagonal of b near 1 while SLEPc works, then
    # restored.
    trace = runtime.allsum([convert.array(b.getDiagonal()).sum(), b.getSize()[0]], a.getComm())
    scale = 2.0 ** -np.round(np.log2(trace[0] / trace[1]))
    operators = {id(m): m for m in (a, b, preconditioner)}.values()
    for mat in operators:
        mat.scale(scale)
    try:
        return _davidson(a, b, count, largest=largest, preconditioner=preconditioner, prefix=prefix,
                         deflation=deflation)
    finally:
        for mat in operators:
            mat.scale(1.0 / scale)


def _davidson(a: Any, b: Any, count: int, *, largest: bool, preconditioner: Any, prefix: str,
              deflation: list[Any] | None) -> tuple[FloatArray, FloatArray, int]:
    """:func:`_preconditioned` on the scaled operators."""
    SLEPc = runtime.slepc()
    eps = _eps(a, b, count, tol=BLOCK_TOL, max_it=BLOCK_MAX_ITERATIONS, prefix=prefix)
    eps.setType(SLEPc.EPS.Type.GD)
    eps.setConvergenceTest(SLEPc.EPS.Conv.NORM)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_REAL if largest else SLEPc.EPS.Which.SMALLEST_REAL)
    if deflation:
        eps.setDeflationSpace(deflation)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.PRECOND)
    st.setPreconditionerMat(preconditioner)
    ksp = st.getKSP()
    ksp.setType(runtime.petsc().KSP.Type.PREONLY)
    ksp.getPC().setType(runtime.petsc().PC.Type.GAMG)
    lam, vec = _run(eps, count, what="Generalized Davidson + GAMG", descending=largest)
    iterations = int(eps.getIterationNumber())
    eps.destroy()
    return lam, vec, iterations


def _residuals(a: Any, b: Any, lam: FloatArray, vec: FloatArray, comm: Any) -> FloatArray:
    """``||A v − λ B v|| / (||A v|| + |λ| ||B v||)`` per column (aromm.reduction.modal_bases._relative_residuals)."""
    sq = np.empty((3, vec.shape[1]))
    for cols, (av, bv) in convert.blocks((a, b), vec):
        sq[:, cols] = [((av - bv * lam[cols]) ** 2).sum(axis=0), (av**2).sum(axis=0), (bv**2).sum(axis=0)]
    sq = runtime.allsum(sq, comm)
    num, ka, mb = np.sqrt(sq)
    return num / np.maximum(ka + np.abs(lam) * mb, 1e-300)


def dirichlet_modes(ref: Reference, count: int, solver: str, out: FloatArray, eigensolver: str = "arpack",
                    ) -> tuple[FloatArray, int]:
    """The ``count`` slowest Dirichlet modes (eq. 6): their eigenvalues (s⁻¹, returned, ascending, with the
    iterations of the preconditioned eigensolver, 0 for shift-invert) and their C0-normalised vectors written
    into the first columns of ``out`` (this rank's rows of the full numbering, zero on Γ)."""
    PETSc = runtime.petsc()
    rows, comm = ref.rows, ref.comm
    interior = np.setdiff1d(np.arange(rows.local), ref.on_gamma())
    n_interior = int(runtime.allsum([interior.size], comm)[0])
    count = min(count, n_interior)
    if count <= 0:
        return np.zeros(0), 0
    index = PETSc.IS().createGeneral((interior + rows.lo).astype(PETSc.IntType), comm=comm)
    k_ii = ref.stiffness.createSubMatrix(index, index)
    c_ii = ref.capacity.createSubMatrix(index, index)
    iterations = 0
    if choose(eigensolver) == "lobpcg":
        label = "Generalized Davidson + GAMG"
        lam, vec, iterations = _preconditioned(k_ii, c_ii, count, largest=False, preconditioner=k_ii,
                                               prefix="aromm_dirichlet_")
        vec /= np.sqrt(convert.diagonal(c_ii, vec, comm))
    else:
        label = solver
        lam, vec, eps = _shift_invert(k_ii, c_ii, count, target=0.0, solver=solver, prefix="aromm_dirichlet_")
        eps.destroy()  # its inner solver's multigrid hierarchy or factorisation (peak memory)
    res = _residuals(k_ii, c_ii, lam, vec, comm)
    if res.max(initial=0.0) > RESIDUAL_TOL:
        raise NumericalError(f"SLEPc Dirichlet eigensolver ({label}): relative residual {res.max():.1e} exceeds "
                             f"{RESIDUAL_TOL:.0e} (mode {int(res.argmax())} of {count})")
    gram = convert.quadratic(c_ii, vec, vec, comm)
    dev = float(np.abs(gram - np.eye(count)).max())
    if dev > ORTHOGONALITY_TOL:
        raise NumericalError(f"SLEPc Dirichlet eigensolver ({label}): modes not C0-orthonormal "
                             f"(max |VᵀCV − I| = {dev:.1e})")
    out[:, :count] = 0.0
    out[interior, :count] = vec
    return lam, iterations


def steklov_modes(ref: Reference, count: int, constants: FloatArray, solver: str, eigensolver: str = "arpack",
                  ) -> tuple[FloatArray, FloatArray, int]:
    """The ``count`` lowest non-zero Steklov modes (eqs. 7–8) outside span(``constants``) (the zero modes, this
    rank's rows): eigenvalues (s⁻¹), C0-normalised vectors, iterations of the preconditioned eigensolver (0 for
    shift-invert)."""
    rows, comm = ref.rows, ref.comm
    n_zero = constants.shape[1]
    b = ref.boundary.copy()
    b.scale(ref.zeta)
    gamma = ref.on_gamma()
    count = min(count, int(runtime.allsum([gamma.size], comm)[0]) - n_zero)
    if count <= 0:
        return np.zeros(0), np.zeros((rows.local, 0)), 0
    ratio = convert.array(ref.stiffness.getDiagonal())[gamma] / convert.array(b.getDiagonal())[gamma]
    top = runtime.allmax(float(ratio.max(initial=0.0)), comm)
    sigma = -STEKLOV_SHIFT * top
    iterations = 0
    if choose(eigensolver) == "lobpcg":
        label = "Generalized Davidson + GAMG"
        sigma = -PRECONDITIONED_SHIFT * top
        lam, vec, iterations = _steklov_preconditioned(ref, b, count, sigma, constants)
    else:
        label = solver
        lam, vec = _steklov_shift_invert(ref, b, count, n_zero, sigma=sigma, solver=solver)
    res = _residuals(ref.stiffness, b, lam, vec, comm)
    if res.max(initial=0.0) > RESIDUAL_TOL:
        raise NumericalError(f"SLEPc Steklov eigensolver (shift {sigma:.2e} s⁻¹, {label}): relative residual "
                             f"{res.max():.1e} exceeds {RESIDUAL_TOL:.0e} (mode {int(res.argmax())} of {count})")
    if lam[0] <= 1e-8 * lam[-1]:
        raise NumericalError("SLEPc Steklov eigensolver: a zero eigenvalue beyond the constants (disconnected body?)")
    vec /= np.sqrt(convert.diagonal(ref.capacity, vec, comm))
    return lam, vec, iterations


def _steklov_preconditioned(ref: Reference, b: Any, count: int, sigma: float, constants: FloatArray) -> tuple[
        FloatArray, FloatArray, int]:
    """The largest μ of ``ζB x = μ M x``, ``M = K0 − σζB``, M-orthogonal to the constants: ``λ = σ + 1/μ``."""
    m = ref.stiffness.copy()
    m.axpy(-sigma, b, structure=runtime.petsc().Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    deflation = [convert.vector(c, ref.rows, ref.comm) for c in constants.T]
    mu, vec, iterations = _preconditioned(b, m, count, largest=True, preconditioner=m, deflation=deflation,
                                          prefix="aromm_steklov_")
    m.destroy()
    if np.any(mu <= 0):
        raise NumericalError("SLEPc Steklov eigensolver (Generalized Davidson): a non-positive eigenvalue of the "
                             "inverted pencil")
    return sigma + 1.0 / mu, vec, iterations


def _steklov_shift_invert(ref: Reference, b: Any, count: int, n_zero: int, *, sigma: float, solver: str) -> tuple[
        FloatArray, FloatArray]:
    """Krylov–Schur shift-invert at σ, purification and Rayleigh–Ritz; the constants dropped."""
    comm = ref.comm
    _, vec, eps = _shift_invert(ref.stiffness, b, count + n_zero, target=sigma, solver=solver,
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
    return lam[n_zero:], vec
