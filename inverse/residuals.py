"""Are the residuals of a fit white noise?  Diagnostics, and an offset check at the first time.

The linearised interval of :mod:`inverse.uncertainty` assumes independent errors of constant
variance.  Model error (homogenisation, discretisation, reduced model) is not like that: it
gives smooth residual curves, and the interval then reflects the noise only.  On each residual
time series r_1 … r_n (one face of one scenario, in time order), pooled over the series:

* lag-1 autocorrelation ρ̂₁ = Σ r_t r_{t+1} / Σ r_t²; under white noise √N ρ̂₁ is
  asymptotically N(0, 1) (N the number of lagged pairs) [BoxJenkins1976, § 6.2];
* Durbin–Watson d = Σ (r_t − r_{t−1})² / Σ r_t² ≈ 2 (1 − ρ̂₁): 2 for white noise, → 0 for
  smooth residuals [DurbinWatson1950];
* Wald–Wolfowitz runs test on the signs: with n₊ positive and n₋ negative residuals
  (zeros dropped) the number of runs R has mean 1 + 2 n₊ n₋ / n and variance
  2 n₊ n₋ (2 n₊ n₋ − n) / (n² (n − 1)) [WaldWolfowitz1940]; means and variances add over
  the series, z = (R − E R)/√Var R, two-sided p = 2 Φ(−|z|).

The residuals are called *systematic* when the runs test or the autocorrelation test rejects
whiteness at the level :data:`ALPHA` (two-sided each, so white noise is flagged in at most
about 2 ALPHA of fits).  These tests need no noise level, so they apply to noise-free data.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from aromm.core.system import FloatArray

ALPHA = 0.01  # level of each whiteness test (runs, lag-1 autocorrelation)
KELVIN = 273.15  # K at 0 °C
ROUND_OFF = 1e-9  # relative floor of the offset test (noise-free data on a flat model)
OFFSET_SPREADS = 5.0  # a first value beyond the model's range widened by this many residual spreads is an offset


@dataclass(frozen=True)
class ResidualDiagnostics:
    """Whiteness statistics of the residual series (``nan`` where undefined, e.g. all residuals zero)."""

    lag1_autocorrelation: float
    durbin_watson: float
    runs: int
    runs_expected: float
    runs_z: float
    runs_p_value: float
    autocorrelation_p_value: float
    series: int
    systematic: bool

    def to_json(self) -> dict[str, object]:
        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {"lag1_autocorrelation": num(self.lag1_autocorrelation), "durbin_watson": num(self.durbin_watson),
                "runs": self.runs, "runs_expected": num(self.runs_expected), "runs_z": num(self.runs_z),
                "runs_p_value": num(self.runs_p_value),
                "autocorrelation_p_value": num(self.autocorrelation_p_value),
                "series": self.series, "systematic": self.systematic}

    def describe(self) -> str:
        if not math.isfinite(self.lag1_autocorrelation):
            return "all residuals are zero"
        runs = (f"{self.runs} sign runs for {self.runs_expected:.4g} expected of white noise "
                f"(p = {self.runs_p_value:.2g})" if math.isfinite(self.runs_p_value)
                else "residuals of one sign along every series")
        return (f"lag-1 autocorrelation {self.lag1_autocorrelation:.3g}, Durbin-Watson {self.durbin_watson:.3g}, "
                f"{runs}")


def _runs(r: FloatArray) -> tuple[int, float, float]:
    """Runs R, E R and Var R of the signs of ``r`` (zeros dropped) [WaldWolfowitz1940]."""
    s = np.sign(r[r != 0])
    n = s.size
    pos = int(np.count_nonzero(s > 0))
    neg = n - pos
    if n < 2:
        return n, float(n), 0.0
    runs = 1 + int(np.count_nonzero(s[1:] != s[:-1]))
    two = 2.0 * pos * neg
    return runs, 1.0 + two / n, two * (two - n) / (n * n * (n - 1.0))


def diagnose(series: Sequence[FloatArray]) -> ResidualDiagnostics:
    """Whiteness diagnostics of residual time series (each 1-D, in time order), pooled over the series."""
    rs = [np.asarray(r, dtype=float).ravel() for r in series]
    ss = sum(float(r @ r) for r in rs)
    lagged = sum(float(r[1:] @ r[:-1]) for r in rs)
    diffs = sum(float(np.sum(np.diff(r) ** 2)) for r in rs)
    pairs = sum(max(r.size - 1, 0) for r in rs)
    rho = lagged / ss if ss > 0 else math.nan
    dw = diffs / ss if ss > 0 else math.nan
    rho_p = float(2.0 * ndtr(-abs(rho) * math.sqrt(pairs))) if ss > 0 and pairs > 0 else math.nan
    counts = [_runs(r) for r in rs]
    runs = sum(c[0] for c in counts)
    mean = sum(c[1] for c in counts)
    var = sum(c[2] for c in counts)
    z = (runs - mean) / math.sqrt(var) if var > 0 else math.nan
    runs_p = float(2.0 * ndtr(-abs(z))) if math.isfinite(z) else math.nan
    systematic = bool((math.isfinite(runs_p) and runs_p < ALPHA) or (math.isfinite(rho_p) and rho_p < ALPHA))
    return ResidualDiagnostics(rho, dw, runs, mean, z, runs_p, rho_p, len(rs), systematic)


def offset_note(t: FloatArray, measured: FloatArray, fitted: FloatArray, *, start: FloatArray,
                faces: Sequence[str], label: str = "") -> str | None:
    """A warning when the data at the first time are far from the model's start, else ``None``.

    ``measured`` and ``fitted`` are (n_times, n_faces), ``start`` (n_faces,) the fitted model at
    t = 0 (the scene's ``[initial] T``).  The model spans the range ``[min, max]`` of its start and
    fitted curve; a first measured value beyond that range by more than the range's own width (or
    :data:`OFFSET_SPREADS` spreads of the residuals about their mean, if larger) on every face is an
    offset of the data, not noise or model error.  It is read as kelvin against °C when moving the
    data by ∓273.15 brings them into the widened range, else as a wrong ``[initial] T``, a sensor
    offset or a time origin after the start of heating.  Needs two times or more.
    """
    y, yhat = np.atleast_2d(measured), np.atleast_2d(fitted)
    if y.shape[0] < 2:
        return None
    span = np.vstack([yhat, np.asarray(start, dtype=float)[None]])
    lo, hi = span.min(axis=0), span.max(axis=0)
    slack = np.maximum(OFFSET_SPREADS * np.std(y - yhat, axis=0), hi - lo) + ROUND_OFF * (1.0 + np.abs(span).max())
    low, high = lo - slack, hi + slack

    def inside(v: FloatArray) -> bool:
        return bool(np.all((low <= v) & (v <= high)))

    first = y[0]
    if not np.all((first < low) | (first > high)):
        return None
    if inside(first - KELVIN):
        cause = "data in kelvin with a scene in °C: use one unit for the measurements and the scene"
    elif inside(first + KELVIN):
        cause = "data in °C with a scene in kelvin: use one unit for the measurements and the scene"
    else:
        cause = ("a wrong [initial] T in the scene, a sensor offset, or a time origin after the start of heating "
                 "(t = 0 must be the start)")
    values = ", ".join(f"{f} {v:.6g}" for f, v in zip(faces, first, strict=True))
    offset = float(np.mean(first - start))
    where = f"scenario {label!r}: " if label else ""
    return (f"{where}the first measured temperatures (t = {t[0]:g} s: {values}) are {offset:+.4g} from the scene's "
            f"initial temperature, beyond what the fitted model reaches; likely cause: {cause}")
