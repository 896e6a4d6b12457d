"""Cell-centred finite volumes (aromm.fv) against independent truths: laminates (harmonic and arithmetic means), an
independent two-point-flux solver written here the way taufactor's equations read, mirror symmetry (periodic =
fixed temperatures), conservation, straight channels in an insulator, and the slab's analytic series."""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from aromm.core.errors import InputError
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem.voxel import assemble_voxels
from aromm.full.analytic import slab_dirichlet_series
from aromm.full.solve import reaction_heat_flow, steady_field, transient
from aromm.fv.volumes import assemble_volumes
from aromm.homogenization.cell_problems import effective_conductivity
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

EPS = np.finfo(float).eps
VOXEL = (1e-3, 2e-3, 1.5e-3)


def _scene(labels: np.ndarray, phases: tuple[PhaseSpec, ...], voxel: tuple[float, ...] = VOXEL) -> Scene:
    return Scene(VoxelGeometry(labels, voxel), phases, discretisation="fv")  # type: ignore[arg-type]


def _floor(contrast: float, n: int) -> float:
    """Relative rounding floor of a direct solve: eps times the condition (≲ contrast · n², n cells per side)."""
    return 1e3 * EPS * contrast * n**2


@pytest.mark.parametrize("boundary", ["periodic", "temperature"])
@pytest.mark.parametrize("contrast", [10.0, 1e4])
def test_laminate_is_exact_across_and_along_the_layers(boundary: str, contrast: float) -> None:
    labels = np.zeros((6, 5, 4), dtype=int)
    labels[1::2] = 1  # layers normal to x
    phases = (PhaseSpec("a", 0, 1.0), PhaseSpec("b", 1, contrast))
    k = effective_conductivity(_scene(labels, phases), boundary, "splu").k
    harmonic, arithmetic = 2.0 / (1.0 + 1.0 / contrast), (1.0 + contrast) / 2.0
    assert np.diag(k) == pytest.approx([harmonic, arithmetic, arithmetic], rel=_floor(contrast, 6))
    assert np.abs(k - np.diag(np.diag(k))).max() <= _floor(contrast, 6) * arithmetic


def _reference_k(labels: np.ndarray, k_of: dict[int, float], voxel: tuple[float, ...], axis: int) -> float:
    """taufactor's scheme written out voxel by voxel: cell unknowns only, harmonic-mean face conductances,
    the fixed temperatures 1 and 0 half a cell outside the first and last layers (conductance 2 k A / d)."""
    shape = labels.shape
    n = labels.size
    number = np.arange(n).reshape(shape)
    area = float(np.prod(voxel)) / voxel[axis]
    a = sp.lil_array((n, n))
    b = np.zeros(n)
    for idx in np.ndindex(shape):
        i = number[idx]
        for ax in range(3):
            face_area = float(np.prod(voxel)) / voxel[ax]
            nxt = list(idx)
            nxt[ax] += 1
            if nxt[ax] < shape[ax]:
                j = number[tuple(nxt)]
                ki, kj = k_of[int(labels[idx])], k_of[int(labels[tuple(nxt)])]
                g = face_area / (voxel[ax] / (2 * ki) + voxel[ax] / (2 * kj))
                a[i, i] += g
                a[j, j] += g
                a[i, j] -= g
                a[j, i] -= g
        if idx[axis] in (0, shape[axis] - 1):
            g = 2.0 * k_of[int(labels[idx])] * area / voxel[axis]
            a[i, i] += g * (2 if shape[axis] == 1 else 1)
            if idx[axis] == 0:
                b[i] += g  # T = 1 on the first face
    t = spla.spsolve(sp.csc_array(a), b)
    hot = np.take(number, 0, axis=axis).ravel()
    conductance = 2.0 * np.array([k_of[int(v)] for v in labels.ravel()])[hot] * area / voxel[axis]
    flow = float(conductance @ (1.0 - t[hot]))
    box_area = area * labels.size / shape[axis]
    return flow * shape[axis] * voxel[axis] / box_area


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("contrast", [10.0, 1e3])
def test_fixed_temperature_k_equals_an_independent_two_point_flux_solver(seed: int, contrast: float) -> None:
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, 3, size=(5, 4, 6))
    k_of = {0: 1.0, 1: contrast, 2: np.sqrt(contrast)}
    phases = tuple(PhaseSpec(f"p{i}", i, k) for i, k in k_of.items())
    k = effective_conductivity(_scene(labels, phases), "temperature", "splu").k
    for axis in range(3):
        assert k[axis, axis] == pytest.approx(_reference_k(labels, k_of, VOXEL, axis), rel=_floor(contrast, 6))


