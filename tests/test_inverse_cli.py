"""``aromm identify``: twin recovery through the command line, JSON shape, plot, checkpoint, exit codes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from inverse_cases import TRUTH, twin_case

from aromm.cli import main
from aromm.full.solve import FullModel
from aromm.scene.scene_file import assemble, load_scene
from inverse.measurements import save_measurements, simulate_measurements


@pytest.fixture
def case(tmp_path: Path) -> tuple[Path, Path]:
    """A 4³ scene and noise-free measurements made by its own full model at the truth."""
    return twin_case(tmp_path)


ARGS = ["--unknown", "fibre.k=0.05:1", "--unknown", "fibre.c=1e5:1e7", "--model", "full", "--particles", "6",
        "--iterations", "5"]


def test_json_output_recovers_the_truth_and_writes_plot_and_checkpoint(
        case: tuple[Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    scene, csv = case
    plot, ck = scene.parent / "fit.png", scene.parent / "run.npz"
    code = main(["identify", str(scene), "--measurements", str(csv), *ARGS, "--json", "--plot", str(plot),
                 "--checkpoint", str(ck)])
    out = capsys.readouterr()
    assert code == 0, out.err
    doc = json.loads(out.out)
    assert list(doc) == ["estimates", "criterion", "evaluations", "seconds", "model", "uncertainty"]
    for name, value in TRUTH.items():
        assert doc["estimates"][name] == pytest.approx(value, rel=1e-3)
    assert doc["model"]["kind"] == "full"
    assert plot.stat().st_size > 10_000 and plot.read_bytes()[:4] == b"\x89PNG"
    assert ck.exists()
    code = main(["identify", str(scene), "--measurements", str(csv), *ARGS, "--json", "--checkpoint", str(ck),
                 "--resume"])
    again = json.loads(capsys.readouterr().out)
    assert code == 0 and again["estimates"] == doc["estimates"]


def test_reduced_model_with_checkpoint_resume(case: tuple[Path, Path], capsys: pytest.CaptureFixture[str],
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """The default model: aromm.reduce at the given order; a resumed run gives the same answer."""
    scene, csv = case
    monkeypatch.setenv("AROMM_CACHE_DIR", str(scene.parent / "cache"))
    ck = scene.parent / "run.npz"
    args = ["identify", str(scene), "--measurements", str(csv), "--unknown", "fibre.k=0.05:1", "--unknown",
            "fibre.c=1e5:1e7", "--order", "8", "--particles", "6", "--iterations", "3", "--json",
            "--checkpoint", str(ck)]
    assert main(args) == 0
    first = json.loads(capsys.readouterr().out)
    assert first["model"]["kind"] == "reduced" and first["model"]["order"] == 8
    assert main([*args, "--resume"]) == 0  # now from the cache: other offline seconds, same problem
    second = json.loads(capsys.readouterr().out)
    assert second["estimates"] == first["estimates"]


def test_table_output(case: tuple[Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    scene, csv = case
    assert main(["identify", str(scene), "--measurements", str(csv), *ARGS]) == 0
    out = capsys.readouterr().out
    assert "fibre.k" in out and "95 % interval" in out and "correlation fibre.k / fibre.c" in out
    assert "95 % HAC interval" in out and "Durbin-Watson" in out


def test_noise_std_and_residual_diagnostics_in_json(case: tuple[Path, Path],
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """Measurements with 0.02 °C noise, stated as 0.001 °C: the residual is ~20 times the stated noise."""
    scene, csv = case
    model = FullModel(assemble(load_scene(scene)))
    save_measurements(simulate_measurements(model, TRUTH, noise=0.02, rng=np.random.default_rng(2)), csv)
    code = main(["identify", str(scene), "--measurements", str(csv), *ARGS, "--json", "--noise-std", "0.001"])
    out = capsys.readouterr()
    assert code == 0, out.err
    unc = json.loads(out.out)["uncertainty"]
    assert unc["noise_std"] == 0.001 and unc["noise_p_value"] < 0.01
    assert set(unc["residuals"]) >= {"lag1_autocorrelation", "durbin_watson", "runs", "runs_p_value", "systematic"}
    assert set(unc["interval95_hac"]) == set(TRUTH) and unc["hac"]["kernel"] == "bartlett"
    assert any("times the stated sensor noise" in w for w in unc["warnings"])
    assert "times the stated sensor noise" in out.err
    assert main(["identify", str(scene), "--measurements", str(csv), *ARGS, "--noise-std", "-1"]) == 2
    assert "--noise-std" in capsys.readouterr().err


@pytest.mark.parametrize(("extra", "needle"), [
    (["--unknown", "fibre.k=0.05-1"], "NAME=LOW:HIGH"),
    (["--unknown", "fibre.k=1:0.05"], "LOW < HIGH"),
    (["--unknown", "fibre.q=0:1"], "'fibre.q' is not a parameter"),
    (["--unknown", "fibre.k=0.05:1", "--resume"], "--resume needs --checkpoint"),
])
def test_bad_arguments_exit_2(case: tuple[Path, Path], capsys: pytest.CaptureFixture[str], extra: list[str],
                              needle: str) -> None:
    scene, csv = case
    code = main(["identify", str(scene), "--measurements", str(csv), "--model", "full", "--particles", "4",
                 "--iterations", "1", *extra])
    assert code == 2
    assert needle in capsys.readouterr().err


def test_measurement_file_with_unknown_face_exits_2(case: tuple[Path, Path],
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    scene, csv = case
    csv.write_text("t,x0\n1,2\n", encoding="utf-8")
    code = main(["identify", str(scene), "--measurements", str(csv), *ARGS])
    assert code == 2
    err = capsys.readouterr().err
    assert str(csv) in err and "'x0'" in err and "allowed: z0, z1" in err
