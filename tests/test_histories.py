"""Load histories (issue 14 item 1): CSV profiles in scenes, the full model at its step times, the reduced
model integrated exactly; checked against an independent 1-D solution of a layered body (tests/slab1d.py)."""

from __future__ import annotations

import json
from pathlib import Path

import mpmath
import numpy as np
import pytest
import scipy.linalg as sla
from hypothesis import given
from hypothesis import strategies as st
from layered import TIMES, H, layered_reference, layered_system
from scene_text import scenario_1

from aromm.cli import main
from aromm.core.errors import InputError
from aromm.core.profiles import Profile
from aromm.core.vocabulary import FaceSpec
from aromm.full.solve import transient
from aromm.reduction.modal_integration import phi1, phi2, propagate
from aromm.reduction.offline import reduce
from aromm.reduction.rom import from_arrays, to_arrays
from aromm.scene.scene_file import assemble, load_scene

# ----------------------------------------------------------------------------- profiles and φ functions

def test_profile_is_linear_between_rows_and_held_outside() -> None:
    g = Profile((1.0, 2.0, 4.0), (3.0, 5.0, -1.0))
    np.testing.assert_allclose(g(np.array([0.0, 1.0, 1.5, 3.0, 4.0, 100.0])), [3.0, 3.0, 4.0, 2.0, -1.0, -1.0])
    d = g.derivative()
    np.testing.assert_allclose(d(np.array([0.5, 1.5, 2.5, 5.0])), [0.0, 2.0, -3.0, 0.0])
    assert d.limits(np.array(1.0), np.array(2.0)) == (2.0, 2.0)
    assert not g.is_constant and Profile((0.0, 5.0), (2.0, 2.0)).is_constant
    for times, values in (((0.0, 0.0), (1.0, 2.0)), ((-1.0,), (1.0,)), ((0.0,), (np.nan,)), ((), ())):
        with pytest.raises(InputError):
            Profile(times, values)


@given(st.one_of(st.floats(0.0, 1e-6), st.floats(0.0, 1.0), st.floats(0.0, 800.0)))
def test_phi_functions_match_high_precision(x: float) -> None:
    """φ1, φ2 against 50-digit arithmetic, through the series branch, the switch and the large-x limit."""
    with mpmath.workdps(50):
        xm = mpmath.mpf(x)
        if x < 1e-3:  # the Taylor series to 40 terms (the closed forms would cancel even in 50 digits)
            exact1 = sum((-xm) ** k / mpmath.factorial(k + 1) for k in range(40))
            exact2 = sum((-xm) ** k / mpmath.factorial(k + 2) for k in range(40))
        else:
            exact1 = -mpmath.expm1(-xm) / xm
            exact2 = (xm + mpmath.expm1(-xm)) / xm**2
    assert phi1(np.array(x)) == pytest.approx(float(exact1), rel=1e-14)
    assert phi2(np.array(x)) == pytest.approx(float(exact2), rel=1e-13)


