"""Named sensors (aromm.scene.sensors): point, face patch, IR camera — against analytic slabs and face means."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scene_text import MESH_CELL, SLAB_ALPHA, SLAB_L, SLAB_TAU, scenario_1, steel_slab

from aromm.bounds.cell_fem import cell_mesh
from aromm.cli import main
from aromm.core.errors import InputError
from aromm.core.observables import read_csv
from aromm.full.analytic import slab_dirichlet_series
from aromm.full.solve import transient
from aromm.reduction.offline import reduce
from aromm.scene.scene_file import assemble, load_scene
from aromm.scene.sensors import hat_means, hat_values

# one third of an element past a node plane on every grid below (s = z/dz = 7/3, 14/3, 28/3): the interpolation
# error ½ f (1 − f) dz² T'' keeps its factor f (1 − f) = 2/9, so the reading's error converges cleanly at order 2
DEPTH = 7 / 24 * SLAB_L


def test_point_sensor_in_a_slab_converges_to_the_analytic_temperature_at_its_depth(tmp_path: Path) -> None:
    """[Hassan2019, eq. 12–13]: T(z, t) between fixed faces; the thermocouple sits off the node planes and off
    the axis, so its reading combines all 8 trilinear weights.  Error O(dz²) (nodal error and interpolation)
    + O(dt²) (dt small enough not to show): rate ≈ 2."""
    t_end = 0.05 * SLAB_TAU
    sensor = f"[outputs.tc]\npoint = [{0.31 * SLAB_L}, {0.77 * SLAB_L}, {DEPTH}]\n"
    exact = slab_dirichlet_series(DEPTH, t_end, SLAB_L, SLAB_ALPHA, 25.0, 25.0, 100.0, n_terms=400)
    errors = []
    for nz in (8, 16, 32):
        system = assemble(load_scene(steel_slab(tmp_path, nz, t_end, t_end / 400, sensor)))
        reading = transient(system, times=[t_end]).mean_T["tc"][0]
        errors.append(abs(reading - float(exact)))
    rates = np.log2(np.asarray(errors[:-1]) / np.asarray(errors[1:]))
    assert np.all(rates > 1.7), (errors, rates)
    assert errors[-1] < 0.05  # K, on a 75 K difference


def test_a_patch_over_the_whole_face_is_the_face_mean_and_rows_sum_to_one(tmp_path: Path) -> None:
    """Two independent constructions of ∫_f φ_a / |f|: the face mass matrix (aromm.core.vocabulary) and the tensor
    product of 1-D hat integrals (aromm.scene.sensors); a camera's pixels tile the face, so their area-weighted
    mean is the face mean too."""
    rng = np.random.default_rng(3)
    np.save(tmp_path / "img.npy", (rng.random((5, 4, 6)) < 0.4).astype(np.int32))
    text = scenario_1("img.npy", "[1e-5, 2e-5, 1.5e-5]", "1.0", "0.1") + """
