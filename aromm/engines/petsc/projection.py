"""Galerkin projection of a distributed ThermalSystem onto a distributed basis (seed 001 eq. 10).

Every term keeps its name and coefficient and gets ``Ψᵀ C_j Ψ``, ``Ψᵀ K_j Ψ`` (r × r) or ``Ψᵀ F_j`` (r): each
rank multiplies its rows (one MatMatMult per term) and the small products are summed over the ranks, so
every rank ends with the same :class:`~aromm.reduced.ReducedModel`, built by its public constructor exactly
as :meth:`ReducedModel.from_system` builds it in one process.
"""

from __future__ import annotations

import numpy as np

from aromm.engines.petsc import convert
from aromm.engines.petsc.assembly import DistributedSystem, DistributedTerm
from aromm.errors import InputError
from aromm.reduced import ProjectedTerm, ReducedModel
from aromm.system import FloatArray


def project(system: DistributedSystem, basis: FloatArray, memo: dict[int, FloatArray] | None = None) -> ReducedModel:
    """The reduced model of ``system`` on the columns of ``basis`` (this rank's rows, n_local × r).

    ``memo`` (id of a PETSc operator → projection) shares work between systems with common terms.
    """
    template = system.template
    if template.dirichlet:
        fixed = ", ".join(d.param for d in template.dirichlet)
        raise InputError(f"fixed temperatures ({fixed}) are not supported by the reduced model (natural boundary "
                         "conditions only); replace them by convection with a large h (penalty)")
    if system.is_steady:
        raise InputError("the reduced model needs a transient system (a [time] section and capacities c)")
    memo = {} if memo is None else memo
    rows, comm = system.rows, system.comm

    def projected(t: DistributedTerm, vector: bool) -> ProjectedTerm:
        key = id(t.operator)
        if key not in memo:
            image = convert.array(t.operator) if vector else convert.apply(t.operator, basis, rows, comm)
            memo[key] = convert.gram(basis, image, comm)
        return ProjectedTerm(t.name, t.coefficient, memo[key])

    ones = np.ones(rows.local)
    initial = tuple(ProjectedTerm(t.name, t.coefficient,
                                  convert.gram(basis, convert.apply(t.operator, ones, rows, comm), comm))
                    for t in system.capacity)
    names = tuple(system.observation)
    e_local = (np.column_stack([convert.array(system.observation[k]) for k in names]) if names
               else np.zeros((rows.local, 0)))
    return ReducedModel(
        capacity=tuple(projected(t, False) for t in system.capacity),
        conductance=tuple(projected(t, False) for t in system.conductance),
        load=tuple(projected(t, True) for t in system.load),
        initial=initial,
        output_names=names,
        output_matrix=convert.gram(e_local, basis, comm),
        parameters={k: float(v) for k, v in template.parameters.items()},
        time=template.time,
    )

