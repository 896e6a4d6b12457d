"""The scipy engine of the offline reduction (:class:`~aromm.reduction.engine_protocol.ReductionEngine` in one process).

Blocks are NumPy arrays (n × m).  Shifted systems ``(K(μ) + s C(μ)) X = B`` are solved

* below :data:`DIRECT_BELOW` unknowns (or off a voxel grid) by a sparse Cholesky factorisation (CHOLMOD, else
  SuperLU; :func:`aromm.linalg.direct.factorize`), the whole block at once;
* above it, on a voxel grid, by conjugate gradients preconditioned by the geometric multigrid V-cycle of
  :mod:`aromm.linalg.multigrid` (Galerkin coarse grids, Chebyshev smoothing) to the true relative residual
  ``rtol``, iteration counts recorded.  The coarse grids of every affine term of K and C are built once
  (:mod:`aromm.linalg.multigrid.affine`: a set-up is then a weighted sum of stored levels).  The columns of a
  block are solved one after the other: CGs in lockstep on the block cost 1.4–1.6× more at 64³ (3 right-hand
  sides, 9–15 iterations; docs/one_machine.md), because scipy's sparse × (n, 3) product takes 1.5× the
  time of three sparse × vector products on this machine.

Orthonormalisation is block classical Gram–Schmidt in the capacity product, twice ("twice is enough"), then
a Cholesky-free orthonormalisation of the new columns by the eigen-decomposition of their Gram matrix, and
one more Gram–Schmidt pass against the whole basis.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.system import FloatArray, ThermalSystem, dense, is_matrix_free, sparse
from aromm.fem.voxel_grid import node_points
from aromm.fem.voxel_terms import as_voxel_terms, is_voxel_family, shifted_operator, weighted_product
from aromm.linalg.direct import check_residual, factorize, resolve_method
from aromm.linalg.multigrid.affine_voxel import AffineLevels
from aromm.linalg.multigrid.pcg import MultigridSolver
from aromm.linalg.orderings import nested_dissection
from aromm.reduction.column_buffer import ColumnBuffer, GrowingProjection
from aromm.reduction.engine_protocol import SolveStats
from aromm.reduction.residual_gram import ResidualGram
from aromm.reduction.rom import ReducedModel

#: Below this many unknowns a sparse Cholesky factorisation of each shifted operator beats multigrid-PCG.
#: benchmarks/krylov_solvers.py on the wood VERs of aromm.studies.chavez2020.small_wood (rtol 1e-10, one BLAS thread,
#: load ≈ 4.3 on 2 cores), CPU s of a set-up / of one right-hand side, CHOLMOD (nested dissection reused) vs
#: multigrid (9–10 CG iterations): 16³ (4,913 unknowns) 0.052 / 0.0017 vs 0.020 / 0.0088; 24³ (15,625) 0.136 /
#: 0.0070 vs 0.049 / 0.0246; 32³ (35,937) 0.541 / 0.0227 vs 0.130 / 0.0759; 40³ (68,921) 1.850 / 0.0536 vs 0.317 /
#: 0.1317: break-even at 4.4, 5.0, 7.7 and 19.6 right-hand sides per set-up; the Krylov reduction solves 6 per
#: set-up (the load and the two outputs, two steps each).  Re-measured 2026-12-02 (commit 77fcd32, load 1.3–1.5, a
#: 256³ build on the other core): 16³ 0.028 / 0.0010 vs 0.010 / 0.0048, 24³ 0.157 / 0.0084 vs 0.033 / 0.0241, 32³
#: 0.570 / 0.0237 vs 0.079 / 0.0511, 40³ 1.511 / 0.0482 vs 0.141 / 0.0853 (9–11 CG iterations): break-even at 4.7,
#: 7.9, 17.9 and 37.0.  The reduction now solves 4 per set-up on the wood VERs (the inputs excited over the box, two
#: steps), so multigrid would win from 16³ on, by < 2 CPU s per reduction at 24³ (30 set-ups); the threshold stays:
#: below it a direct solve costs at most that and needs no rounding-floor acceptance.
DIRECT_BELOW = 20_000
#: A block of at least this many right-hand sides at one shift (the certificate's Gram matrices: inputs, outputs and
#: every term times the basis, 200–600 columns) is solved by a sparse Cholesky factorisation with the voxel grid's
#: nested dissection up to :data:`WIDE_DIRECT_BELOW` unknowns, where the engine otherwise iterates.
#: ``python benchmarks/wide_solve.py --sizes 32 46 --columns 200`` (one BLAS thread, load 0.9, 2026-12-05): CHOLMOD
#: set-up / a column 0.55 / 0.019 CPU s at 32³ (35,937 unknowns), 3.4 / 0.070 at 46³ (103,823), against the
#: multigrid's 0.043 and 0.135 a column; since blocks go through CHOLMOD four columns at a time
#: (:data:`aromm.linalg.factorizations.SPARSE_RHS`, same command, load 0.4–0.7, records/wide_solve_32_46_spsolve.txt)
#: 0.0099 and 0.038 against the multigrid's 0.038 and 0.128.
WIDE_BLOCK = 48
#: Unknowns up to which a wide block is factorised (≈ 58³ nodes; the factor's fill grows as n^(4/3): the process's
#: peak 1.35 GB at 46³ in benchmarks/wide_solve.py).
WIDE_DIRECT_BELOW = 200_000
#: Columns of one sparse × block product (scipy's CSR × (n, m) beats m vector products up to a few tens of columns:
#: 2.2× at 32 columns on the 46³ VER, 0.44× at 128).
PRODUCT_COLUMNS = 32
#: Eigenvalues of a new block's Gram matrix below this fraction of the largest are dependent directions.
GRAM_DROP = 1e-14
log = logging.getLogger(__name__)

SOLVERS = ("auto", "cholmod", "splu", "mg")
#: Coarsest multigrid level of the shifted solves (nodes, solved by CHOLMOD in every V-cycle).  At 46³ with the
#: solver's default (20,000: a 24³ coarsest grid) the coarse solves took 104 of 393 s of the solves (wall seconds
#: under cProfile, load ≈ 16); here one more level, down to ≤ 4,000 nodes (12³), instead.
COARSEST = 4_000


def input_coefficients(system: ThermalSystem, initial: bool, width: int, values: Mapping[str, float]) -> FloatArray:
    """A(μ) (``width`` × q) of :meth:`~aromm.reduction.engine_protocol.ReductionEngine.input_coefficients` for input
    terms laid out as the engines lay them: the load terms, then (``initial``) every capacity term times the uniform
    field and times each initial field of ``system``."""
    loads = len(system.load.terms)
    caps = system.capacity.terms
    fields = 1 + len(system.initial.terms) if initial else 0
    a = np.zeros((width, loads + fields))
    a[:loads, :loads] = np.eye(loads)
    v = system.values(values)
    c = np.array([float(t.coefficient(v)) for t in caps])
    for i in range(fields):
        a[loads + i * len(caps): loads + (i + 1) * len(caps), loads + i] = c
    return a


def input_weights(system: ThermalSystem, initial: bool, values: Mapping[str, float]) -> FloatArray:
    """The q inputs' scalar factors at μ of :meth:`~aromm.reduction.engine_protocol.ReductionEngine.input_weights`:
    each load term's coefficient, then (``initial``) the initial temperature and each initial field's coefficient."""
    v = system.values(values)
    weights = [float(t.coefficient(v)) for t in system.load.terms]
    if initial:
        weights += [float(v["initial.T"])] + [float(t.coefficient(v)) for t in system.initial.terms]  # type: ignore[arg-type]
    return np.array(weights)


class ScipyEngine:
    """:class:`~aromm.reduction.engine_protocol.ReductionEngine` for one process; ``system`` has no fixed temperatures
    left (lift them first), ``solver`` one of :data:`SOLVERS` (``auto``: by :data:`DIRECT_BELOW`)."""

    def __init__(self, system: ThermalSystem, solver: str = "auto", initial: bool = True) -> None:
        if solver not in SOLVERS:
            raise InputError(f"krylov reduction: unknown linear solver {solver!r}; allowed: {', '.join(SOLVERS)}")
        self.system = system
        operators = [t.operator for t in (*system.conductance.terms, *system.capacity.terms)]
        self.voxel = is_voxel_family(operators)  # matrix-free voxel terms: no matrix is ever assembled
        self.points = None if self.voxel else system.unknown_points()
        self.chosen = solver == "auto"  # the engine picks the solver (by size, and by the width of a block)
        if solver == "auto":
            geometry = system.geometry
            nodes = self.points is not None and geometry is not None and geometry.cell_type == "hexahedron" and \
                len(system.fields) == 1
            on_grid = nodes or self.voxel  # Q1 nodes on a voxel grid (finite volumes' points only order a factor)
            solver = "mg" if system.n >= DIRECT_BELOW and on_grid else resolve_method("auto")
        self.method = resolve_method(solver) if solver != "mg" else "mg"
        self._stats = SolveStats(method=self.method)
        self._solver: tuple[tuple[object, ...], object] | None = None
        self._ordering: npt.NDArray[np.int64] | None = None  # one nested dissection for every shifted operator
        self._assembled: tuple[tuple[object, ...], sp.csr_array] | None = None  # K + s C at the last point asked
        self._extended: sp.csr_array | None = None  # the same in extended precision (the certificate's residuals)
        self._gram: ResidualGram | None = None
        self._affine: object | None = None  # the multigrid levels of every term of K and C (built at the first solve)
        self._voxel_levels: AffineLevels | None = None  # the same for matrix-free voxel terms
        self.initial = initial
        self._terms = self._input_vectors()
        self._columns = ColumnBuffer(system.n)
        self._projections = GrowingProjection(operators, _product, lambda x, y: x.T @ y)

    # ----------------------------------------------------------------- inputs and outputs
    @property
    def size(self) -> int:
        return self.system.n

    @property
    def stats(self) -> SolveStats:
        return self._stats

    def _input_vectors(self) -> FloatArray:
        cols = [np.asarray(t.operator, dtype=float) for t in self.system.load.terms]
        if self.initial:
            fields = [np.ones(self.size)] + [np.asarray(t.operator, dtype=float) for t in self.system.initial.terms]
            cols += [np.asarray(c.operator @ f) for f in fields for c in self.system.capacity.terms]
        return np.column_stack(cols) if cols else np.zeros((self.size, 0))

    def input_terms(self) -> FloatArray:
        return self._terms

    def input_coefficients(self, values: Mapping[str, float]) -> FloatArray:
        return input_coefficients(self.system, self.initial, int(self._terms.shape[1]), values)

    def input_weights(self, values: Mapping[str, float]) -> FloatArray:
        return input_weights(self.system, self.initial, values)

    def inputs(self, values: Mapping[str, float]) -> FloatArray:
        return self._terms @ self.input_coefficients(values)

    def constant(self) -> FloatArray:
        return np.ones((self.size, 1))

    def output_block(self) -> FloatArray:
        _, e = self.system.observation_matrix()
        return dense(e).T

    def width(self, block: FloatArray) -> int:
        return int(block.shape[1])

    # ----------------------------------------------------------------- operators and solves
    def _operator(self, values: Mapping[str, float], shift: float) -> sp.csr_array:
        v = self.system.values(values)
        return sp.csr_array(self.system.conductance.evaluate(v) + shift * self.system.capacity.evaluate(v))

    def capacity(self, values: Mapping[str, float], block: FloatArray) -> FloatArray:
        """``C(μ) X`` term by term, ``Σ_t c_t(μ) (C_t X)``: no summed matrix is formed."""
        v = self.system.values(values)
        terms = self.system.capacity.terms
        if self.voxel:  # one matrix-free pass for all phases
            return weighted_product(as_voxel_terms([t.operator for t in terms]),
                                    [float(t.coefficient(v)) for t in terms], block)
        out = float(terms[0].coefficient(v)) * np.asarray(terms[0].operator @ block)
        for t in terms[1:]:
            out += float(t.coefficient(v)) * np.asarray(t.operator @ block)
        return out

    def shifted_solve(self, values: Mapping[str, float], shift: float, rhs: FloatArray, rtol: float,
                      guess: FloatArray | None = None) -> FloatArray:
        method = self.method_for(int(rhs.shape[1]))
        key = (tuple(sorted(values.items())), float(shift), float(rtol), method)
        if self._solver is None or self._solver[0] != key:
            self._solver = None  # release the previous hierarchy before building the next one
            start = time.process_time()
            self._solver = (key, self._setup(values, shift, rtol, method))
            self._stats.setups += 1
            self._stats.setup_seconds += time.process_time() - start
        start = time.process_time()
        out = self._solver[1](rhs, guess)  # type: ignore[operator]
        self._stats.solves += int(rhs.shape[1])
        self._stats.solve_seconds += time.process_time() - start
        return np.asarray(out)

    def shifted_residual(self, values: Mapping[str, float], shift: float, solution: FloatArray, rhs: FloatArray,
                         rtol: float) -> FloatArray:
        """``rhs − (K(μ) + s C(μ)) solution`` with the assembled operator, in extended precision (``np.longdouble``,
        one sparse product by blocks of columns), rounded to float64 at the end: the certificate's residuals
        (:func:`aromm.reduction.certificate.riesz`), whose rounding then enters the bound 2048 times less than in
        float64 on x86-64 (:meth:`residual_rounding`)."""
        a = self._assembled_operator(values, shift, np.longdouble)
        n, m = (int(d) for d in np.shape(rhs))
        r = np.empty((n, m))
        x = np.empty((n, min(PRODUCT_COLUMNS, m)), dtype=np.longdouble)  # one buffer, reused
        for lo in range(0, m, PRODUCT_COLUMNS):
            cols = slice(lo, lo + PRODUCT_COLUMNS)
            part = x[:, :min(PRODUCT_COLUMNS, m - lo)]
            part[...] = solution[:, cols]
            product = a @ part
            np.subtract(rhs[:, cols], product, out=product)  # in extended precision, then rounded once
            r[:, cols] = product
        return r

    def residual_rounding(self, values: Mapping[str, float], shift: float, solution: FloatArray,
                          rtol: float) -> FloatArray:
        """ρ per column, ``ρ² = (k + 1) (ε_x / ε) |x|ᵀ |K + s C| |x|`` (k the most terms in a row, ε_x the machine
        epsilon of :meth:`shifted_residual`'s extended precision, ε float64's): the spread of its rounding, in the
        float64 units of :func:`aromm.reduction.certificate.riesz`.  Its final rounding to float64 moves the Gram
        entries by ``ε |Rᵢ|ᵀ|Zⱼ| ≤ ε rtol √κ`` of their scale, far below the quadratic forms' floor: left out."""
        a = self._assembled_operator(values, shift)
        magnitude = sp.csr_array((np.abs(a.data), a.indices, a.indptr), shape=a.shape)
        terms = int(np.diff(a.indptr).max(initial=0)) + 1
        energy = np.zeros(solution.shape[1])
        for lo in range(0, solution.shape[1], PRODUCT_COLUMNS):
            x = np.abs(solution[:, lo:lo + PRODUCT_COLUMNS])  # one chunk at a time: no n × columns copy
            energy[lo:lo + PRODUCT_COLUMNS] = np.einsum("ij,ij->j", x, magnitude @ x)
        extended = float(np.finfo(np.longdouble).eps) / float(np.finfo(float).eps)
        return np.sqrt(terms * extended * np.maximum(energy, 0.0))

    def _assembled_operator(self, values: Mapping[str, float], shift: float,
                            dtype: type[np.floating] = np.float64) -> sp.csr_array:
        """``K(μ) + s C(μ)`` assembled (in ``dtype``), kept for the next call at the same point (a direct set-up's
        own)."""
        key = (tuple(sorted(values.items())), float(shift))
        if self._assembled is None or self._assembled[0] != key:
            self._assembled = (key, self._operator(values, shift))
            self._extended = None
        if dtype is np.float64:
            return self._assembled[1]
        if self._extended is None:
            self._extended = self._assembled[1].astype(dtype)
        return self._extended

    def method_for(self, columns: int) -> str:
        """The solver of a block of ``columns`` right-hand sides at one shift: the engine's, except that when it
        chose multigrid by size, a block of :data:`WIDE_BLOCK` columns or more (the certificate's) on at most
        :data:`WIDE_DIRECT_BELOW` unknowns is factorised."""
        if self.chosen and self.method == "mg" and columns >= WIDE_BLOCK and self.size < WIDE_DIRECT_BELOW:
            return resolve_method("auto")
        return self.method

    def _nested_dissection(self, a: sp.csr_array) -> npt.NDArray[np.int64] | None:
        """One geometric nested-dissection ordering for every shifted operator (the nodes' points, of the voxel
        grid for matrix-free terms), None off a grid (CHOLMOD then orders by AMD)."""
        if self._ordering is None:
            points = self.points
            if points is None and self.voxel:
                term = as_voxel_terms([t.operator for t in self.system.conductance.terms])[0]
                points = node_points(term.grid.shape, term.grid.voxel_size)[term.free]
            self._ordering = None if points is None else nested_dissection(a, points)
        return self._ordering

    def _setup(self, values: Mapping[str, float], shift: float, rtol: float, method: str) -> object:
        self._assembled, self._extended = None, None  # released before the next set-up; a direct one keeps its own
        if method != "mg":
            a = self._assembled_operator(values, shift)
            fac = factorize(a, method, rtol=rtol, ordering=self._nested_dissection(a))

            def direct(b: FloatArray, guess: FloatArray | None) -> FloatArray:
                x = fac.solve(b, check=False)
                for j in range(b.shape[1]):
                    check_residual(a, x[:, j], b[:, j], rtol, method)
                return x

            return direct
        from aromm.linalg.multigrid.affine import AffineGrid

        terms = (*self.system.conductance.terms, *self.system.capacity.terms)
        v = self.system.values(values)
        weights = [float(t.coefficient(v)) for t in self.system.conductance.terms] + [
            shift * float(t.coefficient(v)) for t in self.system.capacity.terms]
        if self.voxel:
            voxel_terms = as_voxel_terms([t.operator for t in terms])
            if self._voxel_levels is None:
                self._voxel_levels = AffineLevels.build([shifted_operator([t], [1.0]) for t in voxel_terms], COARSEST)
            coarse = self._voxel_levels.levels(weights, voxel_terms[0].fixed)
            mg = MultigridSolver(shifted_operator(voxel_terms, weights), rtol=rtol, coarsest=COARSEST, coarse=coarse)
            return self._grid_columns(mg, voxel_terms[0].free, voxel_terms[0].grid.n, shift, rtol)
        if self._affine is None:
            self._affine = AffineGrid.build([sparse(t.operator) for t in terms], self.points, coarsest=COARSEST)
        grid = self._affine.operator(weights)  # type: ignore[attr-defined]
        mg = MultigridSolver(grid, rtol=rtol, coarsest=COARSEST)
        return self._grid_columns(mg, grid.index, grid.n, shift, rtol)

    def _grid_columns(self, mg: MultigridSolver, index: npt.NDArray[np.intp], nodes: int, shift: float,
                      rtol: float) -> object:
        """``b ↦ A⁻¹ b`` by ``mg`` column by column (scipy's sparse × (n, 3) block is slower), the unknowns embedded
        at ``index`` of the grid's ``nodes`` (zeros elsewhere: absent or fixed nodes), from the columns of ``guess``
        if given; iteration counts recorded."""

        # all nodes unknown, in grid order (ascending and complete: the identity): no scatter, no gather
        whole = index.size == nodes and bool(np.all(index[1:] > index[:-1]))

        def embed(column: FloatArray) -> FloatArray:
            if whole:
                return np.array(column)
            full = np.zeros(nodes)
            full[index] = column
            return full

        def iterative(b: FloatArray, guess: FloatArray | None) -> FloatArray:
            x = np.empty_like(b)
            for j in range(b.shape[1]):
                solution = mg.solve(embed(b[:, j]), None if guess is None else embed(guess[:, j]))
                x[:, j] = solution if whole else solution[index]
            self._stats.iterations.extend(mg.iterations[-b.shape[1]:])
            if mg.at_floor:
                log.info("multigrid: %d of %d solves at s = %.3g met rtol %.0e only within the float64 rounding floor",
                         mg.at_floor, len(mg.iterations), shift, rtol)
            return x

        return iterative

    # ----------------------------------------------------------------- bases and projections
    def orthonormalise(self, basis: FloatArray | None, block: FloatArray, values: Mapping[str, float],
                       drop: float) -> tuple[FloatArray, int]:
        """Five capacity products per block: C X is carried through every linear step (C(XT) = (CX)T) and formed
        anew only after each Gram–Schmidt pass; the columns are appended in the engine's buffer.  The new block's
        own orthonormalisation (eigen-decomposition of its Gram matrix) and the pass against the basis are done
        twice: with capacities 5e7 apart (a coupled heat and moisture body) one of each left ΨᵀCΨ off I by 8e-5
        per block, and the reduced capacity singular after a few blocks."""

        def c(block: FloatArray) -> FloatArray:
            return self.capacity(values, block)

        def remove(x: FloatArray, cx: FloatArray) -> tuple[FloatArray, FloatArray]:
            if basis is not None and basis.shape[1]:
                x -= basis @ (basis.T @ cx)
            return x, c(x)  # formed anew: C(XT) carried through an ill-conditioned T drifts from C X

        x = np.array(block, dtype=float)
        cx = c(x)
        norms = np.sqrt(np.maximum(np.einsum("ij,ij->j", x, cx), 0.0))
        keep = norms > 0
        if not keep.all():
            x, cx, norms = x[:, keep], cx[:, keep], norms[keep]
        x /= norms  # in place: x is this call's copy, cx a fresh product
        cx /= norms
        for _ in range(2):
            x, cx = remove(x, cx)
        remaining = np.sqrt(np.maximum(np.einsum("ij,ij->j", x, cx), 0.0))
        x, cx = x[:, remaining > drop], cx[:, remaining > drop]
        if x.shape[1] == 0:
            return (basis if basis is not None else np.zeros((self.size, 0))), 0
        for _ in range(2):  # twice: a small eigenvalue amplifies the rounding that the pass against the basis undoes
            t = gram_orthonormal(x.T @ cx, drop)
            x, cx = remove(x @ t, cx @ t)
        x /= np.sqrt(np.einsum("ij,ij->j", x, cx))
        return self._columns.append(basis, x), int(x.shape[1])

    def dot(self, left: FloatArray, right: FloatArray) -> FloatArray:
        return np.asarray(left.T @ right)

    def join(self, blocks: Sequence[FloatArray]) -> FloatArray:
        return np.hstack(blocks)

    def combine(self, basis: FloatArray, coefficients: FloatArray, consume: bool = False) -> FloatArray:
        """With ``consume``, a basis of the engine's buffer is written over (no second n × r' array)."""
        return self._columns.combine_in_place(basis, coefficients) if consume else basis @ coefficients

    def project(self, basis: FloatArray) -> ReducedModel:
        """Galerkin projection; the square terms' ``VᵀAV`` grown from the last projection when ``basis`` extends
        its basis in the engine's buffer (only the new columns' products:
        :class:`~aromm.reduction.column_buffer.GrowingProjection`)."""
        return ReducedModel.from_system(self.system, basis, self._projections.memo(self._columns, basis))

    def reduced_operator(self, basis: FloatArray, values: Mapping[str, float], shift: float) -> FloatArray:
        return pencil(self._projections.memo(self._columns, basis), self.system.conductance.terms,
                      self.system.capacity.terms, self.system.values(values), shift)

    @property
    def uses_guess(self) -> bool:
        return self.method == "mg"

    def residual_norms(self, basis: FloatArray, values: Mapping[str, float], shifts: FloatArray,
                       solutions: FloatArray) -> FloatArray:
        """From one Gram matrix per basis (:mod:`aromm.reduction.residual_gram`), kept until the basis changes."""
        conduction, capacity = self.system.conductance.terms, self.system.capacity.terms
        key = (id(basis), basis.shape, float(basis[:, -1].sum()))
        if self._gram is None or self._gram.key != key:
            self._gram = None  # release the previous one first
            ops = [t.operator if is_matrix_free(t.operator) else sp.csr_array(t.operator)
                   for t in (*conduction, *capacity)]
            self._gram = ResidualGram.of(key, self._terms, ops, basis)
        v = self.system.values(values)
        k = np.array([float(t.coefficient(v)) for t in conduction])
        c = np.array([float(t.coefficient(v)) for t in capacity])
        return self._gram.norms(self.input_coefficients(values), k=k, c=c, shifts=shifts, x=solutions)

    def to_numpy(self, block: FloatArray) -> FloatArray:
        return block

    def term_products(self, basis: FloatArray) -> FloatArray:
        """``[K_1 Ψ, …, C_1 Ψ, …]`` (n × m r) over the conductance then the capacity terms (the certificate's M,
        :mod:`aromm.reduction.certificate`)."""
        terms = (*self.system.conductance.terms, *self.system.capacity.terms)
        return np.hstack([_product(t.operator, basis) for t in terms])


