"""The harmonic mean of two 2 × 2 flux matrices of the coupled heat–moisture model, in the cone they share.

Every phase's symmetrised flux matrix of :mod:`aromm.physics.hygrothermal` is ``k E_T + λ D_φ E_φ + (L_v/a) δ_p v vᵀ``
(``v = (a, p)``).  Scaled by ``S = diag(a, p)`` it reads ``S (x E_1 + y E_2 + z 1 1ᵀ) S`` with ``(x, y, z) =
(k/a², λ D_φ/p², L_v δ_p/a)`` ≥ 0: a point of the cone ``𝒦 = {diag(x, y) + z 1 1ᵀ : x, y, z ≥ 0}`` (symmetric,
off-diagonal ≥ 0 and at most either diagonal entry).  A finite-volume link between two phases carries the series
conductance of its two half cells, the matrix harmonic mean ``H = 2 (P⁻¹ + Q⁻¹)⁻¹`` (the parallel sum, twice
[Anderson1969]).  It stays in 𝒦, and its cone coordinates follow without cancellation:

    for ``M = diag(x, y) + z 1 1ᵀ``:  det M = d = x y + z (x + y),   M⁻¹ = [[v + w, −w], [−w, u + w]],
    (u, v, w) = (x, y, z) / d;   with U, V, W the sums over the two phases:
    H = 2 / (U V + W (U + V)) · (diag(U, V) + W 1 1ᵀ).

So a link between phases is three positive semi-definite terms, ``x_H (S E_1 S)``, ``y_H (S E_2 S)`` and
``z_H v vᵀ`` times the link graph's Laplacian, each with a coefficient ≥ 0: the coupled finite-volume operator is
still affine with positive semi-definite terms (the certificate's min-θ constant applies).  A phase that carries heat
only (y = z = 0, d = 0) is the limit ``M⁻¹ → e_1 e_1ᵀ / x`` on its range: its link with a phase ``(u, v, w)`` is
``x_H = 2 / (1/x + v + w)``, ``y_H = z_H = 0`` (the parallel sum of a rank-one matrix), and two such phases link by
the scalar harmonic mean of their k.  In the dry limit every link is the thermal one, ``2 k_p k_q / (k_p + k_q)``.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


def cone_harmonic(first: tuple[FloatArray, FloatArray, FloatArray],
                  second: tuple[FloatArray, FloatArray, FloatArray]) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Cone coordinates ``(x, y, z)`` of ``2 (P⁻¹ + Q⁻¹)⁻¹`` for P, Q given by theirs (arrays broadcast together, each
    coordinate ≥ 0, x > 0; module docstring).

    >>> p = (np.array(2.0), np.array(1.0), np.array(0.5))
    >>> [round(float(c), 12) for c in cone_harmonic(p, p)]  # the harmonic mean of a matrix with itself
    [2.0, 1.0, 0.5]
    >>> [float(c) for c in cone_harmonic((np.array(1.0), np.array(0.0), np.array(0.0)),
    ...                                  (np.array(3.0), np.array(0.0), np.array(0.0)))]  # dry: 2 k_p k_q / (k_p + k_q)
    [1.5, 0.0, 0.0]
    """
    inverses, heat_only = [], []
    for point in (first, second):
        x, y, z = (np.asarray(c, dtype=float) for c in point)
        d = x * y + z * (x + y)
        dry = d <= 0.0
        safe = np.where(dry, 1.0, d)
        inverses.append((np.where(dry, 0.0, x / safe), np.where(dry, 0.0, y / safe), np.where(dry, 0.0, z / safe)))
        heat_only.append((dry, x))
    u, v, w = (a + b for a, b in zip(*inverses, strict=True))
    (dry_p, x_p), (dry_q, x_q) = heat_only
    det = u * v + w * (u + v)
    wet = ~(dry_p | dry_q)
    scale = np.where(wet, 2.0 / np.where(wet, det, 1.0), 0.0)
    x_h, y_h, z_h = scale * u, scale * v, scale * w
    # a heat-only phase: the rank-one parallel sum with the other's (u, v, w), or the scalar mean of two such phases
    one = dry_p ^ dry_q
    x_dry = np.where(dry_p, x_p, x_q)
    rest = np.where(dry_p, inverses[1][1] + inverses[1][2], inverses[0][1] + inverses[0][2])
    x_h = np.where(one, 2.0 / (1.0 / np.where(one, x_dry, 1.0) + rest), x_h)
    both = dry_p & dry_q
    x_h = np.where(both, 2.0 * x_p * x_q / np.where(both, x_p + x_q, 1.0), x_h)
    return x_h, y_h, z_h
