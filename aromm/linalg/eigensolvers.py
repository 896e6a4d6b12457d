"""Block eigensolver for the modal bases when a sparse factorisation no longer pays (or fits).

Solves ``K v = λ N v`` for the ``count`` smallest λ, with ``N`` symmetric positive semi-definite
(possibly singular: the boundary mass of the Steklov modes) and ``M = K − σN`` symmetric
positive-definite for the given shift σ ≤ 0.  The iteration works on the *inverted* pencil
``N x = μ M x``, ``μ = 1/(λ − σ)``, whose largest μ are wanted: its inner product ``xᵀMy`` is a
norm even when ``N`` is singular, so LOBPCG [Knyazev2001] applies to the Steklov modes without
the interior garbage that shift-invert Lanczos leaves with a singular ``N`` (aromm.reduction.modal_bases).  On the
same subspace the Ritz vectors of ``(K, N)`` and ``(N, M)`` coincide and the residuals are related
by ``N x − μ M x = −μ (K x − λ N x)``, so converging the one converges the other.

* Preconditioner ``T ≈ M⁻¹``: one block V-cycle of aromm.linalg.block_multigrid (smoothed aggregation,
  Chebyshev smoothing), applied to all active residuals at once.
* Memory is the basis plus a fixed working set: the modes are found in chunks of ``block``
  columns (plus ``guard`` columns that speed up convergence at the chunk's edge and seed the next
  chunk); each chunk is kept M-orthogonal to the converged modes and to ``constraints`` (the
  constants of the Steklov problem).  Working set: nine n × (block + guard) arrays.
* Soft locking: converged columns stop receiving search directions.  Orthonormalisation by SVQB
  [StathopoulosWu2002] (eigen-decomposition of the Gram matrix, near-dependent directions dropped).
* Convergence: relative residual ``||N x − μ M x|| / (||N x|| + μ ||M x||) ≤ tol`` for every wanted
  column; otherwise :class:`~aromm.core.errors.NumericalError` naming the solver.  A final Rayleigh–Ritz
  over all found modes makes them exactly (to rounding) M- and N-orthogonal.
* Progress: ``progress(EigenProgress)`` after every iteration (converged pairs, iterations).
"""

from __future__ import annotations

import logging
import math
import sys
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from threadpoolctl import threadpool_limits
from tqdm import tqdm

from aromm.core.choices import EIGENSOLVERS
from aromm.core.errors import InputError, NumericalError
from aromm.core.system import FloatArray
from aromm.linalg.block_multigrid import BlockMultigrid

log = logging.getLogger(__name__)

#: ``"auto"`` uses LOBPCG for eigenproblems with more unknowns than this, ARPACK + a sparse factorisation below.
#: A memory crossover, not a speed one (benchmarks/reduce_scaling.py, wood VERs, Ñ = 320, 2026-11-30): ARPACK +
#: CHOLMOD was faster at every size measured (CPU s 19 / 72 / 263 / 1051 at 24³ / 32³ / 46³ / 64³ against
#: LOBPCG's 47 / 125 / 597 / 1538), but its peak memory grows with the factor's fill (4.25 GB at 64³ = 2.7e5
#: unknowns, against LOBPCG's 3.51 GB; exponents 0.90 and 0.82 in N from 24³, the fill tending to N^4/3) and
#: heads for 13–22 GB at 96³ (extrapolated), where LOBPCG measured 11.4 GB and 6,349 CPU s (9.1e5 unknowns).
LOBPCG_ABOVE = 200_000
#: Relative residual at which a pair is converged (below aromm.reduction.modal_bases.RESIDUAL_TOL, which is checked
#: after).
TOL = 1e-7
#: Columns per chunk, and extra (guard) columns iterated with them.
BLOCK = 40
GUARD = 10
#: V-cycles per application of the preconditioner.
CYCLES = 1
#: Iterations allowed per chunk.
MAX_ITERATIONS = 400
#: Preconditioned inverse-iteration steps ``X ← T N X`` applied to the random start of a chunk.
WARMUP = 2
#: Gram eigenvalues below this fraction of the largest are dependent directions (SVQB drops them).
DEPENDENT = 1e-10
#: N is kept on its non-zero rows only when they are fewer than this fraction of all rows.
SPARSE_ROWS = 0.5
#: Rows per slab when combining large blocks (bounds the temporary memory of the updates).
ROW_SLAB = 65536


