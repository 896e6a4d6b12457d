"""The finite-volume rows of the petsc engine (aromm.engines.petsc.volume_assembly.VolumeRows), plain arithmetic
checked without PETSc: over every rank of a layout, the unknowns each rank owns in its padded box are exactly its
row block, and together they number the whole image's unknowns once each."""

from __future__ import annotations

import numpy as np
import pytest

from aromm.core.errors import InputError
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.engines.petsc.layout import BoxLayout
from aromm.engines.petsc.problem import VoxelProblem
from aromm.engines.petsc.volume_assembly import VolumeRows, global_rows, halo_box, padded_system
from aromm.fv.grid import VolumeGrid
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene

PHASES = (PhaseSpec("a", 0, 1.0), PhaseSpec("b", 1, 3.0))


def problem(shape: tuple[int, int, int], boundary: tuple[FaceSpec, ...], outputs: tuple[str, ...]) -> VoxelProblem:
    labels = (np.random.default_rng(1).random(shape) < 0.5).astype(np.int32)
    return VoxelProblem.from_scene(Scene(VoxelGeometry(labels, (1.0, 1.0, 1.0)), PHASES, boundary, 0.0, None, outputs,
                                         discretisation="fv"))


@pytest.mark.parametrize(("shape", "size"), [((5, 4, 6), 1), ((5, 4, 6), 3), ((5, 4, 6), 4), ((3, 7, 2), 6),
                                             ((8, 8, 8), 8)])
def test_owned_unknowns_are_each_ranks_row_block(shape: tuple[int, int, int], size: int) -> None:
    p = problem(shape, (FaceSpec("x0", T=1.0), FaceSpec("z1", h=2.0, T_ext=0.0)), ("y1", "z1"))
    seen = []
    for rank in range(size):
        layout = BoxLayout.split(shape, size, rank)
        numbering = VolumeRows(layout, ("x0", "y1", "z1"))
        _, grid, box, _ = padded_system(p, layout)
        assert box == halo_box(layout)
        rows, mine = global_rows(grid, box, numbering)
        owned = np.sort(rows[mine])
        assert np.array_equal(owned, np.arange(numbering.rows.lo, numbering.rows.hi))
        seen.append(owned)
    whole = int(np.prod(shape)) + shape[1] * shape[2] + shape[0] * shape[2] + shape[0] * shape[1]
    assert np.array_equal(np.sort(np.concatenate(seen)), np.arange(whole))


def test_global_rows_of_the_whole_image_are_a_permutation() -> None:
    p = problem((4, 5, 3), (FaceSpec("y0", flux=1.0),), ("x1",))
    layout = BoxLayout.split((4, 5, 3), 4, 0)
    grid = VolumeGrid(np.zeros((4, 5, 3), dtype=np.int64), (1.0, 1.0, 1.0), ("x1", "y0"))
    rows, _ = global_rows(grid, ((0, 4), (0, 5), (0, 3)), VolumeRows(layout, ("x1", "y0")))
    assert np.array_equal(np.sort(rows), np.arange(grid.n))
    assert p.discretisation == "fv"


def test_an_insulating_phase_is_refused_with_the_way_out() -> None:
    labels = np.zeros((3, 3, 3), dtype=np.int32)
    labels[1] = 1
    scene = Scene(VoxelGeometry(labels, (1.0, 1.0, 1.0)), (PhaseSpec("a", 0, 1.0), PhaseSpec("pore", 1, 0.0)),
                  (FaceSpec("x0", T=1.0), FaceSpec("x1", T=0.0)), 0.0, None, ("x1",), discretisation="fv")
    with pytest.raises(InputError, match=r"phases\.pore: k = 0.*--engine scipy"):
        VoxelProblem.from_scene(scene).refuse_insulating()
