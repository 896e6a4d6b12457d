"""The Krylov engine's capacity-orthonormalisation on a hard case: a coupled heat and moisture body, whose capacity
diagonal spans 5e7 (the gas's ρc against the cell wall's λξ), with the Krylov blocks of the reduction (moments
(K + sC)⁻¹ C … of the inputs at several shifts).  ΨᵀCΨ must stay I to rounding: with one eigen-orthonormalisation
pass per block and C X carried through it, it reached 0.99 (a singular reduced capacity: the shipped moisture
scene's Krylov reduction failed)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from test_hygrothermal import STATE

from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.physics.hygrothermal import coupled
from aromm.reduction.lifting import lift
from aromm.reduction.scipy_engine import ScipyEngine


def test_the_krylov_basis_of_a_coupled_body_stays_capacity_orthonormal() -> None:
    labels = (np.random.default_rng(0).random((6, 6, 6)) < 0.4).astype(int)
    phases = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6)]
    thermal = assemble_voxels(labels, (1e-5,) * 3, phases, [FaceSpec("z0", T=20.0), FaceSpec("z1", h=20.0, T_ext=20.0)],
                              time=TimeGrid(60.0, 1.0), initial_T=20.0, outputs=["z1"])
    moisture = {"fibre": {"xi": 200.0, "D_phi": 2e-9, "delta_p": 1e-13},
                "gas": {"xi": 0.017, "D_phi": 0.0, "delta_p": 2e-10}}
    system = lift(coupled(thermal, STATE, moisture, fixed_phi={"z0": 0.8}, vapour={"z1": (2e-8, 0.5)}))
    engine = ScipyEngine(system, "splu")
    values = system.values({})
    k, c = (sp.csc_array(a.evaluate(values)) for a in (system.conductance, system.capacity))
    capacity = c.diagonal()
    assert capacity.max() / capacity.min() > 1e7  # the hard case
    basis = None
    for shift in (0.0, 0.01, 1.0, 100.0):
        lu = spla.splu(sp.csc_array(k + shift * c))
        block = np.asarray(engine.input_terms())
        for step in range(3):
            block = lu.solve(np.asarray(c @ block) if step else block)
            basis, _ = engine.orthonormalise(basis, block, values, 1e-10)
    assert basis is not None
    r = basis.shape[1]
    gram = basis.T @ engine.capacity(values, basis)
    assert r > 100
    assert np.abs(gram - np.eye(r)).max() <= 100 * r * np.finfo(float).eps  # rounding of r-term sums, with margin
