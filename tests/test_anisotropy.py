"""Anisotropic phases (aromm.core.anisotropy): conductivity tensors and fibre axes from the image, against exact cases.

Independent truths: the energy of a linear field (Q1 elements represent it exactly: Tᵀ K T = |Ω| Gᵀ A G); the
effective tensor of a laminate of anisotropic layers (continuity of the normal flux and of the tangential
gradient; the formula below); its covariance under rotations about the layers' normal; a homogeneous medium
(the effective tensor is the phase's own); the parameters of the full model that made the data.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from aromm.core.anisotropy import PhaseTensor, fibre_axes, rotation
from aromm.core.errors import InputError
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.fem.voxel_grid import node_points
from aromm.full.solve import FullModel
from aromm.homogenization.properties import homogenize
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene, load_scene
from inverse.identification import identify
from inverse.measurements import simulate_measurements

H = 1e-4  # voxel edge (m)
R0 = rotation([1.0, 2.0, 0.5], 0.7)  # principal axes of the layers: a rotation with no special direction


def _tensor_phase(name: str, label: int, values: tuple[float, float, float], axes: np.ndarray) -> PhaseSpec:
    rows = tuple((float(a), float(b), float(c)) for a, b, c in axes)
    return PhaseSpec(name, label, max(values), tensor=PhaseTensor("tensor", values, rows))


def laminate_tensor(tensors: list[np.ndarray], fractions: list[float]) -> np.ndarray:
    """Effective tensor of layers normal to x (index 0): k*_00 = ⟨1/k_00⟩⁻¹, k*_0a = k*_00 ⟨k_0a/k_00⟩,
    k*_ab = ⟨k_ab − k_a0 k_0b / k_00⟩ + ⟨k_a0/k_00⟩ k*_00 ⟨k_0b/k_00⟩."""
    f = np.asarray(fractions)
    ks = np.asarray(tensors)
    k00 = 1.0 / float(f @ (1.0 / ks[:, 0, 0]))
    r = np.einsum("l,la->a", f, ks[:, 0, 1:] / ks[:, 0, 0, None])
    schur = np.einsum("l,lab->ab", f, ks[:, 1:, 1:] - ks[:, 1:, 0, None] * ks[:, 0, None, 1:] / ks[:, 0, 0, None, None])
    out = np.empty((3, 3))
    out[0, 0] = k00
    out[0, 1:] = out[1:, 0] = k00 * r
    out[1:, 1:] = schur + k00 * np.outer(r, r)
    return out


def test_q1_tensor_element_gives_the_exact_energy_of_a_linear_field() -> None:
    """Tᵀ K T = |Ω| Gᵀ A G for T = G·x, any tensor A (off-diagonal terms included), on unequal voxel edges."""
    axes = R0
    phase = _tensor_phase("m", 0, (3.0, 1.0, 0.25), axes)
    voxel = (1e-3, 2e-3, 0.5e-3)
    system = assemble_voxels(np.zeros((3, 2, 4), dtype=int), voxel, [phase])
    k = system.conductance.evaluate(system.values())
    a = axes.T @ np.diag([3.0, 1.0, 0.25]) @ axes
    rng = np.random.default_rng(0)
    for _ in range(3):
        g = rng.normal(size=3)
        t = node_points((3, 2, 4), voxel) @ g
        volume = 3 * 2 * 4 * float(np.prod(voxel))
        assert float(t @ (k @ t)) == pytest.approx(volume * float(g @ a @ g), rel=1e-12)
    equal = _tensor_phase("m", 0, (2.0, 2.0, 2.0), axes)  # v_i v_iᵀ sum to I: the isotropic matrix
    iso = assemble_voxels(np.zeros((3, 2, 4), dtype=int), voxel, [PhaseSpec("m", 0, 2.0)])
    k_equal = assemble_voxels(np.zeros((3, 2, 4), dtype=int), voxel, [equal]).conductance.evaluate(system.values(
        {"m.k_1": 2.0, "m.k_2": 2.0, "m.k_3": 2.0}))
    assert abs(k_equal - iso.conductance.evaluate(iso.values())).max() < 1e-12 * 2.0 * 2e-3


def _laminate_scene(angle: float, method_shape: tuple[int, int, int] = (6, 3, 3)) -> tuple[Scene, list[np.ndarray]]:
    """Layers normal to x: 2 voxels of a tensor phase, 4 of another, their principal axes turned by ``angle``
    about x."""
    turn = rotation([1.0, 0.0, 0.0], angle)
    axes_a = R0 @ turn.T  # rows are the turned axes: v' = turn v
    axes_b = rotation([0.0, 1.0, 1.0], 0.4) @ turn.T
    a = _tensor_phase("a", 0, (3.0, 1.0, 0.25), axes_a)
    b = _tensor_phase("b", 1, (0.5, 0.2, 0.1), axes_b)
    labels = np.zeros(method_shape, dtype=int)
    labels[2:] = 1
    tensors = [ph.tensor.matrix() for ph in (a, b)]  # type: ignore[union-attr]
    return Scene(VoxelGeometry(labels, (H, 2 * H, H)), (a, b)), tensors


def test_laminate_of_anisotropic_layers_has_the_exact_effective_tensor_and_turns_with_its_phases() -> None:
    scene0, tensors0 = _laminate_scene(0.0)
    exact0 = laminate_tensor(tensors0, [2 / 6, 4 / 6])
    k0 = homogenize(scene0, method="cholmod")
    np.testing.assert_allclose(k0, exact0, rtol=1e-9, atol=1e-9 * np.abs(exact0).max())
    assert np.abs(exact0[0, 1:]).max() > 0.05 * exact0[0, 0]  # the case has off-diagonal terms to get right
    angle = 0.9
    scene, _ = _laminate_scene(angle)
    turn = rotation([1.0, 0.0, 0.0], angle)
    np.testing.assert_allclose(homogenize(scene, method="cholmod"), turn @ exact0 @ turn.T, atol=1e-9 * exact0.max())
    np.testing.assert_allclose(homogenize(scene, method="amg"), turn @ exact0 @ turn.T, atol=1e-6 * exact0.max())


def test_diagonal_layers_under_flux_and_temperature_probes() -> None:
    a = _tensor_phase("a", 0, (3.0, 1.0, 0.25), np.eye(3))
    b = _tensor_phase("b", 1, (0.5, 0.2, 0.1), np.eye(3))
    labels = np.zeros((6, 3, 3), dtype=int)
    labels[2:] = 1
    scene = Scene(VoxelGeometry(labels, (H, H, H)), (a, b))
    series = 1.0 / (2 / 6 / 3.0 + 4 / 6 / 0.5)
    parallel = [2 / 6 * 1.0 + 4 / 6 * 0.2, 2 / 6 * 0.25 + 4 / 6 * 0.1]
    for boundary in ("temperature", "flux"):
        k = np.diag(homogenize(scene, boundary=boundary, method="cholmod"))
        assert k[0] == pytest.approx(series, rel=1e-9)
        if boundary == "temperature":
            np.testing.assert_allclose(k[1:], parallel, rtol=1e-9)


def _prisms(n: int = 8, width: int = 3) -> np.ndarray:
    """Straight fibres along t = (0, 1, 1)/√2: voxels with i mod n < width and (k − j) mod n < width; the image is
    periodic and invariant under the shift (0, 1, 1)."""
    i, j, k = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
    return (((i % n) < width) & (((k - j) % n) < width)).astype(np.int32)


T_AXIS = np.array([0.0, 1.0, 1.0]) / math.sqrt(2.0)


def test_structure_tensor_finds_the_axis_of_straight_fibres_exactly() -> None:
    """Sobel derivatives of an image invariant under the shift t satisfy g·t = 0 exactly (periodic border)."""
    mask = _prisms() == 1
    axes = fibre_axes(mask, sigma=1.0, border="wrap")
    np.testing.assert_allclose(np.abs(axes @ T_AXIS), 1.0, atol=1e-9)


def test_fibres_from_the_image_in_a_matrix_of_the_same_tensor_homogenise_to_that_tensor(tmp_path: Path) -> None:
    """Fibre phase (axis from the image) and matrix (the same tensor given by its axes): a homogeneous medium."""
    np.save(tmp_path / "prisms.npy", _prisms())
    u, w = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, -1.0]) / math.sqrt(2.0)
    path = tmp_path / "fibres.toml"
    path.write_text(f"""
