"""Nuisance parameters (issue 14 item 3): h, T_ext, initial T, a flux scale and a clock offset as unknowns of
an identification with the reduced model, checked on the layered body whose 1-D reference is independent
(tests/layered.py)."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from layered import BREAKS, DZ, LAYERS, PROPS, PULSE, RAMP, T0, TIMES, H, layered_reference, layered_system
from scene_text import scenario_1
from slab1d import Slab, solve

from aromm.cli import main
from aromm.core.clock import TIME_OFFSET, TimeShifted
from aromm.core.errors import InputError
from aromm.core.observables import Observables, write_csv
from aromm.full.solve import FullModel
from aromm.reduction.offline import reduce
from aromm.scene.scene_file import assemble, load_scene
from inverse.identification import identify
from inverse.uncertainty import IdentifiabilityWarning

TRUTH = {"fibre.k": PROPS[1][0], "fibre.c": PROPS[1][1], "z1.h": H}
BOUNDS = {"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7), "z1.h": (10.0, 40.0)}


def _table(t: np.ndarray, y: np.ndarray) -> Observables:
    return Observables(t, {"z0": y[:, 0], "z1": y[:, 1]})


def test_time_shifted_model_is_the_model_at_shifted_times() -> None:
    """Ŷ(t; δ) = Y(max(t + δ, 0)): per parameter set, through the full and the reduced model; before t = 0
    the body is at its initial state."""
    full = FullModel(layered_system(0.05))
    shifted = TimeShifted(full)
    assert shifted.parameter_names == full.parameter_names | {TIME_OFFSET}
    t = np.array([0.0, 0.1, 0.5, 2.0])
    y = shifted.simulate_batch({"fibre.k": [0.3, 0.2, 0.3], TIME_OFFSET: [0.3, 0.3, -0.25]}, t)
    np.testing.assert_array_equal(y[0], full.simulate({"fibre.k": 0.3}, t + 0.3).as_array())
    np.testing.assert_array_equal(y[1], full.simulate({"fibre.k": 0.2}, t + 0.3).as_array())
    late = full.simulate({"fibre.k": 0.3}, [0.25, 1.75]).as_array()
    np.testing.assert_allclose(y[2], np.vstack([np.full((2, 2), T0), late]), rtol=1e-15)
    with pytest.raises(InputError, match="already"):
        TimeShifted(shifted)


def test_reduced_model_stays_accurate_as_h_varies_30_percent() -> None:
    """The bases are built at the scene's h; the reduced model's error against the exact 1-D solution at
    0.7 h and 1.3 h stays that at h (measured at order 10: 5.1e-4, 6.8e-4, 8.2e-4 °C), so no h samples are
    needed in the correction vectors (benchmarks/real_experiments.py: the same on a wood image)."""
    rom = reduce(layered_system(), order=10, cache=False)
    errors = [np.abs(rom.simulate({"z1.h": f * H}, TIMES).as_array() - layered_reference({"z1.h": f * H})).max()
              for f in (0.7, 1.0, 1.3)]
    assert max(errors) < 1.5 * errors[1] and max(errors) < 2e-3, errors


def test_identification_recovers_h_and_a_clock_offset_with_the_properties() -> None:
    """Data: the exact 1-D solution read by a clock 0.2 s late.  k_F, c_F, h and δ are recovered to the
    reduced model's error (measured: 1e-6 relative, 1e-7 s); the uncertainty names the offset and gives its
    correlations with k_F, c_F and h."""
    delta = 0.2
    data = _table(TIMES[:-3], layered_reference(times=TIMES[:-3] + delta))
    rom = reduce(layered_system(), order=20, cache=False)
    with warnings.catch_warnings():
        # no identifiability warning for the offset (relative scale: its bounds); the residuals of a reduced model
        # fitted to exact 1-D data are systematic, and saying so (ResidualWarning) is right
        warnings.simplefilter("error", IdentifiabilityWarning)
        result = identify(rom, data, {**BOUNDS, TIME_OFFSET: (-0.5, 0.5)}, seed=0, particles=12, iterations=10)
    for name, value in TRUTH.items():
        assert result.estimates[name] == pytest.approx(value, rel=1e-4), name
    assert result.estimates[TIME_OFFSET] == pytest.approx(delta, abs=1e-4)
    corr = result.uncertainty.to_json()["correlation"]
    assert isinstance(corr, dict)
    row = corr[TIME_OFFSET]
    assert set(row) == {*TRUTH, TIME_OFFSET} and all(abs(v) <= 1.0 for v in row.values())
    assert row[TIME_OFFSET] == pytest.approx(1.0)


def test_identification_from_finer_data_is_biased_by_the_discretisation_error_only() -> None:
    """Data from the 1-D model with 4 nodes per layer (the voxel model's spatial error in the outputs is
    3.5e-4 °C): the estimates move from the truth by the least-squares image of that output error
    (X⁺ Δy, sensitivities of the reduced model), within a tenth of it: they are right to within the
    discretisation error (measured biases: k_F −0.12 %, c_F −0.008 %, h +0.024 %)."""
    lay = np.repeat(LAYERS, 4)
    fine = solve(Slab(np.where(lay == 1, TRUTH["fibre.k"], PROPS[0][0]), np.where(lay == 1, TRUTH["fibre.c"],
                                                                                   PROPS[0][1]), DZ / 4),
                 TIMES, flux=lambda t: float(PULSE(t)), h=H, t_ext=lambda t: float(RAMP(t)), initial=T0,
                 breaks=BREAKS)[:, [0, -1]]
    rom = reduce(layered_system(), order=20, cache=False)
    result = identify(rom, _table(TIMES, fine), BOUNDS, seed=0, particles=12, iterations=10)
    base = rom.simulate(TRUTH, TIMES).as_array()
    columns = []
    for name, value in TRUTH.items():
        step = 1e-4 * value
        up, down = (rom.simulate({**TRUTH, name: value + s}, TIMES).as_array() for s in (step, -step))
        columns.append(((up - down) / (2 * step)).ravel())
    predicted = np.linalg.lstsq(np.array(columns).T, (fine - base).ravel(), rcond=None)[0]
    for (name, value), bias in zip(TRUTH.items(), predicted, strict=True):
        actual = result.estimates[name] - value
        assert abs(actual - bias) < 0.1 * abs(bias) + 1e-6 * value, (name, actual, bias)
        assert abs(actual) < 0.01 * value


def test_nuisance_scene_parameters_are_unknowns_of_the_reduced_model() -> None:
    """Every scene number that is a parameter (h, T_ext and flux scales, initial T) can be estimated with the
    reduced model; here all at once from its own data (an exact twin: recovered to the optimiser's tolerance)."""
    rom = reduce(layered_system(), order=20, cache=False)
    truth = {"z1.h": 25.0, "z1.T_ext": 1.5, "z0.flux": 0.9, "initial.T": 2.0, "fibre.k": 0.3}
    data = _table(TIMES, rom.simulate(truth, TIMES).as_array())
    bounds = {"z1.h": (10.0, 40.0), "z1.T_ext": (0.0, 3.0), "z0.flux": (0.5, 1.5), "initial.T": (-5.0, 5.0),
              "fibre.k": (0.05, 1.0)}
    result = identify(rom, data, bounds, seed=0, particles=16, iterations=15)
    for name, value in truth.items():
        assert result.estimates[name] == pytest.approx(value, rel=1e-4, abs=1e-5), name


def test_cli_identifies_h_and_the_offset_on_a_pulse_scene(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    """`aromm identify --unknown z1.h=... --unknown time_offset=...` on a scene whose flux is a CSV pulse."""
    monkeypatch.setenv("AROMM_CACHE_DIR", str(tmp_path / "cache"))
    labels = np.zeros((3, 3, 4), dtype=np.uint8)
    labels[:, :, ::2] = 1
    np.save(tmp_path / "img.npy", labels)
    (tmp_path / "pulse.csv").write_text("t,flux\n0,0\n0.5,500\n3,500\n3.5,0\n")
    scene = tmp_path / "scene.toml"
    scene.write_text(scenario_1("img.npy", "5.0e-5", "30.0", "0.5").replace("flux = 500.0", 'flux = "pulse.csv"'))
    rom = reduce(assemble(load_scene(scene)), order=20, cache=False)
    t = np.arange(1.0, 25.0, 0.5)
    write_csv(Observables(t, dict(zip(rom.outputs, rom.simulate({"z1.h": 28.0}, t + 0.3).as_array().T,
                                      strict=True))), tmp_path / "m.csv")
    args = ["identify", str(scene), "--measurements", str(tmp_path / "m.csv"), "--order", "20", "--json",
            "--unknown", "fibre.k=0.05:1", "--unknown", "z1.h=10:40", "--unknown", "time_offset=-0.5:0.5",
            "--particles", "10", "--iterations", "8"]
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["estimates"]["z1.h"] == pytest.approx(28.0, rel=1e-3)
    assert out["estimates"][TIME_OFFSET] == pytest.approx(0.3, abs=1e-3)
    assert set(out["uncertainty"]["correlation"][TIME_OFFSET]) == {"fibre.k", "z1.h", TIME_OFFSET}
