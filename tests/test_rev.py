"""REV study (aromm.rev, aromm.homogenization.representative, aromm rev) on a periodic image whose answer is known.

Independent truths: a cube whose edge is a multiple of the period p of an image is a cyclic shift of p-cells at
any position, and periodic homogenisation is invariant under cyclic shifts, so its k̄ is the unit cell's (computed
here on the cell alone) and the spread between positions vanishes to solver tolerance; a cube of another edge is
not such a shift.  On a mirror-symmetric cell the fixed-temperature condition equals the periodic one, and uniform
flux lies below it (aromm.homogenization.cell_problems).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import aromm
from aromm.cli import main
from aromm.core.errors import InputError
from aromm.homogenization.properties import homogenize
from aromm.homogenization.representative import save_rev_plot
from aromm.scene.scene_file import scene_from_dict

PERIOD = 6
PHASES = {"matrix": {"label": 0, "k": 1.0, "c": 1.0e6}, "sphere": {"label": 1, "k": 10.0, "c": 2.0e6}}
GEOMETRY = {"generator": "simple_cubic", "n_cells": 3, "cell_voxels": PERIOD, "phi": 0.3, "voxel_size": 1e-4}


def _scene(n_cells: int = 3):  # type: ignore[no-untyped-def]
    return scene_from_dict({"geometry": {**GEOMETRY, "n_cells": n_cells}, "phases": PHASES})


@pytest.mark.parametrize("method", ["cholmod", "mg"])
def test_rev_of_a_periodic_image_is_its_period(method: str) -> None:
    study = aromm.rev(_scene(), edges=[4, PERIOD, 2 * PERIOD], tolerance=1e-6, method=method)
    cell = np.diag(homogenize(_scene(1), method="cholmod"))  # the unit cell alone
    rtol = 1e-10 if method == "cholmod" else 1e-6  # mg: CG to 1e-8, contrast 10
    by_edge = {e.edge: e for e in study.edges}
    for edge in (PERIOD, 2 * PERIOD):
        assert len(by_edge[edge].origins) == 9
        assert by_edge[edge].spread < rtol
        np.testing.assert_allclose(by_edge[edge].k, np.broadcast_to(cell, by_edge[edge].k.shape), rtol=rtol)
        assert by_edge[edge].c is not None
        np.testing.assert_allclose(by_edge[edge].c, by_edge[edge].c[0], rtol=1e-14)  # equal volume fractions
    assert by_edge[4].spread > 0.05  # not a multiple of the period: positions see different pieces of spheres
    assert study.rev_edge == PERIOD
    assert study.crop == ((6, 12), (6, 12), (6, 12))  # the centred cube of the REV edge in the 18³ image
    k_t, k_p, k_f = (study.boundaries[b] for b in ("temperature", "periodic", "flux"))
    np.testing.assert_allclose(k_t, k_p, rtol=rtol)  # mirror-symmetric cell
    assert np.all(k_f < k_p * (1 - 1e-4))  # uniform flux: lower-bound type
    assert study.boundary_spread == pytest.approx(float(np.max((k_p - k_f) / k_p)), rel=1e-12)
    assert not study.representative  # the flux condition still differs by more than 1e-6


def test_rev_command_json_plot_and_refusals(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "cubic.toml"
    path.write_text("""
[geometry]
generator = "simple_cubic"
n_cells = 2
cell_voxels = 6
phi = 0.3
voxel_size = 1.0e-4
[phases.matrix]
label = 0
k = 1.0
[phases.sphere]
label = 1
k = 10.0
""", encoding="utf-8")
    png = tmp_path / "rev.png"
    assert main(["rev", str(path), "--edges", "4,6", "--positions", "4", "--tolerance", "1e-6", "--json",
                 "--plot", str(png)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["rev_edge"] == 6 and out["crop"] == [[3, 9]] * 3
    assert [e["positions"] for e in out["edges"]] == [4, 4] and out["edges"][0]["c_mean"] is None
    assert set(out["boundaries"]) == {"flux", "periodic", "temperature"}
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert main(["rev", str(path), "--edges", "4,6", "--no-boundaries"]) == 0
    text = capsys.readouterr().out
    assert "REV edge" in text and "flux boundary" not in text
    assert main(["rev", str(path), "--edges", "4,13"]) == 2
    assert "REV edges" in capsys.readouterr().err
    assert main(["rev", str(path), "--edges", "4,x"]) == 2


def test_not_representative_is_said() -> None:
    study = aromm.rev(_scene(2), edges=[4, 5], positions=3, tolerance=1e-3, boundaries=False)
    assert study.rev_edge is None and study.crop is None and not study.representative
    assert "not representative" in str(study)
    with pytest.raises(InputError, match="positions"):
        aromm.rev(_scene(2), positions=0)


def test_rev_plot_is_written(tmp_path: Path) -> None:
    study = aromm.rev(_scene(2), edges=[4, 6], positions=2)
    assert save_rev_plot(study, tmp_path / "rev.svg").read_text(encoding="utf-8").startswith("<?xml")
