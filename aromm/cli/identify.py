"""``aromm identify``: phase properties from measured face-mean temperatures [Chavez2020, § 4]."""

from __future__ import annotations

import dataclasses
import math
import sys
import time
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import click
import numpy as np
from tqdm import tqdm

from aromm.api import is_root
from aromm.cli import checks
from aromm.cli import engine_options as engine_cli
from aromm.cli.common import (
    FORCE,
    SEED,
    FiniteFloat,
    Interrupted,
    echo_json,
    refuse_order_with_full_model,
    write_extras,
)
from aromm.core.domain import training_box
from aromm.core.errors import InputError
from aromm.core.files import check_output, distinct
from aromm.core.forward_model import ForwardModel
from aromm.core.labchecks import PLAUSIBLE
from aromm.full.solve import FullModel
from aromm.scene.scene_file import assemble
from inverse import checkpoint as ckpt
from inverse.farm import FARMS, Farm
from inverse.identification import DEFAULT_ITERATIONS, DEFAULT_PARTICLES, Identification, Progress, identify
from inverse.posterior import (
    DEFAULT_WALKERS,
    Posterior,
    PosteriorWarning,
    check_walkers,
    load_emcee,
    sample_posterior,
)
from inverse.repetitions import Problem, repeated, summary
from inverse.uncertainty import Uncertainty, UncertaintyWarning, budget_total


def _model(scene: Path, source: Any, kind: str, order: int, unknowns: Mapping[str, tuple[float, float]], *,
           tty: bool, engine: str) -> tuple[ForwardModel, dict[str, object]]:
    """The forward model; a reduced one is trained over the scene's box joined with the unknowns' ranges
    (:func:`aromm.core.domain.training_box`): never asked outside its box."""
    if kind == "full":
        system = assemble(source)
        return FullModel(system), {"kind": "full", "dofs": system.n, "scene": str(scene)}
    from aromm.api import reduce

    box = training_box(source.reduction.bounds, unknowns)
    rom = reduce(source, settings=source.reduction.updated(order=order, bounds=box), progress=tty, engine=engine)
    info = {"kind": "reduced", "order": rom.order, "scene": str(scene), "engine": str(rom.info.get("engine", engine))}
    info.update({k: rom.info[k] for k in ("method", "reference_error", "tolerance", "converged", "offline_seconds",
                                          "cached", "error_bound", "certificate") if k in rom.info})
    return rom, info


def aligned(rows: list[list[str]], right: int = 0) -> list[str]:
    """Rows of cells as lines of aligned columns, two spaces apart whatever the widths (never run together); the
    first ``right`` columns after the first are right-aligned."""
    widths = [max(len(r[j]) for r in rows) for j in range(len(rows[0]))]
    return ["  ".join(c.rjust(w) if 0 < j <= right else c.ljust(w)
                      for j, (c, w) in enumerate(zip(r, widths, strict=True))).rstrip() for r in rows]


def _table(result: Identification) -> str:
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
                    "; not the discretisation error of the voxel model (--discretisation-check re-fits with the other "
                    "discretisation, q1 ↔ fv; or state it with --model-error)"))
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
            "stated model error": "refine the voxel model (--refine) to lower the discretisation error"}


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
    where = "over its training grid" if model.get("method") == "krylov" else "at the scene's values"
    certified = f", certified bound {bound:.2g} °C {where}" if math.isfinite(bound) else ""
    return f"; its estimated error {error:.2g} °C over its box{met} (an estimate, not a bound){certified}"


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


@click.command("identify")
@click.argument("scene", type=click.Path(path_type=Path))
@click.option("--measurements", "measurements_path", type=click.Path(path_type=Path), required=True,
              help="CSV t,<face>,... of measured face-mean temperatures (s, °C).")
@click.option("--column", "columns", multiple=True, metavar="COLUMN=OUTPUT",
              help="Read the CSV column COLUMN as the scene's output OUTPUT (a face or a sensor), e.g. TC1=z0 "
                   "(repeat); the columns not mapped are then ignored.")
