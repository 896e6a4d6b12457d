"""POD–Galerkin baseline at the same order and from the same reference snapshots as the amalgam.

The snapshots are the reference excitation states of the detailed modal model (Ñ × K, modal
coordinates), so POD works in the same Ñ-mode space and the comparison isolates what the amalgam
grouping buys.  The constant modes (the mean temperature, energy balance) and the correction vectors are kept
explicitly; POD is applied to the snapshots C0-orthogonally projected off them, in the capacity inner product
``G = Φᵀ C0 Φ`` (method of snapshots: SVD of ``Rᵀ X`` with ``G = R Rᵀ``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from aromm.core.errors import InputError, NumericalError
from aromm.core.system import FloatArray
from aromm.reduction.reductors import DetailedModel

#: Singular values below this fraction of the largest are the snapshots' numerical null space.
RANK_TOL = 1e-13


def pod_coefficients(states: FloatArray, gram: FloatArray, order: int, kept: FloatArray) -> FloatArray:
    """Coefficients ``A`` (Ñ × order): the ``kept`` columns (Ñ × q: constants, corrections), then POD modes.

    An order beyond what the snapshots span (q + their numerical rank) is refused (InputError), never capped.
    """
    states = np.asarray(states, dtype=float)
    n_modes = states.shape[0]
    z = np.asarray(kept, dtype=float).reshape(n_modes, -1)
    if order < max(1, z.shape[1]):
        raise InputError(f"order must be at least {max(1, z.shape[1])} (the constant modes), got {order}")
    g = (gram + gram.T) / 2
    if z.shape[1]:
        zg = z.T @ g
        states = states - z @ np.linalg.solve(zg @ z, zg @ states)
    try:
        r = np.linalg.cholesky(g)
    except np.linalg.LinAlgError:
        raise NumericalError("POD: capacity Gram matrix of the modal basis is not positive definite") from None
    u, s, _ = np.linalg.svd(r.T @ states, full_matrices=False)
    rank = int(np.count_nonzero(s > s[0] * RANK_TOL)) if s.size and s[0] > 0 else 0
    if order - z.shape[1] > rank:
        raise InputError(
            f"POD order {order} is more than the snapshots hold: {z.shape[1] + rank} available "
            f"({z.shape[1]} kept columns + snapshot rank {rank}); ask for order <= {z.shape[1] + rank}, "
            "add reference cases, or use method='greedy'"
        )
    modes = sla.solve_triangular(r.T, u[:, : order - z.shape[1]], lower=False)
    return np.column_stack([z, modes])


@dataclass(frozen=True)
class PodReductor:
    """POD–Galerkin on the same reference states, in the capacity product Φᵀ C0 Φ; constants (and the
    correction vectors when the order leaves room for them) kept as whole columns."""

    name: str = "pod"

    def coefficients(self, detailed: DetailedModel, order: int) -> FloatArray:
        kept = np.column_stack([detailed.constants(), detailed.corrections(order)])
        return pod_coefficients(detailed.states, detailed.basis.gram, order, kept)
