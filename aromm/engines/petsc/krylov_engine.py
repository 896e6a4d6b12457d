"""The petsc engine of the offline reduction: :class:`~aromm.reduction.engine_protocol.ReductionEngine` under MPI.

The Krylov reductor (:mod:`aromm.reduction.krylov`) runs unchanged on every rank (SPMD); what it calls here works on the
distributed operators of :class:`~aromm.engines.petsc.assembly.DistributedSystem` (one MPIAIJ matrix per
affine term).  A *block* is this rank's rows of n × m vectors as a NumPy array (Fortran order): the basis is
one dense matrix, never gathered.  Small results (Gram matrices, reduced operators, residual norms) are summed
over the ranks, so every rank holds the same small arrays and takes the same decisions.

* Shifted solves ``(K(μ) + s C(μ)) X = B`` by PETSc KSP only (no SLEPc): conjugate gradients, column by column
  from the reductor's guess (else zero), stopped on the *unpreconditioned* residual ``‖b − A x‖ ≤ rtol ‖b‖`` and checked
  (:mod:`aromm.engines.petsc.linear`); one KSP (one multigrid hierarchy) per (μ, s), kept while the reductor
  asks for the same (μ, s).  Preconditioner (``solver``): ``"mg"``, geometric multigrid on the DMDA of a voxel
  grid (PCMG: the DMDA's trilinear interpolation, Galerkin coarse operators ``PᵀAP``, Chebyshev–Jacobi
  smoothing), which ``"auto"`` picks when the grid halves at least :data:`MG_MIN_LEVELS` times
  (:func:`grid_levels`); ``"gamg"``, PETSc's algebraic multigrid (any grid, the fallback); ``"mumps"``, one
  Cholesky factorisation per (μ, s).  Measured on the 16³ wood VER (96 solves, rtol 1e-10, 1 rank): PCMG
  11.4 CG iterations, 0.40 s of set-ups and 0.59 s of solves, GAMG 14.6 iterations, 0.69 s and 0.73 s.
* A coupled heat–moisture system (two fields, :mod:`aromm.physics.hygrothermal`) is solved on its operator scaled once
  by its diagonal, ``D^-1/2 (K + s C) D^-1/2`` (block size 2), its CG stopped on the scaled residual as the full
  model's coupled solves (:func:`aromm.engines.petsc.linear.scale_symmetrically`); its initial φ is an input.
* C(μ)-orthonormalisation: the algorithm of the scipy engine (:mod:`aromm.reduction.scipy_engine`) — block
  classical Gram–Schmidt twice, orthonormalisation of the new columns by the eigen-decomposition of their
  Gram matrix, one more pass — with every inner product summed over the ranks.  The basis lives in one
  Fortran buffer that grows as columns come in (:class:`~aromm.reduction.column_buffer.ColumnBuffer`: no copy of the
  basis per appended block).
* Projection and residuals share the products ``P_t = A_t V`` of every matrix term A_t (conduction, exchange,
  capacity) with the basis V, computed once per basis: the reduced operators are ``Vᵀ P_t`` and the residual of a
  reduced frequency response is ``r = U a(μ) − Σ_t θ_t(μ, s) P_t x = W z`` with ``W = [U, P_1, …, P_T]``, so
  ``‖r‖² = zᵀ (WᵀW) z``: one Gram matrix per basis and no n-vector per (μ, s) (the offline/online split of
  reduced-basis residual estimates [Haasdonk2008]).  Its floor is ≈ √ε of the terms' size (relative residuals
  ≈ 1e-8), far below the indicator values the greedy compares.

Units SI; tolerances as in :class:`~aromm.reduction.engine_protocol.ReductionEngine`.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import PENALTY_INSTEAD, FloatArray, require_free_transient
from aromm.engines.petsc import convert, linear, runtime
from aromm.engines.petsc.assembly import DistributedSystem, DistributedTerm
from aromm.engines.petsc.projection import project
from aromm.reduction.column_buffer import ColumnBuffer, GrowingProjection
from aromm.reduction.engine_protocol import SolveStats
from aromm.reduction.residual_form import residual_norms
from aromm.reduction.rom import ReducedModel
from aromm.reduction.scipy_engine import gram_orthonormal, input_coefficients, input_weights, pencil

#: Capacity matrices C(μ) kept for reuse, least recently used dropped first: the reference point's (the capacity
#: product of the basis) and the current moment point's.
KEPT_MATRICES = 2
SOLVERS = ("auto", "mg", "gamg", "mumps")
#: Geometric multigrid needs at least this many levels (``"auto"`` takes GAMG below), and takes at most this many.
MG_MIN_LEVELS, MG_MAX_LEVELS = 3, 6
#: PETSc options of the geometric multigrid (prefix ``aromm_krylov_``), each unless the user set it.
MG_OPTIONS = {"pc_type": "mg", "pc_mg_galerkin": "both", "mg_levels_ksp_type": "chebyshev",
              "mg_levels_pc_type": "jacobi"}


def grid_levels(grid: Any) -> int:
    """Levels of the DMDA ``grid``'s hierarchy by halving (1: none): every axis of M nodes has M − 1 divisible by
    2^(L−1) with at least 3 nodes on the coarsest level, and every rank owns at least 2^L nodes per axis (so
    that it keeps nodes of its own on the coarsest level)."""
    if grid is None:
        return 1
    sizes = grid.getSizes()
    owned = [int(np.min(r)) for r in grid.getOwnershipRanges()]
    levels = 1
    while levels < MG_MAX_LEVELS:
        factor = 2 ** levels
        if not all((m - 1) % factor == 0 and (m - 1) // factor >= 2 for m in sizes):
            break
        if min(owned) < 2 * factor:
            break
        levels += 1
    return levels


PREFIX = "aromm_krylov_"
#: What to do about fixed values of a coupled system (:data:`~aromm.core.system.PENALTY_INSTEAD`'s remedy, with φ's).
COUPLED_PENALTY = ("are not supported (natural boundary conditions only); replace a fixed T by convection with a "
                   "large h and a fixed phi by vapour exchange with a large beta on the same face (penalty), or "
                   "reduce the scene with --engine scipy, which lifts them")


def _key(values: Mapping[str, float]) -> tuple[tuple[str, float], ...]:
    return tuple(sorted((str(k), float(v)) for k, v in values.items()))


def _identity(block: FloatArray) -> tuple[int, int, int]:
    """What tells one basis from another while both are alive: the object, its data's address, its width."""
    return (id(block), int(block.ctypes.data), int(block.shape[1]))


