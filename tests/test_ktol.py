"""``ktol``: the multigrid stops on a bound of k's algebraic error; checked against exact (CHOLMOD) tensors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.ndimage as ndi

from aromm.cli import main
from aromm.core.errors import InputError
from aromm.core.vocabulary import PhaseSpec
from aromm.homogenization.accuracy import arithmetic_bound, harmonic_bound
from aromm.homogenization.cell_problems import effective_conductivity, voxel_operator
from aromm.linalg.direct import factorize
from aromm.linalg.multigrid.hierarchy import assembled_matrix
from aromm.linalg.multigrid.pcg import MultigridSolver
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene


def _random_medium(n: int, contrast: float, seed: int) -> Scene:
    field = ndi.gaussian_filter(np.random.default_rng(seed).standard_normal((n, n, n)), 1.5, mode="wrap")
    labels = (field > np.quantile(field, 0.6)).astype(np.int64)
    return Scene(VoxelGeometry(labels, (1e-3, 1.3e-3, 0.8e-3)),
                 (PhaseSpec("gas", 0, 0.025), PhaseSpec("fibre", 1, 0.025 * contrast)))


@pytest.mark.parametrize("boundary", ["periodic", "temperature", "flux"])
@pytest.mark.parametrize("ktol", [1e-3, 1e-5])
def test_every_entry_within_ktol_of_the_exact_tensor(boundary: str, ktol: float) -> None:
    scene = _random_medium(20, 1e3, seed=3)  # contrast 1e3: a hard case
    exact = effective_conductivity(scene, boundary, "cholmod").k
    result = effective_conductivity(scene, boundary, "mg", ktol=ktol)
    scale = np.min(np.diag(exact))
    assert np.max(np.abs(result.k - exact)) <= ktol * scale
    # from above (energy) or, for the flux, compliance from below; 1e-9: the direct solution's own accuracy
    assert np.all(np.diag(result.k) >= np.diag(exact) * (1 - 1e-9))


def test_ktol_solves_fewer_iterations_than_the_residual_criterion() -> None:
    scene = _random_medium(20, 12.0, seed=4)
    loose = effective_conductivity(scene, "periodic", "mg", ktol=1e-3)
    tight = effective_conductivity(scene, "periodic", "mg", rtol=1e-8)
    assert sum(loose.iterations) < sum(tight.iterations)


def test_wiener_bounds_bracket_the_exact_values() -> None:
    scene = _random_medium(16, 50.0, seed=5)
    for boundary in ("periodic", "temperature", "flux"):
        k = np.diag(effective_conductivity(scene, boundary, "cholmod").k)
        op = voxel_operator(scene)
        for axis in range(3):
            assert harmonic_bound(op, axis) <= k[axis] <= arithmetic_bound(op, axis)


def test_energy_tolerance_bounds_the_energy_error() -> None:
    """‖x* − x‖²_A ≤ energy_tol, with x* from a direct solve of the same operator."""
    scene = _random_medium(20, 100.0, seed=6)
    op = voxel_operator(scene, fixed=("z0", "z1"))
    b = np.random.default_rng(7).standard_normal(op.n)
    for axis, index in op.fixed_planes():
        b.reshape(op.node_shape)[(slice(None),) * axis + (index,)] = 0.0
    matrix = assembled_matrix(op)
    exact = factorize(matrix, "auto").solve(b)
    energy = float(b @ exact)
    for tolerance in (1e-3, 1e-6, 1e-9):
        x = MultigridSolver(op).solve(b, energy_tol=tolerance * energy)
        error = exact - x
        assert float(error @ (matrix @ error)) <= tolerance * energy


@pytest.mark.parametrize("ktol", [0.0, 1.0, -1e-3, float("nan")])
def test_bad_ktol_is_refused(ktol: float) -> None:
    with pytest.raises(InputError, match="ktol"):
        effective_conductivity(_random_medium(8, 10.0, seed=1), "periodic", "mg", ktol=ktol)


def test_cli_homogenize_with_ktol(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A laminate (exact arithmetic / harmonic means) through `aromm homogenize --ktol`; a bad --ktol exits 2."""
    labels = np.zeros((8, 8, 8), dtype=np.uint8)
    labels[:, :, :4] = 1
    np.save(tmp_path / "img.npy", labels)
    scene = tmp_path / "scene.toml"
    scene.write_text('[geometry]\nimage = "img.npy"\nvoxel_size = 1e-3\n[phases.a]\nlabel = 0\nk = 1.0\n'
                     '[phases.b]\nlabel = 1\nk = 10.0\n', encoding="utf-8")
    assert main(["homogenize", str(scene), "--solver", "mg", "--boundary", "temperature", "--ktol", "1e-4",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert np.allclose(np.diag(out["k"]), [5.5, 5.5, 2 / 1.1], rtol=1e-4)
    assert main(["homogenize", str(scene), "--ktol", "0"]) == 2
