"""The petsc engine's finite volumes (aromm.engines.petsc.volume_assembly) against the serial engine's: the same
matrix in another numbering, the same full-model face means, homogenised conductivities and Krylov models, at
1 rank (in the pytest process), 3 ranks (z-slabs of 3 voxels) and 4 ranks cut 2×2×1 (boxes); tolerances as the
q1 engine's tests (tests/test_petsc_engine.py, test_petsc_krylov.py: the solvers' own tolerances)."""

from __future__ import annotations

import numpy as np
import petsc_fv_cases as cases
import pytest
from test_petsc_engine import case_fixtures, pytestmark  # noqa: F401  (the same marks: mpi, skipped without PETSc)

runs, serial = case_fixtures(cases, 3)


@pytest.mark.filterwarnings("ignore::aromm.core.errors.ModelWarning")
def test_decompositions_are_the_ones_asked(runs: dict[str, dict[str, np.ndarray]]) -> None:
    assert [tuple(r["grid"]) for r in runs.values()] == [(1, 1, 1), (1, 1, 3), (2, 2, 1)]


def test_boxes_assemble_the_serial_matrix(runs: dict[str, dict[str, np.ndarray]]) -> None:
    """K x by boxes equals the serial K x, renumbered, within the rounding of a row's sum (ratio ≤ 1)."""
    for label, found in runs.items():
        assert float(found["product_error"]) <= 1.0, label


def test_full_model_and_homogenisation_equal_serial(runs: dict[str, dict[str, np.ndarray]],
                                                     serial: dict[str, np.ndarray]) -> None:
    assert np.abs(serial["transient"]).max() > 1.0  # °C: a real heating
    for label, found in runs.items():
        assert np.abs(found["transient"] - serial["transient"]).max() <= 1e-6, label
        assert np.abs(found["steady"] - serial["steady"]).max() <= 1e-6, label
        for boundary in ("flux", "temperature"):
            np.testing.assert_allclose(found[f"k_{boundary}"], serial[f"k_{boundary}"], rtol=1e-7, atol=0,
                                       err_msg=label)


@pytest.mark.parametrize(("kind", "tol"), [("krylov", 1e-8), ("modal", 1e-10)])
def test_reduced_models_equal_serial(kind: str, tol: float, runs: dict[str, dict[str, np.ndarray]],
                                     serial: dict[str, np.ndarray]) -> None:
    """°C, as the q1 engine's tests: the Krylov model as test_petsc_krylov, the amalgam model without correction
    modes as test_petsc_engine."""
    for label, found in runs.items():
        assert found[kind].shape == serial[kind].shape
        assert np.abs(found[kind] - serial[kind]).max() <= tol, label
