"""Forward commands: ``aromm simulate``, ``aromm homogenize``, ``aromm measure``."""

from __future__ import annotations

import sys
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
import numpy as np

from aromm.cli import engine_options as engine_cli
from aromm.cli.common import (
    DIRECT_BYTES_PER_VOXEL,
    FORCE,
    ORDER,
    REFINE,
    SEED,
    FiniteFloat,
    echo_json,
    reduced_settings,
    refuse_order_with_full_model,
    write_extras,
)
from aromm.core.choices import BOUNDARIES, DEFAULT_RTOL, METHODS
from aromm.core.errors import InputError
from aromm.core.files import OutputKind, check_folder, check_output, signed
from aromm.engines import is_root

if TYPE_CHECKING:
    from aromm.core.observables import Observables

SCENE = click.argument("scene", type=click.Path(path_type=Path))
JSON = click.option("--json", "as_json", is_flag=True, help="JSON on stdout instead of a table.")
KTOL = click.option("--ktol", type=FiniteFloat(min=0.0, max=1.0, min_open=True, max_open=True), default=None,
                    help="Stop each multigrid solve once the algebraic relative error of k is bounded by KTOL "
                         "(CG energy-error estimate over Wiener's lower bound), instead of at --rtol; e.g. 1e-4.")
SOLVER = click.option("--solver", type=click.Choice(METHODS), default="auto", show_default=True,
                      help="Sparse linear solver (cholmod: cvxopt's supernodal Cholesky; splu; amg: pyamg + CG; "
                           "mg: geometric multigrid + CG).")


def _table(obs: Observables, rows: int = 10) -> str:
    from aromm.core.observables import PHI_PREFIX

    faces = list(obs.mean_T)
    lines = ["t (s)".rjust(10) + "".join((f"φ̄_{f.removeprefix(PHI_PREFIX)} (RH)" if f.startswith(PHI_PREFIX)
                                          else f"T̄_{f} (°C)").rjust(14) for f in faces)]
    index = np.unique(np.linspace(0, len(obs.t) - 1, min(rows, len(obs.t))).round().astype(int))
    for i in index:
        lines.append(f"{obs.t[i]:10.4g}" + "".join(f"{obs.mean_T[f][i]:14.6g}" for f in faces))
    return "\n".join(lines)


#: The fields written by ``aromm simulate --out`` (meshio names itself in the VTU header) and their collection.
FIELD = OutputKind("VTU field", signed(b"created by meshio"))
COLLECTION = OutputKind("ParaView collection", signed(b'<VTKFile type="Collection"'))


def _check_out(out: Path, scene: Path, outputs: tuple[str, ...], *, field: bool, series: int,
               force: bool) -> tuple[Path, Path]:
    """The files ``--out`` gets (observables.csv, field.vtu, ``series`` × field_<i>.vtu + field.pvd), checked
    before the simulation."""
    from aromm.cli import checks
    from aromm.core.observables import TIME_SERIES
    from aromm.core.series import series_file

    if not outputs:
        raise InputError(f"--out: {scene} has no [outputs] mean_T (nor sensors): nothing to write; list faces to "
                         "observe")
    check_folder(out, "simulation results", "--out")
    inputs = checks.scene_inputs(scene)
    csv_path = check_output(out / "observables.csv", TIME_SERIES, inputs=inputs, force=force)
    vtu_path = out / "field.vtu"
    if field:
        check_output(vtu_path, FIELD, inputs=inputs, force=force)
    for step in range(series):
        check_output(series_file(out, step), FIELD, inputs=inputs, force=force)
    if series:
        check_output(series_file(out, None), COLLECTION, inputs=inputs, force=force)
    return csv_path, vtu_path


def parse_times(text: str | None) -> tuple[float, ...] | None:
    """``--fields t1,t2,...``: finite, non-negative, strictly increasing times (s)."""
    if text is None:
        return None
    try:
        times = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise click.BadParameter(f"{text!r}: expected times in s separated by commas, e.g. 0.5,1,2",
                                 param_hint="--fields") from None
    t = np.asarray(times)
    if not (np.all(np.isfinite(t)) and np.all(t >= 0) and np.all(np.diff(t) > 0)):
        raise click.BadParameter(f"{text!r}: times must be finite, >= 0 and increasing", param_hint="--fields")
    return times


