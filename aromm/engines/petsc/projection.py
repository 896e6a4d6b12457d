"""Galerkin projection of a distributed ThermalSystem onto a distributed basis [Chavez2020, eq. 10].

Every term keeps its name and coefficient and gets ``Ψᵀ C_j Ψ``, ``Ψᵀ K_j Ψ`` (r × r) or ``Ψᵀ F_j`` (r): each
rank multiplies its rows (a few basis columns at a time, into one reused work block: no temporary of the
basis's size, :func:`aromm.engines.petsc.convert.quadratic`) and the small products are summed over the ranks, so
every rank ends with the same :class:`~aromm.reduction.rom.ReducedModel`, built by its public constructor (a projected
ThermalSystem and the initial-state terms) exactly as :meth:`ReducedModel.from_system` builds it in one process.
"""

from __future__ import annotations

import numpy as np

from aromm.core.system import (
    PENALTY_INSTEAD,
    Affine,
    Coefficient,
    FloatArray,
    Term,
    ThermalSystem,
    require_free_transient,
)
from aromm.engines.petsc import convert
from aromm.engines.petsc.assembly import DistributedSystem, DistributedTerm
from aromm.reduction.rom import ReducedModel


def project(system: DistributedSystem, basis: FloatArray, memo: dict[int, FloatArray] | None = None) -> ReducedModel:
    """The reduced model of ``system`` on the columns of ``basis`` (this rank's rows, n_local × r).

    ``memo`` (id of a PETSc operator → projection) shares work between systems with common terms.
    """
    template = system.template
    require_free_transient(template, "the reduced model", PENALTY_INSTEAD)
    memo = {} if memo is None else memo
    rows, comm = system.rows, system.comm

    def projected(terms: tuple[DistributedTerm, ...], vector: bool) -> Affine:
        out = []
        for t in terms:
            key = id(t.operator)
            if key not in memo:
                memo[key] = (convert.gram(basis, convert.array(t.operator), comm) if vector
                             else convert.quadratic(t.operator, basis, basis, comm))
            out.append(Term(t.name, t.coefficient, memo[key], t.role, template.load[t.name].time if vector else None))
        return Affine(tuple(out))

    # Ψᵀ C_t T0 per capacity term t and part of T0 = initial.T 1 + Σ_i c_i(p) v_i (a coupled system's v_i put
    # initial.phi on φ), named and ordered as ReducedModel.from_system names them
    fields = [(Coefficient(("initial.T",)), np.ones(rows.local), "")]
    fields += [(t.coefficient, convert.array(t.operator), f"·{t.name}") for t in system.initial]
    initial = Affine(tuple(
        Term(t.name + suffix, t.coefficient.times(coef),
             convert.gram(basis, convert.apply(t.operator, vec, rows, comm), comm), "capacity")
        for coef, vec, suffix in fields for t in system.capacity))
    observation = {k: convert.gram(convert.array(v)[:, None], basis, comm)[0] for k, v in system.observation.items()}
    reduced = ThermalSystem(
        n=basis.shape[1],
        conductance=projected(system.conductance, False),
        capacity=projected(system.capacity, False),
        load=projected(system.load, True),
        observation=observation,
        parameters={k: float(v) for k, v in template.parameters.items()},
        time=template.time,
    )
    return ReducedModel(reduced, initial)
