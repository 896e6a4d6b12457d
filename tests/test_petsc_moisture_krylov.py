"""The petsc engine's Krylov reduced model of coupled heat and moisture (issue 39) against the scipy engine's and the
exact full model: 1 rank (in the pytest process), 2 ranks and 4 ranks cut 2×2×1, cases of
:mod:`petsc_moisture_krylov_cases`; `aromm simulate --engine petsc --model reduced --json` at 2 ranks; what it
refuses (modal methods, fixed values).

Tolerances.  Against the scipy engine (the same greedy, the same span, direct solves): the petsc engine's shifted
solves stop at the relative residual RTOL of the diagonally scaled system, so each basis vector is off by at most
κ · RTOL relatively [Higham2002, § 7.1] (κ the scaled operator's condition number,
petsc_moisture_krylov_cases.condition), and the Galerkin model on the span moves by as much at the outputs' scale
max |y|.  Against the exact full model (aromm.full.exact, dense, independent of both engines): the model's error
within its tolerance, and its certified bound above the error up to the dense truth's own rounding.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import petsc_moisture_krylov_cases as cases
import pytest
from test_petsc_engine import decompositions, mpiexec, pytestmark  # noqa: F401  (the same marks: mpi, skipped without PETSc)
from test_petsc_moisture import SCENE

from aromm.core.errors import InputError

#: The CLI's scene: that of tests/test_petsc_moisture.py with z0's fixed T and φ replaced by heat and vapour exchange
#: (the petsc engine's reductions take natural conditions only), trained over fibre.k.
NATURAL = SCENE.replace("[boundary.z0]\nT = 20.0\nphi = 0.8\n",
                        "[boundary.z0]\nh = 50.0\nT_ext = 20.0\nbeta = 1e-7\nphi_ext = 0.8\n")
REDUCTION = '\n[reduction]\nbounds = { "fibre.k" = [0.2, 0.6] }\ntolerance = 1e-3\ncertify = false\n'


Runs = dict[str, dict[str, np.ndarray]]


@pytest.fixture(scope="module")
def models(tmp_path_factory: pytest.TempPathFactory) -> tuple[Runs, dict[str, np.ndarray]]:
    """The petsc engine's model by decomposition (1, 2 and 2×2×1 ranks), and the scipy engine's."""
    return decompositions(tmp_path_factory, cases, 2), cases.serial()


@pytest.fixture(scope="module")
def truth() -> tuple[np.ndarray, float]:
    """The exact full model's outputs at the comparison points (points × times × outputs), and its own rounding: 3×
    the largest difference of two evaluations that round differently (aromm.full.exact.rounding)."""
    from aromm.full.exact import exact_outputs, rounding
    from aromm.scene.scene_file import assemble

    system = assemble(cases.scene())
    assert system.time is not None
    floor = 3 * max(float(np.max(rounding(system, p, system.time.times))) for p in cases.POINTS)
    return np.stack([exact_outputs(system, p, system.time.times) for p in cases.POINTS]), floor


def test_petsc_krylov_model_of_moisture_equals_the_scipy_engines(models: tuple[Runs, dict[str, np.ndarray]]) -> None:
    """mean T and mean φ of both faces at both points, on every decomposition: the same greedy (points, span) and
    outputs within κ · RTOL · max |y| (module docstring)."""
    runs, serial = models
    assert list(serial["names"]) == ["z1", "phi:z1", "x1", "phi:x1"]
    tol = cases.condition() * cases.RTOL * float(np.abs(serial["outputs"]).max())
    for label, found in runs.items():
        assert list(found["names"]) == list(serial["names"]), label
        assert tuple(found["span"]) == tuple(serial["span"]), label
        error = float(np.abs(found["outputs"] - serial["outputs"]).max())
        assert error <= tol, f"{label}: {error:.2e} > {tol:.2e}"


def test_certified_bound_of_the_petsc_build_holds_against_the_exact_full_model(
        models: tuple[Runs, dict[str, np.ndarray]], truth: tuple[np.ndarray, float]) -> None:
    """On every decomposition the model's error (T and φ) is within its tolerance and under its certified bound (Gram
    matrices by the scaled CG + GAMG solves, summed over the ranks), which is not vacuous and is the scipy engine's
    build's up to the residuals' rounding."""
    runs, serial = models
    exact, floor = truth
    for label, found in {**runs, "serial": serial}.items():
        actual = np.abs(found["outputs"] - exact).max(axis=1)  # per point and output
        assert actual.max() <= cases.TOLERANCE, (label, actual)
        bound = found["bound"]
        assert np.all(np.isfinite(bound)), label
        assert np.all(bound >= actual - floor), (label, bound, actual)
        assert np.all(bound <= 1e4 * np.maximum(actual, floor)), (label, bound, actual)  # 3,200 at worst (φ at x1)
        # the bound is the scipy engine's up to the solves' error (as tests/test_petsc_krylov.py's, measured 6e-9) once
        # the residuals' rounding spread is left out; with it, ≥ that (float64 residuals: +0.35% here)
        np.testing.assert_allclose(found["unspread"], serial["unspread"], rtol=1e-6, err_msg=label)
        assert np.all(bound >= found["unspread"]), label


def test_cli_simulate_reduced_on_two_ranks_prints_mean_phi(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`mpiexec -n 2 aromm simulate --engine petsc --model reduced --json` of a coupled scene (method "auto": the
    Krylov model, the only one the petsc engine builds of it) prints one document with mean_phi beside mean_T, the
    exact full model's to the scene's tolerance."""
    from aromm.full.exact import exact_outputs
    from aromm.scene.scene_file import assemble, load_scene

    monkeypatch.setenv("AROMM_CACHE_DIR", str(tmp_path / "cache"))
    np.save(tmp_path / "img.npy", cases.moisture.labels())
    path = tmp_path / "s.toml"
    path.write_text(NATURAL + REDUCTION, encoding="utf-8")
    run = mpiexec("aromm", "simulate", str(path), "--engine", "petsc", "--model", "reduced", "--json")
    assert run.returncode == 0, run.stderr[-3000:]
    lines = [line for line in run.stdout.splitlines() if line.strip()]
    assert len(lines) == 1  # rank 0 only
    found = json.loads(lines[0])
    system = assemble(load_scene(path))
    assert system.time is not None
    exact = exact_outputs(system, {}, np.asarray(found["t"]))
    for kind, column in (("mean_T", 0), ("mean_phi", 1)):
        error = np.abs(np.asarray(found[kind]["z1"]) - exact[:, column]).max()
        assert error <= 1e-3, (kind, error)


def test_what_the_petsc_engine_refuses_of_a_coupled_reduction() -> None:
    """A modal method (asked, or ``"auto"`` with a modal option) and fixed values (T and φ): an InputError naming
    the option and what is allowed."""
    from petsc_moisture_cases import transient_scene

    from aromm import api

    for options, named in (({"method": "aromm"}, "method = 'aromm'"),
                           ({"modes": 30}, r"method = 'auto' with modes \(the amalgam's\)")):
        with pytest.raises(InputError, match=f"moisture: {named}: the petsc engine builds reduced models of coupled "
                                             "heat and moisture by the Krylov method only"):
            api.reduce(cases.scene(), 4, engine="petsc", cache=False, **options)
    with pytest.raises(InputError, match=r"fixed temperatures \(z0\.T, z0\.phi\) are not supported .* a fixed phi by "
                                         "vapour exchange with a large beta"):
        api.reduce(transient_scene(), 4, engine="petsc", method="krylov", cache=False)
