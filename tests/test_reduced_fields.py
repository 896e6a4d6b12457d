"""Temperature fields of the reduced model, T(t) ≈ Ψ X(t), against the exact fields of the full semi-discrete model.

The truth is the exact solution of ``C dT/dt + K T = F`` by a dense generalised eigendecomposition of the full
matrices (no time-stepping error), as in tests/test_reduced.py.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import meshio
import numpy as np
import pytest
import scipy.linalg as sla
from scene_text import SLAB_L, SLAB_TAU, scenario_1, steel_slab

from aromm.cli import main
from aromm.core.errors import InputError
from aromm.core.system import FloatArray, ThermalSystem, TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.fem import assemble_voxels
from aromm.full.solve import transient
from aromm.reduction.offline import reduce
from aromm.scene.scene_file import assemble, load_scene

PHASES = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6)]
FAR = {"fibre.k": 0.3, "fibre.c": 4e6}
TIMES = np.array([0.01, 0.1, 0.5, 2.0])


def _system(n: int = 6) -> ThermalSystem:
    labels = (np.random.default_rng(2).random((n, n, n)) < 0.4).astype(int)
    return assemble_voxels(labels, (5e-6,) * 3, PHASES, [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)],
                           time=TimeGrid(2.0, 0.1), outputs=["z0", "z1"])


def _exact_fields(system: ThermalSystem, values: dict[str, float], times: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Exact nodal fields (len(times), n) from T0 = 0, and the lumped capacity of each node (weights, J/K)."""
    v = system.values(values)
    c = system.capacity.evaluate(v).toarray()
    k = system.conductance.evaluate(v).toarray()
    lam, w = sla.eigh(k, c)
    lam = np.where(lam < 1e-12 * lam.max(), 0.0, lam)
    b = w.T @ np.asarray(system.load.evaluate(v))
    phi = np.where(lam > 0, -np.expm1(-np.outer(times, lam)) / np.where(lam > 0, lam, 1.0), times[:, None])
    return (phi * b) @ w.T, c.sum(axis=1)


def test_reduced_fields_agree_with_the_exact_fields_on_the_output_error_scale(tmp_path: Path) -> None:
    """Fields are not averaged, so they carry more error than face means: the capacity-weighted RMS field error
    stays within 10× the outputs' error (measured 1.0–4.4× at orders 10–80 on this case), the largest nodal
    error within 30× (7–20× measured).  With every mode the reconstruction is exact (1e-9 relative)."""
    system = _system()
    exact, weight = _exact_fields(system, FAR, TIMES)
    _, e = system.observation_matrix()
    rom = reduce(system, order=20, cache=tmp_path, fields=True)
    obs = rom.simulate(FAR, TIMES, fields=True)
    assert obs.fields is not None and obs.fields.shape == (len(TIMES), system.n)
    out_err = np.abs(obs.as_array() - exact @ e.T).max()
    diff = obs.fields - exact
    rms = np.sqrt((diff**2 @ weight) / weight.sum())
    assert out_err < 1e-5 * np.abs(exact).max()
    assert rms.max() <= 10 * out_err, (rms, out_err)
    assert np.abs(diff).max() <= 30 * out_err
    # the reconstructed field observed by the full model's rows is the reduced model's output
    np.testing.assert_allclose(obs.fields @ e.T, obs.as_array(), rtol=0, atol=1e-12 * np.abs(exact).max())
    small = _system(3)
    exact, _ = _exact_fields(small, FAR, TIMES)
    full = reduce(small, order=small.n, modes=small.n, cache=tmp_path, fields=True)
    np.testing.assert_allclose(full.simulate(FAR, TIMES, fields=True).fields, exact, rtol=0,
                               atol=1e-9 * np.abs(exact).max())


def test_basis_stays_out_of_the_light_path_and_is_rebuilt_from_the_cache(tmp_path: Path) -> None:
    system = _system()
    light = reduce(system, order=20, cache=tmp_path)
    assert light.basis is None
    with pytest.raises(InputError, match=r"reduce\(\.\.\., fields=True\)"):
        next(light.iter_fields(FAR, TIMES))
    cached = reduce(system, order=20, cache=tmp_path, fields=True)
    assert cached.info["cached"] == 1 and cached.basis is not None
    fresh = reduce(system, order=20, cache=False, fields=True)
    for (t1, a), (t2, b) in zip(cached.iter_fields(FAR, TIMES), fresh.iter_fields(FAR, TIMES), strict=True):
        assert t1 == t2
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max())
    assert len(list(tmp_path.glob("reconstruction-*.npz"))) == 1


