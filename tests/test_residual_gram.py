"""Residual norms from one Gram matrix per basis against the residual vectors formed explicitly."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from test_multigrid import _system

from aromm.reduction.scipy_engine import ScipyEngine


def test_gram_residual_norms_equal_the_explicit_residuals() -> None:
    system = _system((7, 6, 8), contrast=1e3)
    from aromm.reduction.lifting import lift

    lifted = lift(system, {}, "auto")
    engine = ScipyEngine(lifted)
    rng = np.random.default_rng(5)
    basis = np.linalg.qr(rng.standard_normal((lifted.n, 9)))[0]
    shifts = np.array([0.01, 0.3, 7.0])
    for mu in ({"fibre.k_x": 0.1, "fibre.c": 1e6}, {"fibre.k_z": 3.0, "z1.h": 50.0}):
        v = lifted.values(mu)
        q = engine.inputs(mu).shape[1]
        x = rng.standard_normal((shifts.size, 9, q))
        k = sp.csr_array(lifted.conductance.evaluate(v))
        c = sp.csr_array(lifted.capacity.evaluate(v))
        b = engine.inputs(mu)
        explicit = np.array([np.linalg.norm(b - (k + s * c) @ basis @ x[i], axis=0) for i, s in enumerate(shifts)])
        np.testing.assert_allclose(engine.residual_norms(basis, mu, shifts, x), explicit, rtol=1e-9)