@click.option("--time-unit", type=click.Choice(["ms", "s", "min", "h"]), default=None,
              help="Unit of the CSV's times when the file does not state it (a units row or 't (min)'); default s.")
@click.option("--temperature-unit", type=click.Choice(["C", "K"]), default=None,
              help="Unit of the CSV's temperatures when the file does not state it (K is converted to °C); "
                   "data that look like kelvin against the scene are refused until it is stated.")
@click.option("--plausible", default=None, metavar="LOW:HIGH",
              help="Plausible range of a measured temperature (°C); values outside it are refused as reading "
                   "errors.  [default: -200:1500]")
@click.option("--unknown", "unknowns", multiple=True, required=True, metavar="NAME=LOW:HIGH",
              help="An unknown parameter and its search bounds (repeat), e.g. fibre.k=0.05:1.")
@click.option("--model", "kind", type=click.Choice(["reduced", "full"]), default="reduced", show_default=True,
              help="Model evaluated by the optimiser: the reduced model (seconds) or the full one (hours).")
@click.option("--order", type=click.IntRange(min=1), default=200, show_default=True,
              help="Reduced-model order ñ (with --model reduced).")
@engine_cli.ENGINE
@engine_cli.DISCRETISATION
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of the particle swarm.")
@click.option("--particles", type=click.IntRange(min=2), default=DEFAULT_PARTICLES, show_default=True,
              help="Swarm size of the particle swarm [ClercKennedy2002].")
@click.option("--iterations", type=click.IntRange(min=0), default=DEFAULT_ITERATIONS, show_default=True,
              help="Swarm iterations before the least-squares refinement; particles × (iterations + 1) "
                   "evaluations (0: the random initial swarm only).")
@click.option("--json", "as_json", is_flag=True, help="JSON on stdout instead of a table.")
@click.option("--plot", type=click.Path(path_type=Path), default=None,
              help="Write a figure of the fit and of the convergence (e.g. fit.png).")
@click.option("--checkpoint", type=click.Path(path_type=Path), default=None,
              help="Checkpoint file (.npz) rewritten after every swarm iteration.")
@click.option("--resume", is_flag=True, help="Continue from --checkpoint when it exists.")
@click.option("--noise-std", type=FiniteFloat(min=0.0, min_open=True), default=None, metavar="S",
              help="Known standard deviation of the sensor noise (°C): compared with the residual, and the σ of "
                   "--posterior (sampled when not given).")
@click.option("--model-error", type=FiniteFloat(min=0.0, max=1.0), default=0.0, show_default=True, metavar="E",
              help="Stated relative error of the model's temperature rise (e.g. 0.02: the voxel model's "
                   "discretisation error); widens the intervals, which then say so.")
@click.option("--discretisation-check", "check_discretisation", is_flag=True,
              help="Re-fit with the same model in the other discretisation (q1 ↔ fv, built or cached like the first) "
                   "from the estimates: the shift enters the error budget as 'discretisation' (the two bracket the "
                   "voxel geometry's value).")
@click.option("--posterior", "posterior_steps", type=click.IntRange(min=2), default=None, metavar="N",
              help="Also sample the posterior of the unknowns: N steps of an emcee ensemble started at the estimates "
                   "(optional extra: pip install 'aromm[posterior]'); with --plot, a corner plot FILE_posterior.png.")
@click.option("--walkers", type=click.IntRange(min=2), default=DEFAULT_WALKERS, show_default=True,
              help="Walkers of the --posterior ensemble (at least twice the number of sampled coordinates).")
@click.option("--repeat", type=click.IntRange(min=1), default=None, metavar="N",
              help="Run N identifications (run i: swarm seed SEED + i, the measurements plus fresh noise of "
                   "--repeat-noise) and print the estimates and their spread.")
@click.option("--repeat-noise", type=FiniteFloat(min=0.0), default=0.0, show_default=True, metavar="S",
              help="Standard deviation (°C) of the Gaussian noise added to the measurements in each --repeat run.")
