"""The scene's [moisture] vocabulary (aromm.scene.moisture_section) from the command line: the coupled slab of
tests/test_hygrothermal.py written as a scene file, simulated by `aromm simulate --model reduced --json` against the
exact coupled solution, bad input refused with its key, measure's coupled homogeneous twin, and a
reduced model's cache key split by every moisture value outside its training box."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_hygrothermal import TIMES, _exact_far_face

from aromm.cli import main
from aromm.reduction.model_key import scene_physics_key
from aromm.scene.scene_file import load_scene

SCENE = """
[geometry]
image = "bar.npy"
voxel_size = [{size}, {size}, {size}]

[phases.board]
label = 0
k = 0.04
c = 3.2e5
xi = {xi}
D_phi = 1.0e-9
delta_p = 2.0e-11

[moisture]
T_ref = 20.0
phi_ref = 0.5

[boundary.x0]
T = 20.0
phi = 0.8

[initial]
T = 20.0
phi = 0.5

[time]
end = 7200.0
dt = 600.0

[outputs]
mean_T = ["x1"]
mean_phi = ["x1"]

[reduction]
method = "krylov"
bounds = {{ "board.xi" = [10.0, 40.0] }}
"""


def _scene(folder: Path, cells: int = 16, xi: float = 20.0) -> Path:
    np.save(folder / "bar.npy", np.zeros((cells, 1, 1), dtype=np.int32))
    path = folder / "s.toml"
    path.write_text(SCENE.format(size=0.02 / cells, xi=xi), encoding="utf-8")
    return path


def far_face(path: Path, capsys: pytest.CaptureFixture[str], *options: str) -> np.ndarray:
    """(2, times): T and φ of the far face x1 by `aromm simulate --json` of the scene at ``path``."""
    assert main(["simulate", str(path), "--json", *options]) == 0
    out = json.loads(capsys.readouterr().out)
    return np.array([out["mean_T"]["x1"], out["mean_phi"]["x1"]])


def rounding_floor(y: np.ndarray) -> float:
    """Two runs whose systems differ only in how a value enters (a history equal to 1 times it, a tensor's unit
    operators summed) differ by the rounding of the loads, operators and solves' products: a few ε of the outputs'
    size, times the steps they accumulate over."""
    return 64 * np.finfo(float).eps * float(np.abs(y).max()) * y.shape[1]


@pytest.mark.filterwarnings("ignore::aromm.core.errors.ModelWarning")
def test_simulate_reduced_gives_mean_phi_beside_mean_T_within_the_exact_solution(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    """16 cells: Q1's error on this slab is 6.0e-4 °C and 4.9e-5 in φ (tests/test_hygrothermal.py); the reduced
    model adds at most its certified bound, given in the JSON."""
    monkeypatch.setenv("AROMM_CACHE_DIR", str(tmp_path / "cache"))
    path = _scene(tmp_path)
    assert main(["simulate", str(path), "--model", "reduced", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["mean_T"]) == {"x1"} and set(out["mean_phi"]) == {"x1"}
    t = np.asarray(out["t"])
    at = np.searchsorted(t, TIMES)
    assert np.allclose(t[at], TIMES)
    exact = _exact_far_face(TIMES)
    bound = out["error_bound"]  # per output: x1 in °C, phi:x1 in relative humidity
    assert np.abs(np.asarray(out["mean_T"]["x1"])[at] - exact[:, 0]).max() <= 6.1e-4 + bound["x1"]
    assert np.abs(np.asarray(out["mean_phi"]["x1"])[at] - exact[:, 1]).max() <= 5e-5 + bound["phi:x1"]


def test_the_scene_parameters_name_the_moisture_values(tmp_path: Path) -> None:
    path = _scene(tmp_path)
    path.write_text(path.read_text(encoding="utf-8").replace(
        "[initial]", "[boundary.x1]\nh = 8.0\nT_ext = 18.0\nbeta = 2e-8\nphi_ext = 0.4\n[initial]"), encoding="utf-8")
    scene = load_scene(path)
    params = scene.parameters
    assert params["board.xi"] == 20.0 and params["x0.phi"] == 0.8 and params["initial.phi"] == 0.5
    assert params["x1.beta"] == 2e-8 and params["x1.phi_ext"] == 0.4
    assert scene.moisture is not None and scene.moisture.outputs == ("x1",)


@pytest.mark.parametrize(("edit", "fragment"), [
    (lambda s: s.replace("[moisture]\nT_ref = 20.0\nphi_ref = 0.5\n", ""), "phases.board.xi: a moisture key needs"),
    (lambda s: s.replace("xi = 20.0\n", ""), "phases.board.xi: missing"),
    (lambda s: s.replace("phi = 0.8", "phi = 80"), "boundary.x0.phi: a relative humidity lies in [0, 1]"),
    (lambda s: s.replace("delta_p = 2.0e-11", "delta_p = -1.0"), "phases.board.delta_p: must be >= 0"),
    (lambda s: s.replace("phi_ref = 0.5", "phi_ref = 0.0"), "moisture.phi_ref must lie in (0, 1]"),
    (lambda s: s.replace('mean_phi = ["x1"]', 'mean_phi = ["q1"]'), "outputs.mean_phi: must be a list of faces"),
    (lambda s: s.replace("[initial]", "[boundary.x1]\nbeta = 2e-8\nphi_ext = 0.4\n[initial]"),
     "boundary.x1: a vapour exchange takes beta (kg/(m² s Pa)) and phi_ext, on a face that exchanges heat"),
    (lambda s: s.replace("phi = 0.8", "phi = 0.8\nbeta = 2e-8"), "boundary.x0: a face takes a fixed phi, or"),
])
def test_bad_moisture_input_exits_2_naming_the_key(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                   edit: object, fragment: str) -> None:
    path = _scene(tmp_path)
    path.write_text(edit(path.read_text(encoding="utf-8")), encoding="utf-8")  # type: ignore[operator]
    assert main(["simulate", str(path), "--json"]) == 2
    assert fragment in capsys.readouterr().err


def test_measure_gives_the_coupled_twin_of_a_homogeneous_bar_exactly(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    """The homogeneous bar is its own twin: the properties measure inverts from the effective transport are the
    board's, and its data (T and φ at the far face) are the scene's own full model (`aromm simulate --json`) to the
    steady probes' rounding; noise per kind is added where asked; a moisture face across the loaded axis is
    refused."""
    path = _scene(tmp_path)
    assert main(["simulate", str(path), "--json"]) == 0
    full = json.loads(capsys.readouterr().out)
    assert main(["measure", str(path), "--homogeneous", "--out", str(tmp_path / "y.csv"), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    for key, value in {"xi": 20.0, "D_phi": 1.0e-9, "delta_p": 2.0e-11}.items():
        assert summary["moisture"][key] == pytest.approx(value, rel=1e-6)
    data = np.loadtxt(tmp_path / "y.csv", delimiter=",", skiprows=1)
    header = (tmp_path / "y.csv").read_text(encoding="utf-8").splitlines()[0].split(",")
    assert header == ["t", "x1", "phi:x1"]
    t = np.asarray(full["t"])
    at = np.searchsorted(t, data[:, 0])
    assert np.abs(data[:, 1] - np.asarray(full["mean_T"]["x1"])[at]).max() <= 1e-6  # °C
    assert np.abs(data[:, 2] - np.asarray(full["mean_phi"]["x1"])[at]).max() <= 1e-7
    assert main(["measure", str(path), "--homogeneous", "--out", str(tmp_path / "n.csv"), "--noise", "0.01",
                 "--noise-phi", "0.002", "--seed", "1", "--json"]) == 0
    capsys.readouterr()
    noisy = np.loadtxt(tmp_path / "n.csv", delimiter=",", skiprows=1)
    spread = np.std(noisy[:, 1:] - data[:, 1:], axis=0)
    assert 0.003 < spread[0] < 0.03 and 0.0006 < spread[1] < 0.006  # 12 samples: within 3x of each sigma
    path.write_text(path.read_text(encoding="utf-8").replace("[initial]", "[boundary.y1]\nphi = 0.6\n\n[initial]"),
                    encoding="utf-8")
    assert main(["measure", str(path), "--homogeneous", "--out", str(tmp_path / "z.csv")]) == 2
    assert "boundary.y1: a moisture condition across the loaded axis x" in capsys.readouterr().err


def test_a_moisture_value_outside_the_box_splits_the_cache_key(tmp_path: Path) -> None:
    """ξ outside the training box changes the model; inside it, one model serves (issue 35's rule, moisture too)."""
    first, second = tmp_path / "a", tmp_path / "b"
    first.mkdir()
    second.mkdir()
    a, b = load_scene(_scene(first, xi=20.0)), load_scene(_scene(second, xi=30.0))
    assert scene_physics_key(a) != scene_physics_key(b)
    assert scene_physics_key(a, {"board.xi"}) == scene_physics_key(b, {"board.xi"})


@pytest.mark.filterwarnings("ignore::aromm.core.errors.ModelWarning")
def test_reduce_and_homogenize_say_what_they_do_with_moisture(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """`aromm reduce` names the bound's units (°C, and relative humidity for the phi: outputs); `aromm homogenize`
    gives the heat and moisture transport beside k̄ and c̄ (by default the periodic cell, with its whole tensor)."""
    monkeypatch.setenv("AROMM_CACHE_DIR", str(tmp_path / "cache"))
    path = _scene(tmp_path)
    assert main(["reduce", str(path)]) == 0
    out = capsys.readouterr().out
    assert "outputs: x1, phi:x1" in out and "relative humidity for phi: outputs" in out
    assert main(["homogenize", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    transport = np.asarray(out["moisture"]["transport"])
    assert transport.shape == (3, 2, 2) and out["moisture"]["xi"] == 20.0  # one phase: its own ξ
    assert out["moisture"]["boundary"] == "periodic" and np.asarray(out["moisture"]["tensor"]).shape == (3, 3, 2, 2)
    # one phase: along x its own flux matrix (heat: k + L_v δ_p a, moisture: D_φ + δ_p p at constant T)
    from aromm.physics.hygrothermal import MoistureState

    state = MoistureState(20.0, 0.5)
    expect = np.array([[0.04 + state.latent_heat * 2e-11 * state.a, state.latent_heat * 2e-11 * state.p],
                       [2e-11 * state.a, 1e-9 + 2e-11 * state.p]])
    assert np.allclose(transport[0], expect, rtol=1e-9)


def test_the_shipped_moisture_scene_loads_with_its_parameters() -> None:
    """data/scenes/wood_moisture.toml reads (its simulation takes seconds: run by hand, its figures in its header)."""
    scene = load_scene(Path(__file__).parents[1] / "data" / "scenes" / "wood_moisture.toml")
    assert scene.moisture is not None and scene.moisture.vapour == {"z1": (2e-8, 0.5)}
    assert scene.parameters["fibre.xi"] == 200.0 and scene.parameters["z0.phi"] == 0.8


def test_a_moisture_flux_face_through_the_scene_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """[boundary.x1] g: its parameter joins the scene's, and the steady far face is the exact linear profile of
    tests/test_hygrothermal.py (here on 16 cells; a linear field is exact in Q1), through `aromm simulate --json`."""
    from test_hygrothermal import BOARD, LENGTH, STATE, _physical

    path = _scene(tmp_path)
    text = path.read_text(encoding="utf-8")
    text = text[:text.index("[time]")] + "[outputs]\nmean_T = [\"x1\"]\nmean_phi = [\"x1\"]\n"
    path.write_text(text.replace("[initial]", "[boundary.x1]\ng = 2.0e-7\n\n[initial]"), encoding="utf-8")
    assert load_scene(path).parameters["x1.g"] == 2.0e-7
    assert main(["simulate", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    far = np.array([out["mean_T"]["x1"][-1], out["mean_phi"]["x1"][-1]])
    slope = np.linalg.solve(_physical(STATE, BOARD["k"], BOARD["D_phi"], BOARD["delta_p"]), np.array([0.0, 2.0e-7]))
    exact = np.array([20.0, 0.8]) + slope * LENGTH
    assert np.abs(far - exact).max() <= 1e-9 * np.abs(exact).max()
    path.write_text(path.read_text(encoding="utf-8").replace("g = 2.0e-7", "g = 2.0e-7\nphi = 0.5"),
                    encoding="utf-8")
    assert main(["simulate", str(path), "--json"]) == 2
    assert "boundary.x1: a face takes one moisture condition" in capsys.readouterr().err


def test_sensors_read_the_humidity_too(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """mean_phi may name sensors: a thermocouple-like point and a one-pixel camera on the far face of the bar read
    its humidity (and its temperature), equal to the far face's mean (the field is uniform across the bar)."""
    path = _scene(tmp_path)
    size = 0.02 / 16
    sensors = (f'[outputs.rh]\npoint = [0.02, {size / 2}, {size / 2}]\n\n'
               '[outputs.cam]\nface = "x1"\npixels = [1, 1]\n')
    text = path.read_text(encoding="utf-8").replace('mean_phi = ["x1"]', 'mean_phi = ["x1", "rh", "cam"]')
    path.write_text(text.replace("[reduction]", sensors + "\n[reduction]"), encoding="utf-8")
    assert main(["simulate", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["mean_phi"]) == {"x1", "rh", "cam_0_0"} and set(out["mean_T"]) == {"x1", "rh", "cam_0_0"}
    for kind in ("mean_T", "mean_phi"):
        face = np.asarray(out[kind]["x1"])
        for name in ("rh", "cam_0_0"):
            assert np.abs(np.asarray(out[kind][name]) - face).max() <= 1e-12 * np.abs(face).max()
    path.write_text(path.read_text(encoding="utf-8").replace('"x1", "rh", "cam"]', '"x1", "nope"]'),
                    encoding="utf-8")
    assert main(["simulate", str(path), "--json"]) == 2
    assert "outputs.mean_phi: must be a list of faces among" in capsys.readouterr().err


def test_a_fibre_phase_is_coupled_as_its_orthotropic_twin(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A rotated tensor phase (a fibre axis) couples to moisture with isotropic D_phi and delta_p, whose operator is
    the sum of its unit tensors' (a aᵀ + (I − a aᵀ) = I): a fibre along x is exactly the orthotropic phase
    k = [k_axial, k_t, k_t] along the image axes, on a two-phase 6 × 4 × 4 body (outputs equal to the rounding
    of the two assemblies, a few ε of the outputs times the steps); the axis matters (along y it differs)."""
    labels = (np.random.default_rng(3).random((6, 4, 4)) < 0.5).astype(np.int32)
    np.save(tmp_path / "bar.npy", labels)
    text = SCENE.format(size=0.02 / 6, xi=20.0).replace(
        "[moisture]", "[phases.pore]\nlabel = 1\nk = 0.026\nc = 1.2e3\nxi = 0.5\nD_phi = 1.0e-10\n"
                      "delta_p = 1.9e-10\n\n[moisture]")
    text = text[:text.index("[reduction]")]
    outputs = {}
    for name, k in [("orthotropic", "k = [0.08, 0.04, 0.04]"),
                    ("fibre x", "k_axial = 0.08\nk_transverse = 0.04\naxis = [1.0, 0.0, 0.0]"),
                    ("fibre y", "k_axial = 0.08\nk_transverse = 0.04\naxis = [0.0, 1.0, 0.0]")]:
        path = tmp_path / "s.toml"
        path.write_text(text.replace("k = 0.04\n", k + "\n", 1), encoding="utf-8")
        outputs[name] = far_face(path, capsys)
    floor = rounding_floor(outputs["orthotropic"])
    assert np.abs(outputs["fibre x"] - outputs["orthotropic"]).max() <= floor
    assert np.abs(outputs["fibre y"] - outputs["orthotropic"]).max() > 1e3 * floor


def test_the_full_coupled_field_is_written_with_T_and_phi(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`simulate --model full --out` writes field.vtu for a coupled scene too (it was skipped without a word): point
    data T and phi on the bar's nodes, the last step's field, whose far-face values are the last output row; and the
    unknowns' points for the direct solvers' nested dissection are the nodes' once per field."""
    import meshio

    from aromm.api import assemble

    path = _scene(tmp_path, cells=8)
    assert main(["simulate", str(path), "--model", "full", "--out", str(tmp_path / "out")]) == 0
    capsys.readouterr()
    mesh = meshio.read(tmp_path / "out" / "field.vtu")
    assert set(mesh.point_data) >= {"T", "phi"}
    rows = np.genfromtxt(tmp_path / "out" / "observables.csv", delimiter=",", names=True)
    far = np.isclose(mesh.points[:, 0], 0.02)
    assert np.allclose(mesh.point_data["T"][far], rows["x1"][-1], rtol=0, atol=1e-12)
    assert np.allclose(mesh.point_data["phi"][far], rows["phix1"][-1], rtol=0, atol=1e-12)
    assert np.allclose(mesh.point_data["phi"][np.isclose(mesh.points[:, 0], 0.0)], 0.8)
    system = assemble(load_scene(path))
    points = system.unknown_points()
    assert system.fields == ("T", "phi") and points is not None and points.shape == (system.n, 3)
    np.testing.assert_array_equal(points[: system.n // 2], points[system.n // 2:])