def test_mirror_symmetric_cell_has_the_same_periodic_and_fixed_temperature_tensor() -> None:
    rng = np.random.default_rng(3)
    half = rng.integers(0, 2, size=(4, 3, 5))
    labels = half
    for axis in range(3):
        labels = np.concatenate([labels, np.flip(labels, axis=axis)], axis=axis)
    phases = (PhaseSpec("a", 0, 1.0), PhaseSpec("b", 1, 50.0))
    scene = _scene(labels, phases)
    periodic = effective_conductivity(scene, "periodic", "splu").k
    fixed = effective_conductivity(scene, "temperature", "splu").k
    assert np.diag(periodic) == pytest.approx(np.diag(fixed), rel=_floor(50.0, 10))
    assert periodic == pytest.approx(periodic.T, abs=_floor(50.0, 10) * periodic.max())


def test_heat_in_equals_heat_out_and_the_tensor_follows_a_transposed_image() -> None:
    rng = np.random.default_rng(4)
    labels = rng.integers(0, 2, size=(5, 6, 7))
    phases = [PhaseSpec("a", 0, 0.1), PhaseSpec("b", 1, 20.0)]
    system = assemble_volumes(labels, VOXEL, phases, [FaceSpec("y0", T=1.0), FaceSpec("y1", T=0.0)])
    field = steady_field(system, method="splu")
    into = reaction_heat_flow(system, field, system.dirichlet[0].dofs)
    out = reaction_heat_flow(system, field, system.dirichlet[1].dofs)
    assert into > 0
    assert into + out == pytest.approx(0.0, abs=_floor(200.0, 7) * into)
    k = effective_conductivity(_scene(labels, tuple(phases), (1e-3,) * 3), "periodic", "splu").k
    turned = effective_conductivity(_scene(labels.transpose(2, 0, 1), tuple(phases), (1e-3,) * 3), "periodic",
                                    "splu").k
    order = [2, 0, 1]
    assert turned == pytest.approx(k[np.ix_(order, order)], rel=_floor(200.0, 7))


def test_a_straight_channel_in_an_insulator_conducts_its_area_fraction_only() -> None:
    labels = np.zeros((6, 6, 10), dtype=int)
    labels[2:4, 2:4, :] = 1
    phases = (PhaseSpec("solid", 0, 0.0), PhaseSpec("pore", 1, 2.0))
    for boundary in ("periodic", "temperature", "flux"):
        k = effective_conductivity(_scene(labels, phases, (1e-3,) * 3), boundary, "splu").k
        assert np.diag(k) == pytest.approx([0.0, 0.0, 2.0 * 4 / 36], rel=_floor(1.0, 10), abs=_floor(1.0, 10) * 2.0)


def test_a_direction_without_a_path_between_its_faces_gives_exactly_zero(caplog: pytest.LogCaptureFixture) -> None:
    """An insulating layer across z, with conductors on both sides touching the fixed faces: no heat can go from z0 to
    z1, so k_zz = 0 exactly (a solve gave 2e-15 of rounding before), said in the log; along the layer 7 of 8 slices
    conduct: k_xx = k_yy = 7/8 (the laminate, exact in finite volumes)."""
    labels = np.zeros((8, 8, 8), dtype=int)
    labels[:, :, 4] = 1
    phases = (PhaseSpec("solid", 0, 1.0), PhaseSpec("pore", 1, 0.0))
    with caplog.at_level(logging.INFO, logger="aromm.homogenization.fv_cells"):
        k = effective_conductivity(_scene(labels, phases, (1e-3,) * 3), "temperature", "splu").k
    assert k[2, 2] == 0.0 and "no conducting path along z" in caplog.text
    assert np.diag(k)[:2] == pytest.approx([7 / 8, 7 / 8], rel=_floor(1.0, 8))
    labels[2, 2, 4] = 0  # one conducting voxel through the layer: a path, a positive k_zz
    k = effective_conductivity(_scene(labels, phases, (1e-3,) * 3), "temperature", "splu").k
    assert k[2, 2] > 0.0