@click.option("--farm", type=click.Choice(FARMS), default="serial", show_default=True,
              help="Where the --repeat runs go: serial; processes (a pool on this machine); mpi (mpi4py.futures "
                   "workers: run `mpiexec -n P python -m mpi4py.futures $(which aromm) identify ...`). The model "
                   "is sent once to each worker; the results equal the serial ones bit for bit.")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Workers of the --farm (default: the CPU count, or the MPI ranks but one).")
@FORCE
def identify_cmd(*, scene: Path, measurements_path: Path, columns: tuple[str, ...], time_unit: str | None,
                 temperature_unit: str | None, plausible: str | None, unknowns: tuple[str, ...], kind: str,
                 order: int, engine: str, seed: int,
                 particles: int, iterations: int, as_json: bool, plot: Path | None, checkpoint: Path | None,
                 resume: bool, noise_std: float | None, model_error: float, check_discretisation: bool,
                 posterior_steps: int | None, walkers: int,
                 repeat: int | None, repeat_noise: float, farm: str, workers: int | None, force: bool) -> None:
    """Estimate phase properties of SCENE's material from measured face-mean and sensor temperatures.

    The criterion is [Chavez2020, eq. 12]; the model is evaluated at the measurement times.  Everything is
    checked before the model is built; the result is printed before the plot is written.  With --engine petsc
    (under `mpiexec -n P`) the ranks build the reduced model, each reading its box of the image, and rank 0
    alone identifies and prints; a model in the cache is found whichever engine built it.
    """
    refuse_order_with_full_model(kind)
    if engine == "petsc" and kind == "full":
        raise click.UsageError("--engine petsc builds the reduced model (--model reduced); the full model's "
                               "identification runs on the scipy engine")
    engine_cli.resolve(engine, "auto")
    if repeat is not None and (checkpoint is not None or posterior_steps is not None or plot is not None):
        raise click.UsageError("--repeat runs independent identifications: without --checkpoint, --posterior, --plot")
    if farm == "mpi" and engine == "petsc":
        raise click.UsageError("--farm mpi runs under mpi4py.futures, --engine petsc under plain mpiexec: build the "
                               "model first (`aromm reduce --engine petsc`; identify finds it in the cache)")
    if resume and checkpoint is None:
        raise click.UsageError("--resume needs --checkpoint FILE")
    if posterior_steps is not None:
        load_emcee()  # a missing optional extra is refused first
    source = engine_cli.load(scene, engine)
    sc = engine_cli.outline(source)
    bounds = checks.unknowns(unknowns, sc)
    reading = checks.ReadOptions(checks.parse_columns(columns), time_unit, temperature_unit,
                                 checks.parse_range(plausible, "--plausible", PLAUSIBLE))
    data = checks.measurements(measurements_path, sc, kind, bounds, reading)
    inputs = [*checks.scene_inputs(scene), (measurements_path, "the measurement file (--measurements)")]
    corner = plot.with_name(f"{plot.stem}_posterior{plot.suffix}") if plot is not None and posterior_steps else None
    distinct([(plot, "--plot"), (corner, "--plot (its corner plot)"), (checkpoint, "--checkpoint")])
    if plot is not None:
        from inverse.plotting import check_plot  # matplotlib only with --plot

        check_plot(plot, inputs=inputs, force=force)
        if corner is not None:
            check_plot(corner, inputs=inputs, force=force)
    if checkpoint is not None:
        check_output(checkpoint, ckpt.CHECKPOINT, inputs=inputs, force=force, option="--checkpoint")
        if resume and checkpoint.exists():
            ckpt.read(checkpoint)
    if posterior_steps is not None:
        try:
            check_walkers(walkers, len(bounds), sample_noise=noise_std is None)
        except InputError as err:
            raise click.BadParameter(str(err), param_hint="--walkers") from None
    if kind == "reduced":
        checks.cache_folder(None)
    tty = sys.stderr.isatty()
    other = checks.other_discretisation(sc, engine) if check_discretisation else None
    model, info = _model(scene, source, kind, order, bounds, tty=tty and is_root(engine), engine=engine)
    if not is_root(engine):
        return
    alternative = None
    if other is not None:
        alternative, alt_info = _model(scene, dataclasses.replace(source, discretisation=other), kind, order, bounds,
                                       tty=tty, engine=engine)
        info["discretisation_check"] = {"discretisation": other, **alt_info}
    if repeat is not None:
        _repeated(Problem(model, data, bounds, repeat_noise, particles, iterations, info), repeat, seed,
                  Farm(farm, workers), as_json)
        return
    bar = tqdm(total=iterations, desc="PSO", file=sys.stderr, disable=not tty, leave=False)

    def report(p: Progress) -> None:
        if p.stage == "pso":
            bar.update(p.step - bar.n)
        else:
            bar.set_description("refine")
        bar.set_postfix_str(f"J={p.criterion:.3g}")

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UncertaintyWarning)
        warnings.simplefilter("always", PosteriorWarning)
        try:
            result = identify(model, data, bounds, seed=seed, particles=particles, iterations=iterations,
                              checkpoint=checkpoint, resume=resume, progress=report, description=info,
                              noise_std=noise_std, model_error=model_error, alternative=alternative)
        except KeyboardInterrupt:
            saved = checkpoint is not None and checkpoint.exists()
            raise Interrupted(f"resume with --resume --checkpoint {checkpoint}" if saved else "") from None
        finally:
            bar.close()
        if posterior_steps is not None:
            post = sample_posterior(model, data, bounds, steps=posterior_steps, walkers=walkers, noise_std=noise_std,
                                    start=result, rng=np.random.default_rng(seed), progress=tty)
            result = dataclasses.replace(result, posterior=post)
    for w in caught:
        click.echo(f"aromm: warning: {w.message}", err=True)
    if as_json:
        echo_json(result.to_json())
    else:
        click.echo(_table(result))
    if plot is not None:
        from inverse.plotting import save_identification_plot

        extras = [("plot", lambda: save_identification_plot(result, plot))]
        if corner is not None and result.posterior is not None:
            from inverse.corner import save_posterior_plot

            posterior = result.posterior
            extras.append(("corner plot", lambda: save_posterior_plot(posterior, corner, result.uncertainty)))
        write_extras(*extras)


