"""The tables ``aromm identify`` prints: estimates and intervals, the error budget, the reduced model's note and the
posterior (the JSON form is :meth:`inverse.identification.Identification.to_json`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from inverse.uncertainty import budget_total

if TYPE_CHECKING:
    from inverse.identification import Identification
    from inverse.posterior import Posterior
    from inverse.uncertainty import Uncertainty


def aligned(rows: list[list[str]], right: int = 0) -> list[str]:
    """Rows of cells as lines of aligned columns, two spaces apart whatever the widths (never run together); the
    first ``right`` columns after the first are right-aligned."""
    widths = [max(len(r[j]) for r in rows) for j in range(len(rows[0]))]
    return ["  ".join(c.rjust(w) if 0 < j <= right else c.ljust(w)
                      for j, (c, w) in enumerate(zip(r, widths, strict=True))).rstrip() for r in rows]


def table(result: Identification) -> str:
    """The identification as the command prints it without ``--json``."""
    unc = result.uncertainty
    rows = [["parameter", "estimate", "std error", "rel. se", "95 % interval", "95 % HAC interval"]]
    for i, name in enumerate(unc.names):
        est, se = result.estimates[name], unc.std_error[i]
        rel = f"{100 * se / abs(est):.3g} %" if math.isfinite(se) and est else "-"
        log = " (log)" if i < len(unc.log_scale) and unc.log_scale[i] else ""
        ci = f"[{unc.lower[i]:.6g}, {unc.upper[i]:.6g}]{log}" if math.isfinite(se) else "(not identifiable)"
        hac = f"[{unc.lower_hac[i]:.6g}, {unc.upper_hac[i]:.6g}]" if math.isfinite(unc.std_error_hac[i]) else "-"
        rows.append([name, f"{est:.6g}", f"{se:.3g}", rel, ci, hac])
    lines = aligned(rows, right=3)
    lines += _budget_lines(unc)
    lines.append("the intervals include: " + "; ".join(unc.error_sources)
                 + ("" if unc.model_error or "discretisation" in unc.budget else
                    "; not the discretisation error of the voxel model" + _gap_note(result.model)
                    + " (--discretisation-check re-fits with the other discretisation, q1 ↔ fv; or state it with "
                    "--model-error)")
                 + ("" if "representativeness" in unc.budget else
                    "; not how far the sample may be from the image (--representativeness-check)"))
    noise = result.model.get("noise_by_kind")
    if isinstance(noise, Mapping):  # temperatures and humidities, each weighted by its own noise (inverse.kinds)
        kinds = ", ".join(f"{k} {float(v):.3g}{' °C' if k == 'T' else ''}" for k, v in noise.items())
        lines.append(f"criterion J = {result.criterion:.4g} (eq. 12, each residual divided by the noise of its kind, "
                     f"estimated: {kinds}), {result.evaluations} evaluations, {result.seconds:.1f} s")
    else:
        lines.append(f"criterion J = {result.criterion:.4g} °C² (eq. 12), residual std {unc.residual_std:.3g} °C, "
                     f"{result.evaluations} evaluations, {result.seconds:.1f} s")
    lines.append(f"residuals: {unc.residuals.describe()}: "
                 + ("systematic (see the warning)" if unc.residuals.systematic else "consistent with white noise"))
    for i, a in enumerate(unc.names):
        for j in range(i + 1, len(unc.names)):
            rho = unc.correlation[i, j]
            lines.append(f"correlation {a} / {unc.names[j]}: "
                         + (f"{rho:+.3f}" if math.isfinite(rho) else "undefined (a parameter is not identifiable)"))
    lines.append("model: " + ", ".join(f"{k} {v}" for k, v in result.model.items() if k in ("kind", "order"))
                 + _reduction_note(result.model))
    if result.posterior is not None:
        lines.append(_posterior_table(result.posterior))
    return "\n".join(lines)


#: What to do when a source other than the noise makes most of an interval.
REMEDIES = {"reduced model": "rebuild the model with a tighter [reduction] tolerance or a higher --order",
            "discretisation": "resolve the image finer (--refine 2 halves the gap, docs/method/finite_volumes.md)",
            "stated model error": "refine the voxel model (--refine) to lower the discretisation error",
            "segmentation": "check the threshold against the histogram (aromm segment --plot), or scan finer to narrow "
                            "the band of partial-volume voxels",
            "representativeness": "image a larger volume of the sample (aromm rev shows the spread against the size)"}


def _budget_lines(unc: Uncertainty) -> list[str]:
    """The 95 % half-width of each error source per parameter (when there is more than the noise), and one line
    when a source other than the noise makes most of an interval."""
    if len(unc.budget) < 2:
        return []
    rows = [["error budget (95 % half-width)", *unc.names]]
    rows += [[source, *(f"{h:.3g}" for h in half)] for source, half in unc.budget.items()]
    lines = aligned(rows, right=len(unc.names))
    total = budget_total(unc.budget)
    for source, half in unc.budget.items():
        share = np.asarray(half, dtype=float) / np.where(total > 0, total, np.inf)
        if source in REMEDIES and np.any(share > 0.5):
            j = int(np.argmax(share))
            lines.append(f"the {source} makes {100 * share[j]:.0f} % of the interval of {unc.names[j]}: "
                         f"{REMEDIES[source]}")
    return lines


def _gap_note(model: Mapping[str, object]) -> str:
    """Why the default discretisation row is missing (aromm.cli.identify), when it was tried."""
    gap = model.get("discretisation_gap")
    return f", {gap}" if isinstance(gap, str) else ""


def _reduction_note(model: Mapping[str, object]) -> str:
    """What the reduced model says of its own error, which the intervals do not include: its estimate over its
    training box (greedy estimate plus compression loss, °C; an estimate, not a certified bound) and whether it met
    its tolerance."""
    if model.get("kind") != "reduced" or "reference_error" not in model:
        return ""
    error = float(str(model["reference_error"]))
    met = "" if "converged" not in model else (" (met its tolerance)" if str(model["converged"]) == "1"
                                               else " (above its tolerance)")
    bound = float(str(model.get("error_bound", "nan")))
    if not math.isfinite(bound):
        return f"; its estimated error {error:.2g} °C over its box{met} (an estimate, not a bound)"
    where = "over its training grid" if model.get("method") == "krylov" else "at the scene's values"
    return f"; its certified bound {bound:.2g} °C {where}{met}, its own estimate {error:.2g} °C"


def _posterior_table(post: Posterior) -> str:
    lower, upper = post.interval
    lines = ["", f"posterior (MCMC, emcee: {post.walkers} walkers × {post.steps} steps, burn-in {post.burn}, "
                 f"noise σ {'sampled' if post.noise_std is None else f'{post.noise_std:g} °C given'})",
             ]
    rows = [["parameter", "mean", "std", "95 % credible interval", "τ (steps)", "ESS"]]
    for i, name in enumerate(post.names):
        rows.append([name, f"{post.mean[i]:.6g}", f"{post.std[i]:.3g}", f"[{lower[i]:.6g}, {upper[i]:.6g}]",
                     f"{post.autocorr_time[i]:.3g}", f"{post.effective_samples[i]:.0f}"])
    lines.extend(aligned(rows, right=2))
    for i, a in enumerate(post.names):
        for j in range(i + 1, len(post.names)):
            lines.append(f"posterior correlation {a} / {post.names[j]}: {post.correlation[i, j]:+.3f}")
    lines.append(f"acceptance {post.acceptance:.3f}, {post.evaluations} evaluations, {post.seconds:.1f} s "
                 f"({1e3 * post.seconds / max(post.evaluations, 1):.3g} ms per evaluation)")
    return "\n".join(lines)