def test_cli_writes_a_paraview_series_of_reduced_fields(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AROMM_CACHE_DIR", str(tmp_path / "cache"))
    np.save(tmp_path / "img.npy", (np.random.default_rng(1).random((4, 4, 5)) < 0.5).astype(np.int32))
    scene = tmp_path / "s.toml"
    scene.write_text(scenario_1("img.npy", "5e-6", "2.0", "0.1"), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["simulate", str(scene), "--model", "reduced", "--order", "30", "--out", str(out),
                 "--fields", "0.5,2"]) == 0
    capsys.readouterr()
    collection = ET.parse(out / "field.pvd").getroot()
    steps = [(float(d.get("timestep")), d.get("file")) for d in collection.iter("DataSet")]
    assert [t for t, _ in steps] == [0.5, 2.0]
    sc = load_scene(scene)
    system = assemble(sc)
    rom = reduce(system, order=30, fields=True)
    for (t, file), (_, field) in zip(steps, rom.iter_fields(None, [0.5, 2.0]), strict=True):
        mesh = meshio.read(out / file)
        assert mesh.points.shape == (system.n, 3) and mesh.cells[0].type == "hexahedron"
        np.testing.assert_allclose(mesh.point_data["T"], field, rtol=1e-12), t
    assert (out / "observables.csv").is_file()
    assert main(["simulate", str(scene), "--out", str(out), "--fields", "0.5"]) == 2
    assert "--fields needs --model reduced" in capsys.readouterr().err
    assert main(["simulate", str(scene), "--model", "reduced", "--out", str(out), "--fields", "1,0.5"]) == 2


def test_fields_with_fixed_temperatures_hold_them_and_converge_to_the_full_model(tmp_path: Path) -> None:
    """A slab between faces at 25 and 100 °C: the reduced model carries them by lifting (aromm.reduction.lifting), so
    its field is Ψ X + Σ τ_d ℓ_d.  The fixed nodes hold their temperatures exactly; the field converges to the full
    model's (BDF2 at dt and dt/4, Richardson-extrapolated) with the order, and stays within 10× the error of a
    mid-depth thermocouple's reading (measured 2× at order 40, 4× at order 80; the face means are exact here)."""
    end = 0.2 * SLAB_TAU
    path = steel_slab(tmp_path, 16, end, end / 400, f"[outputs.tc]\npoint = [0.01, 0.02, {0.3 * SLAB_L}]\n")
    system = assemble(load_scene(path))
    t = np.array([0.125, 0.25, 0.5, 1.0]) * end
    coarse = transient(system, times=t, fields=True)
    fine = transient(replace(system, time=TimeGrid(end, end / 1600)), times=t, fields=True)
    assert coarse.fields is not None and fine.fields is not None
    exact = fine.fields + (fine.fields - coarse.fields) / 15  # BDF2 is second order: (4² − 1)
    exact_out = fine.as_array() + (fine.as_array() - coarse.as_array()) / 15
    hot = system.dirichlet[1].dofs
    errors = []
    for order in (40, 80):
        obs = reduce(system, order=order, cache=tmp_path / "cache", fields=True).simulate(None, t, fields=True)
        assert obs.fields is not None
        np.testing.assert_array_equal(obs.fields[:, hot], 100.0)
        field_err = np.abs(obs.fields - exact).max()
        assert field_err <= 10 * np.abs(obs.as_array() - exact_out).max()
        errors.append(field_err)
    assert errors[1] < errors[0] / 100 and errors[1] < 1e-4  # K, on a 75 K difference


def test_a_cached_krylov_model_keeps_its_fields(tmp_path: Path) -> None:
    """The second build of a Krylov model asked for fields loads Ψ from the cache (the kind was unknown to the cache
    and the load raised KeyError): same basis, same fields."""
    import warnings

    from aromm.core.system import TimeGrid
    from aromm.core.vocabulary import FaceSpec, PhaseSpec
    from aromm.fem import assemble_voxels
    from aromm.reduction.offline import reduce

    labels = (np.random.default_rng(2).random((5,) * 3) < 0.4).astype(int)
    phases = [PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4e6)]
    system = assemble_voxels(labels, (5e-6,) * 3, phases, [FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)],
                             time=TimeGrid(2.0, 0.05), outputs=["z0", "z1"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        built, cached = (reduce(system, order=8, method="krylov", bounds={"fibre.k": (0.1, 1.0)}, cache=tmp_path,
                                fields=True) for _ in range(2))
    assert built.info["cached"] == 0 and cached.info["cached"] == 1
    assert built.basis is not None and cached.basis is not None
    np.testing.assert_array_equal(cached.basis, built.basis)
