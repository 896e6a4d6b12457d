"""Homogenisation [Chavez2020, eq. 13–14] against laminate means, Maxwell / Hashin–Shtrikman, symmetry."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from aromm.api import homogenize
from aromm.core.errors import InputError
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.homogenization.properties import fluxmetric, homogeneous_twin, mean_capacity
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene, scene_from_dict

PHI_SPHERE = 4.0 * np.pi / 81.0  # sphere of radius L/3 in a cube of side L


def _maxwell(phi: float, kappa: float) -> float:
    return (kappa + 2 + 2 * phi * (kappa - 1)) / (kappa + 2 - phi * (kappa - 1))


def _hs_bounds(phi: float, kappa: float) -> tuple[float, float]:
    matrix = 1 + phi / (1 / (kappa - 1) + (1 - phi) / 3)
    particle = kappa + (1 - phi) / (1 / (1 - kappa) + phi / (3 * kappa))
    return min(matrix, particle), max(matrix, particle)


def _scene(geometry: dict, k0: float = 1.0, k1: float = 10.0, c: tuple[float, float] | None = None):  # type: ignore[no-untyped-def]
    phases = {"matrix": {"label": 0, "k": k0}, "inclusion": {"label": 1, "k": k1}}
    if c is not None:
        phases["matrix"]["c"], phases["inclusion"]["c"] = c
    return scene_from_dict({"geometry": geometry, "phases": phases})


def test_laminate_gives_arithmetic_along_and_harmonic_across_layers() -> None:
    scene = _scene({"generator": "laminate", "shape": [6, 6, 8], "axis": "z", "layer_voxels": [1, 3, 2, 2],
                    "voxel_size": [1e-3, 2e-3, 0.5e-3]}, 2.0, 30.0, (1e6, 3e6))
    frac = float(scene.geometry.labels.mean())
    arithmetic = (1 - frac) * 2.0 + frac * 30.0
    harmonic = 1.0 / ((1 - frac) / 2.0 + frac / 30.0)
    k_t = homogenize(scene, boundary="temperature")
    np.testing.assert_allclose(np.diag(k_t), [arithmetic, arithmetic, harmonic], rtol=1e-10)
    np.testing.assert_allclose(homogenize(scene), np.diag([arithmetic, arithmetic, harmonic]), rtol=1e-10)  # periodic
    k_f = homogenize(scene, boundary="flux")  # [Chavez2020, eq. 13]: exact across, low along
    assert k_f[2, 2] == pytest.approx(harmonic, rel=1e-10)
    assert harmonic < k_f[0, 0] < arithmetic
    assert mean_capacity(scene) == pytest.approx((1 - frac) * 1e6 + frac * 3e6, rel=1e-14)


@pytest.mark.parametrize("kappa", [0.01, 0.1, 10.0, 100.0])
def test_sphere_in_cube_lies_between_hashin_shtrikman_bounds(kappa: float) -> None:
    scene = _scene({"generator": "sphere_in_cube", "n": 12, "voxel_size": 1e-3}, 1.0, kappa)
    phi = float(scene.geometry.labels.mean())
    lower, upper = _hs_bounds(phi, kappa)
    k = np.diag(homogenize(scene))
    np.testing.assert_allclose(k, k[0], rtol=1e-9)  # cubic symmetry of the cell
    assert lower <= k[0] <= upper


def test_permuting_image_axes_permutes_the_tensor() -> None:
    labels = np.random.default_rng(7).integers(0, 2, size=(5, 6, 7))
    phases = (PhaseSpec("matrix", 0, 1.0), PhaseSpec("inclusion", 1, 10.0))
    scene = Scene(VoxelGeometry(labels, (1e-3, 2e-3, 3e-3)), phases)
    k = np.diag(homogenize(scene))
    perm = (2, 0, 1)
    size = scene.geometry.voxel_size
    permuted = replace(scene, geometry=VoxelGeometry(np.transpose(labels, perm), tuple(size[p] for p in perm)))
    np.testing.assert_allclose(np.diag(homogenize(permuted)), k[list(perm)], rtol=1e-9)
    assert len(set(np.round(k, 6))) == 3  # the image is genuinely anisotropic


def test_unknown_engine_is_refused_whatever_the_boundary() -> None:
    """The engine is checked before the default boundary is chosen, and also when a boundary is named."""
    scene = _scene({"generator": "laminate", "shape": [4, 4, 6], "axis": "z", "layer_voxels": [3, 3],
                    "voxel_size": 1e-3}, 1.0, 5.0)
    for boundary in (None, "flux", "periodic"):
        with pytest.raises(InputError, match="unknown engine 'cuda'; allowed: scipy, petsc"):
            homogenize(scene, boundary, engine="cuda")


def test_homogeneous_twin_reproduces_the_orthotropic_tensor() -> None:
    scene = _scene({"generator": "laminate", "shape": [4, 4, 6], "axis": "z", "layer_voxels": [3, 3],
                    "voxel_size": 1e-3}, 1.0, 5.0, (1e6, 2e6))
    k = homogenize(scene)
    twin = homogeneous_twin(scene, k, mean_capacity(scene))
    np.testing.assert_allclose(homogenize(twin), k, rtol=1e-10)
    with pytest.raises(InputError, match="positive"):
        homogeneous_twin(scene, np.zeros((3, 3)), 1e6)


def _laminate_along_z(h: float | None, T: float | None = None) -> Scene:
    """Layers normal to x (conduction along the layers in z), flux 1e3 W/m² into z0, S2 = z1."""
    scene = _scene({"generator": "laminate", "shape": [8, 2, 6], "axis": "x", "layer_voxels": [3, 1, 3, 1],
                    "voxel_size": 1e-3}, 1.0, 20.0)
    return replace(scene, boundary=(FaceSpec("z0", flux=1e3), FaceSpec("z1", h=h, T=T)))


def test_fluxmetric_is_harmonic_across_layers_whatever_the_cooled_face() -> None:
    """Layers normal to the heat flow: every face stays isothermal, k = harmonic mean exactly [Chavez2020, eq. 13]."""
    scene = _scene({"generator": "laminate", "shape": [3, 3, 8], "axis": "z", "layer_voxels": [1, 3, 2, 2],
                    "voxel_size": [1e-3, 1e-3, 0.5e-3]}, 2.0, 30.0)
    frac = float(scene.geometry.labels.mean())
    harmonic = 1.0 / ((1 - frac) / 2.0 + frac / 30.0)
    for cooled in (FaceSpec("z0", h=7.0), FaceSpec("z0", T=3.0)):
        result = fluxmetric(replace(scene, boundary=(FaceSpec("z1", flux=-250.0), cooled)))
        assert (result.axis, result.heated, result.cooled) == ("z", "z1", "z0")
        assert result.k == pytest.approx(harmonic, rel=1e-10)


def test_fluxmetric_tends_to_eq13_with_an_isothermal_cooled_face() -> None:
    """Along the layers S2 is not isothermal under convection; as h → ∞ it becomes the T = 0 face of eq. 13."""
    along = homogenize(_laminate_along_z(None, 0.0), boundary="flux")[2, 2]
    assert fluxmetric(_laminate_along_z(None, T=0.0)).k == pytest.approx(along, rel=1e-10)
    ks = np.array([fluxmetric(_laminate_along_z(h)).k for h in (10.0, 1e6, 1e8, 1e10)])
    gaps = 1.0 - ks / along
    assert gaps[0] > 0.1  # a weak convection face is far from isothermal: k much lower than eq. 13's
    # the gap closes like 1/h (first order in the face's thermal resistance): x100 in h, /100 in gap
    np.testing.assert_allclose(gaps[1:-1] / gaps[2:], 100.0, rtol=0.02)


@pytest.mark.parametrize(("faces", "match"), [
    ((), "exactly one"),
    ((FaceSpec("z0", flux=1.0), FaceSpec("x0", flux=2.0)), "exactly one"),
    ((FaceSpec("z0", flux=1.0),), "z1"),
    ((FaceSpec("z0", flux=1.0), FaceSpec("z1", h=5.0), FaceSpec("x1", h=5.0)), "x1"),
])
def test_fluxmetric_refuses_a_scene_that_is_not_a_table1_scenario(faces: tuple[FaceSpec, ...], match: str) -> None:
    scene = replace(_laminate_along_z(5.0), boundary=faces)
    with pytest.raises(InputError, match=match):
        fluxmetric(scene)


def test_scalar_twin_is_isotropic() -> None:
    scene = _laminate_along_z(5.0)
    twin = homogeneous_twin(scene, 0.7, 1e6)
    assert twin.phases[0].k == (0.7, 0.7, 0.7)
