"""Figures of an identification: measured vs fitted face means, and convergence of the criterion.

Drawn with matplotlib's object API on an Agg canvas (no pyplot, no global backend change).
"""

from __future__ import annotations

import itertools
import os
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from aromm.files import output_path
from inverse.identification import Identification


def identification_figure(result: Identification) -> Figure:
    """Left: measured (markers) and fitted (lines) face-mean temperatures; right: best J vs evaluations."""
    fig = Figure(figsize=(11.0, 4.2), layout="constrained")
    FigureCanvasAgg(fig)
    fit_ax, conv_ax = fig.subplots(1, 2)
    colours = itertools.cycle(matplotlib.rcParams["axes.prop_cycle"].by_key()["color"])
    for fit in result.fits:
        step = max(1, len(fit.t) // 40)
        for j, face in enumerate(fit.faces):
            colour = next(colours)
            label = f"{fit.name}: {face}" if fit.name else face
            fit_ax.plot(fit.t[::step], fit.measured[::step, j], "o", ms=3, color=colour, label=f"{label} measured")
            fit_ax.plot(fit.t, fit.fitted[:, j], "-", color=colour, label=f"{label} fitted")
    fit_ax.set_xlabel("t (s)")
    fit_ax.set_ylabel("face-mean temperature (°C)")
    est = ", ".join(f"{k} = {v:.4g}" for k, v in result.estimates.items())
    fit_ax.set_title(est, fontsize=9)
    fit_ax.legend(fontsize=7, ncol=2)

    hist = result.history
    stage = np.array(hist.stage)
    crit = np.maximum(hist.criterion, np.finfo(float).tiny)
    for name, marker in (("pso", "o-"), ("refine", "s-")):
        sel = stage == name
        if np.any(sel):
            conv_ax.semilogy(hist.evaluations[sel], crit[sel], marker, ms=3, label=name)
    conv_ax.set_xlabel("model evaluations")
    conv_ax.set_ylabel("best criterion J (°C²)")
    conv_ax.set_title(f"J = {result.criterion:.3g} after {result.evaluations} evaluations, {result.seconds:.1f} s",
                      fontsize=9)
    conv_ax.legend(fontsize=8)
    conv_ax.grid(True, which="both", alpha=0.3)
    return fig


def save_identification_plot(result: Identification, path: str | os.PathLike[str], dpi: int = 120) -> Path:
    """Write :func:`identification_figure` to ``path`` (format from the suffix, e.g. ``.png``)."""
    p = output_path(path, "plot")
    identification_figure(result).savefig(p, dpi=dpi)
    return p
