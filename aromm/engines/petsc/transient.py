"""Full-order simulation on the petsc engine: steady state, or implicit time stepping [Chavez2020, eq. 3].

The schemes are those of :func:`aromm.full.solve.transient`: backward Euler, or BDF2 started by one Euler step,
on the output grid ``dt, 2 dt, ...`` with outputs linearly interpolated at other times.  Each step solves
``(a C / dt + K) T_{n+1} = C (...) / dt + F`` by CG + GAMG from the previous step (or by one MUMPS
factorisation reused at every step).  Fixed temperatures are eliminated symmetrically: the fixed rows become
identity rows holding T_D, and ``A x_D`` (x_D: T_D on the fixed rows, 0 elsewhere) is taken off the
right-hand side, which also cancels ``C_fd T_D`` since T_D does not change in time.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from aromm.core.errors import InputError
from aromm.core.observables import Observables
from aromm.core.system import ParamValues
from aromm.engines.petsc import linear, runtime
from aromm.engines.petsc.assembly import DistributedSystem
from aromm.engines.petsc.reduction import Source, distributed
from aromm.engines.petsc.steady import face_means, fixed_values, steady
from aromm.full.solve import interpolate_rows, output_steps, transient_grid

#: Relative residual of every time step (of a coupled system: :data:`aromm.engines.petsc.linear.COUPLED_RTOL`).
STEP_RTOL = 1e-11


def simulate(source: Source, values: ParamValues | None = None, times: npt.ArrayLike | None = None, *,
             scheme: str = "bdf2", solver: str = "gamg", comm: Any = None) -> Observables:
    """Face means of the full model of ``source`` (steady, or at ``times``): collective, same on every rank."""
    solver = linear.check_solver(solver)
    system = distributed(source, comm if comm is not None else runtime.world())
    refuse_histories(system)
    if system.is_steady or system.time is None:
        state = steady(system, values, solver)
        return Observables(t=np.zeros(1), mean_T={k: np.atleast_1d(v) for k, v in state.means.items()}, steady=True)
    return transient(system, values, times, scheme=scheme, solver=solver)


def refuse_histories(system: DistributedSystem) -> None:
    """Refuse boundary values given as histories (a load's or a fixed value's time function): the steps here hold
    every boundary value constant (the reduced models of the petsc engine keep the histories)."""
    timed = [t.coefficient.params[-1] for t in system.template.load.terms if t.time is not None]
    timed += [d.param for d in system.template.dirichlet if d.time is not None]
    if timed:
        raise InputError(f"boundary.{timed[0]}: the petsc engine's full model holds boundary values constant; a "
                         "history needs the scipy engine's (--engine scipy)")


def _stepper(system: DistributedSystem, a: float, *, c: Any, k: Any, rows: np.ndarray, fixed: Any,
             solver: str) -> tuple[Any, Any]:
    """KSP for ``a C / dt + K`` with the fixed rows eliminated, and the lift ``A x_D``."""
    dt = system.time.dt if system.time is not None else 1.0
    mat = k.copy()
    mat.axpy(a / dt, c, structure=runtime.petsc().Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    lift = mat.createVecLeft()
    mat.mult(fixed, lift)
    if system.dirichlet:  # collective: every rank calls it, with or without fixed rows of its own
        mat.zeroRowsColumns(rows.astype(runtime.petsc().IntType), 1.0)
    ksp = linear.krylov(mat, solver, linear.tolerance(STEP_RTOL, system.fields), "aromm_transient_",
                        fields=system.fields)
    ksp.setInitialGuessNonzero(solver == "gamg")  # CG starts from the previous step; a factorisation ignores it
    return ksp, lift


def transient(system: DistributedSystem, values: ParamValues | None = None, times: npt.ArrayLike | None = None, *,
              scheme: str = "bdf2", solver: str = "gamg") -> Observables:
    """Implicit time integration from the uniform ``initial.T`` and the system's initial terms (a coupled system's
    ``initial.phi``; collective)."""
    grid = transient_grid(system.time, system.is_steady, scheme)
    t_out, steps = output_steps(times, grid)
    v = system.values(values)
    c = system.combine(system.capacity, v)
    k = system.combine(system.conductance, v)
    f = system.load_vector(v)
    rows, temps = fixed_values(system, v)
    local_rows = rows - system.rows.lo
    fixed = f.duplicate()
    fixed.set(0.0)
    fixed.getArray()[local_rows] = temps
    x_prev = system.initial_state(v)
    x_prev.getArray()[local_rows] = temps
    x_older = x_prev.copy()
    history_t, history_y = [0.0], [list(face_means(system, x_prev).values())]
    ksp, lift = _stepper(system, 1.0, c=c, k=k, rows=rows, fixed=fixed, solver=solver)
    rhs, work, x = f.duplicate(), f.duplicate(), x_prev.copy()
    for n in range(1, steps + 1):
        bdf2 = n > 1 and scheme == "bdf2"
        if bdf2:
            work.waxpy(-0.25, x_older, x_prev)  # 2 x_n − x_{n−1}/2, halved to keep one axpy below
            work.scale(2.0)
        else:
            x_prev.copy(work)
        c.mult(work, rhs)
        rhs.scale(1.0 / grid.dt)
        rhs.axpy(1.0, f)
        rhs.axpy(-1.0, lift)
        rhs.getArray()[local_rows] = temps
        linear.solve(ksp, rhs, x, f"time step {n} ({scheme})", linear.tolerance(STEP_RTOL, system.fields))
        if n == 1 and scheme == "bdf2" and steps > 1:
            ksp, lift = _stepper(system, 1.5, c=c, k=k, rows=rows, fixed=fixed, solver=solver)
        x_prev.copy(x_older)
        x.copy(x_prev)
        history_t.append(n * grid.dt)
        history_y.append(list(face_means(system, x).values()))
    hy = interpolate_rows(t_out, np.asarray(history_t), np.asarray(history_y))
    return Observables(t=t_out, mean_T={name: hy[:, i] for i, name in enumerate(system.observation)})
