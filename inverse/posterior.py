"""Full posterior of the unknowns by Markov-chain Monte Carlo (emcee, an optional extra).

Measurement model behind the criterion J of [Chavez2020, eq. 12]: ``Y = Ŷ(β) + ε`` with independent
Gaussian errors of standard deviation σ (°C), so with N observations

    log p(Y | β, σ) = −N log σ − J(β) / σ² + const,        J(β) = ½ Σ (Y − Ŷ(β))²,

and priors uniform on the box of the unknowns' bounds.  σ is either given (the sensor noise, known from
calibration) or sampled with it as one more coordinate, ``log σ``, whose flat prior is Jeffreys' prior
p(σ) ∝ 1/σ [Jeffreys1961].  The sampler is emcee's affine-invariant ensemble [ForemanMackey2013] with the
stretch move [GoodmanWeare2010]; it is vectorised, so each half-step evaluates half the walkers in one
``simulate_batch`` call (milliseconds with the reduced model).  Proposals outside the box are refused without
evaluating the model.

Reported: posterior means and standard deviations, 95 % equal-tailed credible intervals (2.5 and 97.5
percentiles), correlations, the mean acceptance fraction and, per coordinate, the integrated autocorrelation
time τ (in steps) [Sokal1997] and the effective sample size ``walkers × steps / τ``.  The first ``3 τ_max`` steps
are discarded (burn-in, at most half the chain); a retained chain shorter than 50 τ (emcee's own criterion
for a reliable τ) is reported by a :class:`PosteriorWarning`.  The Monte Carlo error of a posterior mean is
``std / sqrt(effective samples)``.

Random numbers: the walkers' start and the seed of emcee's own ``RandomState`` both come from the caller's
``np.random.Generator``; numpy's global generator is never touched.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from types import ModuleType
from typing import Protocol

import numpy as np

from aromm.core.errors import InputError
from aromm.core.system import FloatArray
from inverse import optimisers as opt
from inverse.criterion import LeastSquares, ModelInput, scenarios_of
from inverse.defaults import DEFAULT_WALKERS
from inverse.measurements import Measurements
from inverse.uncertainty import Uncertainty


class Fitted(Protocol):
    """An identification's estimates and linearised uncertainty (:class:`~inverse.identification.Identification`)."""

    @property
    def estimates(self) -> Mapping[str, float]: ...

    @property
    def uncertainty(self) -> Uncertainty: ...


NOISE = "noise_std"  # name of the sampled noise level (°C) among the posterior's coordinates
LEVEL = 0.95
TAU_MULTIPLE = 50  # a retained chain shorter than this many autocorrelation times is reported
BURN_TAUS = 3.0  # burn-in: this many autocorrelation times (at most half the chain)
START_FRACTION = 1e-2  # initial spread (of the bound widths) when no linearised standard error is known


class PosteriorWarning(UserWarning):
    """The chain is too short for its autocorrelation time, or the walkers hardly move."""


