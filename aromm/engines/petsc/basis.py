"""The detailed modal basis on the petsc engine: constants + Steklov + Dirichlet modes + correction modes.

Same definitions as :func:`aromm.reduction.modal_bases.compute_basis` and
:func:`aromm.reduction.corrections.with_corrections` ([Chavez2020,
§ 3.1] and the static / first-order dynamic corrections of the loads), with the operators held by PETSc and
the vectors distributed by rows.  The small dense algebra (Gram matrices, orthonormalisation, the
enrichment) is aromm.reduction.modal_bases' own (:func:`aromm.reduction.corrections.enrich`,
:func:`aromm.reduction.modal_bases.check_gram`) with the
capacity product summed over the ranks.  The returned :class:`~aromm.reduction.modal_bases.ModalBasis` holds this rank's
rows in ``vectors``.
"""

from __future__ import annotations

import time
from collections.abc import Mapping

import numpy as np
import scipy.linalg as sla

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from aromm.engines.petsc import convert, linear, runtime
from aromm.engines.petsc.assembly import DistributedSystem
from aromm.engines.petsc.eigen import Reference, choose, dirichlet_modes, steklov_modes
from aromm.reduction.corrections import enrich
from aromm.reduction.modal_bases import ModalBasis, check_gram, reference_operators, zero_modes

#: Relative residual of the correction solves K(s) x = U_j.
CORRECTION_RTOL = 1e-12


def reference(system: DistributedSystem, values: Mapping[str, float] | None = None) -> tuple[Reference, FloatArray]:
    """Distributed K0, C0, B and ζ at the reference values (aromm.reduction.modal_bases.reference_operators), and the
    capacity-normalised constant modes (this rank's rows)."""
    template = system.template
    ops = reference_operators(template, values)  # the same checks and reference values as the serial path
    conduction = set(template.conductance.with_role("conduction").names)
    k_terms = tuple(t for t in system.conductance if t.name in conduction)
    if any(float(t.coefficient(ops.values)) <= 0 for t in k_terms):
        raise InputError("the modal bases need positive reference conductivities; got "
                         f"{ {t.name: float(t.coefficient(ops.values)) for t in k_terms} }")
    if system.boundary is None:
        raise InputError("the system has no boundary (no exchange term, no face load): Steklov modes need one")
    k0 = system.combine(k_terms, ops.values)
    c0 = system.combine(system.capacity, ops.values)
    rows, comm = system.rows, system.comm
    ones = np.ones(rows.local)
    heat, area = runtime.allsum([convert.apply(c0, ones, rows, comm).sum(),
                                 convert.apply(system.boundary, ones, rows, comm).sum()], comm)
    if not (heat > 0 and area > 0):
        raise InputError("reference capacity and boundary area must be positive to build the bases")
    ref = Reference(k0, c0, system.boundary, float(heat / area), rows, comm)
    # the whole system known to every rank: its connected components; a voxel image with every conductivity
    # positive is one connected body
    constants = (zero_modes(ops)[rows.lo:rows.hi] if system.complete
                 else np.full((rows.local, 1), 1.0 / np.sqrt(heat)))
    return ref, constants


def correction_count(system: DistributedSystem, samples: list[dict[str, float]]) -> int:
    """Correction vectors :func:`with_corrections` computes (before dropping dependent directions)."""
    return len(samples) * len(system.load) * (1 + len(system.capacity)) if system.template.load.terms else 0


def compute_basis(system: DistributedSystem, n_dirichlet: int, n_steklov: int,
                  values: Mapping[str, float] | None = None, solver: str = "gamg", *, reserve: int = 0,
                  eigensolver: str = "arpack") -> ModalBasis:
    """Constants + ``n_steklov`` Steklov (counting the constants) + ``n_dirichlet`` Dirichlet modes, by shift-invert
    (``eigensolver="arpack"``, inner ``solver``; also ``"auto"``) or the preconditioned eigensolver (``"lobpcg"``:
    aromm.engines.petsc.eigen).  ``info`` records the iterations of the preconditioned eigensolver.

    The modes are written into one Fortran-ordered array with ``reserve`` more columns, which
    :func:`with_corrections` fills (:func:`correction_count`): the basis is never copied whole."""
    if n_dirichlet < 0 or n_steklov < 1:
        raise InputError(f"mode counts must be n_dirichlet >= 0 and n_steklov >= 1, got {n_dirichlet}, {n_steklov}")
    start = time.perf_counter()
    ref, z = reference(system, values)
    n0 = z.shape[1]
    buffer = np.empty((ref.rows.local, max(n_steklov, n0) + n_dirichlet + reserve), order="F")
    buffer[:, :n0] = z
    method = choose(eigensolver)
    lam_s, v_s, its_s = steklov_modes(ref, n_steklov - n0, z, solver, method)
    buffer[:, n0:n0 + lam_s.size] = v_s
    del v_s
    t_s = time.perf_counter() - start
    lam_d, its_d = dirichlet_modes(ref, n_dirichlet, solver, buffer[:, n0 + lam_s.size:], method)
    vectors = buffer[:, :n0 + lam_s.size + lam_d.size]
    eigenvalues = np.concatenate([np.zeros(z.shape[1]), lam_s, lam_d])
    kinds = np.array(["zero"] * z.shape[1] + ["steklov"] * lam_s.size + ["dirichlet"] * lam_d.size)
    gram = convert.quadratic(ref.capacity, vectors, vectors, ref.comm)
    cond = check_gram(gram)
    return ModalBasis(vectors, eigenvalues, kinds, ref.zeta, gram,
                      {"seconds": time.perf_counter() - start, "steklov_seconds": t_s, "cached": 0.0,
                       "gram_condition": cond, "steklov_iterations": float(its_s),
                       "dirichlet_iterations": float(its_d)})


