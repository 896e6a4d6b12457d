"""The petsc engine's preconditioned eigensolver (``eigensolver="lobpcg"``: SLEPc Generalized Davidson + GAMG,
aromm.engines.petsc.eigen) at 1 rank and at 2 ranks, and its MUMPS set-up (aromm.engines.petsc.mumps).

Independent truths: the scipy engine's eigenvalues of the same definitions (aromm.reduction.modal_bases, dense
``eigh`` at these 1,320 nodes: exact to round-off); the serial engine's reduced model; a known solution for the
MUMPS probe; MUMPS's own message when asked for a parallel analysis it cannot do.  Tolerances: the eigensolver
converges to a residual of BLOCK_TOL against the matrix norms, ≤ 100 BLOCK_TOL per vector (the module's note), and
a Hermitian eigenvalue moves by at most its relative residual: rtol 100 BLOCK_TOL; the reduced model's face means
by at most that much of their size (°C) without correction modes, and 1e-6 °C with them, as for shift-invert
(tests/test_petsc_engine.py: near-dependent correction directions amplify round-off).
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

import numpy as np
import petsc_cases
import petsc_eigen_cases
import petsc_mumps_cases
import pytest
from test_petsc_engine import mpiexec, pytestmark  # noqa: F401  (the same marks: mpi, skipped without PETSc)

HERE = Path(__file__).parent
RANKS = 2
MUMPS_SAYS = "No parallel ordering tools available"


def _worker(tmp_path_factory: pytest.TempPathFactory, module: str, options: str = "",
            ) -> tuple[dict[str, np.ndarray], str]:
    out = tmp_path_factory.mktemp("mpi") / f"{module}.npz"
    run = mpiexec(sys.executable, str(HERE / "petsc_worker.py"), str(out), module, ranks=RANKS, options=options)
    assert run.returncode == 0, run.stderr[-3000:]
    with np.load(out) as data:
        assert int(data["ranks"]) == RANKS
        return {k: data[k] for k in data.files}, run.stdout


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[dict[str, np.ndarray], str]]:
    from aromm.engines.petsc import runtime

    return {"1 rank": (petsc_eigen_cases.results(runtime.world()), ""),
            "2 ranks": _worker(tmp_path_factory, "petsc_eigen_cases")}


@pytest.fixture(scope="module")
def scipy_engine() -> dict[str, np.ndarray]:
    from aromm.reduction.modal_bases import dirichlet_modes, reference_operators, steklov_modes
    from aromm.scene.scene_file import assemble

    ops = reference_operators(assemble(petsc_cases.basis_scene()))
    return {"dirichlet": dirichlet_modes(ops, petsc_cases.N_DIRICHLET)[0],
            "steklov": steklov_modes(ops, petsc_cases.N_STEKLOV - 1)[0]}


@pytest.mark.parametrize("family", ["dirichlet", "steklov"])
def test_eigenvalues_equal_the_scipy_engines(family: str, runs: dict[str, tuple[dict[str, np.ndarray], str]],
                                             scipy_engine: dict[str, np.ndarray]) -> None:
    from aromm.engines.petsc.eigen import BLOCK_TOL

    for label, (found, _) in runs.items():
        assert found["iterations"].min() > 0, label  # the preconditioned eigensolver ran, not shift-invert
        assert found[family].shape == scipy_engine[family].shape, label
        np.testing.assert_allclose(found[family], scipy_engine[family], rtol=100 * BLOCK_TOL, atol=0.0,
                                   err_msg=label)


def test_reduced_model_on_preconditioned_bases_equals_serial(runs: dict[str, tuple[dict[str, np.ndarray], str]],
                                                             ) -> None:
    from aromm.engines.petsc.eigen import BLOCK_TOL

    serial = petsc_cases.serial()
    for corrections in (True, False):
        key = f"rom_corrections_{corrections}"
        expected = serial[key]
        tol = 1e-6 if corrections else 100 * BLOCK_TOL * float(np.abs(expected).max())
        for label, (found, _) in runs.items():
            assert str(found[f"rom_eigensolver_{corrections}"]) == "lobpcg"
            error = float(np.abs(found[key] - expected).max())
            assert error <= tol, f"{label}, corrections {corrections}: {error:.2e} °C > {tol:.1e}"


def test_mumps_analysis_options_reach_the_factor(runs: dict[str, tuple[dict[str, np.ndarray], str]]) -> None:
    """The factor holds ICNTL(28) = 2 (parallel analysis) where this MUMPS has PT-Scotch or ParMETIS, else 1,
    and MUMPS is never left to print its complaint; the solve is exact to round-off."""
    from aromm.engines.petsc import mumps

    expected = mumps.SEQUENTIAL if mumps.parallel_ordering() is False else mumps.PARALLEL
    for label, (found, stdout) in runs.items():
        assert int(found["icntl_28"]) == expected, label
        assert float(found["probe_error"]) < 1e-12, label
        assert MUMPS_SAYS not in stdout, label


def test_parallel_ordering_detection_agrees_with_mumps(tmp_path: Path) -> None:
    """Forced to ICNTL(28) = 2 by the user's PETSc option (kept) at 2 ranks, this MUMPS says it has no parallel
    ordering tool and fails the analysis (INFOG(1) = −38, named in the error) exactly when
    aromm.engines.petsc.mumps found none in it; else the solve succeeds with the parallel analysis."""
    from aromm.engines.petsc import mumps

    run = mpiexec(sys.executable, str(HERE / "petsc_worker.py"), str(tmp_path / "probe.npz"), "petsc_mumps_cases",
                  ranks=RANKS, options=f"-{petsc_mumps_cases.PROBE_PREFIX}mat_mumps_icntl_28 2")
    if mumps.parallel_ordering() is False:
        assert run.returncode != 0 and MUMPS_SAYS in run.stdout
        assert "INFOG(1) = -38" in run.stderr and "PT-Scotch or ParMETIS" in run.stderr
    else:
        assert run.returncode == 0, run.stderr[-3000:]
        with np.load(tmp_path / "probe.npz") as found:
            assert int(found["icntl_28"]) == mumps.PARALLEL and float(found["probe_error"]) < 1e-12
        assert MUMPS_SAYS not in run.stdout


def test_parallel_analysis_asked_where_the_build_has_the_tools(monkeypatch: pytest.MonkeyPatch) -> None:
    """With PT-Scotch or ParMETIS in the build, the factor gets ICNTL(28) = 2 and ICNTL(29) = 0 (one rank: MUMPS
    analyses sequentially there, silently)."""
    from aromm.engines.petsc import mumps, runtime

    monkeypatch.setattr(mumps, "parallel_ordering", lambda: True)
    found = petsc_mumps_cases.mumps_probe(runtime.world(), prefix="aromm_probe_tools_")
    assert int(found["icntl_28"]) == mumps.PARALLEL and int(found["icntl_29"]) == mumps.ORDERING
    assert float(found["probe_error"]) < 1e-12


def test_sequential_fallback_said_once(monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    from aromm.engines.petsc import mumps, runtime

    monkeypatch.setattr(mumps, "parallel_ordering", lambda: False)
    mumps._say_sequential.cache_clear()
    with caplog.at_level(logging.INFO, logger=mumps.__name__):
        for prefix in ("aromm_probe_a_", "aromm_probe_b_"):
            found = petsc_mumps_cases.mumps_probe(runtime.world(), prefix=prefix)
            assert int(found["icntl_28"]) == mumps.SEQUENTIAL
    said = [r.getMessage() for r in caplog.records if "falls back to sequential" in r.getMessage()]
    assert len(said) == 1 and "without PT-Scotch or ParMETIS" in said[0]


def test_auto_keeps_shift_invert_and_names_are_checked() -> None:
    """``auto`` is shift-invert (the preconditioned eigensolver did not pay where measured: docs/scaling.md)."""
    from aromm.core.errors import InputError
    from aromm.engines.petsc.eigen import choose

    assert choose("auto") == "arpack" and choose("lobpcg") == "lobpcg" and choose("arpack") == "arpack"
    with pytest.raises(InputError, match="allowed: auto, arpack, lobpcg"):
        choose("gd")
