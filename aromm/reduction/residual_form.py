"""The dual norms of the certificate's residuals, per contour point, from one pass over each Gram matrix.

The residual of a reduced solution x(s) on the basis Ψ at the Laplace variable s is ``M c(s)`` with
``M = [U, Eᵀ, K_1Ψ, …, K_mΨ, C_1Ψ, …, C_nΨ]`` (:mod:`aromm.reduction.certificate`) and::

    c(s) = [h(s); −(w_K + s w_C) ⊗ x(s)],    w_K = (k_1(μ), …, k_m(μ), 0, …, 0),  w_C = (0, …, 0, c_1(μ), …, c_n(μ)),

h(s) the inputs' and outputs' coordinates.  Its squared dual norm ``c* G c`` (G = ``Mᵀ N̂_σ⁻¹ M``, real symmetric) is::

    h* G_hh h − 2 Re h* (B_K + s B_C) x + x* A_KK x + 2 Re s x* A_KC x + |s|² x* A_CC x,

``B_a = G_hT (w_a ⊗ I)``, ``A_ab = (w_a ⊗ I)ᵀ G_TT (w_b ⊗ I)``: matrices of r columns formed once per parameter point
and rung (one pass over G), after which each of the contour's points costs O(r² + h r) instead of O(m²) with
m = h + (terms) r.  The coupled heat–moisture model has twelve terms: there one bound evaluation on Gram matrices of
3,005 columns took 4.2 CPU s, 0.54 in this form (docs/method/krylov.md).  The sum is the same products grouped
otherwise (w_K and w_C have disjoint supports, so no term grows), so the rounding floor of the direct form, which
:func:`aromm.reduction.certificate.error_bound` adds, still bounds its rounding: ``8 N ε (|c|ᵀ√diag G)²`` with N
the summands of the longest chain (at most the columns, N ≥ 2 (terms + r + h) here).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aromm.core.system import FloatArray

Complex = npt.NDArray[np.complex128]


@dataclass(frozen=True)
class RungForm:
    """One rung's Gram matrix reduced at a parameter point (module docstring): G_hh, B_K, B_C, A_KK, A_KC, A_CC."""

    ghh: FloatArray
    b_k: FloatArray
    b_c: FloatArray
    a_kk: FloatArray
    a_kc: FloatArray
    a_cc: FloatArray

    @classmethod
    def of(cls, gram: FloatArray, head: int, w_k: FloatArray, w_c: FloatArray) -> RungForm:
        terms = w_k.size
        r = (gram.shape[0] - head) // terms
        ght = gram[:head, head:].reshape(head, terms, r)
        rows = gram[head:, head:].reshape(terms, r, terms * r)  # a view: G_TT is read once, never copied
        left = np.stack([w_k, w_c]) @ rows.transpose(1, 0, 2)  # (r, 2, T r): (w_a ⊗ I)ᵀ G_TT, r small products
        left_k3, left_c3 = left[:, 0].reshape(r, terms, r), left[:, 1].reshape(r, terms, r)
        return cls(np.ascontiguousarray(gram[:head, :head]), np.tensordot(ght, w_k, axes=(1, 0)),
                   np.tensordot(ght, w_c, axes=(1, 0)), np.tensordot(left_k3, w_k, axes=(1, 0)),
                   np.tensordot(left_k3, w_c, axes=(1, 0)), np.tensordot(left_c3, w_c, axes=(1, 0)))

    def square(self, s: Complex, head: Complex, x: Complex) -> FloatArray:
        """``c* G c`` at each point s (rows of ``head`` and ``x``)."""
        def times(v: Complex, a: FloatArray) -> Complex:  # v Aᵀ in two real products (A never copied to complex);
            # the parts made contiguous: numpy < 2 multiplies a strided view without BLAS (the notebook's 7³ coupled
            # build 210 s against 28 in the lowest-versions stage)
            return np.ascontiguousarray(v.real) @ a.T + 1j * (np.ascontiguousarray(v.imag) @ a.T)

        def form(a: FloatArray, u: Complex, v: Complex) -> Complex:  # u_k* A v_k per row k
            return np.einsum("ki,ki->k", u.conj(), times(v, a))

        tt = form(self.a_kk, x, x).real + 2 * (s * form(self.a_kc, x, x)).real + np.abs(s) ** 2 * form(
            self.a_cc, x, x).real
        cross = np.einsum("ki,ki->k", head.conj(), times(x, self.b_k) + s[:, None] * times(x, self.b_c)).real
        return form(self.ghh, head, head).real - 2 * cross + tt


