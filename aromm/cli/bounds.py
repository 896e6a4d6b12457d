"""``aromm bounds``: every effective-conductivity model and bound of [GarnierDanes] for one material."""

from __future__ import annotations

import click

from aromm.cli.common import echo_json


@click.command("bounds")
@click.option("--phi", type=float, required=True, help="Filler volume fraction, in (0, pi/6] (simple-cubic cell).")
@click.option("--ratio", type=float, required=True, help="Conductivity ratio R = lambda_f/lambda_m > 0.")
@click.option("--contact", type=float, default=0.0, show_default=True,
              help="Dimensionless contact resistance C = R_c lambda_m / a >= 0 (a: sphere radius).")
@click.option("--B", "cell_b", type=float, default=None,
              help="Cell parameter B = b/a - 1 >= 0 for the wall bounds [default: from phi, "
                   "phi = pi/(6 (1+B)^3)].")
@click.option("--xi", type=float, default=None,
              help="Microstructure parameter of the Torquato-Rintoul bounds, in [0, 1] "
                   "[default: zeta2 of the simple-cubic array at phi].")
@click.option("--mesh-size", type=float, default=0.3, show_default=True,
              help="Element size / a of the coarse quadratic finite-element meshes computed on demand for "
                   "wall_1a (E_II) and wall_1b (E_1bot), a few seconds; wall_1a/wall_1b within ~0.3 % at 0.3 "
                   "(benchmarks/bounds_fem.py).")
@click.option("--json", "as_json", is_flag=True, help="JSON on stdout: one key per model, E = lambda_eff/lambda_m.")
def bounds(*, phi: float, ratio: float, contact: float, cell_b: float | None, xi: float | None, mesh_size: float,
           as_json: bool) -> None:
    """Every analytical model and bound of [GarnierDanes], E = lambda_eff/lambda_m.

    Classical models use phi and the ratio; the wall-insertion bounds use the simple-cubic cell
    (B, C, D = 1/ratio); wall_1a and wall_1b solve two small finite-element problems with gmsh
    and scikit-fem (absent, null in JSON, for touching spheres B = 0).
    """
    from aromm.bounds.domain import PHI_MAX_SC, checked
    from aromm.bounds.summary import MODEL_KEYS, ROLE, every_model, material

    checked("--phi (filler volume fraction)", phi, 0.0, PHI_MAX_SC, low_open=True)
    checked("--ratio (lambda_f/lambda_m)", ratio, 0.0, low_open=True)
    checked("--contact (C = R_c lambda_m / a)", contact, 0.0)
    if cell_b is not None:
        checked("--B (b/a - 1)", cell_b, 0.0)
    if xi is not None:
        checked("--xi", xi, 0.0, 1.0)
    checked("--mesh-size (element size / a)", mesh_size, 0.0, 1.0, low_open=True)
    mat = material(phi, ratio, contact, cell_b, xi)

    def note(step: str) -> None:
        if not as_json:
            click.echo(f"finite elements: {step} ...", err=True)

    values = every_model(mat, mesh_size=mesh_size, progress=note)
    if as_json:
        echo_json(values)
        return
    click.echo(f"phi = {mat.phi:.6g}   ratio = {mat.kappa:.6g} (D = {mat.D:.6g})   C = {mat.contact:.6g}   "
               f"B = {mat.B:.6g}   xi = {mat.xi:.6g}")
    click.echo(f"{'model':<24}{'E = lambda_eff/lambda_m':>24}   role")
    for key in MODEL_KEYS:
        value = values[key]
        shown = "n/a (B = 0)" if value is None else f"{value:.6g}"
        click.echo(f"{key:<24}{shown:>24}   {ROLE[key]}")


COMMANDS: list[click.Command] = [bounds]
