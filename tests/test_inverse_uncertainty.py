"""Linearised uncertainty: exact least-squares intervals on a linear model, coverage, identifiability warnings."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.stats as st
from inverse_cases import LinearModel, scenario_model

from inverse.identification import identify
from inverse.measurements import Measurements, simulate_measurements
from inverse.uncertainty import IdentifiabilityWarning, bias_shift, linearised

T = np.linspace(0.0, 10.0, 25)
LINE = np.column_stack([np.ones_like(T), T])  # y = a + b t


def _noisy_line(rng: np.random.Generator, sigma: float = 0.3) -> np.ndarray:
    return LINE @ np.array([1.5, -0.4]) + sigma * rng.standard_normal(T.size)


def test_intervals_equal_the_textbook_straight_line_ones() -> None:
    """scipy.stats.linregress (independent code) gives slope/intercept and their standard errors."""
    y = _noisy_line(np.random.default_rng(0))
    fit = st.linregress(T, y)
    beta = np.array([fit.intercept, fit.slope])
    unc = linearised(("a", "b"), beta, LINE, y - LINE @ beta)
    np.testing.assert_allclose(unc.std_error, [fit.intercept_stderr, fit.stderr], rtol=1e-10)
    tq = st.t.ppf(0.975, T.size - 2)
    np.testing.assert_allclose(unc.upper - unc.lower, 2 * tq * np.array([fit.intercept_stderr, fit.stderr]),
                               rtol=1e-10)
    # correlation of intercept and slope: -mean(t) / sqrt(mean(t²))
    assert unc.correlation[0, 1] == pytest.approx(-T.mean() / np.sqrt(np.mean(T**2)), rel=1e-10)
    assert unc.warnings == ()


def test_identify_on_a_linear_model_reports_the_exact_least_squares_intervals() -> None:
    y = _noisy_line(np.random.default_rng(1))
    model = LinearModel(LINE, ("a", "b"))
    res = identify(model, Measurements(model.default_times, {"a": y}), {"a": (-10.0, 10.0), "b": (-5.0, 5.0)},
                   particles=10, iterations=10)
    fit = st.linregress(T, y)
    assert res.estimates["a"] == pytest.approx(fit.intercept, abs=1e-9)
    assert res.estimates["b"] == pytest.approx(fit.slope, abs=1e-9)
    np.testing.assert_allclose(res.uncertainty.std_error, [fit.intercept_stderr, fit.stderr], rtol=1e-6)
    assert res.criterion == pytest.approx(0.5 * np.sum((y - fit.intercept - fit.slope * T) ** 2), rel=1e-9)


def test_95_percent_intervals_cover_the_truth_95_percent_of_the_time() -> None:
    """400 seeded noisy fits: coverage within 3 binomial standard deviations (±3.3 %) of 95 %."""
    rng = np.random.default_rng(2024)
    truth = np.array([1.5, -0.4])
    hits = np.zeros(2)
    n = 400
    for _ in range(n):
        y = _noisy_line(rng)
        beta = np.linalg.lstsq(LINE, y, rcond=None)[0]
        unc = linearised(("a", "b"), beta, LINE, y - LINE @ beta)
        hits += (unc.lower <= truth) & (truth <= unc.upper)
    tol = 3 * np.sqrt(0.95 * 0.05 / n)
    assert np.all(np.abs(hits / n - 0.95) < tol), hits / n


def test_a_parameter_without_effect_is_flagged_and_gets_infinite_error() -> None:
    x = np.column_stack([LINE, np.zeros(T.size)])
    y = _noisy_line(np.random.default_rng(3))
    beta = np.array([1.5, -0.4, 2.0])
    with pytest.warns(IdentifiabilityWarning, match="c has no effect"):
        unc = linearised(("a", "b", "c"), beta, x, y - LINE @ beta[:2])
    assert np.isinf(unc.std_error[2]) and np.all(np.isfinite(unc.std_error[:2]))
    assert unc.to_json()["std_error"]["c"] is None  # JSON has no inf: null


def test_collinear_parameters_are_flagged() -> None:
    x = np.column_stack([T, 2.0 * T])
    with pytest.warns(IdentifiabilityWarning, match="hardly separate"):
        unc = linearised(("a", "b"), np.array([1.0, 1.0]), x, np.ones(T.size))
    assert np.all(np.isinf(unc.std_error))


def test_steady_data_cannot_identify_the_fibre_capacity() -> None:
    """Measurements at steady state carry no information on c_F.

    From t = 2000 s on, even the slowest model in the bounds (c_F = 1e7, time constant c̄ L / h < 60 s)
    is within e^-33 of its steady state, so ∂Ŷ/∂c_F vanishes to round-off.
    """
    model = scenario_model("z", n=4, end=3000.0, dt=10.0)
    late = simulate_measurements(model, {"fibre.k": 0.3, "fibre.c": 4e6}, times=np.arange(2000.0, 3001.0, 100.0))
    with pytest.warns(IdentifiabilityWarning, match=r"fibre\.c has no effect"):
        res = identify(model, late, {"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)}, particles=6, iterations=3,
                       refine=False)
    assert any("fibre.c" in w for w in res.uncertainty.warnings)
    assert np.isinf(res.uncertainty.std_error[1]) and np.isfinite(res.uncertainty.std_error[0])


def test_transient_data_identify_both_without_warning() -> None:
    model = scenario_model("z", n=4, end=40.0, dt=2.0)
    y = simulate_measurements(model, {"fibre.k": 0.3, "fibre.c": 4e6}, noise=0.02, rng=np.random.default_rng(0))
    res = identify(model, y, {"fibre.k": (0.05, 1.0), "fibre.c": (1e5, 1e7)}, particles=8, iterations=8)
    assert res.uncertainty.warnings == ()
    assert res.uncertainty.condition < 1e3
    assert -1.0 < res.uncertainty.correlation[0, 1] < 1.0


def test_a_bounded_output_bias_shifts_the_line_fit_by_at_most_its_bound_and_the_bound_is_attained() -> None:
    """Independent truth: for y = a + b t fitted by least squares (scipy.stats.linregress), a bias δY with
    |δY_i| ≤ ε moves the estimates by X⁺δY; the worst such bias is ε·sign(X⁺ row), which attains the bound."""
    eps = 0.05
    bound = bias_shift(LINE, eps)
    pinv = np.linalg.pinv(LINE)
    rng = np.random.default_rng(3)
    y = _noisy_line(rng)
    base = st.linregress(T, y)
    for j, name in enumerate(("intercept", "slope")):
        worst = eps * np.sign(pinv[j])
        moved = st.linregress(T, y + worst)
        assert abs(getattr(moved, name) - getattr(base, name)) == pytest.approx(bound[j], rel=1e-9)
    for _ in range(20):  # any other bias within the bound moves them less
        moved = st.linregress(T, y + eps * rng.uniform(-1.0, 1.0, T.size))
        assert abs(moved.intercept - base.intercept) <= bound[0] * (1 + 1e-12)
        assert abs(moved.slope - base.slope) <= bound[1] * (1 + 1e-12)


def test_the_budget_adds_the_bias_linearly_to_the_noise_interval() -> None:
    y = _noisy_line(np.random.default_rng(0))
    fit = st.linregress(T, y)
    beta = np.array([fit.intercept, fit.slope])
    plain = linearised(("a", "b"), beta, LINE, y - LINE @ beta)
    biased = linearised(("a", "b"), beta, LINE, y - LINE @ beta, output_error=0.05)
    np.testing.assert_allclose(biased.budget["measurement noise"], (plain.upper - plain.lower) / 2, rtol=1e-12)
    np.testing.assert_allclose(biased.budget["reduced model"], bias_shift(LINE, 0.05), rtol=1e-12)
    np.testing.assert_allclose((biased.upper - biased.lower) / 2,
                               biased.budget["measurement noise"] + biased.budget["reduced model"], rtol=1e-12)
    doc = biased.to_json()
    assert set(doc["budget"]) == {"measurement noise", "reduced model"}  # type: ignore[arg-type]
    assert doc["interval95_total"] == doc["interval95"]