def _bound(rom: Any) -> dict[str, object]:
    """``error_bound``: the certified bound (°C) of ``|reduced − full|`` over the output times per output, or None with
    ``error_bound_note`` saying why there is none (aromm.reduction.certificate)."""
    values = rom.error_bound() if hasattr(rom, "error_bound") else None
    if values is None:
        why = rom.info.get("certificate", "built without one (the petsc engine, or certify = false)")
        return {"error_bound": None, "error_bound_note": str(why)}
    return {"error_bound": dict(zip(rom.outputs, (float(v) for v in values), strict=True))}


def _bound_line(bound: Mapping[str, object]) -> str:
    values = bound["error_bound"]
    if not isinstance(values, Mapping):
        return f"reduced model: no certified error bound ({bound.get('error_bound_note')})"
    from aromm.core.observables import PHI_PREFIX

    parts = ", ".join(f"{k} ≤ {float(v):.2g}{'' if k.startswith(PHI_PREFIX) else ' °C'}" for k, v in values.items())
    return f"reduced model: certified error against the full model at the output times: {parts}"


@click.command("simulate")
@SCENE
@click.option("--model", type=click.Choice(["full", "reduced"]), default="full", show_default=True,
              help="full: finite elements; reduced: the AROMM reduced model [Chavez2020, § 3] (built or cached).")
@ORDER
@click.option("--out", type=click.Path(path_type=Path), default=None,
              help="Folder for observables.csv and field.vtu (final field, full model, scipy engine).")
@click.option("--fields", "field_times", default=None, metavar="T1,T2,...",
              help="With --model reduced and --out: the reconstructed temperature fields at these times (s) as "
                   "field_0000.vtu, ... and field.pvd (ParaView; scipy engine).")
@click.option("--scheme", type=click.Choice(["bdf2", "euler"]), default="bdf2", show_default=True,
              help="Time stepping of the full model: BDF2 (second order) or backward Euler.")
@engine_cli.SOLVER
@engine_cli.ENGINE
@engine_cli.DISCRETISATION
@REFINE
@JSON
@FORCE
def simulate_cmd(*, scene: Path, model: str, order: int | None, out: Path | None, field_times: str | None, scheme: str,
                 solver: str, engine: str, refine: int, as_json: bool, force: bool) -> None:
    """Simulate SCENE: face-mean and sensor temperatures over time (or at steady state).

    The table (or JSON) is printed first; with --out, observables.csv is written next and the fields (field.vtu,
    or the --fields series) last, as extras: if only a field fails, the exit code is 3."""
    from aromm.api import reduce, simulate
    from aromm.cli import checks
    from aromm.core.observables import write_csv
    from aromm.core.series import write_series, write_vtu
    from aromm.scene.moisture_section import split_outputs
    from aromm.scene.scene_file import assemble

    refuse_order_with_full_model(model)
    times = parse_times(field_times)
    if times is not None and (model != "reduced" or out is None or engine != "scipy"):
        raise click.UsageError("--fields needs --model reduced, --out DIR and the scipy engine (the full model "
                               "writes its final field to DIR/field.vtu)")
    solver = engine_cli.resolve(engine, solver)
    sc = engine_cli.load(scene, engine, refine)
    field = out is not None and model == "full" and engine == "scipy"
    files = (_check_out(out, scene, tuple(sc.outputs), field=field, series=len(times or ()), force=force)
             if out is not None else None)
    if model == "reduced":
        checks.cache_folder(None)
    system = assemble(sc) if engine == "scipy" else None
    progress = sys.stderr.isatty() and is_root(engine)
    bound: dict[str, object] = {}
    if model == "reduced":
        rom = reduce(sc, settings=reduced_settings(sc, sc.reduction.updated(solver=solver), order, engine),
                     progress=progress, engine=engine, fields=times is not None)
        obs = rom.simulate()
        bound = _bound(rom)
    else:
        obs = simulate(system if system is not None else sc, fields="last" if field else False,
                       method=solver, scheme=scheme, progress=progress, engine=engine)  # type: ignore[arg-type]
    if not is_root(engine):
        return
    if as_json:
        echo_json({**split_outputs(obs.to_json()), **bound})
    else:
        click.echo(_table(obs))
        if bound:
            click.echo(_bound_line(bound), err=True)
    if files is not None:
        write_csv(obs, files[0], "observables file")
        click.echo(f"wrote {files[0]}", err=True)
        geometry = system.geometry if system is not None else None
        names = system.fields if system is not None else ("T",)
        if field and geometry is not None and obs.fields is not None:
            last = obs.fields[-1]
            write_extras(("field", lambda: write_vtu(files[1], geometry, last, names)))
        elif times is not None and geometry is not None:
            write_extras(("field series", lambda: write_series(files[0].parent, geometry, rom.iter_fields(None, times),
                                                                names=names)[-1]))