[geometry]
image = "prisms.npy"
voxel_size = 1.0e-5
[phases.fibre]
label = 1
k_axial = 2.0
k_transverse = 0.5
axis = "image"
axis_sigma = 1.0
axis_border = "wrap"
[phases.matrix]
label = 0
k = {{ values = [2.0, 0.5, 0.5], axes = [{T_AXIS.tolist()}, {u.tolist()}, {w.tolist()}] }}
""", encoding="utf-8")
    scene = load_scene(path)
    assert {"fibre.k_axial", "fibre.k_transverse", "matrix.k_1", "matrix.k_2", "matrix.k_3"} <= set(scene.parameters)
    exact = 2.0 * np.outer(T_AXIS, T_AXIS) + 0.5 * (np.eye(3) - np.outer(T_AXIS, T_AXIS))
    np.testing.assert_allclose(homogenize(scene, method="cholmod"), exact, atol=1e-9)


ANGLE = math.radians(30.0)
FIBRE = PhaseSpec("fibre", 0, 2.0, 1.5e6, tensor=PhaseTensor("fibre", (2.0, 0.4),
                                                              ((0.0, math.sin(ANGLE), math.cos(ANGLE)),)))


def _block(axis: str, end: float = 60.0, dt: float = 2.0):  # type: ignore[no-untyped-def]
    return assemble_voxels(np.zeros((3, 3, 6), dtype=int), (H, H, H), [FIBRE],
                           [FaceSpec(f"{axis}0", flux=500.0), FaceSpec(f"{axis}1", h=20.0)],
                           time=TimeGrid(end, dt), outputs=[f"{axis}0", f"{axis}1"])


@pytest.mark.filterwarnings("ignore::inverse.uncertainty.ResidualWarning")  # noise-free data: residuals ≈ 0
def test_axial_and_transverse_conductivities_are_identified_from_two_scenarios() -> None:
    truth = {"fibre.k_axial": 2.0, "fibre.k_transverse": 0.4}
    pairs = [(FullModel(_block(axis)), None) for axis in ("z", "x")]
    pairs = [(m, simulate_measurements(m, truth)) for m, _ in pairs]
    result = identify(pairs, unknowns={"fibre.k_axial": (0.2, 10.0), "fibre.k_transverse": (0.05, 2.0)},
                      particles=10, iterations=10)
    errors = {k: abs(result.estimates[k] - v) / v for k, v in truth.items()}
    assert max(errors.values()) < 1e-3, result.estimates


@pytest.mark.parametrize(("phase", "key"), [
    ('k = { values = [1.0, 2.0], axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1]] }', "phases.fibre.k.values"),
    ('k = { values = [1.0, 2.0, 3.0], axes = [[1, 0, 0], [1, 1, 0], [0, 0, 1]] }', "phases.fibre.k.axes"),
    ('k = { values = [1.0, 2.0, 3.0], axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1]], scale = 2 }', "phases.fibre.k.scale"),
    ('k = 0.3\nk_axial = 1.0', "phases.fibre.k_axial"),
    ('k_axial = 1.0\nk_transverse = 0.5', "phases.fibre.axis"),
    ('k_axial = 1.0\naxis = [0, 0, 1]', "phases.fibre.k_transverse"),
    ('k_axial = -1.0\nk_transverse = 0.5\naxis = [0, 0, 1]', "phases.fibre.k_axial"),
    ('k_axial = 1.0\nk_transverse = 0.5\naxis = [0, 0, 1]\naxis_sigma = 2.0', "phases.fibre.axis_sigma"),
    ('k_axial = 1.0\nk_transverse = 0.5\naxis = "image"\naxis_border = "mirror"', "phases.fibre.axis_border"),
    ('k_axial = 1.0\nk_transverse = 0.5\naxis = [0, 0, 0]', "phases.fibre.axis"),
])
def test_bad_tensor_and_fibre_phases_are_refused_naming_the_key(tmp_path: Path, phase: str, key: str) -> None:
    np.save(tmp_path / "img.npy", _prisms(4, 2))
    path = tmp_path / "s.toml"
    path.write_text(f'[geometry]\nimage = "img.npy"\nvoxel_size = 1e-5\n[phases.fibre]\nlabel = 1\n{phase}\n'
                    "[phases.gas]\nlabel = 0\nk = 0.025\n", encoding="utf-8")
    with pytest.raises(InputError, match=f"{key}"):
        load_scene(path)