def test_propagation_equals_the_augmented_matrix_exponential() -> None:
    """Ẏ = −ΛY + b0 + b1 s exactly, for rates from 0 to large (Van Loan's augmented expm as the truth)."""
    rng = np.random.default_rng(1)
    rates = np.array([[0.0, 1e-12, 1e-5, 0.3, 7.0, 300.0]])
    y, b0, b1 = (rng.standard_normal(rates.shape) for _ in range(3))
    s = np.array([0.0, 1e-3, 0.2, 1.5])
    got = propagate(rates, y, b0, b1, s)
    for j, lam in enumerate(rates[0]):
        g = np.array([[-lam, b0[0, j], b1[0, j]], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        want = [(sla.expm(g * si) @ [y[0, j], 1.0, 0.0])[0] for si in s]
        np.testing.assert_allclose(got[0, j], want, rtol=1e-12, atol=1e-14)


# ----------------------------------------------------------------------------- scenes

@pytest.fixture
def scene_dir(tmp_path: Path) -> Path:
    labels = np.zeros((4, 4, 4), dtype=np.uint8)
    labels[1:3, 1:3, :] = 1
    np.save(tmp_path / "img.npy", labels)
    (tmp_path / "pulse.csv").write_text("t,flux\n0,0\n0.2,500\n1.5,500\n1.7,0\n")
    return tmp_path


def _scene(folder: Path, old: str = "", new: str = "", end: str = "4.0") -> Path:
    text = scenario_1("img.npy", "1.0e-4", end, "0.1").replace("flux = 500.0", 'flux = "pulse.csv"')
    path = folder / "scene.toml"
    path.write_text(text.replace(old, new, 1) if old else text, encoding="utf-8")
    return path


def test_the_model_key_holds_a_history_by_its_content_not_its_file(scene_dir: Path) -> None:
    """The same history read from another file is the same load (one model serves both); another history is
    another load."""
    from aromm.reduction.model_key import scene_physics_key

    (scene_dir / "copy.csv").write_text((scene_dir / "pulse.csv").read_text())
    (scene_dir / "other.csv").write_text("t,flux\n0,0\n0.2,500\n1.5,500\n1.8,0\n")
    first = scene_physics_key(load_scene(_scene(scene_dir)))
    assert scene_physics_key(load_scene(_scene(scene_dir, "pulse.csv", "copy.csv"))) == first
    assert scene_physics_key(load_scene(_scene(scene_dir, "pulse.csv", "other.csv"))) != first


def test_a_csv_history_loads_as_a_scaled_profile(scene_dir: Path) -> None:
    scene = load_scene(_scene(scene_dir))
    assert scene.parameters["z0.flux"] == 1.0  # the scale of the history
    term = assemble(scene).load["U_z0"]
    assert term.time is not None and term.time.final == 0.0 and float(term.time(np.array(0.1))) == 250.0


@pytest.mark.parametrize(("old", "new", "csv", "needle"), [
    ('flux = "pulse.csv"', 'flux = "nope.csv"', None, "boundary.z0.flux"),
    ("T_ext = 0.0", 'T_ext = "text.csv"', "t,T\n0,1\n0,2\n", "line 3"),
    ("T_ext = 0.0", 'T_ext = "text.csv"', "t,T\n0,1\n1,x\n", "line 3"),
    ("T_ext = 0.0", 'T_ext = "text.csv"', "t,a,b\n0,1,2\n", "t,<value>"),
    ("h = 20.0", 'h = "text.csv"', "t,h\n0,1\n", "boundary.z1.h"),
    ("[time]\nend = 4.0\ndt = 0.1\n", "", None, "[time]"),
])
def test_bad_histories_are_refused_naming_file_and_line(scene_dir: Path, old: str, new: str, csv: str | None,
                                                        needle: str) -> None:
    if csv is not None:
        (scene_dir / "text.csv").write_text(csv)
    path = _scene(scene_dir, old, new)
    with pytest.raises(InputError) as info:
        load_scene(path)
    assert needle in str(info.value) and str(scene_dir) in str(info.value), str(info.value)


def test_cli_simulate_and_measure_run_unchanged_on_a_history_scene(scene_dir: Path, monkeypatch: pytest.MonkeyPatch,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """`aromm measure` (fluxmetric k̄ with the probe flux, history kept by the twin) and `aromm simulate`
    with both models on a pulse: full (BDF2, dt = 0.1 s) and reduced (exact in time) agree to the full
    model's time-step error, which the refined full model shows to be the difference."""
    monkeypatch.setenv("AROMM_CACHE_DIR", str(scene_dir / "cache"))
    path = _scene(scene_dir)
    assert main(["measure", str(path), "--homogeneous", "--out", str(scene_dir / "m.csv")]) == 0
    measured = np.loadtxt(scene_dir / "m.csv", delimiter=",", skiprows=1)
    assert measured.shape == (40, 3) and measured[:, 1].max() > 0.5
    capsys.readouterr()
    curves = {}
    for model in ("full", "reduced"):
        order = ["--order", "30"] if model == "reduced" else []  # --order with --model full is refused
        assert main(["simulate", str(path), "--model", model, *order, "--json"]) == 0
        curves[model] = np.array(list(json.loads(capsys.readouterr().out)["mean_T"].values()))
    fine = load_scene(_scene(scene_dir, "dt = 0.1", "dt = 0.005"))
    exact = transient(assemble(fine), times=np.round(0.1 * np.arange(1, 41), 12)).as_array().T
    step_error = np.abs(curves["full"] - exact).max()
    assert np.abs(curves["reduced"] - exact).max() < 0.2 * step_error


# ----------------------------------------------------------------------------- the models

def test_a_constant_history_is_the_number() -> None:
    """A one-row profile (held) equals a constant load: full model bit for bit, reduced model to round-off."""
    number = layered_system(z0=FaceSpec("z0", flux=500.0), z1=FaceSpec("z1", h=H, T_ext=2.0))
    profile = layered_system(z0=FaceSpec("z0", flux=Profile((3.0,), (500.0,))),
                             z1=FaceSpec("z1", h=H, T_ext=Profile((0.0, 7.0), (2.0, 2.0))))
    scaled = {"z0.flux": 1.0, "z1.T_ext": 1.0}
    np.testing.assert_allclose(transient(profile).as_array(), transient(number).as_array(), rtol=1e-13)
    rom_n, rom_p = (reduce(s, order=20, cache=False) for s in (number, profile))
    t = np.array([0.0, 0.05, 2.0, 3.0, 3.3, 19.7])
    np.testing.assert_allclose(rom_p.simulate(scaled, t).as_array(), rom_n.simulate({}, t).as_array(), atol=1e-10)


def test_reduced_model_is_exact_in_time_against_an_independent_1d_solution() -> None:
    """Layered body = 1-D: the complete reduced basis reproduces the 1-D FE integrated by matrix exponentials
    to round-off (no time step), at times in any order; order 20 to its reduction error (measured 2e-6 °C)."""
    system = layered_system()
    truth = layered_reference()
    complete = reduce(system, order=1000, modes=1000, cache=False)
    order = np.random.default_rng(0).permutation(TIMES.size)
    np.testing.assert_allclose(complete.simulate_batch({}, TIMES[order])[0], truth[order], atol=1e-9)
    rom = reduce(system, order=20, cache=False)
    assert np.abs(rom.simulate(times=TIMES).as_array() - truth).max() < 2e-5
    # the scale of a history is a parameter: the response is affine in it
    lifted = reduce(system, order=20, cache=False).simulate({"z0.flux": 2.0}, TIMES).as_array()
    base = rom.simulate({"z0.flux": 0.0}, TIMES).as_array()
    np.testing.assert_allclose(lifted - base, 2.0 * (rom.simulate(times=TIMES).as_array() - base), atol=1e-9)
    restored = from_arrays(to_arrays(rom))
    np.testing.assert_array_equal(restored.simulate(times=TIMES).as_array(), rom.simulate(times=TIMES).as_array())


def test_full_model_converges_at_second_order_to_the_1d_solution() -> None:
    """BDF2 with the loads at the step times: the error against the exact 1-D solution falls ~4× per halving."""
    truth = layered_reference()
    errors = [np.abs(transient(layered_system(dt), times=TIMES).as_array() - truth).max() for dt in (0.1, 0.05, 0.025)]
    rates = np.log2(np.asarray(errors[:-1]) / np.asarray(errors[1:]))
    assert np.all(rates > 1.5) and rates[-1] > 1.85, (errors, rates)
    assert errors[-1] < 2e-3
