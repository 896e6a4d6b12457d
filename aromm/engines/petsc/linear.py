"""PETSc linear solvers for symmetric positive-definite voxel systems, with checked residuals.

Two choices (the knob ``solver``), both usable as the inner solver of SLEPc's shift-and-invert:

* ``"gamg"`` (default): conjugate gradients preconditioned by PETSc's algebraic multigrid GAMG; memory
  O(unknowns), cost ≈ O(N^1.1–1.3) (docs/notes/solver_facts.md); converged to ``rtol`` on the
  preconditioned residual, then the true relative residual ``||b − A x|| / ||b||`` is checked.
* ``"mumps"``: Cholesky factorisation by MUMPS (parallel direct, exact to round-off, memory ≈ N^1.3), its
  analysis in parallel where the MUMPS build has PT-Scotch or ParMETIS (aromm.engines.petsc.mumps).

PETSc options with the prefix of each solver (``-aromm_steady_ksp_rtol 1e-8`` ...) override these choices
for the expert; failures raise :class:`~aromm.core.errors.NumericalError` naming the solver and why.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aromm.core.errors import InputError, NumericalError
from aromm.core.system import FloatArray
from aromm.engines.petsc import mumps, runtime

SOLVERS = ("gamg", "mumps")
#: Relative residual of the steady solves (face means to ~1e-9 of the temperature scale on the test cases).
STEADY_RTOL = 1e-11
#: Relative residual of the solves of a coupled system (two fields, aromm.physics.hygrothermal), on its symmetrically
#: Jacobi-scaled form (:func:`krylov` with ``fields`` > 1, which the weight λ ≈ 8e7 J/kg of the moisture rows calls
#: for: unscaled, they outweigh the heat rows in ‖b‖).  On data/scenes/wood_moisture.toml's 23³ image (2 ranks,
#: transient, against the direct solve): face means to 2.2e-4 °C unscaled at 1e-11, 4.8e-6 °C scaled at 1e-11,
#: 2.0e-8 °C (φ 1.1e-10) scaled at 1e-13, ≤ 27 CG iterations a step.
COUPLED_RTOL = 1e-13
#: Largest number of CG iterations before a solve is declared failed.
MAX_ITERATIONS = 5000


def check_solver(solver: str) -> str:
    """``solver`` when it is one of :data:`SOLVERS`; ``"auto"`` means ``"gamg"``."""
    if solver == "auto":
        return "gamg"
    if solver not in SOLVERS:
        raise InputError(f"unknown PETSc solver {solver!r}; allowed with the petsc engine: auto, "
                         f"{', '.join(SOLVERS)}")
    return solver


def tolerance(rtol: float, fields: int) -> float:
    """The relative residual of a solve of a system of ``fields`` unknowns per node: ``rtol``, at most
    :data:`COUPLED_RTOL` for a coupled one."""
    return rtol if fields == 1 else min(rtol, COUPLED_RTOL)


def configure(ksp: Any, solver: str, rtol: float) -> None:
    """Set ``ksp`` (its options prefix set) to CG + GAMG at ``rtol`` or to a MUMPS Cholesky solve (with
    :func:`aromm.engines.petsc.mumps.analysis_options`)."""
    PETSc = runtime.petsc()
    pc = ksp.getPC()
    if check_solver(solver) == "mumps":
        ksp.setType(PETSc.KSP.Type.PREONLY)
        pc.setType(PETSc.PC.Type.CHOLESKY)
        pc.setFactorSolverType("mumps")
        mumps.analysis_options(ksp.getOptionsPrefix() or "", ksp.getComm())
    else:
        ksp.setType(PETSc.KSP.Type.CG)
        pc.setType(PETSc.PC.Type.GAMG)
        ksp.setTolerances(rtol=rtol, atol=0.0, max_it=MAX_ITERATIONS)
        ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)


def krylov(mat: Any, solver: str, rtol: float, prefix: str, grid: Any = None, *, fields: int = 1) -> Any:
    """A KSP for ``mat`` configured by :func:`configure`; PETSc options with ``prefix`` override it.  ``grid`` (a
    DMDA of the unknowns) lets the options choose geometric multigrid (``-<prefix>pc_type mg``).  A coupled system
    (``fields`` > 1) is solved in its symmetrically scaled form ``D^-1/2 A D^-1/2`` (D = diag A, PETSc's
    ``KSPSetDiagonalScale``): still symmetric positive definite, its heat and moisture rows of one size."""
    PETSc = runtime.petsc()
    ksp = PETSc.KSP().create(comm=mat.getComm())
    if grid is not None:
        ksp.setDM(grid)
        ksp.setDMActive(False)  # the operators are ours; the DMDA only gives the grid hierarchy
    ksp.setOperators(mat)
    ksp.setOptionsPrefix(prefix)
    configure(ksp, solver, rtol)
    # petsc4py 3.18 has no KSPSetDiagonalScale: the options for this KSP only, unless the caller's options set them
    options = PETSc.Options(prefix)
    added = [name for name in ("ksp_diagonal_scale", "ksp_diagonal_scale_fix") if fields > 1
             and not options.hasName(name)]
    for name in added:
        options.setValue(name, True)  # _fix: the system is unscaled after each solve
    try:
        ksp.setFromOptions()
    finally:
        for name in added:
            options.delValue(name)
    return ksp


def scale_symmetrically(mat: Any, label: str) -> FloatArray:
    """Scale ``mat`` in place to ``D^-1/2 A D^-1/2`` (D = diag A > 0) and return this rank's entries of
    ``s = diag(A)^-1/2``: the scaled form :func:`krylov` asks PETSc for (``fields`` > 1), held explicitly, so that the
    operator is scaled once (PETSc's ``ksp_diagonal_scale_fix`` scales and unscales it around every solve, which moves
    its entries by a few ε each time).  ``A x = b`` is then ``Â y = s ∘ b``, ``x = s ∘ y``, and the scaled residual
    ``s ∘ b − Â y = s ∘ (b − A x)``: each row relative to its own diagonal, a coupled system's heat rows as its
    λ-weighted moisture rows.  A diagonal entry ≤ 0 (not positive definite) raises :class:`NumericalError`
    (collective)."""
    d = mat.getDiagonal()
    local = d.getArray(readonly=True)
    lowest = -runtime.allmax(-float(local.min(initial=np.inf)), mat.getComm())
    if not lowest > 0.0:
        d.destroy()
        raise NumericalError(f"{label}: a diagonal entry of the operator is {lowest:.3g} (≤ 0): it is not positive "
                             "definite, and cannot be scaled by its diagonal")
    d.sqrtabs()
    d.reciprocal()
    mat.diagonalScale(d, d)
    scale = np.array(d.getArray(readonly=True), dtype=float)
    d.destroy()
    return scale


def solve(ksp: Any, b: Any, x: Any, label: str, rtol: float) -> int:
    """Solve ``A x = b`` (``x`` holds the initial guess); check convergence and the true residual.

    Returns the number of iterations."""
    try:
        ksp.solve(b, x)
    except runtime.petsc().Error as err:
        raise NumericalError(f"PETSc {ksp.getType()}/{ksp.getPC().getType()} ({label}) failed: {err}") from None
    reason = int(ksp.getConvergedReason())
    iterations = int(ksp.getIterationNumber())
    if reason < 0:
        why = mumps.failure(ksp) or ("is part of the body insulated from every fixed temperature or exchange?")
        raise NumericalError(f"PETSc {ksp.getType()}/{ksp.getPC().getType()} ({label}) diverged (reason {reason}) "
                             f"after {iterations} iterations: {why}")
    mat = ksp.getOperators()[0]
    residual = b.duplicate()
    mat.mult(x, residual)
    residual.aypx(-1.0, b)
    norm_b = max(float(b.norm()), 1e-300)
    relative = float(residual.norm()) / norm_b
    if not np.isfinite(relative) or relative > max(100.0 * rtol, 1e-8):
        raise NumericalError(f"PETSc {ksp.getType()}/{ksp.getPC().getType()} ({label}): relative residual "
                             f"{relative:.1e} exceeds {max(100.0 * rtol, 1e-8):.0e} (singular or badly "
                             "conditioned system)")
    return iterations