def _repeated(problem: Problem, repeat: int, seed: int, farm: Farm, as_json: bool) -> None:
    """``--repeat``: the runs on the farm, a row each, then the spread of the estimates."""
    start = time.perf_counter()
    results = repeated(problem, repeat, seed=seed, farm=farm)
    wall = time.perf_counter() - start
    spread = summary(results)
    if as_json:
        echo_json({"repetitions": [{"seed": seed + i, "estimates": r.estimates, "criterion": r.criterion,
                                    "evaluations": r.evaluations} for i, r in enumerate(results)],
                   "summary": spread, "farm": farm.kind, "workers": farm.workers, "noise": problem.noise,
                   "wall_seconds": wall, "model": dict(problem.description)})
        return
    names = list(spread)
    rows = [["run", "seed", *names, "J (°C²)", "evaluations"]]
    rows += [[str(i), str(seed + i), *(f"{r.estimates[n]:.6g}" for n in names), f"{r.criterion:.4g}",
              str(r.evaluations)] for i, r in enumerate(results)]
    click.echo("\n".join(aligned(rows, right=len(names) + 3)))
    for n in names:
        m = spread[n]
        click.echo(f"{n}: mean {m['mean']:.6g}, std {m['std']:.3g} ({100 * m['std'] / abs(m['mean']):.3g} %), "
                   f"range [{m['min']:.6g}, {m['max']:.6g}]")
    click.echo(f"{repeat} runs on the {farm.kind} farm in {wall:.1f} s wall (noise {problem.noise:g} °C)")


COMMANDS: list[click.Command] = [identify_cmd]