@dataclass(frozen=True)
class ResidualForm:
    """The dual norm ``√(c* G c + floor)`` of residuals on a certificate's ladder at one parameter point: ``rungs``
    the Gram matrices reduced (:class:`RungForm`), ``scales`` √diag G per rung and ``spread`` the residuals'
    rounding per rung and column (or None) for the floor, ``summands`` its count, ``w_k``/``w_c`` the terms'
    coefficients (module docstring)."""

    rungs: Sequence[RungForm]
    scales: FloatArray
    spread: FloatArray | None
    summands: int
    head: int
    w_k: FloatArray
    w_c: FloatArray

    @classmethod
    def of(cls, grams: FloatArray, *, scales: FloatArray, spread: FloatArray | None, summands: int, head: int,
           theta: FloatArray, conductances: int) -> ResidualForm:
        w_k = np.where(np.arange(theta.size) < conductances, theta, 0.0)
        w_c = theta - w_k
        return cls([RungForm.of(g, head, w_k, w_c) for g in grams], scales, spread, summands, head, w_k, w_c)

    def _magnitude(self, column: FloatArray, s: Complex, head: Complex, x: Complex) -> FloatArray:
        """``|c|ᵀ column`` per point (|c| = [|h|, (w_K + |s| w_C) ⊗ |x|])."""
        per_term = np.abs(x) @ column[self.head:].reshape(self.w_k.size, -1).T  # (S, T)
        weights = self.w_k[None, :] + np.abs(s)[:, None] * self.w_c[None, :]
        return np.abs(head) @ column[:self.head] + np.einsum("kt,kt->k", per_term, weights)

    def norm(self, s: Complex, head: Complex, x: Complex, weights: FloatArray) -> FloatArray:
        """The dual norm at each point s, the rungs combined with ``weights`` (rungs × points; the interpolation
        of :func:`aromm.reduction.certificate.error_bound`)."""
        eps = np.finfo(float).eps
        square, floor = np.zeros(s.size), np.zeros(s.size)
        for j, rung in enumerate(self.rungs):
            at = weights[j] > 0
            w, ss, hh, xx = weights[j][at], s[at], head[at], x[at]
            square[at] += w * rung.square(ss, hh, xx)
            floor[at] += w * 8 * self.summands * eps * self._magnitude(self.scales[j], ss, hh, xx) ** 2
            if self.spread is not None:  # the residuals' rounding in the Gram matrices (certificate.riesz)
                floor[at] += w * 2 * eps * self._magnitude(self.spread[j], ss, hh, xx) ** 2
        return np.sqrt(np.maximum(square, 0.0) + floor)


def residual_norms(gram: FloatArray, a: FloatArray, *, k: FloatArray, c: FloatArray, shifts: FloatArray,
                   solutions: FloatArray) -> FloatArray:
    """``‖b_i − (K(μ) + s C(μ)) V x‖`` (S × q) from the Gram matrix ``MᵀM`` of ``M = [U, K_1V, …, C_1V, …]``
    (:mod:`aromm.reduction.residual_gram`): input coefficients ``a`` (p × q), the conductance and capacity terms'
    coefficients ``k``, ``c`` at μ, real ``shifts`` (S) and reduced solutions (S × r × q), by :class:`RungForm`
    (one pass over the Gram matrix, then O(r² + p r) per shift and input)."""
    s, _, q = solutions.shape
    rung = RungForm.of(gram, a.shape[0], np.concatenate([k, np.zeros(c.size)]), np.concatenate([np.zeros(k.size), c]))
    rows = np.repeat(np.asarray(shifts, dtype=complex), q)
    squares = rung.square(rows, np.tile(a.T, (s, 1)).astype(complex),
                          np.swapaxes(solutions, 1, 2).reshape(s * q, -1).astype(complex))
    return np.sqrt(np.maximum(squares.reshape(s, q), 0.0))
