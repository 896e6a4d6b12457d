"""DEM commands [Hassan2019]: ``aromm dem pack|calibrate|simulate|homogenize``.

JSON shapes: calibrate -> ``{"C_t": ..., "Z": ...}`` (plus details), homogenize ->
``{"E": ...}`` (E = k_eff / k_matrix of the sphere inclusion of radius L/3), simulate ->
``{"t": [...], "mean_T": {...}}`` like ``aromm simulate``.  Progress bars go to stderr.  Each command imports the
DEM modules when it runs, so a refused option loads none (tests/test_startup.py).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import click
import numpy as np
from tqdm import tqdm

from aromm.cli.common import FORCE, FiniteFloat, echo_json
from aromm.cli.common import SEED as SEED_RANGE
from aromm.core.errors import InputError

if TYPE_CHECKING:
    from aromm.dem.packing import Packing

JSON = click.option("--json", "as_json", is_flag=True, help="JSON on stdout instead of a table.")
PARTICLES = click.option("--particles", type=click.IntRange(min=50), default=10000, show_default=True,
                         help="Number of spheres of a new packing.")
SEED = click.option("--seed", type=SEED_RANGE, default=0, show_default=True, help="Random seed of the packing.")
PACKING = click.option("--packing", "packing_path", type=click.Path(path_type=Path), default=None,
                       help="Use a packing saved by 'aromm dem pack' instead of making one.")
Z = click.option("--z", "z", type=FiniteFloat(min=1.0), default=7.5, show_default=True,
                 help="Mean coordination number of the bond network ([Hassan2019]: 7.5).")
RADIUS = click.option("--radius", type=click.Choice(["pair", "global"]), default="pair", show_default=True,
                      help="R_moy of S = C_t pi R_moy^2: the pair's mean radius or the packing's mean radius.")
QUIET = click.option("--quiet", is_flag=True, help="No progress bar.")


def _pack(particles: int, seed: int, quiet: bool, **options: float) -> Packing:
    """pack_spheres with a progress bar (largest overlap) on stderr."""
    from aromm.dem.packing import pack_spheres

    bar = tqdm(desc="packing", file=sys.stderr, disable=quiet or not sys.stderr.isatty(), leave=False)

    def report(it: int, overlap: float) -> None:
        bar.set_postfix_str(f"it {it}, max overlap {overlap:.1e}")
        bar.update(50)

    try:
        return pack_spheres(particles, np.random.default_rng(seed), progress=report, **options)  # type: ignore[arg-type]
    finally:
        bar.close()


def _packing(path: Path | None, particles: int, seed: int, box: float, quiet: bool) -> Packing:
    """The periodic packing saved at ``path`` (scaled to ``box``) or a new one of ``particles`` spheres."""
    from aromm.dem.packing import load_packing

    if path is None:
        return _pack(particles, seed, quiet, box=box)
    if not path.exists():
        raise InputError(f"--packing: {path} does not exist; give a file written by 'aromm dem pack --out'")
    packing = load_packing(path)
    if not packing.periodic:
        raise InputError(f"--packing: {path} is not periodic (save the packing before cutting it)")
    return packing.scaled(box)


@click.group("dem")
def dem() -> None:
    """Discrete-element equivalent continuum [Hassan2019]: packings, calibration, simulation, homogenisation."""


@dem.command("pack")
@PARTICLES
@SEED
@click.option("--phi", type=FiniteFloat(0.05, 0.7), default=0.64, show_default=True, help="Volume fraction.")
@click.option("--cv", type=FiniteFloat(0.0, 0.39), default=0.3, show_default=True,
              help="Coefficient of variation of the Gaussian radii.")
@click.option("--box", type=FiniteFloat(min=0, min_open=True), default=0.1, show_default=True,
              help="Side of the periodic cube (m).")
@click.option("--out", type=click.Path(path_type=Path), required=True, help="Output .npz file.")
@JSON
@QUIET
@FORCE
def pack(*, particles: int, seed: int, phi: float, cv: float, box: float, out: Path, as_json: bool,
         quiet: bool, force: bool) -> None:
    """Make a periodic dense random packing (FIRE relaxation) and save it as .npz."""
    from aromm.core.files import check_output
    from aromm.dem.packing import PACKING as PACKING_FILE

    check_output(out, PACKING_FILE, force=force)
    start = time.perf_counter()
    packing = _pack(particles, seed, quiet, phi=phi, cv=cv, box=box)
    seconds = time.perf_counter() - start
    packing.save(out)
    r = packing.radii
    info = {"particles": packing.n, "phi": packing.volume_fraction, "box": box, "mean_radius": float(r.mean()),
            "cv": float(r.std() / r.mean()), "seconds": seconds, "file": str(out)}
    if as_json:
        echo_json(info)
    else:
        click.echo("\n".join(f"{k:>12}: {v}" for k, v in info.items()))


@dem.command("calibrate")
@PARTICLES
@SEED
@PACKING
@Z
@RADIUS
@click.option("--boundary", type=click.Choice(["periodic", "slab"]), default="periodic", show_default=True,
              help="periodic: imposed gradient on the periodic network; "
                   "slab: the test of [Hassan2019, Fig. 3] on the cut box.")
@JSON
@QUIET
def calibrate(*, particles: int, seed: int, packing_path: Path | None, z: float, radius: str, boundary: str,
              as_json: bool, quiet: bool) -> None:
    """C_t such that the network conducts like the continuum [Hassan2019, eq. 7-8]."""
    from aromm.dem.calibration import calibrate as calibrate_ct

    packing = _packing(packing_path, particles, seed, 0.1, quiet)
    cal = calibrate_ct(packing, z, radius=radius, boundary=boundary)  # type: ignore[arg-type]
    if as_json:
        echo_json(cal.to_json())
    else:
        click.echo(f"C_t = {cal.c_t:.5f}  (Z = {cal.z:.3f}, Z*C_t = {cal.z * cal.c_t:.4f}, R_moy = {radius}, "
                   f"{boundary}, {packing.n} particles)")


@dem.command("homogenize")
@PARTICLES
@SEED
@PACKING
@Z
@RADIUS
@click.option("--ratio", type=FiniteFloat(min=0, min_open=True), required=True,
              help="Contrast k_inclusion / k_matrix.")
@click.option("--axes", type=click.Choice(["x", "y", "z", "xyz"]), default="xyz", show_default=True,
              help="Direction(s) of the imposed gradient; E is averaged over them.")
@click.option("--boundary", type=click.Choice(["periodic", "faces"]), default="periodic", show_default=True,
              help="periodic: cell of a cubic array (= isothermal/adiabatic faces by symmetry); "
                   "faces: cut packing with two faces at fixed T "
                   "(the set-up of [Hassan2019, § 3.2], cut layer included).")
@JSON
@QUIET
def homogenize(*, particles: int, seed: int, packing_path: Path | None, z: float, radius: str, ratio: float,
               axes: str, boundary: str, as_json: bool, quiet: bool) -> None:
    """E = k_eff / k_matrix of a sphere inclusion of radius L/3 centred in the cube [Hassan2019, § 3.2]."""
    from aromm.dem.calibration import inclusion_network, inclusion_ratio

    packing = _packing(packing_path, particles, seed, 0.1, quiet)
    net = inclusion_network(packing, z, radius=radius, boundary=boundary)  # type: ignore[arg-type]
    res = inclusion_ratio(net, ratio, axes)
    phi = res.inclusion_fraction
    maxwell = (ratio + 2 + 2 * phi * (ratio - 1)) / (ratio + 2 - phi * (ratio - 1))
    payload = {"E": res.E, "E_axes": res.E_axes, "ratio": ratio, "inclusion_fraction": phi, "maxwell": maxwell,
               "boundary": boundary, "particles": packing.n}
    if as_json:
        echo_json(payload)
    else:
        click.echo(f"E = {res.E:.5f}  (per axis {np.round(res.E_axes, 5).tolist()}; Maxwell at the same "
                   f"fraction {phi:.4f}: {maxwell:.5f})")


@dem.command("simulate")
@PARTICLES
@SEED
@PACKING
@Z
@RADIUS
@click.option("--c-t", "c_t", type=FiniteFloat(min=0, min_open=True), default=None,
              help="C_t (default: calibrated on the periodic packing).")
@click.option("--length", type=FiniteFloat(min=0, min_open=True), default=0.1, show_default=True,
              help="Cube side L (m).")
@click.option("--k", "k", type=FiniteFloat(min=0, min_open=True), default=33.0, show_default=True,
              help="Conductivity lambda, W/(m K).")
@click.option("--rho", type=FiniteFloat(min=0, min_open=True), default=7800.0, show_default=True,
              help="Density rho_c, kg/m^3.")
@click.option("--cp", type=FiniteFloat(min=0, min_open=True), default=0.9, show_default=True,
              help="Specific heat, J/(kg K) [Hassan2019, Table 1 prints 0.9].")
@click.option("--times", default="0.05,0.1,0.2", show_default=True, help="Output times (s), comma-separated.")
@click.option("--scheme", type=click.Choice(["explicit", "implicit"]), default="explicit", show_default=True,
              help="explicit: forward Euler as [Hassan2019, eq. 5]; implicit: backward Euler on the network.")
@click.option("--dt", type=FiniteFloat(min=0, min_open=True), default=None,
              help="Time step (s); explicit default 0.9 x stability limit, implicit default end/400.")
@click.option("--bins", type=click.IntRange(min=1), default=10, show_default=True,
              help="Slabs of the y profile reported as outputs y_slab<k>.")
@JSON
@QUIET
def simulate(*, particles: int, seed: int, packing_path: Path | None, z: float, radius: str, c_t: float | None,
             length: float, k: float, rho: float, cp: float, times: str, scheme: str, dt: float | None,
             bins: int, as_json: bool, quiet: bool) -> None:
    """Slab transient of [Hassan2019, § 3.1]: T(y=0) = 25 °C, T(y=L) = 100 °C, T0 = 25 °C, sides adiabatic."""
    from aromm.core.system import TimeGrid
    from aromm.core.vocabulary import FaceSpec
    from aromm.dem.calibration import calibrate as calibrate_ct
    from aromm.dem.explicit import simulate_explicit
    from aromm.dem.neighbours import build_bonds
    from aromm.dem.network import Network
    from aromm.full.solve import simulate as simulate_implicit

    try:
        t_out = np.array([float(s) for s in times.split(",") if s.strip()])
    except ValueError:
        raise InputError(f"--times: expected comma-separated numbers, got {times!r}") from None
    if (t_out.size == 0 or not np.all(np.isfinite(t_out)) or t_out[0] < 0 or t_out[-1] <= 0
            or np.any(np.diff(t_out) <= 0)):
        raise InputError(f"--times: expected finite times >= 0 s, strictly increasing, the last > 0, e.g. "
                         f"0.05,0.1,0.2; got {times!r}")
    packing = _packing(packing_path, particles, seed, length, quiet)
    bonds = build_bonds(packing, z)
    if c_t is None:
        c_t = calibrate_ct(packing, z, radius=radius, bonds=bonds).c_t  # type: ignore[arg-type]
    cut = packing.cut(packing.lower, packing.lower + packing.box)
    cut_bonds = build_bonds(cut, gap=bonds.gap_threshold)
    net = Network(cut, cut_bonds, c_t, np.zeros(cut.n, dtype=np.int64), ("matrix",), radius)  # type: ignore[arg-type]
    end = float(t_out.max()) if t_out.size else 0.0
    values = {"matrix.k": k, "matrix.c": rho * cp, "initial.T": 25.0}
    grid = TimeGrid(end, dt if (dt is not None and scheme == "implicit") else end / 400 if end > 0 else 1.0)
    system = net.system(values, boundary=(FaceSpec("y0", T=25.0), FaceSpec("y1", T=100.0)), profile=("y", bins),
                        time=grid)
    start = time.perf_counter()
    if scheme == "explicit":
        bar = tqdm(desc="explicit steps", file=sys.stderr, disable=quiet or not sys.stderr.isatty(), leave=False)

        def report(step: int, total: int) -> None:
            bar.total = total
            bar.update(step - bar.n)

        try:
            obs = simulate_explicit(system, times=t_out, dt=dt, progress=report)
        finally:
            bar.close()
    else:
        obs = simulate_implicit(system, times=t_out, progress=not quiet and sys.stderr.isatty())
    seconds = time.perf_counter() - start
    if as_json:
        echo_json({**obs.to_json(), "C_t": c_t, "scheme": scheme, "seconds": seconds, "particles": cut.n})
    else:
        names = list(obs.mean_T)
        click.echo("t (s)".rjust(8) + "".join(n.rjust(10) for n in names))
        for i, t in enumerate(obs.t):
            click.echo(f"{t:8.3g}" + "".join(f"{obs.mean_T[n][i]:10.3f}" for n in names))


COMMANDS: list[click.Command] = [dem]
