"""Export of a ThermalSystem to a pyMOR LTIModel (aromm.interop.pymor; skipped without the ``mor`` extra).

Independent truth: aromm's own full model (aromm.full.solve, sparse direct solver) on the same system — backward
Euler on the same grid in time, the steady state, and the transfer function e (K + sC)⁻¹ F.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from test_reduced import PHASES, random_labels

from aromm.core.system import Coefficient, TimeGrid
from aromm.core.vocabulary import FaceSpec
from aromm.fem import assemble_voxels
from aromm.full.solve import simulate, steady_field
from aromm.linalg.direct import DEFAULT_RTOL

pytest.importorskip("pymor")

from pymor.algorithms.timestepping import ImplicitEulerTimeStepper

from aromm.interop.pymor import functional, mu_of, to_lti

FACES = [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0, T_ext=3.0)]  # T_ext ≠ 0: a second load term
VALUES = {"fibre.k": 0.1, "fibre.c": 1.2e6, "initial.T": 1.5}


def system():
    return assemble_voxels(random_labels(5, seed=11), (5e-6,) * 3, PHASES, FACES, time=TimeGrid(2.0, 0.1),
                           outputs=["z0", "z1"])


def test_exported_model_reproduces_the_full_model_in_time() -> None:
    s = system()
    fom = to_lti(s, ImplicitEulerTimeStepper(20))
    assert set(fom.parameters) == {"fibre.k", "fibre.c", "gas.k", "gas.c", "z0.flux", "z1.h", "z1.T_ext",
                                   "initial.T"}
    mu = mu_of(fom, s.values(VALUES))
    # pyMOR's time steppers need a non-parametric mass matrix: assemble E at mu
    y = fom.with_(E=fom.E.assemble(mu)).output(mu=mu, input="1").T  # (21, 2): t = 0, 0.1, ..., 2
    ref = simulate(s, VALUES, scheme="euler").as_array()
    np.testing.assert_allclose(y[0], 1.5, rtol=1e-12)
    np.testing.assert_allclose(y[1:], ref, rtol=10 * DEFAULT_RTOL, atol=10 * DEFAULT_RTOL * np.abs(ref).max())


def test_exported_model_steady_state_and_transfer_function() -> None:
    s = system()
    fom = to_lti(s)
    mu = mu_of(fom, s.values(VALUES))
    b = fom.B.as_range_array(mu)
    steady = fom.C.apply(fom.A.apply_inverse(-b, mu=mu), mu=mu).to_numpy().ravel()
    _, e = s.observation_matrix()
    np.testing.assert_allclose(steady, e @ steady_field(s, VALUES), rtol=10 * DEFAULT_RTOL)
    v = s.values(VALUES)
    k = sp.csc_array(s.conductance.evaluate(v))
    c = sp.csc_array(s.capacity.evaluate(v))
    f = np.asarray(s.load.evaluate(v))
    for freq in (0.5, 20.0):
        tf = np.asarray(fom.transfer_function.eval_tf(1j * freq, mu=mu)).ravel()
        np.testing.assert_allclose(tf, e @ spla.spsolve(k + 1j * freq * c, f.astype(complex)), rtol=1e-9)


def test_coefficients_become_equal_parameter_functionals() -> None:
    from pymor.parameters.base import Parameters

    values = {"a": 0.3, "b": 2.0}
    mu = Parameters({"a": 1, "b": 1}).parse(values)
    for coef in (Coefficient(("a",)), Coefficient(("a", "b"), scale=4.0), Coefficient(("a", "b"), "harmonic", 2.0)):
        assert functional(coef).evaluate(mu) == pytest.approx(float(coef(values)), rel=1e-15)
    assert functional(Coefficient((), scale=3.0)) == 3.0
