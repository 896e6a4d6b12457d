"""Identification from temperatures and relative humidities together (inverse.kinds, issue 39): the coupled slab of
tests/test_hygrothermal_scene.py measured at its far face (exact full model, Gaussian noise of another size per
kind, the humidity logged in %RH), identified from the command line; and the reading of humidity columns."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_hygrothermal_scene import _scene

from aromm.cli import main
from aromm.core.errors import InputError
from aromm.core.labcsv import read_lab_csv
from aromm.full.exact import exact_outputs
from aromm.reduction.lifting import lift
from aromm.scene.scene_file import assemble, load_scene

TRUTH = {"board.xi": 20.0, "board.delta_p": 2.0e-11}
NOISE = {"T": 0.01, "phi": 0.002}  # °C, and relative humidity (0.2 %RH)


def _measured(path: Path, out: Path, seed: int) -> None:
    """The scene's far-face T and φ at its output times (exact in time), noise added, φ written in %RH."""
    system = lift(assemble(load_scene(path)))
    assert system.time is not None
    t = system.time.times
    y = exact_outputs(system, TRUTH, t)
    names = list(system.observation)
    rng = np.random.default_rng(seed)
    t_col, phi_col = names.index("x1"), names.index("phi:x1")
    temperature = y[:, t_col] + NOISE["T"] * rng.standard_normal(t.size)
    humidity = 100 * (y[:, phi_col] + NOISE["phi"] * rng.standard_normal(t.size))
    rows = "\n".join(f"{ti:.17g},{a:.17g},{b:.17g}" for ti, a, b in zip(t, temperature, humidity, strict=True))
    out.write_text(f"t,x1,phi:x1\ns,°C,%RH\n{rows}\n", encoding="utf-8")


@pytest.mark.filterwarnings("ignore::aromm.core.errors.ModelWarning")
def test_identify_from_temperature_and_humidity_covers_the_truth(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """A 42 h humidity step (the far face's φ moves within it; 50 samples per kind).  Each kind is weighted by its
    own noise, estimated from its residuals: the 95 % intervals hold the truth, and the noise found per kind is
    within a factor 1.5 of the noise put in (for an RMS of 50 samples, outside with probability 2.3e-4: χ²₅₀).
    With this seed the unweighted fit (one pooled variance, the temperatures deciding) gives board.xi 19.82
    [19.71, 19.93], which misses the truth; weighted 19.92 [19.80, 20.04] (measured 2026-12-05)."""
    monkeypatch.setenv("AROMM_CACHE_DIR", str(tmp_path / "cache"))
    path = _scene(tmp_path)
    text = path.read_text(encoding="utf-8").replace("dt = 600.0", "dt = 3000.0").replace("end = 7200.0",
                                                                                         "end = 150000.0")
    text = text.replace('bounds = { "board.xi" = [10.0, 40.0] }',
                        'bounds = { "board.xi" = [10.0, 40.0], "board.delta_p" = [1.0e-11, 4.0e-11] }')
    path.write_text(text, encoding="utf-8")
    _measured(path, tmp_path / "m.csv", seed=5)
    assert main(["identify", str(path), "--measurements", str(tmp_path / "m.csv"), "--unknown", "board.xi=10:40",
                 "--unknown", "board.delta_p=1e-11:4e-11", "--particles", "12", "--iterations", "15",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    noise = out["model"]["noise_by_kind"]
    for kind, sigma in NOISE.items():
        assert sigma / 1.5 <= noise[kind] <= 1.5 * sigma, (kind, noise)
    intervals = out["uncertainty"]["interval95_total"]
    for name, value in TRUTH.items():
        lo, hi = intervals[name]
        assert lo <= value <= hi, (name, lo, hi, out["estimates"][name])


def test_humidity_columns_are_read_as_fractions(tmp_path: Path) -> None:
    f = tmp_path / "rh.csv"
    f.write_text("t,x1,phi:x1\ns,K,%RH\n0,293.15,50\n60,293.25,55.5\n", encoding="utf-8")
    lab = read_lab_csv(f, ["x1", "phi:x1"])
    assert lab.table.mean_T["phi:x1"].tolist() == [0.5, 0.555]  # %RH → fraction, not a temperature
    assert np.allclose(lab.table.mean_T["x1"], [20.0, 20.1])  # the temperature column alone is converted
    f.write_text("t,x1,phi:x1\n0,20,50\n60,20.1,55\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"column 'phi:x1': relative humidity 50 .*%RH in the units row"):
        read_lab_csv(f, ["x1", "phi:x1"])
    f.write_text("t,x1,phi:x1\ns,°C,g/kg\n0,20,5\n60,20.1,5\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"unit 'g/kg' for a relative humidity; allowed"):
        read_lab_csv(f, ["x1", "phi:x1"])
