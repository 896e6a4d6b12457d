"""Cases of the petsc engine's homogenised heat and moisture transport (the fixed-value and the flux probe,
aromm.engines.petsc.homogenization.moisture_transport), computed the same way at 1 rank in the pytest process and under
``mpiexec`` (``petsc_worker.py OUT.npz petsc_moisture_homog_cases``): the two-phase 6×5×4 image of
tests/petsc_moisture_cases.py (its face conditions, a moisture flux among them, are the probe's to replace) in Q1 and
in finite volumes, and a two-phase laminate across x (whose effective matrices are exact means).

:func:`solve_bound` is the tolerance of a petsc entry against a direct solve, from the solver's own: each coupled
steady solve is CG on the diagonally scaled system ``Â ŷ = s ∘ b`` (Â = S A S, S = diag(A)^-1/2, identity rows and
columns on the fixed unknowns as PETSc eliminates them) to the relative residual ``rtol = linear.tolerance(STEADY_RTOL,
2)``, so ``‖δŷ‖ ≤ κ(Â) rtol ‖ŷ‖`` [Higham2002, § 7.1]; the flow through a fixed set D is ``1_Dᵀ (K x − F)``, whose
error is ``(1_Dᵀ K S) δŷ``, at most ``‖1_Dᵀ K S‖ κ rtol ‖ŷ‖`` (then × L_i / A_i, and / λ for the moisture flow); the
flux probe's from its face means' (:func:`_flux_bound`).
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
BOUNDARIES = ("temperature", "flux")  # the probes of the petsc engine
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


def solve_bound(scene: Scene, boundary: str = "temperature") -> np.ndarray:
    """(3, 2, 2): the bound of the module docstring on each entry of the petsc engine's matrix of ``scene`` by the
    probe ``boundary``."""
    from aromm.homogenization.moisture_cells import AXES, fixed_value_probe, flux_probe

    build = fixed_value_probe if boundary == "temperature" else flux_probe
    out = np.zeros((3, 2, 2))
    for axis, name in enumerate(AXES):
        system = assemble(build(scene, axis))
        if boundary == "temperature":
            out[axis] = _flow_bound(scene, system, name) * scene.size[axis] / (float(np.prod(scene.size))
                                                                               / scene.size[axis])
        else:
            out[axis] = _flux_bound(scene, system, name)
    return out


def _scaled(system: Any) -> tuple[np.ndarray, np.ndarray, float, float]:
    """K, the scale s = diag(A)^-1/2 of the eliminated matrix A, κ(S A S) and the solve's relative residual."""
    from aromm.engines.petsc import linear

    k = system.conductance.evaluate(system.values()).toarray()
    fixed = np.concatenate([d.dofs for d in system.dirichlet])
    a = k.copy()
    a[fixed, :] = 0.0
    a[:, fixed] = 0.0
    a[fixed, fixed] = 1.0
    s = 1.0 / np.sqrt(np.diag(a))
    return k, s, float(np.linalg.cond(s[:, None] * a * s[None, :])), linear.tolerance(linear.STEADY_RTOL, 2)


def _flow_bound(scene: Scene, system: Any, name: str) -> np.ndarray:
    """(2, 2): the bound on the flows (W; kg/s) through the fixed sets of i0 of the fixed-value probe: a flow's error is
    ``(1_Dᵀ K S) δŷ``, at most ``‖1_Dᵀ K S‖ κ rtol ‖ŷ‖``."""
    from aromm.full.solve import steady_field

    assert scene.moisture is not None
    k, s, kappa, rtol = _scaled(system)
    sets = {d.param: d.dofs for d in system.dirichlet}
    out = np.zeros((2, 2))
    for column, jump in enumerate(({f"{name}0.T": 1.0}, {f"{name}0.phi": 1.0})):
        y = steady_field(system, jump, method="splu") / s
        for row, (param, divide) in enumerate(((f"{name}0.T", 1.0), (f"{name}0.phi", scene.moisture.state.weight))):
            gain = float(np.linalg.norm(k[sets[param]].sum(axis=0) * s))
            out[row, column] = gain * kappa * rtol * float(np.linalg.norm(y)) / divide
    return out


def _flux_bound(scene: Scene, system: Any, name: str) -> np.ndarray:
    """(2, 2): the bound on ``F = L M⁻¹`` of the flux probe: a mean jump's error is ``(e S) δŷ``, at most
    ``‖e S‖ κ rtol ‖ŷ‖`` (δM), and ``δF = −L M⁻¹ δM M⁻¹`` to first order, so ``|δF| ≤ 2 L |M⁻¹| δM |M⁻¹|``
    (the factor 2 covering the higher orders while ``‖M⁻¹ δM‖ ≤ 1/2``)."""
    from aromm.core.observables import PHI_PREFIX
    from aromm.full.solve import steady_field

    _, s, kappa, rtol = _scaled(system)
    means, error = np.zeros((2, 2)), np.zeros((2, 2))
    for column, load in enumerate(({f"{name}0.flux": 1.0}, {f"{name}0.g": 1.0})):
        x = steady_field(system, load, method="splu")
        for row, output in enumerate((f"{name}0", PHI_PREFIX + f"{name}0")):
            e = np.asarray(system.observation[output].toarray() if hasattr(system.observation[output], "toarray")
                           else system.observation[output]).ravel()
            means[row, column] = float(e @ x)
            error[row, column] = float(np.linalg.norm(e * s)) * kappa * rtol * float(np.linalg.norm(x / s))
    inverse = np.abs(np.linalg.inv(means))
    assert np.linalg.norm(inverse @ error, 2) <= 0.5
    length = scene.size["xyz".index(name)]
    return 2.0 * length * inverse @ error @ inverse


def all_cases() -> dict[str, Scene]:
    return {**{d: image_scene(d) for d in DISCRETISATIONS}, "laminate": laminate()}


def results(comm: Any) -> dict[str, np.ndarray]:
    """The matrices and ξ̄ by the petsc engine on ``comm`` (collective)."""
    from aromm.engines.petsc import homogenization
    from aromm.engines.petsc.problem import VoxelProblem, box_layout

    out = {"grid": np.array(box_layout(coupled_cases.SHAPE, comm).grid)}
    for label, scene in all_cases().items():
        for boundary in BOUNDARIES:
            out[f"{label}_{boundary}"] = homogenization.moisture_transport(scene, boundary, comm=comm)
        out[f"{label}_xi"] = np.array(homogenization.mean_moisture_capacity(VoxelProblem.from_scene(scene), comm))
    return out


def serial() -> dict[str, np.ndarray]:
    """The same by the scipy engine (direct solves)."""
    from aromm.homogenization.moisture_cells import mean_moisture_capacity, moisture_transport

    out = {}
    for label, scene in all_cases().items():
        for boundary in BOUNDARIES:
            out[f"{label}_{boundary}"] = moisture_transport(scene, "splu", boundary)
        out[f"{label}_xi"] = np.array(mean_moisture_capacity(scene))
    return out