@dataclass(frozen=True)
class EigenProgress:
    """Reported after every iteration: ``converged`` of ``wanted`` pairs, ``iterations`` so far in all chunks,
    ``residual`` the largest relative residual among the wanted columns of the current chunk."""

    label: str
    converged: int
    wanted: int
    iterations: int
    residual: float


ProgressCallback = Callable[[EigenProgress], None]


def choose_eigensolver(name: str, n: int) -> str:
    """``"arpack"`` or ``"lobpcg"`` for an eigenproblem with ``n`` unknowns (``name`` ``"auto"`` picks by size).

    ``"arpack"`` means the direct path of aromm.reduction.modal_bases: dense ``eigh`` up to its DENSE_LIMIT unknowns,
    ARPACK
    shift-invert on a sparse factorisation above; ``"lobpcg"`` is used at any size when asked for.
    """
    if name not in EIGENSOLVERS:
        raise InputError(f"unknown eigensolver {name!r}; allowed: {', '.join(EIGENSOLVERS)}")
    if name == "auto":
        return "lobpcg" if n > LOBPCG_ABOVE else "arpack"
    return name


class PairsBar:
    """Progress of the eigen-solves: a tqdm bar of converged pairs (all families), a log line per 10 % of the pairs
    of a family (``logging``, for batch runs), and an optional listener of every report.

    ``iterations`` holds the LOBPCG iterations reported per family (0 for a direct solve).
    """

    def __init__(self, *, enabled: bool, listener: ProgressCallback | None = None) -> None:
        self.bar = tqdm(total=0, desc="eigenpairs", unit="pair", disable=not enabled, leave=False, file=sys.stderr)
        self.listener = listener
        self.state: dict[str, tuple[int, int]] = {}
        self.iterations: dict[str, int] = {}

    def __call__(self, report: EigenProgress) -> None:
        before = self.state.get(report.label, (-1, 0))[0]
        tenth = max(1, -(-report.wanted // 10))  # a log line per 10 % of the family's pairs, and at its end
        if math.isnan(report.residual):  # a one-call solve starting (report_done)
            log.info("%s: %d pairs wanted, solving", report.label, report.wanted)
        elif before < 0 or report.converged // tenth != before // tenth or report.converged == report.wanted != before:
            log.info("%s: %d of %d pairs converged (iteration %d, residual %.1e)", report.label, report.converged,
                     report.wanted, report.iterations, report.residual)
        self.state[report.label] = (report.converged, report.wanted)
        self.iterations[report.label] = report.iterations
        self.bar.total = sum(w for _, w in self.state.values())
        self.bar.n = sum(c for c, _ in self.state.values())
        self.bar.set_postfix_str(f"{report.label}: iteration {report.iterations}, residual {report.residual:.0e}",
                                 refresh=False)
        self.bar.refresh()
        if self.listener is not None:
            self.listener(report)

    def close(self) -> None:
        self.bar.close()


def report_done(progress: ProgressCallback | None, label: str, count: int, *, started: bool = False) -> None:
    """Report a family solved in one call (dense or ARPACK: no intermediate progress): when it starts
    (``started``: 0 pairs yet, so that the log and the bars know it is under way) and when it is done."""
    if progress is not None:
        progress(EigenProgress(label, 0 if started else count, count, 0, math.nan if started else 0.0))


@dataclass(frozen=True)
class EigenResult:
    """Eigenvalues λ (ascending), M-orthonormal vectors (n, count), iterations and preconditioner bytes."""

    eigenvalues: FloatArray
    vectors: FloatArray
    iterations: int
    preconditioner_bytes: int


def smallest_eigenpairs(
    k: sp.sparray | sp.spmatrix,
    n_mat: sp.sparray | sp.spmatrix,
    count: int,
    *,
    rng: np.random.Generator,
    shift: float = 0.0,
    constraints: FloatArray | None = None,
    tol: float = TOL,
    block: int = BLOCK,
    guard: int = GUARD,
    max_iterations: int = MAX_ITERATIONS,
    label: str = "eigenpairs",
    progress: ProgressCallback | None = None,
) -> EigenResult:
    """The ``count`` smallest eigenpairs of ``K v = λ N v`` outside span(``constraints``), by chunked LOBPCG.

    ``shift`` σ ≤ 0 must make ``K − σN`` positive-definite; returned vectors are ``(K − σN)``-orthonormal.
    Dense algebra runs on one BLAS thread (on the shared 2-core machine threaded OpenBLAS made the
    tall-skinny products 40× slower in CPU time, measured).
    """
    with threadpool_limits(limits=1, user_api="blas"):
        return _smallest(k, n_mat, count, rng=rng, shift=shift, constraints=constraints, tol=tol, block=block,
                         guard=guard, max_iterations=max_iterations, label=label, progress=progress)


def _smallest(k: sp.sparray | sp.spmatrix, n_mat: sp.sparray | sp.spmatrix, count: int, *,
              rng: np.random.Generator, shift: float, constraints: FloatArray | None, tol: float, block: int,
              guard: int, max_iterations: int, label: str, progress: ProgressCallback | None) -> EigenResult:
    a = sp.csr_array(n_mat)
    m = sp.csr_array(k - shift * a) if shift != 0.0 else sp.csr_array(k)
    n = m.shape[0]
    precondition = BlockMultigrid(m, rng=rng, cycles=CYCLES)
    support = np.flatnonzero(np.diff(a.indptr))
    rows = support if support.size < SPARSE_ROWS * n else None  # N = ζB lives on the boundary rows only
    fixed = 0 if constraints is None else constraints.shape[1]
    found = np.empty((n, fixed + count), order="F")
    if constraints is not None:
        r = _svqb_factor(constraints.T @ (m @ constraints))
        if r.shape[1] != fixed:
            raise NumericalError(f"LOBPCG ({label}): the constraint vectors are dependent")
        found[:, :fixed] = constraints @ r
    mu = np.empty(count)
    done, iterations = 0, 0
    start = rng.standard_normal((n, 0))
    while done < count:
        want = min(block, count - done)
        width = min(want + guard, n - fixed - done)
        x0 = np.column_stack([start, rng.standard_normal((n, max(0, width - start.shape[1])))])[:, :width]
        locked = found[:, : fixed + done]
        chunk = _Chunk(a, m, precondition=precondition, locked=locked, tol=tol, label=label, rows=rows)
        x0 = chunk.warm_start(x0)

        def report(conv: int, it: int, res: float, offset: int = done, before: int = iterations) -> None:
            if progress is not None:
                progress(EigenProgress(label, offset + conv, count, before + it, res))

        vals, x, used = chunk.run(x0, want, max_iterations, report)
        iterations += used
        found[:, fixed + done: fixed + done + want] = x[:, :want]
        mu[done: done + want] = vals[:want]
        start = x[:, want:]
        done += want
    vectors = found[:, fixed:]
    mu, vectors = _final_rayleigh_ritz(a, m, vectors)
    if np.any(mu <= 0):
        raise NumericalError(f"LOBPCG ({label}): a non-positive Ritz value of the inverted pencil")
    lam = shift + 1.0 / mu
    return EigenResult(lam, vectors, iterations, precondition.nbytes)


class _Chunk:
    """LOBPCG on ``N x = μ M x`` for the largest μ, M-orthogonal to the columns of ``locked``.

    Three buffers of 3b columns hold ``S = [X | W | P]``, ``MS`` and ``NS`` (b the chunk width); every
    update is done in place by slabs of rows, so the working set stays fixed.  When N vanishes outside
    ``rows`` (the boundary mass), ``NS`` keeps those rows only.
    """

    def __init__(self, a: sp.csr_array, m: sp.csr_array, *, precondition: BlockMultigrid, locked: FloatArray,
                 tol: float, label: str, rows: np.ndarray | None) -> None:
        self.a, self.m, self.t, self.locked, self.tol, self.label = a, m, precondition, locked, tol, label
        self.rows = rows
        self.a_rows = sp.csr_array(a[rows]) if rows is not None else a

    def restrict(self, v: FloatArray) -> FloatArray:
        """The rows of v where N may be non-zero."""
        return v if self.rows is None else v[self.rows]

    def project(self, w: FloatArray, passes: int = 1) -> FloatArray:
        """Remove the M-components along the locked columns (one matrix product per pass)."""
        if self.locked.shape[1] == 0:
            return w
        for _ in range(passes):
            w = w - self.locked @ (self.locked.T @ (self.m @ w))
        return w

    def warm_start(self, x: FloatArray) -> FloatArray:
        """A few steps of preconditioned subspace iteration ``X ← T N X`` from ``x``, M-orthonormalised after
        each (without it the columns collapse onto the dominant eigenvectors)."""
        for _ in range(max(WARMUP, 0)):
            x = self.t(self.a @ self.project(x))
            x = x @ _svqb_factor(x.T @ (self.m @ x))
        return self.project(x, passes=2)

    def run(self, x0: FloatArray, want: int, max_iterations: int,
            report: Callable[[int, int, float], None]) -> tuple[FloatArray, FloatArray, int]:
        n, b = x0.shape
        bufs = _Buffers(n, b, self.a_rows.shape[0])
        if bufs.load(0, x0, self.m @ x0, self.a_rows @ x0) < b:
            raise NumericalError(f"LOBPCG ({self.label}): the start block is rank-deficient")
        x, mx, ax = bufs.block(0, b)
        mu, c = _ritz(self.restrict(x).T @ ax, x.T @ mx, b)
        bufs.rotate(c, b)
        kp = 0
        for it in range(1, max_iterations + 1):
            x, mx, ax = bufs.block(0, b)
            r = mx * -mu
            if self.rows is None:
                r += ax
            else:
                r[self.rows] += ax
            res = np.linalg.norm(r, axis=0) / np.maximum(
                np.linalg.norm(ax, axis=0) + np.abs(mu) * np.linalg.norm(mx, axis=0), 1e-300)
            conv = res <= self.tol
            n_conv = int(np.count_nonzero(conv[:want]))
            report(n_conv, it - 1, float(res[:want].max()))
            if n_conv == want:
                return mu, x.copy(), it - 1
            act = np.flatnonzero(~conv)
            w = self.project(self.t(r[:, act]))
            del r
            w -= x @ (mx.T @ w)
            kw = bufs.load(b, w, self.m @ w, self.a_rows @ w)
            del w
            if kp:
                kp = bufs.orthonormalise(2 * b, kp)
            try:
                mu, c = _ritz(*_grams(bufs, (b, kw, kp), self.restrict), b)
            except np.linalg.LinAlgError:
                kp = 0  # restart without P
                try:
                    mu, c = _ritz(*_grams(bufs, (b, kw, kp), self.restrict), b)
                except np.linalg.LinAlgError:
                    raise NumericalError(f"LOBPCG ({self.label}): Rayleigh–Ritz Gram matrix is not definite "
                                         "(search directions dependent)") from None
            kp = bufs.update(c, b, kw, kp, act)
        raise NumericalError(
            f"LOBPCG ({self.label}): {n_conv} of {want} pairs of the chunk converged in {max_iterations} "
            f"iterations (largest relative residual {float(res[:want].max()):.1e} > {self.tol:.0e})")


class _Buffers:
    """``S = [X | W | P]``, ``MS`` (n rows) and ``NS`` (``n_rows`` rows) with 3b columns each; X at columns
    [0, b), W at [b, 2b), P at [2b, 3b)."""

    def __init__(self, n: int, b: int, n_rows: int) -> None:
        self.arrays = [np.empty((n, 3 * b)), np.empty((n, 3 * b)), np.empty((n_rows, 3 * b))]
        self.b = b

    def block(self, lo: int, k: int) -> tuple[FloatArray, FloatArray, FloatArray]:
        s, ms, ns = (arr[:, lo:lo + k] for arr in self.arrays)
        return s, ms, ns

    def load(self, lo: int, v: FloatArray, mv: FloatArray, nv: FloatArray) -> int:
        """Store M-orthonormalised columns of v at ``lo`` (SVQB); returns how many were kept."""
        for arr, src in zip(self.arrays, (v, mv, nv), strict=True):
            arr[:, lo:lo + v.shape[1]] = src
        return self.orthonormalise(lo, v.shape[1])

    def orthonormalise(self, lo: int, k: int) -> int:
        s, ms, _ = self.block(lo, k)
        r = _svqb_factor(s.T @ ms)
        self._transform([(lo, k)], r, lo)
        return int(r.shape[1])

    def rotate(self, c: FloatArray, b: int) -> None:
        self._transform([(0, b)], c, 0)

    def update(self, c: FloatArray, b: int, kw: int, kp: int, act: np.ndarray) -> int:
        """X ← X Cx + Q and P ← Q[:, act] with Q = [W P] C_wp (the LOBPCG update); returns the width of P."""
        cx, cwp = c[:b], c[b:]
        spans = [(b, kw)] + ([(2 * b, kp)] if kp else [])
        ka = act.size
        for arr in self.arrays:
            n = arr.shape[0]
            for lo in range(0, n, ROW_SLAB):
                rows = slice(lo, min(lo + ROW_SLAB, n))
                q = _product(arr[rows], spans, cwp)
                x = arr[rows, :b] @ cx
                x += q
                arr[rows, :b] = x
                arr[rows, 2 * b:2 * b + ka] = q[:, act]
        return ka

    def _transform(self, spans: list[tuple[int, int]], c: FloatArray, dest: int) -> None:
        for arr in self.arrays:
            n = arr.shape[0]
            for lo in range(0, n, ROW_SLAB):
                rows = slice(lo, min(lo + ROW_SLAB, n))
                arr[rows, dest:dest + c.shape[1]] = _product(arr[rows], spans, c)


def _product(slab: FloatArray, spans: list[tuple[int, int]], c: FloatArray) -> FloatArray:
    """``[slab[:, span] for span in spans] @ c`` without stacking the column spans."""
    out = None
    row = 0
    for lo, k in spans:
        part = slab[:, lo:lo + k] @ c[row:row + k]
        out = part if out is None else out + part
        row += k
    assert out is not None
    return out


def _grams(bufs: _Buffers, widths: tuple[int, int, int],
           restrict: Callable[[FloatArray], FloatArray]) -> tuple[FloatArray, FloatArray]:
    """``SᵀNS`` and ``SᵀMS`` of S = [X, W, (P)], every block computed (none assumed from the previous
    Rayleigh–Ritz or SVQB: rounding in the implicit updates of MS and NS would otherwise stall the
    residuals near 1e-6).  ``restrict`` picks the rows of NS."""
    b, kw, kp = widths
    spans = [(0, b), (b, kw)] + ([(2 * b, kp)] if kp else [])
    sizes = [k for _, k in spans]
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    gm = np.zeros((offsets[-1], offsets[-1]))
    ga = np.zeros_like(gm)
    s, ms, ns = bufs.arrays
    for i, (lo_i, k_i) in enumerate(spans):
        vi = s[:, lo_i:lo_i + k_i]
        vi_rows = restrict(vi)
        for j in range(i, len(spans)):
            lo_j, k_j = spans[j]
            si, sj = slice(offsets[i], offsets[i + 1]), slice(offsets[j], offsets[j + 1])
            gm[si, sj] = vi.T @ ms[:, lo_j:lo_j + k_j]
            gm[sj, si] = gm[si, sj].T
            ga[si, sj] = vi_rows.T @ ns[:, lo_j:lo_j + k_j]
            ga[sj, si] = ga[si, sj].T
    return (ga + ga.T) / 2, (gm + gm.T) / 2


def _ritz(ga: FloatArray, gm: FloatArray | None, b: int) -> tuple[FloatArray, FloatArray]:
    """The ``b`` largest eigenpairs of ``ga c = θ gm c`` (descending θ)."""
    k = ga.shape[0]
    theta, c = sla.eigh((ga + ga.T) / 2, gm, subset_by_index=(k - b, k - 1))
    return theta[::-1], c[:, ::-1]


def _svqb_factor(g: FloatArray) -> FloatArray:
    """R with ``Rᵀ G R = I`` for the Gram matrix G (SVQB): directions with a relative eigenvalue of the
    diagonally scaled G below DEPENDENT are dropped (R has fewer columns)."""
    g = (g + g.T) / 2
    d = 1.0 / np.sqrt(np.maximum(np.diag(g), 1e-300))
    w, u = np.linalg.eigh(g * d[:, None] * d[None, :])
    keep = w > DEPENDENT * max(float(w.max(initial=0.0)), 1e-300)
    return (d[:, None] * u[:, keep]) / np.sqrt(w[keep])


def _final_rayleigh_ritz(a: sp.csr_array, m: sp.csr_array, v: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Rayleigh–Ritz of ``(N, M)`` on all found columns, in place; μ descending."""
    k = v.shape[1]
    gm = np.empty((k, k))
    ga = np.empty((k, k))
    for lo in range(0, k, BLOCK):
        cols = slice(lo, min(lo + BLOCK, k))
        gm[:, cols] = v.T @ (m @ v[:, cols])
        ga[:, cols] = v.T @ (a @ v[:, cols])
    try:
        mu, c = _ritz(ga, (gm + gm.T) / 2, k)
    except np.linalg.LinAlgError:
        raise NumericalError("LOBPCG: the found modes are dependent (final Rayleigh–Ritz)") from None
    for lo in range(0, v.shape[0], ROW_SLAB):
        rows = slice(lo, min(lo + ROW_SLAB, v.shape[0]))
        v[rows] = v[rows] @ c
    return mu, v
