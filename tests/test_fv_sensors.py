"""Sensors in finite volumes (aromm.fv.observation) against exact fields: between two fixed temperatures a
homogeneous box conducts a linear profile, which the two-point scheme reproduces exactly at the voxel centres and
face unknowns, so a point between centres and a patch aligned with the voxels read the exact value; a face without
a condition reads its voxels; a point among insulating voxels is refused, one beside them renormalised."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aromm.core.errors import InputError
from aromm.full.solve import steady_field
from aromm.scene.scene_file import Scene, assemble, scene_from_dict

H = 1e-3  # m, voxel edge
N = (4, 3, 10)  # voxels; the profile runs along z over L = 10 mm
L = N[2] * H
RTOL = 1e-10  # the steady solve's relative residual; readings are compared within it times the field's scale


def _scene(folder: Path, outputs: dict, labels_k: tuple[float, float] = (1.0, 1.0)) -> Scene:  # type: ignore[type-arg]
    """Two layers across x (voxels x < 2 label 0, the others label 1)."""
    labels = np.zeros(N, dtype=np.int32)
    labels[2:] = 1
    np.save(folder / "layers.npy", labels)
    data = {"geometry": {"image": "layers.npy", "voxel_size": H},
            "phases": {"a": {"label": 0, "k": labels_k[0]}, "b": {"label": 1, "k": labels_k[1]}},
            "boundary": {"z0": {"T": 1.0}, "z1": {"T": 0.0}}, "outputs": outputs, "model": {"discretisation": "fv"}}
    return scene_from_dict(data, folder / "layers.toml")


def _readings(folder: Path, outputs: dict, labels_k: tuple[float, float] = (1.0, 1.0)) -> dict[str, float]:  # type: ignore[type-arg]
    system = assemble(_scene(folder, outputs, labels_k))
    field = steady_field(system, rtol=RTOL)
    return {name: float(np.asarray(row @ field).ravel()[0]) for name, row in system.observation.items()}


def exact(z: float) -> float:
    return 1.0 - z / L


def test_points_between_centres_read_the_linear_profile(tmp_path: Path) -> None:
    points = {"p1": [1.3e-3, 1.1e-3, 3.7e-3], "p2": [2.0e-3, 0.5e-3, 8.21e-3], "p3": [0.6e-3, 2.4e-3, 5.0e-3]}
    got = _readings(tmp_path, {name: {"point": p} for name, p in points.items()})
    for name, p in points.items():
        assert abs(got[name] - exact(p[2])) <= 10 * RTOL, name


def test_a_point_within_half_a_cell_of_a_face_reads_the_outer_centre(tmp_path: Path) -> None:
    got = _readings(tmp_path, {"near": {"point": [1e-3, 1e-3, 0.2e-3]}})
    assert abs(got["near"] - exact(0.5 * H)) <= 10 * RTOL  # first order there (module docstring)


def test_patches_read_face_temperatures_and_aligned_means(tmp_path: Path) -> None:
    got = _readings(tmp_path, {"hot": {"face": "z0", "x": [0.0, 2e-3]}, "cam": {"face": "z1", "pixels": [2, 3]},
                     "side": {"face": "x1", "z": [2e-3, 6e-3]}, "whole_side": {"face": "y0"}})
    assert abs(got["hot"] - 1.0) <= 10 * RTOL  # the fixed face's unknowns
    for i in range(2):
        for j in range(3):
            assert abs(got[f"cam_{i}_{j}"]) <= 10 * RTOL
    assert abs(got["side"] - exact(4e-3)) <= 10 * RTOL  # the mean of a linear profile over [2, 6] mm
    assert abs(got["whole_side"] - 0.5) <= 10 * RTOL


def test_a_two_phase_laminate_reads_each_layer(tmp_path: Path) -> None:
    """Layers across x (k 1 and 10), the flow along z: each layer keeps the same linear profile."""
    got = _readings(tmp_path, {"a": {"point": [0.5e-3, 1e-3, 3e-3]}, "b": {"point": [3.5e-3, 1e-3, 3e-3]},
                     "across": {"point": [2.0e-3, 1e-3, 3e-3]}}, (1.0, 10.0))
    for name in ("a", "b", "across"):
        assert abs(got[name] - exact(3e-3)) <= 10 * RTOL, name


def test_points_among_insulating_voxels(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"outputs\.inside\.point: .* lies among voxels without a temperature"):
        assemble(_scene(tmp_path, {"inside": {"point": [0.5e-3, 1e-3, 5e-3]}}, (0.0, 1.0)))
    got = _readings(tmp_path, {"edge": {"point": [2.0e-3, 1e-3, 3e-3]}}, (0.0, 1.0))  # half on the insulating layer
    assert abs(got["edge"] - exact(3e-3)) <= 10 * RTOL  # renormalised onto the conducting voxels
