"""Image commands: ``aromm segment`` (how a grey image of the scene became labels), ``aromm rev`` (REV study)."""

from __future__ import annotations

from pathlib import Path

import click

from aromm.cli.common import FORCE, FiniteFloat, echo_json, write_extras
from aromm.cli.engine_options import DISCRETISATION, discretisation
from aromm.cli.forward import JSON, KTOL, SCENE
from aromm.core.choices import DEFAULT_RTOL, METHODS, REV_TOLERANCE
from aromm.core.errors import InputError


@click.command("segment")
@SCENE
@click.option("--plot", type=click.Path(path_type=Path), default=None,
              help="Write the grey-level histogram with the thresholds to FILE (format from the suffix, e.g. .png).")
@FORCE
@JSON
def segment_cmd(scene: Path, *, plot: Path | None, force: bool, as_json: bool) -> None:
    """Segmentation report of SCENE's grey image (geometry.segment): thresholds used and labelled volume fractions.

    The scene's crop, down-sampling and denoising are applied as every other command applies them
    (aromm.microstructure.segmentation); the phases' volume fractions follow from the labels.
    """
    from aromm.cli.checks import scene_inputs
    from aromm.microstructure.segmentation import save_histogram
    from aromm.scene.scene_file import load_scene
    from inverse.plotting import check_plot

    if plot is not None:
        check_plot(plot, inputs=scene_inputs(scene), force=force)
    sc = load_scene(scene)
    report = sc.segmentation
    if report is None:
        raise InputError(f"{scene}: geometry: the image is a label image (no segment table): nothing was segmented")
    phases = sc.volume_fractions()
    if as_json:
        echo_json({**report.as_dict(), "phases": phases, "voxel_size": list(sc.geometry.voxel_size)})  # type: ignore[union-attr]
    else:
        click.echo(str(report))
        click.echo("phase volume fractions: " + ", ".join(f"{name} {f:.4f}" for name, f in phases.items()))
    if plot is not None:
        write_extras(("histogram plot", lambda: save_histogram(report, plot)))


def _edges(text: str | None) -> list[int] | None:
    if text is None:
        return None
    try:
        return [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise click.BadParameter(f"{text!r}: expected edges in voxels separated by commas, e.g. 8,16,32",
                                 param_hint="--edges") from None


@click.command("rev")
@SCENE
@click.option("--edges", default=None, help="Sub-volume edges in voxels, comma-separated (default: 1/8, 1/4, 3/8, "
                                            "1/2, 3/4 and all of the smallest side).")
@click.option("--positions", type=click.IntRange(min=1), default=9, show_default=True,
              help="Sub-volumes per edge: the centred cube, the 8 corners, then a 3×3×3 grid of origins.")
@click.option("--tolerance", type=FiniteFloat(min=0.0, max=1.0, min_open=True, max_open=True),
              default=REV_TOLERANCE, show_default=True,
              help="Relative spread (std/mean of k̄ over positions; max − min over boundary conditions) that makes "
                   "a volume representative.")
@click.option("--solver", type=click.Choice(METHODS), default="auto", show_default=True,
              help="Solver of the periodic cell problems (auto: geometric multigrid from 20³ voxels).")
@click.option("--rtol", type=FiniteFloat(min=0.0, max=1.0, min_open=True, max_open=True), default=DEFAULT_RTOL,
              show_default=True, help="Relative residual every cell problem must reach.")
@KTOL
@click.option("--boundaries/--no-boundaries", default=True, show_default=True,
              help="Also homogenise the largest cube under uniform flux and fixed temperatures (their spread "
                   "brackets the effective value of a non-periodic scan).")
@click.option("--plot", type=click.Path(path_type=Path), default=None,
              help="Write the REV curve (k̄ against the sub-volume edge) to FILE (format from the suffix).")
@FORCE
@JSON
@DISCRETISATION
def rev_cmd(scene: Path, *, edges: str | None, positions: int, tolerance: float, solver: str, rtol: float,
            ktol: float | None, boundaries: bool, plot: Path | None, force: bool, as_json: bool) -> None:
    """Representative-volume study of SCENE's image: apparent k̄ (and c̄) of sub-volumes of growing edge at several
    positions, their spread, the REV edge and the recommended crop [Kanit2003].

    Periodic cell problems on the multigrid solver (aromm.homogenization.representative); with --boundaries the
    spread between
    boundary conditions of the largest cube is reported too: above the tolerance, the volume is not representative.
    """
    from aromm.cli.checks import scene_inputs
    from aromm.homogenization.representative import rev, save_rev_plot
    from aromm.scene.scene_file import load_scene
    from inverse.plotting import check_plot

    chosen = _edges(edges)
    if plot is not None:
        check_plot(plot, inputs=scene_inputs(scene), force=force)
    sc = load_scene(scene, discretisation())
    study = rev(sc, chosen, positions=positions, tolerance=tolerance, method=solver, rtol=rtol, ktol=ktol,
                boundaries=boundaries)
    if as_json:
        echo_json(study.as_dict())
    else:
        click.echo(str(study))
    if plot is not None:
        write_extras(("REV plot", lambda: save_rev_plot(study, plot)))


COMMANDS: list[click.Command] = [segment_cmd, rev_cmd]
