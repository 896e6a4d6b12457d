"""The adjoint sensitivity of steady outputs (aromm.full.solve.steady_sensitivity) against a two-layer slab.

A slab of two layers in series along x (lengths L_a, L_b), a flux φ into x0 and x1 held at 0 °C: the steady drop is
T̄_x0 − T̄_x1 = φ (L_a/k_a + L_b/k_b) in q1 and in fv (both exact on a 1-D laminate), and scaling k_a by λ moves it by
d/d ln λ = −φ L_a/k_a.  The tolerance is the linear solver's relative residual, 1e-10, on a quantity of order one.
"""

from __future__ import annotations

import numpy as np
import pytest

from aromm.core.system import dense
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.full.solve import steady_sensitivity
from aromm.fv.volumes import assemble_volumes

H, FLUX = 1e-3, 500.0
PHASES = (PhaseSpec("a", 0, 0.3), PhaseSpec("b", 1, 2.0))


@pytest.mark.parametrize("assemble", [assemble_voxels, assemble_volumes])
@pytest.mark.parametrize("scaled", [("a.k",), ("b.k",), ("a.k", "b.k")])
def test_drop_and_its_slope_match_the_series_formula(assemble, scaled) -> None:  # type: ignore[no-untyped-def]
    labels = np.array([0, 0, 0, 1, 1]).reshape(5, 1, 1)  # L_a = 3 h, L_b = 2 h
    system = assemble(labels, (H,) * 3, PHASES, [FaceSpec("x0", flux=FLUX), FaceSpec("x1", T=0.0)],
                      outputs=["x0", "x1"])
    rows = np.vstack([dense(system.observation[n]).ravel() for n in ("x0", "x1")])
    values = {"a.k": 0.3, "b.k": 2.0}
    y, dy = steady_sensitivity(system, {}, rows, {n: values[n] for n in scaled}, rtol=1e-10)
    parts = {"a.k": FLUX * 3 * H / 0.3, "b.k": FLUX * 2 * H / 2.0}
    drop = sum(parts.values())
    np.testing.assert_allclose(y[0] - y[1], drop, rtol=1e-9)
    np.testing.assert_allclose(dy[0] - dy[1], -sum(parts[n] for n in scaled), rtol=1e-7)  # + the step's O(1e-8)
    assert dy[1] == pytest.approx(0.0, abs=1e-12)  # the held face does not move
