"""Homogenised heat and moisture transport of a voxel image (:mod:`aromm.physics.hygrothermal`): per axis the
effective 2 × 2 flux matrix, by the fixed-value probe of the field's convention, and the mean moisture capacity.

Per axis i, with (T, φ) fixed on the faces i0 and i1 and the other faces adiabatic and sealed, two steady solves of
the coupled system (the symmetrised one: its moisture row is the moisture balance times λ) give the flows through
the fixed face i0 for a unit jump of T, then of φ: the heat flow Q and the moisture flow G = (reaction of the φ rows)
/ λ (the probe: :func:`fixed_value_probe`, its other faces adiabatic and sealed whatever the scene sets there; the
loop: :func:`fixed_value_transport`, shared with the petsc engine's distributed solves).  The effective matrix in
physical units (heat flux W/m², moisture flux kg/(m² s)) is

    [[Q_T, Q_φ], [G_T, G_φ]] · L_i / A_i   ≈   [[k + L_v δ_p a, L_v δ_p p], [δ_p a, D_φ + δ_p p]]  (effective),

assembled by the scene's own discretisation (q1; fv within one phase).  Its (1, 1) entry is the conductivity with
the humidity held (k̄ of the `temperature` probe plus the latent heat carried by the vapour), its (2, 2) entry the
moisture conductivity at constant temperature.  On a laminate it is exactly the arithmetic mean of the phases'
matrices along the layers and their matrix harmonic mean across them (the symmetrised matrices;
tests/test_hygrothermal.py).  The mean moisture capacity ξ̄ is the volume average (as c̄, [Chavez2020, eq. 14]).
The flux probe ([Chavez2020, eq. 13] for both fields, :func:`flux_transport`) imposes a unit heat, then water, flux
on one face and reads the mean jumps.  The periodic cell (:func:`periodic_transport`, Q1) gives the full effective
tensor of the periodic medium the image tiles, off-diagonal blocks included.  Steady solves of the assembled system:
images of a few 10⁴ voxels.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np
import scipy.sparse as sp

from aromm.core.errors import InputError
from aromm.core.observables import PHI_PREFIX
from aromm.core.system import FloatArray, ThermalSystem
from aromm.core.vocabulary import FaceSpec
from aromm.fem.voxel import assemble_voxels
from aromm.fem.voxel_grid import node_points
from aromm.full.solve import reaction_heat_flow, steady_field
from aromm.homogenization.anisotropic_cells import periodic_map
from aromm.linalg.direct import factorize
from aromm.physics.hygrothermal import coupled
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.moisture_section import MoistureScene
from aromm.scene.scene_file import Scene, assemble

AXES = "xyz"


def moisture_transport(scene: Scene, method: str = "auto", boundary: str = "temperature") -> FloatArray:
    """(3, 2, 2): per axis the effective flux matrix in physical units (module docstring) of the scene's image with
    its ``[moisture]`` properties, by the fixed-value probe (``temperature``), the flux probe (``flux``,
    :func:`flux_transport`) or the periodic cell (``periodic``, the diagonal blocks of :func:`periodic_transport`);
    ``method`` the steady solver (:mod:`aromm.linalg.direct`)."""
    if boundary == "flux":
        return flux_transport(scene, method)
    if boundary == "periodic":
        full = periodic_transport(scene, method)
        return np.stack([full[axis, axis] for axis in range(3)])
    if boundary != "temperature":
        raise InputError(f"moisture transport: boundary must be periodic, temperature or flux, got {boundary!r}")
    return fixed_value_transport(scene, lambda probe: _direct_solves(assemble(probe), method))


def fixed_value_probe(scene: Any, axis: int) -> Any:
    """The probe of the fixed-value transport along ``axis`` (0, 1, 2) of a Scene or the petsc engine's VoxelProblem
    (the same type back): (T, φ) held on the faces i0 and i1 (at the parameters ``i0.T``, ``i0.phi``, …, 0 unless
    set), the other faces adiabatic and sealed (no heat or water flux, no vapour exchange), no outputs."""
    moisture = require_moisture(scene)
    fixed = {f"{AXES[axis]}0": 0.0, f"{AXES[axis]}1": 0.0}
    return replace(scene.with_boundary(tuple(FaceSpec(face, T=0.0) for face in fixed), ()),
                   moisture=replace(moisture, fixed_phi=fixed, vapour={}, flux={}, outputs=()))


#: A steady solve of a probe at the parameter values given: its face means (°C, and φ as ``phi:<face>``) and the
#: reactions (W; λ × kg/s for a φ set) through each of its fixed sets, keyed by the set's parameter.
ProbeSolve = Callable[[dict[str, float]], tuple[Mapping[str, float], Mapping[str, float]]]
#: ``prepare(probe)`` assembles a probe (Scene or VoxelProblem) and gives its :data:`ProbeSolve`.
ProbeSolves = Callable[[Any], ProbeSolve]


def fixed_value_transport(scene: Any, prepare: ProbeSolves) -> FloatArray:
    """(3, 2, 2): :func:`moisture_transport`'s fixed-value probe (module docstring) with the steady solves of
    ``prepare`` (direct here; distributed: :mod:`aromm.engines.petsc.homogenization`): the probes of
    :func:`fixed_value_probe`, the flows through the face i0 for a unit jump of T, then of φ."""
    moisture = require_moisture(scene)
    size = scene.size
    out = np.zeros((3, 2, 2))
    for axis, name in enumerate(AXES):
        solve = prepare(fixed_value_probe(scene, axis))  # the scene's own discretisation and refusals
        area = float(np.prod(size)) / size[axis]
        for column, jump in enumerate(({f"{name}0.T": 1.0}, {f"{name}0.phi": 1.0})):
            flows = solve(jump)[1]
            out[axis, :, column] = np.array([flows[f"{name}0.T"], flows[f"{name}0.phi"] / moisture.state.weight]) \
                * size[axis] / area
    return out


def _direct_solves(system: ThermalSystem, method: str) -> ProbeSolve:
    def solve(values: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
        field = steady_field(system, values, method=method)
        return ({name: float(np.asarray(row @ field).ravel()[0]) for name, row in system.observation.items()},
                {d.param: reaction_heat_flow(system, field, d.dofs, values) for d in system.dirichlet})

    return solve


def flux_transport(scene: Scene, method: str = "auto") -> FloatArray:
    """(3, 2, 2): per axis the effective flux matrix by the flux probe of [Chavez2020, eq. 13], for both fields: a
    unit heat flux (W/m²), then a unit water flux (kg/(m² s), :func:`aromm.physics.hygrothermal.coupled`'s
    ``moisture_flux``) enters through the face i0, (T, φ) = 0 is held on i1, the other faces are adiabatic and
    sealed (:func:`flux_probe`).  The mean jumps (T̄, φ̄ on i0) of the two solves are the columns of ``L F⁻¹``, so
    ``F = L M⁻¹`` (:func:`flux_probe_transport`)."""
    return flux_probe_transport(scene, lambda probe: _direct_solves(assemble(probe), method))


def flux_probe(scene: Any, axis: int) -> Any:
    """The flux probe along ``axis`` of a Scene or a VoxelProblem (the same type back): a heat flux (parameter
    ``i0.flux``) and a water flux (``i0.g``) on i0, its face means the outputs, (T, φ) = 0 held on i1, the other faces
    adiabatic and sealed."""
    moisture = require_moisture(scene)
    hot, cold = f"{AXES[axis]}0", f"{AXES[axis]}1"
    area = float(np.prod(scene.size)) / scene.size[axis]
    return replace(scene.with_boundary((FaceSpec(hot, flux=0.0), FaceSpec(cold, T=0.0)), (hot,)),
                   moisture=replace(moisture, fixed_phi={cold: 0.0}, vapour={}, flux={hot: (0.0, area)},
                                    outputs=(hot,)))


def flux_probe_transport(scene: Any, prepare: ProbeSolves) -> FloatArray:
    """(3, 2, 2): :func:`flux_transport` with the steady solves of ``prepare`` (direct here; distributed:
    :mod:`aromm.engines.petsc.homogenization`) on the probes of :func:`flux_probe`."""
    size = scene.size
    out = np.zeros((3, 2, 2))
    for axis, name in enumerate(AXES):
        solve = prepare(flux_probe(scene, axis))
        jumps = np.zeros((2, 2))
        for column, load in enumerate(({f"{name}0.flux": 1.0}, {f"{name}0.g": 1.0})):
            means = solve(load)[0]
            jumps[:, column] = [means[f"{name}0"], means[PHI_PREFIX + f"{name}0"]]
        out[axis] = size[axis] * np.linalg.inv(jumps)
    return out


def periodic_transport(scene: Scene, method: str = "auto") -> FloatArray:
    """(3, 3, 2, 2): the effective flux tensor of the periodic medium the image tiles, in physical units: block
    [i, j] maps the macroscopic gradients along j of (T, φ) to the (heat, moisture) fluxes along i (the module
    docstring's matrix when i = j).

    As the thermal periodic cell (:mod:`aromm.homogenization.anisotropic_cells`), on the coupled Q1 operator K of the
    box (2n unknowns, all faces free: the symmetrised one of :mod:`aromm.physics.hygrothermal`, whose moisture rows
    are the moisture balance times λ): opposite nodes identified by P (both fields), for each field f and axis j the
    gradient g = x_j on the f block, and PᵀKP T̃ = b = −PᵀK g with T̃ periodic (one node of each field pinned: the
    constants of both fields are its null space).  The symmetrised tensor is ``S[(f,i),(h,j)] |Ω| = g_{f,i}ᵀ K g_{h,j}
    − b_{f,i}ᵀ T̃_{h,j}`` (energy identity); its moisture rows divided by λ are the physical fluxes."""
    image, moisture = scene.geometry, require_moisture(scene)
    if not isinstance(image, VoxelGeometry) or scene.discretisation != "q1":
        raise InputError(f"{scene.where}moisture transport: the periodic cell is solved on the Q1 elements of a voxel "
                         "image (finite volumes: --boundary temperature or flux)")
    system = coupled(assemble_voxels(image.labels, image.voxel_size, scene.phases), moisture.state, moisture.phases)
    k_box = sp.csr_array(system.conductance.evaluate(system.values()))
    nodes = k_box.shape[0] // 2
    p_one = periodic_map(image.shape)
    p_map = sp.csr_array(sp.block_diag([p_one, p_one]))
    k_per = sp.csr_array(p_map.T @ k_box @ p_map)
    cells = p_one.shape[1]
    keep = np.ones(2 * cells)
    keep[[0, cells]] = 0.0  # T̃ and φ̃ pinned at node 0: the loads sum to zero in each field
    pin = sp.diags_array(keep)
    points = node_points(image.shape, image.voxel_size)
    first = np.unique(p_one.indices, return_index=True)[1]
    factor = factorize(sp.csr_array(pin @ k_per @ pin + sp.diags_array(1.0 - keep)), method,
                       points=np.vstack([points[first], points[first]]) if method != "amg" else None)
    grads = [np.concatenate([points[:, j], np.zeros(nodes)] if f == 0 else [np.zeros(nodes), points[:, j]])
             for f in range(2) for j in range(3)]  # (T, x), (T, y), (T, z), (φ, x), …
    loads = [-(p_map.T @ (k_box @ g)) for g in grads]
    fields = [factor.solve(b * keep) for b in loads]
    sym = np.array([[float(gi @ (k_box @ gj)) - float(bi @ fj) for gj, fj in zip(grads, fields, strict=True)]
                    for gi, bi in zip(grads, loads, strict=True)]) / float(np.prod(scene.size))
    physical = sym.reshape(2, 3, 2, 3).transpose(1, 3, 0, 2)  # [i, j, f, h]
    physical[:, :, 1, :] /= moisture.state.weight
    return physical


def mean_moisture_capacity(scene: Scene) -> float:
    """ξ̄ (kg/m³): the volume average of the phases' ξ."""
    moisture = require_moisture(scene)
    fractions = scene.volume_fractions()
    return float(sum(fractions[name] * values["xi"] for name, values in moisture.phases.items()))


def require_moisture(scene: Any) -> MoistureScene:
    """The scene's ``[moisture]`` part (a Scene or a VoxelProblem), refused without one."""
    if scene.moisture is None:
        raise InputError(f"{scene.where}moisture: the homogenised moisture transport needs a [moisture] section")
    return scene.moisture
