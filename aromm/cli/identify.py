"""``aromm identify``: phase properties from measured face-mean temperatures [Chavez2020, § 4].

The module declares the command from light modules only (:mod:`aromm.core.choices`, :mod:`inverse.defaults`): a
refused option or ``--help`` loads no solver; the command imports what it runs when it runs (issue 37, item 4).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import sys
import time
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
import numpy as np
from tqdm import tqdm

from aromm.cli import engine_options as engine_cli
from aromm.cli.common import (
    FORCE,
    ORDER,
    SEED,
    FiniteFloat,
    Interrupted,
    echo_json,
    reduced_settings,
    refuse_order_with_full_model,
    write_extras,
)
from aromm.core.errors import InputError, NumericalError
from aromm.engines import is_root
from inverse.defaults import DEFAULT_ITERATIONS, DEFAULT_PARTICLES, DEFAULT_WALKERS
from inverse.farm import FARMS, Farm

log = logging.getLogger(__name__)

if TYPE_CHECKING:
    from aromm.core.forward_model import ForwardModel
    from aromm.scene.scene_file import Scene
    from inverse.identification import Identification, Progress
    from inverse.repetitions import Problem


def _model(scene: Path, source: Any, kind: str, order: int | None, unknowns: Mapping[str, tuple[float, float]], *,
           tty: bool, engine: str) -> tuple[ForwardModel, dict[str, object]]:
    """The forward model; a reduced one is trained over the scene's box joined with the unknowns' ranges
    (:func:`aromm.core.domain.training_box`): never asked outside its box."""
    from aromm.core.domain import training_box
    from aromm.full.solve import FullModel
    from aromm.scene.scene_file import assemble

    if kind == "full":
        system = assemble(source)
        return FullModel(system), {"kind": "full", "dofs": system.n, "scene": str(scene)}
    from aromm.api import reduce

    box = training_box(source.reduction.bounds, unknowns)
    settings = reduced_settings(source, source.reduction.updated(bounds=box), order, engine)
    rom = reduce(source, settings=settings, progress=tty, engine=engine)
    info = {"kind": "reduced", "order": rom.order, "scene": str(scene), "engine": str(rom.info.get("engine", engine))}
    info.update({k: rom.info[k] for k in ("method", "reference_error", "tolerance", "converged", "offline_seconds",
                                          "cached", "error_bound", "certificate") if k in rom.info})
    return rom, info


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
@ORDER
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
@click.option("--discretisation-gap/--no-discretisation-gap", "discretisation_gap", default=True, show_default=True,
              help="Add the discretisation's share to the budget, cheaply: the factor on the unknown phase "
                   "conductivities that gives the other discretisation (q1 ↔ fv) the model's fluxmetric k̄ at the "
                   "estimates (5-7 steady solves; a voxel scene heated on one face and cooled on the opposite one, on "
                   "the scipy engine; --discretisation-check re-fits instead).")
@click.option("--segmentation-check", "check_segmentation", is_flag=True,
              help="For a grey image thresholded once: re-fit with the same model on the image thresholded by "
                   "another standard method (Li's for Otsu's, Otsu's for a given threshold; one more model built or "
                   "cached): the shift enters the error budget as 'segmentation'.")
@click.option("--representativeness-check", "check_representativeness", is_flag=True,
              help="Estimate how far a sample's k̄ and c̄ may be from the image's (the spread of its eight octants' "
                   "k̄ along the loaded axis and c̄, scaled to the whole image) and add the resulting spread of the "
                   "unknown phase conductivities and capacities to the error budget as 'representativeness' (in "
                   "quadrature; a voxel scene; cell problems at the estimates: 8 octants, 64 quarter blocks, the whole "
                   "image and 2 per unknown conductivity).")
@click.option("--posterior", "posterior_steps", type=click.IntRange(min=2), default=None, metavar="N",
              help="Also sample the posterior of the unknowns: N steps of each of the --walkers walkers of an emcee "
                   "ensemble started at the estimates, so N × walkers model evaluations (N = 10000 with 32 walkers: "
                   "320,000), of which the steps after the burn-in are the samples (optional extra: pip install "
                   "'aromm[posterior]'); with --plot, a corner plot FILE_posterior.png.")
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
                 order: int | None, engine: str, seed: int,
                 particles: int, iterations: int, as_json: bool, plot: Path | None, checkpoint: Path | None,
                 resume: bool, noise_std: float | None, model_error: float, check_discretisation: bool,
                 discretisation_gap: bool, check_segmentation: bool, check_representativeness: bool,
                 posterior_steps: int | None, walkers: int,
                 repeat: int | None, repeat_noise: float, farm: str, workers: int | None, force: bool) -> None:
    """Estimate phase properties of SCENE's material from measured face-mean and sensor temperatures.

    The criterion is [Chavez2020, eq. 12]; the model is evaluated at the measurement times.  Everything is
    checked before the model is built; the result is printed before the plot is written.  With --engine petsc
    (under `mpiexec -n P`) the ranks build the reduced model, each reading its box of the image, and rank 0
    alone identifies and prints; a model in the cache is found whichever engine built it.
    """
    from aromm.cli import checks
    from aromm.core.files import check_output, distinct
    from aromm.core.labchecks import PLAUSIBLE
    from inverse import checkpoint as ckpt
    from inverse.identification import identify
    from inverse.posterior import PosteriorWarning, check_walkers, load_emcee, sample_posterior
    from inverse.repetitions import Problem
    from inverse.uncertainty import UncertaintyWarning

    refuse_order_with_full_model(kind)
    if engine == "petsc" and kind == "full":
        raise click.UsageError("--engine petsc builds the reduced model (--model reduced); the full model's "
                               "identification runs on the scipy engine")
    engine_cli.resolve(engine, "auto")
    if repeat is not None and (checkpoint is not None or posterior_steps is not None or plot is not None
                               or check_representativeness or check_discretisation or check_segmentation):
        raise click.UsageError("--repeat runs independent identifications: without --checkpoint, --posterior, --plot, "
                               "--discretisation-check, --segmentation-check, --representativeness-check")
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
    if check_representativeness:
        _check_representativeness(sc, bounds, engine)
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
    segmented = checks.other_segmentation(scene, sc, engine) if check_segmentation else None
    model, info = _model(scene, source, kind, order, bounds, tty=tty and is_root(engine), engine=engine)
    if not is_root(engine):
        return
    alternatives = {}
    if other is not None:
        alternatives["discretisation"], alt_info = _model(scene, dataclasses.replace(source, discretisation=other),
                                                          kind, order, bounds, tty=tty, engine=engine)
        info["discretisation_check"] = {"discretisation": other, **alt_info}
    if segmented is not None:
        rethresholded, (method, threshold) = segmented
        alternatives["segmentation"], alt_info = _model(scene, rethresholded, kind, order, bounds, tty=tty,
                                                        engine=engine)
        info["segmentation_check"] = {"method": method, "threshold": threshold, **alt_info}
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
                              noise_std=noise_std, model_error=model_error, alternatives=alternatives)
        except KeyboardInterrupt:
            saved = checkpoint is not None and checkpoint.exists()
            raise Interrupted(f"resume with --resume --checkpoint {checkpoint}" if saved else "") from None
        finally:
            bar.close()
        if posterior_steps is not None:
            post = sample_posterior(model, data, bounds, steps=posterior_steps, walkers=walkers, noise_std=noise_std,
                                    start=result, rng=np.random.default_rng(seed), progress=tty)
            result = dataclasses.replace(result, posterior=post)
    if discretisation_gap and not check_discretisation:
        result = _discretisation_gap(result, sc, engine)
    if check_representativeness:
        result = _representativeness(result, sc)
    for w in caught:
        click.echo(f"aromm: warning: {w.message}", err=True)
    if as_json:
        echo_json(result.to_json())
    else:
        from aromm.cli.identify_report import table

        click.echo(table(result))
    if plot is not None:
        from inverse.plotting import save_identification_plot

        extras = [("plot", lambda: save_identification_plot(result, plot))]
        if corner is not None and result.posterior is not None:
            from inverse.corner import save_posterior_plot

            posterior = result.posterior
            extras.append(("corner plot", lambda: save_posterior_plot(posterior, corner, result.uncertainty)))
        write_extras(*extras)


def _check_representativeness(scene: Scene, bounds: Mapping[str, Any], engine: str) -> None:
    """Refuse ``--representativeness-check`` before any work where it cannot run."""
    from aromm.homogenization.representativeness import phase_unknowns
    from aromm.scene.geometry import VoxelGeometry

    if engine == "petsc" or not isinstance(scene.geometry, VoxelGeometry):
        raise click.UsageError("--representativeness-check halves a voxel image held whole: a voxel scene on the "
                               "scipy engine")
    try:
        phase_unknowns(scene, bounds)
    except InputError as err:
        raise click.BadParameter(str(err), param_hint="--representativeness-check") from None


def _representativeness(result: Identification, scene: Scene) -> Identification:
    """``--representativeness-check``: the octants' spread at the estimates (aromm.homogenization.representativeness)
    added to the budget, and recorded in the result's model description."""
    from aromm.core.vocabulary import loaded_axis
    from aromm.homogenization.representativeness import half_widths, representativeness
    from inverse.uncertainty import with_source

    unc = result.uncertainty
    rep = representativeness(scene, dict(result.estimates), loaded_axis(scene.boundary, scene.size))
    decay = f"{rep.decay:.3g} measured" if rep.decay is not None else f"{math.sqrt(8):.3g} assumed"
    log.info("representativeness: octants' k̄ spread %.3g, the image's %.3g (decay %s per eightfold volume); c̄ %.3g",
             rep.octant_spread_k, rep.spread_k, decay, rep.spread_c)
    uncertainty = with_source(unc, "representativeness", half_widths(rep.half, unc.names, unc.estimates))
    return dataclasses.replace(result, uncertainty=uncertainty,
                               model={**result.model, "representativeness_check": rep.as_dict()})