[outputs.whole]
face = "z1"
[outputs.whole_x]
face = "x0"
y = [0.0, 8e-5]
[outputs.cam]
face = "z1"
pixels = [3, 2]
[outputs.tc]
point = [2.2e-5, 3.1e-5, 0.0]
"""
    (tmp_path / "s.toml").write_text(text, encoding="utf-8")
    system = assemble(load_scene(tmp_path / "s.toml"))
    b = system.observation
    face = np.asarray(b["z1"])
    np.testing.assert_allclose(b["whole"].toarray()[0], face, rtol=0, atol=1e-15)
    assert set(system.observation) >= {f"cam_{i}_{j}" for i in range(3) for j in range(2)}
    cam = sum(b[f"cam_{i}_{j}"].toarray()[0] for i in range(3) for j in range(2)) / 6  # equal pixels
    np.testing.assert_allclose(cam, face, rtol=0, atol=1e-15)
    for name, row in b.items():
        total = row.sum() if hasattr(row, "toarray") else np.sum(row)
        assert total == pytest.approx(1.0, abs=1e-14), name
    # a thermocouple on a face reads a bilinear interpolation: a linear field is reproduced exactly
    x = np.asarray(system.geometry.points)
    linear = 3.0 + 2e4 * x[:, 0] - 1e4 * x[:, 1] + 5e3 * x[:, 2]
    assert (b["tc"] @ linear)[0] == pytest.approx(3.0 + 2e4 * 2.2e-5 - 1e4 * 3.1e-5, rel=1e-13)
    # a linear field's mean over a patch is its value at the patch centre
    assert (b["whole_x"] @ linear)[0] == pytest.approx(3.0 - 1e4 * 4e-5 + 5e3 * 4.5e-5, rel=1e-13)


def test_hat_weights_reproduce_linear_functions() -> None:
    """1-D hats: values interpolate u exactly; means over [a, b] give the midpoint (linear exactness)."""
    nodes, w = hat_values(7, 0.3, 1.0)
    assert w.sum() == pytest.approx(1.0) and (nodes * 0.3) @ w == pytest.approx(1.0)
    nodes, w = hat_means(7, 0.3, 0.1, 1.75)
    assert w.sum() == pytest.approx(1.0, abs=1e-15)
    assert (nodes * 0.3) @ w == pytest.approx((0.1 + 1.75) / 2, rel=1e-14)


@pytest.mark.parametrize(("sensor", "key"), [
    ("[outputs.tc]\npoint = [0.0, 0.0, 2e-4]", "outputs.tc.point"),            # beyond z = 6 × 1.5e-5 m
    ("[outputs.tc]\npoint = [0.0, 0.0]", "outputs.tc.point"),
    ("[outputs.spot]\nface = \"z1\"\nx = [2e-5, 2e-5]", "outputs.spot.x"),      # empty patch
    ("[outputs.spot]\nface = \"z1\"\nx = [2e-5, 1e-5]", "outputs.spot.x"),
    ("[outputs.spot]\nface = \"z1\"\ny = [0.0, 9e-5]", "outputs.spot.y"),       # outside the face (y ≤ 8e-5)
    ("[outputs.spot]\nface = \"z1\"\nz = [0.0, 1e-5]", "outputs.spot.z"),       # normal axis
    ("[outputs.spot]\nface = \"top\"", "outputs.spot.face"),
    ("[outputs.cam]\nface = \"z1\"\npixels = [0, 4]", "outputs.cam.pixels"),
    ("[outputs.cam]\nface = \"z1\"\npixels = [2.5, 4]", "outputs.cam.pixels"),
    ("[outputs.tc]\npoint = [0, 0, 0]\nface = \"z1\"", "outputs.tc"),
    ("[outputs.tc]\nradius = 1", "outputs.tc.radius"),
    ("[outputs.z1]\npoint = [0, 0, 0]", "outputs.z1"),                          # a face's name
    ("[outputs.cam]\nface = \"z1\"\npixels = [1, 2]\n[outputs.cam_0_1]\npoint = [0, 0, 0]", "outputs"),
    ("[outputs]\nmeanT = [\"z0\"]", "outputs.meanT"),
])
def test_bad_sensors_are_refused_naming_the_key(tmp_path: Path, sensor: str, key: str) -> None:
    np.save(tmp_path / "img.npy", np.zeros((5, 4, 6), dtype=np.int32))
    text = scenario_1("img.npy", "[1e-5, 2e-5, 1.5e-5]", "1.0", "0.1").replace("[phases.fibre]\nlabel = 1",
                                                                               "[phases.fibre]\nlabel = 0")
    text = text.replace("[phases.gas]\nlabel = 0\nk = 0.025\nc = 1.2e3\n", "")
    if sensor.startswith("[outputs]"):
        text = text.replace('[outputs]\nmean_T = ["z0", "z1"]', sensor)
    else:
        text += sensor + "\n"
    (tmp_path / "bad.toml").write_text(text, encoding="utf-8")
    with pytest.raises(InputError, match=rf"bad\.toml: {key.replace('.', '[.]')}\b"):
        load_scene(tmp_path / "bad.toml")


def test_reduced_model_projects_sensor_rows_and_measurements_use_their_names(tmp_path: Path,
                                                                            capsys: pytest.CaptureFixture[str]) -> None:
    """With every mode kept the reduced model is the full semi-discrete model: its sensor outputs equal the full
    model's to the time-stepping error of BDF2 (checked against a 4× finer step: the gap shrinks ~16×)."""
    rng = np.random.default_rng(5)
    np.save(tmp_path / "img.npy", (rng.random((3, 3, 4)) < 0.5).astype(np.int32))
    text = scenario_1("img.npy", "2e-5", "4.0", "0.02") + """
[outputs.tc]
point = [3e-5, 1e-5, 4e-5]
[outputs.cam]
face = "z0"
pixels = [2, 2]
"""
    (tmp_path / "s.toml").write_text(text, encoding="utf-8")
    scene = load_scene(tmp_path / "s.toml")
    system = assemble(scene)
    rom = reduce(system, order=system.n, modes=system.n, cache=tmp_path / "cache")
    assert rom.outputs == ("z0", "z1", "tc", "cam_0_0", "cam_0_1", "cam_1_0", "cam_1_1")
    t = np.array([0.5, 1.0, 4.0])
    reduced = rom.simulate(None, t).as_array()
    gaps = []
    for dt in (0.02, 0.005):
        from dataclasses import replace

        from aromm.core.system import TimeGrid
        full = transient(replace(system, time=TimeGrid(4.0, dt)), times=t).as_array()
        gaps.append(np.abs(full - reduced).max())
    assert gaps[1] < gaps[0] / 8, gaps
    assert gaps[1] < 1e-3 * np.abs(reduced).max()
    # aromm measure writes the sensor columns; identify reads them
    csv = tmp_path / "y.csv"
    assert main(["measure", str(tmp_path / "s.toml"), "--homogeneous", "--conductivity", "flux",
                 "--out", str(csv), "--json"]) == 0
    capsys.readouterr()
    data = read_csv(csv, rom.outputs)
    assert data.outputs == rom.outputs


