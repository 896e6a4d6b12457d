"""What every command checks before its expensive work (issue 10): inputs listed, unknowns and measurements
against the scene as read from its file (no assembly), the cache folder.

A bad ``--unknown`` or measurement CSV is refused in the time it takes to read the scene file and its image,
not after a reduced-model build (tests/test_faults.py times it on the shipped wood scene).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import click
import numpy as np

from aromm.core.cache import ENV_VAR, NpzCache
from aromm.core.clock import TIME_OFFSET
from aromm.core.errors import InputError
from aromm.core.files import Input, check_folder
from aromm.core.labchecks import PLAUSIBLE, fahrenheit_suspect, kelvin_suspect
from aromm.core.labcsv import read_lab_csv
from aromm.core.observables import PHI_PREFIX
from aromm.core.vocabulary import is_positive
from aromm.scene.model_section import refusal, with_discretisation
from aromm.scene.scene_file import Scene, read_toml, scene_files, scene_from_dict
from aromm.scene.sensors import output_names
from inverse.identification import bounds_problem
from inverse.measurements import Measurements

Bounds = dict[str, tuple[float, float]]


@dataclass(frozen=True)
class ReadOptions:
    """How to read a laboratory CSV (``--column``, ``--time-unit``, ``--temperature-unit``, ``--plausible``)."""

    columns: Mapping[str, str] = field(default_factory=dict)
    time_unit: str | None = None
    temperature_unit: str | None = None
    plausible: tuple[float, float] = PLAUSIBLE


def parse_columns(texts: Sequence[str]) -> dict[str, str]:
    """``--column SOURCE=OUTPUT`` (repeatable): a column of the file read as one of the scene's outputs."""
    out: dict[str, str] = {}
    for text in texts:
        source, eq, target = (s.strip() for s in text.partition("="))
        if not (eq and source and target):
            raise click.BadParameter(f"{text!r}: expected FILE_COLUMN=OUTPUT, e.g. TC1=z0", param_hint="--column")
        if source in out:
            raise click.BadParameter(f"column {source!r} is mapped twice", param_hint="--column")
        out[source] = target
    return out


