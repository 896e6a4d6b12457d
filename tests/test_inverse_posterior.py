"""The MCMC posterior (inverse.posterior) against the analytic posteriors of a model linear in its parameters.

For Ŷ = A θ with independent Gaussian noise and a flat prior, the posterior of θ is Gaussian with the
least-squares mean θ̂ = (AᵀA)⁻¹Aᵀy and covariance σ²(AᵀA)⁻¹ when σ is known; with σ unknown under Jeffreys'
prior it is a multivariate Student t with ν = N − p degrees of freedom, covariance ν/(ν − 2) s²(AᵀA)⁻¹
(s² = RSS/ν), and σ² follows a scaled inverse χ²(ν, s²), so E[σ] = s √(ν/2) Γ((ν−1)/2) / Γ(ν/2)
[Jeffreys1961].  Tolerances are 4 Monte Carlo standard errors from the chain's own effective sample size n:
a mean std/√n, a variance var·√(2/n), a correlation (1 − ρ²)/√n.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from inverse_cases import LinearModel, scenario_system
from scene_text import scenario_1
from scipy.special import gammaln

from aromm.cli import main
from aromm.core.errors import InputError
from aromm.core.observables import Observables
from inverse.posterior import NOISE, PosteriorWarning, sample_posterior

T = np.arange(1.0, 41.0)
DESIGN = np.column_stack([np.ones_like(T), T / 40])  # intercept and slope: correlation −0.87
NAMES = ("a0", "a1")
SIGMA = 0.1


def _linear_problem(seed: int = 0) -> tuple[LinearModel, Observables, np.ndarray, np.ndarray, dict]:
    y = DESIGN @ np.array([1.0, 2.0]) + SIGMA * np.random.default_rng(seed).standard_normal(T.size)
    ata_inv = np.linalg.inv(DESIGN.T @ DESIGN)
    theta = ata_inv @ DESIGN.T @ y
    sd = SIGMA * np.sqrt(np.diag(ata_inv))
    bounds = {n: (theta[i] - 30 * sd[i], theta[i] + 30 * sd[i]) for i, n in enumerate(NAMES)}
    return LinearModel(DESIGN, NAMES), Observables(T, {"a": y}), theta, ata_inv, bounds


def _check_gaussian(post, mean: np.ndarray, cov: np.ndarray) -> None:  # type: ignore[no-untyped-def]
    n_eff = post.effective_samples[: len(mean)]
    sd = np.sqrt(np.diag(cov))
    assert np.all(np.abs(post.mean[: len(mean)] - mean) <= 4 * sd / np.sqrt(n_eff)), (post.mean, mean, n_eff)
    var = np.diag(post.covariance)[: len(mean)]
    assert np.all(np.abs(var / sd**2 - 1) <= 4 * np.sqrt(2 / n_eff)), (var / sd**2, n_eff)
    rho = cov[0, 1] / (sd[0] * sd[1])
    assert abs(post.correlation[0, 1] - rho) <= 4 * (1 - rho**2) / np.sqrt(n_eff.min())


def test_known_noise_posterior_is_the_least_squares_gaussian() -> None:
    model, data, theta, ata_inv, bounds = _linear_problem()
    post = sample_posterior(model, data, bounds, steps=3000, rng=np.random.default_rng(1), noise_std=SIGMA,
                            start=dict(zip(NAMES, theta, strict=True)))
    assert post.names == NAMES and post.noise_std == SIGMA
    assert post.effective_samples.min() > 1000
    _check_gaussian(post, theta, SIGMA**2 * ata_inv)
    lower, upper = post.interval  # Gaussian: θ̂ ± 1.96 sd, up to the Monte Carlo error of a 2.5 % quantile
    sd = SIGMA * np.sqrt(np.diag(ata_inv))
    np.testing.assert_allclose(upper - lower, 2 * 1.959964 * sd, rtol=0.1)
    assert post.evaluations >= post.walkers * post.steps * 0.99  # the box is wide: nearly every proposal evaluated


def test_sampled_noise_gives_the_student_posterior_and_the_noise_level() -> None:
    model, data, theta, ata_inv, bounds = _linear_problem(seed=4)
    y = data.mean_T["a"]
    nu = T.size - 2
    s2 = float(np.sum((y - DESIGN @ theta) ** 2)) / nu
    post = sample_posterior(model, data, bounds, steps=3000, rng=np.random.default_rng(2))
    assert post.names == (*NAMES, NOISE) and post.noise_std is None
    _check_gaussian(post, theta, nu / (nu - 2) * s2 * ata_inv)
    mean_sigma = np.sqrt(s2) * np.sqrt(nu / 2) * np.exp(gammaln((nu - 1) / 2) - gammaln(nu / 2))
    sd_sigma = np.sqrt(nu / (nu - 2) * s2 - mean_sigma**2)
    assert abs(post.mean[2] - mean_sigma) <= 4 * sd_sigma / np.sqrt(post.effective_samples[2])


def test_flat_likelihood_returns_the_uniform_prior_of_the_box() -> None:
    """With a noise 1e4 times the model's range the data say nothing: the posterior is the prior, uniform on
    the bounds (mean at the centre, standard deviation width/√12)."""
    model, data, _, _, _ = _linear_problem()
    bounds = {"a0": (0.0, 1.0), "a1": (2.0, 6.0)}
    post = sample_posterior(model, data, bounds, steps=2000, rng=np.random.default_rng(3), noise_std=1e4)
    width = np.array([1.0, 4.0])
    n_eff = post.effective_samples
    assert np.all(np.abs(post.mean - [0.5, 4.0]) <= 4 * width / np.sqrt(12 * n_eff))
    assert np.all(np.abs(post.std / (width / np.sqrt(12)) - 1) <= 4 * np.sqrt(0.8 / n_eff))  # var of U: 0.8/n
    assert post.samples[:, 0].min() >= 0.0 and post.samples[:, 1].max() <= 6.0


@pytest.mark.filterwarnings("ignore::inverse.posterior.PosteriorWarning")
def test_a_seed_reproduces_the_chain_and_numpy_global_state_is_untouched() -> None:
    model, data, theta, _, bounds = _linear_problem()
    before = np.random.get_state()[1].copy()  # noqa: NPY002 - the global state must stay untouched
    runs = [sample_posterior(model, data, bounds, steps=50, rng=np.random.default_rng(seed), noise_std=SIGMA,
                             start=dict(zip(NAMES, theta, strict=True)))
            for seed in (7, 7, 8)]
    np.testing.assert_array_equal(runs[0].samples, runs[1].samples)
    assert not np.array_equal(runs[0].samples, runs[2].samples)
    np.testing.assert_array_equal(np.random.get_state()[1], before)  # noqa: NPY002
    assert any("too short" in w for w in runs[0].warnings)


def test_bad_requests_are_refused() -> None:
    model, data, _, _, bounds = _linear_problem()
    rng = np.random.default_rng(0)
    with pytest.raises(InputError, match="walkers must be an integer >= 2 × 3"):
        sample_posterior(model, data, bounds, steps=10, rng=rng, walkers=4)
    with pytest.raises(InputError, match="noise_std must be a positive"):
        sample_posterior(model, data, bounds, steps=10, rng=rng, noise_std=0.0)
    with pytest.raises(InputError, match="unknown parameter 'b'"):
        sample_posterior(model, data, {"b": (0.0, 1.0)}, steps=10, rng=rng)


def test_missing_emcee_is_an_input_error_before_any_work(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "emcee", None)  # import emcee now raises ImportError
    model, data, _, _, bounds = _linear_problem()
    with pytest.raises(InputError, match=r"pip install 'aromm\[posterior\]'"):
        sample_posterior(model, data, bounds, steps=10, rng=np.random.default_rng(0))
    scene = tmp_path / "missing.toml"  # never read: the extra is checked first
    assert main(["identify", str(scene), "--measurements", "y.csv", "--unknown", "fibre.k=0.05:1",
                 "--posterior", "100"]) == 2
    assert "aromm[posterior]" in capsys.readouterr().err


def test_cli_posterior_json_table_and_corner_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AROMM_CACHE_DIR", str(tmp_path / "cache"))
    labels = (np.indices((4, 4, 4)).sum(axis=0) % 3 == 0).astype(np.int32)
    np.save(tmp_path / "img.npy", labels)
    scene = tmp_path / "s.toml"
    scene.write_text(scenario_1("img.npy", "5e-6", "2.0", "0.1"), encoding="utf-8")
    csv = tmp_path / "y.csv"
    assert main(["simulate", str(scene), "--out", str(tmp_path / "sim")]) == 0
    sim = (tmp_path / "sim" / "observables.csv").read_text().splitlines()
    rng = np.random.default_rng(0)
    rows = [sim[0]] + [",".join([r.split(",")[0]] + [repr(float(v) + 0.01 * rng.standard_normal())
                                                      for v in r.split(",")[1:]]) for r in sim[1:]]
    csv.write_text("\n".join(rows) + "\n")
    capsys.readouterr()
    args = ["identify", str(scene), "--measurements", str(csv), "--unknown", "fibre.k=0.1:1",
            "--unknown", "fibre.c=1e6:1e7", "--order", "30", "--particles", "8", "--iterations", "5",
            "--posterior", "60", "--walkers", "8", "--noise-std", "0.01"]
    assert main([*args, "--json", "--plot", str(tmp_path / "fit.png")]) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)["posterior"]
    assert set(out["mean"]) == {"fibre.k", "fibre.c"} and out["noise"] == {"sampled": False, "std": 0.01}
    assert out["steps"] == 60 and out["walkers"] == 8 and 0 < out["acceptance"] < 1
    lo, hi = out["interval95"]["fibre.k"]
    assert lo < out["mean"]["fibre.k"] < hi
    assert "posterior chain too short" in captured.err
    assert (tmp_path / "fit.png").is_file() and (tmp_path / "fit_posterior.png").is_file()
    assert main(args) == 0
    assert "95 % credible interval" in capsys.readouterr().out


def test_posterior_warning_class_is_raised_for_short_chains() -> None:
    model, data, theta, _, bounds = _linear_problem()
    with pytest.warns(PosteriorWarning, match="too short"):
        sample_posterior(model, data, bounds, steps=20, rng=np.random.default_rng(0), noise_std=SIGMA,
                         start=dict(zip(NAMES, theta, strict=True)))


@pytest.mark.filterwarnings("ignore::inverse.posterior.PosteriorWarning")  # 800 steps < 50 τ: the MC errors say
def test_posterior_of_a_transient_model_agrees_with_the_linearised_intervals(tmp_path: Path) -> None:
    """A nearly linear case (the exact semi-discrete model of a small two-phase cube — a reduced model with every
    mode —, unknowns k_F and c_F, noise 0.01 °C on 40 × 2 face means): the posterior mean is the least-squares
    estimate and its standard deviations are the linearised ones, each within 4 Monte Carlo errors plus 5 % for
    the model's curvature over ±2 sd (the relative change of the sensitivities there, measured < 3 %)."""
    from aromm.reduction.offline import reduce
    from inverse.identification import identify

    system = scenario_system(n=2, end=40.0, dt=1.0)
    model = reduce(system, order=system.n, modes=system.n, cache=tmp_path)
    data = model.simulate({"fibre.k": 0.3, "fibre.c": 4e6}).with_noise(0.01, np.random.default_rng(5))
    bounds = {"fibre.k": (0.1, 1.0), "fibre.c": (1e6, 1e7)}
    fit = identify(model, data, bounds, seed=0, particles=6, iterations=3)
    se = fit.uncertainty.std_error * 0.01 / fit.uncertainty.residual_std  # linearised, at the known σ
    post = sample_posterior(model, data, bounds, steps=800, walkers=32, rng=np.random.default_rng(0),
                            noise_std=0.01, start=fit)
    est = np.array(list(fit.estimates.values()))
    n_eff = post.effective_samples
    assert np.all(np.abs(post.mean - est) <= 4 * post.std / np.sqrt(n_eff) + 0.05 * se), (post.mean, est, se)
    assert np.all(np.abs(post.std / se - 1) <= 4 / np.sqrt(2 * n_eff) + 0.05), (post.std / se, n_eff)
