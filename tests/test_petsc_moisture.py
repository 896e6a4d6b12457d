"""The petsc engine's coupled heat and moisture (the full model) against the serial engine's: face-mean T and φ of the
transient and the steady state of tests/petsc_moisture_cases.py, in Q1 and in finite volumes, at 1 rank (in the
pytest process), 2 ranks (the process grid's own cut) and 4 ranks cut 2×2×1 (boxes); `aromm simulate --engine petsc
--json` and `aromm homogenize --engine petsc` (thermal probes) at 2 ranks; what the petsc engine still refuses of a
coupled scene's full model.

Tolerance, from the solvers' own: every solve of a coupled system is CG on its diagonally scaled form to a relative
residual linear.tolerance(STEP_RTOL, 2) = COUPLED_RTOL (the serial engine solves directly), so its relative error is
at most κ · COUPLED_RTOL [Higham2002, § 7.1], κ the condition number of the scaled matrix as PETSc holds it (identity
rows on the fixed unknowns; ≈ 70 in q1, 370 in fv here).  Taken at the scale of the outputs, max |y| (the entries of
the state are of their size), and added over the solves (the schemes are stable: a step does not amplify an earlier
step's error), that is  solves · κ · COUPLED_RTOL · max |y|  on a face mean (weights summing to 1).
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import petsc_moisture_cases as cases
import pytest
from test_petsc_engine import case_fixtures, mpiexec, pytestmark  # noqa: F401  (the same marks: mpi, skipped without PETSc)

from aromm.cli import main
from aromm.core.errors import InputError
from aromm.scene.scene_file import Scene, load_scene

SCENE = """
[geometry]
image = "img.npy"
voxel_size = [1e-3, 1.2e-3, 0.9e-3]

[phases.fibre]
label = 1
k = 0.3
c = 1.5e6
xi = 200.0
D_phi = 2e-8
delta_p = 2e-11

[phases.gas]
label = 0
k = 0.025
c = 1.2e5
xi = 20.0
D_phi = 1e-9
delta_p = 1.8e-10

[moisture]
T_ref = 20.0
phi_ref = 0.5

[boundary.z0]
T = 20.0
phi = 0.8

[boundary.z1]
flux = 50.0
g = 1e-6

[initial]
T = 20.0
phi = 0.5

[time]
end = 600.0
dt = 60.0

[outputs]
mean_T = ["z1"]
mean_phi = ["z1"]
"""


runs, serial = case_fixtures(cases, 2)


def tolerance(y: np.ndarray, case: Scene) -> float:
    """solves · κ · COUPLED_RTOL · max |y| (module docstring) for the outputs ``y`` (a row per solve) of ``case``."""
    from aromm.engines.petsc.linear import tolerance as solve_tolerance
    from aromm.engines.petsc.transient import STEP_RTOL

    return y.shape[0] * cases.step_condition(case) * solve_tolerance(STEP_RTOL, 2) * float(np.abs(y).max())


def test_decompositions_are_the_ones_asked(runs: dict[str, dict[str, np.ndarray]]) -> None:
    assert [tuple(r["grid"]) for r in runs.values()] == [(1, 1, 1), (2, 1, 1), (2, 2, 1)]


@pytest.mark.parametrize("discretisation", cases.DISCRETISATIONS)
def test_full_coupled_model_equals_serial(discretisation: str, runs: dict[str, dict[str, np.ndarray]],
                                          serial: dict[str, np.ndarray]) -> None:
    """mean T and mean φ of both faces, transient and steady, at every decomposition."""
    names = list(serial[f"{discretisation}_names"])
    assert names == ["z1", "phi:z1", "x1", "phi:x1"]
    phi = [i for i, name in enumerate(names) if name.startswith("phi:")]
    moved = np.ptp(serial[f"{discretisation}_transient"], axis=0)
    assert moved[phi].max() > 0.02 and np.delete(moved, phi).max() > 0.2  # a real wetting and heating
    for label, found in runs.items():
        assert list(found[f"{discretisation}_names"]) == names, label
        for kind, scene in (("transient", cases.transient_scene), ("steady", cases.steady_scene)):
            case = f"{discretisation}_{kind}"
            assert found[case].shape == serial[case].shape, label
            assert np.abs(found[case] - serial[case]).max() <= tolerance(serial[case], scene(discretisation)), (
                label, case)


def test_cli_simulate_on_two_ranks_equals_scipy(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`mpiexec -n 2 aromm simulate --engine petsc --json` prints one document, with mean_phi beside mean_T, equal to
    the scipy engine's."""
    np.save(tmp_path / "img.npy", cases.labels())
    path = tmp_path / "s.toml"
    path.write_text(SCENE, encoding="utf-8")
    assert main(["simulate", str(path), "--json"]) == 0
    expected = json.loads(capsys.readouterr().out)
    run = mpiexec("aromm", "simulate", str(path), "--engine", "petsc", "--json")
    assert run.returncode == 0, run.stderr[-3000:]
    lines = [line for line in run.stdout.splitlines() if line.strip()]
    assert len(lines) == 1  # rank 0 only
    found = json.loads(lines[0])
    assert found["t"] == expected["t"]
    bound = tolerance(np.asarray([expected["mean_T"]["z1"]]).T, load_scene(path))
    for kind in ("mean_T", "mean_phi"):
        y = np.asarray(expected[kind]["z1"])
        assert np.abs(np.asarray(found[kind]["z1"]) - y).max() <= bound, kind


