"""The petsc engine's homogenised heat and moisture transport (the fixed-value and the flux probe, by boxes) against
the scipy engine's ``moisture_transport(..., boundary)`` on the cases of tests/petsc_moisture_homog_cases.py, at 1
rank (in the pytest process) and 2 ranks: equal within the steady solver's bound (that module's ``solve_bound``: from
linear.STEADY_RTOL and the condition number of the scaled probe matrix); on a laminate the fixed-value probe is the
exact arithmetic and harmonic means, the flux probe the harmonic one across the layers; ξ̄ the volume average.
`aromm homogenize --engine petsc` at 2 ranks prints the moisture block and emits it in --json (temperature, and flux,
its default); periodic is refused, naming what the petsc engine supports.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import petsc_moisture_cases as coupled_cases
import petsc_moisture_homog_cases as cases
import pytest
from test_petsc_engine import mpiexec, pytestmark, worker  # noqa: F401  (the same marks: mpi, skipped without PETSc)
from test_petsc_moisture import SCENE

from aromm.cli import main
from aromm.scene.scene_file import load_scene


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, np.ndarray]]:
    from aromm.engines.petsc import runtime

    return {"1 rank": cases.results(runtime.world()),
            "2 ranks": worker(tmp_path_factory, "petsc_moisture_homog_cases", 2)}


@pytest.fixture(scope="module")
def serial() -> dict[str, np.ndarray]:
    return cases.serial()


def test_the_two_ranks_cut_the_image(runs: dict[str, dict[str, np.ndarray]]) -> None:
    assert [int(np.prod(r["grid"])) for r in runs.values()] == [1, 2]


@pytest.mark.parametrize("boundary", cases.BOUNDARIES)
@pytest.mark.parametrize("label", [*cases.DISCRETISATIONS, "laminate"])
def test_moisture_transport_equals_the_scipy_engines(label: str, boundary: str,
                                                     runs: dict[str, dict[str, np.ndarray]],
                                                     serial: dict[str, np.ndarray]) -> None:
    """Every entry of the (3, 2, 2) matrix within its solve bound of the direct solves', ξ̄ to rounding."""
    expected = serial[f"{label}_{boundary}"]
    bound = cases.solve_bound(cases.all_cases()[label], boundary)
    assert np.abs(expected[:, 1, 0]).min() > 0.0  # the coupling shows: vapour moved by the temperature jump
    for where, found in runs.items():
        assert found[f"{label}_{boundary}"].shape == (3, 2, 2)
        assert (np.abs(found[f"{label}_{boundary}"] - expected) <= bound).all(), (where, label)
        assert float(found[f"{label}_xi"]) == pytest.approx(float(serial[f"{label}_xi"]), rel=1e-14)


def test_the_laminate_is_the_exact_means(runs: dict[str, dict[str, np.ndarray]]) -> None:
    """Across the layers the matrix harmonic mean, along them the arithmetic mean (exact for Q1 on voxel layers: the
    only error is the solver's; the flux probe across them only), ξ̄ the volume mean."""
    exact = cases.laminate_means()
    for where, found in runs.items():
        bound = cases.solve_bound(cases.laminate())
        assert (np.abs(found["laminate_temperature"] - exact) <= bound).all(), where
        bound = cases.solve_bound(cases.laminate(), "flux")
        assert (np.abs(found["laminate_flux"][0] - exact[0]) <= bound[0]).all(), where
        assert float(found["laminate_xi"]) == pytest.approx((200.0 + 0.017) / 2, rel=1e-14)


@pytest.mark.parametrize("boundary", cases.BOUNDARIES)
def test_cli_homogenize_prints_the_moisture_transport_on_two_ranks(boundary: str, tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """`mpiexec -n 2 aromm homogenize --engine petsc --boundary B`: one --json document with the moisture block of the
    scipy engine's keys and values (within the solve bound), the text form its block once."""
    np.save(tmp_path / "img.npy", coupled_cases.labels())
    path = tmp_path / "s.toml"
    path.write_text(SCENE, encoding="utf-8")
    assert main(["homogenize", str(path), "--boundary", boundary, "--json"]) == 0
    expected = json.loads(capsys.readouterr().out)["moisture"]
    run = mpiexec("aromm", "homogenize", str(path), "--engine", "petsc", "--boundary", boundary, "--json")
    assert run.returncode == 0, run.stderr[-3000:]
    lines = [line for line in run.stdout.splitlines() if line.strip()]
    assert len(lines) == 1  # rank 0 only
    found = json.loads(lines[0])["moisture"]
    assert sorted(found) == sorted(expected) == ["boundary", "transport", "xi"]
    assert found["boundary"] == boundary and found["xi"] == pytest.approx(expected["xi"], rel=1e-14)
    bound = cases.solve_bound(load_scene(path), boundary)
    assert (np.abs(np.asarray(found["transport"]) - np.asarray(expected["transport"])) <= bound).all()
    assert "moisture transport" not in run.stderr

    text = mpiexec("aromm", "homogenize", str(path), "--engine", "petsc", "--boundary", boundary)
    assert text.returncode == 0, text.stderr[-3000:]
    assert text.stdout.count("heat and moisture transport, ") == 1
    assert text.stdout.count("ξ̄ (kg/m³): 90.5") == 1


def test_cli_homogenize_refuses_the_periodic_cell_on_petsc(tmp_path: Path) -> None:
    """--boundary periodic on the petsc engine (refused for k̄ too): an error naming the probes it solves."""
    np.save(tmp_path / "img.npy", coupled_cases.labels())
    path = tmp_path / "s.toml"
    path.write_text(SCENE, encoding="utf-8")
    run = mpiexec("aromm", "homogenize", str(path), "--engine", "petsc", "--boundary", "periodic", "--json")
    assert run.returncode != 0
    assert "the petsc engine homogenises it by the probes temperature or flux, got 'periodic' (the periodic cell: " \
           "--engine scipy)" in run.stderr
