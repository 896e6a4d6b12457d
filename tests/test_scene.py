"""Scene files: every refusal names the file and the key; the CLI turns it into exit code 2."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scene_text import scenario_1

from aromm.cli import main
from aromm.core.errors import InputError
from aromm.scene.scene_file import load_scene

GOOD = scenario_1("img.npy", "1.0e-4", "1.0", "0.1")


@pytest.fixture
def scene_dir(tmp_path: Path) -> Path:
    labels = np.zeros((4, 4, 4), dtype=np.uint8)
    labels[1:3, 1:3, :] = 1
    np.save(tmp_path / "img.npy", labels)
    return tmp_path


def _write(folder: Path, text: str) -> Path:
    path = folder / "scene.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_good_scene_loads_with_named_parameters(scene_dir: Path) -> None:
    scene = load_scene(_write(scene_dir, GOOD))
    assert scene.geometry.shape == (4, 4, 4)
    assert scene.geometry.voxel_size == (1e-4, 1e-4, 1e-4)
    assert scene.parameters["fibre.k"] == 0.3 and scene.parameters["z1.h"] == 20.0
    assert scene.time is not None and len(scene.time.times) == 10


@pytest.mark.parametrize(
    ("old", "new", "key"),
    [
        ("[outputs]", "[output]", "output"),
        ("k = 0.3\n", "k = 0.3\nrho = 1.0\n", "phases.fibre"),
        ("[boundary.z1]", "[boundary.z2]", "boundary.z2"),
        ('image = "img.npy"', 'image = "missing.npy"', "geometry.image"),
        ("label = 1\n", "label = 7\n", "phases.fibre.label"),
        ("[phases.gas]\nlabel = 0", "[phases.gas]\nlabel = 5", "phases.gas.label"),
        ("k = 0.3\n", "k = -0.3\n", "phases.fibre.k"),
        ("c = 4.0e6\n", "c = nan\n", "phases.fibre.c"),
        ("c = 4.0e6\n", "c = 0.0\n", "phases.fibre.c"),
        ("flux = 500.0\n", "flux = 500.0\nT = 3.0\n", "boundary.z0"),
        ("dt = 0.1", "dt = 0.0", "time.dt"),
        ("end = 1.0", "end = 0.05", "time.end"),
        ("voxel_size = 1.0e-4", "voxel_size = [1.0e-4, 2.0e-4]", "geometry.voxel_size"),
        ("voxel_size = 1.0e-4", "voxel_size = -1.0e-4", "geometry.voxel_size"),
        ('mean_T = ["z0", "z1"]', 'mean_T = ["z0", "top"]', "outputs.mean_T"),
        ("k = 0.3\n", "k = [0.3, 0.2]\n", "phases.fibre.k"),
    ],
)
def test_bad_scenes_are_refused_naming_file_and_key(scene_dir: Path, old: str, new: str, key: str) -> None:
    assert old in GOOD
    path = _write(scene_dir, GOOD.replace(old, new, 1))
    with pytest.raises(InputError) as info:
        load_scene(path)
    message = str(info.value)
    assert str(path) in message and key in message, message


def test_non_3d_image_is_refused(scene_dir: Path) -> None:
    np.save(scene_dir / "img.npy", np.zeros((4, 4), dtype=np.uint8))
    with pytest.raises(InputError, match="3-D"):
        load_scene(_write(scene_dir, GOOD))


def test_cli_exit_codes_and_json(scene_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = _write(scene_dir, GOOD)
    assert main(["simulate", str(good), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert set(payload) == {"t", "mean_T"} and set(payload["mean_T"]) == {"z0", "z1"}
    assert len(payload["t"]) == 10 and payload["mean_T"]["z0"][-1] > payload["mean_T"]["z1"][-1] > 0
    bad = _write(scene_dir, GOOD.replace("k = 0.3", "k = -1"))
    assert main(["simulate", str(bad)]) == 2
    assert "phases.fibre.k" in capsys.readouterr().err
    assert main(["simulate", str(scene_dir / "nope.toml")]) == 2
    assert main(["simulate", str(good), "--model", "bogus"]) == 2


STEADY_FLUX_ONLY = (GOOD.replace("[boundary.z1]\nh = 20.0\nT_ext = 0.0\n", "")
                    .replace("[time]\nend = 1.0\ndt = 0.1\n", ""))


def test_steady_scene_without_temperature_or_exchange_is_refused_at_load(scene_dir: Path,
                                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """Steady, flux on z0, every other face adiabatic: K has constant fields in its kernel (no solution).

    Refused when the scene is read, naming [boundary] and what is needed, before any assembly."""
    path = _write(scene_dir, STEADY_FLUX_ONLY)
    with pytest.raises(InputError, match=r"\[boundary\]: a steady scene needs .* T or .* h; faces given: z0 \(flux\)"):
        load_scene(path)
    assert main(["simulate", str(path)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "[boundary]" in err and "Traceback" not in err
    adiabatic = STEADY_FLUX_ONLY.replace("[boundary.z0]\nflux = 500.0\n", "[boundary.z0]\nflux = 0.0\n")
    with pytest.raises(InputError, match=r"\[boundary\]"):
        load_scene(_write(scene_dir, adiabatic))


def test_material_scene_loads_for_homogenize_but_is_not_simulated(scene_dir: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """No [boundary], no [outputs], no [time]: a material description (aromm homogenize applies its own faces)."""
    material = STEADY_FLUX_ONLY.replace("[boundary.z0]\nflux = 500.0\n", "").split("[outputs]")[0]
    path = _write(scene_dir, material)
    assert load_scene(path).boundary == ()
    assert main(["homogenize", str(path), "--json"]) == 0
    capsys.readouterr()
    assert main(["simulate", str(path)]) == 2
    assert "[boundary]: a steady scene needs" in capsys.readouterr().err


def test_singular_system_built_in_python_is_a_numerical_failure() -> None:
    """Below the scene checks, the solver still names a singular steady system instead of returning NaN."""
    from aromm.core.errors import NumericalError
    from aromm.core.vocabulary import FaceSpec, PhaseSpec
    from aromm.fem import assemble_voxels
    from aromm.full.solve import steady_field

    system = assemble_voxels(np.ones((3, 3, 3), dtype=np.int32), (1e-3,) * 3, (PhaseSpec("a", 1, 1.0),),
                             [FaceSpec("z0", flux=10.0)])
    with pytest.raises(NumericalError):
        steady_field(system)


def test_time_step_count_beyond_the_limit_is_refused_at_load(scene_dir: Path) -> None:
    text = GOOD.replace("[time]\nend = 1.0\ndt = 0.1\n", "[time]\nend = 1.0e6\ndt = 0.01\n")
    with pytest.raises(InputError, match=r"time: end / dt = .* 1e\+08 time steps, more than the 1e\+07 allowed"):
        load_scene(_write(scene_dir, text))


def test_cli_measure_uses_the_scenario_fluxmetric_k_by_default(scene_dir: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    """[Chavez2020, § 4.2]: k̄ from the scenario itself, so the twin ends at the sample's steady face means;
    eq. 13 with an isothermal S2 (--conductivity flux) gives a larger k̄ along the layers, a smaller drop."""
    labels = np.zeros((4, 4, 4), dtype=np.uint8)
    labels[::2] = 1  # layers normal to x, loaded along z
    np.save(scene_dir / "img.npy", labels)
    path = _write(scene_dir, scenario_1("img.npy", "5.0e-5", "400.0", "4.0"))  # 20 time constants c̄ L / h
    assert main(["simulate", str(path), "--out", str(scene_dir / "sim")]) == 0
    sample = np.loadtxt(scene_dir / "sim" / "observables.csv", delimiter=",", skiprows=1)[-1]
    assert main(["measure", str(path), "--homogeneous", "--out", str(scene_dir / "m.csv")]) == 0
    twin = np.loadtxt(scene_dir / "m.csv", delimiter=",", skiprows=1)[-1]
    np.testing.assert_allclose(twin, sample, rtol=1e-7)
    capsys.readouterr()
    assert main(["measure", str(path), "--homogeneous", "--conductivity", "flux", "--json",
                 "--out", str(scene_dir / "f.csv")]) == 0
    assert json.loads(capsys.readouterr().out)["conductivity"] == "flux"
    eq13 = np.loadtxt(scene_dir / "f.csv", delimiter=",", skiprows=1)[-1]
    assert eq13[1] - eq13[2] < 0.99 * (sample[1] - sample[2])


def test_cli_measure_refuses_a_scene_that_is_not_a_table1_scenario(scene_dir: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    np.save(scene_dir / "img.npy", np.arange(8).reshape(2, 2, 2) % 2)
    path = _write(scene_dir, GOOD.replace("[boundary.z1]\nh = 20.0\nT_ext = 0.0", "[boundary.z1]\nflux = 20.0"))
    assert main(["measure", str(path), "--homogeneous", "--out", str(scene_dir / "m.csv")]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "exactly one" in err and "z0" in err and "z1" in err
    assert not (scene_dir / "m.csv").exists()


def test_cli_measure_of_a_homogeneous_body_equals_its_simulation(scene_dir: Path) -> None:
    """One-phase image: the homogeneous twin is the body itself (k̄ = k, c̄ = c), so both give one curve."""
    np.save(scene_dir / "img.npy", np.ones((4, 4, 4), dtype=np.uint8))
    text = GOOD.replace("[phases.gas]\nlabel = 0\nk = 0.025\nc = 1.2e3\n", "")
    path = _write(scene_dir, text)
    assert main(["measure", str(path), "--homogeneous", "--out", str(scene_dir / "m.csv")]) == 0
    assert main(["simulate", str(path), "--out", str(scene_dir / "sim")]) == 0
    measured = np.loadtxt(scene_dir / "m.csv", delimiter=",", skiprows=1)
    simulated = np.loadtxt(scene_dir / "sim" / "observables.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(measured, simulated, rtol=1e-9)
    assert (scene_dir / "sim" / "field.vtu").is_file()
    assert main(["measure", str(path), "--homogeneous", "--noise", "0.1", "--seed", "3",
                 "--out", str(scene_dir / "n1.csv")]) == 0
    assert main(["measure", str(path), "--homogeneous", "--noise", "0.1", "--seed", "3",
                 "--out", str(scene_dir / "n2.csv")]) == 0
    noisy = np.loadtxt(scene_dir / "n1.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(noisy, np.loadtxt(scene_dir / "n2.csv", delimiter=",", skiprows=1))
    assert 0.02 < np.std(noisy[:, 1:] - measured[:, 1:]) < 0.5