def test_cli_homogenize_on_two_ranks_gives_the_thermal_conductivity(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """`aromm homogenize --engine petsc` of a coupled scene: its probes are thermal (the scene's moisture conditions
    left out), k̄ the scipy engine's flux probe's (to 1e-7 relatively, as tests/test_petsc_engine.py's), beside the
    moisture transport by the same probe (checked in tests/test_petsc_moisture_homog.py), no note."""
    np.save(tmp_path / "img.npy", cases.labels())
    path = tmp_path / "s.toml"
    path.write_text(SCENE, encoding="utf-8")
    assert main(["homogenize", str(path), "--boundary", "flux", "--json"]) == 0
    expected = np.asarray(json.loads(capsys.readouterr().out)["k"])
    run = mpiexec("aromm", "homogenize", str(path), "--engine", "petsc", "--json")
    assert run.returncode == 0, run.stderr[-3000:]
    assert "moisture" not in run.stderr
    found = json.loads(run.stdout)
    np.testing.assert_allclose(np.asarray(found["k"]), expected, rtol=1e-7, atol=0.0)
    assert found["moisture"]["boundary"] == "flux"  # its default probe (tests/test_petsc_moisture_homog.py)


def test_what_the_petsc_engine_still_refuses_of_a_coupled_scene(tmp_path: Path) -> None:
    """A history of a boundary value in the full model (moisture or thermal: the steps hold boundary values constant):
    an InputError naming the key and the way out (its reduced models' refusals: tests/test_petsc_moisture_krylov.py)."""
    from aromm import api
    from aromm.core.profiles import Profile
    from aromm.core.vocabulary import FaceSpec

    scene = cases.transient_scene()
    ramp = Profile((0.0, 600.0), (0.5, 0.8))
    wet = replace(scene, moisture=replace(scene.moisture, fixed_phi={"z0": ramp}))
    with pytest.raises(InputError, match=r"boundary\.z0\.phi: the petsc engine's full model holds boundary values "
                                         r"constant; a history needs the scipy engine's \(--engine scipy\)"):
        api.simulate(wet, engine="petsc")
    heated = replace(scene, boundary=(*scene.boundary[:1], FaceSpec("z1", flux=Profile((0.0, 600.0), (0.0, 50.0))),
                                      *scene.boundary[2:]))
    with pytest.raises(InputError, match=r"boundary\.z1\.flux: the petsc engine's full model holds"):
        api.simulate(replace(heated, moisture=None), engine="petsc")
