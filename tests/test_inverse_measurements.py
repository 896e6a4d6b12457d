"""Measurements: CSV reader/writer refusals, noise statistics, the homogeneous twin [Chavez2020, eq. 1, 13, 14]."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from inverse_cases import scenario_model

from aromm.core.errors import InputError
from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec, PhaseSpec
from aromm.full.solve import simulate
from aromm.homogenization.properties import fluxmetric, homogenize, mean_capacity
from aromm.homogenization.synthetic import homogeneous_measurements
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene, assemble
from inverse.measurements import (
    Measurements,
    load_measurements,
    save_measurements,
    simulate_measurements,
)

# plausible temperatures (°C), sorted below: a monotone series has no single outlier (aromm.core.labchecks)
finite = st.floats(min_value=-150.0, max_value=1200.0, allow_nan=False, allow_infinity=False)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(finite, finite), min_size=1, max_size=20))
def test_csv_round_trip_is_exact(tmp_path_factory: pytest.TempPathFactory, rows: list[tuple[float, float]]) -> None:
    t = np.cumsum(np.full(len(rows), 0.25))
    m = Measurements(t, {"z0": np.sort([r[0] for r in rows]), "z1": np.sort([r[1] for r in rows])[::-1]})
    path = tmp_path_factory.mktemp("csv") / "y.csv"
    save_measurements(m, path)
    back = load_measurements(path, ["z0", "z1"])
    assert back.faces == ("z0", "z1")
    np.testing.assert_array_equal(back.t, t)
    np.testing.assert_array_equal(back.as_array(), m.as_array())


def test_save_creates_missing_folders_and_names_an_unwritable_path(tmp_path: Path) -> None:
    m = Measurements(np.array([1.0, 2.0]), {"z0": np.array([0.5, 0.7])})
    path = tmp_path / "out" / "run 1" / "y.csv"  # the README's first command writes into a fresh out/
    save_measurements(m, path)
    np.testing.assert_array_equal(load_measurements(path).as_array(), m.as_array())
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(InputError, match="cannot write the measurement file"):
        save_measurements(m, blocker / "y.csv")
    assert [p.name for p in (tmp_path / "out" / "run 1").iterdir()] == ["y.csv"]  # no temporary left


@pytest.mark.parametrize(("text", "needles"), [
    ("", ["empty file"]),
    ("when,z0\n1,2\n", ["line 1", "header must be 't,<face>,...'"]),
    ("t\n1\n", ["line 1", "header"]),
    ("t,z0\n", ["no data rows"]),
    ("t,z0,z0\n1,2,3\n", ["line 1", "'z0' appears twice"]),
    ("t,z0,q9\n1,2,3\n", ["line 1, column 3", "'q9'", "allowed: z0, z1"]),
    ("t,z0\n1,2\n2,abc\n", ["line 3", "column 'z0'", "'abc' is not a number"]),
    ("t,z0\n1,2\n2,nan\n", ["line 3", "'nan' is not finite"]),
    ("t,z0\n1,2\n2,inf\n", ["line 3", "not finite"]),
    ("t,z0\n1,2\n1,3\n", ["line 3", "does not increase", "strictly increasing"]),
    ("t,z0\n2,2\n1,3\n", ["line 3", "does not increase"]),
    ("t,z0\n-1,2\n", ["line 2", "negative"]),
    ("t,z0\n1,2\n2,3,4\n", ["line 3", "3 fields, the header has 2"]),
])
def test_csv_refusals_name_file_line_and_allowed(tmp_path: Path, text: str, needles: list[str]) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as err:
        load_measurements(path, ["z0", "z1"])
    msg = str(err.value)
    assert str(path) in msg
    for needle in needles:
        assert needle in msg


def test_spreadsheet_csv_with_bom_and_crlf_is_read(tmp_path: Path) -> None:
    path = tmp_path / "excel.csv"
    path.write_bytes("\ufefft,z0\r\n1,2.5\r\n2,3.5\r\n".encode())
    m = load_measurements(path, ["z0"])
    np.testing.assert_array_equal(m.values["z0"], [2.5, 3.5])


def test_missing_file_is_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="cannot read"):
        load_measurements(tmp_path / "absent.csv")


def test_noise_has_the_requested_standard_deviation_and_is_seeded() -> None:
    t = np.arange(1.0, 20001.0)
    m = Measurements(t, {"z0": np.zeros_like(t)})
    a = m.with_noise(0.02, np.random.default_rng(5))
    b = m.with_noise(0.02, np.random.default_rng(5))
    np.testing.assert_array_equal(a.as_array(), b.as_array())
    # sample std of 20000 N(0, 0.02²) draws: relative standard error 1/sqrt(2 * 20000) = 0.5 %
    assert abs(np.std(a.values["z0"]) / 0.02 - 1.0) < 0.02
    assert abs(np.mean(a.values["z0"])) < 4 * 0.02 / np.sqrt(t.size)


def test_simulated_measurements_refuse_unknown_faces_and_need_rng_for_noise() -> None:
    model = scenario_model("z", n=3, end=4.0, dt=1.0)
    with pytest.raises(InputError, match="allowed: z0, z1"):
        simulate_measurements(model, faces=["x0"])
    with pytest.raises(InputError, match="rng"):
        simulate_measurements(model, noise=0.1)
    y = simulate_measurements(model, faces=["z1"])
    assert y.faces == ("z1",)
    np.testing.assert_allclose(y.t, [1.0, 2.0, 3.0, 4.0])


def _slab_scene(axis: str, end: float = 400.0, dt: float = 2.0) -> Scene:
    """A two-phase 4³ box loaded along ``axis`` (the twin only uses its box, faces and time grid)."""
    labels = np.zeros((4, 4, 4), dtype=np.int32)
    labels[::2] = 1
    phases = (PhaseSpec("gas", 0, 0.025, 1.2e3), PhaseSpec("fibre", 1, 0.3, 4.0e6))
    boundary = (FaceSpec(f"{axis}0", flux=500.0), FaceSpec(f"{axis}1", h=20.0))
    return Scene(VoxelGeometry(labels, (2e-4 / 4, 2e-4 / 4, 2e-4 / 4)), phases, boundary, 0.0, TimeGrid(end, dt),
                 (f"{axis}0", f"{axis}1"))


@pytest.mark.parametrize("axis", ["x", "y", "z"])
def test_homogeneous_twin_reaches_the_analytic_steady_state(axis: str) -> None:
    """Long after loading: T̄_1 = φ/h (energy balance) and T̄_0 − T̄_1 = φ L / k_ii (1-D conduction)."""
    k = np.diag([0.087, 0.099, 0.123])
    kii = k["xyz".index(axis), "xyz".index(axis)]
    y = homogeneous_measurements(_slab_scene(axis), k, 1.558e6)
    hot, cold = y.values[f"{axis}0"][-1], y.values[f"{axis}1"][-1]
    assert cold == pytest.approx(500.0 / 20.0, rel=1e-6)
    assert hot - cold == pytest.approx(500.0 * 2e-4 / kii, rel=1e-6)


def test_fluxmetric_twin_ends_at_the_heterogeneous_steady_state_and_eq13_twin_does_not() -> None:
    """[Chavez2020, § 4.2]: k̄ from the scenario itself makes the twin's late face means those of the sample.

    Loading along the layers (4³ two-phase laminate, contrast 12); 400 s is 20 time constants c̄ L / h.
    """
    scene = _slab_scene("z")
    sample = simulate(assemble(scene)).mean_T
    c = mean_capacity(scene)
    twin = homogeneous_measurements(scene, fluxmetric(scene).k, c).values
    eq13 = homogeneous_measurements(scene, homogenize(scene, boundary="flux"), c).values
    for face in ("z0", "z1"):
        assert twin[face][-1] == pytest.approx(sample[face][-1], rel=1e-7)
    drop = sample["z0"][-1] - sample["z1"][-1]
    assert abs((eq13["z0"][-1] - eq13["z1"][-1]) / drop - 1.0) > 0.01  # isothermal-S2 k̄: a biased twin


def test_twin_ignores_transverse_conductivities_and_applies_the_perturbation() -> None:
    scene = _slab_scene("z")
    base = homogeneous_measurements(scene, np.diag([0.087, 0.099, 0.123]), 1.558e6)
    other = homogeneous_measurements(scene, np.diag([0.5, 0.01, 0.123]), 1.558e6)
    np.testing.assert_allclose(other.as_array(), base.as_array(), rtol=1e-10)
    plus = homogeneous_measurements(scene, np.diag([0.087, 0.099, 0.123]), 1.558e6, perturbation=0.02)
    drop = base.values["z0"][-1] - base.values["z1"][-1]
    assert plus.values["z0"][-1] - plus.values["z1"][-1] == pytest.approx(drop / 1.02, rel=1e-6)
    # early on the heat stored ∝ c̄: at t << L²/a the mean rise is φ t / (c̄ L) for both, so +2 % in c̄
    # lowers the early mean temperature
    assert plus.values["z0"][0] < base.values["z0"][0]


def test_twin_refuses_a_steady_scene_and_bad_perturbation() -> None:
    scene = _slab_scene("z")
    steady = Scene(scene.geometry, scene.phases, scene.boundary, 0.0, None, scene.outputs)
    with pytest.raises(InputError, match="transient"):
        homogeneous_measurements(steady, np.eye(3), 1e6)
    with pytest.raises(InputError, match="perturbation"):
        homogeneous_measurements(scene, np.eye(3), 1e6, perturbation=-2.0)
