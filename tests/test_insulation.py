"""An insulating phase (k = 0) in q1 where its system stays non-singular (aromm.fem.insulation).

Independent truths: a laminate of conducting and one-voxel insulating layers, loaded along the layers, has the
linear field as its exact Q1 solution, so k̄ = φ k (the conducting fraction) to the solver's rounding; elsewhere a
k = 0 result must be the limit of k → 0 (k = 1e-9: a relative difference of order 1e-9) and stay above the finite
volumes' (Q1 is conforming, fv the lower value: docs/method/finite_volumes.md).  Refusals name the condition that
fails.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from aromm.core.errors import InputError
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem.insulation import singular_insulation
from aromm.homogenization.cell_problems import effective_conductivity
from aromm.homogenization.properties import fluxmetric
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene, scene_from_dict

RTOL = 1e-8  # the cell problems' default residual


def _scene(labels: np.ndarray, k0: float = 0.0, faces: tuple[FaceSpec, ...] = ()) -> Scene:
    return Scene(VoxelGeometry(labels, (1e-6,) * 3), (PhaseSpec("m", 0, 1.0), PhaseSpec("s", 1, k0)), faces)


def _inclusions(n: int = 16, seed: int = 0) -> np.ndarray:
    """Insulating voxels (label 1, a quarter) inside a conducting skin two voxels thick (seed 0: no node inside an
    insulating 2³ block, so every cell problem is non-singular)."""
    labels = np.zeros((n, n, n), dtype=int)
    labels[2:-2, 2:-2, 2:-2] = np.random.default_rng(seed).random((n - 4,) * 3) < 0.25
    return labels


def test_the_conditions_of_singularity() -> None:
    block = np.ones((4, 4, 4), dtype=bool)
    block[1:3, 1:3, 1:3] = False  # a 2³ insulating block: its centre node touches no conducting voxel
    assert singular_insulation(block, ("x0",)).startswith("1 of the 125 nodes touch no conducting voxel")
    corner = np.ones((3, 3, 3), dtype=bool)
    corner[0, 0, 0] = False  # the box's corner node belongs to that voxel alone
    assert singular_insulation(corner, ("x0",)).startswith("1 of the 64 nodes")
    assert singular_insulation(corner, periodic=True) is None  # periodic: that node has seven more voxels
    layers = np.ones((4, 4, 4), dtype=bool)
    layers[:, :, [1, 3]] = False  # two conducting layers, separate across z even through the periodic wrap
    assert "2 separate clusters" in singular_insulation(layers, periodic=True)
    layers[:, :, 3] = True  # z = 2, 3 and (wrapped) 0 now touch: one cluster
    assert singular_insulation(layers, periodic=True) is None
    chain = np.zeros((3, 3, 3), dtype=bool)
    chain[0] = chain[2] = True  # two conducting slabs across x, an insulating one between: x1's slab floats
    assert singular_insulation(chain, ("x0",)).startswith("33.3 % of the volume")
    chain[1, 0, 0] = True  # one voxel of the middle slab shares nodes with both: one cluster, anchored on x0
    assert singular_insulation(chain, ("x0",)) is None


def test_a_laminate_along_its_layers_gives_the_conducting_fraction_exactly() -> None:
    labels = np.zeros((6, 6, 5), dtype=int)
    labels[:, :, [1, 3]] = 1  # conducting layers z = 0, 2, 4 between one-voxel insulating ones: φ = 3/5
    for method in ("auto", "splu"):
        k = effective_conductivity(_scene(labels), "temperature", method, axes=(0, 1)).k
        np.testing.assert_allclose(np.diag(k)[:2], [0.6, 0.6], rtol=10 * RTOL)
    with pytest.raises(InputError, match=r"temperature cell problem along z: .* reach no face .*--discretisation fv"):
        effective_conductivity(_scene(labels), "temperature", axes=(2,))  # the middle layer floats
    with pytest.raises(InputError, match="separate clusters across the periodic box"):
        effective_conductivity(_scene(labels), "periodic")


@pytest.mark.parametrize("boundary", ["temperature", "flux", "periodic"])
def test_every_cell_problem_is_the_limit_of_a_vanishing_conductivity(boundary: str) -> None:
    labels = _inclusions()
    zero = np.diag(effective_conductivity(_scene(labels), boundary).k)
    limit = np.diag(effective_conductivity(_scene(labels, 1e-9), boundary).k)
    np.testing.assert_allclose(zero, limit, rtol=1e-7)  # O(1e-9) apart, plus the solves' 1e-8 residuals
    fv = np.diag(effective_conductivity(replace(_scene(labels), discretisation="fv"), "temperature", "splu").k)
    assert np.all(zero > fv)  # Q1 above the finite volumes (by 20 % here: heat passes through shared corners)


def test_a_steady_scene_with_an_insulating_phase_in_q1() -> None:
    labels = _inclusions()
    faces = (FaceSpec("z0", flux=100.0), FaceSpec("z1", T=0.0))
    k0 = {m: fluxmetric(_scene(labels, 0.0, faces), m).k for m in ("auto", "cholmod")}
    limit = fluxmetric(_scene(labels, 1e-9, faces), "cholmod").k
    assert k0["auto"] == pytest.approx(limit, rel=1e-7) and k0["cholmod"] == pytest.approx(limit, rel=1e-7)
    labels[0, 0, 0] = 1  # the corner voxel: its corner node now touches no conducting voxel
    with pytest.raises(InputError, match=r"'s': k = 0 \(insulating\) in q1: 1 of the 4913 nodes .*discretisation fv"):
        fluxmetric(_scene(labels, 0.0, faces))


def test_a_transient_with_an_insulating_phase_is_refused_when_read() -> None:
    data = {"geometry": {"generator": "sphere_in_cube", "n": 6, "voxel_size": 1e-3},
            "phases": {"matrix": {"label": 0, "k": 0.0, "c": 1e6}, "inclusion": {"label": 1, "k": 1.0, "c": 1e6}},
            "boundary": {"z0": {"T": 1.0}}, "time": {"end": 1.0, "dt": 0.1}}
    for model in ({"discretisation": "q1"}, {"discretisation": "fv"}):
        with pytest.raises(InputError, match=r"phases\.matrix\.k: k = 0 .* steady scenes"):
            scene_from_dict({**data, "model": model})
