"""Cases of the petsc engine's homogenised heat and moisture transport (the fixed-value probe,
aromm.engines.petsc.homogenization.moisture_transport), computed the same way at 1 rank in the pytest process and under
``mpiexec`` (``petsc_worker.py OUT.npz petsc_moisture_homog_cases``): the two-phase 6×5×4 image of
tests/petsc_moisture_cases.py (its face conditions, a moisture flux among them, are the probe's to replace) in Q1 and
in finite volumes, and a two-phase laminate across x (whose effective matrices are exact means).

:func:`solve_bound` is the tolerance of a petsc entry against a direct solve, from the solver's own: each coupled
steady solve is CG on the diagonally scaled system ``Â ŷ = s ∘ b`` (Â = S A S, S = diag(A)^-1/2, identity rows and
columns on the fixed unknowns as PETSc eliminates them) to the relative residual ``rtol = linear.tolerance(STEADY_RTOL,
2)``, so ``‖δŷ‖ ≤ κ(Â) rtol ‖ŷ‖`` [Higham2002, § 7.1]; the flow through a fixed set D is ``1_Dᵀ (K x − F)``, whose
error is ``(1_Dᵀ K S) δŷ``, at most ``‖1_Dᵀ K S‖ κ rtol ‖ŷ‖`` (then × L_i / A_i, and / λ for the moisture flow).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import petsc_moisture_cases as coupled_cases

from aromm.core.vocabulary import PhaseSpec
from aromm.physics.hygrothermal import MoistureState
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.moisture_section import MoistureScene
from aromm.scene.scene_file import Scene, assemble

DISCRETISATIONS = coupled_cases.DISCRETISATIONS
STATE = MoistureState(T_ref=20.0, phi_ref=0.5)
#: The laminate's phases: k (W/(m K)), D_φ, δ_p (kg/(m s)), ξ (kg/m³), as tests/test_hygrothermal.py's.
LAYERS = {"wall": (0.3, 2e-9, 1e-13, 200.0), "air": (0.025, 0.0, 2e-10, 0.017)}


def image_scene(discretisation: str) -> Scene:
    return coupled_cases.steady_scene(discretisation)


def laminate() -> Scene:
    """Two layers across x (4×3×3 voxels of 10 µm), wall then air."""
    labels = np.zeros((4, 3, 3), dtype=np.int32)
    labels[2:] = 1
    phases = tuple(PhaseSpec(name, i, v[0], 1e6) for i, (name, v) in enumerate(LAYERS.items()))
    moisture = MoistureScene(STATE, {n: {"D_phi": v[1], "delta_p": v[2], "xi": v[3]} for n, v in LAYERS.items()},
                             {}, 0.5)
    return Scene(VoxelGeometry(labels, (1e-5, 1e-5, 1e-5)), phases, moisture=moisture)


def laminate_means() -> np.ndarray:
    """(3, 2, 2): the laminate's exact effective matrices: across x the matrix harmonic mean of the phases'
    symmetrised matrices, along y and z their arithmetic mean (tests/test_hygrothermal.py)."""
    lv, a, p = STATE.latent_heat, STATE.a, STATE.p
    weight = np.diag([1.0, STATE.weight])
    sym = [weight @ np.array([[k + lv * dp * a, lv * dp * p], [dp * a, d + dp * p]])
           for k, d, dp, _ in LAYERS.values()]
    series = np.linalg.inv(weight) @ np.linalg.inv((np.linalg.inv(sym[0]) + np.linalg.inv(sym[1])) / 2)
    parallel = np.linalg.inv(weight) @ ((sym[0] + sym[1]) / 2)
    return np.stack([series, parallel, parallel])


def solve_bound(scene: Scene) -> np.ndarray:
    """(3, 2, 2): the bound of the module docstring on each entry of the petsc engine's matrix of ``scene``."""
    from aromm.engines.petsc import linear
    from aromm.full.solve import steady_field
    from aromm.homogenization.moisture_cells import AXES, fixed_value_probe

    rtol = linear.tolerance(linear.STEADY_RTOL, 2)
    assert scene.moisture is not None
    size, weight = scene.size, scene.moisture.state.weight
    out = np.zeros((3, 2, 2))
    for axis, name in enumerate(AXES):
        system = assemble(fixed_value_probe(scene, axis))
        k = system.conductance.evaluate(system.values()).toarray()
        fixed = np.concatenate([d.dofs for d in system.dirichlet])
        a = k.copy()
        a[fixed, :] = 0.0
        a[:, fixed] = 0.0
        a[fixed, fixed] = 1.0
        s = 1.0 / np.sqrt(np.diag(a))
        kappa = float(np.linalg.cond(s[:, None] * a * s[None, :]))
        sets = {d.param: d.dofs for d in system.dirichlet}
        area = float(np.prod(size)) / size[axis]
        for column, jump in enumerate(({f"{name}0.T": 1.0}, {f"{name}0.phi": 1.0})):
            y = steady_field(system, jump, method="splu") / s
            for row, (param, divide) in enumerate(((f"{name}0.T", 1.0), (f"{name}0.phi", weight))):
                gain = float(np.linalg.norm(k[sets[param]].sum(axis=0) * s))
                out[axis, row, column] = gain * kappa * rtol * float(np.linalg.norm(y)) / divide * size[axis] / area
    return out


def all_cases() -> dict[str, Scene]:
    return {**{d: image_scene(d) for d in DISCRETISATIONS}, "laminate": laminate()}


def results(comm: Any) -> dict[str, np.ndarray]:
    """The matrices and ξ̄ by the petsc engine on ``comm`` (collective)."""
    from aromm.engines.petsc import homogenization
    from aromm.engines.petsc.problem import VoxelProblem, box_layout

    out = {"grid": np.array(box_layout(coupled_cases.SHAPE, comm).grid)}
    for label, scene in all_cases().items():
        out[f"{label}_transport"] = homogenization.moisture_transport(scene, comm=comm)
        out[f"{label}_xi"] = np.array(homogenization.mean_moisture_capacity(VoxelProblem.from_scene(scene), comm))
    return out


def serial() -> dict[str, np.ndarray]:
    """The same by the scipy engine (direct solves)."""
    from aromm.homogenization.moisture_cells import mean_moisture_capacity, moisture_transport

    out = {}
    for label, scene in all_cases().items():
        out[f"{label}_transport"] = moisture_transport(scene, "splu", "temperature")
        out[f"{label}_xi"] = np.array(mean_moisture_capacity(scene))
    return out