class PetscKrylovEngine:
    """:class:`~aromm.reduction.engine_protocol.ReductionEngine` on a :class:`DistributedSystem` (collective: every rank
    makes the same calls); ``solver`` one of :data:`SOLVERS` (module docstring); fixed temperatures are refused
    (natural boundary conditions only, as in the petsc engine's other reductions)."""

    def __init__(self, system: DistributedSystem, solver: str = "gamg") -> None:
        template = system.template
        require_free_transient(template, "the krylov reduction on the petsc engine",
                               PENALTY_INSTEAD if system.fields == 1 else COUPLED_PENALTY)
        if template.feedthrough:
            raise InputError("the krylov reduction on the petsc engine takes a system with no lifted fixed values "
                             "(no feedthrough): give it the scene, or the system before its lifting")
        self.system, self.comm, self.rows = system, system.comm, system.rows
        if solver not in SOLVERS:
            raise InputError(f"krylov reduction on the petsc engine: unknown solver {solver!r}; allowed: "
                             f"{', '.join(SOLVERS)}")
        self.levels = grid_levels(system.grid)
        if solver == "mg" and self.levels < MG_MIN_LEVELS:
            raise InputError(f"solver 'mg' needs a voxel grid that halves {MG_MIN_LEVELS - 1} times on every axis and "
                             f"every rank (got {self.levels} levels): use gamg")
        self.solver = solver if solver != "auto" else "mg" if self.levels >= MG_MIN_LEVELS else "gamg"
        self._stats = SolveStats(method=f"petsc-{self.solver}")
        # the initial inputs C_t T0: a coupled system's always (its initial φ), a thermal one's when T0 ≠ 0
        self.initial = float(template.parameters.get("initial.T", 0.0)) != 0.0 or bool(template.initial.terms)
        self._terms = self._input_vectors()
        self._ksp: tuple[tuple[Any, ...], Any, FloatArray | None] | None = None  # (key, KSP, s of a scaled one)
        self._capacities: dict[tuple[tuple[str, float], ...], Any] = {}
        self._columns = ColumnBuffer(self.rows.local)
        self._projections = GrowingProjection([t.operator for t in self._matrix_terms()], self._apply, self.dot)
        self._gram: tuple[tuple[int, int, int], FloatArray] | None = None  # (basis id, address, width), WᵀW

    # ----------------------------------------------------------------- inputs and outputs
    @property
    def size(self) -> int:
        return self.system.n

    @property
    def stats(self) -> SolveStats:
        return self._stats

    def _block(self, columns: int) -> FloatArray:
        return np.zeros((self.rows.local, columns), order="F")

    def _input_vectors(self) -> FloatArray:
        """``[F_1, …, C_1 1, …, C_1 v_1, …]``: the load terms, then (:attr:`initial`) every capacity term times the
        uniform field and times each initial field v_i of the system (field-major, as the scipy engine and
        :func:`~aromm.engines.petsc.projection.project` lay them)."""
        cols = [convert.array(t.operator) for t in self.system.load]
        if self.initial:
            fields = [np.ones(self.rows.local)] + [convert.array(t.operator) for t in self.system.initial]
            cols += [convert.apply(t.operator, f, self.rows, self.comm) for f in fields for t in self.system.capacity]
        return np.asfortranarray(np.column_stack(cols)) if cols else self._block(0)

    def input_terms(self) -> FloatArray:
        return self._terms

    def input_coefficients(self, values: Mapping[str, float]) -> FloatArray:
        return input_coefficients(self.system.template, self.initial, int(self._terms.shape[1]), values)

    def input_weights(self, values: Mapping[str, float]) -> FloatArray:
        return input_weights(self.system.template, self.initial, values)

    def inputs(self, values: Mapping[str, float]) -> FloatArray:
        return np.asfortranarray(self._terms @ self.input_coefficients(values))

    def constant(self) -> FloatArray:
        return np.ones((self.rows.local, 1), order="F")

    def output_block(self) -> FloatArray:
        names = tuple(self.system.template.observation)
        cols = [convert.array(self.system.observation[k]) for k in names]
        return np.asfortranarray(np.column_stack(cols)) if cols else self._block(0)

    def width(self, block: FloatArray) -> int:
        return int(block.shape[1])

    # ----------------------------------------------------------------- operators and solves
    def _capacity_matrix(self, values: Mapping[str, float]) -> Any:
        key = _key(values)
        mat = self._capacities.pop(key, None)
        if mat is None:
            if len(self._capacities) >= KEPT_MATRICES:
                self._capacities.pop(next(iter(self._capacities))).destroy()
            mat = self.system.combine(self.system.capacity, self.system.values(values))
        self._capacities[key] = mat  # the most recently used last
        return mat

    def _apply(self, mat: Any, block: FloatArray) -> FloatArray:
        out = self._block(block.shape[1])
        for cols, (product,) in convert.blocks((mat,), block):
            out[:, cols] = product
        return out

    def capacity(self, values: Mapping[str, float], block: FloatArray) -> FloatArray:
        return self._apply(self._capacity_matrix(values), block)

    def _setup(self, values: Mapping[str, float], shift: float, rtol: float) -> Any:
        key = (_key(values), float(shift), float(rtol))
        if self._ksp is not None and self._ksp[0] == key:
            return self._ksp[1]
        self._release()  # one hierarchy (or factorisation) alive at a time
        start = time.process_time()
        v = self.system.values(values)
        mat = self.system.combine(self.system.conductance, v)
        mat.axpy(float(shift), self._capacity_matrix(values),
                 structure=runtime.petsc().Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        scale = (linear.scale_symmetrically(mat, f"krylov shifted operator, s = {shift:.3g} 1/s")
                 if self.system.fields > 1 else None)
        ksp = self._krylov(mat, rtol)
        self._ksp = (key, ksp, scale)
        self._stats.setups += 1
        self._stats.setup_seconds += time.process_time() - start
        return ksp

    def _krylov(self, mat: Any, rtol: float) -> Any:
        """The set-up KSP of :meth:`_setup` (CG + GAMG / MUMPS by :mod:`~aromm.engines.petsc.linear`, or PCMG)."""
        if self.solver != "mg":
            ksp = linear.krylov(mat, self.solver, rtol, PREFIX)
            ksp.setUp()
            return ksp
        options = runtime.petsc().Options(PREFIX)
        given = {**MG_OPTIONS, "pc_mg_levels": str(self.levels)}
        added = [k for k in given if not options.hasName(k)]
        for k in added:
            options.setValue(k, given[k])
        try:
            ksp = linear.krylov(mat, "gamg", rtol, PREFIX, self.system.grid)  # CG; the options make the PC PCMG
            ksp.setUp()
        finally:
            for k in added:  # the options database is global: leave it as it was
                options.delValue(k)
        return ksp

    def _scale(self, values: Mapping[str, float], shift: float, rtol: float) -> FloatArray:
        """``s = diag(A)^-1/2`` of the set-up operator A = K(μ) + s C(μ) of a coupled system (this rank's rows), whose
        KSP holds ``Â = D^-1/2 A D^-1/2`` (:func:`aromm.engines.petsc.linear.scale_symmetrically`); ones for one
        field (its KSP holds A)."""
        self._setup(values, shift, rtol)
        assert self._ksp is not None
        scale = self._ksp[2]
        return np.ones(self.rows.local) if scale is None else scale

    def shifted_solve(self, values: Mapping[str, float], shift: float, rhs: FloatArray, rtol: float,
                      guess: FloatArray | None = None) -> FloatArray:
        """``(K(μ) + s C(μ)) X = rhs`` column by column; a coupled system's as ``Â Y = S rhs``, ``X = S Y``
        (S = diag(s), :meth:`_scale`): its CG stops on the scaled residual ``‖S (b − A x)‖ ≤ rtol ‖S b‖``, the test of
        the full model's coupled solves (:func:`aromm.engines.petsc.linear.krylov`)."""
        scale = self._scale(values, shift, rtol)
        ksp = self._setup(values, shift, rtol)
        ksp.setInitialGuessNonzero(guess is not None and self.solver != "mumps")
        start = time.process_time()
        mat = ksp.getOperators()[0]
        b, x = mat.createVecLeft(), mat.createVecRight()
        out = self._block(rhs.shape[1])
        for j in range(rhs.shape[1]):
            b.getArray()[:] = rhs[:, j] * scale
            if guess is None:
                x.set(0.0)
            else:
                x.getArray()[:] = guess[:, j] / scale
            its = linear.solve(ksp, b, x, f"krylov shifted solve, s = {shift:.3g} 1/s", rtol)
            out[:, j] = x.getArray(readonly=True) * scale
            if self.solver != "mumps":
                self._stats.iterations.append(its)
        b.destroy()
        x.destroy()
        self._stats.solves += int(rhs.shape[1])
        self._stats.solve_seconds += time.process_time() - start
        return out

    def shifted_residual(self, values: Mapping[str, float], shift: float, solution: FloatArray, rhs: FloatArray,
                         rtol: float) -> FloatArray:
        """``rhs − (K(μ) + s C(μ)) solution`` with the assembled operator of that shifted solve (a coupled system's
        as ``rhs − S⁻¹ Â (S⁻¹ X)``, :meth:`_scale`)."""
        scale = self._scale(values, shift, rtol)
        product = self._apply(self._setup(values, shift, rtol).getOperators()[0], solution / scale[:, None])
        return np.asarray(rhs, dtype=float) - product / scale[:, None]

    def residual_rounding(self, values: Mapping[str, float], shift: float, solution: FloatArray,
                          rtol: float) -> FloatArray:
        """ρ per column with ``ρ² = (k + 1) ‖A‖_∞ ‖x‖²`` ≥ ``(k + 1) |x|ᵀ|A||x|`` (A symmetric:
        ``‖|A|‖₂ ≤ ‖A‖_∞``; k the most terms in a row): the spread of :meth:`shifted_residual`'s rounding
        (:func:`aromm.reduction.certificate.riesz`), without a product by ``|A|`` across the ranks.

        A coupled system's operator is held scaled, ``Â = S A S`` (:meth:`_scale`), and its residual formed as
        ``rhs − S⁻¹ Â (S⁻¹ x)``: two more roundings per entry, so k + 3 in place of k + 1, and
        ``|x|ᵀ|A||x| = |y|ᵀ|Â||y| ≤ ‖Â‖_∞ ‖y‖²`` with ``y = S⁻¹ x``.  Unscaled, ``‖A‖_∞ ‖x‖²`` would weigh the heat
        unknowns with the λ-weighted moisture rows' norm (λ ≈ 8e7 J/kg): ``Â`` has a unit diagonal."""
        scale = self._scale(values, shift, rtol)
        mat = self._setup(values, shift, rtol).getOperators()[0]
        indptr = mat.getValuesCSR()[0]
        extra = 1 if self._ksp is None or self._ksp[2] is None else 3
        terms = runtime.allmax(float(np.diff(indptr).max(initial=0)), self.comm) + extra
        norm = float(mat.norm(runtime.petsc().NormType.INFINITY))
        y = solution / scale[:, None]
        return np.sqrt(terms * norm * runtime.allsum(np.einsum("ij,ij->j", y, y), self.comm))

    # ----------------------------------------------------------------- bases and projections
    def dot(self, left: FloatArray, right: FloatArray) -> FloatArray:
        return runtime.allsum(left.T @ right, self.comm)

    def _energies(self, c: Any, x: FloatArray) -> FloatArray:
        return np.sqrt(np.maximum(convert.diagonal(c, x, self.comm), 0.0))

    def _remove(self, basis: FloatArray | None, x: FloatArray, c: Any) -> None:
        """x ← x − V Vᵀ C x (one classical Gram–Schmidt pass, in place)."""
        if basis is not None and basis.shape[1]:
            x -= basis @ self.dot(basis, self._apply(c, x))

    def orthonormalise(self, basis: FloatArray | None, block: FloatArray, values: Mapping[str, float],
                       drop: float) -> tuple[FloatArray, int]:
        c = self._capacity_matrix(values)
        x = np.array(block, dtype=float, order="F")
        norms = self._energies(c, x)
        keep = norms > 0
        x = np.asfortranarray(x[:, keep] / norms[keep])
        for _ in range(2):
            self._remove(basis, x, c)
        x = np.asfortranarray(x[:, self._energies(c, x) > drop])
        if x.shape[1] == 0:
            return (basis if basis is not None else self._block(0)), 0
        for _ in range(2):  # twice, as the scipy engine (aromm.reduction.scipy_engine.ScipyEngine.orthonormalise)
            x = np.asfortranarray(x @ gram_orthonormal(self.dot(x, self._apply(c, x)), drop))
            self._remove(basis, x, c)
        x /= self._energies(c, x)
        return self._columns.append(basis, x), int(x.shape[1])

    def join(self, blocks: Sequence[FloatArray]) -> FloatArray:
        return np.asfortranarray(np.hstack(blocks))

    def combine(self, basis: FloatArray, coefficients: FloatArray, consume: bool = False) -> FloatArray:
        """A new block by row chunks (``consume`` is not used: a rank's rows are a fraction of the basis)."""
        return convert.combine_rows(basis, coefficients)

    def _matrix_terms(self) -> tuple[DistributedTerm, ...]:
        return (*self.system.conductance, *self.system.capacity)

    def term_products(self, basis: FloatArray) -> FloatArray:
        """``[K_1 V, …, C_1 V, …]`` (this rank's rows, term-major): the certificate's M
        (:mod:`aromm.reduction.certificate`)."""
        return self.join([self._apply(t.operator, basis) for t in self._matrix_terms()])

    def project(self, basis: FloatArray) -> ReducedModel:
        """The Galerkin model on V (:func:`aromm.engines.petsc.projection.project`); ``VᵀA_tV`` grown with the new
        columns when V extends the last projected basis in the engine's buffer
        (:class:`~aromm.reduction.column_buffer.GrowingProjection`): the reductor projects before every shift."""
        return project(self.system, basis, self._projections.memo(self._columns, basis))

    def reduced_operator(self, basis: FloatArray, values: Mapping[str, float], shift: float) -> FloatArray:
        return pencil(self._projections.memo(self._columns, basis), self.system.conductance, self.system.capacity,
                      self.system.values(values), shift)

    @property
    def uses_guess(self) -> bool:
        return self.solver != "mumps"

    def _residual_gram(self, basis: FloatArray) -> FloatArray:
        """``WᵀW`` for ``W = [U, P_1, …, P_T]``, ``P_t = A_t V`` (module docstring), summed over the ranks."""
        if self._gram is None or self._gram[0] != _identity(basis):
            self._gram = None
            pieces = [self._terms, *(self._apply(t.operator, basis) for t in self._matrix_terms())]
            gram = np.block([[a.T @ b for b in pieces] for a in pieces])
            del pieces
            self._gram = (_identity(basis), runtime.allsum(gram, self.comm))
        return self._gram[1]

    def residual_norms(self, basis: FloatArray, values: Mapping[str, float], shifts: FloatArray,
                       solutions: FloatArray) -> FloatArray:
        gram = self._residual_gram(basis)
        v = self.system.values(values)
        k = np.array([float(t.coefficient(v)) for t in self.system.conductance])
        c = np.array([float(t.coefficient(v)) for t in self.system.capacity])
        return residual_norms(gram, self.input_coefficients(values), k=k, c=c, shifts=shifts, solutions=solutions)

    def to_numpy(self, block: FloatArray) -> FloatArray:
        """This rank's rows (the engine never gathers a basis)."""
        return block

    def _release(self) -> None:
        """Free the set-up solver and its operator."""
        if self._ksp is not None:
            self._ksp[1].getOperators()[0].destroy()
            self._ksp[1].destroy()
            self._ksp = None

    def close(self) -> None:
        """Free the PETSc objects the engine made (solvers, capacity matrices)."""
        self._release()
        for mat in self._capacities.values():
            mat.destroy()
        self._capacities.clear()
