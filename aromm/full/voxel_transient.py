"""The full transient of a matrix-free voxel system: BDF2 on multigrid-preconditioned CG, no matrix assembled.

The same scheme as :func:`aromm.full.solve.transient` (backward Euler for the first step, then BDF2 [Chavez2020,
eq. 3] ``(a C/dt + K) T_n = C (past)/dt + F(t_n)`` with ``a = 3/2``), for a system whose conduction, capacity and
convection terms are :class:`~aromm.fem.voxel_terms.VoxelTerm`: the iteration operator ``K(p) + (a/dt) C(p)`` is
one :class:`~aromm.linalg.multigrid.operator.VoxelOperator` (per-phase conductivities and capacities summed), its
multigrid hierarchy built from class values, each step solved from the previous step's field to the relative
residual ``rtol``.  Memory: a few node vectors and the coarse levels (≈ 50 bytes per voxel) instead of the
assembled matrices.  Fixed temperatures must be lifted first (aromm.reduction.lifting): the full model of a lifted
system has the same outputs.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from aromm.core.errors import InputError
from aromm.core.profiles import time_factor
from aromm.core.system import FloatArray, ParamValues, ThermalSystem
from aromm.fem.voxel_terms import as_voxel_terms, is_voxel_family, shifted_operator, weighted_product
from aromm.linalg.factorizations import DEFAULT_RTOL
from aromm.linalg.multigrid.pcg import MultigridSolver


def is_matrix_free_voxel(system: ThermalSystem) -> bool:
    """True when the system's conduction and capacity terms are matrix-free voxel terms of one family."""
    return is_voxel_family([t.operator for t in (*system.conductance.terms, *system.capacity.terms)])


def voxel_steps(system: ThermalSystem, values: ParamValues, steps: int, dt: float, *, scheme: str,
                output: Callable[[FloatArray, float], FloatArray], rtol: float = DEFAULT_RTOL
                ) -> tuple[list[float], list[FloatArray]]:
    """Times ``0, dt, …, steps dt`` and the outputs ``output(T, t)`` there, from the initial field of ``system``."""
    if system.dirichlet:
        raise InputError("the matrix-free transient needs the fixed temperatures lifted first "
                         "(aromm.reduction.lifting.lift)")
    cond = as_voxel_terms([t.operator for t in system.conductance.terms])
    cap = as_voxel_terms([t.operator for t in system.capacity.terms])
    k = [float(t.coefficient(values)) for t in system.conductance.terms]
    c = [float(t.coefficient(values)) for t in system.capacity.terms]
    free, n = cap[0].free, cap[0].grid.n
    loads = [(float(t.coefficient(values)) * np.asarray(t.operator, dtype=float), t.time) for t in system.load.terms]
    x = np.full(system.n, float(np.asarray(values["initial.T"])))
    if system.initial:
        x += np.asarray(system.initial.evaluate(values), dtype=float)

    def solver(lead: float) -> MultigridSolver:
        return MultigridSolver(shifted_operator(cond + cap, k + [lead / dt * ci for ci in c]), rtol=rtol)

    def forcing(t: float) -> FloatArray:
        return sum((vec * time_factor(g, t) for vec, g in loads), np.zeros(system.n))

    times, outputs = [0.0], [output(x, 0.0)]
    x_older = x
    mg = solver(1.0)
    for step in range(1, steps + 1):
        t_n = step * dt
        past = x if step == 1 or scheme == "euler" else 2.0 * x - 0.5 * x_older
        rhs = weighted_product(cap, c, past) / dt + forcing(t_n)
        full_rhs, guess = np.zeros(n), np.zeros(n)
        full_rhs[free], guess[free] = rhs, x
        x_new = mg.solve(full_rhs, x0=guess)[free]
        if step == 1 and scheme == "bdf2" and steps > 1:
            mg = solver(1.5)
        x_older, x = x, x_new
        times.append(t_n)
        outputs.append(output(x, t_n))
    return times, outputs
