"""``aromm dem ...``: JSON shapes of docs/design.md and exit codes (run on the dem group itself)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from aromm.cli.common import run_guarded
from aromm.cli.dem import dem


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = run_guarded(dem, list(argv))  # type: ignore[arg-type]
    out = capsys.readouterr()
    return code, out.out, out.err


def test_calibrate_json(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _run(capsys, "calibrate", "--particles", "800", "--seed", "1", "--json")
    assert code == 0
    data = json.loads(out)
    assert 0.6 < data["C_t"] < 0.95 and data["Z"] == pytest.approx(7.5, abs=0.02)


def test_pack_then_homogenize_and_simulate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "p.npz"
    code, out, _ = _run(capsys, "pack", "--particles", "800", "--seed", "2", "--out", str(path), "--json")
    assert code == 0 and json.loads(out)["phi"] == pytest.approx(0.64)
    code, out, _ = _run(capsys, "homogenize", "--packing", str(path), "--ratio", "5", "--json")
    assert code == 0
    e = json.loads(out)["E"]
    assert 1.0 < e < 1.0 + 0.1551 * 4  # between 1 and the parallel bound
    code, out, _ = _run(capsys, "simulate", "--packing", str(path), "--times", "0.05,0.2", "--bins", "4", "--json")
    assert code == 0
    data = json.loads(out)
    assert data["t"] == [0.05, 0.2] and set(data["mean_T"]) == {f"y_slab{k}" for k in range(4)}
    assert data["mean_T"]["y_slab3"][1] > data["mean_T"]["y_slab0"][1]  # heated from y = L


def test_bad_inputs_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run(capsys, "homogenize", "--packing", str(tmp_path / "none.npz"), "--ratio", "2")
    assert code == 2 and "does not exist" in err
    path = tmp_path / "p.npz"
    _run(capsys, "pack", "--particles", "300", "--out", str(path))
    code, _, err = _run(capsys, "simulate", "--packing", str(path), "--dt", "1", "--times", "0.1")
    assert code == 2 and "stability limit" in err
