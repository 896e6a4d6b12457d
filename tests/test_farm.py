"""The task farm gives the serial run's results, bit for bit, on a process pool and on mpi4py.futures workers."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import farm_cases
import numpy as np
import pytest

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