@click.command("homogenize")
@SCENE
@click.option("--boundary", type=click.Choice(BOUNDARIES), default=None,
              help="periodic (default for images): full tensor, converges to the effective property; flux: "
                   "[Chavez2020, eq. 13] (flux in, fixed T out; lower-bound type; default for mesh scenes and the "
                   "petsc engine); temperature: fixed T on both faces (mixed, exact on laminates).")
@engine_cli.SOLVER
@click.option("--rtol", type=FiniteFloat(min=0.0, max=1.0, min_open=True, max_open=True), default=DEFAULT_RTOL,
              show_default=True, help="Relative residual ‖b − A x‖/‖b‖ every solve must reach (scipy engine).")
@KTOL
@engine_cli.ENGINE
@engine_cli.DISCRETISATION
@REFINE
@JSON
def homogenize_cmd(scene: Path, *, boundary: str | None, solver: str, rtol: float, ktol: float | None, engine: str,
                   refine: int, as_json: bool) -> None:
    """Effective conductivity tensor (W/(m K)) and mean capacity (J/(m³ K)) of SCENE's material; with a [moisture]
    section also the effective heat and moisture transport (a 2 × 2 flux matrix per axis) and the mean moisture
    capacity ξ̄ (kg/m³), by the same boundary (periodic: scipy engine, q1).

    Solvers: mg (geometric multigrid CG, matrix-free, ~200 B/voxel; the default above 20³ voxels), cholmod and
    splu (direct), amg (pyamg + CG); with the petsc engine gamg or mumps.
    """
    from aromm.api import default_boundary, homogenize, mean_capacity
    from aromm.homogenization.cell_problems import CellResult, effective_conductivity
    from aromm.scene.geometry import VoxelGeometry
    from aromm.scene.scene_file import REFINE_BYTES_PER_VOXEL

    solver = engine_cli.resolve(engine, solver)
    direct = solver in ("cholmod", "splu")
    sc = engine_cli.load(scene, engine, refine, DIRECT_BYTES_PER_VOXEL if direct else REFINE_BYTES_PER_VOXEL)
    capacities = all(ph.c is not None for ph in sc.phases)
    image = sc.geometry if engine == "scipy" and isinstance(sc.geometry, VoxelGeometry) else None
    boundary = boundary or default_boundary(sc, engine)
    moisture = _moisture(sc, engine, image is not None, solver, boundary)  # collective on petsc, its notes once
    if image is None:
        result = CellResult(homogenize(sc, boundary=boundary, method=solver, engine=engine), boundary, solver)
    else:
        result = effective_conductivity(sc, boundary=boundary, method=solver, rtol=rtol, ktol=ktol)
    c = mean_capacity(sc, engine) if capacities else None
    if not is_root(engine):
        return
    k = result.k
    shape = list(image.shape) if image is not None else None
    if as_json:
        echo_json({"k": k, "c": c, "boundary": boundary, "solver": result.method, "iterations": result.iterations,
                   "cpu_seconds": result.cpu_seconds, "shape": shape, **({"moisture": moisture} if moisture else {})})
        return
    click.echo(f"{boundary} boundary, solver {result.method}"
               + (f", {'×'.join(map(str, shape))} voxels" if shape else ", mesh")
               + (f", CG iterations {result.iterations}" if result.method == "mg" else ""))
    click.echo("k̄ (W/(m K)):")
    for row in k:
        click.echo("  " + "  ".join(f"{v:12.6g}" for v in row))
    click.echo(f"c̄ (J/(m³ K)): {c:.6g}" if c is not None else "c̄: (a phase has no c)")
    if moisture:
        probe = {"temperature": "fixed (T, φ) on the two faces of each axis",
                 "flux": "a heat, then a water flux in through one face of each axis, (T, φ) fixed on the other",
                 "periodic": "the periodic cell, per axis (the off-diagonal blocks in --json: tensor)"}[
                     moisture["boundary"]]
        click.echo(f"heat and moisture transport, {probe} (rows: heat flux W/m², moisture flux kg/(m² s); columns: "
                   "per K/m, per unit φ per m):")
        for name, matrix in zip("xyz", moisture["transport"], strict=True):
            click.echo(f"  {name}: " + "; ".join("  ".join(f"{v:12.6g}" for v in row) for row in matrix))
        click.echo(f"ξ̄ (kg/m³): {moisture['xi']:.6g}")


