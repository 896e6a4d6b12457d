"""A priori energy tolerances that bound the algebraic error of an apparent conductivity by ``ktol``.

Every cell problem of :mod:`aromm.homogenization.cell_problems` reads k from a quadratic quantity of its
solution: for ``A x* = b`` and any x found by CG from a zero guess, ``bᵀx* − bᵀx = ‖x* − x‖²_A ≥ 0`` (Galerkin
orthogonality of the Krylov iterate).  So a solve stopped at ``‖x* − x‖²_A ≤ ε`` (estimated by
:meth:`aromm.linalg.multigrid.pcg.MultigridSolver.solve`) knows bᵀx* to ε, and ε is set from bounds of k
that hold before any solve:

* periodic, ``k_jj = ⟨k_j⟩ − b_jᵀT̃_j / V``: ``Δk_jj = ‖e_j‖²_A / V`` (V the volume); off-diagonal in the
  energy form ``k_ij V = T_iᵀ A T_j`` (T_j = g_j + T̃_j): the cross terms vanish because A T*_j is orthogonal to
  every periodic field, so ``Δk_ij = e_iᵀ A e_j / V`` and ``|Δk_ij| ≤ ‖e_i‖_A ‖e_j‖_A / V`` — quadratic like the
  diagonal (the one-sided form −b_iᵀT̃_j / V has a linear error ``T̃_iᵀ A e_j``, which needed ε ∝ ktol²);
* fixed temperatures (ΔT = 1 K), ``k = E L / S`` with E the energy: ``Δk = ‖e‖²_A L / S``;
* uniform flux q, ``k = q L S / (bᵀT)`` with ``bᵀT = q S ΔT̄``: ``Δk / k ≈ ‖e‖²_A / (bᵀT*)``,
  ``bᵀT* = q² S L / k``.

The lower bound of every diagonal value is the harmonic (Reuss) mean k_h = ⟨1/k_j⟩⁻¹ — the discrete Q1 energy is
at least the continuous one, itself at least k_h (along each line of the loaded axis the series value, then
Jensen) — and the upper bound of the uniform-flux value is the arithmetic (Voigt) mean ⟨k_j⟩, the energy of
the linear field, which the Q1 space holds [Wiener1912].  With these, each entry's algebraic error is at most
``ktol`` × k_h (relative error ≤ ``ktol`` on the diagonal).  Units: k in W/(m K), lengths in m, areas in m²,
volumes in m³, energies ‖·‖²_A in the units of bᵀx of each problem.
"""

from __future__ import annotations

import numpy as np

from aromm.linalg.multigrid.operator import VoxelOperator


def _fractions(op: VoxelOperator) -> np.ndarray:
    return np.bincount(op.phase.ravel(), minlength=len(op.conductivity)) / op.phase.size


def harmonic_bound(op: VoxelOperator, axis: int) -> float:
    """⟨1/k_axis⟩⁻¹ over the voxels (W/(m K)): a lower bound of the apparent k_axis,axis."""
    k = np.asarray(op.conductivity, dtype=float)[:, axis]
    present = _fractions(op) > 0
    return float(1.0 / (_fractions(op)[present] @ (1.0 / k[present])))


def arithmetic_bound(op: VoxelOperator, axis: int) -> float:
    """⟨k_axis⟩ over the voxels (W/(m K)): an upper bound of the apparent k_axis,axis."""
    return float(_fractions(op) @ np.asarray(op.conductivity, dtype=float)[:, axis])


def periodic_energy_tolerances(op: VoxelOperator, ktol: float | None, volume: float) -> list[float | None]:
    """ε_j = ``ktol min_i k_h,i V`` for the three periodic loads (V = ``volume``): every entry within ktol min k_h."""
    if ktol is None:
        return [None, None, None]
    tolerance = ktol * min(harmonic_bound(op, j) for j in range(3)) * volume
    return [tolerance] * 3
