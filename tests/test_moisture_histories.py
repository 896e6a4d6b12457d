"""Histories of the moisture boundary values (a fixed φ, an exterior φ_ext, a moisture flux g) as CSV files in a
scene (aromm.scene.histories, aromm.scene.moisture_section, aromm.physics.hygrothermal): a history that holds one
value gives that constant's outputs, in a fraction or in %RH; a flux history delayed by τ on a body at rest delays
its response by τ exactly (the model is linear and time-invariant, and τ is a whole number of output steps); bad
histories are refused naming their key or file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_hygrothermal_scene import _scene, far_face, rounding_floor

from aromm.cli import main
from aromm.core.profiles import Profile
from aromm.scene.scene_file import load_scene


def test_a_history_that_holds_one_value_gives_the_constant(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    path = _scene(tmp_path)
    constant = far_face(path, capsys)
    (tmp_path / "phi.csv").write_text("t,phi\ns,%RH\n0,80\n7200,80\n", encoding="utf-8")
    path.write_text(path.read_text(encoding="utf-8").replace("phi = 0.8", 'phi = "phi.csv"'), encoding="utf-8")
    scene = load_scene(path)
    assert scene.parameters["x0.phi"] == 1.0 and isinstance(scene.moisture.fixed_phi["x0"], Profile)
    assert np.abs(far_face(path, capsys) - constant).max() <= rounding_floor(constant)
    exchange = "[boundary.x1]\nh = 8.0\nT_ext = 20.0\nbeta = 2.0e-8\nphi_ext = 0.6\n\n[initial]"
    path.write_text(path.read_text(encoding="utf-8").replace("[initial]", exchange), encoding="utf-8")
    constant = far_face(path, capsys)
    (tmp_path / "air.csv").write_text("t,phi_ext\n0,0.6\n3600,0.6\n", encoding="utf-8")
    path.write_text(path.read_text(encoding="utf-8").replace("phi_ext = 0.6", 'phi_ext = "air.csv"'),
                    encoding="utf-8")
    assert load_scene(path).parameters["x1.phi_ext"] == 1.0
    assert np.abs(far_face(path, capsys) - constant).max() <= rounding_floor(constant)


def test_a_delayed_moisture_flux_delays_the_response(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """At rest (T and φ of x0 equal to the initial state), g ramps to 2e-7 kg/(m² s) in 1200 s on x1, then holds;
    delayed by 1800 s (three output steps), the outputs are the first ones shifted by three steps, and at rest
    before (a wrong time base, or a history read as a constant, would move them).  Backward Euler, whose steps are
    all alike (BDF2 starts with one Euler step: its first steps differ from the later ones by its time error)."""
    path = _scene(tmp_path)
    text = path.read_text(encoding="utf-8").replace("phi = 0.8", "phi = 0.5")
    path.write_text(text.replace("[initial]", '[boundary.x1]\ng = "g.csv"\n\n[initial]'), encoding="utf-8")
    (tmp_path / "g.csv").write_text("t,g\ns,kg/(m2 s)\n0,0\n1200,2e-7\n", encoding="utf-8")
    first = far_face(path, capsys, "--scheme", "euler")
    (tmp_path / "g.csv").write_text("t,g\ns,kg/(m2 s)\n0,0\n1800,0\n3000,2e-7\n", encoding="utf-8")
    delayed = far_face(path, capsys, "--scheme", "euler")
    rest = np.array([[20.0], [0.5]])
    assert np.abs(first[:, -1:] - rest).max() > 1e-3  # the flux moves the far face
    assert np.abs(delayed[:, :3] - rest).max() <= rounding_floor(first)  # the outputs at 600, 1200 and 1800 s
    assert np.abs(delayed[:, 3:] - first[:, :-3]).max() <= rounding_floor(first)


def test_bad_moisture_histories_are_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _scene(tmp_path)
    original = path.read_text(encoding="utf-8")
    (tmp_path / "phi.csv").write_text("t,phi\n0,0.8\n600,1.04\n", encoding="utf-8")
    path.write_text(original.replace("phi = 0.8", 'phi = "phi.csv"'), encoding="utf-8")
    assert main(["simulate", str(path), "--json"]) == 2
    assert "boundary.x0.phi" in capsys.readouterr().err
    (tmp_path / "g.csv").write_text("t,g\ns,W/m2\n0,0\n600,1\n", encoding="utf-8")
    path.write_text(original.replace("[initial]", '[boundary.x1]\ng = "g.csv"\n\n[initial]'), encoding="utf-8")
    assert main(["simulate", str(path), "--json"]) == 2
    assert "unit 'W/m2' for a moisture flux history" in capsys.readouterr().err
    path.write_text(original.replace("phi = 0.8", 'phi = "nowhere.csv"'), encoding="utf-8")
    assert main(["simulate", str(path), "--json"]) == 2
    assert "boundary.x0.phi: history file not found" in capsys.readouterr().err
    steady = original[:original.index("[time]")] + '[outputs]\nmean_T = ["x1"]\nmean_phi = ["x1"]\n'
    (tmp_path / "phi.csv").write_text("t,phi\n0,0.8\n600,0.9\n", encoding="utf-8")
    path.write_text(steady.replace("phi = 0.8", 'phi = "phi.csv"'), encoding="utf-8")
    assert main(["simulate", str(path), "--json"]) == 2
    assert "a moisture history (CSV file) needs a transient scene" in capsys.readouterr().err


def test_a_moisture_history_enters_the_model_key(tmp_path: Path) -> None:
    """Its parameter is the scale 1 whatever it holds: the key must hold the history itself (issue 35's rule: every
    input that changes the outputs changes the key), as it does a thermal face's.  Failed before 2026-12-05's review:
    two histories of one scale shared a key, so a cached model answered for the other."""
    from aromm.reduction.model_key import scene_physics_key

    keys = []
    for name, humidity in (("a", "0.8"), ("b", "0.9")):
        folder = tmp_path / name
        folder.mkdir()
        path = _scene(folder)
        (folder / "phi.csv").write_text(f"t,phi\n0,0.5\n600,{humidity}\n", encoding="utf-8")
        path.write_text(path.read_text(encoding="utf-8").replace("phi = 0.8", 'phi = "phi.csv"'), encoding="utf-8")
        keys.append(scene_physics_key(load_scene(path)))
    assert keys[1] != keys[0]
