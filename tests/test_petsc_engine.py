"""The petsc engine (PETSc/SLEPc under MPI) against the serial engine and ARPACK: 2 ranks, 1 rank, scipy.

Independent truths: ARPACK (scipy's eigsh, shift-invert, no code of ours) for the Dirichlet and Steklov
eigenvalues of the definitions of aromm.reduction.modal_bases; the serial engine (CHOLMOD, scipy) for the reduced and
full
models, the homogenised k and the CLI.  Tolerances: eigenvalues 1e-10 relative (SLEPc converges to 1e-12 and
the inner solves to 1e-13); full-model face means 1e-6 °C (CG to a relative residual of 1e-11); the reduced
model 1e-6 °C with correction modes — the serial path itself moves by 2.8e-7 °C between CHOLMOD and SuperLU
there (near-dependent correction directions amplify round-off) — and 1e-10 °C without them.
Skipped without petsc4py (the default pip environment); run by the MPI stage of .ci/run.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from aromm.engines import petsc_available

pytestmark = [
    pytest.mark.mpi,
    pytest.mark.skipif(not petsc_available(), reason="petsc engine: petsc4py/slepc4py/mpi4py absent (optional; "
                       "README 'Running on a cluster'; run by the MPI stage of .ci/run)"),
    pytest.mark.skipif(shutil.which("mpiexec") is None, reason="petsc engine: no mpiexec on PATH"),
]

import petsc_cases  # noqa: E402
from scene_text import scenario_1  # noqa: E402

HERE = Path(__file__).parent
#: Hard limit of one mpiexec run: the 2-rank worker took 1-2 min at load 9 on the 2-core machine, over 15 min at
#: load 20 (two ranks wait for each other at every collective when the cores are oversubscribed).
MPI_TIMEOUT = 1800
RANKS = 2


def mpiexec(*args: str, timeout: float = MPI_TIMEOUT) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1", "OMPI_MCA_mpi_yield_when_idle": "1"}
    return subprocess.run(["mpiexec", "-n", str(RANKS), *args], capture_output=True, text=True, timeout=timeout,
                          env=env, check=False)


@pytest.fixture(scope="module")
def two_ranks(tmp_path_factory: pytest.TempPathFactory) -> dict[str, np.ndarray]:
    out = tmp_path_factory.mktemp("mpi") / "two_ranks.npz"
    run = mpiexec(sys.executable, str(HERE / "petsc_worker.py"), str(out))
    assert run.returncode == 0, run.stderr[-3000:]
    with np.load(out) as data:
        return {k: data[k] for k in data.files}


@pytest.fixture(scope="module")
def one_rank() -> dict[str, np.ndarray]:
    from aromm.engines.petsc import runtime

    return petsc_cases.results(runtime.world())


@pytest.fixture(scope="module")
def arpack() -> dict[str, np.ndarray]:
    return petsc_cases.arpack()


@pytest.fixture(scope="module")
def serial() -> dict[str, np.ndarray]:
    return petsc_cases.serial()


@pytest.mark.parametrize("solver", ["mumps", "gamg"])
@pytest.mark.parametrize("family", ["dirichlet", "steklov"])
def test_eigenvalues_equal_arpack(family: str, solver: str, arpack: dict[str, np.ndarray],
                                  one_rank: dict[str, np.ndarray], two_ranks: dict[str, np.ndarray]) -> None:
    reference = arpack[family]
    for found in (one_rank[f"{family}_{solver}"], two_ranks[f"{family}_{solver}"]):
        assert found.shape == reference.shape
        np.testing.assert_allclose(found, reference, rtol=1e-10, atol=0.0)
    assert int(two_ranks["ranks"]) == RANKS


@pytest.mark.parametrize(("corrections", "tol"), [(True, 1e-6), (False, 1e-10)])
def test_reduced_model_face_means_equal_serial(corrections: bool, tol: float, serial: dict[str, np.ndarray],
                                                one_rank: dict[str, np.ndarray],
                                                two_ranks: dict[str, np.ndarray]) -> None:
    expected = serial[f"rom_corrections_{corrections}"]
    assert np.abs(expected).max() > 1.0  # °C: a real heating, not a trivially zero response
    for found in (one_rank, two_ranks):
        assert np.abs(found[f"rom_corrections_{corrections}"] - expected).max() <= tol


def test_full_model_face_means_equal_serial(serial: dict[str, np.ndarray], one_rank: dict[str, np.ndarray],
                                            two_ranks: dict[str, np.ndarray]) -> None:
    for found in (one_rank, two_ranks):
        assert np.abs(found["transient"] - serial["transient"]).max() <= 1e-6
        assert np.abs(found["steady"] - serial["steady"]).max() <= 1e-6


def test_homogenised_conductivity_equals_serial(serial: dict[str, np.ndarray], one_rank: dict[str, np.ndarray],
                                                two_ranks: dict[str, np.ndarray]) -> None:
    for boundary in ("flux", "temperature"):
        for found in (one_rank, two_ranks):
            np.testing.assert_allclose(np.diag(found[f"k_{boundary}"]), np.diag(serial[f"k_{boundary}"]), rtol=1e-7)


def test_cli_reduce_two_ranks_prints_once_and_caches(tmp_path: Path) -> None:
    """`mpiexec -n 2 aromm reduce --engine petsc` on an .npy image read by slabs: one JSON document from rank 0,
    the model built by 2 ranks, then loaded from the cache rank 0 wrote; outputs as the serial engine's."""
    np.save(tmp_path / "img.npy", petsc_cases.labels((6, 7, 8), 3).astype(np.uint8))
    scene = tmp_path / "s.toml"
    scene.write_text(scenario_1("img.npy", "1e-4", "2.0", "0.1"), encoding="utf-8")
    args = ["aromm", "reduce", str(scene), "--order", "10", "--modes", "24", "--engine", "petsc", "--solver", "mumps",
            "--json", "--cache-dir", str(tmp_path / "cache")]
    first = mpiexec(*args)
    assert first.returncode == 0, first.stderr[-3000:]
    lines = [line for line in first.stdout.splitlines() if line.strip()]
    assert len(lines) == 1  # rank 0 only
    info = json.loads(lines[0])
    assert info["ranks"] == RANKS and info["engine"] == "petsc" and info["cached"] == 0
    assert info["outputs"] == ["z0", "z1"]
    second = mpiexec(*args)
    assert json.loads(second.stdout.strip())["cached"] == 1
    assert len(list((tmp_path / "cache").glob("rom-*.npz"))) == 1

