"""Mesh scenes: a conforming tetrahedral mesh with contact resistance, through the scene file and CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scene_text import MESH_CELL

from aromm.bounds.cell_fem import cell_mesh
from aromm.cli import main
from aromm.core.errors import InputError
from aromm.full.solve import transient
from aromm.homogenization.properties import mean_capacity
from aromm.scene.scene_file import assemble, load_scene

SCENE = MESH_CELL


@pytest.fixture(scope="module")
def cell_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("mesh")
    cell_mesh("cell", B=0.5, h=0.5).write(folder / "cell.vtu")
    return folder


def test_neutral_inclusion_is_invisible_through_the_cli(cell_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """D + C = 1 (κ = 2, R = a / (2 λ_m)): the inclusion is neutral, so k_eff = λ_m = 1 for a true sphere.

    The mesh's sphere is a polyhedron (facets of size ~h/4), so 1 is met to the geometric error, 1e-4 here.
    """
    path = cell_dir / "neutral.toml"
    path.write_text(SCENE.format(R=0.5), encoding="utf-8")
    assert main(["homogenize", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(np.diag(out["k"]), 1.0, rtol=1e-3)
    phi = (np.pi / 6) / 1.5**3  # octant of a unit sphere in a cube of side 1 + B
    assert out["c"] == pytest.approx(phi * 3e6 + (1 - phi) * 1e6, rel=0.02)  # polyhedral sphere volume


def test_contact_resistance_lowers_k_and_runs_transient(cell_dir: Path) -> None:
    path = cell_dir / "resistive.toml"
    path.write_text(SCENE.format(R=5.0) + '\n[boundary.z0]\nflux = 1.0\n[boundary.z1]\nh = 1.0\n'
                    '[time]\nend = 2.0\ndt = 0.5\n[outputs]\nmean_T = ["z0", "z1"]\n', encoding="utf-8")
    scene = load_scene(path)
    system = assemble(scene)
    assert "G_filler|matrix" in system.conductance.names
    obs = transient(system)
    assert np.all(np.diff(obs.mean_T["z0"]) > 0)
    assert mean_capacity(scene) > 1e6


def test_bad_mesh_scenes_are_refused(cell_dir: Path) -> None:
    path = cell_dir / "bad.toml"
    path.write_text(SCENE.format(R=0.5).replace("cell.vtu", "none.vtu"), encoding="utf-8")
    with pytest.raises(InputError, match=r"geometry\.mesh"):
        load_scene(path)
    path.write_text(SCENE.format(R=0.5).replace("label = 2", "label = 7"), encoding="utf-8")
    with pytest.raises(InputError, match=r"phases\.matrix\.label"):
        load_scene(path)