def _moisture(sc: Any, engine: str, voxels: bool, solver: str, boundary: str) -> dict[str, Any] | None:
    """The homogenised heat and moisture transport of a ``[moisture]`` scene (a voxel image on the scipy engine;
    :mod:`aromm.homogenization.moisture_cells`) by ``boundary``'s cell problem (periodic: Q1, the whole tensor too;
    finite volumes take the fixed-value probe instead, said); on the petsc engine (collective) the probes
    ``temperature`` and ``flux``, by boxes (:func:`aromm.engines.petsc.homogenization.moisture_transport`).  None
    without moisture (said on a mesh scene, which has some)."""
    if getattr(sc, "moisture", None) is None:
        return None
    if engine == "petsc":  # the probes (periodic refused, as for k̄)
        from aromm.engines.petsc import homogenization as petsc_cells

        return {"transport": petsc_cells.moisture_transport(sc, boundary, solver).tolist(),
                "xi": petsc_cells.mean_moisture_capacity(sc), "boundary": boundary}
    if not voxels:
        click.echo("aromm: note: the moisture transport is homogenised on voxel images only: k̄ and c̄ below are the "
                   "thermal ones", err=True)
        return None
    from aromm.homogenization.moisture_cells import mean_moisture_capacity, moisture_transport, periodic_transport

    probe = boundary
    if boundary == "periodic" and sc.discretisation != "q1":
        click.echo("aromm: note: the periodic cell of the moisture transport is solved in q1: in finite volumes it is "
                   "given by the fixed-value probe (--boundary temperature)", err=True)
        probe = "temperature"
    if probe == "periodic":
        tensor = periodic_transport(sc, _direct(solver))
        return {"transport": [tensor[i, i].tolist() for i in range(3)], "tensor": tensor.tolist(),
                "xi": mean_moisture_capacity(sc), "boundary": probe}
    return {"transport": moisture_transport(sc, _direct(solver), probe).tolist(), "xi": mean_moisture_capacity(sc),
            "boundary": probe}


@click.command("measure")
@SCENE
@click.option("--homogeneous", is_flag=True, required=True,
              help="Use the homogeneous orthotropic model (k̄ by eq. 13, c̄ by eq. 14), as [Chavez2020] does.")
@click.option("--conductivity", type=click.Choice(("scenario", *BOUNDARIES)), default="scenario", show_default=True,
              help="How k̄ is obtained. scenario: eq. 13 under SCENE's own faces [Chavez2020, § 4.2] (the twin "
                   "then has the sample's steady face means); flux, temperature: as `aromm homogenize --boundary`.")
@click.option("--noise", type=FiniteFloat(min=0.0), default=0.0, show_default=True,
              help="Standard deviation of Gaussian noise added to every value (°C).")
@click.option("--noise-phi", type=FiniteFloat(min=0.0), default=0.0, show_default=True,
              help="Standard deviation of Gaussian noise added to every relative humidity (a [moisture] scene's "
                   "phi:<face> outputs, as a fraction).")
@click.option("--seed", type=SEED, default=0, show_default=True, help="Seed of the noise.")
@click.option("--perturb", type=FiniteFloat(min=-1.0, min_open=True), default=0.0, show_default=True,
              help="Relative change of every homogeneous property ([Chavez2020]'s +2 % study: 0.02).")
