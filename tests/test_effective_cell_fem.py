"""Conforming-mesh finite elements with contact resistance: exact discrete cases, limits, convergence."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from aromm.bounds.cell_fem import CellModel, cell_mesh, conductance_from_reaction
from aromm.bounds.domain import cell_phi
from aromm.bounds.models import hasselman_johnson, rayleigh_simple_cubic
from aromm.core.errors import InputError
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem.mesh import assemble_mesh, split_dofs
from aromm.full.solve import simulate


def kuhn_box(n: int, labels_of_z) -> meshio.Mesh:  # type: ignore[no-untyped-def]
    """Structured tetrahedral mesh of the unit cube (6 tets per sub-cube), cell data from the centroid height."""
    g = np.linspace(0.0, 1.0, n + 1)
    zz, yy, xx = np.meshgrid(g, g, g, indexing="ij")
    pts = np.column_stack([xx.ravel(), yy.ravel(), zz.ravel()])

    def nid(i, j, k):  # type: ignore[no-untyped-def]
        return i + (n + 1) * (j + (n + 1) * k)

    tets = []
    for k in range(n):
        for j in range(n):
            for i in range(n):
                c = [nid(i + a, j + b, k + d) for d in (0, 1) for b in (0, 1) for a in (0, 1)]
                for p in ((0, 1, 3, 7), (0, 1, 5, 7), (0, 2, 3, 7), (0, 2, 6, 7), (0, 4, 5, 7), (0, 4, 6, 7)):
                    tets.append([c[q] for q in p])
    tets_a = np.asarray(tets)
    labels = labels_of_z(pts[tets_a].mean(axis=1)[:, 2])
    return meshio.Mesh(pts, [("tetra", tets_a)], cell_data={"gmsh:physical": [labels]})


@pytest.mark.parametrize("order", [1, 2])
def test_layered_box_with_contact_resistance_is_exact(order: int) -> None:
    """Series layers along z with R on one interface: P1 and P2 hold the piecewise-linear field exactly."""
    mesh = kuhn_box(4, lambda z: np.where(z < 0.5, 1, 2))
    phases = [PhaseSpec("a", 1, 2.0), PhaseSpec("b", 2, 0.5)]
    system = assemble_mesh(mesh, phases, [FaceSpec("z0", T=0.0), FaceSpec("z1", T=1.0)],
                           interfaces={"a|b": 0.3}, order=order)
    if order == 1:
        assert system.n == 125 + 25  # one plane of 5 x 5 nodes duplicated
    q = conductance_from_reaction(system, {})
    assert q == pytest.approx(1.0 / (0.5 / 2.0 + 0.3 + 0.5 / 0.5), rel=1e-12)
    # the same through the named parameter h_c = 1/R
    assert conductance_from_reaction(system, {"a|b.h_c": 1 / 0.6}) == pytest.approx(1 / (0.25 + 0.6 + 1.0), rel=1e-12)


@pytest.mark.parametrize("order", [1, 2])
def test_three_layers_resistance_only_where_asked_and_cell_sets_by_name(order: int) -> None:
    mesh = kuhn_box(6, lambda z: np.select([z < 1 / 3, z < 2 / 3], [1, 2], 3))
    labels = mesh.cell_data.pop("gmsh:physical")[0]
    mesh.cell_sets = {name: [np.flatnonzero(labels == tag)] for name, tag in (("a", 1), ("b", 2), ("c", 3))}
    phases = [PhaseSpec("a", 0, 1.0), PhaseSpec("b", 0, 3.0), PhaseSpec("c", 0, 0.2)]
    system = assemble_mesh(mesh, phases, [FaceSpec("z0", T=0.0), FaceSpec("z1", T=1.0)],
                           interfaces={"c|b": 0.5, "a|b": 0.0}, order=order)
    if order == 1:
        assert system.n == 7**3 + 7**2
    assert "G_c|b" in system.term_names and system.parameters["c|b.h_c"] == 2.0
    q = conductance_from_reaction(system, {})
    assert q == pytest.approx(1.0 / (1 / 3 / 1.0 + 1 / 3 / 3.0 + 0.5 + 1 / 3 / 0.2), rel=1e-12)


def test_split_counts_at_a_triple_point() -> None:
    """2-D: four triangles around a centre node 4; phases a, b, b, c; copies per perfect-contact group."""
    tri = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    phase = np.array([0, 1, 1, 2])
    names = ["a", "b", "c"]
    one = split_dofs(tri, phase, 5, names, {"a|b": 1.0})
    # a|c and c|b perfect join a and b through c at the centre: only node 1 (a|b alone) is split
    assert one.n == 5 + 1
    both = split_dofs(tri, phase, 5, names, {"a|b": 1.0, "b|c": 1.0})
    assert both.n == 5 + 1 + 1 + 1  # node 1 (a|b), node 3 (b|c), centre {a, c} | {b}
    every = split_dofs(tri, phase, 5, names, {"a|b": 1.0, "b|c": 1.0, "a|c": 1.0})
    assert every.n == 5 + 2 + 1 + 1 + 1  # centre: three copies; nodes 0, 1, 3: two each
    for split in (one, both, every):
        assert np.array_equal(split.source[:5], np.arange(5))
        rows = np.arange(5)[:, None]
        touched = split.dof >= 0
        assert np.all(split.source[split.dof[touched]] == np.broadcast_to(rows, split.dof.shape)[touched])


@pytest.fixture(scope="module")
def coarse_cell() -> CellModel:
    return CellModel("cell", 0.5, 0.4, order=1)


def test_octant_geometry_volumes_and_interface_area(coarse_cell: CellModel) -> None:
    mesh = coarse_cell.mesh
    pts, tets = mesh.points, mesh.cells[0].data
    e = pts[tets[:, 1:]] - pts[tets[:, :1]]
    vol = np.abs(np.linalg.det(e)) / 6
    label = mesh.cell_data["gmsh:physical"][0]
    assert vol.sum() == pytest.approx(1.5**3, rel=1e-12)
    assert vol[label == 1].sum() == pytest.approx(np.pi / 6, rel=1e-2)  # inscribed polyhedron, O(h^2)
    system = coarse_cell.system(True)
    assert system.geometry is not None
    filler_dofs = np.unique(system.geometry.cells[np.asarray(system.geometry.cell_data["phase"]) == 0])
    x = np.zeros(system.n)
    x[filler_dofs] = 1.0  # jump of x across the interface is 1: x^T (J^T M J) x = interface area
    area = float(x @ (system.conductance["G_filler|matrix"].operator @ x))
    assert area == pytest.approx(np.pi / 2, rel=1e-2)  # octant of the sphere, pi a^2 / 2


@pytest.mark.parametrize("order", [1, 2])
def test_neutral_inclusion_converges_to_one(order: int) -> None:
    """D + C = 1 (kappa = 2, R_c = a/(2 lambda_m)): E_c = 1 in the continuum, not exactly for the
    discrete problem: the polyhedral interface has piecewise-constant normals, so the exact field
    (T = z outside, T = D z inside) no longer balances the interface flux; the defect is geometric
    (the same for P1 and P2) and O(h^2)."""
    errors = [abs(CellModel("cell", 0.5, h, order).E(0.5, 0.5) - 1.0) for h in (0.4, 0.25)]
    assert errors[0] < 1e-4 and errors[1] < 4e-5
    assert errors[0] / errors[1] > (0.4 / 0.25) ** 1.5


def test_dilute_limit_matches_hasselman_johnson() -> None:
    model = CellModel("cell", 3.0, 0.4)  # P2
    phi = float(cell_phi(3.0))
    for c, d in [(0.0, 0.1), (0.2, 0.01), (2.0, 0.1)]:
        fe = model.E(c, d)
        assert (fe - 1) / (hasselman_johnson(phi, 1 / d, c) - 1) == pytest.approx(1.0, abs=0.01)


def test_vanishing_resistance_matches_the_perfect_interface(coarse_cell: CellModel) -> None:
    perfect = coarse_cell.E(0.0, 0.1)
    assert coarse_cell.E(1e-9, 0.1) == pytest.approx(perfect, rel=1e-8)
    assert coarse_cell.E(1e-4, 0.1) < perfect


@pytest.mark.parametrize(("order", "bound", "min_rate"), [(1, 3e-3, 0.5), (2, 5e-4, 1.5)])
def test_cell_value_converges_to_the_exact_simple_cubic_value(order: int, bound: float, min_rate: float) -> None:
    """E_c against Rayleigh's series (error < 2e-6 at phi = 4 pi/81); rate against h.

    P1 is pre-asymptotic on these meshes (~2 on finer ones, benchmarks/bounds_fem.py); P2 is
    limited by the O(h^2) polyhedral geometry."""
    exact = rayleigh_simple_cubic(4 * np.pi / 81, 10.0, 0.1)
    errors = [abs(CellModel("cell", 0.5, h, order).E(0.1, 0.1) - exact) for h in (0.4, 0.25)]
    rate = np.log(errors[0] / errors[1]) / np.log(0.4 / 0.25)
    assert errors[1] < bound * exact
    assert rate > min_rate


def test_sub_cells_order_the_single_wall_bounds(coarse_cell: CellModel) -> None:
    from aromm.bounds.wall import wall_1a, wall_1b, wall_inf_a, wall_inf_b

    b, c, d = 0.5, 0.1, 0.1
    e_c = coarse_cell.E(c, d)
    e_ii = CellModel("cylinder", b, 0.4, order=1).E(c, d)
    e_bot = CellModel("slab", b, 0.4, order=1).E(c, d)
    assert wall_inf_a(b, c, d) <= wall_1a(b, e_ii) <= e_c <= wall_1b(b, e_bot) <= wall_inf_b(b, c, d)


def test_transient_system_conserves_heat_with_contact_resistance() -> None:
    """Flux q into z0, every other face adiabatic: total heat = q A t exactly for the discrete system."""
    mesh = cell_mesh("cell", 1.0, 0.5, a=1e-3)
    phases = [PhaseSpec("filler", 1, 10.0, c=2e6), PhaseSpec("matrix", 2, 0.5, c=1e6)]
    system = assemble_mesh(mesh, phases, [FaceSpec("z0", flux=1e3)], interfaces={"filler|matrix": 1e-4},
                           time=TimeGrid(end=2.0, dt=0.5), outputs=["z0", "z1"], order=2)
    assert set(system.term_names) >= {"C_filler", "C_matrix", "K_filler", "K_matrix", "G_filler|matrix", "U_z0"}
    obs = simulate(system, fields=True)
    assert obs.fields is not None
    cap = system.capacity.evaluate(system.values())
    heat = np.array([np.ones(system.n) @ (cap @ f) for f in obs.fields])
    area = (2e-3) ** 2
    assert heat == pytest.approx(1e3 * area * obs.t, rel=1e-9)
    assert np.all(obs.mean_T["z0"] > obs.mean_T["z1"])


@pytest.mark.parametrize(("call", "word"), [
    (lambda: CellModel("cell", 0.0, 0.4), "B"),
    (lambda: cell_mesh("cube", 0.5, 0.4), "kind"),  # type: ignore[arg-type]
    (lambda: cell_mesh("cell", 0.5, 0.0), "h"),
])
def test_bad_cell_input(call, word: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InputError, match=word):
        call()


def test_bad_mesh_input(coarse_cell: CellModel) -> None:
    phases = [PhaseSpec("filler", 1, 1.0), PhaseSpec("matrix", 2, 1.0)]
    with pytest.raises(InputError, match="interface"):
        assemble_mesh(coarse_cell.mesh, phases, interfaces={"filler|gas": 1.0})
    with pytest.raises(InputError, match="R must"):
        assemble_mesh(coarse_cell.mesh, phases, interfaces={"filler|matrix": -1.0})
    with pytest.raises(InputError, match="no phase"):
        assemble_mesh(coarse_cell.mesh, phases[:1])
    with pytest.raises(InputError, match="D"):
        coarse_cell.E(0.1, 0.0)


@pytest.mark.parametrize("order", [1, 2])
def test_two_dimensional_triangle_mesh_with_contact_resistance_is_exact(order: int) -> None:
    n = 6
    g = np.linspace(0.0, 1.0, n + 1)
    xx, yy = np.meshgrid(g, g, indexing="xy")
    pts = np.column_stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)])
    tri = []
    for j in range(n):
        for i in range(n):
            a = i + (n + 1) * j
            tri += [[a, a + 1, a + n + 2], [a, a + n + 2, a + n + 1]]
    tri_a = np.asarray(tri)
    labels = np.where(pts[tri_a].mean(axis=1)[:, 1] < 0.5, 1, 2)
    mesh = meshio.Mesh(pts, [("triangle", tri_a)], cell_data={"gmsh:physical": [labels]})
    system = assemble_mesh(mesh, [PhaseSpec("a", 1, 2.0), PhaseSpec("b", 2, 0.5)],
                           [FaceSpec("y0", T=0.0), FaceSpec("y1", T=1.0)], interfaces={"a|b": 0.3}, order=order,
                           outputs=["y1"])
    field = simulate(system, fields=True).fields
    assert field is not None
    k = system.conductance.evaluate(system.values())
    top = next(d.dofs for d in system.dirichlet if d.name == "T_y1")
    assert float(np.sum((k @ field[0])[top])) == pytest.approx(1 / (0.25 + 0.3 + 1.0), rel=1e-12)
    with pytest.raises(InputError, match="face"):
        assemble_mesh(mesh, [PhaseSpec("a", 1, 2.0), PhaseSpec("b", 2, 0.5)], [FaceSpec("z0", T=0.0)])