def parse_range(text: str | None, option: str, default: tuple[float, float]) -> tuple[float, float]:
    """``LOW:HIGH`` (finite, LOW < HIGH), or ``default`` when not given."""
    if text is None:
        return default
    low, colon, high = text.partition(":")
    try:
        lo, hi = float(low), float(high)
    except ValueError:
        lo = hi = math.nan
    if not (colon and math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise click.BadParameter(f"{text!r}: expected LOW:HIGH, finite with LOW < HIGH, e.g. -50:400",
                                 param_hint=option)
    return lo, hi


def scene_inputs(path: Path, role: str = "the scene file") -> list[Input]:
    """The scene file and every file it names, with their roles in messages (run after the scene loaded)."""
    first, *named = scene_files(path)
    return [(first, role), *((f, f"a file named by the scene {path}") for f in named)]


def parse_unknown(text: str) -> tuple[str, tuple[float, float]]:
    """``NAME=LOW:HIGH`` (SI units), e.g. ``fibre.k=0.05:1`` or ``fibre.c=1e5:1e7``."""
    name, eq, bounds = text.partition("=")
    low, colon, high = bounds.partition(":")
    try:
        if not (eq and colon and name.strip()):
            raise ValueError
        lo, hi = float(low), float(high)
    except ValueError:
        raise click.BadParameter(f"{text!r}: expected NAME=LOW:HIGH, e.g. fibre.k=0.05:1",
                                 param_hint="--unknown") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise click.BadParameter(f"{text!r}: bounds must be finite with LOW < HIGH", param_hint="--unknown")
    return name.strip(), (lo, hi)


def unknowns(texts: Sequence[str], scene: Scene) -> Bounds:
    """The ``--unknown`` options checked against ``scene``: known names (its parameters and ``time_offset``),
    each given once, positive intervals for conductivities, capacities and exchange coefficients."""
    known = sorted({*scene.parameters, TIME_OFFSET})
    out: Bounds = {}
    for text in texts:
        name, (lo, hi) = parse_unknown(text)
        if name in out:
            raise click.BadParameter(f"{name} is given twice; give each unknown once", param_hint="--unknown")
        if name not in known:
            raise click.BadParameter(f"{name!r} is not a parameter of {scene.path}; allowed: {', '.join(known)}",
                                     param_hint="--unknown")
        if is_positive(name) and lo <= 0:
            raise click.BadParameter(f"{text!r}: {name} is positive by nature; give 0 < LOW < HIGH",
                                     param_hint="--unknown")
        problem = bounds_problem(name, lo, hi)
        if problem is not None:
            raise click.BadParameter(f"{text!r}: {problem}", param_hint="--unknown")
        out[name] = (lo, hi)
    return out


def measurements(path: Path, scene: Scene, kind: str, bounds: Bounds,
                 options: ReadOptions | None = None) -> Measurements:
    """The measurement CSV read as a laboratory export (:func:`aromm.core.labcsv.read_lab_csv` with ``options``: column
    mapping, stated units, plausible range; what it converted or dropped is logged, :mod:`aromm.cli.logs`), then
    checked against the scene before any build: enough observations for the unknowns, data in kelvin against a
    scene in °C (refused unless the unit is stated), and the last time (plus the largest clock offset searched)
    within ``[time] end``."""
    opts = options or ReadOptions()
    humid = () if scene.moisture is None else tuple(PHI_PREFIX + f for f in scene.moisture.outputs)
    lab = read_lab_csv(path, (*scene.outputs, *output_names(scene.sensors), *humid), columns=opts.columns,
                       time_unit=opts.time_unit, temperature_unit=opts.temperature_unit, plausible=opts.plausible)
    data = lab.table
    rows, cols = len(data.t), len(data.outputs)
    if rows * cols <= len(bounds):
        raise InputError(f"{path}: too few rows to identify the unknowns: {rows} row(s) × {cols} column(s) = "
                         f"{rows * cols} observation(s) for {len(bounds)} unknown(s) ({', '.join(bounds)}); at least "
                         f"{len(bounds) + 1} are needed (one more than the unknowns, for the residual variance)")
    values = np.concatenate([np.asarray(series, dtype=float) for series in data.mean_T.values()])
    if float(np.ptp(values)) == 0.0:
        raise InputError(f"{path}: every measured temperature is {float(values[0]):g} °C, in every column and all "
                         f"{rows} rows: these data carry nothing to identify (an unplugged sensor? the wrong column?)")
    if not lab.temperature_stated:
        for out, series in data.mean_T.items():
            if out in humid:
                continue
            if kelvin_suspect(series, scene.initial_T):
                raise InputError(f"{path}, column {lab.columns[out]!r}: the values start near "
                                 f"{float(series[0]):g}, that is {float(series[0]) - 273.15:g} °C if they are "
                                 f"kelvin, while {scene.path} starts at {scene.initial_T:g} °C: state the unit "
                                 "(a units row 's,K,...', or --temperature-unit K to convert, or --temperature-unit "
                                 "C if these really are °C)")
            elif fahrenheit_suspect(series, scene.initial_T):
                raise InputError(f"{path}, column {lab.columns[out]!r}: the values start near {float(series[0]):g}, "
                                 f"that is {(float(series[0]) - 32) / 1.8:.3g} °C if they are degrees Fahrenheit, "
                                 f"while {scene.path} starts at {scene.initial_T:g} °C: convert them to °C "
                                 "((F − 32) / 1.8) and state the unit (a units row 's,°C,...')")
    if scene.time is not None:
        offset = bounds.get(TIME_OFFSET)
        if offset is not None and offset[1] - offset[0] > scene.time.end:
            raise InputError(f"--unknown time_offset={offset[0]:g}:{offset[1]:g}: a clock offset range of "
                             f"{offset[1] - offset[0]:g} s is wider than the whole experiment of {scene.path} "
                             f"([time] end = {scene.time.end:g} s); give a range of a few time steps")
        reach = float(data.t[-1]) + max(0.0, offset[1] if offset is not None else 0.0)
        if reach > scene.time.end * (1 + 1e-9):
            unit = opts.time_unit or "s"
            raise InputError(f"{path}: the last time {reach:g} s (measurements in {unit}, plus the largest "
                             f"time_offset) is past the end of the experiment of {scene.path} ([time] end = "
                             f"{scene.time.end:g} s): times in another unit (ms? min?) must be stated (a units "
                             "row, or --time-unit); else raise end" + (", or use --model reduced (exact at any "
                             "time)" if kind == "full" else ""))
    return data


def cache_folder(directory: Path | None, option: str = "--cache-dir") -> Path:
    """The cache folder (``directory``, else ``$AROMM_CACHE_DIR`` or the user's cache), writable or creatable."""
    folder = NpzCache(directory).directory
    return check_folder(folder, "cache", option if directory is not None else f"cache folder (${ENV_VAR})")


def other_discretisation(scene: Scene, engine: str) -> str:
    """The discretisation ``--discretisation-check`` compares with (q1 ↔ fv), refused where it cannot model the
    scene (:func:`aromm.scene.model_section.refusal`) before any model is built."""
    if engine != "scipy":
        raise click.UsageError("--discretisation-check runs on the scipy engine")
    other = "fv" if scene.discretisation == "q1" else "q1"
    refused = refusal(other, scene.geometry, scene.phases)
    if refused is not None:
        raise click.UsageError(f"--discretisation-check: {other} cannot model this scene: {refused[0]}: {refused[1]}")
    return other


def other_segmentation(path: Path, scene: Scene, engine: str) -> tuple[Scene, tuple[str, float]]:
    """The scene on its grey image thresholded by the other standard method (``--segmentation-check``: Li's for
    Otsu's, Otsu's for a threshold given by hand; :data:`aromm.microstructure.segmentation.OTHER_METHOD`), everything
    else as read, and (that method, its threshold); refused before any model is built where there is no such
    threshold."""
    if engine != "scipy":
        raise click.UsageError("--segmentation-check runs on the scipy engine (the petsc engine reads label images)")
    report = scene.segmentation
    if report is None:
        raise click.UsageError(f"--segmentation-check: {path} names a label image (no geometry.segment): nothing was "
                               "thresholded, there is no segmentation error to estimate")
    if report.other is None:
        raise click.UsageError(f"--segmentation-check compares one threshold with another standard method's; {path} "
                               f"has {len(report.thresholds)} thresholds ({report.method})")
    data = read_toml(path)
    geometry = dict(data["geometry"])
    kept = {k: v for k, v in geometry["segment"].items() if k in ("denoise", "size", "sigma")}
    geometry["segment"] = {**kept, "thresholds": [report.other[1]]}
    rethresholded = scene_from_dict(with_discretisation({**data, "geometry": geometry}, scene.discretisation), path)
    return rethresholded, report.other