def test_point_sensor_on_a_mesh_interpolates_p1_and_p2_and_patches_are_refused(tmp_path: Path) -> None:
    """A mesh scene's thermocouple reproduces a linear (P1) or quadratic (P2) field exactly: the Lagrange
    interpolant of its element, on the split unknowns of a contact resistance."""
    cell_mesh("cell", B=0.5, h=0.5).write(tmp_path / "cell.vtu")
    base = MESH_CELL.replace('"cell.vtu"', '"cell.vtu"\norder = {order}').replace("{R}", "5.0") + """
[boundary.z0]
flux = 1.0
[boundary.z1]
h = 1.0
[time]
end = 1.0
dt = 0.5
[outputs]
mean_T = ["z1"]
[outputs.tc]
point = [0.9, 0.2, 1.1]
"""
    for order in (1, 2):
        (tmp_path / "m.toml").write_text(base.format(order=order), encoding="utf-8")
        system = assemble(load_scene(tmp_path / "m.toml"))
        x = np.asarray(system.geometry.points)
        quadratic = 1.0 + x[:, 0] - 2 * x[:, 1] + 0.5 * x[:, 2] + (order - 1) * x[:, 0] * x[:, 2]
        expected = 1.0 + 0.9 - 0.4 + 0.55 + (order - 1) * 0.99
        assert (system.observation["tc"] @ quadratic)[0] == pytest.approx(expected, rel=1e-12)
    (tmp_path / "m.toml").write_text(base.format(order=1) + '[outputs.spot]\nface = "z1"\n', encoding="utf-8")
    with pytest.raises(InputError, match=r"m\.toml: outputs\.spot\.face: face patches and cameras need a voxel"):
        load_scene(tmp_path / "m.toml")
    (tmp_path / "m.toml").write_text(base.format(order=1).replace("[0.9, 0.2, 1.1]", "[2.0, 0.2, 1.1]"),
                                     encoding="utf-8")
    with pytest.raises(InputError, match=r"outputs\.tc\.point: .* outside the box"):
        load_scene(tmp_path / "m.toml")


def test_simulate_json_lists_sensor_outputs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    np.save(tmp_path / "img.npy", np.ones((2, 2, 3), dtype=np.int32))
    text = scenario_1("img.npy", "1e-5", "0.5", "0.1").replace("[phases.gas]\nlabel = 0\nk = 0.025\nc = 1.2e3\n", "")
    (tmp_path / "s.toml").write_text(text + "[outputs.tc]\npoint = [1e-5, 1e-5, 1.5e-5]\n", encoding="utf-8")
    assert main(["simulate", str(tmp_path / "s.toml"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert list(out["mean_T"]) == ["z0", "z1", "tc"]
    # the body is one phase: at mid-depth the reading lies between the two face means
    assert out["mean_T"]["z1"][-1] < out["mean_T"]["tc"][-1] < out["mean_T"]["z0"][-1]
