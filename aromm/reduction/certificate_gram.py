"""The certificate's Gram matrices kept along a growing basis (:mod:`aromm.reduction.certificate`).

A Krylov greedy that stops on the certified bound certifies its span after every new point, and the compressed model
at the end.  Each certificate needs ``G_σ = Mᵀ N̂_σ⁻¹ M`` per rung σ of the ladder, ``M = [U, Eᵀ, A_1V, …, A_mV]``
(A_t the conductance then the capacity terms, V the basis): one shifted solve per column of M and rung.  But the
greedy only appends columns to V, and every later basis is a combination of the span's columns, so:

* when V gains columns V₊, G gains the rows and columns of ``A_tV₊`` only: ``N̂_σ⁻¹ A_tV₊`` is solved, and the entries
  between old and new columns are ``M_oldᵀ (N̂_σ⁻¹ M₊)`` (N̂_σ is symmetric);
* a model on ``Ψ = V W`` (the compression's coefficients W) has ``M_Ψ = M T``, ``T = diag(I, W, …, W)``, hence the Gram
  matrices ``Tᵀ G T`` and ``ΨᵀU = Wᵀ VᵀU``: its certificate costs no solve at all.

So a certified Krylov build costs one solve per column of the final span's M and rung, instead of one per column of
every certified M.  The solves' residuals R correct the Gram matrices to second order
(:func:`~aromm.reduction.certificate.riesz`); between old and new columns that takes ``Ẑ_oldᵀ R₊``, so the ledger
keeps ``Z = N̂_σ⁻¹ M`` of every column in float32 (the correction is itself ≈ 1e-11 of the entries: float32 loses
nothing that matters), ``n × columns × 4`` bytes per rung.  Rounding: ``Tᵀ G T`` is formed from the span's
entries, so the floor of the bound's quadratic forms
(:func:`aromm.reduction.certificate.error_bound`) takes its column norms as ``|T|ᵀ √diag G`` (an upper bound of
``‖M T e_k‖`` by the triangle inequality) and counts the span's columns in its sums; the residuals' rounding
(:func:`~aromm.reduction.certificate.riesz`) likewise takes ``|T|ᵀρ`` (the triangle inequality of the ``|N̂|``
semi-norm).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping

import numpy as np

from aromm.core.system import FloatArray, ThermalSystem
from aromm.reduction.certificate import Certificate, CertifyingEngine, ladder, riesz

log = logging.getLogger(__name__)


class GramLedger:
    """Gram matrices of M for a basis that only grows (module docstring), normed at ``reference`` (μ̂); shifted
    solves to ``rtol``.  tests/test_certificate.py checks its certificates against :func:`~aromm.reduction.certificate.
    certify` of the same bases."""

    def __init__(self, engine: CertifyingEngine, system: ThermalSystem, reference: Mapping[str, float],
                 rtol: float) -> None:
        assert system.time is not None
        self.engine, self.reference, self.rtol = engine, dict(reference), rtol
        v = system.values(reference)
        terms = (*system.conductance.terms, *system.capacity.terms)
        self.theta = np.array([float(t.coefficient(v)) for t in terms])
        self.sigmas = ladder(system.time.end, system.time.dt)
        self.u = engine.input_terms()
        self.head = engine.join([self.u, engine.output_block()])
        self.loads = len(system.load.terms)
        self.terms = len(terms)
        self.riesz: list[list[FloatArray]] = [[] for _ in self.sigmas]  # N̂_σ⁻¹ M per rung, float32, by extension
        self.width = 0  # basis columns accounted for
        self.grams = np.zeros((len(self.sigmas), 0, 0))  # in arrival order: the head, then each extension's block
        self.spread = np.zeros((len(self.sigmas), 0))  # the residuals' rounding per column (riesz), arrival order
        self.labels: list[tuple[int, int]] = []  # per Gram column: (-1, j) the head's j-th, (t, k) A_t times V[:, k]
        self.vtu = np.zeros((0, 0))
        self.solves = 0

    def extend(self, basis: FloatArray) -> None:
        """Account for the columns of ``basis`` beyond those seen (its first columns must be the earlier basis)."""
        width = int(basis.shape[1])
        if width <= self.width:
            return
        start = time.process_time()
        eng, new = self.engine, basis[:, self.width:]
        fresh = eng.term_products(new)  # term-major: A_1 V₊, A_2 V₊, …
        labels = [(t, self.width + k) for t in range(self.terms) for k in range(width - self.width)]
        old = None
        if self.labels:
            old = eng.join([self.head, eng.term_products(basis[:, :self.width])])
        else:
            fresh = eng.join([self.head, fresh])
            labels = [(-1, j) for j in range(int(self.head.shape[1]))] + labels
        grown, spread = [], []
        for j, sigma in enumerate(self.sigmas):
            z, r, rho = riesz(eng, self.reference, float(sigma), fresh, self.rtol)
            spread.append(rho)
            corner = eng.dot(fresh, z) + eng.dot(r, z)
            if old is None:
                grown.append((corner + corner.T) / 2)
            else:  # M_oldᵀ N̂⁻¹ M₊ = M_oldᵀ Z₊ + Ẑ_oldᵀ R₊ (module docstring)
                low = r.astype(np.float32)
                side = eng.dot(old, z)[self._order()] + np.vstack([eng.dot(b, low) for b in self.riesz[j]])
                grown.append(np.block([[self.grams[j], side], [side.T, (corner + corner.T) / 2]]))
            self.riesz[j].append(z.astype(np.float32))
        self.solves += int(fresh.shape[1]) * len(self.sigmas)
        self.grams, self.labels, self.width = np.stack(grown), self.labels + labels, width
        self.spread = np.hstack([self.spread, np.stack(spread)])
        self.vtu = eng.dot(basis, self.u)
        log.info("certificate: Gram matrices of %d columns on %d rungs (%d solves in all), %.1f CPU s",
                 len(self.labels), len(self.sigmas), self.solves, time.process_time() - start)

    def _order(self) -> list[int]:
        """Index in the term-major layout of each arrival-order column."""
        head = int(self.head.shape[1])
        return [k if t < 0 else head + t * self.width + k for t, k in self.labels]

    def certificate(self, coefficients: FloatArray | None = None) -> Certificate:
        """The certificate of the model on the accounted basis V, or on ``V @ coefficients`` (no solve)."""
        layout = np.argsort(self._order())  # arrival column of each term-major one
        # one gather (np.ix_): C-contiguous, where two fancy indexings gave another memory order, which every bound
        # evaluation then copied (0.92 → 0.54 CPU s an evaluation on the 6×5×4 coupled scene: benchmarks/
        # training_box_cost.py --bounds, record benchmarks/records/training_box_cost_c1663b5.txt)
        grams = self.grams[np.ix_(np.arange(len(self.sigmas)), layout, layout)]
        spread = self.spread[:, layout]
        if coefficients is None:
            return Certificate(self.theta, self.sigmas, grams, self.vtu, self.loads, spread=spread)
        w = np.asarray(coefficients, dtype=float)
        head, (rows, cols) = int(self.head.shape[1]), w.shape
        t_mat = np.zeros((head + self.terms * rows, head + self.terms * cols))
        t_mat[:head, :head] = np.eye(head)
        for t in range(self.terms):
            t_mat[head + t * rows:head + (t + 1) * rows, head + t * cols:head + (t + 1) * cols] = w
        projected = np.stack([_block_projection(g, w, head, self.terms) for g in grams])
        scales = np.sqrt(np.maximum(np.diagonal(grams, axis1=1, axis2=2), 0.0)) @ np.abs(t_mat)
        return Certificate(self.theta, self.sigmas, (projected + projected.transpose(0, 2, 1)) / 2, w.T @ self.vtu,
                           self.loads, scales=scales, summands=t_mat.shape[0], spread=spread @ np.abs(t_mat))


def _block_projection(gram: FloatArray, w: FloatArray, head: int, terms: int) -> FloatArray:
    """``Tᵀ G T`` for ``T = diag(I_head, W, …, W)`` (``terms`` blocks W, rows × cols) by blocks: ``Wᵀ G_ab W`` per pair
    of terms and ``G_hb W`` beside the head, 2 terms² rows (rows + cols) cols flops instead of the dense product's
    2 m_T (m_T + m_W) m_W (a 7³ coupled build: its two certificates 45 s on numpy 1.26, whose stacked products of
    transposed views do not go through BLAS, before)."""
    rows, cols = w.shape
    g = np.ascontiguousarray(gram)
    right = (g[:, head:].reshape(-1, rows) @ w).reshape(g.shape[0], terms * cols)  # G T's term columns
    out = np.empty((head + terms * cols, head + terms * cols))
    out[:head, :head] = g[:head, :head]
    out[:head, head:] = right[:head]
    lower = np.ascontiguousarray(right[head:]).reshape(terms, rows, terms * cols)
    out[head:, head:] = np.matmul(np.ascontiguousarray(w.T), lower).reshape(terms * cols, terms * cols)
    out[head:, :head] = out[:head, head:].T
    return out