@dataclass(frozen=True)
class Posterior:
    """Posterior samples (after burn-in, all walkers) and their summary; ``names`` may end with ``noise_std``."""

    names: tuple[str, ...]
    samples: FloatArray
    acceptance: float
    autocorr_time: FloatArray
    steps: int
    walkers: int
    burn: int
    evaluations: int
    seconds: float
    cpu_seconds: float
    noise_std: float | None
    warnings: tuple[str, ...] = ()

    @property
    def mean(self) -> FloatArray:
        return np.asarray(self.samples.mean(axis=0))

    @property
    def std(self) -> FloatArray:
        return np.asarray(self.samples.std(axis=0, ddof=1))

    @property
    def covariance(self) -> FloatArray:
        return np.atleast_2d(np.cov(self.samples, rowvar=False))

    @property
    def correlation(self) -> FloatArray:
        cov = self.covariance
        d = np.sqrt(np.diag(cov))
        return np.asarray(cov / np.outer(d, d))

    @property
    def interval(self) -> tuple[FloatArray, FloatArray]:
        """Equal-tailed credible interval at :data:`LEVEL` (lower, upper)."""
        q = np.percentile(self.samples, [50 * (1 - LEVEL), 50 * (1 + LEVEL)], axis=0)
        return q[0], q[1]

    @property
    def effective_samples(self) -> FloatArray:
        """``walkers × retained steps / τ`` per coordinate."""
        return np.asarray(self.walkers * (self.steps - self.burn) / self.autocorr_time)

    def to_json(self) -> dict[str, object]:
        idx = list(enumerate(self.names))
        lower, upper = self.interval
        corr = self.correlation
        return {
            "parameters": list(self.names),
            "mean": {n: float(self.mean[i]) for i, n in idx},
            "std": {n: float(self.std[i]) for i, n in idx},
            "interval95": {n: [float(lower[i]), float(upper[i])] for i, n in idx},
            "correlation": {a: {b: float(corr[i, j]) for j, b in idx} for i, a in idx},
            "acceptance": float(self.acceptance),
            "autocorrelation_time": {n: float(self.autocorr_time[i]) for i, n in idx},
            "effective_samples": {n: float(self.effective_samples[i]) for i, n in idx},
            "steps": self.steps, "walkers": self.walkers, "burn": self.burn,
            "evaluations": self.evaluations, "seconds": self.seconds, "cpu_seconds": self.cpu_seconds,
            "noise": {"sampled": self.noise_std is None, "std": self.noise_std},
            "warnings": list(self.warnings),
        }


def load_emcee() -> ModuleType:
    """emcee, imported on first use; InputError naming the optional extra when it is not installed."""
    try:
        import emcee
    except ImportError:
        raise InputError("sampling the posterior needs the optional package emcee (>= 3): "
                         "pip install 'aromm[posterior]'") from None
    return emcee


def check_walkers(walkers: int, unknowns: int, *, sample_noise: bool) -> int:
    """The number of sampled coordinates (the unknowns, plus log σ when the noise is sampled); InputError unless
    ``walkers`` is an integer at least twice that (emcee's stretch move needs two halves of the ensemble that
    each span the space)."""
    ndim = unknowns + sample_noise
    if isinstance(walkers, bool) or not isinstance(walkers, int) or walkers < 2 * ndim:
        raise InputError(f"posterior: walkers must be an integer >= 2 × {ndim} coordinates ({unknowns} unknowns"
                         + (" and the noise σ" if sample_noise else "") + f"), got {walkers!r}")
    return ndim


