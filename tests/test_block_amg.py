"""Smoothed aggregation of a coupled heat–moisture operator (:class:`aromm.linalg.block_multigrid.BlockMultigrid` with
``near_null`` and ``blocksize``, as benchmarks/coupled_solvers.py uses it) as the preconditioner of CG: the solution
is the direct one within what the residual tolerance implies, in both discretisations and at a conduction contrast
of 1e4."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import petsc_moisture_cases as moisture
import petsc_moisture_krylov_cases as krylov_cases
import pytest
import scipy.sparse as sp

from aromm.linalg.block_multigrid import BlockMultigrid
from aromm.linalg.multigrid.pcg import pcg
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import assemble

RTOL = 1e-10
SHAPE = (10, 8, 6)  # 1,386 (Q1) / 1,376 (fv) unknowns: above the multigrid's dense coarsest size, so it aggregates


def coupled_operator(discretisation: str, values: dict[str, float], shift: float) -> sp.csr_array:
    """``K + s C`` of :func:`petsc_moisture_krylov_cases.scene` (no fixed values) on a :data:`SHAPE` image."""
    case = krylov_cases.scene(discretisation)
    labels = (np.random.default_rng(3).random(SHAPE) < 0.4).astype(np.int32)
    system = assemble(replace(case, geometry=VoxelGeometry(labels, moisture.VOXEL)))
    assert not system.dirichlet
    v = system.values(values)
    return sp.csr_array(system.conductance.evaluate(v) + shift * system.capacity.evaluate(v))


@pytest.mark.parametrize("discretisation", moisture.DISCRETISATIONS)
@pytest.mark.parametrize("values, shift", [(moisture.PROBE, 1.0 / 60), ({"fibre.k": 250.0}, 1e-3)],
                         ids=["probe", "contrast-1e4"])
def test_aggregation_cg_matches_direct(discretisation: str, values: dict[str, float], shift: float) -> None:
    a = coupled_operator(discretisation, values, shift)
    n = a.shape[0]
    order = np.arange(n).reshape(2, n // 2).T.ravel()  # T and φ of a node side by side
    scale = 1.0 / np.sqrt(a.diagonal()[order])
    scaled = sp.csr_array(sp.diags_array(scale) @ a[order][:, order] @ sp.diags_array(scale))
    near_null = np.zeros((n, 2))
    near_null[0::2, 0], near_null[1::2, 1] = 1.0 / scale[0::2], 1.0 / scale[1::2]
    mg = BlockMultigrid(scaled, rng=np.random.default_rng(0), near_null=near_null, blocksize=2)
    assert len(mg.levels) > 1
    b = np.random.default_rng(1).standard_normal(n)
    y, _, its = pcg(scaled, lambda r, out: np.copyto(out, mg(r)) or out, np.zeros(n), b.copy(),
                    target=RTOL * float(np.linalg.norm(b)), budget=200, work=[np.empty(n) for _ in range(3)])
    assert its < 200
    assert np.linalg.norm(b - scaled @ y) <= 1.01 * RTOL * np.linalg.norm(b)  # the recursive residual is the true one
    exact = np.linalg.solve(scaled.toarray(), b)
    eig = np.linalg.eigvalsh(scaled.toarray())
    kappa = float(eig[-1] / eig[0])
    # ‖y − y*‖ / ‖y*‖ ≤ κ ‖b − Â y‖ / ‖b‖ ≤ κ rtol, plus the direct solve's own rounding κ ε
    assert np.linalg.norm(y - exact) <= kappa * (1.01 * RTOL + 10 * np.finfo(float).eps) * np.linalg.norm(exact)