def with_corrections(system: DistributedSystem, basis: ModalBasis, samples: list[dict[str, float]],
                     values: Mapping[str, float] | None = None, solver: str = "gamg") -> ModalBasis:
    """The basis enriched with the static and first-order dynamic correction modes of the loads at each
    parameter sample (aromm.reduction.corrections.with_corrections), solved by PETSc."""
    template = system.template
    if not template.load.terms:
        return basis
    comm = system.comm
    # C0 only (the C0 product of the enrichment): K0 of reference() is not needed here
    capacity = system.combine(system.capacity, reference_operators(template, values).values)
    exchange = bool(template.conductance.with_role("exchange"))
    count = correction_count(system, samples)
    room = _reserved(basis.vectors, count)  # the correction vectors go where the correction modes will be
    cols = np.empty((basis.vectors.shape[0], count), order="F") if room is None else room
    j = 0
    for sample in samples:
        v = template.values({k: val for k, val in sample.items() if k in template.parameter_names})
        k_mat = system.combine(system.conductance, v)
        if not exchange:  # K singular: shift by a tiny multiple of the capacity, as the serial path does
            c_mat = system.combine(system.capacity, v)
            trace = runtime.allsum([convert.array(k_mat.getDiagonal()).sum(),
                                    convert.array(c_mat.getDiagonal()).sum()], comm)
            k_mat.axpy(1e-8 * trace[0] / trace[1], c_mat,
                       structure=runtime.petsc().Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        ksp = linear.krylov(k_mat, solver, CORRECTION_RTOL, "aromm_correction_")
        for t in system.load:
            x = k_mat.createVecRight()
            x.set(0.0)
            linear.solve(ksp, t.operator, x, "correction modes", CORRECTION_RTOL)
            cols[:, j] = x.getArray(readonly=True)
            j += 1
            for c in system.capacity:
                rhs = c.operator.createVecLeft()
                c.operator.mult(x, rhs)
                y = k_mat.createVecRight()
                y.set(0.0)
                linear.solve(ksp, rhs, y, "correction modes", CORRECTION_RTOL)
                cols[:, j] = y.getArray(readonly=True)
                j += 1
        ksp.destroy()  # one multigrid hierarchy (or factorisation) alive at a time (peak memory)
        k_mat.destroy()
    extra, coefficients = enrich(cols[:, :j], basis, lambda a, b: convert.quadratic(capacity, a, b, comm))
    del cols  # read by enrich only: its columns now receive the correction modes
    return ModalBasis(_extended(basis.vectors, extra),
                      np.concatenate([basis.eigenvalues, np.full(extra.shape[1], np.nan)]),
                      np.concatenate([basis.kinds, np.array(["correction"] * extra.shape[1])]),
                      basis.zeta, sla.block_diag(basis.gram, np.eye(extra.shape[1])),
                      {**basis.info, "corrections": float(coefficients.shape[1])}, coefficients)


def _reserved(vectors: FloatArray, m: int) -> FloatArray | None:
    """The ``m`` columns :func:`compute_basis` reserved after ``vectors`` (a view of the same array), or None."""
    base = vectors.base
    r = vectors.shape[1]
    if (isinstance(base, np.ndarray) and base.ndim == 2 and base.flags.f_contiguous and base.shape[1] >= r + m
            and base.shape[0] == vectors.shape[0] and vectors.ctypes.data == base.ctypes.data):
        return base[:, r:r + m]
    return None


def _extended(vectors: FloatArray, extra: FloatArray) -> FloatArray:
    """``[vectors, extra]``: written into the reserved columns when they suffice (no copy of the basis), else a
    new array."""
    room = _reserved(vectors, extra.shape[1])
    if room is None:
        return np.column_stack([vectors, extra])
    room[:] = extra
    base = vectors.base
    assert isinstance(base, np.ndarray)  # _reserved found it
    return base[:, :vectors.shape[1] + extra.shape[1]]
