"""Corner plot of posterior samples (matplotlib only): marginal histograms on the diagonal, pairwise
2-D histograms below it, the 95 % credible intervals as dashed lines and, when given, the linearised
Gaussian approximation (its density on the diagonal, its 95 % ellipse below) for comparison.

Drawn with matplotlib's object API on an Agg canvas (no pyplot, no global backend change).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import scipy.stats as st
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from aromm.core.files import output_path
from inverse.posterior import LEVEL, Posterior
from inverse.uncertainty import Uncertainty

BINS = 40


def posterior_figure(posterior: Posterior, linearised: Uncertainty | None = None) -> Figure:
    """The corner plot of ``posterior`` (one row and column per coordinate, ``noise_std`` included)."""
    names, x = posterior.names, posterior.samples
    p = len(names)
    fig = Figure(figsize=(2.4 * p + 1.0, 2.4 * p + 0.6), layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_2d(fig.subplots(p, p, squeeze=False))
    lower, upper = posterior.interval
    lin = _linearised(linearised, names)
    for i in range(p):
        for j in range(p):
            ax = axes[i, j]
            if j > i:
                ax.set_axis_off()
                continue
            if i == j:
                ax.hist(x[:, i], bins=BINS, density=True, color="0.6", histtype="stepfilled")
                for v in (lower[i], upper[i]):
                    ax.axvline(v, ls="--", color="k", lw=0.8)
                if lin is not None and np.isfinite(lin[1][i, i]):
                    left, right = ax.get_xlim()
                    grid = np.linspace(left, right, 200)
                    ax.plot(grid, st.norm.pdf(grid, lin[0][i], np.sqrt(lin[1][i, i])), color="C1", lw=1.2)
                ax.set_yticks([])
            else:
                ax.hist2d(x[:, j], x[:, i], bins=BINS, cmap="Greys")
                if lin is not None:
                    _ellipse(ax, lin[0][[j, i]], lin[1][np.ix_([j, i], [j, i])])
            if i == p - 1:
                ax.set_xlabel(names[j])
            if j == 0 and i > 0:
                ax.set_ylabel(names[i])
    fig.suptitle(f"posterior: {posterior.walkers} walkers × {posterior.steps} steps (burn-in {posterior.burn}), "
                 f"acceptance {posterior.acceptance:.2f}; dashed: {100 * LEVEL:.0f} % credible intervals"
                 + ("; orange: linearised" if lin is not None else ""), fontsize=9)
    return fig


def _linearised(unc: Uncertainty | None, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray] | None:
    """Mean and covariance of the linearised Gaussian on the posterior's coordinates (NaN where it has none)."""
    if unc is None:
        return None
    mean = np.full(len(names), np.nan)
    cov = np.full((len(names), len(names)), np.nan)
    for a, name in enumerate(names):
        if name not in unc.names:
            continue
        i = unc.names.index(name)
        mean[a] = unc.estimates[i]
        for b, other in enumerate(names):
            if other in unc.names:
                j = unc.names.index(other)
                cov[a, b] = unc.correlation[i, j] * unc.std_error[i] * unc.std_error[j]
    return mean, cov


def _ellipse(ax: Axes, mean: np.ndarray, cov: np.ndarray) -> None:
    """The 95 % ellipse of a 2-D Gaussian: mean + L (r cos φ, r sin φ), r² = χ²₂(0.95), L Lᵀ = cov."""
    if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
        return
    try:
        chol = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        return
    phi = np.linspace(0.0, 2.0 * np.pi, 200)
    r = np.sqrt(st.chi2.ppf(LEVEL, 2))
    pts = mean[:, None] + chol @ (r * np.vstack([np.cos(phi), np.sin(phi)]))
    ax.plot(pts[0], pts[1], color="C1", lw=1.2)


def save_posterior_plot(posterior: Posterior, path: str | os.PathLike[str], linearised: Uncertainty | None = None,
                        dpi: int = 120) -> Path:
    """Write :func:`posterior_figure` to ``path`` (format from the suffix, e.g. ``.png``)."""
    p = output_path(path, "posterior plot")
    posterior_figure(posterior, linearised).savefig(p, dpi=dpi)
    return p
