"""The task farm gives the serial run's results, bit for bit, on a process pool and on mpi4py.futures workers."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import farm_cases
import numpy as np
import pytest
from inverse_cases import twin_case

from aromm.core.errors import InputError
from inverse.farm import Farm


@pytest.fixture(scope="module")
def serial() -> np.ndarray:
    return farm_cases.estimates(Farm("serial"))


def test_serial_repetitions_differ_and_recover_the_truth(serial: np.ndarray) -> None:
    """Different noise per repetition (the tasks are not copies of one), estimates near the truth."""
    assert len({tuple(row) for row in serial}) == serial.shape[0]
    truth = np.array(list(farm_cases.TRUTH.values()))
    assert np.all(np.abs(serial / truth - 1) < 0.2)


def test_process_pool_equals_serial(serial: np.ndarray) -> None:
    np.testing.assert_array_equal(farm_cases.estimates(Farm("processes", workers=2)), serial)


@pytest.mark.mpi
@pytest.mark.skipif(shutil.which("mpiexec") is None, reason="task farm 'mpi': no mpiexec on PATH")
def test_mpi_futures_equals_serial(serial: np.ndarray, tmp_path: Path) -> None:
    pytest.importorskip("mpi4py", reason="task farm 'mpi': mpi4py absent (the MPI stage of .ci/run has it)")
    out = tmp_path / "estimates.npy"
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    run = subprocess.run(["mpiexec", "-n", "2", sys.executable, "-m", "mpi4py.futures",
                          str(Path(__file__).parent / "farm_worker.py"), str(out)],
                         capture_output=True, text=True, timeout=600, env=env, check=False)
    assert run.returncode == 0, run.stderr[-3000:]
    np.testing.assert_array_equal(np.load(out), serial)


def test_unknown_farm_is_refused() -> None:
    with pytest.raises(InputError, match="unknown task farm 'cloud'; allowed: serial, processes, mpi"):
        Farm("cloud")
    with pytest.raises(InputError, match="at least one worker"):
        Farm("processes", workers=0)


def test_shared_object_travels_once_per_worker() -> None:
    """Six tasks on two workers: what they share is pickled once per worker (at most 2), not once per task (6)."""
    farm_cases.PICKLED[0] = 0
    shared = farm_cases.Counted(2.5)
    got = Farm("processes", workers=2).map_shared(farm_cases.scaled, shared, range(6))
    assert got == [2.5 * t for t in range(6)]
    assert 1 <= farm_cases.PICKLED[0] <= 2
    assert Farm("serial").map_shared(farm_cases.scaled, shared, range(6)) == got


def _repeat(args: list[str], capsys: pytest.CaptureFixture[str]) -> dict[str, object]:
    from aromm.cli import main

    assert main(args) == 0
    return json.loads(capsys.readouterr().out)


def test_cli_repeat_on_processes_equals_serial(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`aromm identify --repeat 3 --farm processes`: the serial estimates bit for bit, different per run (noise
    and swarm seeds differ), each near the truth."""
    scene, csv = twin_case(tmp_path, dt="2.0")
    args = ["identify", str(scene), "--measurements", str(csv), *farm_cases.REPEAT]
    serial = _repeat(args, capsys)
    pool = _repeat([*args, "--farm", "processes", "--workers", "2"], capsys)
    assert pool["repetitions"] == serial["repetitions"] and pool["farm"] == "processes"
    estimates = [tuple(r["estimates"].values()) for r in serial["repetitions"]]  # type: ignore[index, union-attr]
    assert len(set(estimates)) == 3
    truth = np.array(list(farm_cases.TRUTH.values()))
    assert np.all(np.abs(np.array(estimates) / truth - 1) < 0.2)


def test_cli_repeat_refuses_single_run_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from aromm.cli import main

    scene, csv = twin_case(tmp_path, dt="2.0")
    code = main(["identify", str(scene), "--measurements", str(csv), *farm_cases.REPEAT, "--plot",
                 str(tmp_path / "f.png")])
    assert code == 2 and "--repeat runs independent identifications" in capsys.readouterr().err


@pytest.mark.mpi
@pytest.mark.skipif(shutil.which("mpiexec") is None, reason="task farm 'mpi': no mpiexec on PATH")
def test_cli_repeat_on_mpi_futures_equals_serial(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("mpi4py", reason="task farm 'mpi': mpi4py absent (the MPI stage of .ci/run has it)")
    scene, csv = twin_case(tmp_path, dt="2.0")
    args = ["identify", str(scene), "--measurements", str(csv), *farm_cases.REPEAT]
    serial = _repeat(args, capsys)
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    run = subprocess.run(["mpiexec", "-n", "3", sys.executable, "-m", "mpi4py.futures",
                          str(Path(__file__).parent / "farm_cli_worker.py"), *args, "--farm", "mpi"],
                         capture_output=True, text=True, timeout=600, env=env, check=False)
    assert run.returncode == 0, run.stderr[-3000:]
    assert json.loads(run.stdout)["repetitions"] == serial["repetitions"]