#: The cache kind of identify's default discretisation row (aromm.core.cache.KINDS).
GAP_KIND = "discretisation-gap"


def _discretisation_gap(result: Identification, scene: Scene, engine: str) -> Identification:
    """The default discretisation row (aromm.homogenization.discretisation_gap) added to the budget, or why it is
    not, recorded in the result's model description either way; kept in the cache (``discretisation-gap``) at
    estimates rounded to six digits, so that a repeated identification does not solve again."""
    from aromm.core.cache import NpzCache
    from aromm.homogenization.discretisation_gap import DiscretisationGap, discretisation_gap
    from aromm.homogenization.representativeness import half_widths
    from aromm.scene.geometry import VoxelGeometry
    from inverse.uncertainty import with_source

    unc = result.uncertainty
    if engine != "scipy" or not isinstance(scene.geometry, VoxelGeometry):
        why = "the petsc engine holds no whole image" if engine != "scipy" else "a mesh scene has one discretisation"
        return dataclasses.replace(result, model={**result.model, "discretisation_gap": f"not estimated: {why}"})
    key, store = gap_key(scene, result.estimates), NpzCache()
    found = store.load(GAP_KIND, key) if key is not None else None
    try:
        gap = DiscretisationGap.from_arrays(found) if found is not None else \
            discretisation_gap(scene, dict(result.estimates))
    except (InputError, NumericalError) as err:
        log.info("discretisation gap not estimated: %s", err)
        return dataclasses.replace(result, model={**result.model, "discretisation_gap": f"not estimated: {err}"})
    if found is None and key is not None:
        try:
            store.save(GAP_KIND, key, gap.arrays())
        except OSError as err:  # a read-only cache: the row is there, only the next run recomputes it
            log.info("discretisation gap not cached: %s", err)
    log.info("discretisation gap%s: fluxmetric k̄ %.5g (%s) against %.5g (%s), matched by %.4g × the unknown "
             "conductivities, %.2g CPU s", " (from the cache)" if found is not None else "", gap.k_model,
             gap.discretisation, gap.k_other, gap.other, gap.scale, gap.seconds)
    uncertainty = with_source(unc, "discretisation", half_widths(gap.half, unc.names, unc.estimates))
    return dataclasses.replace(result, uncertainty=uncertainty, model={
        **result.model, "discretisation_gap": {**gap.as_dict(), "cached": found is not None}})


def gap_key(scene: Scene, estimates: Mapping[str, float]) -> str | None:
    """The cache key of the discretisation row of ``scene`` at the ``estimates`` (rounded as the row computes them):
    the scene's physics key with the estimates' names as its box (aromm.reduction.model_key.scene_physics_key: the
    image, the phases, faces and discretisation) and the rounded estimates; None where the scene has no such key."""
    from aromm.core.cache import content_key
    from aromm.homogenization.discretisation_gap import rounded
    from aromm.reduction.model_key import scene_physics_key

    physics = scene_physics_key(scene, frozenset(estimates))
    if physics is None:
        return None
    return content_key("discretisation gap", 1, physics, sorted(rounded(estimates).items()))


def _repeated(problem: Problem, repeat: int, seed: int, farm: Farm, as_json: bool) -> None:
    """``--repeat``: the runs on the farm, a row each, then the spread of the estimates."""
    from aromm.cli.identify_report import aligned
    from inverse.repetitions import repeated, summary

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
