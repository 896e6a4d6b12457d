"""Export a :class:`~aromm.core.system.ThermalSystem` to a parametric pyMOR ``LTIModel`` (optional extra ``mor``).

The semi-discrete heat equation ``C(p) dT/dt + K(p) T = F(p)``, ``y = E T`` [Chavez2020, eq. 3] becomes
pyMOR's descriptor system with one step input ``u(t) = 1``::

    E(μ) ẋ = A(μ) x + B(μ) u,   y = C x,   x(0) = T0(μ) 1,
    E = Σ c_j(μ) C_j,   A = −Σ k_j(μ) K_j,   B = Σ f_j(μ) U_j,   C = face-mean rows,

every sum a ``LincombOperator`` of ``NumpyMatrixOperator``s whose coefficients are pyMOR parameter
functionals of aromm's own parameter names (``"fibre.k"``, ``"z0.flux"``, ``"initial.T"``): a product of
parameters becomes a ``ProductParameterFunctional`` of ``ProjectionParameterFunctional``s, a harmonic mean
(DEM bonds, finite-volume links) a ``GenericParameterFunctional``.  So pyMOR's projections keep the affine
structure, and ``mu`` takes the same values as :meth:`ThermalSystem.values`.  Importing this module needs pyMOR
(``pip install -e ".[mor]"``); ``aromm`` itself never imports it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.system import PENALTY_INSTEAD, Affine, Coefficient, ThermalSystem, dense, require_free_transient

try:
    from pymor.models.iosys import LTIModel
    from pymor.operators.constructions import LincombOperator, VectorOperator
    from pymor.operators.numpy import NumpyMatrixOperator
    from pymor.parameters.functionals import (
        GenericParameterFunctional,
        ProductParameterFunctional,
        ProjectionParameterFunctional,
    )
except ImportError as err:  # pragma: no cover - exercised only without the extra
    raise ImportError("aromm.interop.pymor needs pyMOR: pip install -e '.[mor]'") from err


def _generic(coefficient: Coefficient) -> Any:
    def mapping(mu: Any) -> float:
        return float(coefficient({name: float(mu[name][0]) for name in coefficient.params}))

    return GenericParameterFunctional(mapping, dict.fromkeys(coefficient.params, 1), name=coefficient.describe())


def functional(coefficient: Coefficient) -> Any:
    """The pyMOR parameter functional (or number) equal to an aromm coefficient."""
    if coefficient.kind != "product":  # a harmonic mean (DEM bonds, finite-volume links) or a coupled link
        return _generic(coefficient)
    factors = [ProjectionParameterFunctional(p) for p in coefficient.params]
    if not factors:
        return float(coefficient.scale)
    if len(factors) == 1 and coefficient.scale == 1.0:
        return factors[0]
    return ProductParameterFunctional([float(coefficient.scale), *factors])


def _lincomb(affine: Affine, sign: float, name: str, column: bool = False) -> Any:
    ops, coefs = [], []
    for t in affine.terms:
        op = np.asarray(t.operator, dtype=float)[:, None] if column else sp.csr_matrix(t.operator) * sign
        ops.append(NumpyMatrixOperator(op, name=t.name))
        coefs.append(functional(t.coefficient))
    return LincombOperator(ops, coefs, name=name)


def to_lti(system: ThermalSystem, time_stepper: Any = None) -> LTIModel:
    """The pyMOR ``LTIModel`` of ``system`` (module docstring); with ``time_stepper`` (e.g.
    ``ImplicitEulerTimeStepper(nt)``) it also simulates over the system's time grid, ``T = time.end``."""
    require_free_transient(system, "export to pyMOR", PENALTY_INSTEAD)
    if not system.load:
        raise InputError("export to pyMOR needs at least one load term (B)")
    outputs, rows = system.observation_matrix()
    if not outputs:
        raise InputError("export to pyMOR needs outputs (observed faces)")
    e = _lincomb(system.capacity, 1.0, "E")
    a = _lincomb(system.conductance, -1.0, "A")
    b = _lincomb(system.load, 1.0, "B", column=True)
    c = NumpyMatrixOperator(dense(rows), name="C")
    options: dict[str, Any] = {}
    if time_stepper is not None:
        if system.time is None:
            raise InputError("export to pyMOR with a time stepper needs a time grid ([time] section)")
        ones = a.source.from_numpy(np.ones(system.n))
        options = {"T": system.time.end, "time_stepper": time_stepper,
                   "initial_data": LincombOperator([VectorOperator(ones)],
                                                   [ProjectionParameterFunctional("initial.T")])}
    return LTIModel(a, b, c, E=e, name="aromm", **options)


def mu_of(model: LTIModel, values: Mapping[str, float]) -> Any:
    """pyMOR parameter values for ``model`` from aromm values (only the names the model uses)."""
    return model.parameters.parse({k: float(values[k]) for k in model.parameters})
