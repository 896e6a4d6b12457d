"""A reduced model built on the petsc engine is found by `aromm identify` on the scipy engine, and one built on
the scipy engine by `aromm identify --engine petsc` on 2 ranks (issue 21, item 5): one cache key whichever engine
built the model (aromm.reduction.model_key).

Independent truth for the cross-engine agreement: a model built afresh on the other engine, equal within the
engines' tolerance 1e-8 °C (MUMPS against CHOLMOD, the drop threshold of tests/petsc_krylov_cases.py); the model
found in the cache must be the one the other engine wrote (its ``engine`` and ``model_key``), so the identify
run on the finding engine gives the finder's estimates from the writer's model bit for bit.  MPI stage only.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import petsc_cases
import petsc_krylov_cases as cases
import pytest
from scene_text import scenario_1
from test_petsc_engine import mpiexec, pytestmark  # noqa: F401  (the same marks: mpi, skipped without PETSc)

import aromm
from aromm.cli import main
from inverse.measurements import save_measurements

HERE = Path(__file__).parent
TOL = 1e-8  # °C, the engines' agreement (tests/test_petsc_krylov.py)
TRUTH = {"fibre.k": 0.3, "fibre.c": 4.0e6}
IDENTIFY = ["--unknown", "fibre.k=0.1:1", "--unknown", "fibre.c=1e6:1e7", "--particles", "4", "--iterations", "2",
            "--json"]


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("model_key")
    np.save(folder / "img.npy", petsc_cases.labels((6, 7, 8), 3))
    path = folder / "s.toml"
    path.write_text(scenario_1("img.npy", "1e-4", "2.0", "0.2") + '\n[reduction]\nmethod = "krylov"\n'
                    'bounds = { "fibre.k" = [0.1, 1.0], "fibre.c" = [1.0e6, 1.0e7] }\n', encoding="utf-8")
    return path


def _measurements(rom: aromm.ReducedModel, folder: Path) -> Path:
    path = folder / "m.csv"
    if not path.exists():
        save_measurements(rom.simulate(TRUTH), path)
    return path


def _scipy(scene: Path, cache: Path | bool) -> aromm.ReducedModel:
    sc = aromm.load_scene(scene)
    with cases.dropping(cases.DROP):
        return aromm.reduce(sc, 200, settings=sc.reduction, solver="cholmod", cache=cache)


def _agree(a: aromm.ReducedModel, b: aromm.ReducedModel) -> None:
    for p in cases.POINTS:
        assert float(np.abs(a.simulate(p).as_array() - b.simulate(p).as_array()).max()) <= TOL


def test_petsc_model_found_by_identify_on_scipy(scene: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    cache = tmp_path / "cache"
    run = mpiexec(sys.executable, str(HERE / "model_key_worker.py"), str(cases.DROP), "reduce", str(scene),
                  "--order", "200", "--engine", "petsc", "--solver", "mumps", "--json", "--cache-dir", str(cache))
    assert run.returncode == 0, run.stderr[-3000:]
    built = json.loads(run.stdout.strip().splitlines()[-1])
    assert built["cached"] == 0 and built["engine"] == "petsc"
    found = _scipy(scene, cache)
    assert found.info["cached"] == 1 and found.info["engine"] == "petsc"
    assert found.info["model_key"] == built["model_key"]
    _agree(found, _scipy(scene, False))
    monkeypatch.setenv("AROMM_CACHE_DIR", str(cache))
    assert main(["identify", str(scene), "--measurements", str(_measurements(found, tmp_path)), *IDENTIFY]) == 0
    model = json.loads(capsys.readouterr().out)["model"]
    assert model["cached"] == 1 and model["engine"] == "petsc"


def test_scipy_model_found_by_identify_on_petsc(scene: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    cache = tmp_path / "cache"
    built = _scipy(scene, cache)
    assert built.info["cached"] == 0 and built.info["engine"] == "scipy"
    data = _measurements(built, tmp_path)
    monkeypatch.setenv("AROMM_CACHE_DIR", str(cache))
    assert main(["identify", str(scene), "--measurements", str(data), *IDENTIFY]) == 0
    serial = json.loads(capsys.readouterr().out)
    run = mpiexec(sys.executable, str(HERE / "model_key_worker.py"), str(cases.DROP), "identify", str(scene),
                  "--measurements", str(data), "--engine", "petsc", *IDENTIFY)
    assert run.returncode == 0, run.stderr[-3000:]
    petsc = json.loads(run.stdout)  # rank 0 alone prints
    assert petsc["model"]["cached"] == 1 and petsc["model"]["engine"] == "scipy"
    assert petsc["estimates"] == serial["estimates"]  # the same model, the same swarm: bit for bit
    with cases.dropping(cases.DROP):
        fresh = aromm.reduce(aromm.load_scene(scene), 200, settings=aromm.load_scene(scene).reduction,
                             engine="petsc", solver="mumps", cache=False)  # 1 rank, in process
    _agree(built, fresh)