def test_an_isolated_cluster_is_left_out_and_said_in_the_log(caplog: pytest.LogCaptureFixture) -> None:
    labels = np.zeros((6, 6, 10), dtype=int)
    labels[2:4, 2:4, :] = 1
    labels[0, 0, 4:6] = 1  # two voxels that touch no face along z and no channel
    phases = [PhaseSpec("solid", 0, 0.0), PhaseSpec("pore", 1, 2.0)]
    with caplog.at_level(logging.INFO, logger="aromm.fv.volumes"):
        system = assemble_volumes(labels, (1e-3,) * 3, phases, [FaceSpec("z0", T=1.0), FaceSpec("z1", T=0.0)])
    assert system.n == 40 + 2 * 4  # the channel's cells and its face unknowns; the cluster is gone
    assert "2 voxels (0.5556 % of the volume)" in caplog.text


def test_a_homogeneous_image_gives_the_same_k_in_both_discretisations() -> None:
    labels = np.zeros((5, 4, 6), dtype=int)
    scene = _scene(labels, (PhaseSpec("a", 0, (1.0, 2.0, 3.0)),))
    for boundary in ("periodic", "temperature"):
        fv = np.diag(effective_conductivity(scene, boundary, "splu").k)
        q1 = np.diag(effective_conductivity(replace(scene, discretisation="q1"), boundary, "splu").k)
        assert fv == pytest.approx([1.0, 2.0, 3.0], rel=_floor(3.0, 6))
        assert q1 == pytest.approx(fv, rel=1e-8)  # the q1 cell problems' default residual 1e-8


def _slab_error(nz: int, dt: float, t_end: float) -> float:
    length, k, c = 0.01, 1.0, 1e6
    system = assemble_volumes(np.zeros((1, 1, nz), dtype=int), (length, length, length / nz),
                              [PhaseSpec("a", 0, k, c)], [FaceSpec("z0", T=25.0), FaceSpec("z1", T=100.0)],
                              time=TimeGrid(t_end, dt), initial_T=25.0)
    obs = transient(system, times=[t_end], fields=True, method="splu")
    assert obs.fields is not None
    z = (np.arange(nz) + 0.5) * length / nz  # the cell centres
    exact = slab_dirichlet_series(z, t_end, length, k / c, 25.0, 25.0, 100.0, n_terms=400)
    return float(np.max(np.abs(obs.fields[0][:nz] - exact)))


def test_slab_between_fixed_faces_converges_at_second_order_in_space() -> None:
    t_end = 0.05 * 0.01**2 / 1e-6
    errors = [_slab_error(nz, t_end / 400, t_end) for nz in (8, 16, 32)]
    rates = np.log2(np.asarray(errors[:-1]) / np.asarray(errors[1:]))
    assert np.all(rates > 1.8), (errors, rates)


def test_insulating_phase_and_rotated_tensors_are_refused_where_they_do_not_apply() -> None:
    labels = np.array([0, 1]).reshape(2, 1, 1)
    phases = [PhaseSpec("solid", 0, 0.0, 1e6), PhaseSpec("pore", 1, 2.0, 1e6)]
    with pytest.raises(InputError, match=r"'solid': k = 0 .* steady scenes"):
        assemble_volumes(labels, (1e-3,) * 3, phases, [FaceSpec("x0", T=1.0)], time=TimeGrid(1.0, 0.1))
    with pytest.raises(InputError, match=r"k = 0 .* finite volumes"):
        assemble_voxels(labels, (1e-3,) * 3, phases, [FaceSpec("x0", T=1.0)])