def gram_orthonormal(gram: FloatArray, drop: float) -> FloatArray:
    """T with ``Tᵀ G T = I`` for the Gram matrix G = XᵀCX of a block X, the directions of G below :data:`GRAM_DROP`
    of its largest eigenvalue or ``drop²`` left out.  When none is, ``T = G^{-1/2}`` (symmetric: X T is the
    orthonormal block nearest X, so a block already orthonormal stays as it is instead of turning by an arbitrary
    rotation of a near-multiple eigenvalue)."""
    w, u = np.linalg.eigh((gram + gram.T) / 2)
    ok = w > max(GRAM_DROP * float(w.max()), drop**2)  # unit columns in: a direction below drop is noise
    t = u[:, ok] / np.sqrt(w[ok])
    return np.asarray(t @ u.T) if ok.all() else t


def pencil(memo: Mapping[int, FloatArray], conduction: Sequence[Any], capacity: Sequence[Any],
           values: Mapping[str, Any], shift: float) -> FloatArray:
    """``Σ_t k_t(μ) VᵀK_tV + s Σ_t c_t(μ) VᵀC_tV`` from a projection memo (id of a term's operator → VᵀA_tV)."""
    parts = [float(t.coefficient(values)) * memo[id(t.operator)] for t in conduction]
    parts += [shift * float(t.coefficient(values)) * memo[id(t.operator)] for t in capacity]
    return np.asarray(np.sum(parts, axis=0), dtype=float)


def _product(a: Any, block: FloatArray) -> FloatArray:
    """``A X``; a matrix-free operator a few columns a pass (:func:`aromm.fem.voxel_terms.grouped_product`)."""
    return np.asarray((a if is_matrix_free(a) else sp.csr_array(a)) @ block)
