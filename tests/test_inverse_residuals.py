"""Residual diagnostics, HAC intervals, known-noise comparison and the first-time offset check.

Independent truths: the Durbin–Watson/autocorrelation identity, the exact null distribution of the runs count
(enumerated), White's sandwich and a brute-force lag sum for the HAC covariance, seeded coverage frequencies
against binomial bounds, Andrews' bandwidth formula with the true AR(1) coefficient, the 273.15 K offset.
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest
from inverse_cases import PHASES, TRUTH, LinearModel, scenario_model, tracheids
from scipy.signal import lfilter

from aromm.core.system import TimeGrid
from aromm.core.vocabulary import FaceSpec
from aromm.full.solve import FullModel
from aromm.homogenization.properties import fluxmetric, mean_capacity
from aromm.homogenization.synthetic import homogeneous_measurements
from aromm.scene.geometry import VoxelGeometry
from aromm.scene.scene_file import Scene, assemble
from inverse import hac
from inverse.identification import identify
from inverse.measurements import Measurements, simulate_measurements
from inverse.residuals import ALPHA, _runs, diagnose
from inverse.uncertainty import ResidualWarning, linearised

T = np.linspace(0.0, 10.0, 400)
LINE = np.column_stack([np.ones_like(T), T])
BETA = np.array([1.5, -0.4])


def _ar1(rng: np.random.Generator, rho: float, n: int) -> np.ndarray:
    """Stationary AR(1) noise e_i = ρ e_(i-1) + z_i, z_i ~ N(0, 1), e_0 ~ N(0, 1/(1 - ρ²))."""
    z = rng.standard_normal(n)
    z[0] /= np.sqrt(1.0 - rho**2)
    return np.asarray(lfilter([1.0], [1.0, -rho], z))


def _binomial_band(p: float, n: int) -> float:
    """Three binomial standard deviations of a frequency of probability p over n trials."""
    return 3.0 * float(np.sqrt(p * (1.0 - p) / n))


def test_durbin_watson_and_lag1_autocorrelation_satisfy_their_identity() -> None:
    """Σ(r_t − r_{t−1})² = 2Σr² − r_1² − r_n² − 2Σ r_t r_{t−1}: d = 2 − 2ρ̂₁ − (r_1² + r_n²)/Σr²."""
    r = np.random.default_rng(5).standard_normal(57) + np.sin(np.arange(57) / 5.0)
    d = diagnose([r])
    assert d.durbin_watson == pytest.approx(2 - 2 * d.lag1_autocorrelation - (r[0] ** 2 + r[-1] ** 2) / (r @ r),
                                            rel=1e-12)


def test_runs_mean_and_variance_are_the_exact_null_moments() -> None:
    """Every arrangement of 5 positive and 4 negative signs is equally likely under the null: enumerate them."""
    counts = []
    for neg in itertools.combinations(range(9), 4):
        s = np.ones(9)
        s[list(neg)] = -1.0
        counts.append(1 + int(np.count_nonzero(s[1:] != s[:-1])))
    _, mean, var = _runs(np.array([1.0] * 5 + [-1.0] * 4))
    assert mean == pytest.approx(np.mean(counts), rel=1e-12)
    assert var == pytest.approx(np.var(counts), rel=1e-12)


def test_white_noise_is_rarely_called_systematic_and_correlated_noise_always() -> None:
    """Two tests at level ALPHA: white noise flagged in ≤ 2 ALPHA of 500 seeded series (+3 binomial sd)."""
    rng = np.random.default_rng(7)
    n = 500
    white = sum(diagnose([rng.standard_normal(200)]).systematic for _ in range(n)) / n
    assert white <= 2 * ALPHA + _binomial_band(2 * ALPHA, n)
    assert all(diagnose([_ar1(rng, 0.6, 200)]).systematic for _ in range(50))
    smooth = diagnose([1e-3 * np.sin(np.linspace(0, 3, 200)), 1e-3 * np.cos(np.linspace(0, 3, 200))])
    assert smooth.systematic and smooth.durbin_watson < 0.01 and smooth.series == 2


def test_hac_without_lags_is_whites_sandwich() -> None:
    """Window 0: (XᵀX)⁻¹ Xᵀ diag(r²) X (XᵀX)⁻¹ [White1980], written out independently."""
    rng = np.random.default_rng(3)
    r = rng.standard_normal(T.size) * (1 + T)
    g = hac.scores(LINE, r, [np.arange(T.size)[:, None]])
    meat = hac.long_run(g, 0.0)
    np.testing.assert_allclose(meat, LINE.T @ (r[:, None] ** 2 * LINE), rtol=1e-10)


def test_fft_lag_sums_equal_the_direct_double_loop() -> None:
    rng = np.random.default_rng(4)
    g = [rng.standard_normal((37, 3)), rng.standard_normal((20, 3))]
    window = 7.5
    direct = np.zeros((3, 3))
    for b in g:
        for lag in range(b.shape[0]):
            w = max(0.0, 1.0 - lag / window)
            gamma = sum(np.outer(b[t], b[t - lag]) for t in range(lag, b.shape[0]))
            direct += gamma if lag == 0 else w * (gamma + gamma.T)
    np.testing.assert_allclose(hac.long_run(g, window), direct, rtol=1e-10, atol=1e-12)


def test_andrews_bandwidth_matches_the_formula_with_the_true_coefficient() -> None:
    """One AR(1) score of ρ = 0.5 over 20 000 times: S_T → 1.1447 (4ρ²/((1−ρ)²(1+ρ)²) T)^{1/3} [Andrews1991].

    ρ̂ has sd ≈ √((1−ρ²)/T) = 0.006, which moves S_T by < 3 %.
    """
    rho, n = 0.5, 20_000
    g = [_ar1(np.random.default_rng(8), rho, n)[:, None]]
    expected = 1.1447 * (4 * rho**2 / ((1 - rho) ** 2 * (1 + rho) ** 2) * n) ** (1 / 3)
    assert hac.bandwidth(g) == pytest.approx(expected, rel=0.03)


def test_hac_intervals_recover_coverage_lost_to_correlated_noise() -> None:
    """AR(1) noise (ρ = 0.5, 400 times), 300 seeded fits of a straight line.

    The white-noise interval covers far less than 95 % (measured 0.68–0.73); HAC with Andrews' bandwidth
    comes back to ~0.88 (Newey–West is known to under-cover in finite samples [Andrews1991, § 9]).
    The bounds are 3 binomial sd around those frequencies; every fit is flagged as systematic.
    """
    rng = np.random.default_rng(1)
    truth = BETA
    n = 300
    white = np.zeros(2)
    robust = np.zeros(2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResidualWarning)
        for _ in range(n):
            y = LINE @ BETA + 0.3 * _ar1(rng, 0.5, T.size)
            b = np.linalg.lstsq(LINE, y, rcond=None)[0]
            unc = linearised(("a", "b"), b, LINE, y - LINE @ b)
            assert unc.residuals.systematic
            white += (unc.lower <= truth) & (truth <= unc.upper)
            robust += (unc.lower_hac <= truth) & (truth <= unc.upper_hac)
    assert np.all(white / n < 0.75 + _binomial_band(0.75, n))
    assert np.all(robust / n > 0.85 - _binomial_band(0.85, n))


def test_white_noise_identification_covers_the_truth_95_percent_of_the_time() -> None:
    """200 seeded identifications (PSO + refinement) on white noise: both intervals cover 95 % ± 3 binomial sd.

    Residual warnings (false alarms, two tests at ALPHA) stay within 2 ALPHA + 3 binomial sd.
    """
    model = LinearModel(LINE[::8], ("a", "b"))
    rng = np.random.default_rng(2024)
    truth = BETA
    n = 200
    hits = np.zeros(2)
    hits_hac = np.zeros(2)
    alarms = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResidualWarning)
        for _ in range(n):
            y = model.design @ BETA + 0.3 * rng.standard_normal(model.design.shape[0])
            unc = identify(model, Measurements(model.default_times, {"a": y}),
                           {"a": (-10.0, 10.0), "b": (-5.0, 5.0)}, particles=6, iterations=4).uncertainty
            hits += (unc.lower <= truth) & (truth <= unc.upper)
            hits_hac += (unc.lower_hac <= truth) & (truth <= unc.upper_hac)
            alarms += unc.residuals.systematic
    band = _binomial_band(0.95, n)
    assert np.all(np.abs(hits / n - 0.95) < band), hits / n
    assert np.all(np.abs(hits_hac / n - 0.95) < band + 0.02), hits_hac / n  # HAC: also estimates its window
    assert alarms / n <= 2 * ALPHA + _binomial_band(2 * ALPHA, n)


def _twin_scene() -> Scene:
    """[Chavez2020] scenario 1 on a 6³ tracheid image (the full model is the reference, no reduction)."""
    n = 6
    return Scene(VoxelGeometry(tracheids(n), (231e-6 / n,) * 3), PHASES,
                 (FaceSpec("z0", flux=500.0), FaceSpec("z1", h=20.0)), 0.0, TimeGrid(40.0, 1.0), ("z0", "z1"))


def test_noise_free_homogeneous_twin_data_is_covered_or_warned() -> None:
    """[Chavez2020, § 4.2] data (homogeneous twin, k̄ from the scenario, c̄ eq. 14): the interval covers the truth or a
    residual warning says it reflects noise only.  The residuals are model error, smooth: Durbin–Watson ≪ 2."""
    scene = _twin_scene()
    data = homogeneous_measurements(scene, fluxmetric(scene).k, mean_capacity(scene))
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        unc = identify(FullModel(assemble(scene)), data, {"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)},
                       particles=8, iterations=6).uncertainty
    truth = np.array([TRUTH["fibre.k"], TRUTH["fibre.c"]])
    covered = bool(np.all((unc.lower <= truth) & (truth <= unc.upper)))
    warned = any("reflects the noise only" in w for w in unc.warnings)
    assert covered or warned, (unc.lower, unc.upper)
    assert unc.residuals.durbin_watson < 0.5 and unc.residuals.systematic


def test_known_noise_is_compared_with_the_residual() -> None:
    model = scenario_model("z", n=4, end=40.0, dt=2.0)
    y = simulate_measurements(model, TRUTH, noise=0.02, rng=np.random.default_rng(0))
    bounds = {"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)}
    right = identify(model, y, bounds, particles=8, iterations=6, noise_std=0.02).uncertainty
    assert not any("sensor noise" in w for w in right.warnings) and right.noise_p_value > 0.01
    with pytest.warns(ResidualWarning, match=r"times the stated sensor noise"):
        low = identify(model, y, bounds, particles=8, iterations=6, noise_std=0.002).uncertainty
    assert low.to_json()["noise_std"] == 0.002
    with pytest.warns(ResidualWarning, match=r"below the stated sensor noise"):
        identify(model, y, bounds, particles=8, iterations=6, noise_std=0.2)


@pytest.mark.parametrize(("offset", "needle"), [(273.15, "kelvin with a scene in °C"),
                                                (-273.15, "°C with a scene in kelvin"),
                                                (-100.0, "[initial] T"), (0.0, None)])
def test_data_offset_from_the_initial_temperature_is_named(offset: float, needle: str | None) -> None:
    model = scenario_model("z", n=4, end=40.0, dt=2.0)
    y = simulate_measurements(model, TRUTH, noise=0.02, rng=np.random.default_rng(1))
    shifted = Measurements(y.t, {f: v + offset for f, v in y.values.items()})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = identify(model, shifted, {"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)}, particles=8, iterations=6)
    named = [w for w in res.uncertainty.warnings if "first measured temperatures" in w]
    if needle is None:
        assert not named
    else:
        assert len(named) == 1 and needle in named[0], named
        assert [w.category for w in caught if "first measured" in str(w.message)] == [ResidualWarning]
