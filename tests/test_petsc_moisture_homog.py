"""The petsc engine's homogenised heat and moisture transport (the fixed-value probe, by boxes) against the scipy
engine's ``moisture_transport(..., "temperature")`` on the cases of tests/petsc_moisture_homog_cases.py, at 1 rank (in
the pytest process) and 2 ranks: equal within the steady solver's bound (that module's ``solve_bound``: from
linear.STEADY_RTOL and the condition number of the scaled probe matrix); on a laminate the exact arithmetic and
harmonic means; ξ̄ the volume average.  `aromm homogenize --engine petsc --boundary temperature` at 2 ranks prints
the moisture block and emits it in --json; another boundary says what the petsc engine supports.
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


@pytest.mark.parametrize("label", [*cases.DISCRETISATIONS, "laminate"])
def test_moisture_transport_equals_the_scipy_engines(label: str, runs: dict[str, dict[str, np.ndarray]],
                                                     serial: dict[str, np.ndarray]) -> None:
    """Every entry of the (3, 2, 2) matrix within its solve bound of the direct solves', ξ̄ to rounding."""
    expected = serial[f"{label}_transport"]
    bound = cases.solve_bound(cases.all_cases()[label])
    assert np.abs(expected[:, 1, 0]).min() > 0.0  # the coupling shows: vapour moved by the temperature jump
    for where, found in runs.items():
        assert found[f"{label}_transport"].shape == (3, 2, 2)
        assert (np.abs(found[f"{label}_transport"] - expected) <= bound).all(), (where, label)
        assert float(found[f"{label}_xi"]) == pytest.approx(float(serial[f"{label}_xi"]), rel=1e-14)


def test_the_laminate_is_the_exact_means(runs: dict[str, dict[str, np.ndarray]]) -> None:
    """Across the layers the matrix harmonic mean, along them the arithmetic mean (exact for Q1 on voxel layers: the
    only error is the solver's), ξ̄ the volume mean."""
    exact = cases.laminate_means()
    bound = cases.solve_bound(cases.laminate())
    for where, found in runs.items():
        assert (np.abs(found["laminate_transport"] - exact) <= bound).all(), where
        assert float(found["laminate_xi"]) == pytest.approx((200.0 + 0.017) / 2, rel=1e-14)


def test_cli_homogenize_prints_the_moisture_transport_on_two_ranks(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """`mpiexec -n 2 aromm homogenize --engine petsc --boundary temperature`: one --json document with the moisture
    block of the scipy engine's keys and values (within the solve bound), the text form its block; with
    --boundary flux the note naming what is supported, and no moisture block."""
    np.save(tmp_path / "img.npy", coupled_cases.labels())
    path = tmp_path / "s.toml"
    path.write_text(SCENE, encoding="utf-8")
    assert main(["homogenize", str(path), "--boundary", "temperature", "--json"]) == 0
    expected = json.loads(capsys.readouterr().out)["moisture"]
    run = mpiexec("aromm", "homogenize", str(path), "--engine", "petsc", "--boundary", "temperature", "--json")
    assert run.returncode == 0, run.stderr[-3000:]
    lines = [line for line in run.stdout.splitlines() if line.strip()]
    assert len(lines) == 1  # rank 0 only
    found = json.loads(lines[0])["moisture"]
    assert sorted(found) == sorted(expected) == ["boundary", "transport", "xi"]
    assert found["boundary"] == "temperature" and found["xi"] == pytest.approx(expected["xi"], rel=1e-14)
    bound = cases.solve_bound(load_scene(path))
    assert (np.abs(np.asarray(found["transport"]) - np.asarray(expected["transport"])) <= bound).all()
    assert "moisture transport" not in run.stderr

    text = mpiexec("aromm", "homogenize", str(path), "--engine", "petsc", "--boundary", "temperature")
    assert text.returncode == 0, text.stderr[-3000:]
    assert text.stdout.count("heat and moisture transport, fixed (T, φ) on the two faces of each axis") == 1
    assert text.stdout.count("ξ̄ (kg/m³): 90.5") == 1

    flux = mpiexec("aromm", "homogenize", str(path), "--engine", "petsc", "--json")  # the petsc default: flux
    assert flux.returncode == 0, flux.stderr[-3000:]
    assert flux.stderr.count("the petsc engine homogenises the moisture transport with --boundary temperature "
                             "only") == 1
    assert "moisture" not in json.loads(flux.stdout)
