"""Heteroskedasticity-and-autocorrelation-consistent (HAC) covariance of least-squares estimates.

With sensitivities X (N × p) and residuals r, the least-squares estimate has the sandwich
covariance [NeweyWest1987]

    Cov(β̂) = (XᵀX)⁻¹ Ŝ (XᵀX)⁻¹,     Ŝ = Γ₀ + Σ_{l≥1} k(l / S_T) (Γ_l + Γ_lᵀ),
    Γ_l = Σ_t g_t g_{t−l}ᵀ,           g_t = Σ_f x_{t f} r_{t f},

where the scores g_t gather, at each time t of one experiment, every observed face f (so
correlation between faces at one time is kept too, as in [DriscollKraay1998]); lags never
cross from one experiment (scenario) to another, which are independent.  The kernel is
Bartlett's, k(x) = max(0, 1 − x), which keeps Ŝ positive semi-definite [NeweyWest1987].  The
bandwidth S_T is Andrews' AR(1) plug-in for the Bartlett kernel [Andrews1991, eq. 6.2 and
§ 6]: fit g_{t,a} = ρ_a g_{t−1,a} + e_t per component a (variance σ_a²), then

    α(1) = Σ_a 4 ρ_a² σ_a⁴ / ((1 − ρ_a)⁶ (1 + ρ_a)²)  /  Σ_a σ_a⁴ / (1 − ρ_a)⁴,
    S_T = 1.1447 (α(1) T)^{1/3},   capped at T (T times),

so the window widens with the measured correlation of the residuals: white residuals give
S_T ≈ 0 (the plain White/Gauss–Newton sandwich), smooth ones the whole record.

Why HAC rather than a block bootstrap: it reuses the sensitivity matrix already computed at the
optimum (a bootstrap needs one re-identification, hundreds of model evaluations, per replicate),
it is deterministic (no random stream in a reported interval), and it is positive semi-definite
by construction.  Neither accounts for a *bias*: residuals that are a deterministic model error
(e.g. homogenisation error in noise-free twin data) satisfy the normal equations Σ_t g_t = 0,
which caps Ŝ; the interval then still reflects correlated noise only, and the caller says so.
The lagged sums are computed by FFT, O(p² T log T).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from aromm.core.system import FloatArray

ANDREWS_BARTLETT = 1.1447  # [Andrews1991, eq. 6.2], Bartlett kernel
RHO_CAP = 1.0 - 1e-12  # an AR(1) coefficient this close to ±1 means a window over the whole record


def scores(sensitivity: FloatArray, residuals: FloatArray,
           blocks: Sequence[npt.NDArray[np.intp]]) -> list[FloatArray]:
    """Scores g_t (T_b × p) of each block; a block is an index array (n_times, n_faces) into the rows."""
    x = np.asarray(sensitivity, dtype=float)
    r = np.asarray(residuals, dtype=float).ravel()
    return [np.einsum("tfp,tf->tp", x[idx], r[idx]) for idx in blocks]


def bandwidth(g: Sequence[FloatArray]) -> float:
    """Andrews' AR(1) plug-in bandwidth S_T for the Bartlett kernel, pooled over blocks, capped at T."""
    longest = max(b.shape[0] for b in g)
    lagged = sum(np.einsum("tp,tp->p", b[1:], b[:-1]) for b in g)
    before = sum(np.einsum("tp,tp->p", b[:-1], b[:-1]) for b in g)
    live = before > 0
    if not np.any(live) or longest < 2:
        return 0.0
    rho = np.clip(lagged[live] / before[live], -RHO_CAP, RHO_CAP)
    innov = sum(np.sum((b[1:, live] - rho * b[:-1, live]) ** 2, axis=0) for b in g) / sum(b.shape[0] - 1 for b in g)
    num = np.sum(4.0 * rho**2 * innov**2 / ((1.0 - rho) ** 6 * (1.0 + rho) ** 2))
    den = np.sum(innov**2 / (1.0 - rho) ** 4)
    if not den > 0:
        return 0.0
    return float(min(ANDREWS_BARTLETT * (num / den * longest) ** (1.0 / 3.0), longest))


def long_run(g: Sequence[FloatArray], window: float) -> FloatArray:
    """Ŝ = Σ_blocks [Γ₀ + Σ_l k(l/S_T)(Γ_l + Γ_lᵀ)] with Bartlett weights k(x) = max(0, 1 − x)."""
    p = g[0].shape[1]
    total = np.zeros((p, p))
    for b in g:
        t = b.shape[0]
        f = np.fft.rfft(b, n=2 * t, axis=0)
        # cross[l, a, c] = Σ_t g_{t,a} g_{t−l,c} for l = 0 … T−1
        cross = np.fft.irfft(f[:, :, None] * np.conj(f[:, None, :]), n=2 * t, axis=0)[:t]
        lags = np.arange(t)
        w = np.maximum(0.0, 1.0 - lags / window) if window > 0 else (lags == 0).astype(float)
        w[0] = 1.0
        s = np.einsum("l,lac->ac", w, cross)
        total += s + s.T - cross[0]  # Γ₀ counted once
    return 0.5 * (total + total.T)
