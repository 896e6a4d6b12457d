"""Three or more phases through homogenisation, reduction and identification, against a three-layer laminate.

Independent truths: the series (harmonic) and parallel (arithmetic) means of a laminate [Wiener1912], the
steady face temperatures of a layered slab (thermal resistances in series), and the exact solution of the
full semi-discrete system by a dense generalised eigendecomposition.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

from aromm.core.system import ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.full.solve import FullModel
from aromm.homogenization.properties import homogenize, mean_capacity
from aromm.reduction.offline import reduce
from aromm.scene.scene_file import scene_from_dict
from inverse.identification import identify
from inverse.measurements import simulate_measurements

#: wall / lumen / resin of a wood image: k (W/(m K)), c (J/(m³ K)), layer thickness (voxels)
PHASES = (PhaseSpec("wall", 0, 0.40, 1.6e6), PhaseSpec("lumen", 1, 0.025, 1.2e3), PhaseSpec("resin", 2, 0.20, 2.0e6))
LAYERS = (3, 2, 3)
H = 1e-4  # voxel edge, m


def _laminate(shape_xy: int = 4) -> np.ndarray:
    labels = np.concatenate([np.full(n, ph.label) for n, ph in zip(LAYERS, PHASES, strict=True)])
    return np.broadcast_to(labels, (shape_xy, shape_xy, labels.size)).copy()


def _fractions() -> np.ndarray:
    return np.array(LAYERS, dtype=float) / sum(LAYERS)


def _scene(labels: np.ndarray):  # type: ignore[no-untyped-def]
    phases = {ph.name: {"label": ph.label, "k": ph.k, "c": ph.c} for ph in PHASES}
    return scene_from_dict({"geometry": {"generator": "laminate", "shape": list(labels.shape), "axis": "z",
                                         "layer_voxels": list(LAYERS), "labels": [0, 1, 2], "voxel_size": H},
                            "phases": phases})


@pytest.mark.parametrize("method", ["cholmod", "mg"])
def test_three_layer_laminate_homogenises_to_the_series_and_parallel_means(method: str) -> None:
    scene = _scene(_laminate())
    assert np.array_equal(scene.geometry.labels, _laminate())
    f, k = _fractions(), np.array([float(ph.k) for ph in PHASES])  # type: ignore[arg-type]
    parallel, series = float(f @ k), 1.0 / float(f @ (1.0 / k))
    rtol = 1e-10 if method == "cholmod" else 1e-6  # mg: CG to ‖r‖/‖b‖ 1e-8, contrast 16 → k̄ to 1e-6
    for boundary in ("periodic", "temperature"):
        tensor = homogenize(scene, boundary=boundary, method=method)
        np.testing.assert_allclose(np.diag(tensor), [parallel, parallel, series], rtol=rtol)
        np.testing.assert_allclose(tensor - np.diag(np.diag(tensor)), 0.0, atol=rtol * parallel)
    assert homogenize(scene, boundary="flux", method=method)[2, 2] == pytest.approx(series, rel=rtol)
    assert mean_capacity(scene) == pytest.approx(float(f @ [ph.c for ph in PHASES]), rel=1e-14)


def _slab(end: float = 400.0, dt: float = 4.0) -> ThermalSystem:
    """Flux 500 W/m² into z0 across the layers, h = 20 W/(m² K) to 0 °C on z1."""
    return assemble_voxels(_laminate(2), (H,) * 3, PHASES, [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)],
                           time=TimeGrid(end, dt), outputs=["z0", "z1"])


def _exact(system: ThermalSystem, values: dict[str, float], times: np.ndarray) -> np.ndarray:
    v = system.values(values)
    c, k = system.capacity.evaluate(v).toarray(), system.conductance.evaluate(v).toarray()
    lam, w = sla.eigh(k, c)
    b, y0 = w.T @ np.asarray(system.load.evaluate(v)), np.zeros(system.n)
    ys = [w @ (np.exp(-lam * t) * y0 + -np.expm1(-lam * t) / lam * b) for t in times]
    return np.array(ys) @ system.observation_matrix()[1].T


def test_three_phase_slab_reduced_model_matches_the_exact_solution_and_the_series_resistance(tmp_path: Path) -> None:
    system = _slab()
    assert {"wall.k", "lumen.k", "resin.k", "wall.c", "lumen.c", "resin.c"} <= set(system.parameters)
    other = {**system.parameters, "wall.k": 0.25, "wall.c": 1.0e6}  # away from the bases' reference values
    rom = reduce(system, order=30, cache=tmp_path)
    times = np.array([4.0, 40.0, 400.0, 1e6])
    exact = _exact(system, other, times)
    got = rom.simulate(other, times).as_array()
    rise = float(np.abs(exact).max())
    assert np.abs(got - exact).max() < 1e-4 * rise
    # steady limit: T_z1 = q/h, T_z0 = T_z1 + q Σ L_i / k_i (resistances in series)
    k = {"wall": 0.25, "lumen": 0.025, "resin": 0.20}
    resistance = sum(n * H / k[ph.name] for n, ph in zip(LAYERS, PHASES, strict=True))
    np.testing.assert_allclose(exact[-1], [500.0 / 20.0 + 500.0 * resistance, 500.0 / 20.0], rtol=1e-9)


@pytest.mark.filterwarnings("ignore::inverse.uncertainty.ResidualWarning")  # noise-free data: residuals ≈ 0
def test_identify_the_wall_of_a_three_phase_image_with_the_others_known() -> None:
    """Data from the full three-phase model at the truth, no noise: wall k and c recovered, lumen and resin fixed."""
    truth = {"wall.k": 0.33, "wall.c": 1.4e6}
    model = FullModel(_slab(end=200.0, dt=4.0))
    y = simulate_measurements(model, truth)
    result = identify(model, y, {"wall.k": (0.05, 1.0), "wall.c": (1e5, 1e7)}, seed=0, particles=10, iterations=10)
    errors = {name: abs(result.estimates[name] - value) / value for name, value in truth.items()}
    assert max(errors.values()) < 1e-3, errors
