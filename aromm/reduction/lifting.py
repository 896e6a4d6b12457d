"""Fixed temperatures for the modal reduction: lifting onto the free unknowns.

The reduced model expands the temperature on modes that satisfy no boundary condition of their own
(natural conditions, [Chavez2020, § 3.1]).  A face held at ``T_d(t) = τ_d g_d(t)`` (parameter ``τ_d``,
e.g. ``x0.T``; history ``g_d``, 1 when constant) is an essential condition; it is carried by a lifting

    T = Σ_d τ_d g_d(t) ℓ_d + θ,        θ = 0 on the fixed nodes,

where ``ℓ_d`` is the steady solution at the reference values p0 (the basis values) that is 1 on the
nodes of face d, 0 on the other fixed nodes and has no other load: ``K(p0)_ff ℓ_f = −K(p0)_fd ℓ_d``.  The
lifting is a fixed vector, so the equation for θ on the free unknowns stays affine in the parameters::

    C_ff(p) θ̇ + K_ff(p) θ = F_f(p, t) − Σ_d τ_d [ g_d(t) Σ_j k_j(p) (K_j ℓ_d)_f + ġ_d(t) Σ_j c_j(p) (C_j ℓ_d)_f ],
    θ(0) = initial.T − Σ_d τ_d g_d(0) ℓ_d,f,          y = E_f θ + Σ_d τ_d g_d(t) E ℓ_d.

Every conduction/exchange term j gives one load term with the coefficient ``k_j τ_d`` and the history
``g_d``; every capacity term one with ``c_j τ_d`` and the piecewise-constant history ``ġ_d`` (only when
g_d varies); the outputs gain a feedthrough.  At p = p0 the conduction loads cancel (ℓ is harmonic
there); elsewhere they are the residual ``K(p) ℓ``, which the static correction vectors of
:func:`aromm.reduction.corrections.with_corrections` resolve exactly at their samples.

The basis for θ is then built on the free unknowns: the Dirichlet modes vanish on the whole boundary
Γ as before, the Steklov modes solve ``K0_ff v = λ ζ B_ff v``, i.e. they vanish on the fixed face and
satisfy the Steklov condition on the free boundary Γ \\ Γ_D, and the constant is no longer a mode (it
does not vanish on Γ_D) unless a component of the body touches no fixed face.  The lifted system is an
ordinary :class:`~aromm.core.system.ThermalSystem` (its ``initial`` and ``feedthrough`` groups carry the
lifting), so the full solver reproduces the original system's outputs from it exactly (tested): the
lifting itself adds no error, the reduced model's error is that of the basis.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.profiles import Profile
from aromm.core.system import Affine, Coefficient, FloatArray, Geometry, Term, ThermalSystem, is_matrix_free, sparse
from aromm.fem.voxel_terms import as_voxel_terms, harmonic_extension, is_voxel_family
from aromm.linalg.direct import factorize

#: Unknowns from which a system of matrix-free voxel terms is lifted by matrix-free multigrid (below: assembled).
MATRIX_FREE_LIFTING = 20_000


def _restricted(affine: Affine, free: np.ndarray) -> list[Term]:
    """The terms on the free unknowns: ``A_ff`` for a matrix, ``f_f`` for a vector."""
    out = []
    for t in affine.terms:
        op = t.operator
        if is_matrix_free(op):  # a voxel term stays matrix-free when the fixed nodes are whole faces
            sub = op.restricted(free) or sparse(op)[free][:, free]  # type: ignore[union-attr]
        else:
            sub = sp.csr_array(sp.csr_array(op)[free][:, free]) if sp.issparse(op) else np.asarray(op)[free]
        out.append(Term(t.name, t.coefficient, sub, t.role, t.time))
    return out


#: A lifting load ``(A_j ℓ)_f`` below this fraction of ``‖A_j‖ ‖ℓ‖`` (max norms) is round-off: dropped.  It
#: happens for every term of a one-phase body, whose lifting is harmonic for any conductivity.
NULL_LOAD = 1e-12


def _lifting_loads(affine: Affine, vec: FloatArray, free: np.ndarray, scale: Coefficient, *, suffix: str,
                   time: Profile | None) -> list[Term]:
    """``−c_j τ_d (A_j ℓ_d)_f`` for every term j of ``affine`` (with the history ``time``), null ones dropped."""
    out = []
    for t in affine.terms:
        load = -np.asarray(t.operator @ vec)[free]
        largest = t.operator.abs_max() if is_matrix_free(t.operator) else float(  # type: ignore[union-attr]
            np.abs(sp.csr_array(t.operator).data).max(initial=0.0))
        size = largest * float(np.abs(vec).max(initial=0.0))
        if float(np.abs(load).max(initial=0.0)) > NULL_LOAD * size:
            out.append(Term(f"{t.name}·{suffix}", t.coefficient.times(scale), load, "load", time))
    return out


def liftings(system: ThermalSystem, values: Mapping[str, float] | None = None, method: str = "auto") -> FloatArray:
    """The lifting vectors ℓ_d (n, n_dirichlet): steady at the reference ``values`` (overrides of the system's
    parameters), 1 on the nodes fixed by set d, 0 on the other fixed nodes (module doc)."""
    owner = system.fixed_owner()
    free, fixed = np.flatnonzero(owner < 0), np.flatnonzero(owner >= 0)
    if free.size == 0:
        raise InputError("every unknown has a fixed temperature: nothing to reduce")
    vals = system.values({k: v for k, v in (values or {}).items() if k in system.parameter_names})
    ell = np.zeros((system.n, len(system.dirichlet)))
    for i in range(len(system.dirichlet)):
        ell[fixed, i] = (owner[fixed] == i).astype(float)
    ops = [t.operator for t in system.conductance.terms]
    if is_voxel_family(ops) and method in ("auto", "mg") and system.n >= MATRIX_FREE_LIFTING:
        weights = [float(t.coefficient(vals)) for t in system.conductance.terms]
        for i in range(ell.shape[1]):
            ell[:, i] = harmonic_extension(as_voxel_terms(ops), weights, ell[:, i], free)
        return ell
    k = sp.csr_array(system.conductance.evaluate(vals))
    rows = k[free]
    k_ff, k_fd = sp.csr_array(rows[:, free]), sp.csr_array(rows[:, fixed])
    ell = np.zeros((system.n, len(system.dirichlet)))
    for i in range(len(system.dirichlet)):
        ell[fixed, i] = (owner[fixed] == i).astype(float)
    points = system.unknown_points()
    points = None if points is None else points[free]
    fac = factorize(k_ff, method, points=points)
    for i in range(ell.shape[1]):
        ell[free, i] = fac.solve(-(k_fd @ ell[fixed, i]))
    return ell


def lift(system: ThermalSystem, values: Mapping[str, float] | None = None, method: str = "auto") -> ThermalSystem:
    """The system for θ on the free unknowns (module doc); a system without fixed temperatures is returned as is.

    ``values`` are the reference values p0 of the liftings (the basis values of the reduction).
    """
    if not system.dirichlet:
        return system
    if system.is_steady:
        raise InputError("lifting fixed temperatures is for transient systems (the reduced model)")
    ell = liftings(system, values, method)
    owner = system.fixed_owner()
    free = np.flatnonzero(owner < 0)
    loads = _restricted(system.load, free)
    initial = _restricted(system.initial, free)
    names, e = system.observation_matrix()
    e_free = e[:, free]  # dense rows, or CSR when there are sensors (aromm.scene.sensors)
    direct = list(system.feedthrough.terms)
    for i, d in enumerate(system.dirichlet):
        vec = ell[:, i]
        scale = Coefficient((d.param,))
        loads += _lifting_loads(system.conductance, vec, free, scale, suffix=f"lift_{d.name}", time=d.time)
        if d.time is not None and not d.time.is_constant:
            loads += _lifting_loads(system.capacity, vec, free, scale, suffix=f"dlift_{d.name}",
                                    time=d.time.derivative())
        start = 1.0 if d.time is None else float(d.time(0.0))
        if start != 0.0:
            initial.append(Term(f"lift_{d.name}", Coefficient((d.param,), scale=-start), vec[free], "initial"))
        if names:
            direct.append(Term(f"lift_{d.name}", scale, e @ vec, "output", d.time))
    geometry = None
    points = system.unknown_points()
    if system.geometry is not None and points is not None:  # the free unknowns' points, for orderings (no cells;
        geo = system.geometry  # several fields' unknowns are not a mesh's nodes: "vertex", no node-grid solver)
        geometry = Geometry(points[free], np.zeros((0, geo.cells.shape[1]), dtype=np.int64),
                            geo.cell_type if len(system.fields) == 1 else "vertex")
    boundary = sp.csr_array(system.boundary[free][:, free]) if system.boundary is not None else None
    return ThermalSystem(
        n=free.size,
        conductance=Affine(tuple(_restricted(system.conductance, free))),
        capacity=Affine(tuple(_restricted(system.capacity, free))),
        load=Affine(tuple(loads)),
        observation={name: e_free[[j]] if sp.issparse(e_free) else e_free[j] for j, name in enumerate(names)},
        parameters=dict(system.parameters),
        time=system.time,
        geometry=geometry,
        boundary=boundary,
        initial=Affine(tuple(initial)),
        feedthrough=Affine(tuple(direct)),
    )
