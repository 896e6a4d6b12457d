"""Distributed steady solves ``K(p) T = F(p)`` [Chavez2020, eq. 3] with dT/dt = 0 and face means.

Fixed temperatures are eliminated symmetrically (``MatZeroRowsColumns``: the fixed rows become identity
rows, their columns move to the right-hand side), so the matrix stays symmetric positive definite for CG.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from aromm.core.system import FloatArray, ParamValues
from aromm.engines.petsc import linear, runtime
from aromm.engines.petsc.assembly import DistributedSystem


@dataclass(frozen=True)
class SteadyState:
    """This rank's rows of the steady field (K), the face means (°C) and the solver's record."""

    field: FloatArray
    means: dict[str, float]
    iterations: int
    heat_flow: dict[str, float]  # W entering the body through each Dirichlet set (reaction K T − F there)


def fixed_values(system: DistributedSystem, values: ParamValues) -> tuple[np.ndarray, FloatArray]:
    """This rank's fixed rows (global numbers) and their temperatures."""
    template = system.template
    rows, temps = [], []
    for d in template.dirichlet:
        own = system.dirichlet[d.name]
        rows.append(own)
        temps.append(np.full(own.size, float(np.asarray(values[d.param]))))
    if not rows:
        return np.zeros(0, dtype=np.int64), np.zeros(0)
    return np.concatenate(rows), np.concatenate(temps)


def face_means(system: DistributedSystem, field: Any) -> dict[str, float]:
    """Face-mean temperatures ``e · T`` of a distributed field (collective)."""
    names = list(system.observation)
    local = [float(np.dot(system.observation[k].getArray(readonly=True), field.getArray(readonly=True)))
             for k in names]
    total = runtime.allsum(local, system.comm)
    return {k: float(v) for k, v in zip(names, total, strict=True)}


def steady(system: DistributedSystem, values: ParamValues | None = None, solver: str = "gamg",
           rtol: float = linear.STEADY_RTOL) -> SteadyState:
    """Steady field, face means and Dirichlet heat flows of ``system`` at ``values`` (collective)."""
    PETSc = runtime.petsc()
    v = system.values(values)
    k = system.combine(system.conductance, v)
    f = system.load_vector(v)
    original = k.copy() if system.dirichlet else None
    rows, temps = fixed_values(system, v)
    x = k.createVecRight()
    x.set(0.0)
    index = PETSc.IntType
    if original is not None:
        x.setValues(rows.astype(index), temps)
        x.assemble()
        k.zeroRowsColumns(rows.astype(index), 1.0, x, f)
    rtol = linear.tolerance(rtol, system.fields)
    ksp = linear.krylov(k, solver, rtol, "aromm_steady_", fields=system.fields)
    iterations = linear.solve(ksp, f, x, "steady state", rtol)
    heat = {}
    if original is not None:
        reaction = original.createVecLeft()
        original.mult(x, reaction)
        load = system.load_vector(v)
        reaction.axpy(-1.0, load)
        local = reaction.getArray(readonly=True)
        lo = system.rows.lo
        flows = [float(local[system.dirichlet[d.name] - lo].sum()) for d in system.template.dirichlet]
        heat = dict(zip([d.name for d in system.template.dirichlet],
                        (float(s) for s in runtime.allsum(flows, system.comm)), strict=True))
    return SteadyState(np.array(x.getArray(readonly=True)), face_means(system, x), iterations, heat)
