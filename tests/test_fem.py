"""Voxel assembly: equality with scikit-fem's generic Hex1 assembly, and only the terms asked for."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import skfem
from skfem.helpers import dot, grad

from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels, face_mass

VOXEL = (1.0e-3, 1.5e-3, 0.7e-3)


def _skfem_mesh(shape: tuple[int, int, int]) -> tuple[skfem.MeshHex, np.ndarray]:
    """scikit-fem box mesh and the permutation from its node numbering to ours (x fastest)."""
    axes = [np.arange(n + 1) * h for n, h in zip(shape, VOXEL, strict=True)]
    mesh = skfem.MeshHex.init_tensor(*axes)
    ijk = np.rint(mesh.p / np.asarray(VOXEL)[:, None]).astype(int)
    ours = ijk[0] + (shape[0] + 1) * (ijk[1] + (shape[1] + 1) * ijk[2])
    return mesh, ours


def _to_ours(mat: sp.spmatrix, perm: np.ndarray, n: int) -> sp.csr_array:
    coo = sp.coo_array(mat)
    return sp.csr_array((coo.data, (perm[coo.row], perm[coo.col])), shape=(n, n))


@skfem.BilinearForm
def _stiffness(u, v, w):
    return dot(grad(u), grad(v))


@skfem.BilinearForm
def _stiffness_x(u, v, w):
    return grad(u)[0] * grad(v)[0]


@skfem.BilinearForm
def _mass(u, v, w):
    return u * v


def test_reference_scatter_equals_generic_scikit_fem_assembly() -> None:
    rng = np.random.default_rng(3)
    shape = (3, 4, 5)
    labels = rng.integers(0, 2, size=shape)
    phases = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, (0.3, 0.2, 0.5), 4e6)]
    system = assemble_voxels(labels, VOXEL, phases, [FaceSpec("z1", h=20.0)], time=TimeGrid(1.0, 0.1))
    mesh, perm = _skfem_mesh(shape)
    centre = mesh.p[:, mesh.t].mean(axis=1) / np.asarray(VOXEL)[:, None]
    voxel_of_element = np.floor(centre).astype(int)
    element_label = labels[tuple(voxel_of_element)]
    for label, name in ((0, "gas"), (1, "fibre")):
        basis = skfem.Basis(mesh, skfem.ElementHex1(), elements=np.flatnonzero(element_label == label))
        mass = _to_ours(_mass.assemble(basis), perm, system.n)
        assert abs(system.capacity[f"C_{name}"].operator - mass).max() < 1e-12 * abs(mass).max()
        if name == "gas":
            stiff = _to_ours(_stiffness.assemble(basis), perm, system.n)
            assert abs(system.conductance["K_gas"].operator - stiff).max() < 1e-12 * abs(stiff).max()
        else:
            stiff_x = _to_ours(_stiffness_x.assemble(basis), perm, system.n)
            err = abs(system.conductance["K_fibre_x"].operator - stiff_x).max()
            assert err < 1e-12 * abs(stiff_x).max()
    facets = mesh.facets_satisfying(lambda x: np.isclose(x[2], shape[2] * VOXEL[2]))
    fbasis = skfem.FacetBasis(mesh, skfem.ElementHex1(), facets=facets)
    boundary = _to_ours(_mass.assemble(fbasis), perm, system.n)
    assert abs(face_mass(shape, VOXEL, "z1") - boundary).max() < 1e-12 * abs(boundary).max()
    assert abs(system.conductance["H_z1"].operator - boundary).max() < 1e-12 * abs(boundary).max()


def test_only_the_terms_a_scene_calls_for() -> None:
    labels = np.zeros((3, 3, 3), dtype=int)
    labels[1, 1, 1] = 1
    two = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6)]
    steady = assemble_voxels(labels, VOXEL, two, [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)])
    assert not steady.capacity and steady.is_steady
    assert steady.conductance.names == ("K_gas", "K_fibre", "H_z1")
    adiabatic = assemble_voxels(labels, VOXEL, two, [FaceSpec("z0", flux=500.0)], time=TimeGrid(1.0, 0.1))
    assert not any(name.startswith("H_") for name in adiabatic.term_names)
    assert adiabatic.capacity.names == ("C_gas", "C_fibre")
    one = assemble_voxels(np.zeros((3, 3, 3), dtype=int), VOXEL, two, [FaceSpec("x0", T=1.0)])
    assert one.conductance.names == ("K_gas",)
    assert "fibre.k" not in one.parameter_names
    assert one.load.names == ()


def test_face_mean_rows_average_and_masses_integrate_the_area() -> None:
    shape = (4, 5, 6)
    system = assemble_voxels(np.zeros(shape, dtype=int), VOXEL, [PhaseSpec("m", 0, 1.0)],
                             outputs=["x0", "y1", "z0"])
    for face, row in system.observation.items():
        assert row.sum() == pytest.approx(1.0, rel=1e-13)
        axis = "xyz".index(face[0])
        area = np.prod([n * h for ax, (n, h) in enumerate(zip(shape, VOXEL, strict=True)) if ax != axis])
        assert face_mass(shape, VOXEL, face).sum() == pytest.approx(area, rel=1e-13)
