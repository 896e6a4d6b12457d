"""The petsc engine's reading of a coupled heat–moisture scene without PETSc (aromm.engines.petsc.problem): the
scene is no longer refused; the boxes' coupled systems (VoxelProblem.part, what each rank assembles) add up to the
whole image's serial coupled system, term by term, load by load, fixed set by fixed set.  The distributed solves,
and what the engine still refuses, are tested under MPI (tests/test_petsc_moisture.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import petsc_moisture_cases as cases
import pytest
import scipy.sparse as sp
from test_hygrothermal_scene import _scene

from aromm.core.system import dense
from aromm.engines.petsc.layout import BoxLayout
from aromm.engines.petsc.problem import VoxelProblem
from aromm.fem.voxel_grid import node_index
from aromm.scene.scene_file import assemble, load_scene


def _box_unknowns(layout: BoxLayout, nodes: int) -> np.ndarray:
    """The whole image's unknowns (T block, then φ block) of the box's unknowns (the same blocks over its nodes)."""
    (x0, x1), (y0, y1), (z0, z1) = layout.box
    i, j, k = np.meshgrid(np.arange(x0, x1 + 1), np.arange(y0, y1 + 1), np.arange(z0, z1 + 1), indexing="ij")
    natural = node_index(layout.shape, i, j, k).ravel(order="F")
    return np.concatenate([natural, natural + nodes])


@pytest.mark.parametrize("processors", [(2, 1, 1), (1, 2, 2)])
def test_boxes_add_up_to_the_whole_coupled_system(processors: tuple[int, int, int]) -> None:
    """Every coupled term of the whole image (conduction, capacity, vapour exchange) is the sum of the boxes'
    (within rounding), every load too (the heat and moisture fluxes through the whole face shared by area), and each
    fixed set is the union of the boxes'."""
    scene = cases.transient_scene()
    whole = assemble(scene)
    problem = VoxelProblem.from_scene(scene)
    assert problem.fields == 2 and problem.template().fields == ("T", "phi")
    nodes = whole.n // 2
    size = int(np.prod(processors))
    sums: dict[str, sp.csr_array | np.ndarray] = {}
    fixed: dict[str, set[int]] = {}
    for rank in range(size):
        layout = BoxLayout.split(cases.SHAPE, size, rank, processors)
        box = problem.part(problem.image.read(layout.box), layout.faces())
        where = _box_unknowns(layout, nodes)
        embed = sp.csr_array((np.ones(where.size), (where, np.arange(where.size))), shape=(whole.n, box.n))
        for term in (*box.conductance.terms, *box.capacity.terms, *box.load.terms):
            op = embed @ sp.csr_array(term.operator) @ embed.T if sp.issparse(term.operator) \
                else embed @ np.asarray(term.operator)
            sums[term.name] = sums[term.name] + op if term.name in sums else op
        for d in box.dirichlet:
            fixed.setdefault(d.name, set()).update(where[d.dofs].tolist())
    for term in (*whole.conductance.terms, *whole.capacity.terms, *whole.load.terms):
        expected = dense(term.operator) if not sp.issparse(term.operator) else term.operator.toarray()
        found = sums[term.name].toarray() if sp.issparse(sums[term.name]) else dense(sums[term.name])
        scale = float(np.abs(expected).max())
        assert scale > 0.0 and np.abs(found - expected).max() <= 1e-12 * scale, term.name
    assert {d.name: set(d.dofs.tolist()) for d in whole.dirichlet} == fixed


def test_a_coupled_scene_is_read_with_the_serial_parameters_and_outputs(tmp_path: Path) -> None:
    """The problem keeps the scene's moisture: its template has the serial system's parameters and outputs."""
    scene = load_scene(_scene(tmp_path))
    problem = VoxelProblem.from_scene(scene)
    template = problem.template()
    assert problem.moisture is not None and template.fields == ("T", "phi")
    assert template.parameters == assemble(scene).parameters and list(template.observation) == ["x1", "phi:x1"]
