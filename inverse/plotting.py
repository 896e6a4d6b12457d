"""Figures of an identification: measured vs fitted face means, and convergence of the criterion.

Drawn with matplotlib's object API on an Agg canvas (no pyplot, no global backend change).
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Sequence
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from aromm.core.errors import InputError
from aromm.core.files import Input, OutputKind, atomic_path, check_output, signed
from inverse.identification import Identification

#: A figure written by matplotlib: its PNG, PDF, SVG, PS and EPS files name it as their producer; the other
#: formats (jpg, tif, webp, gif, avif, svgz, raw, rgba) carry no producer and are replaced only with --force.
PLOT = OutputKind("figure", signed(b"matplotlib"))


def check_plot(path: str | os.PathLike[str], *, inputs: Sequence[Input] = (), force: bool = False,
               option: str = "--plot") -> Path:
    """``path`` if a figure can be written there (:func:`aromm.core.files.check_output`) in a format matplotlib
    knows from its suffix; InputError naming ``option`` and the supported formats otherwise."""
    p = Path(path)
    formats = sorted(FigureCanvasAgg(Figure()).get_supported_filetypes())
    if p.suffix.lower().lstrip(".") not in formats:
        raise InputError(f"{option}: {p}: unsupported figure format {p.suffix or '(no suffix)'!r}; "
                         f"supported suffixes: {', '.join('.' + f for f in formats)}")
    return check_output(p, PLOT, inputs=inputs, force=force, option=option)


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
    p = Path(path)
    with atomic_path(p, "plot") as tmp:
        try:
            identification_figure(result).savefig(tmp, dpi=dpi, format=p.suffix.lstrip(".").lower() or None)
        except (RuntimeError, ValueError) as err:  # e.g. .pgf without a TeX installation
            raise InputError(f"{p}: matplotlib could not write the figure ({err})") from None
    return p