@click.option("--out", type=click.Path(path_type=Path), required=True, help="CSV file t,<face>,...")
@engine_cli.SOLVER
@engine_cli.ENGINE
@engine_cli.DISCRETISATION
@JSON
@FORCE
def measure_cmd(*, scene: Path, homogeneous: bool, conductivity: str, noise: float, noise_phi: float, seed: int,
                perturb: float,
                out: Path, solver: str, engine: str, as_json: bool, force: bool) -> None:
    """Synthetic measurements: mean surface temperatures of SCENE's homogeneous model.

    With --engine petsc (under `mpiexec -n P`) the ranks compute k̄ and c̄ of the image by boxes; rank 0 then
    simulates the homogeneous twin (one element across each unloaded axis: small) and writes the file."""
    from aromm.api import fluxmetric, homogenize, mean_capacity
    from aromm.cli import checks
    from aromm.core.observables import TIME_SERIES
    from aromm.homogenization.synthetic import homogeneous_measurements
    from inverse.measurements import save_measurements

    solver = engine_cli.resolve(engine, solver)
    source = engine_cli.load(scene, engine)
    sc = engine_cli.outline(source)
    if sc.time is None:
        raise InputError(f"{scene}: [time]: measurements need a transient scene; add [time] with end and dt (s)")
    if not sc.outputs:
        raise InputError(f"{scene}: [outputs] mean_T: no face to measure; list faces, e.g. mean_T = [\"z0\", \"z1\"]")
    check_output(out, TIME_SERIES, inputs=checks.scene_inputs(scene), force=force)
    moisture = _moisture_twin(sc, conductivity, solver) if sc.moisture is not None else None
    if moisture is not None:
        k = moisture.pop("k") * np.eye(3)
    elif conductivity == "scenario":
        probe = fluxmetric(source, method=solver, engine=engine)
        k = probe.k * np.eye(3)  # isotropic twin = orthotropic one along the loaded axis
    else:
        k = homogenize(source, boundary=conductivity, method=solver, engine=engine)
    c = mean_capacity(source, engine)
    if not is_root(engine):
        return
    data = homogeneous_measurements(sc, k, c, perturbation=perturb, method=solver if engine == "scipy" else "auto",
                                    moisture=moisture)
    k, c = k * (1.0 + perturb), c * (1.0 + perturb)
    twin = None if moisture is None else {n: v * (1.0 + perturb) for n, v in moisture.items()}
    if noise > 0 or noise_phi > 0:
        data = data.with_noise(noise, np.random.default_rng(seed), noise_phi)
    save_measurements(data, out)
    summary = {"out": str(out), "conductivity": conductivity, "k": k, "c": c, "noise": noise, "seed": seed,
               "times": len(data.t), "engine": engine,
               **({} if twin is None else {"moisture": twin, "noise_phi": noise_phi})}
    if as_json:
        echo_json(summary)
    else:
        if twin is not None:
            click.echo(f"coupled twin: k = {k[0, 0]:.5g} W/(m K), c̄ = {c:.5g} J/(m³ K), "
                       + ", ".join(f"{n} = {v:.5g}" for n, v in twin.items()))
        elif conductivity == "scenario":
            click.echo(f"k̄_{probe.axis * 2} = {k[0, 0]:.5g} W/(m K) (eq. 13 under the scene's faces), "
                       f"c̄ = {c:.5g} J/(m³ K)")
        else:
            click.echo(f"k̄ = diag({k[0, 0]:.5g}, {k[1, 1]:.5g}, {k[2, 2]:.5g}) W/(m K), c̄ = {c:.5g} J/(m³ K)")
        click.echo(f"wrote {len(data.t)} times × {len(data.faces)} faces to {out}")


def _direct(solver: str) -> str:
    """The steady solver of the moisture cell problems (assembled: a factorisation asked for, else auto)."""
    return solver if solver in ("cholmod", "splu") else "auto"


def _moisture_twin(sc: Any, conductivity: str, solver: str) -> dict[str, float]:
    """A [moisture] scene's homogeneous twin (aromm.homogenization.synthetic.moisture_twin): k, xi, D_phi and delta_p
    from the effective transport along the loaded axis (the fixed-value probe) and ξ̄; refused where the twin would
    not be exact (a moisture condition on a face across another axis, another --conductivity)."""
    from aromm.core.vocabulary import loaded_axis
    from aromm.homogenization.moisture_cells import mean_moisture_capacity, moisture_transport
    from aromm.homogenization.synthetic import moisture_twin

    if conductivity not in ("scenario", "temperature"):
        raise InputError(f"{sc.where}moisture: the coupled twin takes the effective transport of the fixed-value "
                         "probe along the loaded axis; --conductivity scenario (the default) or temperature")
    axis = loaded_axis(sc.boundary, sc.size)
    faces = {*sc.moisture.fixed_phi, *sc.moisture.vapour, *sc.moisture.flux}
    across = sorted(f for f in faces if f[0] != "xyz"[axis])
    if across:
        raise InputError(f"{sc.where}boundary.{across[0]}: a moisture condition across the loaded axis "
                         f"{'xyz'[axis]}; the homogeneous twin is one-dimensional along it")
    k, values = moisture_twin(moisture_transport(sc, _direct(solver))[axis], sc.moisture.state)
    return {"k": k, "xi": mean_moisture_capacity(sc), **values}


COMMANDS: list[click.Command] = [simulate_cmd, homogenize_cmd, measure_cmd]