def sample_posterior(
    model: ModelInput,
    measurements: Measurements | None = None,
    unknowns: Mapping[str, tuple[float, float]] | None = None,
    *,
    steps: int,
    rng: np.random.Generator,
    walkers: int = DEFAULT_WALKERS,
    noise_std: float | None = None,
    start: Fitted | Mapping[str, float] | None = None,
    fixed: Mapping[str, float] | None = None,
    progress: bool = False,
) -> Posterior:
    """Sample the posterior of ``unknowns`` (name → bounds, SI) given ``measurements`` (or a joint list of pairs).

    ``steps`` is the number of steps of each of ``walkers`` walkers (emcee's ``nsteps``).  ``noise_std`` is
    the known σ (°C); None samples it (Jeffreys prior).  ``start`` centres the walkers: an
    :class:`~inverse.identification.Identification` (its estimates, spread by its linearised standard errors:
    the walkers then start close to the posterior and the burn-in is short), or values by name; by default the
    centre of the box.
    """
    emcee = load_emcee()
    if unknowns is None:
        raise InputError("unknowns are required, e.g. {'fibre.k': (0.05, 1.0), 'fibre.c': (1e5, 1e7)}")
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 2:
        raise InputError(f"posterior: steps must be an integer >= 2, got {steps!r}")
    if noise_std is not None and not (math.isfinite(noise_std) and noise_std > 0):
        raise InputError(f"noise_std must be a positive temperature (°C), got {noise_std!r}")
    box = opt.Box.from_bounds(unknowns)
    criterion = LeastSquares(scenarios_of(model, measurements, {*box.names, *(fixed or {})}), box.names, fixed)
    n_obs = criterion.n_observations
    ndim = check_walkers(walkers, box.dim, sample_noise=noise_std is None)

    def log_prob(x: FloatArray) -> FloatArray:
        theta = x[:, : box.dim]
        inside = np.all((theta >= box.lower) & (theta <= box.upper), axis=1)
        out = np.full(len(x), -np.inf)
        if np.any(inside):
            r = criterion.residuals(theta[inside])
            half_ss = 0.5 * np.einsum("ij,ij->i", r, r)
            if noise_std is None:
                log_s = x[inside, box.dim]
                out[inside] = -n_obs * log_s - half_ss * np.exp(-2.0 * log_s)
            else:
                out[inside] = -half_ss / noise_std**2
        return out

    p0 = _start(box, start, rng, walkers=walkers, noise_std=noise_std, criterion=criterion)
    sampler = emcee.EnsembleSampler(walkers, ndim, log_prob, vectorize=True)
    state = emcee.State(p0, random_state=np.random.RandomState(int(rng.integers(2**32))).get_state())
    wall, cpu = time.perf_counter(), time.process_time()
    sampler.run_mcmc(state, steps, progress=progress)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    chain = np.asarray(sampler.get_chain())  # (steps, walkers, ndim)
    tau = emcee.autocorr.integrated_time(chain, tol=0, quiet=True)
    burn = min(steps // 2, math.ceil(BURN_TAUS * float(np.max(tau))))
    tau = emcee.autocorr.integrated_time(chain[burn:], tol=0, quiet=True)
    kept = chain[burn:].reshape(-1, ndim).copy()
    names = box.names + ((NOISE,) if noise_std is None else ())
    if noise_std is None:
        kept[:, -1] = np.exp(kept[:, -1])
    acceptance = float(np.mean(sampler.acceptance_fraction))
    notes = []
    if steps - burn < TAU_MULTIPLE * float(np.max(tau)):
        notes.append(f"posterior chain too short: {steps - burn} retained steps < {TAU_MULTIPLE} autocorrelation times "
                     f"(τ = {float(np.max(tau)):.3g} steps, {names[int(np.argmax(tau))]}); the intervals are rough: "
                     f"give at least {math.ceil(TAU_MULTIPLE * float(np.max(tau)) + burn)} steps")
    if acceptance < 0.1:
        notes.append(f"posterior: acceptance fraction {acceptance:.2f} < 0.1, the walkers hardly move (a posterior "
                     "much narrower than the initial spread, or a multimodal one)")
    for msg in notes:
        warnings.warn(msg, PosteriorWarning, stacklevel=2)
    return Posterior(names, kept, acceptance, np.asarray(tau, dtype=float), steps, walkers, burn,
                     criterion.evaluations, wall, cpu, noise_std, tuple(notes))


def _start(box: opt.Box, start: Fitted | Mapping[str, float] | None, rng: np.random.Generator, *,
           walkers: int, noise_std: float | None, criterion: LeastSquares) -> FloatArray:
    """Walkers' initial positions: a Gaussian ball inside the box (reflected at the bounds), plus ``log σ``."""
    width = box.upper - box.lower
    centre, spread = box.lower + 0.5 * width, START_FRACTION * width
    if start is not None and not isinstance(start, Mapping):  # an Identification
        centre = np.array([start.estimates[n] for n in box.names])
        se = np.asarray(start.uncertainty.std_error, dtype=float)
        spread = np.where(np.isfinite(se) & (se > 0), np.minimum(se, 0.25 * width), spread)
    elif start is not None:
        missing = [n for n in box.names if n not in start]
        if missing:
            raise InputError(f"posterior start: no value for {missing}")
        centre = np.array([float(start[n]) for n in box.names])
    theta = centre + spread * rng.standard_normal((walkers, box.dim))
    folded = np.mod(theta - box.lower, 2.0 * width)  # reflected at the bounds into the box
    theta = box.lower + width - np.abs(folded - width)
    if noise_std is not None:
        return np.asarray(theta)
    r = criterion.residuals(centre[None])[0]
    n = r.size
    log_s = math.log(max(float(np.sqrt(r @ r / n)), np.finfo(float).tiny))
    return np.column_stack([theta, log_s + rng.standard_normal(walkers) / math.sqrt(2.0 * n)])
