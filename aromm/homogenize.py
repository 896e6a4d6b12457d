"""Homogenisation of a two-phase (or n-phase) voxel scene (seed 001 section 4.2).

Effective conductivity by the flux method (seed 001 eq. 13): for each axis i a uniform
flux q enters face i0, face i1 is held at T = 0, the four other faces are adiabatic,
and at steady state

    k_ii = q L_i / (T̄_{i0} - T̄_{i1}),

with T̄ the face-mean temperatures (``boundary="flux"``, the default).  Imposing a
uniform flux is a static (Neumann-type) condition: along the layers of a laminate it
gives less than the arithmetic mean, because the heated face is not isothermal.
``boundary="temperature"`` holds both faces at fixed temperatures instead (T = 1 on i0,
T = 0 on i1) and takes the heat flow Q from the reaction at i0, k_ii = Q L_i / (A_i ΔT):
exact for laminates in both directions and for mirror-symmetric periodic cells.

Both give the principal values along the image axes (the material is taken orthotropic
in those axes, as in the seed); the off-diagonal entries of the returned tensor are zero.  The effective capacity is the
volume average (eq. 14): c̄ = Σ_phases c_p |Ω_p| / |Ω|.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from aromm.errors import InputError
from aromm.fem import FaceSpec, PhaseSpec
from aromm.scene import Scene, assemble
from aromm.solve import steady_field
from aromm.system import FloatArray

MESH_TWIN_CELLS = 32  # elements along a loaded axis of the twin of a mesh scene (no voxel size to inherit)
PROBE_FLUX = 1.0  # W/m^2; the problem is linear, so any value gives the same k


BOUNDARIES = ("flux", "temperature")


def homogenize(scene: Scene, boundary: str = "flux", method: str = "auto") -> FloatArray:
    """Effective conductivity tensor (3x3, W/(m K)); ``boundary="flux"`` is seed 001 eq. 13.

    Uses the scene's geometry and phases only; it applies the boundary conditions itself.
    ``method`` is the linear solver (aromm.linalg).
    """
    if boundary not in BOUNDARIES:
        raise InputError(f"unknown homogenisation boundary {boundary!r}; allowed: {', '.join(BOUNDARIES)}")
    k = np.zeros((3, 3))
    size = scene.size
    for i, axis in enumerate("xyz"):
        hot, cold = f"{axis}0", f"{axis}1"
        area = size[0] * size[1] * size[2] / size[i]
        if boundary == "flux":
            system = assemble(_probe(scene, FaceSpec(hot, flux=PROBE_FLUX), FaceSpec(cold, T=0.0)))
            field = steady_field(system, method=method)
            drop = float(system.observation[hot] @ field - system.observation[cold] @ field)
            k[i, i] = PROBE_FLUX * size[i] / drop
        else:
            system = assemble(_probe(scene, FaceSpec(hot, T=1.0), FaceSpec(cold, T=0.0)))
            field = steady_field(system, method=method)
            reaction = sp.csr_array(system.conductance.evaluate(system.values())) @ field
            heat_flow = float(reaction[system.dirichlet[0].dofs].sum())
            k[i, i] = heat_flow * size[i] / area
    return k


def _probe(scene: Scene, hot: FaceSpec, cold: FaceSpec) -> Scene:
    """The scene's material, steady, with only the two probe faces loaded."""
    return scene.with_boundary((hot, cold), (hot.face, cold.face), time=None)


def mean_capacity(scene: Scene) -> float:
    """Volume-averaged volumetric heat capacity c̄ (J/(m^3 K)), seed 001 eq. 14."""
    missing = [ph.name for ph in scene.phases if ph.c is None]
    if missing:
        raise InputError(f"mean capacity needs c for every phase; missing for {missing}")
    fractions = scene.volume_fractions()
    return float(sum(fractions[ph.name] * float(ph.c) for ph in scene.phases if ph.c is not None))


def homogeneous_twin(scene: Scene, k: FloatArray, c: float, name: str = "homogeneous") -> Scene:
    """The homogeneous orthotropic model of seed 001 eq. 1 on the same box and boundary conditions.

    Material: one phase with k = diag(k) and capacity c.  Its mesh keeps the scene's
    resolution (32 elements for a mesh scene) only along axes that carry a face condition; along the others one element
    spans the box, which is exact because the solution does not vary along an axis whose
    faces are both adiabatic (uniform face conditions, diagonal k).
    """
    diag = np.diag(np.asarray(k, dtype=float))
    if np.any(~np.isfinite(diag)) or np.any(diag <= 0):
        raise InputError(f"homogeneous model needs positive finite k_xx, k_yy, k_zz, got {diag.tolist()}")
    loaded = {f.face[0] for f in scene.boundary}
    cells = scene.labels.shape if scene.mesh is None else (MESH_TWIN_CELLS,) * 3
    shape = tuple(n if ax in loaded else 1 for n, ax in zip(cells, "xyz", strict=True))
    vx, vy, vz = (L / n for n, L in zip(shape, scene.size, strict=True))
    phase = PhaseSpec(name, 0, (float(diag[0]), float(diag[1]), float(diag[2])), float(c))
    return replace(scene, labels=np.zeros(shape, dtype=np.int64), voxel_size=(vx, vy, vz), phases=(phase,),
                   interfaces={}, mesh=None)
