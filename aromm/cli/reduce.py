"""``aromm reduce``: build (or load from the cache) the AROMM reduced model of a scene."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import click

from aromm.cli import engine_options as engine_cli
from aromm.cli.common import REFINE, FiniteFloat, echo_json
from aromm.core.choices import EIGENSOLVERS
from aromm.engines import is_root
from aromm.scene.reduction_section import REDUCTION_METHODS as REDUCTIONS


@click.command("reduce")
@click.argument("scene", type=click.Path(path_type=Path))
@click.option("--order", type=click.IntRange(min=1), default=200, show_default=True,
              help="Reduced order ñ (number of amalgamated modes, [Chavez2020, eq. 9]).")
@click.option("--modes", type=click.IntRange(min=1), default=None,
              help="Detailed basis size Ñ (Dirichlet + Steklov modes); default 1.5 × order + 20.")
@click.option("--method", type=click.Choice(REDUCTIONS), default=None,
              help="aromm: amalgam of Dirichlet–Steklov modes; pod: POD–Galerkin baseline on the same snapshots; "
                   "greedy: POD-greedy; krylov: eigen-free rational Krylov over the scene's [reduction] bounds. "
                   "auto: krylov above 30,000 unknowns, else aromm (or when modal options are given). "
                   "Default: the scene's [reduction] method, else auto.")
@click.option("--tolerance", type=FiniteFloat(min=0.0, min_open=True), default=None,
              help="Krylov reduction: the greedy over the box stops when its estimated output error is below this "
                   "(°C; default the scene's [reduction] tolerance, else 1e-5). A Krylov option: with --method auto "
                   "it asks for krylov.")
@click.option("--certify/--no-certify", default=None,
              help="Attach (or not) the certified bound of the output error against the full model, any method "
                   "on the scipy engine, krylov on the petsc engine "
                   "(default: the scene's [reduction] certify, else below 200,000 unknowns; a Krylov model of the "
                   "46³ VER: 88-115 CPU s and 3.0-3.4 GB against 17-19 CPU s without; amalgam at order 200 about "
                   "as much as its build). --certify also makes the Krylov greedy stop on the bound (by default "
                   "below 40,000 unknowns; 250 CPU s on the 46³ VER).")
@click.option("--reference", "references", multiple=True, type=click.Path(path_type=Path),
              help="Extra reference scene on the same image (e.g. the other scenarios of [Chavez2020]); repeatable.")
@engine_cli.SOLVER
@click.option("--eigensolver", type=click.Choice(EIGENSOLVERS), default="auto", show_default=True,
              help="Modal bases by ARPACK shift-invert on a factorisation, or by LOBPCG with a multigrid "
                   "preconditioner (memory: the basis plus the preconditioner); auto picks by size. With "
                   "--engine petsc: SLEPc shift-invert, or Generalized Davidson + GAMG.")
@engine_cli.ENGINE
@engine_cli.DISCRETISATION
@click.option("--cache-dir", type=click.Path(path_type=Path), default=None,
              help="Cache folder (default $AROMM_CACHE_DIR, else ~/.cache/aromm).")
@click.option("--no-cache", is_flag=True, help="Neither read nor write the cache.")
@REFINE
@click.option("--json", "as_json", is_flag=True, help="JSON on stdout instead of a table.")
def reduce_cmd(scene: Path, order: int, *, modes: int | None, method: str | None, tolerance: float | None,
               certify: bool | None, references: tuple[Path, ...],
               solver: str, eigensolver: str, engine: str, cache_dir: Path | None, no_cache: bool, refine: int,
               as_json: bool) -> None:
    """Build the reduced model of SCENE (bases and reduced models are cached: a second run is instant).

    With --engine petsc run it under `mpiexec -n P`: every rank assembles its box of the image."""
    from aromm.api import reduce
    from aromm.cli import checks
    from aromm.core.cache import NpzCache

    solver = engine_cli.resolve(engine, solver)
    if not no_cache:
        checks.cache_folder(cache_dir)
    sc, *refs = [engine_cli.load(path, engine, refine) for path in (scene, *references)]
    cache = False if no_cache else NpzCache(cache_dir)
    settings = sc.reduction.updated(order=order, modes=modes, method=method, solver=solver, eigensolver=eigensolver,
                                    tolerance=tolerance, certify=certify)
    rom = reduce(sc, settings=settings, references=refs, cache=cache, engine=engine,
                 progress=sys.stderr.isatty() and is_root(engine))
    if not is_root(engine):
        return
    info = dict(rom.info)
    info["cache_dir"] = "" if no_cache else str(NpzCache(cache_dir).directory)
    if as_json:
        echo_json({**info, "outputs": list(rom.outputs), "parameters": sorted(rom.parameter_names)})
        return
    if info.get("method") == "krylov":
        click.echo(f"reduced model of {scene}: order ñ = {rom.order} from a rational Krylov span of "
                   f"{info.get('modes')} columns at {info.get('krylov_points')} parameter points "
                   f"({info.get('solves')} shifted solves, {info.get('solver')}), method krylov")
    else:
        click.echo(f"reduced model of {scene}: order ñ = {rom.order} from Ñ = {info.get('modes')} modes "
                   f"({info.get('n_dirichlet')} Dirichlet, {info.get('n_steklov')} Steklov incl. constants), "
                   f"method {info.get('method')}")
    if info.get("cached"):
        click.echo(f"loaded from the cache in {info['cache_dir']}")
    else:
        click.echo(f"offline build {float(info['offline_seconds']):.1f} s (bases {float(info['basis_seconds']):.1f} s"
                   f"{', cached' if info.get('basis_cached') else ''}); "
                   f"max output error on the reference case {float(info['reference_error']):.3g} °C")
    click.echo(f"outputs: {', '.join(rom.outputs)}; parameters: {', '.join(sorted(rom.parameter_names))}")
    bound = float(info.get("error_bound", float("nan")))
    where = "at worst over its training grid" if info.get("method") == "krylov" else "at the scene's values"
    from aromm.core.observables import PHI_PREFIX

    humid = any(o.startswith(PHI_PREFIX) for o in rom.outputs)
    unit = f" (°C, or relative humidity for {PHI_PREFIX} outputs)" if humid else " °C"
    click.echo(f"certified output error bound {bound:.2g}{unit} {where}" if math.isfinite(bound)
               else f"no certified error bound ({info.get('certificate', 'built without one')})")


COMMANDS: list[click.Command] = [reduce_cmd]
